"""How one point of a study is computed: a registry of evaluators by kind of scenario.

An evaluator looks at a scenario and says whether it can compute its points
(`check` -> '' or why not), and `prepare`s a picklable `Prepared` object that
the workers call once per point with the point's parameters. `choose` picks
the cheapest faithful evaluator: they are tried in the order of ORDER.

* "crank-kernel": a drive with a closed form (a MotorStartup instance feeding
  a BallInShell instance its platform motion) runs monolithically in the
  compiled kernel: `ballmill.physics.simulate` with CrankStartup, no FMU, no
  communication step. The study's model settings (RK4, h, dt, target_P) set
  the integration; the error of each point is estimated for the contact point
  and N, and h is halved for the points whose estimate exceeds 0.8 x target_P,
  so every point gets the cheapest step that meets the target. By default
  (model.error = "one-pass") the run estimates its own error in the same kernel
  pass, without a second run or an extra stage: each step's local error is the
  residual of the run's states against a 5th-order quadrature of the derivatives
  the run computes anyway, and its effect on the contact point and on N is
  summed over the steps (fast.study_run, bm_lerr in _kernel.c; within a stated
  factor of the error against a run at h/16: tests/test_sweep_one_pass.py); the
  run ends at the first sample where the model stops holding (N > 0 and |F_t| <=
  mu N: `indicators.validity`), since no indicator reads past it: the indicators
  are those of the full run bit for bit, and the estimate covers the samples
  they read (up to t_invalid). model.error = "richardson": step doubling instead
  (the same run at 2h, sampled every 2 dt, a second full run; |P_h - P_2h| /
  (2^4 - 1) for RK4's order 4; on halving, the previous run serves as the
  coarse one).
* "cosim": anything else (the induction motor, CSV sources): the scenario
  through the fmpy co-simulation master, exactly as `ballmill run` does; its
  error is the ball FMU's own estimate, the largest `coupling_error`.

The absorber (a structure that feels the ball: `ballmill.sweep.absorber`) is
such a model: a built-in case (``case = "absorber"`` in a study file, no FMU
scenario) with its own evaluator, indicators, refinement rounds and chains.
A later model registers its own
evaluator with `register` (with ``before`` to be tried ahead of the
co-simulation), with its own built-in ``indicators`` and `Prepared.evaluate`
if a mill's indicators do not fit it; the sweep engine does not change.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..scenario import spec as _scen
from .indicators import BUILTIN, HYBRID, VALIDITY, VALIDITY_HYBRID, Record, evaluate, evaluate_hybrid

REGISTRY: dict[str, "Evaluator"] = {}
ORDER: list[str] = []
# built-in model cases a study names with ``case = NAME`` instead of an FMU scenario: NAME ->
# an object with MODES, MODEL (default model settings), POSITIVE (settings that must be > 0),
# check_study(grid, model, mode, where), study_grid(grid, mode) and scenario(set_) (the
# pseudo-scenario the engine and the evaluator read); see ballmill.sweep.absorber
CASES: dict = {}


def register_case(name: str, case):
    CASES[name] = case


class Evaluator:
    """Base class: ``kind`` (its name), ``description``, ``indicators`` (the built-in
    indicators its points report: name -> (unit, description), the results' columns),
    ``validity`` (what its valid and t_invalid mean, same form); `check`, `prepare`."""

    kind = ""
    description = ""
    indicators = BUILTIN
    validity = VALIDITY

    def check(self, sc: _scen.Scenario) -> str:
        raise NotImplementedError

    def prepare(self, sc: _scen.Scenario, study, build_dir=None) -> "Prepared":
        raise NotImplementedError


class Prepared:
    """What a worker needs to compute points. ``run(params)`` -> (Record, meta) where
    params maps "instance.parameter" -> value (the swept ones; the scenario's and the
    study's fixed values are already in) and meta holds "model", "error_P_m",
    "error_N_N", "error_method"; raises on a bad point (the engine makes it a failed row)."""

    model = ""

    def run(self, params: dict):
        raise NotImplementedError

    def evaluate(self, rec: Record, custom) -> dict:
        """The indicators of a point's record (the evaluator's ``indicators``, the study's
        own, valid, t_invalid); a model with other indicators overrides this."""
        return evaluate(rec, custom)


def register(ev: Evaluator, before: str | None = None):
    """Add an evaluator; ``before``: the kind it should be tried before (else last)."""
    REGISTRY[ev.kind] = ev
    if ev.kind in ORDER:
        ORDER.remove(ev.kind)
    ORDER.insert(ORDER.index(before) if before in ORDER else len(ORDER), ev.kind)


def choose(sc: _scen.Scenario, kind: str = "auto") -> Evaluator:
    """The evaluator for a scenario: ``kind`` by name, or the first in ORDER that can."""
    if kind != "auto":
        if kind not in REGISTRY:
            raise ValueError(f"model.kind {kind!r}: no such evaluator (known: auto, {', '.join(ORDER)})")
        why = REGISTRY[kind].check(sc)
        if why:
            raise ValueError(f"model.kind {kind!r} cannot compute scenario {sc.name}: {why}")
        return REGISTRY[kind]
    reasons = []
    for k in ORDER:
        why = REGISTRY[k].check(sc)
        if not why:
            return REGISTRY[k]
        reasons.append(f"{k}: {why}")
    raise ValueError(f"no evaluator can compute scenario {sc.name}: " + "; ".join(reasons))


def _with(sc: _scen.Scenario, params: dict) -> dict:
    """Instance name -> parameters of the scenario with a point's values in."""
    out = {n: dict(i.parameters) for n, i in sc.instances.items()}
    for key, v in params.items():
        inst, p = key.split(".", 1)
        if inst not in out:
            raise ValueError(f"{key}: no instance {inst!r} in scenario {sc.name} "
                             f"(instances: {', '.join(out)})")
        out[inst][p] = v
    return out


def _refs(sc: _scen.Scenario, values: dict, defaults: dict) -> dict:
    """Window references: start, stop, after, and every instance.parameter."""
    refs = {"start": sc.start, "stop": sc.stop}
    for inst, ps in defaults.items():
        for p, v in ps.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                refs[f"{inst}.{p}"] = float(v)
    for inst, ps in values.items():
        for p, v in ps.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                refs[f"{inst}.{p}"] = float(v)
    after = sc.summary.get("after", sc.start)
    if isinstance(after, str):
        if after not in refs:
            raise ValueError(f"summary.after = {after!r}: no such parameter")
        after = refs[after]
    refs["after"] = float(after)
    return refs


# ----------------------------------------------------------------------------
# the monolithic kernel for a closed-form crank drive
BALL_PHYSICS = {"r": "r", "R": "R", "m": "m", "g": "g", "mu": "mu", "delta": "rolling_resistance",
                "c_drag": "drag"}
BALL_INITIAL = ("xC0", "yC0", "wx0", "wy0", "wz0")
BALL_BED = ("bed", "h_bed", "w_bed")  # the material bed: Ball.bed_depth (h_bed with bed = 1, else None), bed_band
# the FMU's numerical settings: they choose how the co-simulation integrates, and do not apply
# to the monolithic run (which takes the study's model settings)
BALL_NUMERICS = ("formulation", "integrator", "tolerance", "h_fixed", "input_mode", "max_step", "corrector",
                 "coupling_warn")
DRIVE_LAW = ("l", "n0", "t0", "law")
DRIVE_LOAD = ("m_platform", "J_crank")
BALL_KNOWN = set(BALL_PHYSICS) | set(BALL_INITIAL) | set(BALL_NUMERICS) | set(BALL_BED)
MOTION = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
SAFETY = 0.8  # RK4: halve h while the estimated contact-point error exceeds SAFETY * target
MAX_HALVINGS = 4
LAW_CODES = {1: "quadratic", 2: "scurve", 3: "linear", 4: "quintic"}  # MotorStartup's law parameter
# how RK4's error is estimated (model.error): from the run itself, stopping where the model stops
# holding (default), or by step doubling (Richardson: a second full run at 2h)
ERROR_METHODS = ("one-pass", "richardson")
RICHARDSON = "Richardson: RK4 at h and 2h, |difference| / 15 (order 4)"
ONE_PASS = ("the run's own: its local errors (residual against a 5th-order quadrature of its derivatives) "
            "carried to the contact point and N and summed, over the samples the indicators read")


class CrankKernel(Evaluator):
    kind = "crank-kernel"
    description = "monolithic run in the compiled kernel (closed-form crank drive)"

    def check(self, sc):
        from ..physics import KERNEL_AVAILABLE, KERNEL_REASON

        if not KERNEL_AVAILABLE:
            return f"compiled kernel unavailable: {KERNEL_REASON}"
        balls = [n for n, i in sc.instances.items() if i.fmu == "BallInShell"]
        if len(balls) != 1:
            return f"needs exactly one BallInShell instance, found {len(balls)}"
        ball = balls[0]
        feeds = {(di, dv): (si, sv) for si, sv, di, dv in sc.connections}
        srcs = {feeds[(ball, v)][0] for v in MOTION if (ball, v) in feeds}
        if len(srcs) != 1:
            return "the ball's platform inputs do not all come from one instance"
        drive = srcs.pop()
        if sc.instances[drive].fmu != "MotorStartup":
            return f"the ball is driven by {sc.instances[drive].fmu or 'a table'} (no closed form)"
        for v in MOTION:
            if feeds.get((ball, v)) != (drive, v):
                return f"{ball}.{v} is not connected to {drive}.{v}"
        for di, _dv in feeds:
            if di == ball and _dv not in MOTION:
                return f"{ball}.{_dv} is connected"
        return ""

    def prepare(self, sc, study, build_dir=None):
        feeds = {(di, dv): si for si, sv, di, dv in sc.connections}
        ball = next(n for n, i in sc.instances.items() if i.fmu == "BallInShell")
        drive = feeds[(ball, "x1O")]
        m = study.model
        return CrankPrepared(sc=sc, ball=ball, drive=drive, method=m["method"], h=float(m["h"]),
                             tol=float(m["tolerance"]), dt=float(m["dt"]), target=float(m["target_P"]),
                             error=m.get("error", ERROR_METHODS[0]))


@dataclass
class CrankPrepared(Prepared):
    sc: _scen.Scenario
    ball: str
    drive: str
    method: str
    h: float
    tol: float
    dt: float
    target: float = 1e-5
    error: str = ERROR_METHODS[0]
    timing: dict = field(default_factory=lambda: {"integration": 0.0})
    _models: dict = field(default_factory=dict, repr=False, compare=False)  # (Ball, h) -> (model, problem)
    # the ball's parameters (instance values, in order) -> its Ball (frozen): checked and built once
    # for the points that share them, as the drive's swept values do
    _balls: dict = field(default_factory=dict, repr=False, compare=False)
    _times: tuple = field(default=(None, None), repr=False, compare=False)  # ((start, stop, dt), the samples)

    def __getstate__(self):  # a worker builds its own models, kernel problems and balls
        return {**self.__dict__, "_models": {}, "_balls": {}, "_times": (None, None)}

    @property
    def model(self):
        return self.model_at(self.h)

    def model_at(self, h):
        setting = f"h = {h:g} s" if self.method == "RK4" else f"tol = {self.tol:g}"
        return f"crank-kernel: monolithic, compiled kernel, {self.method} {setting}, outputs every {self.dt:g} s"

    def objects(self, params: dict):
        """(Ball, CrankStartup, initial position/spin, J_total, parameter values) of a point."""
        from ..physics import Ball, CrankStartup
        from ..physics.errors import ParameterError

        values = _with(self.sc, params)
        bp, dp = values[self.ball], values[self.drive]
        try:
            key = tuple(bp.items())
            ball = self._balls.get(key)
        except TypeError:  # a value that is not hashable: no reuse
            key = ball = None
        known_d = set(DRIVE_LAW) | set(DRIVE_LOAD)
        for inst, ps, known in (((self.ball, bp, BALL_KNOWN),) if ball is None else ()) + ((self.drive, dp, known_d),):
            for p in ps:
                if p not in known:
                    raise ParameterError(f"{inst}.{p}: no such parameter (known: {', '.join(sorted(known))})")
        if ball is None:
            bed = bp.get("bed", 0)
            if bed not in (0, 1):
                raise ParameterError(f"{self.ball}.bed must be one of [0, 1] (0 = the material fills the chamber, "
                                     f"1 = a bed of depth h_bed), got {bed!r}")
            bed_kw = {"bed_band": bp["w_bed"]} if "w_bed" in bp else {}
            if bed == 1:
                bed_kw["bed_depth"] = bp.get("h_bed", 0.0)
            ball = Ball(**{BALL_PHYSICS[k]: v for k, v in bp.items() if k in BALL_PHYSICS}, **bed_kw)
            if key is not None:
                if len(self._balls) > 256:
                    self._balls.clear()
                self._balls[key] = ball
        law = dp.get("law", 1)
        if law not in LAW_CODES:
            raise ParameterError(f"{self.drive}.law must be one of {sorted(LAW_CODES)} "
                                 f"({', '.join(f'{k} = {v}' for k, v in LAW_CODES.items())}), got {law!r}")
        kw = {k: dp[k] for k in ("l", "n0", "t0") if k in dp}
        crank = CrankStartup(law=LAW_CODES[law], **kw)
        j_total = 0.0
        for k, unit in (("m_platform", "kg"), ("J_crank", "kg.m2")):
            v = dp.get(k, 0.0)
            if not (isinstance(v, (int, float)) and 0.0 <= v < math.inf):
                raise ParameterError(f"{self.drive}.{k} must be non-negative and finite, got {v!r} {unit}")
        j_total = float(dp.get("J_crank", 0.0)) + float(dp.get("m_platform", 0.0)) * crank.l ** 2
        init = tuple(float(bp.get(k, 0.0)) for k in BALL_INITIAL)
        defaults = {self.ball: {"r": ball.r, "R": ball.R, "m": ball.m, "g": ball.g, "mu": ball.mu},
                    self.drive: {"l": crank.l, "n0": crank.n0, "t0": crank.t0}}
        return ball, crank, init, j_total, values, defaults

    def _rk4_one_pass(self, ball, crank, init):
        """RK4 at h with the error the run estimates of itself (fast.study_run: the local errors'
        effect on the contact point and on N, accumulated over the samples the indicators
        read; no second run), ending at the first sample where the model stops holding; while
        the contact point's estimate exceeds SAFETY * target, the run again at h / 2 (the run
        that exceeded it ends where it did), at most MAX_HALVINGS times. None when the kernel cannot do the point (then `_rk4` does it, and
        reports a failure as it always has)."""
        from ..physics import BallModel, fast

        t0, t_end, dt = self.sc.start, self.sc.stop, self.dt
        n_steps = int(round((t_end - t0) / dt))  # simulate's grid
        if n_steps < 1:
            return None
        if self._times[0] != (t0, t_end, dt):  # the same samples for every point: made once
            grid = t0 + dt * np.arange(n_steps + 1)
            grid.setflags(write=False)  # shared by the points' records (their t): never written
            self._times = ((t0, t_end, dt), grid)
        times = self._times[1]
        mu = ball.mu

        def run(h, limit):
            key = (ball, h)
            if key not in self._models:  # the model and its kernel problem, once per ball and step
                if len(self._models) > 64:
                    self._models.clear()
                model = BallModel(ball, method=self.method, tol=self.tol, h_fixed=h)
                self._models[key] = (model, fast.study_problem(model))
            model, template = self._models[key]
            if template is None or fast._motion_params(crank)[0] is None:
                return None
            state = model.initial(init[0], init[1], init[2:], t0=t0)
            r = fast.study_run(model, crank, times, state, True, mu, template, limit)
            return None if r.failed else r

        h = self.h
        for halving in range(MAX_HALVINGS + 1):
            last = halving == MAX_HALVINGS
            # a run whose estimate passes the target's share ends there: it is redone at h / 2
            r = run(h, None if last else SAFETY * self.target)
            if r is None:
                return None
            if not r.exceeded:
                break
            h *= 0.5
        k = r.last + 1
        from ..physics.model import Trajectory
        from ..physics.outputs import Outputs

        outs = r.outs[:k]
        traj = Trajectory(times[:k], r.ys[:k], {name: outs[:, j] for j, name in enumerate(Outputs._fields)})
        return traj, {"model": self.model_at(h), "error_P_m": r.err_P, "error_N_N": r.err_N,
                      "error_method": ONE_PASS}

    def _rk4(self, ball, crank, init):
        """RK4 at h with its error estimated by step doubling (Richardson, order 4: |P_h - P_2h| / 15,
        the 2h run sampled every 2 dt); while the estimate exceeds SAFETY * target, halve h
        (the previous run becoming the coarse one), at most MAX_HALVINGS times."""
        h = self.h
        coarse = self._simulate(ball, crank, init, 2.0 * h, 2.0 * self.dt)
        traj = self._simulate(ball, crank, init, h, self.dt)
        stride = 2
        for _ in range(MAX_HALVINGS + 1):
            if not traj.success:
                raise ArithmeticError(traj.message)
            est = _difference(traj, coarse, stride, 1.0 / 15.0, RICHARDSON)
            if est["error_P_m"] is None or est["error_P_m"] <= SAFETY * self.target or h <= self.h / 2 ** MAX_HALVINGS:
                break
            coarse, stride, h = traj, 1, 0.5 * h
            traj = self._simulate(ball, crank, init, h, self.dt)
        return traj, {"model": self.model_at(h), **est}

    def _simulate(self, ball, crank, init, h, dt, outputs=True):
        from ..physics import BallModel, simulate

        model = BallModel(ball, method=self.method, tol=self.tol, h_fixed=h)
        state = model.initial(init[0], init[1], init[2:], t0=self.sc.start)
        return simulate(model, crank, t_end=self.sc.stop, dt=dt, state=state, outputs=outputs, kernel="c")

    def run(self, params):
        ball, crank, init, j_total, values, defaults = self.objects(params)
        c0 = time.perf_counter()
        done = self._rk4_one_pass(ball, crank, init) if self.method == "RK4" and self.error == "one-pass" else None
        if done is not None:
            traj, meta = done
        elif self.method == "RK4":
            traj, meta = self._rk4(ball, crank, init)
        else:
            traj = self._simulate(ball, crank, init, self.h, self.dt)
            if not traj.success:
                raise ArithmeticError(traj.message)
            # the error estimate: the run at 32x the tolerance (every other sample)
            coarse = CrankPrepared(self.sc, self.ball, self.drive, self.method, self.h, self.tol * 32.0,
                                   self.dt)._simulate(ball, crank, init, self.h, 2.0 * self.dt)
            meta = {"model": self.model, **_difference(traj, coarse, 2, 1.0,
                                                       "difference to the run at 32x the tolerance (upper bound)")}
        self.timing["integration"] += time.perf_counter() - c0
        t = traj.t
        psi, wd, wdd = crank.angles(t)
        s = {f"{self.ball}.{k}": v for k, v in traj.out.items()}
        d = self.drive + "."
        T = j_total * wdd - traj["M_reaction"]
        s.update({d + "psi": psi, d + "psi_dot": wd, d + "psi_ddot": wdd, d + "T_drive": T,
                  d + "P_drive": T * wd})
        rec = Record(t, s, self.ball, self.drive, ball.mu, _refs(self.sc, values, defaults))
        return rec, meta


def _difference(fine, coarse, stride: int, factor: float, how: str) -> dict:
    """error_P_m, error_N_N, error_method from two runs: factor * the largest difference of
    the contact point and of N at the coarse run's samples (every stride-th of the fine run)."""
    f = {k: fine[k][::stride] for k in ("xP", "yP", "zP", "N")}
    if not coarse.success or len(coarse.t) != len(f["N"]):
        return {"error_P_m": None, "error_N_N": None,
                "error_method": f"none: the comparison run failed ({coarse.message})"}
    dP = np.sqrt((f["xP"] - coarse["xP"]) ** 2 + (f["yP"] - coarse["yP"]) ** 2 + (f["zP"] - coarse["zP"]) ** 2)
    return {"error_P_m": float(dP.max()) * factor, "error_N_N": float(np.abs(f["N"] - coarse["N"]).max()) * factor,
            "error_method": how}


# ----------------------------------------------------------------------------
# the hybrid ball (rolling, sliding, flight, impacts) in the compiled kernel, for the same drives
class HybridKernel(CrankKernel):
    kind = "hybrid-kernel"
    description = ("the ball that rolls, slides, flies and strikes the shell (physics.hybrid.simulate_hybrid, "
                   "compiled kernel) under a closed-form crank drive")
    indicators = {**BUILTIN, **HYBRID}
    validity = VALIDITY_HYBRID

    def prepare(self, sc, study, build_dir=None):
        from ..physics.params import Contact

        feeds = {(di, dv): si for si, sv, di, dv in sc.connections}
        ball = next(n for n, i in sc.instances.items() if i.fmu == "BallInShell")
        m = study.model
        return HybridPrepared(sc=sc, ball=ball, drive=feeds[(ball, "x1O")], method=m["method"], h=float(m["h"]),
                              tol=float(m["tolerance"]), dt=float(m["dt"]), target=float(m["target_P"]),
                              contact=Contact(**(study.contact or {})))


@dataclass
class HybridPrepared(CrankPrepared):
    """A point: `simulate_hybrid` of the point's ball and crank start over the scenario's
    [start, stop], sampled every dt, from the rolling model's initial state (as the
    crank-kernel's run), with the study's Contact and integrator (DOP853 or RK45 at the
    tolerance: a fixed RK4 step cannot follow the stiff Coulomb direction of sliding)."""

    contact: object = None

    def model_at(self, h=None):
        c = self.contact
        return (f"hybrid-kernel: rolling/sliding/flight/impacts, compiled kernel, {self.method} tol = "
                f"{self.tol:g}, mu_k = {c.mu_k if c.mu_k is not None else 'mu'}, e_n = {c.e_n:g}, "
                f"v_rest = {c.v_rest:g} m/s, creep_eps = {c.creep_eps:g} m/s, outputs every {self.dt:g} s")

    def run(self, params):
        from ..physics import BallModel
        from ..physics.hybrid import simulate_hybrid

        ball, crank, init, j_total, values, defaults = self.objects(params)
        c0 = time.perf_counter()
        state = BallModel(ball).initial(init[0], init[1], init[2:], t0=self.sc.start)
        traj = simulate_hybrid(ball, crank, self.sc.stop, self.dt, self.contact, initial=state,
                               method=self.method, tol=self.tol)
        self.timing["integration"] += time.perf_counter() - c0
        n_steps = int(round((self.sc.stop - self.sc.start) / self.dt))
        t = self.sc.start + self.dt * np.arange(n_steps + 1)  # the grid, also where the run stopped early
        k = len(traj.t)
        o = traj.out

        def col(x):
            x = np.asarray(x, float)
            return x if k == len(t) else np.concatenate([x, np.full(len(t) - k, np.nan)])

        b = self.ball + "."
        N, Ft = o["N"], o["Ft"]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(N > 0.0, Ft / N, 0.0)  # no contact force in flight
        s = {b + "N": col(N), b + "Ft": col(Ft), b + "friction_ratio": col(ratio)}
        for i, ax in enumerate("xyz"):  # C relative to O; P = C + r n, the ball's point nearest the shell
            s[b + ax + "C"] = col(o[ax + "C"])
            s[b + ax + "P"] = col(o[ax + "C"] + ball.r * o["n" + ax])
        for name in ("mode", "slip_speed", "gap", "E", "W_chamber", "E_friction", "E_impact", "n_impacts",
                     "v_impact_max", "t_first_slip", "t_first_flight"):
            s[b + name] = col(o[name])
        psi, wd, wdd = crank.angles(t)
        d = self.drive + "."
        s.update({d + "psi": psi, d + "psi_dot": wd, d + "psi_ddot": wdd})
        rec = Record(t, s, self.ball, self.drive, ball.mu, _refs(self.sc, values, defaults))
        rec.stopped_at = None if traj.success else k
        meta = {"model": self.model, "error_P_m": None, "error_N_N": None,
                "error_method": f"none: {self.method} at tol = {self.tol:g} controls the local error"
                                + ("" if traj.success else f"; the run stopped: {traj.message}")}
        return rec, meta

    def evaluate(self, rec, custom):
        return evaluate_hybrid(rec, custom, rec.stopped_at)


# ----------------------------------------------------------------------------
# the co-simulation through the FMUs (anything the kernel does not cover)
class Cosim(Evaluator):
    kind = "cosim"
    description = "co-simulation of the scenario's FMUs through fmpy (as ballmill run)"

    def check(self, sc):
        balls = [n for n, i in sc.instances.items() if i.fmu == "BallInShell"]
        return "" if len(balls) == 1 else f"needs exactly one BallInShell instance, found {len(balls)}"

    def prepare(self, sc, study, build_dir=None):
        from ..scenario import runner

        # build once, here (workers reuse the FMUs), and check the fixed overrides
        sc, models, paths = runner.prepare(str(sc.path), study.set, build_dir, log=lambda m: None)
        ball = next(n for n, i in sc.instances.items() if i.fmu == "BallInShell")
        drive = next((si for si, sv, di, dv in sc.connections if di == ball and dv == "x1O"), None)
        defaults = {n: {v.name: _start(v) for v in models[i.fmu].modelVariables if v.causality == "parameter"}
                    for n, i in sc.instances.items() if i.fmu}
        return CosimPrepared(path=str(sc.path), overrides=list(study.set), build_dir=build_dir, ball=ball,
                             drive=drive, defaults=defaults, step=sc.step, stop=study.stop,
                             extra=tuple(i.variable for i in study.indicators), paths=dict(paths))


BALL_NEEDED = ("N", "friction_ratio", "xP", "yP", "zP", "xC", "yC", "zC", "M_reaction", "coupling_error", "Ft",
               "P_grind", "s_bed")
DRIVE_NEEDED = ("psi", "psi_dot", "T_drive", "P_drive")


def _record_needed(sc, models, ball, drive, extra):
    """Add to the scenario's records what the indicators read (where the FMU has it)."""
    have = set(sc.record)
    want = [(ball, v) for v in BALL_NEEDED] + ([(drive, v) for v in DRIVE_NEEDED] if drive else [])
    want += [tuple(v.split(".", 1)) for v in extra]
    for inst, var in want:
        if (inst, var) in have or inst not in sc.instances or sc.instances[inst].fmu is None:
            continue
        if any(v.name == var and v.causality == "output" for v in models[sc.instances[inst].fmu].modelVariables):
            sc.record.append((inst, var))
            have.add((inst, var))


def _start(v):
    try:
        return float(v.start)
    except (TypeError, ValueError):
        return v.start


@dataclass
class CosimPrepared(Prepared):
    path: str
    overrides: list
    build_dir: object
    ball: str
    drive: str | None
    defaults: dict
    step: float
    stop: float | None = None
    extra: tuple = ()  # variables the study's own indicators read
    timing: dict = field(default_factory=lambda: {"integration": 0.0})
    paths: dict = field(default_factory=dict)  # model name -> FMU, built and checked once by Cosim.prepare

    @property
    def model(self):
        return f"cosim: FMUs through fmpy, communication step {self.step:g} s"

    def run(self, params):
        from ..scenario import runner

        c0 = time.perf_counter()
        sets = self.overrides + [f"{k}={_toml(v)}" for k, v in params.items()]
        # the FMUs were built and checked by Cosim.prepare, once per study: a point loads the scenario
        # with its values, checked against the model descriptions (parsed once per process), no build check
        paths = self.paths
        sc, models = runner.load_built(self.path, sets, paths)
        if self.stop is not None:
            sc.stop = self.stop
        _record_needed(sc, models, self.ball, self.drive, self.extra)
        res = runner.run(sc, models, paths, progress=False, echo=False)
        self.timing["integration"] += time.perf_counter() - c0
        if not res.success:
            raise ArithmeticError(res.message)
        t = res.column("time")
        series = {c: res.data[:, j] for j, c in enumerate(res.columns) if c != "time"}
        b = self.ball + "."
        need = [b + v for v in ("N", "friction_ratio", "xP", "yP", "zP", "xC", "yC", "zC")]
        missing = [n for n in need if n not in series]
        if missing:
            raise ValueError(f"the scenario does not record {', '.join(missing)} (the indicators need them)")
        values = {n: dict(i.parameters) for n, i in sc.instances.items()}
        mu = float(values[self.ball].get("mu", self.defaults[self.ball]["mu"]))
        rec = Record(t, series, self.ball, self.drive, mu, _refs(sc, values, self.defaults))
        ce = series.get(b + "coupling_error")
        meta = {"model": self.model,
                "error_P_m": float(np.max(ce)) if ce is not None else None, "error_N_N": None,
                "error_method": ("the ball FMU's coupling_error (predicted vs corrected contact point)"
                                 if ce is not None else "none (coupling_error not recorded)")}
        return rec, meta


def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v + '"'
    return repr(v)


register(CrankKernel())
register(Cosim())
register(HybridKernel())  # chosen by a study's [contact] table (spec.build), never by "auto" alone
from . import absorber as _absorber  # noqa: E402,F401 - registers the absorber case and its evaluator
