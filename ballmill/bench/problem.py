"""The benchmark problem, its reference solution and the error metrics.

Problem: the paper's fast start, CrankStartup(l=0.5, n0=60, t0=2.5) with
Ball() defaults, the ball at rest at the bottom at t = 0, integrated to
t_end = 10 s with outputs on a uniform 0.01 s grid.

Metrics on that grid: max |P - P_ref| (Euclidean, P = (xP, yP, zP)) and
max |N - N_ref|.
"""
from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass, field

import numpy as np

from ballmill.physics import Ball, BallModel, CrankStartup, simulate


@dataclass(frozen=True)
class Problem:
    t_end: float = 10.0
    dt: float = 0.01
    ball: Ball = field(default_factory=Ball)
    drive: CrankStartup = field(default_factory=lambda: CrankStartup(l=0.5, n0=60.0, t0=2.5))

    @property
    def n_out(self) -> int:
        return int(round(self.t_end / self.dt)) + 1

    @property
    def grid(self) -> np.ndarray:
        return self.dt * np.arange(self.n_out)

    @property
    def w_ref(self) -> float:
        """Angular-velocity scale used by the library's absolute tolerance."""
        b = self.ball
        return b.d * b.omega_small / b.r


@dataclass
class Sample:
    """A trajectory on the output grid: contact point and normal force."""

    P: np.ndarray  # (n, 3)
    N: np.ndarray  # (n,)


@dataclass
class RunResult:
    """One benchmarked setting."""

    family: str  # e.g. "library (vector)", "paper-literal", "compiled (C)"
    method: str
    setting: str  # human readable, e.g. "tol 1e-9" / "h 1e-3" / "rtol 1e-8"
    param: float  # tolerance or step, for sorting
    err_P: float = math.nan
    err_N: float = math.nan
    wall: float = math.nan  # median [s]
    walls: list = field(default_factory=list)
    steps: int | None = None
    rejected: int | None = None
    nfev: int | None = None
    extra: dict = field(default_factory=dict)
    ok: bool = True
    message: str = ""

    @property
    def label(self) -> str:
        return f"{self.family} {self.method} {self.setting}"


def errors(sample: Sample, ref: Sample) -> tuple[float, float]:
    """(max |dP| [m], max |dN| [N]) over the grid."""
    n = min(len(sample.N), len(ref.N))
    if n < len(ref.N):
        return math.inf, math.inf
    dP = np.sqrt(np.sum((sample.P[:n] - ref.P[:n]) ** 2, axis=1))
    dN = np.abs(sample.N[:n] - ref.N[:n])
    return float(np.max(dP)), float(np.max(dN))


def median_time(fn, repeats: int, warmup: int = 1):
    """Run fn warmup + repeats times; (median wall [s], all walls, last result)."""
    result = None
    for _ in range(warmup):
        result = fn()
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls), walls, result


def fmt_setting(method: str, param: float) -> str:
    return f"h {param:g} s" if method == "RK4" else f"tol {param:g}"


# ---------------------------------------------------------------------------
# the library
def library_model(problem: Problem, formulation: str, method: str, param: float) -> BallModel:
    if method == "RK4":
        return BallModel(problem.ball, formulation=formulation, method="RK4", h_fixed=param)
    return BallModel(problem.ball, formulation=formulation, method=method, tol=param)


KERNEL_FAMILY = "library (C kernel)"


def run_library(problem: Problem, formulation: str, method: str, param: float, kernel: str = "python"):
    """One monolithic run of the public driver; (Sample, model, trajectory).
    kernel: simulate's kernel argument ("python": the pure-Python path, "c": the compiled kernel)."""
    model = library_model(problem, formulation, method, param)
    traj = simulate(model, problem.drive, t_end=problem.t_end, dt=problem.dt, kernel=kernel)
    P = np.column_stack([traj["xP"], traj["yP"], traj["zP"]]) if traj.out else np.empty((0, 3))
    N = traj["N"] if traj.out else np.empty(0)
    return Sample(P, N), model, traj


