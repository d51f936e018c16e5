"""The `ballmill` command: build the FMUs, run scenarios, benchmark.

    ballmill build [--force]                 build and validate every FMU into build/
    ballmill run SCENARIO [--out DIR] [--set inst.param=value ...]
                                             exit status: 0 ran and stayed valid, 1 an FMU stopped
                                             the run, 2 bad scenario, 3 ran but the ball model's
                                             validity ended (statistics over the valid span only)
    ballmill bench [...]                      speed/accuracy map -> BENCHMARKS.md
    ballmill export-ssp SCENARIO OUT.ssp [--set inst.param=value ...]
                                             the scenario as an SSP package for other FMI tools
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path


def _build(args) -> int:
    from .fmi import build
    try:
        build.build_all(Path(args.build_dir) if args.build_dir else None, force=args.force)
    except build.BuildError as e:
        print(f"ballmill build: {e}", file=sys.stderr)
        return 1
    return 0


def _run(args) -> int:
    from .fmi.build import BuildError
    from .scenario import report, runner
    from .scenario.spec import ScenarioError
    try:
        sc, models, paths = runner.prepare(args.scenario, args.set or (),
                                           Path(args.build_dir) if args.build_dir else None,
                                           log=lambda m: print(m, file=sys.stderr))
    except (ScenarioError, BuildError) as e:
        print(f"ballmill run: {e}", file=sys.stderr)
        return 2
    out = Path(args.out or Path("out") / sc.name)
    print(f"running {sc.name}: {sc.description}", file=sys.stderr)
    res = runner.run(sc, models, paths, progress=not args.quiet)
    summary = report.write_all(res, models, out)
    brief = {k: summary.get(k) for k in ("success", "message", "wall_time_s", "statistics_over", "N", "ring",
                                         "zP_max_m", "M_reaction_peak_abs_Nm", "validity", "t_invalid_s")
             if k in summary}
    print(json.dumps(brief, indent=2))
    print(f"results: {out / 'results.csv'}, {out / 'summary.json'}, plots: "
          f"{', '.join(str(out / p) for p in summary.get('plots', []))}", file=sys.stderr)
    if not res.success:
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


def _scenario_arguments(p):
    """What every command that reads a scenario accepts."""
    p.add_argument("scenario", help="scenario name in scenarios/ (e.g. fast_start) or a .toml path")
    p.add_argument("--set", action="append", metavar="INSTANCE.PARAM=VALUE",
                   help="override a parameter, e.g. --set drive.t0=30 (repeatable)")
    p.add_argument("--build-dir", help="where the FMUs are (default: build/)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="ballmill", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build and validate every FMU into build/")
    b.add_argument("--force", action="store_true", help="rebuild even when up to date")
    b.add_argument("--build-dir", help="where to put the FMUs (default: build/)")
    r = sub.add_parser("run", help="run a scenario (builds the FMUs if needed)")
    _scenario_arguments(r)
    r.add_argument("--out", help="output folder (default: out/SCENARIO)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    e = sub.add_parser("export-ssp", help="write a scenario as an SSP package (.ssp) for other FMI tools")
    _scenario_arguments(e)
    e.add_argument("out", help="the .ssp file to write")
    sub.add_parser("bench", help="speed/accuracy benchmarks -> BENCHMARKS.md (see ballmill bench -h)",
                   add_help=False)
    args, rest = parser.parse_known_args(argv)
    if args.command == "bench":
        return _bench(args, rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    return {"build": _build, "run": _run, "export-ssp": _export_ssp}[args.command](args)


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
    os._exit(code or 0)


if __name__ == "__main__":
    entry()
