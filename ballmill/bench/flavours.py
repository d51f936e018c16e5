"""Benchmark of the two FMU flavours (native C and pythonfmu), for BENCHMARKS.md.

Measures, in one run on this machine:

* the cost of one communication step of each FMU in each flavour through fmpy's
  FMU2Slave (set the inputs, doStep), median of repeats;
* the floor the master itself sets: the same for a native FMU of our own that does
  nothing (ballmill/bench/null_model.c on the project's plumbing): no FMU can be
  cheaper per step through fmpy than that;
* the coupled fast start through fmpy (`ballmill run`'s master) at the default 2 ms
  step, whole run (load, initialisation, steps), native against pythonfmu, with its
  contact-point error against the converged monolithic solution, against the
  paper-literal monolithic program's time at the same error;
* the floor libcosim's master sets: two do-nothing native FMUs connected in a loop;
* the same coupled run through libcosim (native FMUs, an SSP package from
  `ballmill export-ssp`), its time per communication step against the compiled
  kernel's own integration time per step (the monolithic `simulate(kernel="c")` of
  the same problem at the same output step, once for the predictor and once for the
  corrector: what the ball FMU integrates per step);
* the native FMUs' own time per step measured directly, not by subtraction: a minimal
  master in C (coupled_host.c) steps them as libcosim does, timed by CPU time, against
  the kernel's integration timed the same way; and, where `perf` works, their share of
  libcosim's CPU time while it steps (sampled, cpu-clock).
"""
from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

from ..fmi.interface import Interface, Variable

NULL = Interface("Null", "Does nothing: y = u (the master's per-call floor)", (
    Variable("u", "input", 0.0, "Input", unit="1"),
    Variable("y", "output", 0.0, "Output, equal to the input", unit="1", depends=("u",)),
))
H = 0.002


def _instance(path: Path, name: str):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    unzip = extract(str(path))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName=name)
    fmu.instantiate()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def _per_step_us(path: Path, inputs, n_steps: int, repeats: int, integers=None) -> float:
    """Median microseconds per (setReal inputs + doStep) over n_steps steps of H
    (``integers``: Integer parameters to set first, name -> value)."""
    times = []
    for _ in range(repeats):
        fmu, vr = _instance(path, "bench")
        if integers:  # (a motion = 2 scene: its inputs at t = 0 before the initialisation too)
            fmu.setInteger([vr[n] for n in integers], list(integers.values()))
            fmu.setReal([vr[n] for n in inputs(0.0)], list(inputs(0.0).values()))
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        refs = [vr[n] for n in inputs(0.0)]
        t = 0.0
        t0 = time.perf_counter()
        for _ in range(n_steps):
            fmu.setReal(refs, list(inputs(t).values()))
            fmu.doStep(t, H)
            t += H
        times.append((time.perf_counter() - t0) / n_steps * 1e6)
        fmu.terminate()
        fmu.freeInstance()
    return statistics.median(times)


def timed_models(ball_inputs, drive_inputs, fig1_inputs, structure_inputs):
    """(model, inputs(t)) of the FMUs whose step is timed, in the table's order."""
    return (("BallInShell", ball_inputs), ("MotorStartup", drive_inputs), ("InductionMotor", drive_inputs),
            ("Fig1Drive", fig1_inputs), ("Structure", structure_inputs))


# BallInShell's motion = 2 (the general model): the fast start's crank translation on it, and
# the Fig. 1 machine (frame turning, cranks on it)
MOTION2_CASES = ("BallInShell motion=2, crank translation", "BallInShell motion=2, Fig. 1 machine")


