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
* what each modelling choice of a scene costs per communication step
  (formulation, integrator, corrector, input path, the force outputs).
"""
from __future__ import annotations

import statistics
import subprocess
import sys
import time

import numpy as np

# (label, --set overrides for the ball, scenario) ; communication steps are swept per setting
SETTINGS = [
    ("derivative inputs, RK45 tol 1e-8 (default)", [], "fast_start"),
    ("derivative inputs, DOP853 tol 1e-9", ["ball.integrator=1", "ball.tolerance=1e-9"], "fast_start"),
    ("derivative inputs, RK45 tol 1e-6", ["ball.tolerance=1e-6"], "fast_start"),
    ("positions only, RK45 tol 1e-8", [], "fast_start_positions"),
]
STEPS = (0.002, 0.005, 0.01, 0.02, 0.04)
QUICK_STEPS = (0.005, 0.02)
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
             "steps": c["n_steps"], "success": c["success"]} for c in cases]


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


def report(rows, startup_s, scene, forces_us, literal_at_1e5, target=1e-5) -> list[str]:
    """Markdown lines for BENCHMARKS.md."""
    ok = [r for r in rows if r["success"] and r["dP"] <= target]
    best = min(ok, key=lambda r: r["wall"]) if ok else None
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
             "FMU extraction, instantiation and initialisation (also shown apart) plus the steps. "
             "The runs record only what is compared (ball.xP, yP, zP, N), not every output (a "
             "scenario's default): a scene computes and reads only what it asks for. "
             "Medians of round-robin repeats. " + kernel, ""]
    if best:
        ratio = f"{best['wall'] / literal_at_1e5:.2f}x the" if literal_at_1e5 else "(no paper-literal time)"
        lines += [f"- **coupled at {target:g} m contact-point error**: {best['wall']:.3f} s "
                  f"({best['setting']}, H = {best['step'] * 1e3:g} ms; load and initialisation "
                  f"{best['init']:.3f} s), {ratio} paper-literal monolithic peer at the same error "
                  f"({literal_at_1e5:.3f} s)" if literal_at_1e5 else "", ""]
    lines += [f"- process start to the end of the first communication step (imports, FMU "
              f"extraction and loading, initialisation): {startup_s:.3f} s median", ""]
    lines += ["| setting | H [ms] | max \\|dP\\| [m] | max \\|dN\\| [N] | wall [s] | load+init [s] | steps |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['setting']} | {r['step'] * 1e3:g} | {r['dP']:.2e} | {r['dN']:.2e} | "
                     f"{r['wall']:.3f} | {r['init']:.3f} | {r['steps']} |")
    lines += ["", "### What each modelling choice of a scene costs", "",
              "One BallInShell communication step of 2 ms through fmpy (set inputs + doStep), exact "
              "crank inputs, median of repeats:", "",
              "| choice | us per step |", "| --- | ---: |"]
    for label, us in scene:
        lines.append(f"| {label} | {us:.0f} |")
    lines += ["", f"The force outputs and the validity check (N, F, torques, friction ratio) cost "
              f"{forces_us:.1f} us per evaluation, two per step (the confirmed check at t_k and the "
              f"published outputs at t_k + H); DESIGN.md requires the validity check every step, so "
              f"they are always computed. The ball's orientation is never integrated: the model's "
              f"state is (n, omega) only.", ""]
    return lines
