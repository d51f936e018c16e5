"""The `ballmill` command: build the FMUs, run scenarios, benchmark.

    ballmill build [--force]                 build and validate every FMU, both flavours: native
                                             (C) in build/, pythonfmu in build/pythonfmu/
    ballmill run SCENARIO [--out DIR] [--set inst.param=value ...] [--flavour pythonfmu]
                 [--interface cs|me] [--quiet]
                                             exit status: 0 ran and stayed valid, 1 an FMU stopped
                                             the run, 2 bad scenario or value (every problem listed
                                             before anything runs), 3 ran but the ball model's
                                             validity ended (statistics over the valid span only);
                                             builds the FMUs the scenario uses when needed, and
                                             says so; --quiet: only errors, nothing on success
    ballmill bench [...]                      speed/accuracy map -> BENCHMARKS.md
    ballmill export-ssp SCENARIO OUT.ssp [--set inst.param=value ...]
                                             the scenario as an SSP package for other FMI tools
    ballmill sweep SCENARIO|STUDY [--grid inst.param=VALUES ...] [--out DIR] [...]
                                             a design study: many points, one row each in
                                             DIR/results.parquet (see ballmill sweep -h); a ball
                                             absorber study (absorber_frf: --mode steady|up|down|both)
                                             also DIR/frf.csv and DIR/frf.png; exit status: 0 done
                                             (the failed points and the first reason on stderr),
                                             1 every point failed, 2 bad study or values (checked
                                             before any point runs, as ballmill run checks them)
    ballmill steady [--n0 ...] [--l ...] [--r ...] [--R ...] [--mu ...]
                                             the ball's relative equilibrium on the crank circle
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path


class _Phases:
    """Wall-clock marks (time.perf_counter, the system's monotonic clock: comparable with the
    clock of the process that started this one) at the ends of a command's phases. With
    $BALLMILL_PHASES set to a file name they are written there as JSON when the command ends
    (ballmill bench's start-up section reads them); otherwise they cost nothing."""

    def __init__(self):
        self.marks = [("cli imported", time.perf_counter())]
        self.extra = {}

    def __call__(self, name: str) -> None:
        self.marks.append((name, time.perf_counter()))

    def write(self) -> None:
        path = os.environ.get("BALLMILL_PHASES")
        if path:
            Path(path).write_text(json.dumps({"marks": self.marks, **self.extra}))


_phases = _Phases()


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def _build(args) -> int:
    from .fmi import build
    build_dir = Path(args.build_dir) if args.build_dir else None
    try:
        paths = build.build_all(build_dir, force=args.force, log=_say)
    except build.BuildError as e:
        print(f"ballmill build: {e}", file=sys.stderr)
        return 1
    print(f"{len(paths)} FMUs, both flavours, built, validated and up to date: native in "
          f"{build.fmu_path('', build_dir).parent}, pythonfmu in {build.fmu_path('', build_dir, 'pythonfmu').parent}")
    return 0


def _run(args) -> int:
    from .fmi.build import BuildError
    from .scenario import report, runner
    from .scenario.spec import ScenarioError
    _phases("imports")
    say = (lambda m: None) if args.quiet else _say  # --quiet: only errors
    try:
        sc, models, paths = runner.prepare(args.scenario, args.set or (),
                                           Path(args.build_dir) if args.build_dir else None,
                                           log=say, flavour=args.flavour, interface=args.interface)
    except (ScenarioError, BuildError) as e:
        print(f"ballmill run: {e}", file=sys.stderr)
        return 2
    _phases("prepare")  # the build check, the scenario and the model descriptions it uses
    out = Path(args.out or Path("out") / sc.name)
    say(f"running {sc.name}: {sc.description}")
    res = runner.run(sc, models, paths, progress=not args.quiet, echo=not args.quiet, interface=args.interface)
    _phases("run")
    _phases.extra.update(init_s=res.init_time, wall_s=res.wall_time)  # FMU load + initialisation, of the run
    bare = None
    structure = sc.summary.get("structure")
    if structure and sc.summary.get("bare", True) and res.success:
        ball = report._ball_instance(res)
        say(f"running {sc.name} again without {ball!r}: the bare structure")
        bare = runner.run(runner.without(sc, ball, [(structure, v) for v in report.STRUCTURE_RECORD]),
                          models, paths, progress=not args.quiet, echo=not args.quiet, interface=args.interface)
    if bare is not None:
        _phases("bare run")
    summary = report.write_all(res, models, out, bare)
    _phases("results and plots")
    if not args.quiet:
        brief = {k: summary.get(k) for k in ("success", "message", "wall_time_s", "statistics_over", "N", "ring",
                                             "zP_max_m", "M_reaction_peak_abs_Nm", "structure", "validity",
                                             "t_invalid_s")
                 if k in summary}
        print(json.dumps(brief, indent=2))
        say(f"results: {out / 'results.csv'}, {out / 'summary.json'}, plots: "
            f"{', '.join(str(out / p) for p in summary.get('plots', []))}")
    if not res.success:
        if args.quiet:  # otherwise the summary above says it
            print(f"ballmill run: {sc.name} stopped: {res.message}", file=sys.stderr)
        return 1
    if summary.get("left_validity"):
        print(f"ballmill run: the model's validity ended at t = {summary['t_invalid_s']:.6g} s; the "
              f"statistics cover the valid span only (exit status 3)", file=sys.stderr)
        return 3
    return 0


def _export_ssp(args) -> int:
    from .fmi.build import BuildError
    from .scenario import ssp
    from .scenario.spec import ScenarioError
    try:
        out = ssp.export_ssp(args.scenario, args.out, args.set or (),
                             Path(args.build_dir) if args.build_dir else None,
                             log=lambda m: print(m, file=sys.stderr))
    except (ScenarioError, BuildError) as e:
        print(f"ballmill export-ssp: {e}", file=sys.stderr)
        return 2
    print(f"wrote {out} (run it in libcosim, e.g. ballmill.scenario.ssp.run_ssp_libcosim; "
          f"see docs/OTHER_TOOLS.md)", file=sys.stderr)
    return 0


def _bench(args, rest) -> int:
    from . import bench
    return bench.main(rest)


def _sweep(args) -> int:
    from .sweep import engine, spec
    try:
        grid = dict(spec.parse_grid_option(g) for g in (args.grid or ()))
        sample = spec.parse_sample_option(args.sample) if args.sample else None
        if sample is not None:
            sample["ranges"] = dict(spec.parse_grid_option(r) for r in (args.range or ()))
        elif args.range:
            raise spec.StudyError(["--range needs --sample lhs:N or random:N"])
        model = {k: v for k, v in (("kind", args.model), ("method", args.method), ("h", args.h),
                                   ("dt", args.dt), ("target_P", args.target), ("error", args.error))
                 if v is not None}
        study = spec.load(args.study, set_=args.set or (), grid=grid or None, sample=sample, model=model,
                          stop=args.stop, mode=args.mode)
        if not study.swept:
            raise spec.StudyError(["nothing to sweep: give --grid inst.param=VALUES or --sample with --range "
                                   "(or a study file with [grid] or [sample])"])
        out = Path(args.out or Path("out") / "sweep" / study.name)
        scheduler = "in-process" if args.in_process else args.scheduler
        n_points = len(study.points())
        print(f"sweep {study.name}: {n_points} points over {', '.join(study.swept)} -> {out}", file=sys.stderr)
        res = engine.run_study(study, out, scheduler=scheduler, workers=args.workers, batch=args.batch,
                               retry_failed=args.retry_failed, progress=not args.quiet,
                               build_dir=Path(args.build_dir) if args.build_dir else None,
                               plots=not args.no_plots)
    except (spec.StudyError, ValueError) as e:
        print(f"ballmill sweep: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # a scheduler that cannot be reached, an unwritable --out
        print(f"ballmill sweep: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    rate = res.computed / res.run_s if res.run_s > 0 and res.computed else 0.0
    print(json.dumps({"results": str(res.results), "points": len(res.rows), "computed": res.computed,
                      "skipped (already in the results)": res.skipped, "failed": res.failed,
                      "evaluator": res.evaluator, "executor": res.executor, "batch": res.batch,
                      "wall_s": round(res.wall_s, 3), "compute_s": round(res.compute_s, 3),
                      "points_per_s (first task to last result)": round(rate, 1),
                      "timing": str(res.out_dir / "timing.json"), "plots": [str(p) for p in res.plots]}, indent=2))
    failed = [r for r in res.rows if r.get("status") != "ok"]
    if failed:
        first = failed[0]
        values = ", ".join(f"{k} = {first.get(k)!r}" for k in study.swept if k in first)
        what = f"the first (point {first.get('point')}{': ' + values if values else ''}): {first.get('message')}"
        if len(failed) == len(res.rows):
            print(f"ballmill sweep: all {len(res.rows)} points failed; {what}", file=sys.stderr)
            return 1
        print(f"ballmill sweep: {len(failed)} of {len(res.rows)} points failed; {what}", file=sys.stderr)
    return 0


def _design_options(p, what: str):
    """What `ballmill optimize` and `ballmill sensitivity` accept besides their own options."""
    p.add_argument("study", help="a study file (scenarios/studies/NAME.toml or a path) with [variables] and "
                                 f"[{what}]")
    p.add_argument("--out", help=f"output folder (default: out/{what}/STUDY); re-running resumes")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786), or local (a Dask LocalCluster); default: "
                        "Dask's local processes scheduler, workers forked from this one")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    p.add_argument("--in-process", action="store_true", help="no Dask: compute the batches in this process")
    p.add_argument("--batch", type=int, help="points per task (default: about 8 tasks per worker and batch)")
    p.add_argument("--no-plots", action="store_true", help="write no PNGs")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--build-dir", help="where the FMUs are (co-simulated points only)")


def _design_run(args, command: str, body) -> int:
    """A design command's errors as `ballmill sweep` reports them: 2 for a bad study, 1 for a
    scheduler that cannot be reached or an unwritable --out."""
    from .sweep import spec
    try:
        return body()
    except (spec.StudyError, ValueError) as e:
        print(f"ballmill {command}: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"ballmill {command}: {type(e).__name__}: {e}", file=sys.stderr)
        return 1


def _design_kw(args) -> dict:
    return dict(scheduler="in-process" if args.in_process else args.scheduler, workers=args.workers,
                batch=args.batch, build_dir=Path(args.build_dir) if args.build_dir else None,
                progress=not args.quiet, plots=not args.no_plots)


def _optimize(args) -> int:
    def body():
        from .sweep import optimize
        prob = optimize.load(args.study, population=args.population, generations=args.generations, seed=args.seed)
        out = Path(args.out or Path("out") / "optimize" / prob.ds.study.name)
        print(f"optimize {prob.ds.study.name}: {prob.algorithm}, {prob.population} x {prob.generations} designs "
              f"over {', '.join(prob.ds.names)} -> {out}", file=sys.stderr)
        res = optimize.run(prob, out, **_design_kw(args))
        print(json.dumps(optimize.summary(prob, res), indent=2))
        if not res.best:
            print(f"ballmill optimize: no feasible design among {len(res.session.order)} evaluations "
                  f"(see {res.session.out_dir / 'results.parquet'}: margin:* and violation)", file=sys.stderr)
            return 1
        return 0
    return _design_run(args, "optimize", body)


def _sensitivity(args) -> int:
    def body():
        from .sweep import sensitivity
        an = sensitivity.load(args.study, N=args.N, seed=args.seed)
        out = Path(args.out or Path("out") / "sensitivity" / an.ds.study.name)
        n = an.N * (len(an.ds.names) + 2)
        print(f"sensitivity {an.ds.study.name}: Sobol indices of {', '.join(an.indicators)} over "
              f"{', '.join(an.ds.names)}, N = {an.N} ({n} evaluations) -> {out}", file=sys.stderr)
        res = sensitivity.run(an, out, **_design_kw(args))
        print(sensitivity.text_table(res))
        s = res.session
        print(f"{len(s.order)} samples ({s.computed} computed, {s.reused} already in the results), "
              f"{res.wall_s:.1f} s; {out / 'sobol.parquet'}, {out / 'results.parquet'}"
              + (f", {', '.join(map(str, res.plots))}" if res.plots else ""))
        for w in res.warnings:
            print(f"ballmill sensitivity: warning: {w}", file=sys.stderr)
        if not res.table:
            print("ballmill sensitivity: no indicator has indices (see the table above)", file=sys.stderr)
            return 1
        return 0
    return _design_run(args, "sensitivity", body)


def _steady(args) -> int:
    from .physics import Ball, ParameterError
    from .physics.steady import equilibrium, limits
    try:
        kw = {k: getattr(args, k) for k in ("r", "R", "m", "g", "mu") if getattr(args, k) is not None}
        ball = Ball(**kw)
        eq = equilibrium(ball, args.l, args.n0)
        lim = limits(ball, args.l, n_max=args.n_max, dn=args.dn)
    except (ParameterError, ArithmeticError, ValueError) as e:
        print(f"ballmill steady: {e}", file=sys.stderr)
        return 2
    out = {"ball": {"r_m": ball.r, "R_m": ball.R, "m_kg": ball.m, "g_m_s2": ball.g, "mu": ball.mu},
           "crank": {"l_m": args.l, "n0_per_min": args.n0},
           "equilibrium": {"theta_deg": eq.theta_deg, "phi_deg": eq.phi_deg, "contact_radius_Oxy_m": eq.rho_P,
                           "zP_m": eq.zP, "N_N": eq.N, "friction_ratio": eq.friction_ratio, "rolling": eq.rolling,
                           "M_reaction_Nm": eq.M_reaction,
                           "ring_frequencies_rad_s": list(eq.ring_frequencies),
                           "ball_lowest_point_m": eq.ball_lowest},
           "fill_level": {"ball_touches_bed_above_m": eq.ball_lowest,
                          "contact_path_in_bed_above_m": eq.zP},
           "limits_on_the_branch": lim}
    print(json.dumps(out, indent=2))
    return 0


def _scenario_arguments(p):
    """What every command that reads a scenario accepts."""
    p.add_argument("scenario", help="scenario name in scenarios/ (e.g. fast_start) or a .toml path")
    p.add_argument("--set", action="append", metavar="INSTANCE.PARAM=VALUE",
                   help="override a parameter, e.g. --set drive.t0=30 (repeatable)")
    p.add_argument("--build-dir", help="where the FMUs are (default: build/)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="ballmill", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build and validate every FMU (native in build/, pythonfmu in "
                                     "build/pythonfmu/)")
    b.add_argument("--force", action="store_true", help="rebuild even when up to date")
    b.add_argument("--build-dir", help="where to put the FMUs (default: build/)")
    r = sub.add_parser("run", help="run a scenario (builds the FMUs if needed)")
    _scenario_arguments(r)
    r.add_argument("--out", help="output folder (default: out/SCENARIO)")
    r.add_argument("--quiet", action="store_true",
                   help="print only errors (nothing on success: the exit status tells)")
    r.add_argument("--flavour", choices=("native", "pythonfmu"), default="native",
                   help="which FMUs to run: native (C, build/, the default) or pythonfmu (the Python "
                        "reference, build/pythonfmu/)")
    r.add_argument("--interface", choices=("cs", "me"), default="cs",
                   help="cs: co-simulation, the FMUs stepped on the communication grid (default); me: "
                        "Model Exchange, every FMU's continuous states integrated together as one ODE "
                        "(scipy, [master] solver/rtol/atol) with time and state events, recorded on the "
                        "same grid (native FMUs only: pythonfmu has no Model Exchange)")
    e = sub.add_parser("export-ssp", help="write a scenario as an SSP package (.ssp) for other FMI tools")
    _scenario_arguments(e)
    e.add_argument("out", help="the .ssp file to write")
    w = sub.add_parser("sweep", help="a design study over a scenario's parameters -> DIR/results.parquet")
    w.add_argument("study", help="a study file (scenarios/studies/NAME.toml or a path) or a scenario name")
    w.add_argument("--grid", action="append", metavar="INSTANCE.PARAM=VALUES",
                   help="a grid axis: a list 1,2,2.5 or start:stop:count 40:80:5 (repeatable; full grid)")
    w.add_argument("--sample", metavar="lhs:N[:SEED]|random:N[:SEED]",
                   help="a Latin-hypercube or random sample of N points instead of a grid (with --range)")
    w.add_argument("--range", action="append", metavar="INSTANCE.PARAM=LOW:HIGH", help="a sampled range")
    w.add_argument("--set", action="append", metavar="INSTANCE.PARAM=VALUE",
                   help="a fixed override, as in ballmill run (repeatable)")
    w.add_argument("--out", help="output folder (default: out/sweep/STUDY); re-running resumes")
    w.add_argument("--stop", type=float, help="simulate up to this time [s] instead of the scenario's stop")
    w.add_argument("--model", help="evaluator: auto (default), crank-kernel, cosim or hybrid-kernel (the ball "
                                   "that slides, flies and strikes; a study with a [contact] table runs on it) "
                                   "(absorber for case studies)")
    w.add_argument("--mode", choices=("steady", "up", "down", "both"),
                   help="a case study's mode (absorber: independent steady states refined at the peaks, or "
                        "stepped sweeps up, down or both, continuing from state to state)")
    w.add_argument("--method", help="kernel integrator: RK4 (default; DOP853 for hybrid-kernel, which refuses "
                                    "RK4), RK45 or DOP853")
    w.add_argument("--h", type=float, help="RK4 first step [s] (default 0.01; halved per point to meet the target)")
    w.add_argument("--target", type=float, help="RK4: estimated contact-point error to reach [m] (default 1e-5)")
    w.add_argument("--dt", type=float, help="output sampling for the indicators [s] (default 0.01)")
    w.add_argument("--error", choices=("one-pass", "richardson"),
                   help="RK4's error estimate: the run's own, from its local errors, no second run, up to "
                        "where the model stops holding (one-pass, default), or step doubling: a second full "
                        "run at 2h (richardson)")
    w.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786), or local (a Dask LocalCluster); default: "
                        "Dask's local processes scheduler, workers forked from this one (a LocalCluster "
                        "where the platform cannot fork)")
    w.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    w.add_argument("--in-process", action="store_true", help="no Dask: compute the batches in this process")
    w.add_argument("--batch", type=int, help="points per task (default: about 8 tasks per worker, <= 250)")
    w.add_argument("--retry-failed", action="store_true", help="recompute points that failed before")
    w.add_argument("--no-plots", action="store_true", help="write no PNGs")
    w.add_argument("--quiet", action="store_true", help="no progress bar")
    w.add_argument("--build-dir", help="where the FMUs are (co-simulated points only)")
    o = sub.add_parser("optimize", help="the design variables that minimise or maximise indicators under "
                                        "constraints (NSGA-II or differential evolution, on Dask)")
    _design_options(o, "optimize")
    o.add_argument("--population", type=int, help="designs per generation (replaces the file's)")
    o.add_argument("--generations", type=int, help="generations (replaces the file's)")
    o.add_argument("--seed", type=int, help="the algorithm's seed (replaces the file's)")
    v = sub.add_parser("sensitivity", help="Sobol indices of indicators over parameters (SALib, on Dask)")
    _design_options(v, "sensitivity")
    v.add_argument("--N", type=int, help="base sample, a power of 2 (replaces the file's)")
    v.add_argument("--seed", type=int, help="the sample's and the bootstrap's seed (replaces the file's)")
    q = sub.add_parser("steady", help="the ball's relative equilibrium on the crank circle (quasi-static)")
    q.add_argument("--n0", type=float, default=60.0, help="crank speed [1/min] (default 60)")
    q.add_argument("--l", type=float, default=0.5, help="crank length [m] (default 0.5)")
    for name, unit in (("r", "m"), ("R", "m"), ("m", "kg"), ("g", "m/s2"), ("mu", "1")):
        q.add_argument(f"--{name}", type=float, help=f"ball/chamber {name} [{unit}] (default: the paper's)")
    q.add_argument("--n-max", type=float, default=200.0, help="scan the branch up to this speed [1/min]")
    q.add_argument("--dn", type=float, default=2.0, help="scan step [1/min]")
    sub.add_parser("bench", help="speed/accuracy benchmarks -> BENCHMARKS.md (see ballmill bench -h)",
                   add_help=False)
    args, rest = parser.parse_known_args(argv)
    if args.command == "bench":
        return _bench(args, rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    return {"build": _build, "run": _run, "export-ssp": _export_ssp, "sweep": _sweep,
            "steady": _steady, "optimize": _optimize,
            "sensitivity": _sensitivity}[args.command](args)


def entry() -> None:
    """The console script: `main`, then leave the process without running C-level exit
    handlers. pythonfmu 0.7.0's FMU libraries (InductionMotor.so, ...) corrupt the heap
    at process exit in a few % of runs: the library's destructor function
    (finalizePythonInterpreter, run by _dl_fini) assigns to a static std::shared_ptr
    that the C++ static destructors (run earlier by exit()) have already destroyed,
    reading its freed control block ("corrupted double-linked list";
    docs/OTHER_TOOLS.md). Every FMU instance has been freed by then, files are
    closed; os._exit skips exactly those handlers."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    _phases("end")
    _phases.write()
    os._exit(code or 0)


if __name__ == "__main__":
    entry()
