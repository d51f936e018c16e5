"""The one declaration of each FMU's interface, shared by both flavours.

Names, value references (the position in ``variables``), causality,
variability, type, units, descriptions, bounds, start values, the outputs'
dependencies during initialisation (InitialUnknowns), the DefaultExperiment
and the rules the parameters must meet beyond their bounds (``rules``, e.g.
BallInShell's r < R) of BallInShell, MotorStartup, InductionMotor, Fig1Drive
and Structure are written here once. The
pythonfmu adapters (fmu_src/, drive_models/) register these variables
(`ballmill.fmi.slave.Slave.declare`), and the native build
(`ballmill.fmi.native`) writes the model description and the C header of
value references from them; tests/test_interface.py checks that the two
model descriptions agree variable by variable.

Plain data, no FMI library and no physics beyond the default values.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from ballmill.physics.drives.crank import CrankStartup
from ballmill.physics.drives.induction import CrankDrive
from ballmill.physics.drives.induction import InductionMotor as MotorData
from ballmill.physics.params import Contact
from ballmill.physics.params import Ball

# unit name -> SI base-unit exponents (and factor) for <UnitDefinitions>
UNITS = {
    "m": {"m": 1},
    "kg": {"kg": 1},
    "s": {"s": 1},
    "1": {},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "1/min": {"s": -1, "factor": 1.0 / 60.0},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "W": {"kg": 1, "m": 2, "s": -3},
    "kg.m2": {"kg": 1, "m": 2},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "A": {"A": 1},
    "Hz": {"s": -1},
    "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2},
    "Wb": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "N.s/m": {"kg": 1, "s": -1},
    "Hz/s": {"s": -2},
    "1/s": {"s": -1},
}

LOG_CATEGORIES = {
    "logStatusWarning": "Warnings: loss of contact, onset of slip, refused inputs.",
    "logStatusDiscard": "A step that was refused; the last good state is kept.",
    "logStatusError": "Errors: bad parameters, unusable inputs.",
    "logStatusFatal": "Fatal errors.",
    "logAll": "All messages.",
}

CAUSALITIES = ("parameter", "input", "output", "local")  # local: Model Exchange's states and derivatives
_TYPES = {float: "Real", int: "Integer", bool: "Boolean"}


@dataclass(frozen=True)
class Variable:
    """One scalar variable. The Python type of ``start`` is its FMI type (float ->
    Real, int -> Integer, bool -> Boolean). ``depends``: the inputs an output depends
    on during initialisation; with ``feedthrough`` also while stepping (direct feedthrough:
    a master reads the output again after setting the input, without a step)."""

    name: str
    causality: str
    start: float | int | bool
    description: str
    unit: str | None = None
    min: float | int | None = None
    max: float | int | None = None
    depends: tuple = ()
    variability: str | None = None  # None: fixed for parameters, continuous for Reals, else discrete
    # the inputs (of ``depends``) the output depends on while stepping too (direct feedthrough,
    # ModelStructure/Outputs): the FMU recomputes the output when one of them is set, no step
    feedthrough: tuple = ()

    def __post_init__(self):
        if self.causality not in CAUSALITIES:
            raise ValueError(f"{self.name}: causality {self.causality!r} not in {CAUSALITIES}")
        if type(self.start) not in _TYPES:
            raise ValueError(f"{self.name}: start {self.start!r} is not a float, int or bool")
        if self.type == "Real" and self.unit is None:
            raise ValueError(f"Real variable {self.name!r} needs a unit")
        if self.unit is not None and self.unit not in UNITS:
            raise ValueError(f"unit {self.unit!r} of {self.name!r} is not in UNITS")
        if not self.description.strip():
            raise ValueError(f"{self.name}: no description")

    @property
    def type(self) -> str:
        return _TYPES[type(self.start)]

    @property
    def fmi_variability(self) -> str:
        if self.variability:
            return self.variability
        if self.causality == "parameter":
            return "fixed"
        return "continuous" if self.type == "Real" else "discrete"


@dataclass(frozen=True)
class Rule:
    """A condition the FMU's parameters must meet beyond each one's [min, max]: the FMU
    refuses fmi2ExitInitializationMode when it fails (docs/conformance.md, "Parameters").
    ``names``: the parameters it reads; ``expected``: the condition in words, with its
    reason; ``holds(p)``: whether it holds, p mapping every parameter of the FMU to its
    value. The scenario checker (ballmill.scenario.spec) evaluates the rules in order
    before a run, so that a bad value is refused with its source instead of by the FMU."""

    names: tuple
    expected: str
    holds: Callable[[dict], bool]


def _positive(*names) -> tuple:
    """Parameters whose declared min is 0 but which must be > 0 (the FMU divides by them)."""
    return tuple(Rule((n,), f"{n} > 0", lambda p, n=n: p[n] > 0) for n in names)


@dataclass(frozen=True)
class Interface:
    """An FMU's variables in value-reference order, with its model-level facts."""

    name: str
    description: str
    variables: tuple
    # start, stop, communication step [s]: 2 ms, the step docs/OTHER_TOOLS.md recommends and the
    # scenarios use (the ball coupled through derivative inputs: contact point within 1e-9 m)
    default_experiment: tuple = (0.0, 10.0, 2e-3)
    log_categories: dict = field(default_factory=lambda: dict(LOG_CATEGORIES))
    rules: tuple = ()  # Rule: what the parameters must meet together, in the FMU's order of checking
    # Model Exchange (native flavour only): its continuous states and event indicators; None: co-simulation only
    model_exchange: ModelExchange | None = None

    def __post_init__(self):
        names = [v.name for v in self.variables]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"{self.name}: variables declared twice: {sorted(dup)}")
        for v in self.variables:
            unknown = set(v.depends) - {w.name for w in self.variables if w.causality == "input"}
            if unknown:
                raise ValueError(f"{self.name}.{v.name} depends on non-inputs {sorted(unknown)}")
            if set(v.feedthrough) - set(v.depends):
                raise ValueError(f"{self.name}.{v.name}: feedthrough {sorted(v.feedthrough)} must be "
                                 f"among its depends {sorted(v.depends)}")
        parameters = {v.name for v in self.variables if v.causality == "parameter"}
        for rule in self.rules:
            if not rule.names or set(rule.names) - parameters:
                raise ValueError(f"{self.name}: rule {rule.expected!r} reads non-parameters "
                                 f"{sorted(set(rule.names) - parameters)}")

    def __getitem__(self, name: str) -> Variable:
        for v in self.variables:
            if v.name == name:
                return v
        raise KeyError(f"{self.name} has no variable {name!r}")

    def value_reference(self, name: str) -> int:
        return [v.name for v in self.variables].index(name)

    def of(self, causality: str) -> list[Variable]:
        return [v for v in self.variables if v.causality == causality]

    @property
    def native_variables(self) -> tuple:
        """The native FMU's variables: ``variables`` (both flavours, the same value references),
        then Model Exchange's continuous states and their derivatives (local; value references
        after every declared one, so that the co-simulation interface keeps its numbers)."""
        return self.variables + (self.model_exchange.variables() if self.model_exchange else ())


@dataclass(frozen=True)
class ModelExchange:
    """What a model gives an FMI Model Exchange importer: its continuous states
    (``states``: (name, unit, description, nominal) rows; each becomes a local variable with
    its derivative ``der(name)``), its event indicators (``indicators``: (name, unit,
    description) rows in the order the FMU returns them; each a local variable too, which FMI
    3.0's ModelStructure/EventIndicator names) and what its Model Exchange supports
    (``notes``: the configurations it refuses, with why; for docs/fmus.md)."""

    states: tuple = ()
    indicators: tuple = ()
    notes: str = ""
    # outputs that depend directly on inputs in Model Exchange only ((output names, input names)
    # rows): co-simulation integrates over the step in between, so its ModelStructure/Outputs
    # (the archive's one, read by co-simulation masters to find algebraic loops) does not list
    # them; an ME importer that sorts its equations must add them
    direct: tuple = ()
    # the inputs each state's derivative depends on directly ((state names, input names) rows; a
    # state in no row: none): ModelStructure/Derivatives lists them with every state (declared
    # conservatively), so an ME importer sorting its equations sees, e.g., the ball's der(w) on
    # the platform acceleration. Only ME importers read Derivatives: co-simulation is unaffected
    derivative_inputs: tuple = ()

    def direct_inputs(self, output: str) -> tuple:
        return tuple(i for outs, ins in self.direct if output in outs for i in ins)

    def derivative_dependencies(self, state: str) -> tuple:
        return tuple(i for states, ins in self.derivative_inputs if state in states for i in ins)

    def variables(self) -> tuple:
        rows = [Variable(name, "local", 0.0, desc, unit=unit) for name, unit, desc, _ in self.states]
        rows += [Variable(f"der({name})", "local", 0.0, f"Time derivative of {name}",
                          unit=DERIVATIVE_UNITS[unit]) for name, unit, _, _ in self.states]
        rows += [Variable(name, "local", 0.0, f"Event indicator: {desc}", unit=unit)
                 for name, unit, desc in self.indicators]
        return tuple(rows)


