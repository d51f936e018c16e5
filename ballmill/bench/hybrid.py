"""Benchmark section "The hybrid ball on the event-driven driver" of BENCHMARKS.md.

    ballmill bench --section hybrid [--quick]     run only this section and splice it into the report

What `simulate_hybrid` (ballmill/physics/hybrid.py, on `events.integrate`) costs, in Python and
in the compiled kernel (`fast.hybrid_run`, the same numbers bit for bit), next to the rolling model
it runs while the ball rolls:

1. a scene that stays rolling (the crank start with t0 = 2.5 s over its first 2 s):
   `simulate` in Python and in the kernel, `simulate_hybrid` without and with the energy
   quadrature (the same driver; the hybrid evaluates its guards on each step's dense output),
   in Python and in the kernel;
2. scenes with events: a ball dropped on the bottom of a chamber at rest (flight and impacts
   to rest), the fast crank start with t0 = 0.5 s (slip at once, sliding, sticking; also on
   RK45 at 1e-8, and on the unreduced model without the creeping slide), the
   Fig. 1 machine's first 3 s (slip, flight, impacts): time per simulated second, per
   event (the whole run's time over its events), and the time spent locating the events
   (`events._locate`: regula falsi on the method's own steps) and detecting them
   (`events._detect`: the guards on each step's dense output), timed by wrapping those two
   functions during the run (in Python); and the same run's time in the kernel;
3. the BallInShell FMU, native and pythonfmu, through fmpy's FMU2Slave (as
   bench/flavours.py loads them): the fast start (t0 = 0.5 s, the crank's exact inputs
   x1O..ay1O at each 2 ms communication point, over its first FMU_SPAN seconds: the slide from
   t = 0, rolling, the slide from 0.269 s), contact_model 1 (the rolling model, its validity
   latched at the first slip) against 2 (the hybrid ball), DOP853 at 1e-9 and RK45 at 1e-8
   (the FMU's default): CPU per simulated second, the ratio of the two contact models and of
   the two flavours.

Each time is the median of ``repeats`` runs (after one untimed run), in CPU time of this
process (`time.process_time`; the runs are single-threaded): on a machine shared with other
work, contention for the cores stretches wall time several-fold but not the CPU time a run
takes.
"""
from __future__ import annotations

import statistics
import time
from collections import Counter
from pathlib import Path

from .report import _table, splice_section

BEGIN, END = "<!-- section: hybrid -->", "<!-- end of section: hybrid -->"


