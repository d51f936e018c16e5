"""Co-simulation benchmark: the fast start as two FMUs coupled through fmpy.

Measures, in the same run as the rest of ``ballmill bench``:

* the coupled MotorStartup -> BallInShell fast start for a set of
  communication steps and ball settings: max contact-point and N error
  against a converged monolithic solution on the same grid (the runs record
  only the compared outputs ball.xP, yP, zP, N, not the scenario's default
  of every output), and the wall
  time of a whole ``ballmill run`` (FMU extraction, instantiation and
  initialisation included, reported apart as well), median of repeats taken
  round-robin;
* the time from process start to the first communication step;
* cold and warm whole runs: the first run in a fresh process (FMU files extracted,
  libraries loaded, model descriptions parsed) against later runs, which the runner's
  cache (ballmill.scenario.fmucache) spares that work;
* the coupled run against the paper-literal monolithic program at the same
  contact-point error: the coupled front (error against whole-run time over the
  communication step) and the literal one (error against time over rtol) compared at
  each matched error, re-timed interleaved;
* what each modelling choice of a scene costs per communication step
  (formulation, integrator, corrector, input path, the force outputs).
"""
from __future__ import annotations

import math
import statistics
import subprocess
import sys
import time

import numpy as np

from . import analysis
from .problem import RunResult, round_order

# (label, --set overrides for the ball, scenario) ; communication steps are swept per setting
SETTINGS = [
    ("derivative inputs, RK45 tol 1e-8 (default)", [], "fast_start"),
    ("derivative inputs, DOP853 tol 1e-9", ["ball.integrator=1", "ball.tolerance=1e-9"], "fast_start"),
    ("derivative inputs, RK45 tol 1e-6", ["ball.tolerance=1e-6"], "fast_start"),
    ("positions only, RK45 tol 1e-8", [], "fast_start_positions"),
]
DEFAULT = SETTINGS[0][0]
STEPS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.04)
QUICK_STEPS = (0.002, 0.005, 0.02)
# what the benchmark compares against the reference: a scene computes (and the master reads)
# only what it asks for, so the coupled runs record these and not every output
COMPARED = [("ball", "xP"), ("ball", "yP"), ("ball", "zP"), ("ball", "N")]


def _reference(step, t_end, cache):
    if step not in cache:
        from ballmill.physics import Ball, BallModel, CrankStartup, simulate
        cache[step] = simulate(BallModel(Ball(), tol=1e-13), CrankStartup(0.5, 60.0, 2.5), t_end, step)
    return cache[step]


def _errors(res, ref):
    n = min(len(res.data), len(ref.t))
    dP = np.sqrt(sum((res.column(f"ball.{c}")[:n] - ref[c][:n]) ** 2 for c in ("xP", "yP", "zP")))
    return float(dP.max()), float(np.abs(res.column("ball.N")[:n] - ref["N"][:n]).max())


def coupled(repeats: int, quick: bool, progress=print, t_end: float = 10.0):
    """Rows of (setting, step, dP, dN, wall median, load+init median, steps)."""
    from ballmill.scenario import runner
    steps = QUICK_STEPS if quick else STEPS
    cases = []
    for label, sets, scenario in SETTINGS:
        for h in steps:
            sc, models, paths = runner.prepare(scenario, sets, log=lambda m: None)
            sc.step, sc.stop = h, t_end
            sc.record = list(COMPARED)
            cases.append({"setting": label, "step": h, "sc": sc, "models": models, "paths": paths,
                          "walls": [], "inits": []})
    refs = {}
    for case in cases:  # untimed first run: errors
        res = runner.run(case["sc"], case["models"], case["paths"], progress=False, echo=False)
        case["dP"], case["dN"] = _errors(res, _reference(case["step"], t_end, refs))
        case["success"], case["n_steps"] = res.success, res.steps
    for r in range(repeats):  # round-robin timing
        for case in cases:
            res = runner.run(case["sc"], case["models"], case["paths"], progress=False, echo=False)
            case["walls"].append(res.wall_time)
            case["inits"].append(res.init_time)
        progress(f"co-simulation round {r + 1}/{repeats}")
    return [{"setting": c["setting"], "step": c["step"], "dP": c["dP"], "dN": c["dN"],
             "wall": statistics.median(c["walls"]), "init": statistics.median(c["inits"]),
             "steps": c["n_steps"], "success": c["success"],
             "rerun": lambda c=c: runner.run(c["sc"], c["models"], c["paths"], progress=False, echo=False)}
            for c in cases]


