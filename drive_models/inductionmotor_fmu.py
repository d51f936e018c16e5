"""InductionMotor FMU: an induction motor that drives the crank and feels the ball.

A thin pythonfmu adapter over ballmill.physics.drives.induction.CrankDrive (docs/design.md
section 4): a three-phase induction motor given by its datasheet (Kloss's
formula, or a 4-state dq model fitted to the same datasheet), a starter
(direct on line, voltage ramp, V/f frequency ramp), an ideal gear of ratio
i = motor speed / crank speed, and the crank shaft with the platform:

    J_total psi'' = i T_motor + M_reaction,
    J_total = J_crank + m_platform l^2 + i^2 J_rotor.

Unlike MotorStartup (a prescribed law), the crank speed here follows from
the torques: the ball's reaction torque M_reaction (input, from
BallInShell.M_reaction) slows the drive down. The outputs are MotorStartup's
(crank angle, speed, acceleration and the platform kinematics, all from the
integrated state) plus the motor's speed, torque, current and power.

Each do_step integrates the drive's ODE from t_k to t_k + H (DOP853 with
error control, the step size carried across communication points) into a
scratch state and keeps it only on success. Over the step M_reaction is
extrapolated linearly from the last two communication points (or held,
M_input = 1); outputs at t_k + H use the same extrapolated value, so they do
not depend on the input set at t_k + H (no direct feedthrough). A
non-finite M_reaction, or a failing integration, refuses the step
(fmi2Discard, the reason in the log) and leaves the last good state.
"""
from __future__ import annotations

import os
import sys

# An earlier FMU in this process may have imported ballmill from its own, since deleted,
# resources folder (fmpy removes them after a run): forget it, so that the import below
# finds this FMU's copy (or an installed ballmill) again.
if not os.path.exists(getattr(sys.modules.get("ballmill"), "__file__", None) or os.curdir):
    for _name in [n for n in sys.modules if n.split(".")[0] == "ballmill"]:
        del sys.modules[_name]

import math

import numpy as np

from ballmill.fmi.interface import CRANK_KINEMATICS, INDUCTION_MOTOR
from ballmill.fmi.slave import Slave
from ballmill.physics.errors import ParameterError
from ballmill.physics.integrators import Integrator
from ballmill.physics.drives.induction import RPM, CrankDrive
from ballmill.physics.drives.induction import InductionMotor as MotorData
from ballmill.physics.drives.induction import platform_state

MODELS = {1: "kloss", 2: "dq"}
STARTS = {1: "dol", 2: "voltage_ramp", 3: "frequency_ramp"}
M_INPUTS = {1: "hold", 2: "linear"}
# the physics' names of the datasheet values -> this FMU's parameter names (for error messages)
NAMES = {"rated_power": "P_rated", "rated_speed": "n_rated", "rated_voltage": "U_rated",
         "rated_frequency": "f_rated", "rated_current": "I_rated", "power_factor": "cos_phi",
         "efficiency": "eta", "breakdown_ratio": "Tb_ratio", "stator_copper_share": "Rs_share"}

KINEMATICS = CRANK_KINEMATICS


MAX_INTERNAL_STEPS = 20000  # work bound: internal DOP853 steps of one doStep


