"""What a point of a study costs with the hybrid ball against the rolling model, on one grid.

Every point of the grid is computed by both evaluators, the rolling study's (`t0_n0`,
crank-kernel: RK4 with its one-pass error estimate, ending at the first sample where rolling
stops holding) and the hybrid one's (`t0_n0_hybrid`, hybrid-kernel: simulate_hybrid, DOP853),
in turn, point by point, in this process (run and indicators, no Dask): medians of the CPU time
of the process and of the wall time per point, and the points per second of one core (from the
mean CPU time).

    python -m ballmill.studies.hybrid_cost [GRID_STUDY]

GRID_STUDY: the study whose grid is used (default t0_n0_hybrid, the shockless map's; t0_n0
for the paper's grid, where most points keep rolling).
"""
from __future__ import annotations

import statistics
import sys
import time


def measure(grid_study: str = "t0_n0_hybrid") -> dict:
    """name -> (evaluator kind, CPU ms per point, wall ms per point) on grid_study's grid."""
    from ..sweep import evaluators as ev
    from ..sweep import load
    from ..sweep.spec import check_scenario

    hyb = load("t0_n0_hybrid", grid=load(grid_study).grid)
    studies = {"rolling": load("t0_n0", grid=hyb.grid), "hybrid": hyb}
    preps = {}
    for name, st in studies.items():
        sc = check_scenario(st)
        e = ev.choose(sc, st.model["kind"])
        preps[name] = (e.kind, e.prepare(sc, st), st.indicators)
    cpu = {k: [] for k in preps}
    wall = {k: [] for k in preps}
    for p in hyb.points():
        for name, (_, prep, custom) in preps.items():
            w0, c0 = time.perf_counter(), time.process_time()
            rec, _ = prep.run(p)
            prep.evaluate(rec, custom)
            cpu[name].append(1e3 * (time.process_time() - c0))
            wall[name].append(1e3 * (time.perf_counter() - w0))
    return {name: (kind, cpu[name], wall[name]) for name, (kind, _, _) in preps.items()}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    grid = argv[0] if argv else "t0_n0_hybrid"
    res = measure(grid)
    n = len(next(iter(res.values()))[1])
    print(f"{n} points ({grid}'s grid), each evaluator in turn on each point, run + indicators, in process")
    print(f"{'evaluator':<26}{'CPU ms/point':>14}{'wall ms/point':>15}{'points/s (1 core)':>19}")
    for name, (kind, c, w) in res.items():
        print(f"{name + ' (' + kind + ')':<26}{statistics.median(c):>14.2f}{statistics.median(w):>15.2f}"
              f"{1e3 / statistics.mean(c):>19.1f}")
    ratio = statistics.median(res["hybrid"][1]) / statistics.median(res["rolling"][1])
    print(f"medians of the CPU time per point; points/s from its mean. hybrid / rolling: {ratio:.1f}")


if __name__ == "__main__":
    main()
