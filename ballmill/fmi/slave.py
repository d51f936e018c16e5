"""Base class for the project's pythonfmu slaves (bundled into every FMU): the FMI
call semantics all three FMUs share (docs/conformance.md is their specification).

pythonfmu 0.7.0 writes no units, no min/max and no InitialUnknowns, so its
FMUs fail `fmpy validate` as built. `Slave` declares each variable with its
unit, description and bounds in one call (`add`), and extends `to_xml` with
UnitDefinitions, unit/min/max attributes, output dependencies and
InitialUnknowns. `declare` registers an FMU's variables from its one
declaration in ballmill.fmi.interface. It also provides full FMU-state save/restore: subclasses
return their internal state from `internal_state()` and take it back in
`restore_internal_state()`; pythonfmu alone would save registered variables
only and rollback would silently lose the integrator's state.

It owns, once for every FMU (docs/conformance.md):

* the life cycle (instantiated -> initialisation -> stepping -> terminated) and
  the step-size policy of fmi2DoStep (`Slave.do_step`): a step that is not
  positive and finite, not contiguous with the FMU's time, longer than the
  model's ``max_step``, or comes after fmi2Terminate is refused, state intact;
* the parameter check at the exit of initialisation (finite, within the
  declared min/max) and the refusal of fixed parameters set after it (only
  parameters declared ``tunable`` take a new value then);
* the one state-restore path: a saved or deserialised FMU state carries the
  model's name, a format number, every variable and the internal state; it is
  validated, the model is rebuilt from the restored parameters, and anything
  wrong restores the instance as it was and refuses the call;
* the serialised form of an FMU state (`state_to_bytes`, `state_from_bytes`): a
  header line with the format number, the state as JSON, and a CRC-32 of all of it,
  so that a state with any byte changed is refused before it is parsed;
* the validity latch (outputs ``valid`` and ``t_invalid``, `Slave.invalidate`).

Everything here is FMI plumbing: no physics.
"""
from __future__ import annotations

import copy
import json
import math
import re
import zlib
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status
from pythonfmu.default_experiment import DefaultExperiment

from .interface import CRANK_KINEMATICS, LOG_CATEGORIES, UNITS, Interface  # noqa: F401 (re-exported)

_CAUSALITY = {"parameter": Fmi2Causality.parameter, "input": Fmi2Causality.input,
              "output": Fmi2Causality.output, "local": Fmi2Causality.local}
_TYPES = {float: Real, int: Integer, bool: Boolean}


# the FMU's time t_c and a doStep's currentCommunicationPoint agree when they differ
# by at most T_REL max(1 s, |t_c|) (a master's own time arithmetic)
T_REL = 1e-13
STATE_FORMAT = 6  # version of the FMU-state layout (`Slave._get_fmu_state`, `state_to_bytes`)
STATE_MAGIC = b"ballmill FMU state, format "  # a serialised state's first line: this, the format, LF
BIG = 1e300  # stands for +-infinity in outputs (FMI tools choke on inf); see `Slave.finite`
NEVER = 1e300  # t_invalid while the model is valid


def state_to_bytes(state: dict) -> bytes:
    """A serialised FMU state: the line ``ballmill FMU state, format 6`` (LF), the state as
    JSON, and the CRC-32 (zlib.crc32) of every byte before it, 4 bytes little-endian."""
    body = STATE_MAGIC + str(STATE_FORMAT).encode() + b"\n" + json.dumps(state).encode()
    return body + zlib.crc32(body).to_bytes(4, "little")


