"""BallInShell FMU: the ball rolling without slip in a translating spherical chamber.

A thin pythonfmu adapter over ballmill.physics (DESIGN.md sections 3 and 5).
Inputs: the platform position x1O, y1O (and, when the source knows them, its
velocity and acceleration). Outputs: contact point, normal force, the ball's
force on the chamber, the reaction torque on the crank shaft, the moment
about the chamber centre, the ball's centre and angular velocity, and the
validity of the model (contact, rolling). Losses to the ground material
(rolling resistance ``delta``, viscous drag ``c_drag``; 0 by default) are
parameters, and ``P_diss`` reports the power they take.

The integration between communication points (BallModel.advance along the
reconstructed input's cubic) runs in the compiled kernel bundled with the FMU
(ballmill/physics/_kernel.c) when it loads on this platform, and in Python
otherwise (or with BALLMILL_NO_KERNEL=1), with the same results bit for bit.

Each do_step computes into a scratch state and keeps it only on success:
a refused step (non-finite input, the paper formulation at the equator, an
integrator failure) returns fmi2Discard with the reason in the log and
leaves the last good state in place.
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

from ballmill.fmi.interface import BALL_IN_SHELL, BALL_INPUTS, BALL_OUTPUTS, BIG
from ballmill.fmi.slave import Slave
from ballmill.physics import Ball, BallModel, BallState, InputReconstruction, ParameterError

FORMULATIONS = {1: "vector", 2: "paper"}
METHODS = {1: "DOP853", 2: "RK45", 3: "RK4"}
INPUT_MODES = {1: "derivatives", 2: "positions", 3: "hold"}
OUTPUTS = BALL_OUTPUTS
INPUTS = BALL_INPUTS


class BallInShell(Slave):
    """A heavy ball rolling without slip inside a spherical chamber that translates
    horizontally (shockless ball mill; ball vibration absorber)."""

    description = BALL_IN_SHELL.description

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.declare(BALL_IN_SHELL)
        self._model = None
        self._max_step = math.inf
        self._state = None
        self._inputs = None

    # -- life cycle --------------------------------------------------------
    def initialise(self):
        try:
            ball = Ball(r=self.r, R=self.R, m=self.m, g=self.g, mu=self.mu,
                        rolling_resistance=self.delta, drag=self.c_drag)
            self._model = BallModel(ball, formulation=self.choice("formulation", FORMULATIONS),
                                    method=self.choice("integrator", METHODS),
                                    tol=self.tolerance, h_fixed=self.h_fixed)
            self._state = self._model.initial(self.xC0, self.yC0, (self.wx0, self.wy0, self.wz0),
                                              t0=self._start_time)
            if not (self.max_step >= 0.0 and math.isfinite(self.max_step)):
                raise ParameterError(f"max_step must be >= 0 and finite (0 = automatic), "
                                     f"got max_step = {self.max_step!r} s")
            self._max_step = self.max_step or 0.05 * 2.0 * math.pi / ball.omega_small
            mode = self.choice("input_mode", INPUT_MODES)
            self._inputs = InputReconstruction(mode)
            self._inputs.push(*self._sample(self._start_time))
            self._correct = bool(self.corrector) and mode != "hold"
        except (ValueError, ArithmeticError) as e:
            self.error(f"BallInShell '{self.instance_name}': initialisation failed: {e}")
            raise
        # corrected states at the times of the samples in the reconstruction window
        self._history = [self._state]
        self._coupling_warned, self.coupling_error = False, 0.0
        out = self._outputs_at(self._state, self._start_time)
        self._publish(out)
        if not self._initialising:  # report once, at the exit of initialisation mode
            self._report(self._start_time, None, out, (True, True))

    _start_time = 0.0

    def setup_experiment(self, start_time, stop_time, tolerance):
        self._start_time = float(start_time)

    def _sample(self, t):
        return (t,) + tuple(getattr(self, name) for name in INPUTS)

    def do_step(self, current_time, step_size):
        t_end = current_time + step_size
        if step_size > self._max_step * (1.0 + 1e-12):
            return self.discard(
                f"BallInShell '{self.instance_name}': communication step {step_size:g} s refused: it "
                f"exceeds max_step = {self._max_step:.4g} s (1/20 of the ball's natural period unless "
                f"set), over which the platform motion cannot be extrapolated accurately; use a "
                f"smaller step, or set max_step if you accept the error")
        if abs(current_time - self._state.t) > 1e-9 * max(1.0, abs(current_time)):
            return self.discard(f"BallInShell '{self.instance_name}': doStep at t = {current_time:.9g} s "
                                f"but the state is at t = {self._state.t:.9g} s; steps must be contiguous "
                                f"(restore an FMU state to go back)")
        try:
            self._inputs.push(*self._sample(current_time))
            accel = self._inputs.accel_function()
            history = self._corrected_history(current_time, accel)
            state = history[-1]
            confirmed = self._outputs_at(state, current_time)
            predicted = self._model.advance(state, t_end, accel)
            out = self._outputs_at(predicted, t_end)
        except (ValueError, ArithmeticError) as e:
            # a valid sample recorded before the failure is harmless: a retry at the
            # same time replaces it
            return self.discard(f"BallInShell '{self.instance_name}': step from t = {current_time:.9g} s "
                                f"refused, last good state kept: {e}")
        if self._correct and history[-1] is not self._state:
            # a-posteriori estimate of the step's error: predicted vs corrected state at t_k
            (px, py, pz), (qx, qy, qz) = self._model.nw(self._state)[0], self._model.nw(history[-1])[0]
            self.coupling_error = self.R * math.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)
            if self.coupling_error > self.coupling_warn and not self._coupling_warned:
                self._coupling_warned = True
                self.warn(f"BallInShell '{self.instance_name}': at t = {current_time:.9g} s the contact "
                          f"point predicted over the last step was off by {self.coupling_error:.3g} m "
                          f"(> coupling_warn = {self.coupling_warn:g} m): the communication step is too "
                          f"long for how fast the platform motion changes; outputs between "
                          f"communication points carry errors of that size (warned once)")
        self._history = history
        self._state = predicted
        self._publish(out)
        self._report(current_time, self._t_prev, confirmed, self._confirmed)
        self._t_prev = current_time
        return True

    _t_prev = None
    _coupling_warned = False
    _fields = None

    def _corrected_history(self, t_now, accel):
        """Corrector: integrate the current fit from the corrected state at the oldest
        sample of the window up to t_now, through every sample time. Over the window the
        fit interpolates, so each step is redone until its samples leave the window (at
        the start this also repairs the first steps, taken when few samples existed).
        Without the corrector, or if the window's oldest state is unknown, the predicted
        state at t_now is used as it is."""
        times = [smp[0] for smp in self._inputs.samples]
        by_time = {st.t: st for st in self._history}
        if not self._correct or times[0] not in by_time:
            return [self._state]
        out = [by_time[times[0]]]
        for t in times[1:]:
            out.append(self._model.advance(out[-1], t, accel))
        if abs(out[-1].t - t_now) > 1e-9 * max(1.0, abs(t_now)):  # the window ends at t_now
            return [self._state]
        return out
    _confirmed = (True, True)

    # -- outputs -------------------------------------------------------------
    def _outputs_at(self, state, t):
        """Outputs of a state at time t, with the platform motion reconstructed at t."""
        x, y, _, _, ax, ay = self._inputs.state(t)
        return self._model.outputs(state, ax, ay, x, y)

    def _publish(self, out):
        fields = out._fields
        if fields is not self._fields:  # the index of each output in an Outputs tuple, once
            self._fields, self._index = fields, [(name, fields.index(name)) for name, _, _ in OUTPUTS]
        isfinite = math.isfinite
        for name, i in self._index:
            v = out[i]
            setattr(self, name, v if isfinite(v) else BIG)
        self.contact, self.rolling = bool(out.contact), bool(out.rolling)
        self.P_diss = out.P_diss

    def _report(self, t, t_prev, out, before):
        """Log loss of contact and onset of slip, judged at communication point t
        with the true inputs there (the published flags use extrapolated inputs)."""
        was_contact, was_rolling = before
        self._confirmed = (bool(out.contact), bool(out.rolling))
        when = f"at t = {t:.9g} s" if t_prev is None else f"between t = {t_prev:.9g} s and {t:.9g} s"
        if was_contact and not out.contact:
            self.warn(f"BallInShell '{self.instance_name}': contact lost {when} (N = {out.N:.6g} N): "
                      f"the ball leaves the wall and the rolling model no longer holds")
        elif was_rolling and out.contact and not out.rolling:
            self.warn(f"BallInShell '{self.instance_name}': slip {when}: |F_t|/N = "
                      f"{out.friction_ratio:.4g} > mu = {self.mu:g}; the ball would slide")

    # -- state save/restore ------------------------------------------------
    def internal_state(self):
        return {"state": self._state.to_dict(), "inputs": self._inputs.get_state(),
                "start": self._start_time, "t_prev": self._t_prev, "confirmed": list(self._confirmed),
                "history": [st.to_dict() for st in self._history], "warned": self._coupling_warned}

    def restore_internal_state(self, s):
        self._state = BallState.from_dict(s["state"])
        self._inputs.set_state(s["inputs"])
        self._start_time = s["start"]
        self._t_prev = s["t_prev"]
        self._confirmed = tuple(s["confirmed"])
        self._history = [BallState.from_dict(d) for d in s["history"]]
        self._coupling_warned = s["warned"]
