"""Benchmark section: what the general (turning-chamber) model costs per step against the
translation-only model, and what a scene without rotation pays through simulate_chamber.

Per-step cost = wall time of a monolithic 10 s run / accepted steps (DOP853, tol 1e-9,
outputs every 10 ms included), median over repeats; one right-hand side with its motion
evaluation, by timeit. Python path and compiled kernel, where each exists.
"""
from __future__ import annotations

import statistics
import time

import numpy as np

from ballmill.physics import Ball, BallModel, CrankStartup, fast, simulate
from ballmill.physics.turning import model as turning
from ballmill.physics.turning.motions import Fig1Machine, Spin, Translation

from .micro import per_call_us

T_END, DT = 10.0, 0.01


def _runs(repeats: int):
    """[(label, model kind, kernel, wall [s], steps, nfev)] for each case."""
    ball = Ball()
    crank = CrankStartup(l=0.5, n0=60.0, t0=2.5)
    cases = [
        ("translation-only model, fast start (`simulate`)", "bm", crank),
        ("general model, the same translation (`simulate_general`)", "gen", Translation(crank)),
        ("`simulate_chamber` with a Translation (dispatches to `simulate`)", "chamber", Translation(crank)),
        ("general model, spinning bowl (Omega = 3 rad/s)", "gen", Spin((0.0, 0.0, 3.0), (0.0, 0.0, 0.25))),
        ("general model, Fig. 1 machine", "gen", Fig1Machine()),
    ]
    out = []
    for label, kind, motion in cases:
        for kernel in ("python", "c"):
            if kernel == "c" and not fast.KERNEL_AVAILABLE:
                continue
            if kind == "gen" and kernel == "c" and isinstance(motion, Translation):
                continue  # the general kernel has no Translation: such scenes use the translation model

            def run():
                if kind == "bm":
                    m = BallModel(ball, kernel=kernel)
                    return simulate(m, motion, T_END, DT, kernel=kernel), m.info
                if kind == "chamber":
                    tr = turning.simulate_chamber(ball, motion, T_END, DT, kernel=kernel)
                    return tr, tr.info
                m = turning.ChamberModel(ball, kernel=kernel)
                tr = turning.simulate_general(m, motion, T_END, DT, m.initial(motion))
                return tr, m.info
            walls = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                tr, info = run()
                walls.append(time.perf_counter() - t0)
            out.append((label, kernel, statistics.median(walls), info.steps, info.nfev, tr.success))
    return out


def _rhs_us(repeats: int, min_time: float):
    ball = Ball()
    crank = CrankStartup(l=0.5, n0=60.0, t0=2.5)
    y = np.array([0.3, -0.2, -0.9327379053088815, 1.0, 2.0, -0.5])
    bm = BallModel(ball, kernel="python")
    f_bm = bm.rhs(crank.accel)
    cm = turning.ChamberModel(ball, kernel="python")
    f_tr = cm.rhs(Translation(crank))
    f_fig = cm.rhs(Fig1Machine())
    f_spin = cm.rhs(Spin((0.0, 0.0, 3.0), (0.0, 0.0, 0.25)))
    return [
        ("translation-only: `BallModel.rhs(CrankStartup.accel)`", per_call_us(lambda: f_bm(5.0, y), repeats, min_time)[0]),
        ("general: `ChamberModel.rhs(Translation(crank))`", per_call_us(lambda: f_tr(5.0, y), repeats, min_time)[0]),
        ("general: `ChamberModel.rhs(Spin)`", per_call_us(lambda: f_spin(5.0, y), repeats, min_time)[0]),
        ("general: `ChamberModel.rhs(Fig1Machine())`", per_call_us(lambda: f_fig(5.0, y), repeats, min_time)[0]),
    ]


def measure(repeats: int = 5, min_time: float = 0.1):
    return {"runs": _runs(repeats), "rhs": _rhs_us(repeats, min_time), "repeats": repeats}


def report(m) -> list[str]:
    """Markdown lines of the section."""
    L = ["## 7. A chamber that turns: the general model's cost\n",
         f"Monolithic 10 s runs, DOP853 tol 1e-9, outputs every {DT * 1e3:g} ms, median of "
         f"{m['repeats']} runs; per-step cost = wall time / accepted steps (output evaluation included). "
         f"A scene without rotation (`chamber.Translation`) runs on the translation-only model through "
         f"`simulate_chamber`; the general model on the same translation gives the same trajectory "
         f"bit for bit (tests/test_turning.py) and is listed to show what it would cost.\n",
         "| run | path | wall [ms] | steps | evaluations | per step [us] | ok |",
         "| --- | --- | ---: | ---: | ---: | ---: | --- |"]
    base = {}
    for label, kernel, wall, steps, nfev, ok in m["runs"]:
        per = wall / steps * 1e6 if steps else float("nan")
        if label.startswith("translation-only"):
            base[kernel] = per
        L.append(f"| {label} | {kernel} | {wall * 1e3:.1f} | {steps} | {nfev} | {per:.2f} | {ok} |")
    L.append("")
    ratios = []
    for label, kernel, wall, steps, nfev, ok in m["runs"]:
        if "Fig. 1" in label and kernel in base and steps:
            ratios.append(f"{kernel}: {wall / steps * 1e6 / base[kernel]:.2f}x")
    if ratios:
        L.append("Fig. 1 machine against the translation-only fast start, per step: " + ", ".join(ratios) + ".\n")
    walls = {(label.split(" (")[0], kernel): wall for label, kernel, wall, *_ in m["runs"]}
    extra = []
    for kernel in ("python", "c"):
        a = walls.get(("translation-only model, fast start", kernel))
        b = walls.get(("`simulate_chamber` with a Translation", kernel))
        if a is not None and b is not None:
            extra.append(f"{kernel}: {(b - a) / (T_END / DT + 1) * 1e6:.1f} us")
    if extra:
        L.append("What `simulate_chamber` adds to a translation scene is the mapping of the translation "
                 "model's outputs to the general columns (platform state, energy, drive moments), per "
                 "output point, not per step: " + ", ".join(extra) + " per point. The integration "
                 "itself is `simulate`'s.\n")
    L += ["One right-hand side with its motion evaluation (Python, timeit median):\n",
          "| right-hand side | us per call |", "| --- | ---: |"]
    L += [f"| {name} | {us:.2f} |" for name, us in m["rhs"]]
    L.append("")
    return L


def main():  # pragma: no cover - manual use: python -m ballmill.bench.turning
    for line in report(measure(3, 0.05)):
        print(line)


if __name__ == "__main__":  # pragma: no cover
    main()
