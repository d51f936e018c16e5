"""Benchmark section "Start-up: what a command costs before and around its run" of BENCHMARKS.md.

    ballmill bench --section startup [--quick]     run only this section and splice it into the report

Everything is measured as a user meets it, whole processes (``python -m ballmill.cli ...``,
without the console script's launcher, which adds its own start: a pyenv shim, for
instance), on a build folder of this section's own:

1. ``python -c pass`` (the interpreter and site), ``ballmill --help``, ``ballmill run --help``;
2. the import time of ``ballmill.cli`` and of ``ballmill.fmi.interface`` (``python -X
   importtime``, cumulative);
3. the up-to-date build check (``build_all`` on a built folder, in one process: median of
   many calls, and the first call, which loads what the check needs);
4. ``ballmill run fast_start --quiet`` warm (FMUs built): the whole command's wall time,
   and its phases as the command itself clocks them (``$BALLMILL_PHASES``, ballmill.cli):
   interpreter start and ``import ballmill.cli``, the imports the run needs, preparing (the
   build check, the scenario and the model descriptions it uses), FMU load and
   initialisation, the simulation, results and plots, and leaving the process;
5. the first run on an empty build folder (compiling the FMUs it needs), once;
6. the run's plots in one process (``PLOTS_SCRIPT``, after a run of the scenario there): the
   first figure made (matplotlib's import), the 4 PNGs first drawn and written, and the same
   4 again (warm: drawing and encoding only), CPU time and wall time of each.

Items 1-4 and 6 also for the code as it was before the start-up work (``BASELINE``; or the
revision ``ballmill bench --section startup --baseline REF`` names), extracted
with ``git archive`` into a temporary folder, its FMUs built by its own first run), in the
same rounds: each round runs every measurement of both, old and new interleaved, and the
tables give medians over the rounds. Without git (or the baseline commit) the comparison
is left out and the section says so.
"""
from __future__ import annotations

import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

from .report import _table, splice_section

BEGIN, END = "<!-- section: startup -->", "<!-- end of section: startup -->"
BASELINE = "b184759"  # the last commit before the start-up work (lazy imports, the build's stamp)
ROOT = Path(__file__).resolve().parents[2]
SCENARIO = "fast_start"
PHASES = (  # (label, mark that ends it); the first starts at the process's launch
    ("interpreter start + `import ballmill.cli`", "cli imported"),
    ("argument parsing + the imports `run` needs (numpy, the runner)", "imports"),
    ("preparing: build check, scenario, model descriptions (fmpy)", "prepare"),
    ("FMU load + initialisation", None),
    ("simulation (10 s simulated, 5000 steps)", "run"),
    ("results.csv, summary.json and the 4 plots", "results and plots"),
    ("leaving the process", "exit"),
)


def _env(tree: Path, **extra) -> dict:
    from .machine import command_env

    return command_env(tree, **extra)


def _cpu() -> float:
    """CPU time (user + system) of this process's finished children and theirs [s]."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _timed(cmd: list[str], env: dict, cwd: Path) -> tuple[float, float, float, subprocess.CompletedProcess]:
    """(launch, end, wall) on time.perf_counter's clock, and the finished process (its CPU time
    in ``proc.cpu``)."""
    c0, t0 = _cpu(), time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)
    t1 = time.perf_counter()
    proc.cpu = _cpu() - c0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return t0, t1, t1 - t0, proc


def _cli(*args) -> list[str]:
    return [sys.executable, "-m", "ballmill.cli", *args]


def _import_s(tree: Path, module: str, cwd: Path) -> float:
    """Cumulative import time of `module` in a fresh interpreter [s] (python -X importtime)."""
    _, _, _, proc = _timed([sys.executable, "-X", "importtime", "-c", f"import {module}"], _env(tree), cwd)
    for line in proc.stderr.splitlines():
        parts = [p.strip() for p in line.split("|")]
        if len(parts) == 3 and parts[2] == module:
            return int(parts[1]) * 1e-6
    raise RuntimeError(f"no import time for {module} in: {proc.stderr[-500:]}")


CHECK_SCRIPT = """
import inspect, json, sys, time
from pathlib import Path
from ballmill.fmi import build
d = Path(sys.argv[1])
# as `ballmill run` checks: the native flavour's FMUs (the code before the start-up work: both flavours)
kw = {"only": True} if "only" in inspect.signature(build.build_all).parameters else {}
t = time.perf_counter(); build.build_all(d, log=lambda m: None, **kw); first = time.perf_counter() - t
times = []
for _ in range(50):
    t = time.perf_counter(); build.build_all(d, log=lambda m: None, **kw); times.append(time.perf_counter() - t)