STARTUP = """
import time, sys
t_start = float(sys.argv[1])
from ballmill.scenario import runner
sc, models, paths = runner.prepare("fast_start", log=lambda m: None)
sc.stop = sc.step
sc.record = [("ball", "xP"), ("ball", "yP"), ("ball", "zP"), ("ball", "N")]
res = runner.run(sc, models, paths, progress=False, echo=False)
print(time.time() - t_start)
"""


def startup(repeats: int) -> float:
    """Median seconds from launching a Python process to the end of the first
    communication step of the coupled fast start (FMUs already built)."""
    out = []
    for _ in range(repeats):
        t0 = time.time()
        proc = subprocess.run([sys.executable, "-c", STARTUP, repr(t0)], capture_output=True, text=True,
                              check=True)
        out.append(float(proc.stdout.strip().splitlines()[-1]))
    return statistics.median(out)


COLD = """
import json, sys, time
H = float(sys.argv[1])
from ballmill.scenario import runner, fmucache
import ballmill.fmi.build, ballmill.fmi.native, ballmill.scenario.spec, fmpy.fmi2, fmpy.model_description
t0 = time.perf_counter()
sc, models, paths = runner.prepare("fast_start", log=lambda m: None)  # build check, descriptions parsed
t_prepare = time.perf_counter() - t0
sc.step, sc.stop = H, 10.0
sc.record = [("ball", "xP"), ("ball", "yP"), ("ball", "zP"), ("ball", "N")]
cold = runner.run(sc, models, paths, progress=False, echo=False)
warm = runner.run(sc, models, paths, progress=False, echo=False)
print(json.dumps({"prepare": t_prepare, "cold": cold.wall_time, "cold_init": cold.init_time,
                  "warm": warm.wall_time, "warm_init": warm.init_time, "ok": cold.success and warm.success}))
"""


def cold_warm(repeats: int, steps=(0.04, 0.002)) -> dict:
    """{H: {"prepare", "cold", "cold_init", "warm", "warm_init"}} medians over `repeats` fresh
    processes (imports untimed): ``prepare`` (the build's up-to-date check, parsing the model
    descriptions, checking the scenario), then the first whole run in the process (cold: the
    FMUs extracted and their libraries loaded) and the second (warm: both kept by fmucache)."""
    import json

    out = {}
    for H in steps:
        runs = []
        for _ in range(repeats):
            proc = subprocess.run([sys.executable, "-c", COLD, repr(H)], capture_output=True, text=True, check=True)
            runs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
        if not all(r["ok"] for r in runs):
            raise RuntimeError(f"a cold/warm run of the fast start at H = {H} s failed")
        out[H] = {k: statistics.median(r[k] for r in runs) for k in ("prepare", "cold", "cold_init", "warm",
                                                                     "warm_init")}
    return out


def load_breakdown(repeats: int) -> list[tuple[str, float, float]]:
    """Where a cold start of the two FMUs goes, step by step as a master without a cache
    does it (fmpy: parse the model description, unzip, load the library and bind the fmi2
    functions, instantiate, set up and initialise, the first step, free, remove the files):
    [(part, MotorStartup ms, BallInShell ms)], medians over `repeats` (each from a fresh
    extraction; the library is unloaded between repeats)."""
    import ctypes
    import shutil
    import tempfile
    from pathlib import Path

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from ballmill.fmi import native
    from ballmill.fmi.build import fmu_path

    parts = ["parse and validate the model description (fmpy)", "unzip the whole FMU (fmpy.extract)",
             "unzip without sources/ (what fmucache extracts)", "dlopen the binary",
             "fmpy binding its fmi2 functions (FMU2Slave; the library already loaded)", "fmi2Instantiate",
             "setupExperiment, enter and exit initialisation (the FMU's own setup)",
             "first doStep (40 ms)", "terminate and free the instance", "remove the extracted files"]
    times = {(m, p): [] for m in ("MotorStartup", "BallInShell") for p in parts}
    for _ in range(repeats):
        for model in ("MotorStartup", "BallInShell"):
            path = str(fmu_path(model))
            lap = [time.perf_counter()]

            def tick(part):
                now = time.perf_counter()
                times[(model, part)].append((now - lap[0]) * 1e3)
                lap[0] = time.perf_counter()
            md = read_model_description(path)
            tick(parts[0])
            # the two extractions in alternating order, so neither always comes first
            for part in (parts[1], parts[2]) if len(times[(model, parts[1])]) % 2 == 0 else (parts[2], parts[1]):
                lap[0] = time.perf_counter()
                if part == parts[1]:
                    d = extract(path)
                else:
                    d2 = extract(path, tempfile.mkdtemp(),
                                 include=lambda n: not n.startswith(("sources/", "documentation/")))
                tick(part)
            lib = Path(d) / "binaries" / native.platform_dir() / f"{model}{native.shared_suffix()}"
            handle = ctypes.CDLL(str(lib))
            tick(parts[3])
            fmu = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=model, instanceName="x")
            tick(parts[4])
            fmu.instantiate()
            tick(parts[5])
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            tick(parts[6])
            fmu.doStep(0.0, 0.04)
            tick(parts[7])
            fmu.terminate()
            fmu.freeInstance()
            tick(parts[8])
            shutil.rmtree(d)
            tick(parts[9])
            from fmpy import freeLibrary
            freeLibrary(handle._handle)
            shutil.rmtree(d2, ignore_errors=True)
    return [(p, statistics.median(times[("MotorStartup", p)]), statistics.median(times[("BallInShell", p)]))
            for p in parts]