def state_from_bytes(blob: bytes) -> dict:
    """The state in a serialised FMU state, or ValueError naming what failed: not a
    ballmill state, another format version, a checksum mismatch (any byte changed), JSON
    that does not parse. What the state holds is checked when it is set (`Slave`)."""
    blob = bytes(blob)
    head = blob.split(b"\n", 1)[0]
    if not head.startswith(STATE_MAGIC):
        try:  # format 2 and older: the JSON alone, its format inside
            old = json.loads(blob)
        except ValueError:
            old = None
        if isinstance(old, dict) and "__format__" in old:
            raise ValueError(f"format version {old['__format__']!r}, expected {STATE_FORMAT}")
        raise ValueError(f"it begins with {blob[:len(STATE_MAGIC)]!r}, expected {STATE_MAGIC!r}: "
                         f"not a ballmill FMU state")
    version = head[len(STATE_MAGIC):]
    if version != str(STATE_FORMAT).encode():
        raise ValueError(f"format version {version[:20].decode('ascii', 'replace')}, expected {STATE_FORMAT}")
    if len(blob) < len(head) + 1 + 4:
        raise ValueError(f"size {len(blob)} bytes, shorter than its header line and checksum")
    stored, computed = int.from_bytes(blob[-4:], "little"), zlib.crc32(blob[:-4])
    if stored != computed:
        raise ValueError(f"checksum mismatch: stored 0x{stored:08x}, computed 0x{computed:08x} (the state was "
                         f"changed after it was serialised)")
    try:
        return json.loads(blob[len(head) + 1:-4])
    except ValueError as e:
        raise ValueError(f"its JSON does not parse: {e}") from None


class Refused(ValueError):
    """A call the FMU refuses (pythonfmu turns the exception into fmi2Fatal; the
    message names the variable, the value and what is accepted)."""