def _scenes():
    from ballmill.physics import Ball, CrankStartup, Fixed
    from ballmill.physics.hybrid import Contact
    from ballmill.physics.turning.motions import Fig1Machine

    b = Ball()
    drop = ((0.0, 0.0, b.R - b.d + 0.05), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    return [  # (label, motion, t_end [s], keyword arguments of simulate_hybrid)
        ("ball dropped 5 cm, e_n = 0.5, chamber at rest", Fixed(), 0.5,
         {"contact": Contact(e_n=0.5), "initial": drop}),
        ("fast crank start, t0 = 0.5 s", CrankStartup(l=0.5, n0=60.0, t0=0.5), 1.0, {}),
        # a slide from zero slip on RK45 (the FMU's default), and on the unreduced model (no
        # creeping slide: Coulomb's stiff u/|u| down to zero slip), for comparison
        ("fast crank start, t0 = 0.5 s, RK45 at 1e-8", CrankStartup(l=0.5, n0=60.0, t0=0.5), 1.0,
         {"method": "RK45", "tol": 1e-8}),
        ("fast crank start, t0 = 0.5 s, unreduced (`creep_eps = 0`)", CrankStartup(l=0.5, n0=60.0, t0=0.5), 1.0,
         {"contact": Contact(creep_eps=0.0)}),
        ("Fig. 1 machine, first 3 s", Fig1Machine(), 3.0, {}),
    ]


def _median_time(fn, repeats: int):
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


class _Clock:
    """Wraps a module function, summing the time spent in it and counting its calls."""

    def __init__(self, module, name):
        self.module, self.name, self.inner = module, name, getattr(module, name)
        self.seconds, self.calls = 0.0, 0

    def __enter__(self):
        inner = self.inner

        def timed(*a, **k):
            t0 = time.process_time()
            try:
                return inner(*a, **k)
            finally:
                self.seconds += time.process_time() - t0
                self.calls += 1
        setattr(self.module, self.name, timed)
        return self

    def __exit__(self, *exc):
        setattr(self.module, self.name, self.inner)


FMU_SPAN = 0.5  # s of the fast start the FMU rows simulate
FMU_BUDGET = 5.0  # s of CPU: an FMU run longer than this is timed once, not repeated
FMU_INTEGRATORS = (("DOP853", 1, 1e-9), ("RK45", 2, 1e-8))


def _fmu_cpu(path, contact_model: int, integrator: int, tolerance: float) -> float:
    """CPU seconds of one BallInShell run through fmpy's FMU2Slave: the fast start's exact
    platform motion set at each 2 ms communication point over FMU_SPAN (instantiation and
    initialisation not counted); the FMU's log dropped."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import (FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)

    from ballmill.physics import CrankStartup

    law, h = CrankStartup(l=0.5, n0=60.0, t0=0.5), 0.002
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda *args: None)  # the rolling model's latch warns
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    fmu.instantiate(callbacks=callbacks)
    try:
        fmu.setInteger([vr["contact_model"], vr["integrator"]], [contact_model, integrator])
        fmu.setReal([vr["tolerance"]], [tolerance])
        refs = [vr[n] for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")]
        fmu.setReal(refs, list(law.state(0.0)))
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        t, c0 = 0.0, time.process_time()
        for k in range(int(round(FMU_SPAN / h))):
            fmu.setReal(refs, list(law.state(t)))
            fmu.doStep(t, h)
            t = (k + 1) * h
        cpu = time.process_time() - c0
        fmu.terminate()
    finally:
        fmu.freeInstance()
    return cpu


def measure_fmus(repeats: int, progress=print) -> list:
    """[(flavour, method, {contact_model: (CPU s over FMU_SPAN, runs timed)})]: medians of
    ``repeats`` runs after an untimed one, a run over FMU_BUDGET timed once."""
    from ballmill.fmi import build

    rows = []
    for flavour in ("native", "pythonfmu"):
        (path,) = build.build_all(None, log=progress, flavour=flavour, only=True, names=["BallInShell"])
        for method, integrator, tol in FMU_INTEGRATORS:
            cells = {}
            for cm in (1, 2):
                progress(f"hybrid: BallInShell FMU ({flavour}), {method}, contact_model = {cm}")
                first = _fmu_cpu(path, cm, integrator, tol)
                times = [first] if first > FMU_BUDGET else [_fmu_cpu(path, cm, integrator, tol)
                                                              for _ in range(repeats)]
                cells[cm] = (statistics.median(times), len(times))
            rows.append((flavour, method, cells))
    return rows


def measure(repeats: int, progress=print) -> dict:
    from ballmill.physics import KERNEL_AVAILABLE, Ball, BallModel, CrankStartup, events, simulate
    from ballmill.physics.hybrid import simulate_hybrid

    b = Ball()
    crank = CrankStartup(l=0.5, n0=60.0, t0=2.5)
    t_roll = 2.0
    rolling = [("`simulate`, Python", lambda: simulate(BallModel(b), crank, t_roll, 0.01, kernel="python"))]
    if KERNEL_AVAILABLE:
        rolling.append(("`simulate`, compiled kernel",
                        lambda: simulate(BallModel(b), crank, t_roll, 0.01, kernel="c")))
    rolling += [("`simulate_hybrid(energy=False)`, Python",
                 lambda: simulate_hybrid(b, crank, t_roll, 0.01, energy=False, kernel="python")),
                ("`simulate_hybrid` (with the energy quadrature), Python",
                 lambda: simulate_hybrid(b, crank, t_roll, 0.01, kernel="python"))]
    if KERNEL_AVAILABLE:
        rolling += [("`simulate_hybrid(energy=False)`, compiled kernel",
                     lambda: simulate_hybrid(b, crank, t_roll, 0.01, energy=False, kernel="c")),
                    ("`simulate_hybrid` (with the energy quadrature), compiled kernel",
                     lambda: simulate_hybrid(b, crank, t_roll, 0.01, kernel="c"))]
    roll_rows = []
    for label, fn in rolling:
        progress(f"hybrid: rolling scene, {label}")
        roll_rows.append((label, _median_time(fn, repeats)))
    scene_rows = []
    for label, motion, t_end, kw in _scenes():
        progress(f"hybrid: {label}")

        def run(motion=motion, t_end=t_end, kw=kw, kernel="python"):
            return simulate_hybrid(b, motion, t_end, 0.01, kernel=kernel, **kw)

        cpu = _median_time(run, repeats)
        cpu_c = _median_time(lambda: run(kernel="c"), repeats) if KERNEL_AVAILABLE else None
        locs, dets = [], []
        for _ in range(repeats):
            with _Clock(events, "_locate") as loc, _Clock(events, "_detect") as det:
                tr = run()
            locs.append((loc.seconds, loc.calls))
            dets.append(det.seconds)
        if not tr.success:
            raise RuntimeError(f"hybrid scene {label!r} failed: {tr.message}")
        scene_rows.append({"label": label, "t_end": t_end, "cpu": cpu, "cpu_c": cpu_c, "events": tr.events,
                           "steps": tr.info.steps, "rejected": tr.info.rejected,
                           "locate": statistics.median(s for s, _ in locs), "locate_calls": locs[0][1],
                           "detect": statistics.median(dets)})
    return {"t_roll": t_roll, "rolling": roll_rows, "scenes": scene_rows, "repeats": repeats,
            "fmus": measure_fmus(repeats, progress)}


def report(data: dict, quick: bool) -> str:
    t_roll, reps = data["t_roll"], data["repeats"]
    base = data["rolling"][0][1]
    L = [BEGIN, "## The hybrid ball on the event-driven driver\n",
         f"Measured by `ballmill bench --section hybrid{' --quick' if quick else ''}` "
         f"(ballmill/bench/hybrid.py): `simulate_hybrid` in Python and in the compiled kernel "
         f"(`simulate_hybrid(kernel=\"c\")`: the same numbers bit for bit), CPU time of the process (`time.process_time`: contention on a "
         f"shared machine stretches wall time, not this), medians of {reps} runs. Events are located "
         f"to 1e-11 s on the method's own steps (docs/design.md section 14).\n",
         f"**A scene that stays rolling** (the crank start, t0 = 2.5 s, its first {t_roll:g} s, "
         f"DOP853 at 1e-9, dt = 10 ms): the hybrid runs the rolling model's own right-hand side "
         f"on the same driver and gives its numbers; what it adds is its guards (slip, loss of "
         f"contact) on each step's dense output.\n"]
    L.append(_table(["run", "CPU [ms]", "per simulated second [ms/s]", "vs `simulate`, Python"],
                [[label, f"{w * 1e3:.1f}", f"{w / t_roll * 1e3:.1f}", f"{w / base:.2f}x"]
                 for label, w in data["rolling"]]))
    L.append("\n**Scenes with events** (DOP853 at 1e-9 unless the scene names another method, dt = 10 ms). Per event: the run's time "
             "over its events. Location: the time inside the root finder (`events._locate`, "
             "regula falsi on the method's own step from the step's start), per call (one per "
             "bracketed guard crossing) and its share of the run; detection: the guards on each "
             "step's dense output (`events._detect`), share of the run; both in Python. Kernel: the "
             "same run in the compiled kernel.\n")
    rows = []
    for r in data["scenes"]:
        n = len(r["events"])
        kinds = ", ".join(f"{c} {k}" for k, c in sorted(Counter(e.kind for e in r["events"]).items()))
        calls = max(r["locate_calls"], 1)
        rows.append([r["label"], f"{r['t_end']:g}", f"{n} ({kinds})", f"{r['steps']} ({r['rejected']})",
                     f"{r['cpu'] * 1e3:.0f}", f"{r['cpu'] / r['t_end'] * 1e3:.0f}",
                     f"{r['cpu'] / n * 1e3:.1f}" if n else "-",
                     f"{r['locate'] / calls * 1e3:.2f} ({r['locate'] / r['cpu']:.0%})",
                     f"{r['detect'] / r['cpu']:.0%}",
                     "-" if r.get("cpu_c") is None else
                     f"{r['cpu_c'] * 1e3:.1f} ({r['cpu'] / max(r['cpu_c'], 1e-9):.0f}x faster)"])
    L.append(_table(["scene", "simulated [s]", "events", "steps (rejected)", "CPU [ms]",
                 "per simulated second [ms/s]", "per event [ms]", "location per call [ms] (share)",
                 "detection (share)", "kernel CPU [ms]"], rows))
    if data.get("fmus"):
        L.append(_fmu_table(data["fmus"], reps))
    L.append(END)
    return "\n".join(L) + "\n"


def _fmu_table(fmus, reps: int) -> str:
    native = {method: cells for flavour, method, cells in fmus if flavour == "native"}
    rows = []
    for flavour, method, cells in fmus:
        (c1, n1), (c2, n2) = cells[1], cells[2]
        runs = "" if n1 == n2 == reps else f" ({n1} and {n2} runs)"
        vs = "-" if flavour == "native" else \
            f"{c1 / native[method][1][0]:.0f}x, {c2 / native[method][2][0]:.0f}x"
        rows.append([f"{flavour}{runs}", method, f"{c1 / FMU_SPAN * 1e3:.1f}", f"{c2 / FMU_SPAN * 1e3:.1f}",
                     f"{c2 / c1:.1f}x", vs])
    return ("\n**The BallInShell FMU** through fmpy's FMU2Slave, native and pythonfmu: the fast start "
            f"(t0 = 0.5 s, the crank's exact inputs x1O..ay1O at each 2 ms communication point, its first "
            f"{FMU_SPAN:g} s: slides from t = 0, rolls from 0.073 s, slides again from 0.269 s), contact_model 1 "
            "(the rolling model; its validity latches at the first slip, the integration goes on) against 2 "
            "(the hybrid ball, every event located inside the steps), DOP853 at 1e-9 and RK45 at 1e-8 (the "
            f"FMU's default); CPU per simulated second, medians of {reps} runs (a run over {FMU_BUDGET:g} s of "
            "CPU timed once), instantiation and initialisation not counted. A slide that starts from zero "
            "slip follows its slow manifold (the creeping slide, docs/design.md section 14), so neither "
            "method is held to tiny steps there; what the hybrid adds is its guards and event location, "
            "which the pythonfmu flavour pays in Python.\n\n"
            + _table(["FMU", "integrator", "contact_model = 1 [ms/s]", "contact_model = 2 [ms/s]",
                      "2 vs 1", "vs native (1, 2)"], rows))


def splice(path: Path, section: str):
    """Put the section into the report at path (replacing an earlier one, else appended)."""
    splice_section(path, section, BEGIN, END)


def run_section(out: Path, quick: bool, progress=print) -> Path:
    data = measure(3 if quick else 5, progress)
    splice(out, report(data, quick))
    return out
