"""Micro benchmarks: one right-hand side, one communication step, process start-up.

timeit with automatic loop count, median over repeats, in microseconds.
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import timeit
from pathlib import Path

import numpy as np

from ballmill.physics import BallModel, PaperFormulation, VectorFormulation, omega_dot_cramer, simulate

from . import literal
from .problem import Problem


def per_call_us(fn, repeats: int = 7, min_time: float = 0.2) -> tuple[float, int]:
    """Median time of one call [us] and the loop count per repeat."""
    timer = timeit.Timer(fn)
    number = 1
    while True:
        if timer.timeit(number) >= min_time:
            break
        number *= 2 if number < 1000 else 4
    times = timer.repeat(repeat=repeats, number=number)
    return statistics.median(times) / number * 1e6, number


def mid_run_state(problem: Problem, model: BallModel, t: float):
    """The model's state at time t of the fast start."""
    traj = simulate(model, problem.drive, t_end=t, dt=problem.dt, outputs=False)
    st = model.initial()
    st.t, st.y = float(traj.t[-1]), traj.y[-1].copy()
    return st


def rhs_cases(problem: Problem, repeats: int, min_time: float):
    ball, drive = problem.ball, problem.drive
    t = 5.0
    vec_model = BallModel(ball)
    sv = mid_run_state(problem, vec_model, t)
    pap_model = BallModel(ball, formulation="paper")
    sp = mid_run_state(problem, pap_model, t)
    yv, yp = sv.y.tolist(), sp.y.tolist()
    ax, ay = drive.accel(t)
    vec = VectorFormulation(ball)
    pap = PaperFormulation(ball)
    cra = PaperFormulation(ball, cramer=True)
    f_model = vec_model.rhs(drive.accel)
    f_lit, _ = literal.make_rhs(problem)

    class _NoList(np.ndarray):  # an array whose tolist() hands back numpy scalars
        def tolist(self):
            return list(self.view(np.ndarray))

    f_lit_np = (lambda t, y: f_lit(t, y.view(_NoList)))
    y_nd = sv.y.copy()
    yp_nd = sp.y.copy()
    cases = [
        ("VectorFormulation.derivative (closed form)", lambda: vec.derivative(yv, ax, ay)),
        ("PaperFormulation.derivative (closed form)", lambda: pap.derivative(yp, ax, ay)),
        ("PaperFormulation(cramer=True).derivative (3x3 Cramer each call)",
         lambda: cra.derivative(yp, ax, ay)),
        ("omega_dot_cramer alone", lambda: omega_dot_cramer(ball, yp[0], yp[1], yp[2], yp[3], yp[4], ax, ay)),
        ("CrankStartup.accel(t)", lambda: drive.accel(t)),
        ("BallModel.rhs f(t, y): accel + tolist + vector derivative", lambda: f_model(t, y_nd)),
        ("paper-literal f(t, y) (inline drive + Cramer, y.tolist(), returns list)", lambda: f_lit(t, yp_nd)),
        ("the same with y unpacked as numpy scalars (no tolist)", lambda: f_lit_np(t, yp_nd)),
    ]
    rows = []
    for name, fn in cases:
        us, number = per_call_us(fn, repeats, min_time)
        rows.append((name, us, number))
    return rows


def advance_cases(problem: Problem, repeats: int, min_time: float):
    """One communication step of BallModel.advance from the state at t = 5 s."""
    ball, drive = problem.ball, problem.drive
    settings = [
        ("vector", "DOP853", dict(tol=1e-9)),
        ("vector", "RK45", dict(tol=1e-6)),
        ("vector", "RK4", dict(h_fixed=1e-3)),
        ("paper", "DOP853", dict(tol=1e-9)),
    ]
    rows = []
    for form, method, kw in settings:
        for H in (1e-3, 1e-2):
            model = BallModel(ball, formulation=form, method=method, **kw)
            st = mid_run_state(problem, model, 5.0)
            # carry the controller's step as an FMU would: take a few steps of size H first
            for _ in range(3):
                st = model.advance(st, st.t + H, drive.accel)
            t_end = st.t + H
            before = model.info.steps, model.info.nfev
            model.advance(st, t_end, drive.accel)
            steps, nfev = model.info.steps - before[0], model.info.nfev - before[1]
            us, number = per_call_us(lambda: model.advance(st, t_end, drive.accel), repeats, min_time)
            setting = ", ".join(f"{k} {v:g}" for k, v in kw.items())
            rows.append((form, method, setting, H, us, steps, nfev))
    return rows


def _package_parent() -> Path:
    """The directory holding the imported ballmill package (what PYTHONPATH needs)."""
    import ballmill

    return Path(ballmill.__file__).resolve().parents[1]


def _python_env():
    env = dict(os.environ)
    parent = str(_package_parent())
    env["PYTHONPATH"] = parent + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


FIRST_STEP = (
    "from ballmill.physics import Ball, BallModel, CrankStartup\n"
    "m = BallModel(Ball()); s = m.initial()\n"
    "s = m.advance(s, 0.001, CrankStartup().accel)\n"
)


def startup(root: Path, repeats: int):
    """Wall time of fresh interpreters [s], median of repeats: bare, import, first step."""
    import time

    env = _python_env()
    cwd = str(_package_parent())
    cases = [
        ("python -c pass (bare interpreter)", "pass"),
        ("python -c 'import numpy'", "import numpy"),
        ("python -c 'import ballmill.physics'", "import ballmill.physics"),
        ("import + BallModel + first advance (1 ms, DOP853)", FIRST_STEP),
    ]
    rows = []
    for name, code in cases:
        walls = []
        for i in range(repeats + 1):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd,
                                  capture_output=True, text=True)
            wall = time.perf_counter() - t0
            if proc.returncode != 0:
                raise RuntimeError(f"start-up run failed: {code!r}: {proc.stderr}")
            if i:  # the first run warms the file cache
                walls.append(wall)
        rows.append((name, statistics.median(walls), min(walls)))
    return rows