def _coupled_result(row) -> RunResult:
    r = RunResult("coupled (fmpy)", "co-simulation", f"H {row['step'] * 1e3:g} ms", row["step"],
                  err_P=row["dP"], err_N=row["dN"], wall=row["wall"], ok=row["success"])
    r.extra["row"] = row
    return r


def matched(lit, rows, repeats: int, progress=print):
    """The coupled fast start (default ball setting, whole runs over the communication step)
    against the paper-literal program (over rtol) at matched contact-point errors.

    Both fronts are Pareto fronts of error against wall time. At each coupled point whose
    error the literal front reaches, the literal time is interpolated (log-log) between the
    two literal front points around that error; at each literal front point inside the
    coupled front's range of errors, the coupled time likewise. Every point involved is
    re-timed round-robin (`repeats` rounds, order shuffled per round), coupled and literal in
    the same rounds, and the ratios use those medians. Returns a dict with the rows."""
    coupled = [_coupled_result(r) for r in rows if r["setting"] == DEFAULT and r["success"]]
    c_front, l_front = analysis.pareto(coupled), analysis.pareto(lit)
    if not c_front or not l_front:
        return None
    timed = {}
    pairs = []  # (which side is measured, its point, AtError on the other front)
    for c in c_front:
        at = analysis.time_at_error(l_front, c.err_P)
        pairs.append(("coupled", c, at))
        timed[id(c)] = c
        for r in (at.bracket or ((at.cheapest,) if at.cheapest else ())):
            timed[id(r)] = r
    e_lo, e_hi = min(c.err_P for c in c_front), max(c.err_P for c in c_front)
    for r in l_front:
        if e_lo <= r.err_P <= e_hi:
            at = analysis.time_at_error(c_front, r.err_P)
            pairs.append(("literal", r, at))
            timed[id(r)] = r
            for c in (at.bracket or ((at.cheapest,) if at.cheapest else ())):
                timed[id(c)] = c
    walls = {k: [] for k in timed}
    inits = {k: [] for k in timed}
    items = list(timed.items())
    for j in range(repeats):
        for k, r in round_order(items, j):
            if r.family == "paper-literal":
                t0 = time.perf_counter()
                r.extra["rerun"]()
                walls[k].append(time.perf_counter() - t0)
            else:
                res = r.extra["row"]["rerun"]()
                walls[k].append(res.wall_time)
                inits[k].append(res.init_time)
        progress(f"matched errors: round {j + 1}/{repeats} ({len(items)} runs)")
    med = {k: statistics.median(v) for k, v in walls.items()}

    def wall_of(r):
        return med[id(r)]

    out = []
    for side, r, at in pairs:
        other = analysis.retimed(at, wall_of) if at.time is not None else None
        if side == "coupled":
            c_wall, l_wall = wall_of(r), other
            init = statistics.median(inits[id(r)])
            how = (f"rtol {at.bracket[0].param:g} .. {at.bracket[1].param:g}" if at.bracket else
                   f"rtol {at.cheapest.param:g} (more accurate)" if at.cheapest else "not reached")
            out.append({"error": r.err_P, "coupled": c_wall, "init": init, "coupled_at": r.setting,
                        "literal": l_wall, "literal_at": how, "bracketed": bool(at.bracket)})
        else:
            if at.time is None:
                continue
            how = (f"H {at.bracket[0].param * 1e3:g} .. {at.bracket[1].param * 1e3:g} ms" if at.bracket
                   else f"{at.cheapest.setting} (more accurate)")
            init = statistics.median([x for c in (at.bracket or (at.cheapest,)) for x in inits[id(c)]])
            out.append({"error": r.err_P, "coupled": other, "init": init, "coupled_at": how,
                        "literal": wall_of(r), "literal_at": r.setting, "bracketed": bool(at.bracket)})
    out.sort(key=lambda x: -x["error"])
    return {"rows": out, "rounds": repeats}