def step_costs(repeats: int, n_steps: int, build_dir: Path | None = None):
    """{(model, flavour): us per step} and the do-nothing FMU's us per step."""
    from ..fmi import native
    from ..fmi.build import fmu_path
    from ..physics import CrankStartup

    law = CrankStartup()
    platform = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")

    def ball_inputs(t):
        return dict(zip(platform, law.state(t)))

    def drive_inputs(t):
        return {"M_reaction": 0.0}

    from ..physics.turning import Fig1Machine
    from ..physics.turning.reconstruction import NAMES, inputs_of

    machine, R = Fig1Machine(), 0.25

    def machine_inputs(t):  # the Fig. 1 machine's chamber motion, exact
        return dict(zip(NAMES, inputs_of(machine.state(t), R)))

    def fig1_inputs(t):  # the ball's wrench at rest at the bottom (Fig1Drive's defaults: the Fig. 1 machine)
        return {"Fx": 0.0, "Fy": 0.0, "Fz": -5.0, "MO1x": 0.0, "MO1y": 0.0, "MO1z": 0.0}

    def structure_inputs(t):  # no ball: the structure at rest
        return {"Fx_ball": 0.0, "Fy_ball": 0.0}

    rows = {}
    for model, inputs in timed_models(ball_inputs, drive_inputs, fig1_inputs, structure_inputs):
        for flavour in ("native", "pythonfmu"):
            rows[(model, flavour)] = _per_step_us(fmu_path(model, build_dir, flavour), inputs, n_steps, repeats)
    for case, inputs in zip(MOTION2_CASES, (ball_inputs, machine_inputs)):
        for flavour in ("native", "pythonfmu"):
            rows[(case, flavour)] = _per_step_us(fmu_path("BallInShell", build_dir, flavour), inputs, n_steps,
                                                 repeats, integers={"motion": 2})
    with tempfile.TemporaryDirectory(prefix="ballmill_null_") as tmp:
        null = native.build_native("Null", Path(tmp), NULL, Path(__file__).with_name("null_model.c"))
        floor = _per_step_us(null, lambda t: {"u": t}, n_steps, repeats)
    return rows, floor


def coupled_fast_start(repeats: int, stop: float | None = None):
    """{flavour: (median wall s, load+init s, steps, max contact-point error m)} of the
    fast start through fmpy at H = 2 ms (whole run)."""
    from ..physics import Ball, BallModel, CrankStartup, simulate
    from ..scenario import runner
    from .cosim import COMPARED, _errors

    cases = {}
    for flavour in ("native", "pythonfmu"):
        sc, models, paths = runner.prepare("fast_start", [], log=lambda m: None, flavour=flavour)
        sc.step = H
        if stop is not None:
            sc.stop = stop
        sc.record = list(COMPARED)
        cases[flavour] = (sc, models, paths)
    ref = simulate(BallModel(Ball(), tol=1e-13), CrankStartup(0.5, 60.0, 2.5), cases["native"][0].stop, H)
    out = {}
    walls = {f: [] for f in cases}
    inits = {f: [] for f in cases}
    results = {}
    for _ in range(repeats):  # round-robin
        for flavour, (sc, models, paths) in cases.items():
            res = runner.run(sc, models, paths, progress=False, echo=False)
            walls[flavour].append(res.wall_time)
            inits[flavour].append(res.init_time)
            results[flavour] = res
    for flavour, res in results.items():
        dP, _ = _errors(res, ref)
        out[flavour] = (statistics.median(walls[flavour]), statistics.median(inits[flavour]), res.steps, dP)
    return out


def libcosim_fast_start(repeats: int, stop: float | None = None):
    """(median s of the steps, steps, us per step, median s of loading) of the fast start
    in libcosim with the native FMUs (an SSP package from export-ssp, no observer), or
    None when libcosimpy is not installed."""
    try:
        from libcosimpy.CosimExecution import CosimExecution
    except ImportError:
        return None
    import zipfile

    from ..scenario import ssp

    ssp.set_libcosim_log_level("warning")
    with tempfile.TemporaryDirectory(prefix="ballmill_ssp_bench_") as tmp:
        pkg = ssp.export_ssp("fast_start", Path(tmp) / "fast_start.ssp", [], log=lambda m: None)
        _, ssd_stop, _ = ssp._experiment(ssp.read_ssd(pkg))
        stop = stop or ssd_stop
        unzipped = Path(tmp) / "unzipped"
        zipfile.ZipFile(pkg).extractall(unzipped)
        n = int(round(stop / H))
        step_ns = int(round(H * 1e9))
        loads, walls = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            execution = CosimExecution.from_ssp_file(str(unzipped), step_size=step_ns)
            t1 = time.perf_counter()
            if not execution.simulate_until(n * step_ns):
                raise RuntimeError("libcosim did not complete the fast start")
            walls.append(time.perf_counter() - t1)
            loads.append(t1 - t0)
            del execution
    wall = statistics.median(walls)
    return wall, n, wall / n * 1e6, statistics.median(loads)