class Slave(Fmi2Slave):
    """pythonfmu slave with units, bounds, dependencies, full state save and the
    project's call semantics (see the module docstring)."""

    log_categories = LOG_CATEGORIES
    # physics' names in error messages -> this FMU's variable names
    NAMES: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._meta: dict[str, dict] = {}
        self.author = "ballmill"
        self.license = "MIT"
        self._phase = "instantiated"  # -> initialisation -> stepping -> terminated
        self._time = 0.0  # the FMU's current time t_c

    @property
    def who(self) -> str:
        return f"{type(self).__name__} '{self.instance_name}'"

    # -- declaration -------------------------------------------------------
    def declare(self, interface: Interface):
        """Register every variable of the FMU's one declaration (ballmill.fmi.interface),
        in its value-reference order, and its DefaultExperiment."""
        for v in interface.variables:
            self.add(v.name, v.causality, v.start, v.description, v.unit, v.min, v.max, v.depends,
                     variability=v.fmi_variability, feedthrough=v.feedthrough)
        self.set_default_experiment(*interface.default_experiment)

    def add(self, name: str, causality: str, start, description: str, unit: str | None = None,
            vmin: float | None = None, vmax: float | None = None, depends=None, tunable: bool = False,
            variability=None, feedthrough=()):
        """Declare a variable and set its start value as an attribute.

        The Python type of ``start`` chooses the FMI type (float -> Real,
        int -> Integer, bool -> Boolean). ``depends`` lists the input names an
        output depends on during initialisation (InitialUnknowns); ``feedthrough``
        those it depends on while stepping too (ModelStructure/Outputs: the subclass
        recomputes the output when one of them is set, see `inputs_set`). A parameter
        is fixed unless ``tunable`` (then it may be set between steps and takes
        effect at the next one).
        """
        kind = _TYPES[type(start)]
        if kind is Real and unit is None:
            raise ValueError(f"Real variable {name!r} needs a unit")
        if unit is not None and unit not in UNITS:
            raise ValueError(f"unit {unit!r} of {name!r} is not in UNITS")
        setattr(self, name, start)
        tunable = tunable or variability == "tunable"
        if variability is not None:
            variability = Fmi2Variability[variability]
        elif causality == "parameter":
            variability = Fmi2Variability.tunable if tunable else Fmi2Variability.fixed
        elif kind is Real:
            variability = Fmi2Variability.continuous
        else:
            variability = Fmi2Variability.discrete
        self.register_variable(kind(name, causality=_CAUSALITY[causality], description=description,
                                    variability=variability))
        self._meta[name] = {"unit": unit, "min": vmin, "max": vmax, "depends": depends or (),
                            "feedthrough": tuple(feedthrough or ()),
                            "causality": causality, "tunable": tunable, "type": type(start)}

    def choice(self, name: str, table: dict):
        """The meaning of an enumerated Integer parameter, or a ValueError naming
        the value and the allowed ones."""
        value = getattr(self, name)
        if value not in table:
            raise ValueError(f"{name} must be one of {sorted(table)} "
                             f"({', '.join(f'{k} = {v}' for k, v in table.items())}), got {value!r}")
        return table[value]

    def set_default_experiment(self, start: float, stop: float, step: float, tolerance: float | None = None):
        self.default_experiment = DefaultExperiment(start, stop, step, tolerance)

    def _range_text(self, name) -> str:
        meta = self._meta[name]
        unit = f" {meta['unit']}" if meta["unit"] and meta["unit"] != "1" else ""
        lo = "-inf" if meta["min"] is None else f"{meta['min']:g}"
        hi = "inf" if meta["max"] is None else f"{meta['max']:g}"
        return f"[{lo}, {hi}]{unit}"

    def check_parameters(self):
        """Every parameter finite and within its declared [min, max] (ParameterError
        naming the variable, the value and the range otherwise)."""
        for name, meta in self._meta.items():
            if meta["causality"] != "parameter" or meta["type"] is bool:
                continue
            v = getattr(self, name)
            unit = f" {meta['unit']}" if meta["unit"] and meta["unit"] != "1" else ""
            if not math.isfinite(v) or (meta["min"] is not None and v < meta["min"]) \
                    or (meta["max"] is not None and v > meta["max"]):
                raise ValueError(f"parameter {name} = {v!r}{unit} is outside its accepted range "
                                 f"{self._range_text(name)}")

    def rename(self, message: str) -> str:
        """A physics message with the physics' names replaced by this FMU's."""
        if not self.NAMES:
            return message
        return re.sub(r"\b(" + "|".join(self.NAMES) + r")\b", lambda mo: self.NAMES[mo.group(1)], message)

    # -- model description ---------------------------------------------------
    def to_xml(self, model_options=dict()) -> Element:  # noqa: B006 - pythonfmu's signature
        root = super().to_xml(model_options)
        used = sorted({m["unit"] for m in self._meta.values() if m["unit"]})
        units = Element("UnitDefinitions")
        for u in used:
            spec = dict(UNITS[u])
            factor = spec.pop("factor", None)
            unit_el = SubElement(units, "Unit", name=u)
            attrs = {k: str(v) for k, v in spec.items()}
            if factor is not None:
                attrs["factor"] = repr(factor)
            SubElement(unit_el, "BaseUnit", attrs)
        # schema order: CoSimulation, UnitDefinitions, TypeDefinitions, LogCategories, ...
        root.insert(list(root).index(root.find("CoSimulation")) + 1, units)

        index = {}
        for i, sv in enumerate(root.find("ModelVariables")):
            name = sv.get("name")
            index[name] = i + 1
            meta = self._meta.get(name)
            if not meta:
                continue
            typed = sv[0]
            if meta["unit"]:
                typed.set("unit", meta["unit"])
            for key in ("min", "max"):
                if meta[key] is not None:
                    v = meta[key]
                    typed.set(key, str(v) if isinstance(v, int) and sv.find("Integer") is not None
                              else repr(float(v)))
        structure = root.find("ModelStructure")
        outputs = structure.find("Outputs")
        init = SubElement(structure, "InitialUnknowns")
        if outputs is not None:
            for unknown in outputs:
                name = root.find("ModelVariables")[int(unknown.get("index")) - 1].get("name")
                # outputs at t_k come from the state, and the inputs of direct feedthrough
                unknown.set("dependencies", " ".join(
                    str(index[d]) for d in self._meta.get(name, {}).get("feedthrough", ())))
                deps = " ".join(str(index[d]) for d in self._meta.get(name, {}).get("depends", ()))
                SubElement(init, "Unknown", index=unknown.get("index"), dependencies=deps)
        if not len(init):
            structure.remove(init)
        return root

    # -- life cycle ----------------------------------------------------------
    # Subclasses implement: build() (the model from the parameters, validated; raises
    # ValueError/ArithmeticError naming the variable), start() (the state at self._time and
    # its outputs), step(t, t_end) (True, or self.discard(...)), max_step() [s], and
    # internal_state()/restore_internal_state() (validating what they take back).
    def build(self) -> None:
        """Subclasses: build the model from the parameters (raise on a bad value)."""

    def start(self) -> None:
        """Subclasses: the initial state at self._time, and its outputs."""

    def step(self, t: float, t_end: float) -> bool:
        """Subclasses: advance from t (= the FMU's time) to t_end."""
        return True

    def step_limit(self) -> float:
        """The longest communication step the model accepts [s] (inf: any)."""
        return math.inf

    def initialise(self) -> None:
        """Check the parameters, build the model and publish the outputs at the start
        time from the current inputs. Called at the exit of initialisation mode and
        on every read during it, so that a master that iterates over connected FMUs
        in initialisation mode (libcosim, ballmill's runner) sees outputs consistent
        with the inputs it set. Raises Refused (the message names the variable, the
        value and the accepted range)."""
        try:
            self.check_parameters()
            self.build()
            self.start()
        except (ValueError, ArithmeticError) as e:
            raise Refused(f"{self.who}: initialisation failed: {self.rename(str(e))}") from None

    def setup_experiment(self, start_time, stop_time, tolerance):
        if self._phase != "instantiated":
            raise Refused(f"{self.who}: fmi2SetupExperiment is allowed only after fmi2Instantiate "
                          f"(or fmi2Reset), not in the {self._phase} phase")
        if not math.isfinite(start_time):
            raise Refused(f"{self.who}: startTime = {start_time!r} s refused: it must be finite")
        self._time = float(start_time)

    def enter_initialization_mode(self):
        if self._phase != "instantiated":
            raise Refused(f"{self.who}: fmi2EnterInitializationMode is allowed only after "
                          f"fmi2Instantiate (or fmi2Reset), not in the {self._phase} phase")
        self._phase = "initialisation"

    def exit_initialization_mode(self):
        if self._phase != "initialisation":
            raise Refused(f"{self.who}: fmi2ExitInitializationMode outside initialisation mode "
                          f"({self._phase} phase)")
        try:
            self.initialise()
        except Refused as e:
            self.error(str(e))
            raise
        self._phase = "stepping"

    def terminate(self):
        self._phase = "terminated"

    def get_real(self, vrs):
        self._refresh()
        return super().get_real(vrs)

    def get_boolean(self, vrs):
        self._refresh()
        return super().get_boolean(vrs)

    def _refresh(self):
        if self._phase == "initialisation":
            try:
                self.initialise()
            except Refused:
                pass  # reported (and the call refused) at fmi2ExitInitializationMode

    # -- the step-size policy ------------------------------------------------
    def do_step(self, current_time, step_size):
        """fmi2DoStep: the policy of docs/conformance.md, then `step`. A refused call
        returns fmi2Discard (pythonfmu's only non-fatal refusal) with the reason
        logged; the state is untouched."""
        call = f"doStep(currentCommunicationPoint = {current_time!r} s, communicationStepSize = {step_size!r} s)"
        if self._phase != "stepping":
            when = "after fmi2Terminate" if self._phase == "terminated" else "before fmi2ExitInitializationMode"
            return self.refuse(f"{self.who}: {call} {when} refused")
        t_c = self._time
        if not (math.isfinite(step_size) and step_size > 0.0):
            return self.refuse(f"{self.who}: {call} refused: communicationStepSize must be positive and "
                               f"finite, accepted range (0, {self.step_limit():.6g}] s; state kept at t = {t_c!r} s")
        if not (math.isfinite(current_time)
                and abs(current_time - t_c) <= T_REL * max(1.0, abs(t_c))):
            return self.refuse(f"{self.who}: {call} refused: currentCommunicationPoint must equal the "
                               f"FMU's time t = {t_c!r} s (steps are contiguous; restore an FMU state to go "
                               f"back); state kept")
        t_end = current_time + step_size
        if not t_end > t_c:
            return self.refuse(f"{self.who}: {call} refused: the step ends at {t_end!r} s, not after the "
                               f"FMU's time t = {t_c!r} s; state kept")
        limit = self.step_limit()
        if step_size > limit * (1.0 + 1e-12):
            return self.discard(
                f"{self.who}: {call} refused: communicationStepSize exceeds max_step = {limit:.6g} s, "
                f"accepted range (0, {limit:.6g}] s; state kept at t = {t_c!r} s")
        if not self.step(t_c, t_end):
            return False
        self._time = t_end
        return True

    def refuse(self, msg: str) -> bool:
        """A call with arguments the FMI standard does not allow: logged as an error,
        fmi2Discard returned (pythonfmu cannot return fmi2Error from doStep)."""
        self.log(msg, Fmi2Status.error)
        return False

    # -- setting variables ---------------------------------------------------
    def _check_set(self, vrs, values):
        """Refuse (Refused, nothing set) outputs, and fixed parameters after initialisation."""
        for vr, value in zip(vrs, values):
            name = self.vars[vr].name
            meta = self._meta.get(name)
            if meta is None:
                continue
            unit = f" {meta['unit']}" if meta["unit"] and meta["unit"] != "1" else ""
            if meta["causality"] == "output":
                raise Refused(f"{self.who}: {name} is an output and cannot be set (got {name} = {value!r}{unit})")
            if meta["causality"] != "parameter" or self._phase in ("instantiated", "initialisation"):
                continue
            if not meta["tunable"]:
                raise Refused(f"{self.who}: parameter {name} is fixed: it can be set only before "
                              f"fmi2ExitInitializationMode; {name} = {value!r}{unit} refused, {name} keeps "
                              f"{getattr(self, name)!r}{unit}")
            ok = math.isfinite(value) and (meta["min"] is None or value >= meta["min"]) \
                and (meta["max"] is None or value <= meta["max"])
            if not ok:
                raise Refused(f"{self.who}: tunable parameter {name} = {value!r}{unit} refused: accepted "
                              f"range {self._range_text(name)}; {name} keeps {getattr(self, name)!r}{unit}")

    def set_real(self, vrs, values):
        self._check_set(vrs, values)
        super().set_real(vrs, values)
        if self._phase == "stepping" and any(self._meta.get(self.vars[vr].name, {}).get("causality") == "input"
                                             for vr in vrs):
            self.inputs_set()

    def inputs_set(self) -> None:
        """Subclasses with direct feedthrough: recompute those outputs at the FMU's time from
        the inputs just set (fmi2SetReal between steps), without stepping. Leave the outputs
        as they are when the inputs are unusable (the next step refuses them)."""

    def set_integer(self, vrs, values):
        self._check_set(vrs, values)
        super().set_integer(vrs, values)

    def set_boolean(self, vrs, values):
        self._check_set(vrs, values)
        super().set_boolean(vrs, values)

    # -- the validity latch ----------------------------------------------------
    def invalidate(self, t: float, reason: str) -> None:
        """Latch valid = False at time t (the first call wins; until reset)."""
        if self.valid:
            self.valid, self.t_invalid = False, float(t)
            self.warn(f"{self.who}: valid = false from t = {t:.9g} s (latched until reset): {reason}")

    # -- serialised FMU states (state_to_bytes, state_from_bytes) ---------------
    # pythonfmu calls these two on the class (no instance: the message names the model)
    @classmethod
    def _fmu_state_to_bytes(cls, state) -> bytes:
        return state_to_bytes(state)

    @classmethod
    def _fmu_state_from_bytes(cls, blob) -> dict:
        """fmi2DeSerializeFMUstate: the state, or Refused naming what failed."""
        try:
            return state_from_bytes(blob)
        except ValueError as e:
            raise Refused(f"{cls.__name__}: fmi2DeSerializeFMUstate: FMU state refused, the instance keeps its "
                          f"state: {e}") from None

    # -- state save/restore ------------------------------------------------
    def internal_state(self) -> dict:
        """Subclasses: everything beyond the registered variables, as plain data."""
        return {}

    def restore_internal_state(self, state: dict) -> None:
        """Subclasses: take back what `internal_state` returned (ValueError if it does
        not fit the model just built from the restored parameters)."""

    def _get_fmu_state(self):
        state = super()._get_fmu_state()
        built = self._phase in ("stepping", "terminated")
        state["__format__"] = STATE_FORMAT
        state["__model__"] = type(self).__name__
        state["__phase__"] = self._phase
        state["__time__"] = self._time
        state["__internal__"] = copy.deepcopy(self.internal_state()) if built else None
        return state

    def _check_blob(self, state):
        if not isinstance(state, dict):
            raise ValueError(f"an FMU state must be a mapping, got {type(state).__name__}")
        if state.get("__model__") != type(self).__name__ or state.get("__format__") != STATE_FORMAT:
            raise ValueError(f"the state belongs to model {state.get('__model__')!r} with format "
                             f"{state.get('__format__')!r}, expected {type(self).__name__!r} with format "
                             f"{STATE_FORMAT}")
        if state.get("__phase__") not in ("instantiated", "initialisation", "stepping", "terminated"):
            raise ValueError(f"unknown phase {state.get('__phase__')!r}")
        if not (isinstance(state.get("__time__"), (int, float)) and math.isfinite(state["__time__"])):
            raise ValueError(f"time must be finite, got {state.get('__time__')!r}")
        for name, meta in self._meta.items():
            if name not in state:
                raise ValueError(f"variable {name} is missing")
            v = state[name]
            kind = meta["type"]
            ok = isinstance(v, bool) if kind is bool else (
                isinstance(v, int) and not isinstance(v, bool) if kind is int
                else isinstance(v, (int, float)) and not isinstance(v, bool))
            if not ok:
                raise ValueError(f"variable {name} = {v!r} has the wrong type (expected {kind.__name__})")
            if kind is float and meta["causality"] != "input" and not math.isfinite(v):
                raise ValueError(f"variable {name} = {v!r} is not finite")

    def _apply_state(self, state):
        for name, meta in self._meta.items():
            setattr(self, name, meta["type"](state[name]))
        self._phase, self._time = state["__phase__"], float(state["__time__"])
        if self._phase in ("stepping", "terminated"):
            self.check_parameters()
            self.build()
            internal = state.get("__internal__")
            if not isinstance(internal, dict):
                raise ValueError("the internal state is missing")
            self.restore_internal_state(copy.deepcopy(internal))

    def _set_fmu_state(self, state):
        """The one restore path (fmi2SetFMUstate, also after fmi2DeSerializeFMUstate):
        validate, take over the whole configuration, rebuild the model, restore the
        internal state; on any problem put the instance back as it was and refuse."""
        try:
            self._check_blob(state)
        except ValueError as e:
            raise Refused(f"{self.who}: FMU state refused, the instance keeps its state: {e}") from None
        backup = self._get_fmu_state()
        try:
            self._apply_state(state)
        except (ValueError, ArithmeticError, KeyError, TypeError, IndexError) as e:
            self._apply_state(backup)
            raise Refused(f"{self.who}: FMU state refused, the instance keeps its state: "
                          f"{self.rename(str(e))}") from None

    # -- logging helpers ---------------------------------------------------
    def log(self, msg, status=Fmi2Status.ok, category=None, debug=None):
        # pythonfmu hands the message to the FMI logger as a printf format string
        # (cppfmu's Logger::Log): a literal '%' must travel as '%%'
        super().log(str(msg).replace("%", "%%"), status, category)

    def warn(self, msg: str):
        self.log(msg, Fmi2Status.warning)

    def error(self, msg: str):
        self.log(msg, Fmi2Status.error)

    def discard(self, msg: str) -> bool:
        """Log why a step is refused and return False (fmi2Discard)."""
        self.log(msg, Fmi2Status.discard)
        return False

    # -- outputs -------------------------------------------------------------
    @staticmethod
    def finite(name: str, value: float, allow_infinite: bool = False) -> float:
        """An output value to publish: finite as it is; +-inf as +-1e300 where the
        output's definition allows infinity; anything else raises ArithmeticError
        naming the output (the step or initialisation is then refused)."""
        if math.isfinite(value):
            return value
        if allow_infinite and value == value:
            return math.copysign(BIG, value)
        raise ArithmeticError(f"output {name} would be {value!r}")