class InductionMotor(Slave):
    """Induction motor (Kloss or dq) + starter + gear + crank + platform, loaded by M_reaction."""

    NAMES = NAMES

    description = INDUCTION_MOTOR.description

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.declare(INDUCTION_MOTOR)
        self._drive = None
        self._integrator = None
        self._z = None  # drive state + W_motor
        self._h = None
        self._samples = []  # last (t, M_reaction) at communication points

    # -- life cycle --------------------------------------------------------
    def build(self):
        motor = MotorData(
            rated_power=self.P_rated, rated_speed=self.n_rated, rated_voltage=self.U_rated,
            rated_frequency=self.f_rated, pole_pairs=self.pole_pairs, rated_current=self.I_rated,
            power_factor=self.cos_phi, efficiency=self.eta, breakdown_ratio=self.Tb_ratio,
            J_rotor=self.J_rotor, start=self.choice("start_mode", STARTS), ramp_time=self.ramp_time,
            u_start=self.u_start, f_start=self.f_start, stator_copper_share=self.Rs_share)
        self._drive = CrankDrive(motor=motor, i=self.i, J_crank=self.J_crank, m_platform=self.m_platform,
                                 l=self.l, model=self.choice("model", MODELS))
        self.choice("M_input", M_INPUTS)
        w_scale = motor.synchronous_speed / self._drive.i
        flux = motor.phase_voltage_peak / (2.0 * math.pi * motor.rated_frequency)
        self._scale = [1.0, w_scale] + ([flux] * 4 if self._drive.model == "dq" else []) \
            + [max(1.0, 0.5 * self._drive.J_total * w_scale ** 2)]
        if not all(math.isfinite(v) for v in self._scale):
            raise ParameterError(f"the drive's scales are not finite ({self._scale!r}): check P_rated, "
                                 f"n_rated, U_rated, f_rated, i, J_crank, m_platform, l")
        self._integrator = Integrator("DOP853", tol=self.tolerance, scale=self._scale,
                                      max_steps=MAX_INTERNAL_STEPS)

    def start(self):
        if not math.isfinite(self.M_reaction):
            raise ParameterError(f"input M_reaction must be finite, got {self.M_reaction!r} N.m")
        y0 = self._drive.initial_state()
        self._z = np.concatenate([y0, [0.0]])
        self._h = None
        self._samples = [(self._time, float(self.M_reaction))]
        self._publish(self._time, self._z, self._load(self._samples))

    # -- the load over a step ------------------------------------------------
    def _load(self, samples):
        """M_reaction(t) over the coming step from the communication-point samples."""
        tk, mk = samples[-1]
        if self.M_input == 2 and len(samples) > 1 and samples[-1][0] > samples[-2][0]:
            tp, mp = samples[-2]
            slope = (mk - mp) / (tk - tp)
            return lambda t: mk + slope * (t - tk)
        return lambda t: mk

    def _rhs(self, load):
        drive = self._drive
        motor, i, J = drive.motor, drive.i, drive.J_total
        if drive.model == "kloss":
            torque = motor.torque

            def f(t, z):
                w_m = i * z[1]
                T = torque(w_m, t)
                return (z[1], (i * T + load(t)) / J, T * w_m)
        else:
            dq_rhs, dq_torque = motor.dq_rhs, motor.dq_torque

            def f(t, z):
                w_m = i * z[1]
                x = z[2:6]
                T = dq_torque(x)
                return (z[1], (i * T + load(t)) / J) + tuple(dq_rhs(t, x, w_m)) + (T * w_m,)
        return f

    def step(self, t, t_end):
        m_r = self.M_reaction
        if not math.isfinite(m_r):
            return self.discard(f"{self.who}: input M_reaction must be finite, got {m_r!r} N.m at "
                                f"t = {t:.9g} s; step refused, last good state kept")
        # the slope of M_reaction from the last sample at least half a step back (a very short
        # previous step would otherwise amplify the input's noise into the slope)
        older = [s for s in self._samples if s[0] <= t - 0.5 * (t_end - t)] or \
            [s for s in self._samples if s[0] < t]
        samples = older[-1:] + [(t, float(m_r))]
        load = self._load(samples)
        keep = [s for s in self._samples if s[0] < t][-3:] + [(t, float(m_r))]
        try:
            z, h, _ = self._integrator.advance(self._rhs(load), t, self._z, t_end, self._h)
            outputs = self._outputs(t_end, z, load)
        except ArithmeticError as e:
            return self.discard(f"{self.who}: step from t = {t:.9g} s refused, last good state kept: {e}")
        self._z, self._h, self._samples = z, h, keep
        self._set(outputs)
        return True

    # -- outputs -------------------------------------------------------------
    def _outputs(self, t, z, load):
        """The outputs of state z at time t, as (name, value) pairs (ArithmeticError naming
        an output that would not be finite)."""
        drive = self._drive
        y = z[:drive.n_states]
        m_r = load(t)
        w_m = drive.i * y[1]
        if drive.model == "kloss":
            T, I, P = drive.motor.torque(w_m, t), 0.0, 0.0
        else:
            T, I, P = drive.motor.dq_outputs(t, y[2:6])
        psi_ddot = (drive.i * T + m_r) / drive.J_total
        values = (y[0], y[1], psi_ddot) + platform_state(drive.l, y[0], y[1], psi_ddot)
        out = [(name, float(v)) for (name, _, _), v in zip(KINEMATICS, values)]
        ws = drive.motor.synchronous_speed_at(t)
        out += [("w_motor", float(w_m)), ("n_motor", float(w_m / RPM)),
                ("slip", float((ws - w_m) / ws) if ws > 0.0 else 0.0),
                ("T_motor", float(T)), ("I_motor", float(I)), ("P_el", float(P)),
                ("P_motor", float(T * w_m)), ("W_motor", float(z[-1])),
                ("E_drive", float(drive.kinetic_energy(y)))]
        return [(name, self.finite(name, v)) for name, v in out]

    def _set(self, outputs):
        for name, v in outputs:
            setattr(self, name, v)

    def _publish(self, t, z, load):
        self._set(self._outputs(t, z, load))

    # -- state save/restore ------------------------------------------------
    def internal_state(self):
        return {"z": [float(v) for v in self._z], "h": self._h, "samples": [list(s) for s in self._samples]}

    def restore_internal_state(self, s):
        z = s["z"]
        n = self._drive.n_states + 1
        if not (isinstance(z, list) and len(z) == n and all(isinstance(v, (int, float)) and math.isfinite(v)
                                                              for v in z)):
            raise ValueError(f"drive state {z!r}: expected {n} finite numbers for model "
                             f"{self._drive.model!r}")
        h = s["h"]
        if h is not None and not (isinstance(h, (int, float)) and h > 0 and math.isfinite(h)):
            raise ValueError(f"internal step h = {h!r}: expected a positive finite number or null")
        samples = [tuple(float(v) for v in smp) for smp in s["samples"]]
        if not samples or any(len(smp) != 2 or not all(map(math.isfinite, smp)) for smp in samples):
            raise ValueError(f"M_reaction samples {s['samples']!r}: expected (t, M) pairs of finite numbers")
        self._z, self._h, self._samples = np.array(z, dtype=float), h, samples