def libcosim_floor_us(repeats: int, n_steps: int) -> float | None:
    """us per communication step of two do-nothing native FMUs (null_model.c) connected in a
    loop (y -> u both ways, like the drive and the ball) in libcosim: the floor that
    libcosim's own master sets, whatever the FMUs do. None without libcosimpy."""
    try:
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimSlave import CosimLocalSlave
    except ImportError:
        return None
    from ..fmi import native
    from ..scenario import ssp

    ssp.set_libcosim_log_level("warning")
    vr = {v.name: i for i, v in enumerate(NULL.variables)}
    step_ns = int(round(H * 1e9))
    times = []
    with tempfile.TemporaryDirectory(prefix="ballmill_null_") as tmp:
        null = native.build_native("Null", Path(tmp), NULL, Path(__file__).with_name("null_model.c"))
        for _ in range(repeats):
            execution = CosimExecution.from_step_size(step_ns)
            a = execution.add_local_slave(CosimLocalSlave(str(null), "a"))
            b = execution.add_local_slave(CosimLocalSlave(str(null), "b"))
            execution.connect_real_variables(a, vr["y"], b, vr["u"])
            execution.connect_real_variables(b, vr["y"], a, vr["u"])
            t0 = time.perf_counter()
            if not execution.simulate_until(n_steps * step_ns):
                raise RuntimeError("libcosim did not complete the do-nothing run")
            times.append((time.perf_counter() - t0) / n_steps * 1e6)
            del execution
    return statistics.median(times)


PLATFORM = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")


