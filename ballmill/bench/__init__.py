"""ballmill.bench: the benchmark harness behind ``ballmill bench``.

Measures, in one run on this machine, and writes BENCHMARKS.md (plus PNG
figures in benchmarks/figures/):

1. micro: one right-hand side (vector, paper closed form, paper with the
   3x3 Cramer solve), one communication step of BallModel.advance, and the
   time from process start to the first step;
2. the monolithic fast start (CrankStartup(0.5, 60, 2.5), 10 s, outputs
   every 0.01 s) against a converged reference, for a grid of formulations,
   methods and tolerances/steps: max contact-point error, max N error, wall
   time (median of repeats), steps and evaluations; the vector settings
   both in pure Python (``kernel="python"``) and through the library's
   compiled kernel (``kernel="c"``, family "library (C kernel)");
3. two peers on the same problem in the same run: "paper-literal" (the
   paper's coordinates and Cramer solve under scipy's solve_ivp RK45) and
   "compiled" (the kernel's C, ballmill/physics/_kernel.c, as a standalone
   program with a generated main, built with gcc -O2);
4. Pareto fronts, the time of each family at a 1e-6 m contact-point error
   and the ratios, and where the library's time goes.
7. a chamber that turns (bench/turning.py): the general model's cost per
   step (Fig. 1 machine, spinning bowl, the same translation) against the
   translation-only model, Python and compiled kernel, and what a scene
   without rotation pays through simulate_chamber;
8. start-up (bench/startup.py): what `ballmill --help` and a warm `ballmill run
   fast_start` cost as whole processes, phase by phase, and the first run's build,
   against the code before the start-up work in the same rounds;
9. the hybrid ball (bench/hybrid.py): `simulate_hybrid` on the event-driven driver,
   a scene that stays rolling next to `simulate`, and scenes with slip, flight and
   impacts: cost per simulated second, per event, and of locating the events; and the
   BallInShell FMU of each flavour through fmpy on the fast start, contact_model 1
   against 2, DOP853 and RK45;
10. design (bench/design.py): `ballmill optimize` (NSGA-II, 40 x 25) and `ballmill
   sensitivity` (Sobol, 5 parameters, N = 1024) as whole processes on the kernel evaluator;
11. Model Exchange (bench/model_exchange.py): the coupled fast start through
   `ballmill run --interface me` next to co-simulation, and one ME derivative call
   of BallInShell against the compiled kernel's right-hand side.

Speed is measured here, never asserted in tests. ``--quick`` runs a reduced
grid (about a minute) and by default writes to benchmarks/_work/ so that it
does not replace the published BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

__all__ = ["main"]


def _default_root() -> Path:
    """The repository holding this package if it looks like one, else the cwd."""
    here = Path(__file__).resolve().parents[2]
    if (here / "pyproject.toml").exists() and (here / "ballmill").is_dir():
        return here
    return Path.cwd()


# The report's sections after the headline comparison, in the order `--section all` runs them:
# name -> (module in this package, what it measures, how its run_section is called). Each
# module is imported only when its section runs, and splices its part into the same report.
SECTIONS = {
    "studies": ("studies", "the design studies",
                lambda m, out, a, root, progress: m.run_section(out, a.quick, progress)),
    "absorber": ("absorber", "the absorber co-simulation",
                 lambda m, out, a, root, progress: m.run_section(out, a.quick, progress)),
    "startup": ("startup", "what a command costs before and around its run",
                lambda m, out, a, root, progress: m.run_section(out, a.quick, progress, a.baseline)),
    "sweep-grid": ("sweep_grid", "the whole sweep command on the 4000-point grid, A/B",
                   lambda m, out, a, root, progress: m.run_section(
                       out, a.repeats or (3 if a.quick else 5), a.baseline, root, progress)),
    "hybrid": ("hybrid", "the hybrid ball on the event-driven driver, next to the rolling scene, and in "
               "the BallInShell FMU of each flavour",
               lambda m, out, a, root, progress: m.run_section(out, a.quick, progress)),
    "design": ("design", "NSGA-II 40 x 25 and Sobol N = 1024 over 5 parameters, whole commands",
               lambda m, out, a, root, progress: m.run_section(out, a.repeats or (1 if a.quick else 3),
                                                               progress)),
    "me": ("model_exchange", "the coupled fast start as one ODE through --interface me against "
           "co-simulation, one ME derivative call against the kernel's right-hand side",
           lambda m, out, a, root, progress: m.run_section(out, a.quick, a.repeats, progress)),
}



def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="ballmill bench",
        description="Benchmark the physics library against a literal port of the paper's program "
                    "and a compiled peer; write BENCHMARKS.md and figures.")
    p.add_argument("--quick", action="store_true",
                   help="reduced grid and repeats (about a minute); writes to benchmarks/_work/ "
                        "unless --out/--figures are given")
    p.add_argument("--root", type=Path, default=None,
                   help="repository root (default: the checkout holding this package, else the cwd)")
    p.add_argument("--out", type=Path, default=None,
                   help="report path (default: <root>/BENCHMARKS.md; quick: "
                        "<root>/benchmarks/_work/BENCHMARKS.quick.md)")
    p.add_argument("--figures", type=Path, default=None,
                   help="directory for PNG figures (default: <root>/benchmarks/figures; quick: "
                        "<root>/benchmarks/_work/figures)")
    p.add_argument("--work", type=Path, default=None,
                   help="scratch directory for the C peer (default: <root>/benchmarks/_work)")
    p.add_argument("--repeats", type=int, default=None,
                   help="timed rounds (one run of every setting per round), median reported (default 9; quick 3; minimum 3)")
    p.add_argument("--target", type=float, default=1e-6,
                   help="contact-point error for the headline comparison [m] (default 1e-6)")
    p.add_argument("--cc", default="gcc", help="C compiler for the compiled peer (default gcc)")
    p.add_argument("--no-compiled", action="store_true", help="skip the compiled (C) peer")
    p.add_argument("--debug", action="store_true", help="show the traceback when a benchmark fails")
    p.add_argument("--section", choices=("all", *SECTIONS), default="all",
                   help="run only one section and splice it into the report (default: all sections): "
                        + "; ".join(f"'{name}': {what} (ballmill/bench/{module}.py)"
                                    for name, (module, what, _) in SECTIONS.items()))
    p.add_argument("--baseline", metavar="REF",
                   help="sweep-grid: also time the command with the code of git revision REF (git archive of "
                        "the repository at --root, its kernel built beside it); startup: compare with REF "
                        "instead of the code before the start-up work (b184759)")
    return p


class Progress:
    def __init__(self, stream=None):
        self.t0 = time.perf_counter()
        self.stream = stream or sys.stdout

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def __call__(self, msg: str):
        print(f"[{self.elapsed():6.1f} s] {msg}", file=self.stream, flush=True)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.repeats is not None and args.repeats < 3:
        print("ballmill bench: --repeats must be at least 3", file=sys.stderr)
        return 2
    if not (0.0 < args.target < 1.0):
        print(f"ballmill bench: --target must be a positive error in m below 1, got {args.target}",
              file=sys.stderr)
        return 2
    from .runner import Config, run

    root = (args.root or _default_root()).resolve()
    work = (args.work or root / "benchmarks" / "_work").resolve()
    if args.quick:
        out = args.out or work / "BENCHMARKS.quick.md"
        figures = args.figures or work / "figures"
    else:
        out = args.out or root / "BENCHMARKS.md"
        figures = args.figures or root / "benchmarks" / "figures"
    cfg = Config.quick_run() if args.quick else Config.full_run()
    if args.repeats is not None:
        cfg.repeats = args.repeats
    cfg.target = args.target
    cfg.cc = args.cc
    cfg.compiled = not args.no_compiled
    progress = Progress()
    try:
        if args.section == "all":
            run(cfg, root=root, out=Path(out).resolve(), figures=Path(figures).resolve(),
                work=work, progress=progress)
        for name, (module, _, run_section) in SECTIONS.items():
            if args.section in ("all", name):
                run_section(importlib.import_module(f".{module}", __name__), Path(out).resolve(), args, root,
                            progress)
    except KeyboardInterrupt:
        print("ballmill bench: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # report, do not dump a traceback on the user
        print(f"ballmill bench: failed: {type(e).__name__}: {e}", file=sys.stderr)
        if args.debug:
            raise
        return 1
    progress(f"done: {out}")
    return 0