# unit of a state -> unit of its time derivative
DERIVATIVE_UNITS = {"1": "1/s", "rad": "rad/s", "rad/s": "rad/s2", "m": "m/s", "m/s": "m/s2", "Wb": "V",
                    "J": "W"}


def _interface(name, description, rows, **kw) -> Interface:
    return Interface(name, description, tuple(Variable(*r[:4], **(r[4] if len(r) > 4 else {}))
                                              for r in rows), **kw)


# ----------------------------------------------------------------------------- the drives
# the crank and platform outputs every drive FMU provides (BallInShell's inputs)
CRANK_KINEMATICS = (
    ("psi", "rad", "Crank angle"),
    ("psi_dot", "rad/s", "Crank angular speed"),
    ("psi_ddot", "rad/s2", "Crank angular acceleration"),
    ("x1O", "m", "Platform point O, x (crank axis at the origin)"),
    ("y1O", "m", "Platform point O, y"),
    ("vx1O", "m/s", "Platform velocity x"),
    ("vy1O", "m/s", "Platform velocity y"),
    ("ax1O", "m/s2", "Platform acceleration x"),
    ("ay1O", "m/s2", "Platform acceleration y"),
)

_law = CrankStartup()
_STARTUP_RULES = _positive("l")  # (drive_models/motorstartup.c setup; t0 >= 1e-3 by its bounds)
MOTOR_STARTUP = _interface(
    "MotorStartup",
    "Kinematic crank start-up law (quadratic speed rise to n0 in t0) driving a platform on a circle "
    "of radius l; reports the drive torque and power",
    [
        ("l", "parameter", _law.l, "Crank length (radius of the platform's circle)",
         dict(unit="m", min=0.0, max=1e3)),
        ("n0", "parameter", _law.n0, "Steady crank speed", dict(unit="1/min", min=0.0, max=1e5)),
        ("t0", "parameter", _law.t0, "Start-up time to reach n0", dict(unit="s", min=1e-3, max=1e6)),
        ("m_platform", "parameter", 0.0, "Mass of the platform and chamber (adds m l^2 to the inertia)",
         dict(unit="kg", min=0.0, max=1e9)),
        ("J_crank", "parameter", 0.0, "Inertia of cranks and gear about the crank axis",
         dict(unit="kg.m2", min=0.0, max=1e9)),
        ("M_reaction", "input", 0.0, "Torque of the ball on the crank shaft (BallInShell.M_reaction)",
         dict(unit="N.m")),
        *[(name, "output", 0.0, desc, dict(unit=unit)) for name, unit, desc in CRANK_KINEMATICS],
        ("T_drive", "output", 0.0, "Torque the drive must supply: J_total psi'' - M_reaction",
         dict(unit="N.m", depends=("M_reaction",), feedthrough=("M_reaction",))),
        ("P_drive", "output", 0.0, "Power the drive must supply: T_drive psi'",
         dict(unit="W", depends=("M_reaction",), feedthrough=("M_reaction",))),
        # declared last: earlier value references stay as they were
        ("law", "parameter", 1, "Shape of the speed rise to n0 in t0: 1 = quadratic (the paper's), "
         "2 = S-curve (cubic smoothstep, zero acceleration at both ends), 3 = linear (constant "
         "acceleration), 4 = quintic (zero acceleration and jerk at both ends)", dict(min=1, max=4)),
    ], rules=_STARTUP_RULES,
    model_exchange=ModelExchange(notes="no continuous states: the crank angle is a function of time; time "
                                 "events at t = 0 and t = t0, where the speed rise starts and ends (the "
                                 "acceleration or the jerk jumps there)"))


def _motor(name):
    return MotorData.__dataclass_fields__[name].default


def _drive(name):
    return CrankDrive.__dataclass_fields__[name].default


_FEEDTHROUGH = ("psi_ddot", "ax1O", "ay1O")  # InductionMotor: depend on M_reaction at initialisation
RATED_CONSISTENCY = 0.15  # P_rated / eta and sqrt(3) U_rated I_rated cos_phi agree within 15 %
# the datasheet's consistency (drive_models/inductionmotor.c setup, the physics' InductionMotor);
# whether the dq model can be fitted to it is found only by fitting (the FMU refuses it then)
_INDUCTION_RULES = (
    *_positive("P_rated", "n_rated", "U_rated", "f_rated", "I_rated", "J_rotor", "ramp_time", "cos_phi", "eta"),
    Rule(("f_start",), "f_start < 1", lambda p: p["f_start"] < 1.0),
    Rule(("Rs_share",), "Rs_share < 1", lambda p: p["Rs_share"] < 1.0),
    Rule(("Tb_ratio",), "Tb_ratio > 1 (Kloss's formula has no rated point otherwise)", lambda p: p["Tb_ratio"] > 1.0),
    Rule(("n_rated", "f_rated", "pole_pairs"), "n_rated < 60 f_rated / pole_pairs, the synchronous speed "
         "(a motor runs with positive slip)", lambda p: p["n_rated"] < 60.0 * p["f_rated"] / p["pole_pairs"]),
    Rule(("P_rated", "eta", "U_rated", "I_rated", "cos_phi"),
         f"P_rated / eta = sqrt(3) U_rated I_rated cos_phi within {RATED_CONSISTENCY:.0%} (check the units)",
         lambda p: 1.0 - RATED_CONSISTENCY <= p["P_rated"] / (
             p["eta"] * (math.sqrt(3.0) * p["U_rated"] * p["I_rated"] * p["cos_phi"])) <= 1.0 + RATED_CONSISTENCY),
    *_positive("l"),  # (i >= 1e-3 by its bounds)
)
INDUCTION_MOTOR = _interface(
    "InductionMotor",
    "Three-phase induction motor from its datasheet (Kloss or dq model; direct on line, voltage ramp "
    "or V/f ramp) driving a platform on cranks through a gear; the ball's reaction torque M_reaction "
    "loads the crank shaft",
    [
        # motor datasheet
        ("P_rated", "parameter", _motor("rated_power"), "Rated (shaft) power of the motor",
         dict(unit="W", min=0.0, max=1e8)),
        ("n_rated", "parameter", _motor("rated_speed"), "Rated speed of the motor",
         dict(unit="1/min", min=0.0, max=1e6)),
        ("U_rated", "parameter", _motor("rated_voltage"), "Rated line-to-line voltage (rms)",
         dict(unit="V", min=0.0, max=1e6)),
        ("f_rated", "parameter", _motor("rated_frequency"), "Rated supply frequency",
         dict(unit="Hz", min=0.0, max=1e4)),
        ("pole_pairs", "parameter", _motor("pole_pairs"), "Number of pole pairs (2 for a 4-pole motor)",
         dict(min=1, max=100)),
        ("I_rated", "parameter", _motor("rated_current"), "Rated line current (rms) at U_rated",
         dict(unit="A", min=0.0, max=1e6)),
        ("cos_phi", "parameter", _motor("power_factor"), "Power factor at the rated point (dq fit)",
         dict(unit="1", min=0.0, max=1.0)),
        ("eta", "parameter", _motor("efficiency"), "Efficiency at the rated point (dq fit)",
         dict(unit="1", min=0.0, max=1.0)),
        ("Tb_ratio", "parameter", _motor("breakdown_ratio"), "Breakdown torque / rated torque",
         dict(unit="1", min=1.0, max=100.0)),
        ("J_rotor", "parameter", _motor("J_rotor"), "Rotor inertia (and anything on the motor shaft)",
         dict(unit="kg.m2", min=0.0, max=1e6)),
        ("Rs_share", "parameter", _motor("stator_copper_share"), "Share of the rated losses (other than "
         "rotor copper) attributed to stator copper; sets Rs of the fitted dq model",
         dict(unit="1", min=0.0, max=1.0)),
        # starter
        ("start_mode", "parameter", 1, "Starter: 1 = direct on line, 2 = voltage ramp (soft starter, "
         "U/Un from u_start to 1 in ramp_time), 3 = frequency ramp (inverter, V/f, f/fn from f_start "
         "to 1 in ramp_time)", dict(min=1, max=3)),
        ("ramp_time", "parameter", _motor("ramp_time"), "Duration of the voltage or frequency ramp",
         dict(unit="s", min=0.0, max=1e6)),
        ("u_start", "parameter", _motor("u_start"), "U/Un at t = 0 of a voltage ramp",
         dict(unit="1", min=0.0, max=1.0)),
        ("f_start", "parameter", _motor("f_start"), "f/fn at t = 0 of a frequency ramp",
         dict(unit="1", min=0.0, max=1.0)),
        ("model", "parameter", 1, "Motor model: 1 = Kloss (quasi-static torque-speed curve), "
         "2 = dq (4 flux states, electrical transients, current and power)", dict(min=1, max=2)),
        # gear, crank, platform
        ("i", "parameter", _drive("i"), "Gear ratio: motor speed / crank speed",
         dict(unit="1", min=1e-3, max=1e4)),
        ("J_crank", "parameter", _drive("J_crank"), "Inertia of cranks and gear output about the crank "
         "axis", dict(unit="kg.m2", min=0.0, max=1e9)),
        ("m_platform", "parameter", _drive("m_platform"), "Mass of the translating platform with the "
         "chamber (adds m l^2 to the inertia)", dict(unit="kg", min=0.0, max=1e9)),
        ("l", "parameter", _drive("l"), "Crank length (radius of the platform's circle)",
         dict(unit="m", min=0.0, max=1e3)),
        # numerics
        ("tolerance", "parameter", 1e-9, "Relative tolerance of the internal DOP853 integrator",
         dict(unit="1", min=1e-14, max=0.1)),
        ("M_input", "parameter", 2, "M_reaction over a communication step: 1 = held at its value at "
         "the step's start, 2 = extrapolated linearly from the last two communication points",
         dict(min=1, max=2)),
        ("M_reaction", "input", 0.0, "Torque of the load (BallInShell.M_reaction) on the crank shaft, "
         "positive counter-clockwise seen from above", dict(unit="N.m")),
        *[(name, "output", 0.0,
           "Crank angular acceleration (i T_motor + M_reaction) / J_total" if name == "psi_ddot" else desc,
           dict(unit=unit, depends=("M_reaction",) if name in _FEEDTHROUGH else ()))
          for name, unit, desc in CRANK_KINEMATICS],
        ("w_motor", "output", 0.0, "Motor speed i psi'", dict(unit="rad/s")),
        ("n_motor", "output", 0.0, "Motor speed i psi'", dict(unit="1/min")),
        ("slip", "output", 1.0, "Slip (w_sync(t) - w_motor) / w_sync(t) of the supply at t "
         "(0 while the supply frequency is zero)", dict(unit="1")),
        ("T_motor", "output", 0.0, "Electromagnetic (air-gap) torque of the motor, at the motor shaft",
         dict(unit="N.m")),
        ("I_motor", "output", 0.0, "Stator line current (rms); dq model only, 0 with Kloss", dict(unit="A")),
        ("P_el", "output", 0.0, "Electrical input power; dq model only, 0 with Kloss", dict(unit="W")),
        ("P_motor", "output", 0.0, "Mechanical power of the motor T_motor w_motor", dict(unit="W")),
        ("W_motor", "output", 0.0, "Mechanical work of the motor since the start, integral of P_motor",
         dict(unit="J")),
        ("E_drive", "output", 0.0, "Kinetic energy of rotor, gear, cranks and platform 1/2 J_total psi'^2",
         dict(unit="J")),
    ], rules=_INDUCTION_RULES,
    model_exchange=ModelExchange(
        states=(("s_psi", "rad", "Crank angle psi (the state behind the output psi)", 1.0),
                ("s_psi_dot", "rad/s", "Crank angular speed psi' (the state behind the output psi_dot)", 1.0),
                ("s_flux_sd", "Wb", "Stator flux linkage, d axis (dq model; stays 0 with Kloss)", 1.0),
                ("s_flux_sq", "Wb", "Stator flux linkage, q axis (dq model; stays 0 with Kloss)", 1.0),
                ("s_flux_rd", "Wb", "Rotor flux linkage, d axis (dq model; stays 0 with Kloss)", 1.0),
                ("s_flux_rq", "Wb", "Rotor flux linkage, q axis (dq model; stays 0 with Kloss)", 1.0),
                ("s_W_motor", "J", "Mechanical work of the motor since the start (the output W_motor)", 1.0)),
        direct=((("psi_ddot", "ax1O", "ay1O"), ("M_reaction",)),),
        derivative_inputs=((("s_psi_dot",), ("M_reaction",)),),
        notes="M_reaction is read as set at every call (M_input, tolerance: co-simulation's); time "
              "events at t = 0 (the supply is switched on) and, with a voltage or frequency ramp, at "
              "t = ramp_time (the ramp ends: the supply's slope jumps)"))

