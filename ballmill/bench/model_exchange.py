"""Benchmark section "Model Exchange" of BENCHMARKS.md.

    ballmill bench --section me [--quick] [--repeats N]     run only this section and splice it in

1. The coupled fast start (MotorStartup + BallInShell, scenarios/fast_start.toml) through the
   scenario master, native FMUs, warm (the FMUs loaded by an earlier run, as in a sweep):
   co-simulation at the scenario's 2 ms step against Model Exchange (`ballmill run
   --interface me`: one ODE, scipy's DOP853) at its default tolerance and at a looser one;
   the median wall time of the runs (interleaved rounds), the integrator's steps and the
   events, and the largest contact-point and N differences from the monolithic library (the
   ball on the exact crank law, DOP853 at tol 1e-13, on the same 2 ms grid).
2. One Model Exchange derivative evaluation of BallInShell through ctypes with prebuilt
   arguments (fmi2SetContinuousStates + fmi2GetDerivatives: what an importer's solver pays
   per evaluation with the inputs unchanged; and with fmi2SetTime and the six platform inputs
   by fmi2SetReal too), against the compiled kernel's right-hand side (bm_eval_rhs of
   ballmill/physics/_kernel.c: the crank law's acceleration and the vector formulation's
   derivative) called the same way. The FMU evaluates its outputs with its derivatives (they
   are published at every evaluation), the kernel only the derivative.
"""
from __future__ import annotations

import ctypes
import statistics
from pathlib import Path

import numpy as np

from .report import splice_section

BEGIN, END = "<!-- section: model-exchange -->", "<!-- end of section: model-exchange -->"
SETTINGS = (  # name, interface, [master] overrides
    ("co-simulation, H = 2 ms", "cs", {}),
    ("Model Exchange, DOP853, rtol = atol = 1e-10 (default)", "me", {}),
    ("Model Exchange, DOP853, rtol = atol = 1e-8", "me", {"rtol": 1e-8, "atol": 1e-8}),
)


def _library(sc):
    from ballmill.physics import Ball, BallModel, CrankStartup, simulate

    p, d = sc.instances["ball"].parameters, sc.instances["drive"].parameters
    ball = Ball(r=p["r"], R=p["R"], m=p["m"], mu=p["mu"])
    crank = CrankStartup(l=d["l"], n0=d["n0"], t0=d["t0"])
    model = BallModel(ball, method="DOP853", tol=1e-13)
    return model, crank, simulate(model, crank, sc.stop, sc.step)


def measure_runs(repeats: int, stop: float, progress=print) -> list[dict]:
    from ballmill.scenario import runner

    sc, models, paths = runner.prepare("fast_start", [], log=progress, interface="me")
    sc.stop = stop
    sc.record = [("ball", v) for v in ("xP", "yP", "zP", "N")]
    _, _, ref = _library(sc)
    P_ref = np.stack([ref.out[v] for v in ("xP", "yP", "zP")], axis=1)
    base = dict(sc.master)
    walls = {name: [] for name, _, _ in SETTINGS}
    last = {}
    for round_ in range(repeats + 1):  # round 0 warms up (loads the libraries, imports scipy's integrators)
        for name, interface, master in SETTINGS:
            sc.master = {**base, **master}
            res = runner.run(sc, models, paths, progress=False, echo=False, interface=interface)
            if not res.success:
                raise RuntimeError(f"{name}: {res.message}")
            if round_:
                walls[name].append(res.wall_time)
            last[name] = res
        progress(f"model exchange: round {round_}/{repeats}")
    rows = []
    for name, interface, master in SETTINGS:
        res = last[name]
        P = np.stack([res.column(f"ball.{v}") for v in ("xP", "yP", "zP")], axis=1)
        rows.append({"name": name, "interface": interface, "wall": statistics.median(walls[name]),
                     "steps": res.steps, "events": res.events,
                     "dP": float(np.max(np.linalg.norm(P - P_ref, axis=1))),
                     "dN": float(np.max(np.abs(res.column("ball.N") - ref.out["N"])))})
    return rows