def fmus_in_c_host(repeats: int, stop: float = 10.0, build_dir: Path | None = None):
    """The native FMUs' own time per communication step of the coupled fast start, measured
    directly: a minimal C master (coupled_host.c, compiled here, no Python in the loop) steps
    MotorStartup -> BallInShell as libcosim does and reads the clock around each FMU's own
    calls. Returns {"both", "both_median", "both_wall", "drive", "ball", "zP", "zP_ref", "steps",
    "cycles"}: us per step of both FMUs (whole runs timed as one, the thread's CPU time: minimum
    and median over `repeats` cycles in one process; both_wall: elapsed, minimum), of each FMU
    (as many cycles with the clock read around its calls: minimum),
    and zP, the contact point's height at `stop`, with the converged monolithic solution's
    zP_ref (a check that the host ran the fast start); None without a C compiler or native
    FMUs."""
    import subprocess

    from ..fmi import native
    from ..fmi.build import fmu_path
    from ..scenario import fmucache

    if not native.has_compiler():
        return None
    libs = {}
    for model in ("MotorStartup", "BallInShell"):
        path = fmu_path(model, build_dir, "native")
        if not native.is_native(path):
            return None
        md = fmucache.model_description(path)
        unzip = fmucache.extracted(path)
        libs[model] = (unzip / "binaries" / native.platform_dir() / f"{model}{native.shared_suffix()}", md.guid,
                       (unzip / "resources").as_uri(), {v.name: v.valueReference for v in md.modelVariables})
    n = int(round(stop / H))
    (dl, dg, dr, dvr), (bl, bg, br, bvr) = libs["MotorStartup"], libs["BallInShell"]
    with tempfile.TemporaryDirectory(prefix="ballmill_host_") as tmp:
        exe = Path(tmp) / "coupled_host"
        cmd = [native.compiler(), "-O2", "-Wall", "-Wextra", "-I", str(native.fmi_headers_dir()),
               str(Path(__file__).with_name("coupled_host.c")), "-o", str(exe), "-ldl"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0 or proc.stderr.strip():
            raise RuntimeError(f"compiling coupled_host.c failed or warned:\n{' '.join(cmd)}\n{proc.stderr}")
        proc = subprocess.run([str(exe), str(dl), dg, dr, str(bl), bg, br, str(n), repr(H), str(2 * repeats),
                               ",".join(str(dvr[v]) for v in PLATFORM), ",".join(str(bvr[v]) for v in PLATFORM),
                               str(bvr["M_reaction"]), str(dvr["M_reaction"]), str(bvr["zP"])],
                              capture_output=True, text=True, timeout=600)
        if proc.returncode != 0:
            raise RuntimeError(f"coupled_host failed ({proc.returncode}): {proc.stderr}")
    rows = [[float(x) for x in line.split()] for line in proc.stdout.split("\n") if line.strip()]
    whole, split = [r for r in rows if r[0] == 0], [r for r in rows if r[0] == 1]
    from ..physics import Ball, BallModel, CrankStartup, simulate
    ref = simulate(BallModel(Ball(), tol=1e-13), CrankStartup(0.5, 60.0, 2.5), n * H, H, kernel="c")
    return {"both": min(r[2] for r in whole), "both_median": statistics.median(r[2] for r in whole),
            "both_wall": min(r[1] for r in whole),
            "drive": min(r[3] for r in split), "ball": min(r[4] for r in split), "zP": rows[-1][5],
            "zP_ref": float(ref["zP"][-1]), "steps": n, "cycles": len(whole)}


def kernel_us_per_step(repeats: int, stop: float = 10.0, statistic=statistics.median, clock=time.perf_counter) -> float:
    """The compiled kernel's integration time per 2 ms interval of the fast start (RK45
    1e-8 as the FMU), times two (predictor and corrector), in us (`statistic` over the
    repeats: the median, or min to compare with the C host's minimum; `clock`: elapsed, or
    time.thread_time for the thread's CPU time, as the C host measures)."""
    from ..physics import Ball, BallModel, CrankStartup, fast, simulate

    if not fast.KERNEL_AVAILABLE:
        return float("nan")
    times = []
    for _ in range(repeats):
        model = BallModel(Ball(), method="RK45", tol=1e-8)
        t0 = clock()
        simulate(model, CrankStartup(0.5, 60.0, 2.5), stop, H, outputs=False, kernel="c")
        times.append(clock() - t0)
    return 2.0 * statistic(times) / round(stop / H) * 1e6


def section(repeats: int, quick: bool, literal_time_at, progress=print) -> list[str]:
    """Markdown lines for BENCHMARKS.md. literal_time_at(err) -> the paper-literal
    monolithic program's time [s] at contact-point error err (or None)."""
    n_steps = 200 if quick else 1000
    stop = 2.0 if quick else None
    progress("flavours: per-step cost of each FMU through fmpy")
    costs, floor = step_costs(repeats, n_steps)
    progress("flavours: coupled fast start through fmpy, native vs pythonfmu")
    coupled = coupled_fast_start(repeats, stop)
    progress("flavours: coupled fast start through libcosim (native FMUs)")
    lc = libcosim_fast_start(repeats, stop)
    lc_floor = libcosim_floor_us(repeats, n_steps * 5) if lc else None
    kernel = kernel_us_per_step(repeats, stop or 10.0)
    progress("flavours: the native FMUs' own time per step (C host) against the kernel's integration")
    host = fmus_in_c_host(max(repeats, 5) * 2, stop or 10.0)
    kernel_min = kernel_us_per_step(max(repeats, 5) * 2, stop or 10.0, statistic=min, clock=time.thread_time)
    share = libcosim_perf_share(stop or 10.0) if lc else None
    lines = ["## Native and pythonfmu FMUs", "",
             "The same FMUs in both flavours (`build/<Model>.fmu`: C, no Python; "
             "`build/pythonfmu/<Model>.fmu`: the Python reference); they give the same results bit for "
             "bit on every scenario (tests/test_flavours.py). "
             + ("Quick run: reduced steps and a 2 s coupled run. " if quick else ""), "",
             "### One communication step through fmpy", "",
             f"Set the inputs, doStep H = {H * 1e3:g} ms; median of {repeats} runs of {n_steps} steps. "
             f"The do-nothing native FMU is the floor that fmpy's per-call cost sets: {floor:.1f} us "
             f"per step.", "",
             "| FMU | native [us] | pythonfmu [us] | pythonfmu / native | native / floor |",
             "| --- | ---: | ---: | ---: | ---: |"]
    for model in [m for m, _ in timed_models(None, None, None, None)] + list(MOTION2_CASES):
        a, b = costs[(model, "native")], costs[(model, "pythonfmu")]
        lines.append(f"| {model} | {a:.1f} | {b:.1f} | {b / a:.1f} | {a / floor:.1f} |")
    m1 = costs[("BallInShell", "native")]
    m2 = costs[("BallInShell motion=2, crank translation", "native")]
    p1 = costs[("BallInShell", "pythonfmu")]
    p2 = costs[("BallInShell motion=2, crank translation", "pythonfmu")]
    lines += ["", f"BallInShell's `motion`: the same crank translation costs {m2 / m1:.2f}x per step "
              f"on the general model (motion = 2) as on the translation-only one (motion = 1) natively, "
              f"{p2 / p1:.2f}x in the pythonfmu flavour; a motion = 1 scene runs the translation-only code "
              f"as before (its outputs are those of the build before motion = 2 existed, bit for bit, tests/test_fmu_chamber.py) "
              f"plus a check that the 18 new inputs hold their defaults and 9 more outputs."]
    lines += ["", "### The coupled fast start, whole run (load, initialisation, steps)", "",
              f"MotorStartup -> BallInShell at H = {H * 1e3:g} ms through `ballmill run`'s fmpy master; "
              f"contact-point error against the converged monolithic solution; medians of {repeats} "
              f"round-robin runs.", "",
              "| flavour | wall [s] | load+init [s] | steps | max \\|dP\\| [m] | paper-literal at that error [s] "
              "| literal / this |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    if stop is not None:  # a shorter run than the literal program's 10 s: no comparison
        literal_time_at = None
    for flavour, (wall, init, steps, dP) in coupled.items():
        lit = literal_time_at(dP) if literal_time_at else None
        lit_s = f"{lit:.3f}" if lit else "-"
        ratio = f"{lit / wall:.1f}" if lit else "-"
        lines.append(f"| {flavour} | {wall:.3f} | {init:.3f} | {steps} | {dP:.2e} | {lit_s} | {ratio} |")
    a, b = coupled["native"][0], coupled["pythonfmu"][0]
    lines += ["", f"Native is {b / a:.1f}x faster than pythonfmu on the whole run." + (
        "" if stop is not None or (literal_time_at and literal_time_at(coupled["native"][3])) else
        " (The paper-literal program's tolerances in this run do not reach the coupled run's "
        "contact-point error: no time at that error.)") + (
        " The paper-literal times here come from the sweep of section 2; the interleaved comparison "
        "at matched errors is in the co-simulation section." if literal_time_at else ""), ""]
    if lc:
        wall, n, us, load = lc
        lines += ["### The same in libcosim (native FMUs, from the SSP export)", "",
                  f"{wall:.3f} s for {n} steps (loading the package and instantiating: {load:.3f} s more): "
                  f"{us:.1f} us per communication step for both FMUs and libcosim's master, against "
                  f"{kernel:.1f} us of the compiled kernel's own integration per step (predictor and "
                  f"corrector, measured as the monolithic `simulate(kernel=\"c\")` of the same problem): "
                  f"{us / kernel:.1f}x the kernel. The floor libcosim's own master sets (two do-nothing native "
                  f"FMUs connected in a loop, {n_steps * 5} steps): {lc_floor:.1f} us per step, so "
                  f"{max(us - lc_floor, 0.0):.1f} us per step are the two FMUs' by subtraction "
                  f"(a difference of two numbers that libcosim's thread hand-offs make noisy: measured "
                  f"directly below).", ""]
    else:
        lines += ["(libcosimpy is not installed: the libcosim row is left out.)", ""]
    lines += _fmus_own_lines(host, kernel_min, share, lc, lc_floor)
    return lines


def _fmus_own_lines(host, kernel_min, share, lc, lc_floor) -> list[str]:
    """Markdown lines: the native FMUs' own time per step against the kernel's integration."""
    lines = ["### The native FMUs' own time per step, measured directly", ""]
    if host is None:
        return lines + ["(no C compiler or no native FMUs: not measured)", ""]
    both, ratio = host["both"], host["both"] / kernel_min
    lines += [f"A minimal master in C (`ballmill/bench/coupled_host.c`, compiled here; no Python in the loop) "
              f"steps MotorStartup -> BallInShell as libcosim does (get outputs, set inputs, doStep both; "
              f"every status checked), {host['steps']} steps of {H * 1e3:g} ms, {host['cycles']} cycles in "
              f"one process (and as many with the clock read around each FMU's calls, for the split): "
              f"the thread's CPU time, minimum over the cycles (the work is deterministic; CPU time and "
              f"the minimum are least disturbed by other processes; elapsed: {host['both_wall']:.2f} us). "
              f"The kernel's integration is timed the same way (CPU time of the thread, minimum). "
              f"It ends at zP = {host['zP']:.9f} m (the converged monolithic solution: "
              f"{host['zP_ref']:.9f} m).", "",
              "| | us per step |", "| --- | ---: |",
              f"| both native FMUs (the loop timed as a whole, CPU time) | {both:.2f} |",
              f"| BallInShell alone (elapsed time around its calls) | {host['ball']:.2f} |",
              f"| MotorStartup alone | {host['drive']:.2f} |",
              f"| the compiled kernel's integration (monolithic, predictor + corrector, minimum) | {kernel_min:.2f} |",
              "",
              f"- **the native FMUs' time per step: {ratio:.2f}x the kernel's integration time** (target: "
              f"within 2x: {'met' if ratio <= 2.0 else 'NOT met'}; median over the cycles "
              f"{host['both_median']:.2f} us). What BallInShell does on top of the integration, every "
              f"step: the input reconstruction (the fit through the input samples), the outputs and the "
              f"validity check at t_k and t_k + H, the coupling-error estimate and the status checks."]
    if lc:
        wall, n, us, load = lc
        lines.append(f"- in libcosim the same step costs {us:.1f} us (its master's floor {lc_floor:.1f} us): "
                     f"the FMUs are {both / us * 100:.0f} % of it by this direct measurement; the rest is "
                     f"libcosim's (its thread pool hands every step to a worker thread and back).")
    if share:
        lines.append(f"- sampled inside libcosim (`perf record`, cpu-clock, {share['samples']} samples in the "
                     f"stepping window only): {share['fmu_pct']:.1f} % of the process's CPU time is in the "
                     f"two FMU libraries and libm (their pow, sincos, hypot), {share['fmu_us']:.2f} us of "
                     f"{share['cpu_us']:.1f} us CPU per step ({share['fmu_us'] / kernel_min:.2f}x the kernel's "
                     f"integration; sampling and the other thread's cache traffic make this the upper "
                     f"figure); libcosim, the C++ runtime and the operating system's thread switches take "
                     f"the rest.")
    return lines + [""]


PERF_SCRIPT = """
import os, sys, time, zipfile
from pathlib import Path
from libcosimpy.CosimExecution import CosimExecution
from ballmill.scenario import ssp
ssp.set_libcosim_log_level("warning")
pkg, unzipped, n, ctl, ack = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
zipfile.ZipFile(pkg).extractall(unzipped)
step_ns = 2000000
execution = CosimExecution.from_ssp_file(str(unzipped), step_size=step_ns)
execution.simulate_until(step_ns)  # initialised, first step taken
def say(word):
    with open(ctl, "w") as f:
        f.write(word + "\\n")
    with open(ack) as f:
        f.read(5)
say("enable")
c0, t0 = time.process_time(), time.perf_counter()
ok = execution.simulate_until((n + 1) * step_ns)
c1, t1 = time.process_time(), time.perf_counter()
say("disable")
print(c1 - c0, t1 - t0, int(bool(ok)))
"""


def libcosim_perf_share(stop: float = 10.0, repeats: int = 1, laps: int = 4):
    """The native FMUs' share of libcosim's CPU time per step, sampled by `perf record`
    (cpu-clock at 10 kHz) only while libcosim steps the fast start (`laps` times `stop`, for
    enough samples: past t0 every step does the same work): samples in BallInShell.so,
    MotorStartup.so and libm (the FMUs' pow, sincos, hypot; nothing else in the process calls
    libm while libcosim steps) count as the FMUs'. Returns
    {"fmu_pct", "fmu_us", "cpu_us", "samples"} (the run with the median share of `repeats`),
    or None when perf is missing or not permitted here."""
    import os
    import shutil
    import subprocess
    import sys

    perf = shutil.which("perf")
    if perf is None:
        return None
    from ..scenario import ssp

    n = int(round(laps * stop / H))
    runs = []
    with tempfile.TemporaryDirectory(prefix="ballmill_perf_") as tmp:
        tmp = Path(tmp)
        pkg = ssp.export_ssp("fast_start", tmp / "fast_start.ssp", [], log=lambda m: None)
        for k in range(repeats):
            ctl, ack, data = tmp / f"ctl{k}", tmp / f"ack{k}", tmp / f"perf{k}.data"
            os.mkfifo(ctl)
            os.mkfifo(ack)
            cmd = [perf, "record", "-q", "-e", "cpu-clock", "-F", "10000", "-D",
                   "-1", "--control", f"fifo:{ctl},{ack}", "-o", str(data), "--", sys.executable, "-c",
                   PERF_SCRIPT, str(pkg), str(tmp / f"u{k}"), str(n), str(ctl), str(ack)]
            try:
                proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            except subprocess.TimeoutExpired:
                return None
            if proc.returncode != 0 or not proc.stdout.strip():
                return None
            cpu, wall, ok = proc.stdout.strip().splitlines()[-1].split()
            if ok != "1":
                return None
            rep = subprocess.run([perf, "report", "-i", str(data), "--stdio", "--sort", "dso"],
                                 capture_output=True, text=True)
            by_dso, total = {}, None
            for line in rep.stdout.splitlines():
                parts = line.split()
                if line.startswith("# Samples:") and len(parts) > 2:
                    total = _count(parts[2])
                if len(parts) >= 2 and parts[0].endswith("%"):
                    by_dso[parts[1]] = float(parts[0].rstrip("%"))
            if not total:
                return None
            fmu = sum(v for k, v in by_dso.items() if k.startswith(("BallInShell", "MotorStartup", "libm.")))
            cpu_us = float(cpu) / n * 1e6
            runs.append({"fmu_pct": fmu, "fmu_us": fmu / 100.0 * cpu_us, "cpu_us": cpu_us, "samples": total})
    runs.sort(key=lambda r: r["fmu_pct"])
    return runs[len(runs) // 2]


def _count(text: str) -> int:
    """perf's sample count, e.g. '12K' or '3456'."""
    text = text.strip()
    scale = {"K": 1000, "M": 1000000}.get(text[-1:], 1)
    return int(float(text.rstrip("KM")) * scale)