# ----------------------------------------------------------------------------- the Fig. 1 machine
_WRENCH = ("Fx", "Fy", "Fz", "MO1x", "MO1y", "MO1z")
_AX = ("x", "y", "z")
FIG1_DRIVE = _interface(
    "Fig1Drive",
    "The drives of the paper's Fig. 1 machine: the bearing frame turns about a fixed shaft through O1 "
    "(horizontal x1 or vertical z1) by phi(t), the cranks carry the platform point O on a circle of "
    "radius l relative to the frame by psi(t) (circular translation relative to the frame); outputs the "
    "chamber's motion for BallInShell (motion = 2) and, from the ball's wrench, the reaction moments, "
    "torques and powers of both drives (ballmill.physics.turning.drive)",
    [
        ("shaft", "parameter", 1, "The frame's shaft through O1: 1 = the horizontal x1 axis (Fig. 1), "
         "2 = the vertical z1 axis (a turntable)", dict(min=1, max=2)),
        ("Omega_frame", "parameter", 0.5, "Steady angular speed of the frame about its shaft (either sign)",
         dict(unit="rad/s", min=-1e4, max=1e4)),
        ("frame_law", "parameter", 0, "Frame speed law: 0 = constant speed Omega_frame from t = 0; 1..4 = "
         "a rise from rest to Omega_frame in t0_frame with MotorStartup's shapes (1 = quadratic, "
         "2 = S-curve, 3 = linear, 4 = quintic)", dict(min=0, max=4)),
        ("t0_frame", "parameter", 2.5, "Rise time of the frame's speed (frame_law 1..4)",
         dict(unit="s", min=1e-3, max=1e6)),
        ("l", "parameter", 0.5, "Crank length (radius of O's circle relative to the frame; 0 = no cranks)",
         dict(unit="m", min=0.0, max=1e3)),
        ("n0", "parameter", 60.0, "Steady crank speed relative to the frame", dict(unit="1/min", min=0.0, max=1e5)),
        ("t0", "parameter", 2.5, "Start-up time of the cranks to reach n0", dict(unit="s", min=1e-3, max=1e6)),
        ("law", "parameter", 1, "Shape of the cranks' speed rise to n0 in t0: 1 = quadratic (the paper's), "
         "2 = S-curve, 3 = linear, 4 = quintic (as MotorStartup)", dict(min=1, max=4)),
        ("arrangement", "parameter", 1, "Crank axes: 1 = perpendicular to the shaft (circle in the frame's "
         "xy plane for the x1 shaft, yz plane for the z1 shaft), 2 = parallel to it (yz resp. xy plane)",
         dict(min=1, max=2)),
        ("xc", "parameter", 0.0, "Centre of O's crank circle in the frame's axes, x", dict(unit="m", min=-1e3, max=1e3)),
        ("yc", "parameter", 0.0, "Centre of O's crank circle in the frame's axes, y", dict(unit="m", min=-1e3, max=1e3)),
        ("zc", "parameter", 0.0, "Centre of O's crank circle in the frame's axes, z (-R puts the chamber "
         "centre A on the shaft's plane)", dict(unit="m", min=-1e3, max=1e3)),
        ("J_frame", "parameter", 0.0, "Inertia of everything turning with the frame about the shaft (frame, "
         "the cranks' and the platform's own inertia about it)", dict(unit="kg.m2", min=0.0, max=1e9)),
        ("J_crank", "parameter", 0.0, "Inertia of the cranks and their gear about the crank axes",
         dict(unit="kg.m2", min=0.0, max=1e9)),
        ("m_platform", "parameter", 0.0, "Mass of the platform with the chamber, a point mass at O",
         dict(unit="kg", min=0.0, max=1e9)),
        ("g", "parameter", 9.81, "Gravitational acceleration (the platform's weight in T_frame, T_crank)",
         dict(unit="m/s2", min=0.0, max=1e3)),
        ("Fx", "input", 0.0, "Force of the ball on the chamber, x1 (BallInShell.Fx)", dict(unit="N")),
        ("Fy", "input", 0.0, "Force of the ball on the chamber, y1 (BallInShell.Fy)", dict(unit="N")),
        ("Fz", "input", 0.0, "Force of the ball on the chamber, z1 (BallInShell.Fz)", dict(unit="N")),
        ("MO1x", "input", 0.0, "Moment of the ball's force on the chamber about O1, x1 (BallInShell.MO1x)",
         dict(unit="N.m")),
        ("MO1y", "input", 0.0, "Moment of the ball's force on the chamber about O1, y1 (BallInShell.MO1y)",
         dict(unit="N.m")),
        ("MO1z", "input", 0.0, "Moment of the ball's force on the chamber about O1, z1 (BallInShell.MO1z)",
         dict(unit="N.m")),
        ("phi", "output", 0.0, "Frame angle about the shaft", dict(unit="rad")),
        ("phi_dot", "output", 0.0, "Frame angular speed", dict(unit="rad/s")),
        ("phi_ddot", "output", 0.0, "Frame angular acceleration", dict(unit="rad/s2")),
        ("psi", "output", 0.0, "Crank angle relative to the frame", dict(unit="rad")),
        ("psi_dot", "output", 0.0, "Crank angular speed relative to the frame", dict(unit="rad/s")),
        ("psi_ddot", "output", 0.0, "Crank angular acceleration relative to the frame", dict(unit="rad/s2")),
        *[(f"{c}1O", "output", 0.0, f"Platform point O (the chamber's lowest point when Q = I), {c}1",
           dict(unit="m")) for c in _AX],
        *[(f"v{c}1O", "output", 0.0, f"Velocity of O, {c}1", dict(unit="m/s")) for c in _AX],
        *[(f"a{c}1O", "output", 0.0, f"Acceleration of O, {c}1", dict(unit="m/s2")) for c in _AX],
        *[(f"Omega_{c}", "output", 0.0, f"Angular velocity of the chamber, {c}1", dict(unit="rad/s")) for c in _AX],
        *[(f"Omega_dot_{c}", "output", 0.0, f"Angular acceleration of the chamber, {c}1", dict(unit="rad/s2"))
          for c in _AX],
        *[(f"Q{i}{j}", "output", 1.0 if i == j else 0.0, f"Orientation of the chamber (chamber axes to fixed "
           f"axes), row {i}, column {j}", dict(unit="1")) for i in (1, 2, 3) for j in (1, 2, 3)],
        ("M_frame", "output", 0.0, "Reaction moment of the ball's load on the frame shaft: e . MO1",
         dict(unit="N.m", depends=_WRENCH)),
        ("M_crank", "output", 0.0, "Reaction moment of the ball's load on the cranks: (dO/dpsi) . F",
         dict(unit="N.m", depends=_WRENCH)),
        ("T_frame", "output", 0.0, "Torque the frame drive must supply: inertias (J_frame, the cranks' "
         "coupling, the platform as a point mass at O with its weight) minus M_frame",
         dict(unit="N.m", depends=_WRENCH)),
        ("T_crank", "output", 0.0, "Torque the crank drive must supply: J_crank times the cranks' angular "
         "acceleration about their axes, the platform's inertia and weight, minus M_crank",
         dict(unit="N.m", depends=_WRENCH)),
        ("P_frame", "output", 0.0, "Power the frame drive must supply: T_frame phi'", dict(unit="W", depends=_WRENCH)),
        ("P_crank", "output", 0.0, "Power the crank drive must supply: T_crank psi'", dict(unit="W", depends=_WRENCH)),
    ],
    model_exchange=ModelExchange(
        direct=((("M_frame", "M_crank", "T_frame", "T_crank", "P_frame", "P_crank"), _WRENCH),),
        notes="no continuous states: the frame and crank angles are functions of time; time events at "
              "t = 0, t0 (the cranks' rise ends) and t0_frame (the frame's, frame_law 1..4)"))