def literal_floor(lit, ref_P, grid, t0: float = 2.5) -> list[str]:
    """Lines on how far the paper-literal program's error falls with rtol, where it stops,
    and why (from the sweep's own results; ref_P: the reference contact points on grid)."""
    ok = sorted((r for r in lit if r.ok), key=lambda r: -r.param)
    if not ok:
        return []
    best = min(ok, key=lambda r: r.err_P)
    lines = ["- The paper-literal program's rtol sweep (scipy's solve_ivp RK45, atol = rtol x the "
             "state's scale), contact-point error against the converged reference: "
             + ", ".join(f"rtol {r.param:g}: {r.err_P:.2e} m" for r in ok) + "."]
    # where a tighter rtol buys less than a factor 2 (or nothing)
    for a, b in zip(ok, ok[1:]):
        if b.err_P <= a.err_P / 2.0 or b is best:
            continue
        where = ""
        sample = b.extra.get("sample")
        if sample is not None:
            dP = np.linalg.norm(sample.P - ref_P, axis=1)
            before, after = float(dP[grid < t0 - 1e-9].max()), float(dP[grid >= t0 - 1e-9].max())
            where = (f" At rtol {b.param:g} the error up to t0 = {t0:g} s is {before:.1e} m and after it "
                     f"{after:.1e} m: it is made where the start-up law's jerk jumps (t0), across which "
                     f"the adaptive step accepts a larger error than elsewhere;")
        change = "rises" if b.err_P >= a.err_P else "falls only"
        lines.append(f"- From rtol {a.param:g} to {b.param:g} the error {change} from {a.err_P:.2e} to "
                     f"{b.err_P:.2e} m.{where} tighter tolerances resolve it.")
    if ok[-1].param > 1e-13:  # the sweep stopped short of scipy's smallest rtol (quick runs)
        lines.append(f"- The smallest error of this run's sweep: {best.err_P:.1e} m (rtol {best.param:g}, "
                     f"{best.wall:.2f} s); the full run goes down to scipy's smallest rtol.")
        return lines
    lines.append(f"- The error stops falling at {best.err_P:.1e} m (rtol {best.param:g}, {best.wall:.2f} s; scipy "
                 f"accepts no rtol below 100 machine epsilons, 2.2e-14): there the literal program agrees "
                 f"with the reference to the reference's own accuracy (the reference and the independent "
                 f"solutions of the convergence checks in section 2 agree to a few 1e-13 m), so that is its "
                 f"floor as measured here: it is not the program's accuracy but the measurement's.")
    return lines