def measure_calls(repeats: int, progress=print) -> list[tuple[str, float]]:
    """Microseconds per call (median of ``repeats``): the FMU's Model Exchange evaluations
    against the kernel's right-hand side, at the fast start's state at t = 5 s."""
    from fmpy.fmi2 import FMU2Model, fmi2ValueReference

    from ballmill.physics import fast
    from ballmill.scenario import fmucache, runner

    from .micro import per_call_us

    sc, models, paths = runner.prepare("fast_start", [], log=progress, interface="me")
    sc.stop = 5.0
    model, crank, tr = _library(sc)
    t, y = 5.0, np.ascontiguousarray(tr.y[-1], dtype=float)
    path, md = paths["BallInShell"], models["BallInShell"]
    fmu = FMU2Model(guid=md.guid, unzipDirectory=str(fmucache.extracted(path)),
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="bench")
    fmu.instantiate()
    try:
        vr = {v.name: v.valueReference for v in md.modelVariables}
        p = sc.instances["ball"].parameters
        fmu.setReal([vr[k] for k in p], [float(v) for v in p.values()])
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.newDiscreteStates()
        fmu.enterContinuousTimeMode()
        comp = ctypes.c_void_p(fmu.component)
        bare = {n: runner._bare(fmu, n) for n in ("fmi2SetTime", "fmi2SetContinuousStates", "fmi2GetDerivatives",
                                                    "fmi2SetReal")}
        x = (ctypes.c_double * 6)(*y.tolist())
        dx = (ctypes.c_double * 6)()
        n = ctypes.c_size_t(6)
        names = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
        vrs = (fmi2ValueReference * 6)(*[vr[k] for k in names])
        u = (ctypes.c_double * 6)(*crank.state(t))
        now = ctypes.c_double(t)
        set_t, set_x, get_dx, set_u = (bare[k] for k in ("fmi2SetTime", "fmi2SetContinuousStates",
                                                          "fmi2GetDerivatives", "fmi2SetReal"))
        set_t(comp, now)
        set_u(comp, vrs, n, u)

        def states_and_derivatives():
            set_x(comp, x, n)
            get_dx(comp, dx, n)

        def full_evaluation():
            set_t(comp, now)
            set_x(comp, x, n)
            set_u(comp, vrs, n, u)
            get_dx(comp, dx, n)
        states_and_derivatives()
        fmu_dx = np.array(dx[:])
        P = fast.problem(model, crank)
        f = np.empty(6)
        # called as the FMU's functions are: the bare C function, no argtypes, ready ctypes arguments
        rhs = ctypes.CFUNCTYPE(None)(ctypes.cast(fast._kernel().bm_eval_rhs, ctypes.c_void_p).value)
        Pref, yp, fp = ctypes.byref(P), y.ctypes.data_as(fast._dp), f.ctypes.data_as(fast._dp)
        rhs(Pref, now, yp, fp)
        if not np.allclose(fmu_dx, f, rtol=1e-12, atol=1e-12):  # the same function, or the timing means nothing
            raise RuntimeError(f"the FMU's derivatives {fmu_dx} differ from the kernel's {f}")
        cases = [
            ("BallInShell ME: fmi2SetContinuousStates + fmi2GetDerivatives", states_and_derivatives),
            ("BallInShell ME: fmi2SetTime + fmi2SetContinuousStates + fmi2SetReal (6 inputs) + "
             "fmi2GetDerivatives", full_evaluation),
            ("compiled kernel: bm_eval_rhs (crank acceleration + vector derivative)",
             lambda: rhs(Pref, now, yp, fp)),
        ]
        return [(name, per_call_us(fn, repeats)[0]) for name, fn in cases]
    finally:
        fmu.terminate()
        fmu.freeInstance()


def report(runs, calls, stop: float, command: str) -> str:
    lines = [BEGIN, "## Model Exchange: one ODE for the coupled fast start", "",
             f"Measured by `{command}` (ballmill/bench/model_exchange.py). The coupled fast start "
             f"(MotorStartup + BallInShell, native FMUs, {stop:g} s) through the scenario master, warm "
             f"(libraries loaded by an earlier run), median wall time of interleaved rounds; the differences "
             f"are the largest over the 2 ms grid from the monolithic library (the ball on the exact crank law, "
             f"DOP853 at tol 1e-13).", "",
             "| run | wall time [s] | integrator steps | events | max contact-point difference [m] | "
             "max N difference [N] |", "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in runs:
        steps = f"{r['steps']}" + (" (communication steps)" if r["interface"] == "cs" else "")
        lines.append(f"| {r['name']} | {r['wall']:.3f} | {steps} | {r['events'] if r['interface'] == 'me' else '-'} "
                     f"| {r['dP']:.2e} | {r['dN']:.2e} |")
    cs = next(r for r in runs if r["interface"] == "cs")
    me = next(r for r in runs if r["interface"] == "me")
    lines += ["", f"Model Exchange at its default tolerance costs {me['wall'] / cs['wall']:.1f} x the co-simulation "
              f"run and removes the coupling error: N {cs['dN'] / me['dN']:.0f} x closer to the library. The FMUs' "
              f"calls of one evaluation cost microseconds (below); the rest is the master's Python per evaluation "
              f"(scipy's stepping, the connections resolved at every derivative evaluation, the outputs read at "
              f"every 2 ms grid point from the dense output).",
              "", "One derivative evaluation (ctypes, prebuilt arguments, median of repeats, state of the fast start "
              "at t = 5 s):", "", "| call | time [us] |", "| --- | ---: |"]
    lines += [f"| {name} | {us:.2f} |" for name, us in calls]
    lines += [END, ""]
    return "\n".join(lines)


def run_section(out: Path, quick: bool, repeats: int | None = None, progress=print) -> Path:
    stop = 4.0 if quick else 10.0
    repeats = repeats or (3 if quick else 7)
    runs = measure_runs(repeats, stop, progress)
    calls = measure_calls(7 if not quick else 3, progress)
    command = "ballmill bench --section me" + (" --quick" if quick else "")
    splice_section(out, report(runs, calls, stop, command), BEGIN, END)
    return out
