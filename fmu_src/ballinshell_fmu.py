"""BallInShell FMU: the ball rolling without slip in a spherical chamber that translates
(motion = 1) or moves in 3-D and turns (motion = 2: inputs z1O..az1O, Omega, Omega_dot, Q;
the general model of ballmill.physics.turning along turning/reconstruction.py's fit of the
chamber's motion; outputs also in the chamber's axes and the moment about O1).

With contact_model = 2 the ball also slides, flies and strikes the shell (docs/design.md
section 14): every step resumes the library's hybrid ball (hybrid.HybridBall.resume, on
events.integrate) from its state at the step's start along the step's fit of the inputs
(InputReconstruction.motion, ChamberReconstruction.motion), events located inside the step.

A thin pythonfmu adapter over ballmill.physics (docs/design.md sections 3 and 5).
Inputs: the platform position x1O, y1O (and, when the source knows them, its
velocity and acceleration). Outputs: contact point, normal force, the ball's
force on the chamber, the reaction torque on the crank shaft, the moment
about the chamber centre, the ball's centre and angular velocity, and the
validity of the model (contact, rolling). Losses to the ground material
(rolling resistance ``delta``, viscous drag ``c_drag``; 0 by default) are
parameters, and ``P_diss`` reports the power they take; ``bed = 1`` puts the material in a
bed of depth ``h_bed`` (blend band ``w_bed``) instead of everywhere, ``P_grind`` is the
grinding power and ``s_bed`` the resistance's share at the contact point.

The integration between communication points (BallModel.advance along the
reconstructed input's cubic) runs in the compiled kernel bundled with the FMU
(ballmill/physics/_kernel.c) when it loads on this platform, and in Python
otherwise (or with BALLMILL_NO_KERNEL=1), with the same results bit for bit.

Each do_step computes into a scratch state and keeps it only on success:
a refused step (non-finite input, the paper formulation at the equator, an
integrator failure, more than MAX_INTERNAL_STEPS internal steps) returns
fmi2Discard with the reason in the log and leaves the last good state in
place. The call semantics (step-size policy, fixed parameters, FMU state,
the validity latch ``valid``/``t_invalid``) are ballmill.fmi.slave's and
docs/conformance.md's.
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
import operator

import numpy as np

from ballmill.fmi.interface import (BALL_ALL_INPUTS, BALL_FEEDTHROUGH, BALL_IN_SHELL, BALL_INPUTS,
                                    BALL_MOTION_INPUTS, BALL_MOTION_START, BALL_OUTPUTS, DRAG_LIMIT,
                                    MAX_INTERNAL_STEPS)
from ballmill.fmi.slave import NEVER, Slave
from ballmill.physics import Ball, BallModel, BallState, InputReconstruction
from ballmill.physics.events import BURST, MAX_RATE, zeno_words
from ballmill.physics.hybrid import FLIGHT, ROLLING, SLIDING, Contact, HybridBall
from ballmill.physics.platform import GAIN_POSITIONS, ulp
from ballmill.physics.turning.model import ChamberModel, evaluate_c
from ballmill.physics.turning.reconstruction import ChamberReconstruction, centre

FORMULATIONS = {1: "vector", 2: "paper"}
METHODS = {1: "DOP853", 2: "RK45", 3: "RK4"}
INPUT_MODES = {1: "derivatives", 2: "positions", 3: "hold", 4: "accelerations"}
OUTPUTS = BALL_OUTPUTS
INPUTS = BALL_INPUTS
MOTIONS = {1: "translation", 2: "general"}
CONTACT_MODELS = {1: "rolling", 2: "hybrid"}
# contact_model = 2: the driver's Zeno guard (events.integrate's defaults, events.BURST and MAX_RATE;
# fmu_src/ballinshell.c's HYB_BURST, HYB_MAX_RATE): more than HYB_BURST events within HYB_BURST /
# HYB_MAX_RATE s hold the ball on the wall
HYB_BURST, HYB_MAX_RATE = BURST, MAX_RATE
_T_HELD, _HELD_WINDOW = HybridBall.BOOK.index("t_held"), HybridBall.BOOK.index("held_window")  # NaN: not held
GENERAL_MODES = {1: "derivatives", 3: "hold"}  # input modes of motion = 2
_UNITS = {v.name: v.unit for v in BALL_IN_SHELL.variables}
_MOTION_VALUES = operator.attrgetter(*BALL_MOTION_INPUTS)
_MOTION_DEFAULTS = tuple(BALL_MOTION_START[name] for name in BALL_MOTION_INPUTS)
FEEDTHROUGH = frozenset(BALL_FEEDTHROUGH)


class BallInShell(Slave):
    """A heavy ball rolling without slip inside a spherical chamber that translates
    horizontally (shockless ball mill; ball vibration absorber)."""

    description = BALL_IN_SHELL.description
    NAMES = {"rolling_resistance": "delta", "drag": "c_drag", "bed_depth": "h_bed", "bed_band": "w_bed"}
    BEDS = {0: "everywhere", 1: "bed"}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.declare(BALL_IN_SHELL)
        self._model = None
        self._max_step = math.inf
        self._state = None
        self._inputs = None
        self._history = []
        self._fed = None  # the inputs of the last feedthrough refresh since the last step

    # -- life cycle --------------------------------------------------------
    def build(self):
        ball = Ball(r=self.r, R=self.R, m=self.m, g=self.g, mu=self.mu,
                    rolling_resistance=self.delta, drag=self.c_drag, bed_band=self.w_bed)
        if self.choice("bed", self.BEDS) == "bed":
            if not 0.0 <= self.h_bed <= 2.0 * self.R:
                raise ValueError(f"parameter h_bed = {self.h_bed!r} m is outside its accepted range [0, 2 R = "
                                 f"{2.0 * self.R:g}] m with bed = 1 (the bed's surface lies between the chamber's "
                                 f"lowest and highest points)")
            ball = ball.with_(bed_depth=self.h_bed)
        if self.delta > ball.r:
            raise ValueError(f"parameter delta = {self.delta!r} m is outside its accepted range "
                             f"[0, r = {ball.r:g}] m (a rolling-resistance length beyond the ball's radius)")
        c_max = DRAG_LIMIT * ball.m * ball.omega_small
        if self.c_drag > c_max:
            raise ValueError(f"parameter c_drag = {self.c_drag!r} N.s/m is outside its accepted range "
                             f"[0, {c_max:.6g}] N.s/m (1e4 m omega0: a viscous time constant m/c_drag below "
                             f"1e-4/omega0 makes the equations too stiff for the explicit integrators)")
        self._check_contact()
        self._max_step = self.max_step or 0.05 * 2.0 * math.pi / ball.omega_small
        method = self.choice("integrator", METHODS)
        if method == "RK4" and self._max_step / self.h_fixed > MAX_INTERNAL_STEPS:
            raise ValueError(f"parameter h_fixed = {self.h_fixed!r} s is outside its accepted range "
                             f"[{self._max_step / MAX_INTERNAL_STEPS:.6g}, inf) s (max_step / "
                             f"{MAX_INTERNAL_STEPS} internal steps, max_step = {self._max_step:.6g} s)")
        self._general = self.choice("motion", MOTIONS) == "general"
        self._hybrid = self.choice("contact_model", CONTACT_MODELS) == "hybrid"
        self._system = None
        if self._general:
            self._build_general(ball, method)
            return
        self._model = BallModel(ball, formulation=self.choice("formulation", FORMULATIONS),
                                method=method, tol=self.tolerance, h_fixed=self.h_fixed,
                                max_steps=MAX_INTERNAL_STEPS)
        mode = self.choice("input_mode", INPUT_MODES)
        self._inputs = InputReconstruction(mode, a_tol=self.input_tol)
        self._correct = bool(self.corrector) and mode != "hold"

    def _new_system(self):
        """contact_model = 2: the hybrid ball (hybrid.HybridBall) over the current fit of the inputs
        (its motion is replaced at every step: HybridBall.resume), rolling without the work
        quadrature (energy = False: the rolling model's own floats), the FMU's integrator with the
        library's bound on internal steps (Integrator's 1e6, fmu_src/ballinshell.c's HYB_MAX_STEPS,
        not MAX_INTERNAL_STEPS: a slide that starts from zero slip may take more than that within
        one step, and the flavours must fail alike)."""
        ball = self._model.ball
        contact = Contact(mu_k=None if self.mu_k == -1.0 else self.mu_k, e_n=self.e_n, v_rest=self.v_rest,
                          creep_eps=self.creep_eps)
        self._system = HybridBall(ball, self._inputs.motion(), contact, METHODS[self.integrator], self.tolerance,
                                  None, False, self.h_fixed, t_ref=self._time)

    def _check_contact(self):
        """The hybrid contact's parameters (interface._BALL_RULES; fmu_src/ballinshell.c's
        check_contact, the same messages)."""
        if not (self.mu_k == -1.0 or 0.0 <= self.mu_k <= self.mu):
            raise ValueError(f"parameter mu_k = {self.mu_k!r} is outside its accepted range: -1 (equal to mu) "
                             f"or [0, mu = {self.mu!r}] (kinetic friction does not exceed static friction)")
        if not self.v_rest > 0.0:
            raise ValueError(f"v_rest must be positive and finite, got v_rest = {self.v_rest!r} m/s")
        if self.contact_model != 2:
            return
        if self.formulation != 1:
            raise ValueError(f"contact_model = 2 needs formulation = 1 (the paper's coordinates end at the "
                             f"chamber's equator; a sliding or flying ball is followed in fixed axes), got "
                             f"formulation = {self.formulation!r}")
        if self.delta != 0.0 or self.c_drag != 0.0:
            raise ValueError(f"contact_model = 2 models no ground-material losses off rolling: delta = "
                             f"{self.delta!r} m and c_drag = {self.c_drag!r} N.s/m must be 0")
        if self.bed != 0:
            raise ValueError(f"contact_model = 2 has no material bed: bed = {self.bed!r} must be 0 (the hybrid "
                             f"ball models no ground-material losses)")

    def _build_general(self, ball, method):
        """motion = 2: the general model (ballmill.physics.turning) and the chamber's
        reconstruction; vector formulation, no losses, input modes 1 and 3."""
        if self.formulation != 1:
            raise ValueError(f"motion = 2 needs formulation = 1 (vector; the paper's coordinates describe "
                             f"only a translating chamber's lower hemisphere), got formulation = "
                             f"{self.formulation!r}")
        if self.delta != 0.0 or self.c_drag != 0.0:
            raise ValueError(f"motion = 2 is lossless: delta = {self.delta!r} m and c_drag = {self.c_drag!r} "
                             f"N.s/m must be 0 (the ground material's losses exist only with motion = 1)")
        if self.bed != 0:
            raise ValueError(f"motion = 2 has no material bed: bed = {self.bed!r} must be 0 (the turning "
                             f"chamber's model is lossless)")
        if self.input_mode not in GENERAL_MODES:
            raise ValueError(f"input_mode = {self.input_mode!r} is not available with motion = 2: use "
                             f"1 (derivatives) or 3 (hold)")
        self._model = ChamberModel(ball, method=method, tol=self.tolerance, h_fixed=self.h_fixed,
                                   max_steps=MAX_INTERNAL_STEPS)
        self._inputs = ChamberReconstruction(GENERAL_MODES[self.input_mode], R=ball.R, a_tol=self.input_tol)
        self._correct = bool(self.corrector) and self.input_mode != 3

    def start(self):
        if self._general:
            # the checks (and messages) of the translation-only model's initial state
            BallModel(self._model.ball).initial(self.xC0, self.yC0, (self.wx0, self.wy0, self.wz0))
            problem = self._inputs.push(*self._sample(self._time))
            self._state = self._model.initial(self._inputs, self.xC0, self.yC0,
                                              (self.wx0, self.wy0, self.wz0), t0=self._time)
        else:
            self._state = self._model.initial(self.xC0, self.yC0, (self.wx0, self.wy0, self.wz0),
                                              t0=self._time)
            problem = self._inputs.push(*self._sample(self._time))
        if self._hybrid:  # the rolling model's start, where the wall decides (hybrid.HybridBall.begin)
            self._new_system()
            _, mode, y = self._system.begin(self._time, self._state)
            self._state = _HState(self._time, mode, y, self._state.h, self._system.bookkeeping())
        # corrected states at the times of the samples in the reconstruction window
        self._history = [self._state]
        self._fed = None
        self._coupling_warned, self.coupling_error = False, 0.0
        self._ignored_warned = False
        self.valid, self.t_invalid = True, NEVER
        self._confirmed = (True, True)
        self._t_prev = None
        self._noise_sum, self._a_mid = 0.0, None
        out = self._outputs_at(self._state, self._time)
        self.mode, self.slip_speed, self.gap, self.n_impacts, self.v_impact_max = 1, 0.0, 0.0, 0, 0.0
        self.E_friction, self.E_impact, self.t_first_slip, self.t_first_flight = 0.0, 0.0, NEVER, NEVER
        try:
            self._publish(out)
            for name, v in self._motion_values(self._state, self._time, None, self.M_reaction):
                setattr(self, name, v)
        except ArithmeticError as e:
            raise ValueError(f"the initial state (xC0 = {self.xC0!r} m, yC0 = {self.yC0!r} m, wx0 = "
                             f"{self.wx0!r}, wy0 = {self.wy0!r}, wz0 = {self.wz0!r} rad/s) gives non-finite "
                             f"outputs: {e}") from None
        if problem:  # cannot happen with one sample
            raise ValueError(problem)

    def exit_initialization_mode(self):
        super().exit_initialization_mode()
        out = self._outputs_at(self._state, self._time)
        self._note_ignored(self._time)
        self._report(self._time, None, out, (True, True))  # once, at the exit of initialisation mode

    def step_limit(self):
        return self._max_step

    def _sample(self, t):
        names = BALL_ALL_INPUTS if self._general else INPUTS
        return (t,) + tuple(getattr(self, name) for name in names)

    def _note_ignored(self, t):
        """motion = 1 takes a horizontal translation: the inputs of motion = 2 are ignored,
        whatever a master sets them to (FMI lets it set any input, and some masters set every
        one). The first one seen away from its default is named once, in case a chamber was
        meant to turn."""
        if self._general or self._ignored_warned or _MOTION_VALUES(self) == _MOTION_DEFAULTS:
            return
        for name in BALL_MOTION_INPUTS:
            v = getattr(self, name)
            if v != BALL_MOTION_START[name]:
                unit = _UNITS[name]
                unit = f" {unit}" if unit and unit != "1" else ""
                self._ignored_warned = True
                self.warn(f"{self.who}: at t = {t:.9g} s input {name} = {v!r}{unit} (default "
                          f"{BALL_MOTION_START[name]!r}) is ignored: motion = 1 (horizontal translation) uses "
                          f"x1O..ay1O only, not z1O..az1O, Omega, Omega_dot or Q; set motion = 2 for a chamber "
                          f"that moves vertically or turns (said once)")
                return

    def step(self, t, t_end):
        try:
            self._inputs.set_horizon(t_end - t)
            problem = self._inputs.push(*self._sample(t))
            accel = self._inputs.accel_function()
            if self._hybrid:
                accel = _Fit(self._inputs.motion())
                self._system.set_motion(accel.motion, t)
            history = self._corrected_history(t, accel)
            state = history[-1]
            confirmed = self._outputs_at(state, t)
            predicted = self._advance(state, t_end, accel)
            out = self._outputs_at(predicted, t_end)
            values = self._values(out)
            h = t_end - t
            m_mean = self._torque_mean(state, predicted, h) if self._hybrid else dict(values)["M_reaction"]
            values += self._motion_values(predicted, t_end, h, m_mean)
        except (ValueError, ArithmeticError) as e:
            # a valid sample recorded before the failure is harmless: a retry at the
            # same time replaces it
            return self.discard(f"{self.who}: step from t = {t:.9g} s refused, last good state kept: "
                                f"{self.rename(str(e))}")
        coupling_error = self.coupling_error
        noise_sum = self._noise_sum
        if self._correct and history[-1] is not self._state:
            # a-posteriori estimate of the step's error: predicted vs corrected state at t_k
            (px, py, pz), (qx, qy, qz) = self._n_pair(self._state, history[-1])
            step_error = self.R * math.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)
            # what the corrector cannot repair: the fit itself moves when a new sample arrives
            # (input noise). Each step's change of the fitted acceleration, da (the previous and
            # this fit mid-way through the previous interval), kicks the ball's swing by
            # (5/7) da H / (R - r); uncorrelated
            # kicks add in quadrature and the swing's amplitude is the kick / omega0, so the
            # contact point's accumulated error is R (5/7) sqrt(sum (da H)^2) / ((R - r) omega0)
            # (modes 2 and 4, the measured-motion paths; in mode 1 a noisy input is flagged by the
            # consistency check instead). Only once the fits' degree is settled.
            measured = self._inputs.mode in ("positions", "accelerations")
            nodes = self._inputs.nodes()
            full = len(nodes) == self._inputs.points
            if measured and full and self._a_mid is not None and self._t_prev is not None:
                tm, ox, oy = self._a_mid
                nx, ny = accel(tm)
                noise_sum += ((ox - nx) ** 2 + (oy - ny) ** 2) * (t - self._t_prev) ** 2
            ball = self._model.ball
            drift = self.R * (5.0 / 7.0) * math.sqrt(noise_sum) / (ball.d * ball.omega_small)
            # positions only: their round-off, ulp(X) for positions of magnitude X, is up to
            # GAIN_POSITIONS ulp(X) / hs^2 in the fitted acceleration (hs >= h/2, the node
            # spacing), which over the step h moves the ball's centre by (5/7) a h^2 / 2
            # relative to the chamber: at most (R/d) (5/7) 2 GAIN_POSITIONS ulp(X) at the
            # contact point (a 1e6 m offset: 3.4e-8 m)
            resolution = 0.0
            if self._inputs.mode == "positions":
                X = max(max(abs(smp[1]), abs(smp[2])) for smp in nodes)
                resolution = self.R / ball.d * (5.0 / 7.0) * 2.0 * GAIN_POSITIONS * ulp(X)
            coupling_error = math.sqrt(step_error * step_error + drift * drift + resolution * resolution)
        self._noise_sum = noise_sum
        if self._t_prev is not None and not self._general:  # this fit's a mid-way through the interval
            tm = 0.5 * (self._t_prev + t)
            self._a_mid = (tm,) + tuple(self._inputs.accel_function()(tm))
        self._history = history
        self._state = predicted
        self._fed = None
        self._set_outputs(values, out)
        self.coupling_error = coupling_error
        if self.coupling_error > self.coupling_warn and not self._coupling_warned:
            self._coupling_warned = True
            self.warn(f"{self.who}: at t = {t:.9g} s the contact point predicted over the last step was "
                      f"off by {self.coupling_error:.3g} m (> coupling_warn = {self.coupling_warn:g} m): the "
                      f"communication step is too long for how fast the platform motion changes; outputs "
                      f"between communication points carry errors of that size (warned once)")
        self._note_ignored(t)
        if problem:
            if not self._inconsistency_warned:
                self._inconsistency_warned = True
                self.warn(f"{self.who}: at t = {t:.9g} s {problem}; flagged: valid = false (warned once)")
            self.invalidate(t, problem)
        dropped = self._inputs.dropped
        if dropped and not self._resolution_warned:
            self._resolution_warned = True
            X, w = dropped
            self.warn(f"{self.who}: at t = {t:.9g} s the positions (|x1O|, |y1O| up to {X:.6g} m, resolution "
                      f"{X * 2.0 ** -52:.3g} m) over a window of {w:.3g} s would give acceleration errors "
                      f"above 1e-6 m/s2: the reconstruction uses the velocity and acceleration inputs "
                      f"there (warned once)")
        self._report(t, self._t_prev, confirmed, self._confirmed)
        if self._hybrid:  # slip, flight and impacts are the model's: valid stays true, unless the ball is held
            if not math.isnan(predicted.book[_T_HELD]):
                self.invalidate(predicted.book[_T_HELD], self._held_reason(predicted))
        elif not out.contact:
            self.invalidate(t_end, f"contact lost (N = {out.N:.6g} N) at the end of the step")
        elif not out.rolling:
            self.invalidate(t_end, f"slip: |F_t|/N = {out.friction_ratio:.4g} > mu = {self.mu:g} at the end "
                                   f"of the step")
        self._t_prev = t
        return True

    @staticmethod
    def _held_reason(state):
        """contact_model = 2: why valid latched when the ball is held on the wall from a Zeno stop
        (HybridBall.hold: its time and the burst's span in the bookkeeping)."""
        return (zeno_words(HYB_BURST, state.book[_HELD_WINDOW], state.book[_T_HELD], HYB_MAX_RATE)
                + ": the ball is held on the wall from there, rolling only (as contact_model = 1 after its latch; "
                "a larger v_rest ends a bounce sequence sooner)")

    _t_prev = None
    _general = False
    _coupling_warned = False
    _resolution_warned = False
    _inconsistency_warned = False
    _ignored_warned = False
    _noise_sum = 0.0
    _a_mid = None
    _fields = None

    def _corrected_history(self, t_now, accel):
        """Corrector: integrate the current fit from the corrected state at the oldest
        node of the reconstruction window up to t_now, through every sample time in
        it. Over the window the fit interpolates, so each step is redone until its
        samples leave the window (at the start this also repairs the first steps,
        taken when few samples existed). Without the corrector, or if the window's
        oldest state is unknown, the predicted state at t_now is used as it is."""
        times = self._inputs.window()
        by_time = {st.t: st for st in self._history}
        # the states at the history's sample times stay (older nodes of later windows)
        keep = {smp[0] for smp in self._inputs.samples}
        uncorrected = [st for st in self._history if st.t in keep and st.t < self._state.t] + [self._state]
        if not self._correct or len(times) < 2 or times[0] not in by_time:
            return uncorrected
        if self._hybrid and not math.isnan(self._state.book[_T_HELD]) and math.isnan(by_time[times[0]].book[_T_HELD]):
            return uncorrected  # a state held on the wall (HybridBall.hold) is not redone from one before the hold
        out = [by_time[times[0]]]
        for t in times[1:]:
            out.append(self._advance(out[-1], t, accel))
        if abs(out[-1].t - t_now) > 1e-9 * max(1.0, abs(t_now)):  # the window ends at t_now
            return uncorrected
        return [st for st in self._history if st.t in keep and st.t < times[0]] + out

    _confirmed = (True, True)

    # -- outputs -------------------------------------------------------------
    def _advance(self, state, t_end, accel):
        if self._hybrid:  # accel: the step's _Fit
            run = self._system.resume(state.mode, state.t, state.y, state.h, state.book, t_end, accel.motion,
                                      burst=HYB_BURST, max_rate=HYB_MAX_RATE, on_zeno="hold")
            if not run.success:
                raise ValueError(f"the hybrid ball could not be followed from t = {state.t:.9g} s in mode "
                                 f"{_MODE_NAMES[state.mode]}: {run.message}")
            return _HState(float(t_end), run.mode, run.y, run.h, self._system.bookkeeping())
        if self._general:
            return self._model.advance(state, t_end, _Kin(accel))
        return self._model.advance(state, t_end, accel)

    def _n(self, state):
        return tuple(state.y[:3]) if self._general else self._model.nw(state)[0]

    def _n_pair(self, p, q):
        """The contact directions of the predicted and corrected states at t (coupling_error);
        with the hybrid, unless both roll, the ball centres over R - r instead (their
        difference times R is the contact point's)."""
        if not self._hybrid:
            return self._n(p), self._n(q)
        if p.mode == q.mode == ROLLING:
            return self._n(p.rolling()), self._n(q.rolling())
        d = self._model.ball.d
        return tuple(tuple(self._system.free_state(st.mode, st.t, st.y)[:3] / d) for st in (p, q))

    def inputs_set(self):
        """Direct feedthrough (interface.BALL_FEEDTHROUGH): the force, moments and contact
        signals at the FMU's time from the chamber motion just set, on the state published at
        that time (input modes 1, 3 and 4; with positions alone the acceleration is
        reconstructed at the next step), when the inputs they depend on differ from those the
        published outputs were computed from; left as they are if one would not be finite. A
        master that iterates the algebraic loop of a structure feeling the ball reads them
        without stepping."""
        if self._inputs is None or self._inputs.mode == "positions" or self._state is None:
            return
        now = self._sample(self._time)
        state = self._state
        if self._hybrid and state.mode != ROLLING:
            out = self._free_feedthrough(now)
        else:
            state = state.rolling() if self._hybrid else state
            out = self._general_feedthrough(now, state) if self._general else self._translation_feedthrough(now, state)
        if out is None:
            return
        try:
            values = self._values(out)
        except ArithmeticError:
            return
        self._set_outputs([(n, v) for n, v in values if n in FEEDTHROUGH], out)
        self._fed = now  # what the published outputs now come from

    def _published_inputs(self):
        """The sample the published outputs were computed from: that of the last feedthrough
        refresh since the last step, else the one the last step (or the initialisation) took."""
        if self._fed is not None:
            return self._fed
        return self._inputs.samples[-1] if self._inputs.samples else None

    def _free_feedthrough(self, now):
        """contact_model = 2, sliding or in flight: the outputs with the chamber of the sample
        `now` (motion = 1: A = (x1O, y1O, R), v_A, a_A from the inputs; motion = 2:
        reconstruction.centre, Omega, Q); None as the rolling ones' (not usable, or unchanged)."""
        if not all(map(math.isfinite, now)) or (self._general and self._inputs.sample_problem(now) is not None):
            return None
        last = self._published_inputs()
        if last is not None and last[1:] == now[1:]:
            return None
        if self._general:
            A, vA, aA = centre(now, self.R)
            chamber = (A, vA, aA, now[10:13], now[13:16], now[16:25])
        else:
            _, x, y, vx, vy, ax, ay = now
            chamber = ((x, y, self.R), (vx, vy, 0.0), (ax, ay, 0.0), (0.0,) * 3, (0.0,) * 3, _IDENTITY)
        try:
            return self._free_outputs(self._state, self._time, chamber)
        except (ValueError, ArithmeticError):
            return None

    def _translation_feedthrough(self, now, state):
        """motion = 1: the outputs with the chamber acceleration and position of the sample
        `now`; None when one is not finite (the next step refuses it) or none of them differs
        from what the published outputs were computed from (another input was set, or the
        same values again)."""
        _, x, y, _, _, ax, ay = now
        if not all(math.isfinite(v) for v in (x, y, ax, ay)):
            return None
        last = self._published_inputs()
        if last is not None:
            _, sx, sy, _, _, sax, say = last
            if (sx, sy, sax, say) == (x, y, ax, ay):
                return None
        try:
            return _Translated(self._model.outputs(state, ax, ay, x, y), x, y, self.R)
        except (ValueError, ArithmeticError):
            return None

    def _general_feedthrough(self, now, state):
        """motion = 2: the same at the chamber state of the sample `now` (A, v_A, a_A from O,
        Omega, Omega', Q: reconstruction.centre); None when it is not a valid sample (the next
        step refuses it) or equal, all 24 inputs, to what the published outputs were computed
        from."""
        if not all(map(math.isfinite, now)) or self._inputs.sample_problem(now) is not None:
            return None
        last = self._published_inputs()
        if last is not None and last[1:] == now[1:]:
            return None
        A, vA, aA = centre(now, self.R)
        cs = A + vA + aA + now[10:25] + (0.0,) * 14
        try:
            return _general_outputs(self._model, state, cs)
        except (ValueError, ArithmeticError):
            return None

    def _outputs_at(self, state, t):
        """Outputs of a state at time t, with the platform motion reconstructed at t."""
        if self._hybrid:
            if state.mode != ROLLING:
                return self._free_outputs(state, t, self._chamber(self._fit_motion(), t))
            out = self._rolling_outputs_at(state.rolling(), t)
            out.hybrid = self._book_values(state, ROLLING, 0.0, 0.0)
            return out
        return self._rolling_outputs_at(state, t)

    def _fit_motion(self):
        return self._system.motion

    def _chamber(self, motion, t):
        """(A, v_A, a_A, Omega, Omega', Q) of a motion of the hybrid (the step's fit) at t."""
        st = motion.state(t)
        if self._general:
            return st[0:3], st[3:6], st[6:9], st[9:12], st[12:15], st[15:24]
        x, y, vx, vy, ax, ay = st
        return (x, y, self.R), (vx, vy, 0.0), (ax, ay, 0.0), (0.0,) * 3, (0.0,) * 3, _IDENTITY

    def _book_values(self, state, mode, slip, gap):
        """The hybrid's own outputs of a state: its mode, slip speed, gap, and the bookkeeping
        (the first slip and flight: NEVER until they happen)."""
        book = state.book
        ef = book[6] if mode == ROLLING else float(state.y[10])
        return [("mode", mode), ("slip_speed", slip), ("gap", gap), ("n_impacts", int(book[1])),
                ("v_impact_max", book[2]), ("E_friction", ef), ("E_impact", book[0]),
                ("t_first_slip", NEVER if math.isnan(book[3]) else book[3]),
                ("t_first_flight", NEVER if math.isnan(book[4]) else book[4])]

    def _free_outputs(self, state, t, chamber):
        """The outputs of a sliding or flying ball (free state z = (C, v_C, omega, W, E_friction))
        at t with the chamber (A, v_A, a_A, Omega, Omega', Q): N from section 14's formula and
        friction mu_k N against the slip while sliding, no force in flight; the contact point is
        the wall's point nearest the ball, A + R n (in flight not the ball's point C + r n);
        the moments as the rolling outputs' (about A: R n x F; about O1: A x F + M_A)."""
        z = state.y
        zl = z.tolist()
        A, vA, aA, Om, Omd, Q = chamber
        R, d = self.R, self._model.ball.d
        rho = (zl[0] - A[0], zl[1] - A[1], zl[2] - A[2])
        dist = math.sqrt(rho[0] * rho[0] + rho[1] * rho[1] + rho[2] * rho[2])
        n = (rho[0] / dist, rho[1] / dist, rho[2] / dist)
        if state.mode == SLIDING:
            self._system.set_bookkeeping(state.book)  # the sliding direction's seed
            N, Ftv, slip, _, _, _ = self._system._slide_forces(t, zl, chamber=(A, vA, aA, Om, Omd))
            F = (N * n[0] - Ftv[0], N * n[1] - Ftv[1], N * n[2] - Ftv[2])
            Ft = math.sqrt(Ftv[0] * Ftv[0] + Ftv[1] * Ftv[1] + Ftv[2] * Ftv[2])
            gap = 0.0
        else:
            N, F, Ft, slip, gap = 0.0, (0.0, 0.0, 0.0), 0.0, 0.0, max(d - dist, 0.0)
        ratio = Ft / N if N > 0.0 else math.inf
        e = (R * Q[2], R * Q[5], R * Q[8])  # A - O
        O = (A[0] - e[0], A[1] - e[1], A[2] - e[2])
        rn = (R * n[0], R * n[1], R * n[2])
        MA = (rn[1] * F[2] - rn[2] * F[1], rn[2] * F[0] - rn[0] * F[2], rn[0] * F[1] - rn[1] * F[0])
        MO = ((A[1] * F[2] - A[2] * F[1]) + MA[0], (A[2] * F[0] - A[0] * F[2]) + MA[1],
              (A[0] * F[1] - A[1] * F[0]) + MA[2])
        Mr = MO[2] if self._general else O[0] * F[1] - O[1] * F[0]
        Pch = tuple(Q[i] * rn[0] + Q[3 + i] * rn[1] + Q[6 + i] * rn[2] for i in range(3))
        Fch = tuple(Q[i] * F[0] + Q[3 + i] * F[1] + Q[6 + i] * F[2] for i in range(3))
        g = _General()
        g.contact, g.rolling, g.N, g.friction_ratio = N > 0.0, False, N, ratio
        g.values = (
            ("xP", rn[0] + e[0]), ("yP", rn[1] + e[1]), ("zP", rn[2] + e[2]), ("N", N),
            ("Fx", F[0]), ("Fy", F[1]), ("Fz", F[2]), ("M_reaction", Mr),
            ("MAx", MA[0]), ("MAy", MA[1]), ("MAz", MA[2]),
            ("xC", rho[0] + e[0]), ("yC", rho[1] + e[1]), ("zC", rho[2] + e[2]),
            ("wx", zl[6]), ("wy", zl[7]), ("wz", zl[8]), ("Ft", Ft), ("friction_ratio", ratio),
            ("P_diss", 0.0), ("P_grind", 0.0), ("s_bed", 1.0),
            ("xP_ch", Pch[0]), ("yP_ch", Pch[1]), ("zP_ch", Pch[2] + R),
            ("Fx_ch", Fch[0]), ("Fy_ch", Fch[1]), ("Fz_ch", Fch[2]),
            ("MO1x", MO[0]), ("MO1y", MO[1]), ("MO1z", MO[2]))
        g.hybrid = self._book_values(state, state.mode, slip, gap)
        return g

    def _rolling_outputs_at(self, state, t):
        """Outputs of a rolling state at time t, with the platform motion reconstructed at t."""
        if self._general:
            return _general_outputs(self._model, state, self._inputs.state(t))
        x, y, _, _, ax, ay = self._inputs.state(t)
        out = self._model.outputs(state, ax, ay, x, y)
        return _Translated(out, x, y, self.R)

    def _centre_velocity(self, state, t):
        """v_C [m/s] of a rolling state at t, fixed axes: v_A + R (Omega x n) + r (n x omega), with
        v_A and Omega the reconstruction's at t (motion = 1: (vx1O, vy1O, 0), Omega = 0), n and
        omega the state's; in this operation order (fmu_src/ballinshell.c's centre_velocity)."""
        if self._hybrid:
            if state.mode != ROLLING:
                return tuple(state.y[3:6].tolist())
            state = state.rolling()
        if self._general:
            y = state.y.tolist()
            n, w = y[0:3], y[3:6]
            cs = self._inputs.state(t)
            vA, Om = cs[3:6], cs[9:12]
        else:
            n, w = self._model.nw(state)
            _, _, vx, vy, _, _ = self._inputs.state(t)
            vA, Om = (vx, vy, 0.0), (0.0, 0.0, 0.0)
        R, r = self.R, self.r
        c1 = (Om[1] * n[2] - Om[2] * n[1], Om[2] * n[0] - Om[0] * n[2], Om[0] * n[1] - Om[1] * n[0])
        c2 = (n[1] * w[2] - n[2] * w[1], n[2] * w[0] - n[0] * w[2], n[0] * w[1] - n[1] * w[0])
        return tuple((vA[i] + R * c1[i]) + r * c2[i] for i in range(3))

    def _torque_mean(self, s0, s1, h):
        """contact_model = 2: M_reaction_mean over the step of length h from the hybrid state s0 to
        s1 along the step's fit (the system's motion): ((Lq1 - Lq0) - (K1 - K0)) / h, K the
        angular momentum the torque drains and Lq its quadrature (HybridBall.reaction_momentum;
        fmu_src/ballinshell.c's torque_mean, in this operation order)."""
        sys_ = self._system
        z0, z1 = sys_.free_state(s0.mode, s0.t, s0.y), sys_.free_state(s1.mode, s1.t, s1.y)
        K0, K1 = sys_.reaction_momentum(s0.t, z0), sys_.reaction_momentum(s1.t, z1)
        return float(((z1[-1] - z0[-1]) - (K1 - K0)) / h)

    def _motion_values(self, state, t, h, m_mean):
        """vxC..vzC at t and the force averaged over the step of length h that ends there,
        m (g_vec - (v_C(t) - v_C(t - h)) / h) with v_C(t - h) the published one (h None: the
        start, where the mean is the instantaneous force Fx..Fz just published);
        M_reaction_mean = m_mean (`_torque_mean`; at the start and with contact_model = 1
        M_reaction itself)."""
        vc = self._centre_velocity(state, t)
        finite = self.finite
        values = [(name, finite(name, v)) for name, v in zip(("vxC", "vyC", "vzC"), vc)]
        if h is None:
            mean = (self.Fx, self.Fy, self.Fz)
        else:
            m, gv, v0 = self.m, (0.0, 0.0, -self.g), (self.vxC, self.vyC, self.vzC)
            mean = tuple(m * (gv[i] - (vc[i] - v0[i]) / h) for i in range(3))
        values += [(name, finite(name, v)) for name, v in zip(("Fx_mean", "Fy_mean", "Fz_mean"), mean)]
        values.append(("M_reaction_mean", finite("M_reaction_mean", m_mean)))
        return values

    def _values(self, out):
        """The output values to publish (ArithmeticError naming an output that is not finite;
        friction_ratio is +inf when N <= 0, published as 1e300)."""
        hybrid = [(name, v if type(v) is int else self.finite(name, v)) for name, v in getattr(out, "hybrid", ())]
        if type(out) is _General:
            finite = self.finite
            return [(name, finite(name, v, allow_infinite=(name == "friction_ratio")))
                    for name, v in out.values] + hybrid
        extra = out.extra
        out = out.out
        fields = out._fields
        if fields is not self._fields:  # the index of each output in an Outputs tuple, once
            self._fields, self._index = fields, [(name, fields.index(name)) for name, _, _ in OUTPUTS]
        finite = self.finite
        values = [(name, finite(name, out[i], allow_infinite=(name == "friction_ratio")))
                  for name, i in self._index]
        values.append(("P_diss", finite("P_diss", out.P_diss)))
        values.append(("P_grind", finite("P_grind", out.P_grind)))
        values.append(("s_bed", finite("s_bed", out.s_bed)))
        values.extend((name, finite(name, v)) for name, v in extra)
        return values + hybrid

    def _set_outputs(self, values, out):
        for name, v in values:
            setattr(self, name, v)
        self.contact, self.rolling = bool(out.contact), bool(out.rolling)

    def _publish(self, out):
        self._set_outputs(self._values(out), out)

    def _report(self, t, t_prev, out, before):
        """Log loss of contact and onset of slip, judged at communication point t
        with the true inputs there (the published flags use extrapolated inputs),
        and latch valid = false."""
        was_contact, was_rolling = before
        self._confirmed = (bool(out.contact), bool(out.rolling))
        if self._hybrid:  # slip, flight and impacts are the model's, not the end of its validity
            return
        when = f"at t = {t:.9g} s" if t_prev is None else f"between t = {t_prev:.9g} s and {t:.9g} s"
        if was_contact and not out.contact:
            self.warn(f"{self.who}: contact lost {when} (N = {out.N:.6g} N): "
                      f"the ball leaves the wall and the rolling model no longer holds")
        elif was_rolling and out.contact and not out.rolling:
            self.warn(f"{self.who}: slip {when}: |F_t|/N = "
                      f"{out.friction_ratio:.4g} > mu = {self.mu:g}; the ball would slide")
        if not out.contact:
            self.invalidate(t, f"contact lost (N = {out.N:.6g} N)")
        elif not out.rolling:
            self.invalidate(t, f"slip: |F_t|/N = {out.friction_ratio:.4g} > mu = {self.mu:g}")

    # -- state save/restore ------------------------------------------------
    def internal_state(self):
        return {"state": self._state.to_dict(), "inputs": self._inputs.get_state(),
                "t_prev": self._t_prev, "confirmed": list(self._confirmed),
                "history": [st.to_dict() for st in self._history], "warned": self._coupling_warned,
                "resolution_warned": self._resolution_warned, "inconsistency_warned": self._inconsistency_warned,
                "ignored_warned": self._ignored_warned,
                "noise_sum": self._noise_sum, "a_mid": None if self._a_mid is None else list(self._a_mid),
                "fed": None if self._fed is None else list(self._fed)}

    def restore_internal_state(self, s):
        ndim = 6 if self._general else self._model.form.ndim
        self._inputs.set_state(s["inputs"])
        if self._hybrid:
            self._new_system()
        state = self._checked_state(s["state"], ndim)
        if abs(state.t - self._time) > 1e-9 * max(1.0, abs(self._time)):
            raise ValueError(f"the ball state is at t = {state.t!r} s but the FMU time is {self._time!r} s")
        history = [self._checked_state(d, ndim) for d in s["history"]]
        confirmed = s["confirmed"]
        if not (isinstance(confirmed, list) and len(confirmed) == 2 and all(isinstance(c, bool) for c in confirmed)):
            raise ValueError(f"confirmed flags {confirmed!r}: expected two Booleans")
        t_prev = s["t_prev"]
        if t_prev is not None and not (isinstance(t_prev, (int, float)) and math.isfinite(t_prev)):
            raise ValueError(f"t_prev = {t_prev!r}: expected a finite time or null")
        self._state, self._history = state, history
        self._t_prev = t_prev
        self._confirmed = tuple(confirmed)
        self._coupling_warned = bool(s["warned"])
        self._resolution_warned = bool(s.get("resolution_warned", False))
        self._inconsistency_warned = bool(s.get("inconsistency_warned", False))
        self._ignored_warned = bool(s.get("ignored_warned", False))
        noise_sum = s.get("noise_sum", 0.0)
        if not (isinstance(noise_sum, (int, float)) and math.isfinite(noise_sum) and noise_sum >= 0.0):
            raise ValueError(f"noise_sum = {noise_sum!r}: expected a finite number >= 0")
        a_mid = s.get("a_mid")
        if a_mid is not None and not (isinstance(a_mid, list) and len(a_mid) == 3
                                      and all(isinstance(v, (int, float)) and math.isfinite(v) for v in a_mid)):
            raise ValueError(f"a_mid = {a_mid!r}: expected null or three finite numbers")
        fed = s.get("fed")
        n_fed = len(self._sample(0.0))
        if fed is not None and not (isinstance(fed, list) and len(fed) == n_fed
                                    and all(isinstance(v, (int, float)) and math.isfinite(v) for v in fed)):
            raise ValueError(f"fed = {fed!r}: expected null or {n_fed} finite numbers (the inputs of the "
                             f"last feedthrough refresh)")
        self._noise_sum = float(noise_sum)
        self._a_mid = None if a_mid is None else tuple(float(v) for v in a_mid)
        self._fed = None if fed is None else tuple(float(v) for v in fed)

    def _checked_state(self, d, ndim):
        """A BallState (contact_model = 2: a hybrid state) from saved data, or ValueError saying
        what does not fit this model."""
        if self._hybrid:
            return self._checked_hybrid(d)
        if "mode" in d or "book" in d:
            raise ValueError(f"a hybrid ball's state (mode, bookkeeping) for contact_model = {self.contact_model}: "
                             f"expected the rolling model's (t, y, h)")
        y = d["y"]
        if not (isinstance(y, list) and len(y) == ndim and all(isinstance(v, (int, float)) for v in y)):
            raise ValueError(f"ball state {y!r}: expected {ndim} numbers for formulation {self.formulation}"
                             f" (motion = {self.motion})")
        state = BallState.from_dict(d)
        if not (math.isfinite(state.t) and np.all(np.isfinite(state.y))) or \
                (state.h is not None and not (isinstance(state.h, (int, float)) and state.h > 0)):
            raise ValueError(f"ball state {d!r} is not finite")
        vector = self._general or self._model.form.name == "vector"
        if vector and abs(math.sqrt(sum(v * v for v in state.y[:3])) - 1.0) > 1e-6:
            raise ValueError(f"ball state {d!r}: n = y[0:3] must be a unit vector")
        if not self._general:
            self._model.form.check(state.y)
        return state


    def _checked_hybrid(self, d):
        """contact_model = 2: an _HState from saved data (mode 0, 1, 2; y of 7 numbers rolling, 12
        otherwise; a unit n while rolling; the bookkeeping HybridBall.set_bookkeeping accepts,
        null for a first slip or flight not yet), or ValueError naming what does not fit."""
        if not isinstance(d, dict) or set(d) != {"t", "mode", "y", "h", "book"}:
            raise ValueError(f"hybrid ball state {d!r}: expected t, mode, y, h and book (contact_model = 2)")
        mode, y, book = d["mode"], d["y"], d["book"]
        if mode not in (FLIGHT, ROLLING, SLIDING) or type(mode) is not int:
            raise ValueError(f"hybrid ball state: mode {mode!r}, expected 0 (flight), 1 (rolling) or 2 (sliding)")
        n = 7 if mode == ROLLING else 12  # the states and the torque's quadrature Lq
        if not (isinstance(y, list) and len(y) == n and all(type(v) in (int, float) and math.isfinite(v) for v in y)):
            raise ValueError(f"hybrid ball state y = {y!r}: expected {n} finite numbers in mode {_MODE_NAMES[mode]}")
        t, h = d["t"], d["h"]
        if not (type(t) in (int, float) and math.isfinite(t)) or \
                (h is not None and not (type(h) in (int, float) and math.isfinite(h) and h > 0)):
            raise ValueError(f"hybrid ball state t = {t!r}, h = {h!r}: expected a finite time and a positive step "
                             f"or null")
        if mode == ROLLING and abs(math.sqrt(sum(v * v for v in y[:3])) - 1.0) > 1e-6:
            raise ValueError(f"hybrid ball state {d!r}: n = y[0:3] must be a unit vector while rolling")
        if not (isinstance(book, list) and all(v is None or type(v) in (int, float) for v in book)):
            raise ValueError(f"hybrid bookkeeping {book!r}: expected a list of numbers")
        book = tuple(math.nan if v is None else float(v) for v in book)
        self._system.set_bookkeeping(book)  # the system's own check
        return _HState(t, mode, y, h, book)


class _Kin:
    """A chamber motion for ChamberModel.advance from the reconstruction's kin(t)."""

    __slots__ = ("accel",)

    def __init__(self, kin):
        self.accel = kin


class _Translated:
    """motion = 1: outputs.Outputs at t and the new outputs derived from them (contact point and
    force in the chamber's axes = the frame's, since the chamber does not turn; the moment about
    O1 = A x F + M_A with A = (x1O, y1O, R), so that MO1z = M_reaction + MAz; with losses M_A
    holds the ground material's moments too)."""

    __slots__ = ("out", "extra", "contact", "rolling", "N", "friction_ratio", "hybrid")

    def __init__(self, out, x, y, R):
        self.out = out
        self.hybrid = ()
        self.contact, self.rolling, self.N, self.friction_ratio = out.contact, out.rolling, out.N, out.friction_ratio
        sx, sy, sz = out.Fx, out.Fy, out.Fz
        self.extra = (("xP_ch", out.xP), ("yP_ch", out.yP), ("zP_ch", out.zP),
                      ("Fx_ch", sx), ("Fy_ch", sy), ("Fz_ch", sz),
                      ("MO1x", (y * sz - R * sy) + out.MAx), ("MO1y", (R * sx - x * sz) + out.MAy),
                      ("MO1z", out.M_reaction + out.MAz))


class _General:
    """motion = 2: the FMU's outputs from turning.model's ChamberOutputs (see the interface)."""

    __slots__ = ("values", "contact", "rolling", "N", "friction_ratio", "hybrid")

    def __init__(self):
        self.hybrid = ()


def _general_outputs(model, state, cs):
    """The FMU's outputs for motion = 2 at the chamber state cs (ChamberState's 38 floats):
    P - O and C - O in fixed axes (O = A - Q (0, 0, R)), N, F, the moment about A and about O1
    (M_reaction = MO1z), the contact point and force in the chamber's axes; the order of
    operations is fmu_src/ballinshell.c's (general_publish)."""
    y = state.y.tolist()
    o = evaluate_c(model._oc, y, cs)
    ball = model.ball
    R, d = ball.R, ball.d
    nx, ny, nz = y[0], y[1], y[2]
    ex, ey, ez = R * cs[17], R * cs[20], R * cs[23]
    sx, sy, sz = o.Fx, o.Fy, o.Fz
    Px, Py, Pz = o.Px, o.Py, o.Pz
    mo = (Py * sz - Pz * sy, Pz * sx - Px * sz, Px * sy - Py * sx)
    g = _General()
    g.contact, g.rolling, g.N, g.friction_ratio = o.contact, o.rolling, o.N, o.friction_ratio
    g.values = (
        ("xP", R * nx + ex), ("yP", R * ny + ey), ("zP", R * nz + ez), ("N", o.N),
        ("Fx", sx), ("Fy", sy), ("Fz", sz), ("M_reaction", mo[2]),
        ("MAx", R * (ny * sz - nz * sy)), ("MAy", R * (nz * sx - nx * sz)), ("MAz", R * (nx * sy - ny * sx)),
        ("xC", d * nx + ex), ("yC", d * ny + ey), ("zC", d * nz + ez),
        ("wx", o.wx), ("wy", o.wy), ("wz", o.wz), ("Ft", o.Ft), ("friction_ratio", o.friction_ratio),
        ("P_diss", 0.0), ("P_grind", 0.0), ("s_bed", 1.0),
        ("xP_ch", o.Pch_x), ("yP_ch", o.Pch_y), ("zP_ch", o.Pch_z),
        ("Fx_ch", o.Fch_x), ("Fy_ch", o.Fch_y), ("Fz_ch", o.Fch_z),
        ("MO1x", mo[0]), ("MO1y", mo[1]), ("MO1z", mo[2]))
    return g


_IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
_MODE_NAMES = {FLIGHT: "flight", ROLLING: "rolling", SLIDING: "sliding"}


class _Fit:
    """contact_model = 2: the step's fit of the inputs as the hybrid ball's chamber motion
    (platform.ReconstructedPlatform, turning.reconstruction.ReconstructedChamber)."""

    __slots__ = ("motion",)

    def __init__(self, motion):
        self.motion = motion


class _HState:
    """contact_model = 2: the hybrid ball's state at t: its mode, the mode's state y (rolling:
    n, omega, Lq; sliding and flight: C, v_C, omega, W, E_friction, Lq), the integrator's next step
    h and the bookkeeping (HybridBall.BOOK's 14 floats)."""

    __slots__ = ("t", "mode", "y", "h", "book")

    def __init__(self, t, mode, y, h, book):
        self.t, self.mode, self.y, self.book = float(t), int(mode), np.array(y, dtype=float), tuple(book)
        self.h = None if h is None else float(h)

    def rolling(self):
        """The rolling model's BallState of a rolling state (n, omega: without Lq)."""
        return BallState(self.t, self.y[:6], self.h)

    def to_dict(self):
        return {"t": self.t, "mode": self.mode, "y": [float(v) for v in self.y], "h": self.h,
                "book": [None if math.isnan(v) else float(v) for v in self.book]}