def scene_costs(repeats: int, n_steps: int = 400, H: float = 0.002):
    """Microseconds per BallInShell communication step (direct FMI calls through
    fmpy, exact crank inputs) for each modelling choice, and the cost of one
    evaluation of the force outputs."""
    import timeit

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from ballmill.fmi.build import fmu_path
    from ballmill.physics import Ball, BallModel, CrankStartup

    path = str(fmu_path("BallInShell"))
    md = read_model_description(path)
    unzip = extract(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    inputs = [vr[n] for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")]
    law = CrankStartup()
    choices = [
        ("default: vector, RK45 1e-8, derivative inputs, corrector", {}),
        ("corrector off", {"corrector": False}),
        ("positions only (corrector over 5 steps)", {"input_mode": 2}),
        ("paper formulation", {"formulation": 2}),
        ("RK4, h = 1 ms", {"integrator": 3}),
        ("DOP853 tol 1e-9", {"integrator": 1, "tolerance": 1e-9}),
    ]
    rows = []
    for label, params in choices:
        times = []
        for _ in range(repeats):
            fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="BallInShell",
                            instanceName="bench")
            fmu.instantiate()
            for k, v in params.items():
                (fmu.setBoolean if isinstance(v, bool) else fmu.setInteger if isinstance(v, int)
                 else fmu.setReal)([vr[k]], [v])
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            t = 0.0
            t0 = time.perf_counter()
            for _ in range(n_steps):
                fmu.setReal(inputs, list(law.state(t)))
                fmu.doStep(t, H)
                t += H
            times.append((time.perf_counter() - t0) / n_steps * 1e6)
            fmu.terminate()
            fmu.fmi2FreeInstance(fmu.component)
        rows.append((label, statistics.median(times)))
    model = BallModel(Ball())
    state = model.initial(0.05, 0.0)
    forces = min(timeit.repeat(lambda: model.outputs(state, 1.0, 2.0, 0.5, 0.1), number=2000,
                               repeat=5)) / 2000 * 1e6
    return rows, forces


def report(rows, startup_s, scene, forces_us, cw=None, match=None, floor_lines=(), breakdown=None,
           target=1e-5) -> list[str]:
    """Markdown lines for BENCHMARKS.md."""
    from ballmill.physics import fast

    if fast.KERNEL_AVAILABLE:
        kernel = ("The FMUs are the native flavour (C on the compiled kernel, build/<Model>.fmu); the "
                  "next section compares them with the pythonfmu flavour.")
    else:
        kernel = (f"BallInShell integrates in pure Python (compiled kernel unavailable: "
                  f"{fast.KERNEL_REASON}).")
    lines = ["## Co-simulation through fmpy (MotorStartup -> BallInShell)", "",
             "The fast start as two FMUs coupled by `ballmill run`'s master (Jacobi, fixed step), "
             "against the converged monolithic solution on the same grid. Wall time is a whole run: "
             "instantiation and initialisation of both FMUs (also shown apart as load+init) plus the "
             "steps and freeing the instances. The runner keeps each FMU's parsed model description, "
             "extracted files and loaded library between runs in a process, keyed by the FMU file's "
             "content (`ballmill.scenario.fmucache`), as FMI tools do; these are warm runs (the first "
             "run in a process, cold, is measured apart below). "
             "The runs record only what is compared (ball.xP, yP, zP, N), not every output (a "
             "scenario's default): a scene computes and reads only what it asks for. "
             "Medians of round-robin repeats. " + kernel, ""]
    if match and match["rows"]:
        ms = match["rows"]
        ratios = [m["literal"] / m["coupled"] for m in ms if m["literal"] and m["coupled"]]
        at_default = next((m for m in ms if m["coupled_at"] == "H 2 ms"), None)
        near = min((m for m in ms if m["literal"]), key=lambda m: abs(math.log(m["error"] / target)), default=None)
        lines += ["### Against the paper-literal program at the same contact-point error", "",
                  "Two Pareto fronts of contact-point error against wall time: the coupled run (default "
                  "ball setting, whole runs, over the communication step H) and the paper-literal "
                  "monolithic program (scipy RK45 and outputs, over rtol). Each row matches one front's "
                  "point with the other front interpolated (log-log) at its error; all points re-timed "
                  f"interleaved in the same {match['rounds']} rounds (medians).", ""]
        if ratios:
            lines.append(f"- **literal / coupled: {min(ratios):.1f}x to {max(ratios):.1f}x over the "
                         f"{len(ratios)} matched errors from {min(m['error'] for m in ms):.1e} to "
                         f"{max(m['error'] for m in ms):.1e} m** (target: at least 5x at every matched "
                         f"error: {'met' if min(ratios) >= 5.0 else 'NOT met'})")
        if at_default and at_default["literal"]:
            lines.append(f"- at the default step's error ({at_default['error']:.2e} m, H = 2 ms): coupled "
                         f"{at_default['coupled']:.3f} s (load+init {at_default['init'] * 1e3:.1f} ms), "
                         f"paper-literal {at_default['literal']:.3f} s ({at_default['literal_at']}): "
                         f"**{at_default['literal'] / at_default['coupled']:.1f}x**")
        elif at_default:
            lines.append(f"- at the default step's error ({at_default['error']:.2e} m): the literal program's "
                         f"sweep does not reach it")
        if near and near["literal"] and near["coupled"]:
            lines.append(f"- nearest {target:g} m ({near['error']:.2e} m, coupled {near['coupled_at']}): coupled "
                         f"{near['coupled']:.4f} s (load+init {near['init'] * 1e3:.1f} ms), paper-literal "
                         f"{near['literal']:.4f} s: **{near['literal'] / near['coupled']:.1f}x**")
        low = [m for m in ms if m["literal"] and m["coupled"] and m["literal"] / m["coupled"] < 5.0]
        if low:
            lines.append("- below 5x at: " + ", ".join(f"{m['error']:.1e} m ({m['literal'] / m['coupled']:.1f}x)"
                                                        for m in low))
        lines += ["", "| matched error [m] | coupled at | coupled whole run [s] | of which load+init [ms] "
                  "| paper-literal at | paper-literal [s] | literal / coupled |",
                  "| ---: | --- | ---: | ---: | --- | ---: | ---: |"]
        for m in ms:
            lit_s = f"{m['literal']:.4f}" if m["literal"] else "-"
            ratio = f"{m['literal'] / m['coupled']:.1f}" if m["literal"] and m["coupled"] else "-"
            lines.append(f"| {m['error']:.2e} | {m['coupled_at']} | {m['coupled']:.4f} | {m['init'] * 1e3:.2f} | "
                         f"{m['literal_at']} | {lit_s} | {ratio} |")
        lines += [""] + list(floor_lines) + [""]
    if breakdown:
        lines += ["### Where loading and initialising the FMUs goes", "",
                  "Each part of a cold start as a master without a cache does it (fmpy, one FMU after the "
                  "other, each from a fresh extraction), milliseconds, medians. Only `fmi2Instantiate`, "
                  "the set-up and the first step are the FMUs' own work; `ballmill run` keeps the "
                  "parsed description, the extracted files (without `sources/`) and the loaded, bound "
                  "library between runs in a process (`ballmill.scenario.fmucache`), so a warm run pays "
                  "only those and freeing the instance.", "",
                  "| part | MotorStartup [ms] | BallInShell [ms] |", "| --- | ---: | ---: |"]
        for part, a, b in breakdown:
            lines.append(f"| {part} | {a:.3f} | {b:.3f} |")
        lines.append("")
    if cw:
        lines += ["### Cold and warm runs", "",
                  "A fresh process per measurement (imports untimed), medians over repeats: `prepare` "
                  "(the build's up-to-date check, parsing the model descriptions, checking the scenario), "
                  "then the first whole run in the process (cold: the FMUs extracted, their libraries "
                  "loaded and fmpy's function table built) and a second one (warm).", "",
                  "| H [ms] | prepare [ms] | cold run [s] | cold load+init [ms] | warm run [s] | warm load+init [ms] |",
                  "| ---: | ---: | ---: | ---: | ---: | ---: |"]
        for H, c in cw.items():
            lines.append(f"| {H * 1e3:g} | {c['prepare'] * 1e3:.1f} | {c['cold']:.4f} | {c['cold_init'] * 1e3:.1f} | "
                         f"{c['warm']:.4f} | {c['warm_init'] * 1e3:.2f} |")
        lines.append("")
        if match and match["rows"]:
            for H, c in cw.items():
                m = next((m for m in match["rows"] if m["coupled_at"] == f"H {H * 1e3:g} ms" and m["literal"]), None)
                if m:
                    lines.append(f"- cold at H = {H * 1e3:g} ms against the literal program at its error "
                                 f"({m['error']:.1e} m): {m['literal'] / (c['cold'] + c['prepare']):.1f}x with "
                                 f"`prepare` and the cold run counted ({m['literal'] / c['cold']:.1f}x the cold "
                                 f"run alone; the literal program's own imports, numpy and scipy, are not counted "
                                 f"either)")
            lines.append("")
    lines += ["### Every setting and communication step", "",
              f"- process start to the end of the first communication step (imports, FMU "
              f"extraction and loading, initialisation): {startup_s:.3f} s median", ""]
    lines += ["| setting | H [ms] | max \\|dP\\| [m] | max \\|dN\\| [N] | wall [s] | load+init [s] | steps |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['setting']} | {r['step'] * 1e3:g} | {r['dP']:.2e} | {r['dN']:.2e} | "
                     f"{r['wall']:.4f} | {r['init']:.4f} | {r['steps']} |")
    lines += ["", "### What each modelling choice of a scene costs", "",
              "One BallInShell communication step of 2 ms through fmpy (set inputs + doStep), exact "
              "crank inputs, median of repeats:", "",
              "| choice | us per step |", "| --- | ---: |"]
    for label, us in scene:
        lines.append(f"| {label} | {us:.0f} |")
    lines += ["", f"The force outputs and the validity check (N, F, torques, friction ratio) cost "
              f"{forces_us:.1f} us per evaluation, two per step (the confirmed check at t_k and the "
              f"published outputs at t_k + H); docs/design.md section 3 requires the validity check every step, so "
              f"they are always computed. The ball's orientation is never integrated: the model's "
              f"state is (n, omega) only.", ""]
    return lines