times.sort()
print(json.dumps({"first": first, "median": times[len(times) // 2]}))
"""


def _build_check(tree: Path, build_dir: Path, cwd: Path) -> dict:
    """The up-to-date check as `ballmill run` makes it, in one process: the first call and the
    median of 50 more [s]."""
    _, _, _, proc = _timed([sys.executable, "-c", CHECK_SCRIPT, str(build_dir)], _env(tree), cwd)
    return json.loads(proc.stdout.strip().splitlines()[-1])


PLOTS_SCRIPT = """
import inspect, json, sys, time
from pathlib import Path
from ballmill.scenario import report, runner
build, out = Path(sys.argv[1]), Path(sys.argv[2])
sc, models, paths = runner.prepare("fast_start", (), build, log=lambda m: None)
res = runner.run(sc, models, paths, progress=False, echo=False)
summary = report.summarise(res, models, None)
kw = {"summary": summary} if "summary" in inspect.signature(report.plot).parameters else {}
out.mkdir(parents=True, exist_ok=True)
times = {}
def clock(name, f):
    c, t = time.process_time(), time.perf_counter()
    f()
    times[name + " wall"], times[name + " cpu"] = time.perf_counter() - t, time.process_time() - c
try:  # the figures' module (the plain pyplot import before it existed)
    from ballmill.plotting import figures
    clock("import", lambda: figures.subplots())
except ImportError:
    clock("import", lambda: __import__("matplotlib.pyplot"))
clock("plots first", lambda: report.plot(res, out, models, **kw))
clock("plots again", lambda: report.plot(res, out, models, **kw))
print(json.dumps(times))
"""
PLOT_ROWS = (("import", "matplotlib's import (the first figure made)"),
             ("plots first", "the 4 PNGs of `ballmill run fast_start`, first drawn in the process"),
             ("plots again", "the same 4 PNGs again (warm: drawing and encoding only)"))


def _plots(tree: Path, build_dir: Path, work: Path) -> dict:
    """PLOTS_SCRIPT in a fresh process of the tree: wall and CPU time of each of PLOT_ROWS [s]."""
    _, _, _, proc = _timed([sys.executable, "-c", PLOTS_SCRIPT, str(build_dir), str(work / "plots")],
                           _env(tree), work)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _run(tree: Path, build_dir: Path, work: Path, clocked: bool) -> dict:
    """One `ballmill run fast_start --quiet`: its wall time and (clocked) its phases [s]."""
    marks = work / "phases.json"
    marks.unlink(missing_ok=True)
    env = _env(tree, BALLMILL_PHASES=str(marks)) if clocked else _env(tree)
    launch, end, wall, proc = _timed(_cli("run", SCENARIO, "--quiet", "--build-dir", str(build_dir),
                                          "--out", str(work / "out")), env, work)
    out = {"wall": wall, "cpu": proc.cpu}
    if clocked:
        data = json.loads(marks.read_text())
        at = dict(data["marks"])
        at["exit"] = end
        previous = launch
        for label, mark in PHASES:
            if mark is None:  # FMU load + initialisation: the run's own clock, inside the "run" phase
                out[label] = data["init_s"]
                continue
            out[label] = at[mark] - previous - (data["init_s"] if mark == "run" else 0.0)
            previous = at[mark]
        out["summary wall_time_s"] = data["wall_s"]
    return out


def _baseline(work: Path, progress, ref: str = BASELINE) -> Path | None:
    """The tree of revision ref, extracted from git into work/old (None, and why, when impossible)."""
    old = work / "old"
    try:
        proc = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", ref],
                              capture_output=True, timeout=120)
    except (OSError, subprocess.SubprocessError) as e:
        progress(f"startup: no baseline ({e})")
        return None
    if proc.returncode != 0:
        progress(f"startup: no baseline {ref}: {proc.stderr.decode(errors='replace').strip()}")
        return None
    tar = work / "old.tar"
    tar.write_bytes(proc.stdout)
    with tarfile.open(tar) as t:
        t.extractall(old, filter="data")
    tar.unlink()
    return old


def measure(quick: bool, progress=print, baseline: str | None = None) -> dict:
    """Every measurement of the current code and (in the same rounds) of revision ``baseline``
    (default BASELINE: the code before the start-up work)."""
    baseline = baseline or BASELINE
    rounds = 3 if quick else 5
    work = Path(tempfile.mkdtemp(prefix="ballmill_bench_startup_"))
    try:
        trees = {"new": ROOT}
        old = _baseline(work, progress, baseline)
        if old is not None:
            trees["old"] = old
        builds = {k: work / f"build_{k}" for k in trees}
        first = {}
        for k, tree in trees.items():  # the first run: compiles what it needs (the old code: both flavours)
            progress(f"startup: first run ({k} code, empty build folder)")
            first[k] = _timed(_cli("run", SCENARIO, "--quiet", "--build-dir", str(builds[k]), "--out",
                                   str(work / "out")), _env(tree), work)[2]
        samples: dict = {k: {} for k in trees}

        def add(k, name, value):
            samples[k].setdefault(name, []).append(value)
        for i in range(rounds):
            progress(f"startup: round {i + 1}/{rounds}")
            for k, tree in trees.items():
                add(k, "python -c pass", _timed([sys.executable, "-c", "pass"], _env(tree), work)[2])
                add(k, "ballmill --help", _timed(_cli("--help"), _env(tree), work)[2])
                add(k, "ballmill run --help", _timed(_cli("run", "--help"), _env(tree), work)[2])
                add(k, "import ballmill.cli", _import_s(tree, "ballmill.cli", work))
                add(k, "import ballmill.fmi.interface", _import_s(tree, "ballmill.fmi.interface", work))
                check = _build_check(tree, builds[k], work)
                add(k, "build check (first call)", check["first"])
                add(k, "build check (median of 50 more)", check["median"])
                for name, value in _run(tree, builds[k], work, clocked=(k == "new")).items():
                    add(k, name, value)
                for name, value in _plots(tree, builds[k], work).items():
                    add(k, name, value)
        medians = {k: {name: statistics.median(v) for name, v in s.items()} for k, s in samples.items()}
        fastest = {k: {name: min(v) for name, v in s.items()} for k, s in samples.items()}
        return {"medians": medians, "fastest": fastest, "first": first, "rounds": rounds, "baseline": baseline if old else None,
                "load": os.getloadavg() if hasattr(os, "getloadavg") else None}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _t(v: float | None) -> str:
    if v is None:
        return "—"
    return f"{v * 1e6:.0f} µs" if v < 1e-3 else f"{v * 1e3:.1f} ms" if v < 0.1 else f"{v:.2f} s"


def report(data: dict, quick: bool) -> str:
    new, old = data["medians"]["new"], data["medians"].get("old")
    cmd = "ballmill bench --section startup" + (" --quick" if quick else "") + (
        f" --baseline {data['baseline']}" if data.get("baseline") not in (None, BASELINE) else "")
    L = [BEGIN, "## Start-up: what a command costs before and around its run\n",
         f"Generated by `{cmd}`: whole processes (`python -m ballmill.cli ...`; a console-script "
         f"launcher such as a pyenv shim adds its own start), medians over {data['rounds']} rounds, each "
         f"running every measurement of "
         + (f"the current code and of the code at commit {data['baseline']}"
            + (" (before the start-up work)" if data["baseline"] == BASELINE else "")
            + ", extracted with `git archive`, interleaved" if old else "the current code (no baseline: git or "
            "the baseline commit unavailable)")
         + f"; load average at the end {', '.join(f'{x:.1f}' for x in data['load']) if data['load'] else 'n/a'} "
         f"(a shared machine: the ratios, measured side by side, are the robust part). Each code has its "
         f"own build folder, built by its first run.\n"]
    rows = []
    names = ["python -c pass", "ballmill --help", "ballmill run --help", "import ballmill.cli",
             "import ballmill.fmi.interface", "build check (first call)", "build check (median of 50 more)",
             "wall", "cpu"]
    labels = {"wall": f"`ballmill run {SCENARIO} --quiet`, warm, whole process: wall",
              "cpu": "the same: CPU time (user + system)",
              "build check (first call)": "build check as `ballmill run` makes it, up to date: first call in "
                                          "a process (after `import ballmill.fmi.build`)",
              "build check (median of 50 more)": "the same check: median of 50 more calls"}
    fast_new, fast_old = data["fastest"]["new"], data["fastest"].get("old", {})
    for name in names:
        a, b = (old or {}).get(name), new.get(name)
        rows.append([labels.get(name, f"`{name}`"), _t(a) if old else "—", _t(b),
                     f"{a / b:.1f}x" if old and a and b else "—",
                     _t(fast_old.get(name)) if old else "—", _t(fast_new.get(name))])
    L.append(_table(["", f"before ({data['baseline']}), median" if old else "before", "now, median",
                     "before / now", "before, fastest round", "now, fastest round"], rows) + "\n")
    L.append("The fastest round is the nearest this shared machine came to an idle one.\n")
    first = data["first"]
    L.append(f"First run on an empty build folder (compiling the FMUs; once, at the load above): now "
             f"{first['new']:.1f} s (the native FMUs the run needs, compiled in parallel, one per core)"
             + (f"; before {first['old']:.1f} s (both flavours of every FMU, one after the other, "
                f"without a word)" if "old" in first else "") + ".\n")
    rows = [[label, _t(new.get(label))] for label, _ in PHASES]
    rows.append(["**whole process** (median of the whole)", f"**{_t(new['wall'])}**"])
    L.append(f"Where a warm `ballmill run {SCENARIO}` spends its time now, phase by phase (the command's "
             f"own clock, `$BALLMILL_PHASES`; medians per phase):\n")
    L.append(_table(["phase", "wall time"], rows) + "\n")
    rows = []
    for name, label in PLOT_ROWS:
        for unit in ("cpu", "wall"):
            a, b = (old or {}).get(f"{name} {unit}"), new.get(f"{name} {unit}")
            rows.append([f"{label}: {'CPU' if unit == 'cpu' else 'wall'}", _t(a) if old else "—", _t(b),
                         f"{a / b:.2f}x" if old and a and b else "—"])
    L.append("The run's plots in one process, after a run of the scenario there (CPU time is what load "
             "inflates least; medians):\n")
    L.append(_table(["", f"before ({data['baseline']})" if old else "before", "now", "before / now"], rows) + "\n")
    L.append(f"The co-simulation's own `wall_time_s` in its summary (FMU load, initialisation and "
             f"simulation): {_t(new['summary wall_time_s'])}.\n")
    L.append(END + "\n")
    return "\n".join(L)


def splice(path: Path, section: str):
    splice_section(path, section, BEGIN, END)


def run_section(out: Path, quick: bool, progress=print, baseline: str | None = None) -> Path:
    splice(out, report(measure(quick, progress, baseline), quick))
    return out