# ----------------------------------------------------------------------------- the ball
BALL_INPUTS = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
BALL_OUTPUTS = (  # the Real outputs that come straight from outputs.Outputs (same names)
    ("xP", "m", "Contact point P, x in the chamber frame Oxyz (motion = 2: P - O, fixed axes)"),
    ("yP", "m", "Contact point P, y in the chamber frame Oxyz (motion = 2: P - O, fixed axes)"),
    ("zP", "m", "Contact point P, height above the chamber's lowest point O (motion = 2: P - O, fixed "
                "axes)"),
    ("N", "N", "Normal force of the chamber on the ball (> 0: ball pressed on the wall)"),
    ("Fx", "N", "Force of the ball on the chamber, x in the fixed axes O1x1y1z1"),
    ("Fy", "N", "Force of the ball on the chamber, y in the fixed axes O1x1y1z1"),
    ("Fz", "N", "Force of the ball on the chamber, z in the fixed axes O1x1y1z1 (-m g at rest)"),
    ("M_reaction", "N.m", "Torque of the ball's force about the vertical axis z1 through O1 (positive "
                          "counter-clockwise seen from above): motion = 1, the crank shaft's torque of the "
                          "translating platform, x1O Fy - y1O Fx; motion = 2, MO1z"),
    ("MAx", "N.m", "Moment of the ball's force about the chamber centre A, x (fixed axes)"),
    ("MAy", "N.m", "Moment of the ball's force about the chamber centre A, y (fixed axes)"),
    ("MAz", "N.m", "Moment of the ball's force about the chamber centre A, z (fixed axes)"),
    ("xC", "m", "Ball centre C, x in Oxyz (motion = 2: C - O, fixed axes)"),
    ("yC", "m", "Ball centre C, y in Oxyz (motion = 2: C - O, fixed axes)"),
    ("zC", "m", "Ball centre C, z in Oxyz (motion = 2: C - O, fixed axes)"),
    ("wx", "rad/s", "Absolute angular velocity of the ball, x (fixed axes)"),
    ("wy", "rad/s", "Absolute angular velocity of the ball, y (fixed axes)"),
    ("wz", "rad/s", "Absolute angular velocity of the ball, z (fixed axes)"),
    ("Ft", "N", "Magnitude of the friction (tangential) force on the ball"),
    ("friction_ratio", "1", "|F_t| / N: the ball rolls while this is <= mu (1e300 when N <= 0)"),
)
_INPUT_TEXT = {
    "x1O": ("Platform point O, x in the fixed frame (crank axis at the origin)", "m"),
    "y1O": ("Platform point O, y in the fixed frame", "m"),
    "vx1O": ("Platform velocity x (used with input_mode = 1)", "m/s"),
    "vy1O": ("Platform velocity y (used with input_mode = 1)", "m/s"),
    "ax1O": ("Platform acceleration x (used with input_mode = 1 or 3)", "m/s2"),
    "ay1O": ("Platform acceleration y (used with input_mode = 1 or 3)", "m/s2"),
}
# the chamber's motion in 3-D (motion = 2; declared after the original variables, so that
# earlier value references stay). Defaults: no vertical motion, no rotation, Q = identity.
_Q = tuple(f"Q{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
BALL_MOTION_INPUTS = ("z1O", "vz1O", "az1O", "Omega_x", "Omega_y", "Omega_z",
                      "Omega_dot_x", "Omega_dot_y", "Omega_dot_z") + _Q
BALL_MOTION_START = {name: (1.0 if name in ("Q11", "Q22", "Q33") else 0.0) for name in BALL_MOTION_INPUTS}
_MOTION_INPUT_TEXT = {
    "z1O": ("Platform point O, z in the fixed frame (z1 up; motion = 2): (x1O, y1O, z1O) is the "
            "chamber-fixed point O, the chamber's lowest point when Q = I; the chamber centre is "
            "A = O + Q (0, 0, R)", "m"),
    "vz1O": ("Velocity of O, z (motion = 2; used with input_mode = 1)", "m/s"),
    "az1O": ("Acceleration of O, z (motion = 2; used with input_mode = 1 or 3)", "m/s2"),
    **{f"Omega_{c}": (f"Angular velocity of the chamber, {c} in the fixed axes (motion = 2)", "rad/s")
       for c in "xyz"},
    **{f"Omega_dot_{c}": (f"Angular acceleration of the chamber dOmega/dt, {c} in the fixed axes "
                          f"(motion = 2)", "rad/s2") for c in "xyz"},
    **{f"Q{i}{j}": (f"Orientation of the chamber, row {i} column {j} of the rotation matrix Q from the "
                    f"chamber's axes to the fixed axes (motion = 2; start: identity; must be orthonormal "
                    f"within 1e-6 with det Q > 0)", "1") for i in (1, 2, 3) for j in (1, 2, 3)},
}
BALL_MOTION_OUTPUTS = (
    ("xP_ch", "m", "Contact point in the chamber's axes, x of Q^T (P - A) + (0, 0, R) (at rest at the "
                   "bottom: the origin; motion = 1: xP)"),
    ("yP_ch", "m", "Contact point in the chamber's axes, y of Q^T (P - A) + (0, 0, R)"),
    ("zP_ch", "m", "Contact point in the chamber's axes, z of Q^T (P - A) + (0, 0, R) (height above the "
                   "chamber's lowest point, in the chamber)"),
    ("Fx_ch", "N", "Force of the ball on the chamber, x in the chamber's axes (Q^T F)"),
    ("Fy_ch", "N", "Force of the ball on the chamber, y in the chamber's axes (Q^T F)"),
    ("Fz_ch", "N", "Force of the ball on the chamber, z in the chamber's axes (Q^T F)"),
    ("MO1x", "N.m", "Moment of the ball's force on the chamber about the fixed origin O1, x in the fixed "
                    "axes (A x F + M_A; motion = 1: A = (x1O, y1O, R)): a drive of the chamber with "
                    "twist (w, v) feels w . MO1 + v . F"),
    ("MO1y", "N.m", "Moment of the ball's force on the chamber about the fixed origin O1, y in the fixed "
                    "axes"),
    ("MO1z", "N.m", "Moment of the ball's force on the chamber about the fixed origin O1, z in the fixed "
                    "axes (about the vertical axis z1 through O1)"),
)
BALL_ALL_INPUTS = BALL_INPUTS + BALL_MOTION_INPUTS
_ball = Ball()
_contact = Contact()
W0_MAX = 1e4  # rad/s: bound of the initial angular velocity components
MAX_INTERNAL_STEPS = 20000  # BallInShell's work bound: internal steps of one integration in a doStep
DRAG_LIMIT = 1e4  # BallInShell: c_drag <= DRAG_LIMIT m omega0 (viscous time constant m/c_drag >= 1e-4 / omega0)
PAPER_MARGIN = 0.02  # formulation = 2 needs the ball centre's n_z < -PAPER_MARGIN (below the equator)


def _omega0(p) -> float:
    """BallInShell's small-oscillation angular frequency sqrt(g / ((1 + I/(m r^2)) (R - r))) [rad/s]."""
    return math.sqrt(p["g"] / (1.0 + _ball.inertia_factor) / (p["R"] - p["r"]))


def _auto_max_step(p) -> float:
    """BallInShell's longest communication step [s]: max_step, or 0 = 1/20 of the natural period."""
    return p["max_step"] or 0.05 * 2.0 * math.pi / _omega0(p)


# fmu_src/ballinshell.c setup (and ballinshell_fmu.py's build/start), in its order
_BALL_RULES = (
    *_positive("r", "R", "m", "g", "mu"),
    Rule(("r", "R"), "r < R (the ball must fit in the chamber)", lambda p: p["r"] < p["R"]),
    Rule(("r", "R"), "R - r >= 1e-9 R", lambda p: (p["R"] - p["r"]) / p["R"] >= 1e-9),
    *_positive("h_fixed"),
    Rule(("delta", "r"), "delta <= r (a rolling-resistance length within the ball's radius)",
         lambda p: p["delta"] <= p["r"]),
    Rule(("c_drag", "m", "g", "r", "R"), f"c_drag <= {DRAG_LIMIT:g} m omega0, omega0 = sqrt(g / (1.4 (R - r))) "
         "(a shorter viscous time constant m/c_drag is too stiff for the explicit integrators)",
         lambda p: p["c_drag"] <= DRAG_LIMIT * p["m"] * _omega0(p)),
    Rule(("xC0", "yC0", "r", "R"), "sqrt(xC0^2 + yC0^2) <= R - r (the ball centre lies on the sphere of "
         "radius R - r)", lambda p: p["xC0"] ** 2 + p["yC0"] ** 2 <= (p["R"] - p["r"]) ** 2),
    Rule(("motion", "formulation"), "formulation = 1 with motion = 2 (the paper's coordinates describe only "
         "a translating chamber's lower hemisphere)", lambda p: p["motion"] != 2 or p["formulation"] == 1),
    Rule(("motion", "delta", "c_drag"), "delta = c_drag = 0 with motion = 2 (the ground material's losses "
         "exist only with motion = 1)", lambda p: p["motion"] != 2 or p["delta"] == p["c_drag"] == 0.0),
    *_positive("w_bed"),
    Rule(("bed", "h_bed", "R"), "h_bed <= 2 R with bed = 1 (the bed's surface lies between the chamber's "
         "lowest and highest points)", lambda p: p["bed"] != 1 or p["h_bed"] <= 2.0 * p["R"]),
    Rule(("motion", "bed"), "bed = 0 with motion = 2 (the turning chamber's model has no losses, so no "
         "material bed)", lambda p: p["motion"] != 2 or p["bed"] == 0),
    Rule(("motion", "input_mode"), "input_mode = 1 or 3 with motion = 2",
         lambda p: p["motion"] != 2 or p["input_mode"] in (1, 3)),
    Rule(("integrator", "h_fixed", "max_step", "g", "r", "R"), f"h_fixed >= max_step / {MAX_INTERNAL_STEPS} "
         "with integrator = 3 (RK4; max_step = 0: 1/20 of the natural period 2 pi / omega0)",
         lambda p: p["integrator"] != 3 or _auto_max_step(p) / p["h_fixed"] <= MAX_INTERNAL_STEPS),
    Rule(("formulation", "xC0", "yC0", "r", "R"), f"n_z = -sqrt(1 - (xC0^2 + yC0^2) / (R - r)^2) <= "
         f"-{PAPER_MARGIN:g} with formulation = 2 (the paper's coordinates end near the chamber's equator)",
         lambda p: p["formulation"] != 2 or -math.sqrt(max(0.0, 1.0 - (p["xC0"] ** 2 + p["yC0"] ** 2)
                                                             / (p["R"] - p["r"]) ** 2)) <= -PAPER_MARGIN),
    # the hybrid contact (contact_model = 2: rolling, sliding, flight, impacts; docs/design.md 14, 15)
    Rule(("mu_k", "mu"), "mu_k = -1 (equal to mu) or 0 <= mu_k <= mu (kinetic friction does not exceed "
         "static friction)", lambda p: p["mu_k"] == -1.0 or 0.0 <= p["mu_k"] <= p["mu"]),
    *_positive("v_rest"),
    Rule(("contact_model", "formulation"), "formulation = 1 with contact_model = 2 (the paper's coordinates "
         "end at the chamber's equator, and a sliding or flying ball is followed in fixed axes)",
         lambda p: p["contact_model"] != 2 or p["formulation"] == 1),
    Rule(("contact_model", "delta", "c_drag"), "delta = c_drag = 0 with contact_model = 2 (the hybrid ball "
         "models no ground-material losses off rolling)",
         lambda p: p["contact_model"] != 2 or p["delta"] == p["c_drag"] == 0.0),
    Rule(("contact_model", "bed"), "bed = 0 with contact_model = 2 (the hybrid ball models no ground-material "
         "losses, so no material bed)", lambda p: p["contact_model"] != 2 or p["bed"] == 0),
)
NEVER = 1e300  # t_invalid while the model is valid
_out = dict(depends=BALL_ALL_INPUTS)
# the outputs outputs.evaluate computes from the chamber's motion at the current instant: with
# input_mode 1, 3 or 4 both flavours recompute them when one of the inputs they depend on is set
# (the algebraic loop of a ball in a structure that feels it): motion = 1 the position and
# acceleration x1O, y1O, ax1O, ay1O; motion = 2 also z1O, az1O, Omega, Omega' and Q (the chamber
# centre's acceleration and the orientation). The velocities enter the force of a sliding ball
# (contact_model = 2: N = m (n.(g - a_A) + |v_C - v_A|^2 / |C - A|), the slip against v_W), so every
# input is declared (with contact_model = 1 they change nothing).
BALL_FEEDTHROUGH = ("N", "Fx", "Fy", "Fz", "M_reaction", "MAx", "MAy", "MAz", "Ft", "friction_ratio",
                    "contact", "rolling", "P_diss", "P_grind", "Fx_ch", "Fy_ch", "Fz_ch", "MO1x", "MO1y", "MO1z")
BALL_FEEDTHROUGH_INPUTS = BALL_ALL_INPUTS
_feed = dict(depends=BALL_ALL_INPUTS, feedthrough=BALL_FEEDTHROUGH_INPUTS)
# the hybrid ball (contact_model = 2; declared after every other variable: earlier value references
# stay). With contact_model = 1 the outputs say what the rolling model knows: mode 1, no slip, no
# gap, no impacts, no losses, t_first_slip and t_first_flight never (t_invalid dates the latch).
BALL_HYBRID_OUTPUTS = ("mode", "slip_speed", "gap", "n_impacts", "v_impact_max", "E_friction", "E_impact",
                       "t_first_slip", "t_first_flight", "vxC", "vyC", "vzC", "Fx_mean", "Fy_mean", "Fz_mean",
                       "M_reaction_mean")
BALL_HYBRID_ROWS = (
    ("contact_model", "parameter", 1, "Contact: 1 = rolling only (the ball rolls without slip on the wall; "
     "valid latches false at the first slip or loss of contact), 2 = hybrid (rolling, sliding, flight and "
     "impacts, each switch located inside the communication step; formulation = 1, no ground-material "
     "losses; co-simulation only)", dict(min=1, max=2)),
    ("mu_k", "parameter", -1.0, "Kinetic friction coefficient of a sliding ball and of an impact that "
     "slips (contact_model = 2): -1 = equal to mu, else 0 <= mu_k <= mu", dict(unit="1", min=-1.0, max=100.0)),
    ("e_n", "parameter", 0.5, "Normal coefficient of restitution of an impact on the wall (contact_model = 2)",
     dict(unit="1", min=0.0, max=1.0)),
    ("v_rest", "parameter", 0.01, "Rest speed (contact_model = 2): a rebound slower than this (e_n v_n < "
     "v_rest) ends a bounce sequence, the ball stays on the wall (no Zeno chattering)",
     dict(unit="m/s", min=0.0, max=1e3)),
    ("mode", "output", 1, "Contact mode: 0 = flight, 1 = rolling, 2 = sliding (contact_model = 1, and "
     "contact_model = 2 once a Zeno sequence has latched valid: always 1)",
     _out),
    ("slip_speed", "output", 0.0, "Slip speed |u| of the ball's point at P on the wall (0 while rolling and in "
     "flight; contact_model = 1: 0)", dict(unit="m/s", min=0.0, **_out)),
    ("gap", "output", 0.0, "Gap between ball and wall, R - r - |C - A| (0 on the wall)",
     dict(unit="m", min=0.0, **_out)),
    ("n_impacts", "output", 0, "Number of impacts on the wall so far", dict(min=0, **_out)),
    ("v_impact_max", "output", 0.0, "Largest normal approach speed of an impact so far (0: none)",
     dict(unit="m/s", min=0.0, **_out)),
    ("E_friction", "output", 0.0, "Energy taken by friction while sliding (and by the impulses that end a "
     "slip) so far", dict(unit="J", min=0.0, **_out)),
    ("E_impact", "output", 0.0, "Energy taken by the impacts so far (the kinetic energy lost in the frame of "
     "the wall's material point at P)", dict(unit="J", min=0.0, **_out)),
    ("t_first_slip", "output", NEVER, "Time the ball first slid (1e300: not yet; contact_model = 1: always "
     "1e300, t_invalid dates the latch)", dict(unit="s", **_out)),
    ("t_first_flight", "output", NEVER, "Time the ball first left the wall (1e300: not yet; contact_model = "
     "1: always 1e300, t_invalid dates the latch)", dict(unit="s", **_out)),
    ("vxC", "output", 0.0, "Velocity of the ball centre C, x in the fixed axes (absolute)",
     dict(unit="m/s", **_out)),
    ("vyC", "output", 0.0, "Velocity of the ball centre C, y in the fixed axes (absolute)",
     dict(unit="m/s", **_out)),
    ("vzC", "output", 0.0, "Velocity of the ball centre C, z in the fixed axes (absolute)",
     dict(unit="m/s", **_out)),
    *[(f"F{c}_mean", "output", 0.0, f"Force of the ball on the chamber, {c} in the fixed axes, averaged over "
       f"the last communication step with the impulses of its impacts: m (g_vec - (v_C(t) - v_C(t - h)) / "
       f"h)_{c}, from the published v{c}C (the momentum the chamber received over the step, divided by h; "
       f"at the start time: F{c})", dict(unit="N", **_out)) for c in "xyz"],
    ("M_reaction_mean", "output", 0.0, "M_reaction averaged over the last communication step with the torque "
     "impulses of its impacts (contact_model = 2): a drive that integrates it over the step receives the "
     "torque's integral, exact to the integrator's tolerance (an angular-momentum balance, docs/design.md "
     "section 14: motion = 1 -(K(t) - K(t - h)) / h + the mean of m (v_A x v_C)_z with K = m (A x v_C)_z; "
     "motion = 2 -(L_z(t) - L_z(t - h)) / h, L_z the ball's angular momentum about z1). At the start time, "
     "and with contact_model = 1 (the rolling model carries no torque quadrature), M_reaction itself",
     dict(unit="N.m", **_out)),
)
BALL_IN_SHELL = _interface(
    "BallInShell",
    "Ball rolling without slip inside a spherical chamber that translates (motion = 1, Gibbs-Appell "
    "model of the shockless ball mill) or moves in 3-D and turns (motion = 2)",
    [
        ("r", "parameter", _ball.r, "Ball radius", dict(unit="m", min=0.0, max=1e3)),
        ("R", "parameter", _ball.R, "Chamber (inner sphere) radius, > r", dict(unit="m", min=0.0, max=1e3)),
        ("m", "parameter", _ball.m, "Ball mass (default: steel ball of r = 25 mm)", dict(unit="kg", min=0.0, max=1e6)),
        ("g", "parameter", _ball.g, "Gravitational acceleration", dict(unit="m/s2", min=0.0, max=1e3)),
        ("mu", "parameter", _ball.mu, "Friction coefficient ball/chamber, for the rolling check",
         dict(unit="1", min=0.0, max=100.0)),
        ("xC0", "parameter", 0.0, "Initial ball centre x (lower half of the chamber; motion = 2: in the "
         "chamber's axes)", dict(unit="m")),
        ("yC0", "parameter", 0.0, "Initial ball centre y (lower half of the chamber; motion = 2: in the "
         "chamber's axes)", dict(unit="m")),
        ("wx0", "parameter", 0.0, "Initial angular velocity x (motion = 2: relative to the chamber, in its "
         "axes; 0 = co-rotating)", dict(unit="rad/s", min=-W0_MAX, max=W0_MAX)),
        ("wy0", "parameter", 0.0, "Initial angular velocity y (motion = 2: relative to the chamber, in its "
         "axes)", dict(unit="rad/s", min=-W0_MAX, max=W0_MAX)),
        ("wz0", "parameter", 0.0, "Initial angular velocity z (motion = 2: relative to the chamber, in its "
         "axes)", dict(unit="rad/s", min=-W0_MAX, max=W0_MAX)),
        ("formulation", "parameter", 1, "Equations: 1 = vector (n, omega; whole sphere), "
         "2 = paper (xC, yC, omega; lower hemisphere only)", dict(min=1, max=2)),
        # default RK45 at 1e-8: with communication steps of a few ms the coupling error dominates
        # and RK45 gives the same contact point and N as DOP853 at 1e-9 for ~30 % less time
        # (BENCHMARKS.md, co-simulation section)
        ("integrator", "parameter", 2, "Internal integrator: 1 = DOP853 (adaptive, 8th order), "
         "2 = RK45 (adaptive), 3 = RK4 (fixed step h_fixed)", dict(min=1, max=3)),
        ("tolerance", "parameter", 1e-8, "Relative tolerance of the adaptive integrators",
         dict(unit="1", min=1e-15, max=0.1)),
        ("h_fixed", "parameter", 1e-3, "Step of the fixed-step RK4 integrator", dict(unit="s", min=0.0)),
        ("input_mode", "parameter", 1, "How the platform acceleration between communication points "
         "is obtained: 1 = from the derivative inputs vx1O..ay1O (Hermite extrapolation), "
         "2 = from the positions x1O, y1O alone (polynomial through the last 6 samples), "
         "3 = hold ax1O, ay1O constant (first order), 4 = measured accelerations ax1O, ay1O, linear "
         "between samples (x1O, y1O only for the moment arm; for noisy measured motion); motion = 2 takes "
         "1 (z1O like x1O, Omega and Omega_dot as a velocity/acceleration pair) or 3 (hold az1O and "
         "Omega_dot) and refuses 2 and 4", dict(min=1, max=4)),
        ("max_step", "parameter", 0.0, "Largest communication step accepted; longer steps are "
         "refused (fmi2Discard) because the platform motion cannot be extrapolated accurately over "
         "them. 0 = automatic: 1/20 of the ball's natural period 2 pi sqrt(7 (R - r) / (5 g))",
         dict(unit="s", min=0.0)),
        ("corrector", "parameter", True, "Predictor-corrector (input modes 1 and 2): once the inputs "
         "at the end of a step are known, re-integrate the steps inside the input window (1 step with "
         "derivative inputs, 5 with positions only) along the interpolating fit, so extrapolation "
         "errors do not accumulate; costs that many extra integrations per step"),
        *[(name, "input", 0.0, _INPUT_TEXT[name][0], dict(unit=_INPUT_TEXT[name][1]))
          for name in BALL_INPUTS],
        *[(name, "output", 0.0, desc, dict(unit=unit, **(_feed if name in BALL_FEEDTHROUGH else _out)))
          for name, unit, desc in BALL_OUTPUTS],
        ("contact", "output", True, "The ball touches the wall (N > 0); with contact_model = 1 the model is "
         "invalid otherwise",
         _feed),
        ("rolling", "output", True, "Contact and |F_t| <= mu N: the ball rolls without slip", _feed),
        # losses to the ground material (declared after the outputs: earlier value references stay)
        ("delta", "parameter", 0.0, "Rolling-resistance length: the ground material resists the "
         "rolling with a moment delta N opposite to the rolling angular velocity (0 = none)",
         dict(unit="m", min=0.0)),
        ("c_drag", "parameter", 0.0, "Viscous drag of the ground material on the ball's centre, "
         "F_d = -c_drag v_C,rel (0 = none); Fx..Fz and M_reaction then include its reaction on the "
         "material the chamber carries", dict(unit="N.s/m", min=0.0)),
        ("P_diss", "output", 0.0, "Power dissipated by rolling resistance and drag (0 without them)",
         dict(unit="W", **_feed)),
        ("coupling_error", "output", 0.0, "Estimated error of the contact point from the input "
         "reconstruction: the last step's predicted vs corrected contact point, combined in "
         "quadrature with the drift accumulated from the changes of the fitted acceleration that the "
         "corrector cannot repair (input noise); 0 without the corrector", dict(unit="m", min=0.0, **_out)),
        ("coupling_warn", "parameter", 1e-4, "coupling_error above which a warning is logged (once): "
         "the communication step is too long for how fast the inputs change (tunable)",
         dict(unit="m", min=0.0, variability="tunable")),
        # the call semantics of docs/conformance.md (declared last: earlier value references stay)
        ("input_tol", "parameter", 1e-2, "Input consistency (input_mode = 1): x1O, v1O, a1O of two "
         "consecutive communication points disagreeing by more than this acceleration are flagged "
         "(valid = false, warning) and the reconstruction restarts at the newer point",
         dict(unit="m/s2", min=1e-9, max=1e3)),
        ("valid", "output", True, "False from the first loss of contact, onset of slip (contact_model = 1) or "
         "flagged input inconsistency (or, contact_model = 2, a Zeno sequence the hybrid ball cannot "
         "resolve: from there the ball is held on the wall, rolling only, mode 1) until reset (latched): "
         "outputs after t_invalid are not those of the model's physics", _out),
        ("t_invalid", "output", NEVER, "Time at which valid became false (1e300 while valid)",
         dict(unit="s", **_out)),
        # the chamber's motion in 3-D (motion = 2; declared last: earlier value references stay)
        ("motion", "parameter", 1, "Chamber motion: 1 = translation in the horizontal plane (x1O, y1O "
         "and derivatives; the new inputs must keep their defaults), 2 = general rigid motion (z1O, "
         "Omega, Omega_dot, Q as well; vector formulation, no losses, input_mode 1 or 3)",
         dict(min=1, max=2)),
        *[(name, "input", BALL_MOTION_START[name], _MOTION_INPUT_TEXT[name][0],
           dict(unit=_MOTION_INPUT_TEXT[name][1])) for name in BALL_MOTION_INPUTS],
        *[(name, "output", 0.0, desc, dict(unit=unit, **(_feed if name in BALL_FEEDTHROUGH else _out)))
          for name, unit, desc in BALL_MOTION_OUTPUTS],
        # the material bed and the grinding power (declared last: earlier value references stay)
        ("bed", "parameter", 0, "Where the ground material lies: 0 = it fills the chamber (delta and "
         "c_drag act wherever the ball touches the wall); 1 = a bed in the chamber's bottom whose free "
         "surface is the horizontal plane zP = h_bed: they act only while the contact point is below it "
         "(motion = 1 only)", dict(min=0, max=1)),
        ("h_bed", "parameter", 0.0, "Depth of the material bed (bed = 1): height of its free surface above "
         "the chamber's lowest point (0 = no material; at most 2 R)", dict(unit="m", min=0.0, max=1e3)),
        ("w_bed", "parameter", _ball.bed_band, "Width of the band below the bed's surface across which the "
         "material's resistance rises smoothly (C-infinity) from 0 at the surface to its full value "
         "(bed = 1)", dict(unit="m", min=0.0, max=1e3)),
        ("P_grind", "output", 0.0, "Grinding power: the power the ball delivers to the ground material, "
         "the work rate of its rolling resistance and drag relative to the material the chamber carries "
         "(the rolling model dissipates nothing else: equal to P_diss)", dict(unit="W", **_feed)),
        ("s_bed", "output", 1.0, "Share of the material's resistance acting at the contact point: 1 in the "
         "bed (deeper than w_bed below its surface; always with bed = 0), 0 above its surface",
         dict(unit="1", **_out)),
        *BALL_HYBRID_ROWS,
        # the creeping slide's threshold (declared last: earlier value references stay)
        ("creep_eps", "parameter", _contact.creep_eps, "Creeping-slide threshold (contact_model = 2): below "
         "this slip speed a slide's friction takes the direction of its slow manifold (the friction-free "
         "relative tangential acceleration of the contact point, where the slip lies along it), so a slide "
         "that starts from zero slip is not stiff (docs/design.md section 14); 0 = the unreduced Coulomb "
         "model (friction against the slip at every speed: many more internal steps), else 0 < creep_eps "
         "<= 1000 m/s", dict(unit="m/s", min=0.0, max=1e3)),
    ], rules=_BALL_RULES,
    model_exchange=ModelExchange(
        states=(("n_x", "1", "Contact direction n (unit vector from the chamber centre to the contact "
                 "point), x; the vector formulation's state", 1.0),
                ("n_y", "1", "Contact direction n, y", 1.0),
                ("n_z", "1", "Contact direction n, z", 1.0),
                ("w_x", "rad/s", "Ball angular velocity x (the state of the output wx)", 1.0),
                ("w_y", "rad/s", "Ball angular velocity y", 1.0),
                ("w_z", "rad/s", "Ball angular velocity z", 1.0)),
        derivative_inputs=((("w_x", "w_y", "w_z"), ("ax1O", "ay1O")),),
        indicators=(("z_contact", "N", "N, the normal force; it crosses 0 from above where the ball loses "
                     "contact"),
                    ("z_rolling", "N", "mu N - Ft; it crosses 0 from above where the rolling ball would begin "
                     "to slip")),
        notes="vector formulation (formulation = 1), motion = 1, input_mode 1 or 4: the platform "
              "acceleration ax1O, ay1O and position x1O, y1O are read directly at every call (no "
              "reconstruction: the importer supplies them); input_mode 2 (positions alone, "
              "differentiated by a fit) and 3 (inputs held over a communication step) are "
              "co-simulation rules and are refused, as are formulation = 2 and motion = 2 (a chamber "
              "that moves in 3-D and turns: its equations take the chamber's motion from co-simulation's "
              "reconstruction; the refusal names each parameter, its value and what is supported); "
              "contact_model = 2 is refused too (the hybrid ball's states change with its mode, rolling's n, omega "
              "are only one of them: co-simulation only; mu_k, e_n, v_rest and creep_eps are then not used); "
              "integrator, tolerance, h_fixed, max_step, corrector, input_tol and coupling_warn "
              "belong to co-simulation's internal integration and are not used (coupling_error "
              "stays 0: there is no coupling error). valid and t_invalid latch at the state event "
              "where an indicator crosses 0"))

# ----------------------------------------------------------------------------- the structure
# A linear structure per horizontal axis carrying the ball's cavity (ballmill.absorber.structure,
# docs/design.md section 11): up to STRUCTURE_MODES modes per axis, excited by a harmonic force and/or a
# harmonic ground acceleration (a slow linear frequency sweep allowed) plus a ground-acceleration
# record from the master (inputs ag_x, ag_y), and by the ball's force on the cavity (inputs
# Fx_ball, Fy_ball). Its outputs are the cavity's absolute motion under BallInShell's input names.
STRUCTURE_MODES = 3
AXES = ("x", "y")


def _mode_parameters(axis):
    rows = [(f"n_{axis}", "parameter", 1, f"Number of modes of axis {axis}" + (
             " (at least 1)" if axis == "x" else f" (0: the cavity follows the ground in {axis})"),
             dict(min=1 if axis == "x" else 0, max=STRUCTURE_MODES))]
    for j in range(1, STRUCTURE_MODES + 1):
        mode = f"mode {j} of axis {axis}"
        rows += [
            (f"M_{axis}{j}", "parameter", 100.0, f"Modal mass M of {mode}", dict(unit="kg", min=1e-12, max=1e15)),
            (f"f_{axis}{j}", "parameter", (0.8, 2.5, 4.5)[j - 1], f"Undamped natural frequency of {mode}",
             dict(unit="Hz", min=1e-9, max=1e6)),
            (f"zeta_{axis}{j}", "parameter", 0.01, f"Damping ratio of {mode}", dict(unit="1", min=0.0, max=100.0)),
            (f"phi_{axis}{j}", "parameter", 1.0, f"Shape of {mode} at the absorber (the cavity moves by "
             f"phi q)", dict(unit="1", min=-1e6, max=1e6)),
            (f"psi_{axis}{j}", "parameter", 1.0, f"Shape of {mode} where the external force acts "
             f"(the load point: x_load = sum psi q)", dict(unit="1", min=-1e6, max=1e6)),
            (f"L_{axis}{j}", "parameter", 100.0, f"Participation L of {mode} in a ground acceleration "
             f"(M phi for a single mass; set it with M)", dict(unit="kg", min=-1e15, max=1e15)),
        ]
    return rows


def _structure_outputs():
    rows = []
    for a in AXES:
        F, ag = f"F{a}_ball", f"ag_{a}"
        rows += [
            (f"{a}1O", "output", 0.0, f"Cavity (absorber point) absolute position {a}: ground + sum phi q",
             dict(unit="m")),
            (f"v{a}1O", "output", 0.0, f"Cavity absolute velocity {a}", dict(unit="m/s")),
            (f"a{a}1O", "output", 0.0, f"Cavity absolute acceleration {a} (depends directly on {F} and {ag})",
             dict(unit="m/s2", depends=(F, ag), feedthrough=(F, ag))),
        ]
    for a in AXES:
        F, ag = f"F{a}_ball", f"ag_{a}"
        rows += [(f"q_{a}{j}", "output", 0.0, f"Modal coordinate of mode {j} of axis {a} (relative to "
                  f"the ground)", dict(unit="m")) for j in range(1, STRUCTURE_MODES + 1)]
        rows += [
            (f"{a}_rel", "output", 0.0, f"Cavity displacement {a} relative to the ground, sum phi q",
             dict(unit="m")),
            (f"{a}_load", "output", 0.0, f"Structure displacement {a} at the load point relative to the "
             f"ground, sum psi q", dict(unit="m")),
            (f"a{a}_load", "output", 0.0, f"Absolute acceleration {a} at the load point",
             dict(unit="m/s2", depends=(F, ag), feedthrough=(F, ag))),
            (f"{a}g", "output", 0.0, f"Ground displacement {a} (integrated from the ground acceleration "
             f"from rest at the start)", dict(unit="m")),
            (f"v{a}g", "output", 0.0, f"Ground velocity {a}", dict(unit="m/s")),
            (f"ag{a}_total", "output", 0.0, f"Ground acceleration {a}: harmonic part + input {ag}",
             dict(unit="m/s2", depends=(ag,), feedthrough=(ag,))),
            (f"F{a}_exc", "output", 0.0, f"External (harmonic) force on the structure, {a}", dict(unit="N")),
        ]
    return rows


STRUCTURE = _interface(
    "Structure",
    "Linear modal structure per horizontal axis (up to 3 modes) carrying a ball absorber's cavity: "
    "harmonic force or ground acceleration (optional slow sweep) or a ground-acceleration record as "
    "inputs; the ball's force on the cavity as input, the cavity's absolute motion as outputs",
    [
        *_mode_parameters("x"),
        *_mode_parameters("y"),
        ("F0_x", "parameter", 0.0, "Amplitude of the harmonic force in x: F_x = F0_x sin(theta(t))",
         dict(unit="N", min=-1e12, max=1e12)),
        ("F0_y", "parameter", 0.0, "Amplitude of the harmonic force in y: F_y = F0_y sin(theta(t) + phase_y)",
         dict(unit="N", min=-1e12, max=1e12)),
        ("ag0_x", "parameter", 0.0, "Amplitude of the harmonic ground acceleration in x: a_gx = ag0_x "
         "sin(theta(t)) (+ input ag_x)", dict(unit="m/s2", min=-1e6, max=1e6)),
        ("ag0_y", "parameter", 0.0, "Amplitude of the harmonic ground acceleration in y: a_gy = ag0_y "
         "sin(theta(t) + phase_y) (+ input ag_y)", dict(unit="m/s2", min=-1e6, max=1e6)),
        ("f_exc", "parameter", 0.8, "Excitation frequency at t = 0: theta(t) = 2 pi (f_exc t + "
         "sweep_rate t^2 / 2)", dict(unit="Hz", min=1e-9, max=1e6)),
        ("sweep_rate", "parameter", 0.0, "Rate of a slow linear frequency sweep: the instantaneous "
         "frequency is f_exc + sweep_rate t (0: steady harmonic)", dict(unit="Hz/s", min=-1e6, max=1e6)),
        ("phase_y", "parameter", 0.0, "Phase of the y excitation after the x excitation",
         dict(unit="rad", min=-1e3, max=1e3)),
        ("h_max", "parameter", 1e-3, "Largest internal step of the fixed-step RK4 integrator (a "
         "communication step is cut into ceil(H / h_max) equal steps)", dict(unit="s", min=1e-9, max=10.0)),
        ("input_order", "parameter", 2, "The inputs Fx_ball..ag_y over a communication step: 0 = held "
         "at the step's start, 1 = extrapolated linearly from the last 2 communication points, "
         "2 = quadratically from the last 3", dict(min=0, max=2)),
        ("Fx_ball", "input", 0.0, "Force of the ball on the cavity, x (BallInShell.Fx)", dict(unit="N")),
        ("Fy_ball", "input", 0.0, "Force of the ball on the cavity, y (BallInShell.Fy)", dict(unit="N")),
        ("ag_x", "input", 0.0, "Ground acceleration x from a record (added to the harmonic part)",
         dict(unit="m/s2")),
        ("ag_y", "input", 0.0, "Ground acceleration y from a record (added to the harmonic part)",
         dict(unit="m/s2")),
        *_structure_outputs(),
        ("f_inst", "output", 0.8, "Instantaneous excitation frequency f_exc + sweep_rate t", dict(unit="Hz")),
        ("E", "output", 0.0, "Energy of the modes relative to the ground: sum (M q'^2 + K q^2) / 2",
         dict(unit="J")),
        ("W_exc", "output", 0.0, "Work of the excitation on the modes since the start: integral of "
         "sum q' (psi F - L a_g)", dict(unit="J")),
        ("W_damp", "output", 0.0, "Energy dissipated in the modal dampers since the start: integral of "
         "sum C q'^2", dict(unit="J")),
        ("W_ball", "output", 0.0, "Work of the ball's force on the structure since the start: integral "
         "of sum phi q' F_ball (relative to the ground)", dict(unit="J")),
    ],
    default_experiment=(0.0, 60.0, 2e-3),
    model_exchange=ModelExchange(
        states=tuple(
            [(f"s_q_{a}{j}", "m", f"Modal coordinate of mode {j} of axis {a} (stays 0 for a mode beyond "
              f"n_{a})", 1.0) for a in AXES for j in range(1, STRUCTURE_MODES + 1)]
            + [(f"s_qd_{a}{j}", "m/s", f"Modal velocity of mode {j} of axis {a}", 1.0)
               for a in AXES for j in range(1, STRUCTURE_MODES + 1)]
            + [row for a in AXES for row in ((f"s_{a}g", "m", f"Ground displacement {a}", 1.0),
                                               (f"s_v{a}g", "m/s", f"Ground velocity {a}", 1.0))]
            + [(f"s_{w}", "J", f"The work integral {w}", 1.0) for w in ("W_exc", "W_damp", "W_ball")]),
        derivative_inputs=(
            (tuple(f"s_qd_{a}{j}" for a in AXES for j in range(1, STRUCTURE_MODES + 1)) + ("s_W_exc",),
             ("Fx_ball", "Fy_ball", "ag_x", "ag_y")),
            (("s_vxg", "s_vyg"), ("ag_x", "ag_y")),
            (("s_W_ball",), ("Fx_ball", "Fy_ball"))),
        notes="Fx_ball, Fy_ball, ag_x, ag_y are read as set at every call (h_max, input_order: "
              "co-simulation's). With BallInShell the coupling is an algebraic loop: ax1O, ay1O "
              "depend directly on Fx_ball, Fy_ball (ModelStructure/Outputs) and BallInShell's Fx, Fy "
              "on ax1O, ay1O; an importer solves it (the loop is linear: both sides are affine in "
              "the other's output) or breaks it"))

INTERFACES = {i.name: i for i in (BALL_IN_SHELL, MOTOR_STARTUP, INDUCTION_MOTOR, FIG1_DRIVE, STRUCTURE)}

BIG = 1e300  # stands for infinity in outputs (FMI tools choke on inf)
assert math.isfinite(BIG)