def prepare_library(problem: Problem, ref: Sample, formulation: str, method: str,
                    param: float, kernel: str = "python") -> RunResult:
    """One untimed run: errors, step counts, and the closure that repeats the run
    (timed later, round-robin with the other settings: see `time_round_robin`)."""
    family = KERNEL_FAMILY if kernel == "c" else f"library ({formulation})"
    res = RunResult(family, method, fmt_setting(method, param), param)
    sample, model, traj = run_library(problem, formulation, method, param, kernel)
    res.ok, res.message = traj.success, traj.message
    res.err_P, res.err_N = errors(sample, ref)
    res.steps, res.rejected, res.nfev = model.info.steps, model.info.rejected, model.info.nfev
    res.extra["sample"] = sample
    res.extra["rerun"] = lambda: run_library(problem, formulation, method, param, kernel)
    return res


def round_order(items, k: int):
    """``items`` in the order of round k: a fixed pseudo-random permutation per round,
    so that which setting follows which changes from round to round. The first run of
    a family after a stretch of other work finds cold caches (a compiled-kernel run
    right after Python runs takes up to about 1.6x as long as one after another
    kernel run); shuffled, every setting meets that about equally often."""
    import random

    order = list(items)
    random.Random(1000 + k).shuffle(order)
    return order


def time_round_robin(results, repeats: int, progress=None, label: str = ""):
    """Time every result's rerun ``repeats`` times, one run of each setting per
    round (order shuffled from round to round: `round_order`), so that a burst of
    load from other processes spreads over all settings instead of falling on
    one; wall = median over the rounds."""
    todo = [r for r in results if r.ok and "rerun" in r.extra]
    walls = {id(r): [] for r in todo}
    for k in range(repeats):
        for r in round_order(todo, k):
            t0 = time.perf_counter()
            r.extra["rerun"]()
            walls[id(r)].append(time.perf_counter() - t0)
        if progress:
            progress(f"{label}timing round {k + 1}/{repeats} done ({len(todo)} settings)")
    for r in todo:
        r.walls = walls[id(r)]
        r.wall = statistics.median(r.walls)
    return results


# ---------------------------------------------------------------------------
# reference
@dataclass
class Reference:
    sample: Sample
    tol: float
    wall: float
    steps: int
    nfev: int
    checks: list  # (description, max |dP|, max |dN|)


def reference(problem: Problem, tol: float = 1e-13, check_tol: float = 1e-12,
              independent: bool = True) -> Reference:
    """Converged reference: the library's DOP853 at ``tol`` (vector form),
    checked against the same at ``check_tol`` and, independently, against
    scipy's solve_ivp DOP853 (free steps, dense output) at rtol = tol."""
    t0 = time.perf_counter()
    ref, model, traj = run_library(problem, "vector", "DOP853", tol)
    wall = time.perf_counter() - t0
    if not traj.success:
        raise RuntimeError(f"reference run failed: {traj.message}")
    checks = []
    chk, _, _ = run_library(problem, "vector", "DOP853", check_tol)
    checks.append((f"library DOP853 tol {check_tol:g} (vector)", *errors(chk, ref)))
    chk, _, _ = run_library(problem, "paper", "DOP853", tol)
    checks.append((f"library DOP853 tol {tol:g} (paper formulation)", *errors(chk, ref)))
    if independent:
        checks.append((f"scipy solve_ivp DOP853 rtol {tol:g}, free steps + dense output (vector eqs.)",
                       *errors(_scipy_vector(problem, tol), ref)))
    return Reference(ref, tol, wall, model.info.steps, model.info.nfev, checks)


def _scipy_vector(problem: Problem, tol: float) -> Sample:
    from scipy.integrate import solve_ivp

    from ballmill.physics import VectorFormulation, evaluate

    form = VectorFormulation(problem.ball)
    drive = problem.drive

    def f(t, y):
        ax, ay = drive.accel(t)
        return form.derivative(y.tolist(), ax, ay)

    scale = np.array([1.0, 1.0, 1.0] + [problem.w_ref] * 3)
    sol = solve_ivp(f, (0.0, problem.t_end), [0.0, 0.0, -1.0, 0.0, 0.0, 0.0], method="DOP853",
                    t_eval=problem.grid, rtol=tol, atol=tol * scale)
    P, N = [], []
    for t, y in zip(sol.t, sol.y.T):
        n = y[:3] / np.linalg.norm(y[:3])
        x, yy, _, _, ax, ay = drive.state(float(t))
        o = evaluate(problem.ball, tuple(n), tuple(y[3:]), ax, ay, x, yy)
        P.append((o.xP, o.yP, o.zP))
        N.append(o.N)
    return Sample(np.array(P), np.array(N))
