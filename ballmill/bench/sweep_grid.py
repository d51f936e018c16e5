"""Benchmark section "A study at 1000 points/s" of BENCHMARKS.md: the whole `ballmill sweep`
command on the grid a user would try, plots on.

    ballmill bench --section sweep-grid [--repeats N] [--baseline REF[,REF...]] [--out PATH]

The study: ``ballmill sweep fast_start --grid drive.t0=1:5:40 --grid drive.n0=40:80:100``
(4000 points, t0 from 1 s, up to 80 1/min, 10 s simulated each), each run a fresh
process into an empty folder, plots on, so that its wall time holds the interpreter
start, the imports, the workers' start, the points, results.parquet and the PNGs. The
variants run interleaved, one of each per round, and the medians are reported:

* "one-pass" (the default): RK4's run estimating its own error (no second run), each point
  ending where the model stops holding, on Dask's local processes scheduler, its workers
  forked from the command;
* "--error richardson": step doubling, two separate full runs per point, the same executor;
* "--error richardson --scheduler local": and a Dask LocalCluster of spawned workers;
* with ``--baseline REF`` (several: comma-separated): the code of git revision REF
  (extracted with ``git archive`` and its kernel built beside it), the same command:
  what the study cost before. The table names each variant's executor.

Also the CPU time of each command and its children (the workers), so that load from
other processes, which inflates the wall times, can be told apart, and the split of the
default variant's timing.json. For the current code and each baseline, in every round:

* the command's own CPU time (not its workers'), part by part (``FIXED_SCRIPT``: the same
  command in one process, its functions clocked): imports, checking the scenario, its share
  of the points (the task graph, the results as they come), results.parquet, matplotlib's
  import and the PNGs (drawn here, or by the workers: then this process's part is making the
  jobs and handing them out, and matplotlib's import runs in a thread while the workers compute
  the points): the fixed costs;
* a worker's CPU per point, part by part (``SPLIT_SCRIPT``: every 10th point of the grid in
  one process, no Dask): the kernel's run, the rest of the point's run in Python (its
  objects, the records), the indicators, and the row's assembly.
"""
from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from .report import splice_section

BEGIN, END = "<!-- section: sweep-grid -->", "<!-- end of section: sweep-grid -->"
GRID = ["fast_start", "--grid", "drive.t0=1:5:40", "--grid", "drive.n0=40:80:100"]
VARIANTS = (("one-pass (default)", []), ("--error richardson", ["--error", "richardson"]),
            ("--error richardson --scheduler local", ["--error", "richardson", "--scheduler", "local"]))


# both scripts' CPU clock on a function: wraps owner.name so that its CPU time adds to cpu[key]
# (once: only its first call counts)
CLOCKED = """
import time
cpu = {}
def clocked(owner, name, key, once=False):
    f = getattr(owner, name)
    def g(*a, **k):
        c = time.process_time()
        try:
            return f(*a, **k)
        finally:
            if not (once and key in cpu):
                cpu[key] = cpu.get(key, 0.0) + time.process_time() - c
    setattr(owner, name, g)
"""
SPLIT_SCRIPT = CLOCKED + """
import json, sys, time
from pathlib import Path
from ballmill.physics import fast
from ballmill.sweep import engine, evaluators, spec
grid = {k: spec.parse_grid_option(g)[1] for k, g in (("drive.t0", "drive.t0=1:5:40"), ("drive.n0", "drive.n0=40:80:100"))}
study = spec.load("fast_start", grid=grid)
st = engine.setup(study, Path(sys.argv[1]), None, lambda m: None)
sample = [(i, spec.point_id(p), p) for i, p in enumerate(study.points())][::10]
clocked(fast, "study_run", "kernel")
clocked(evaluators.CrankPrepared, "run", "run")
clocked(evaluators.CrankPrepared, "evaluate", "indicators")
engine.run_batch(st.prepared, study.indicators, sample[:20])  # (warm: the models, the kernel problems)
cpu.clear()
c = time.process_time()
engine.run_batch(st.prepared, study.indicators, sample)
total, n = time.process_time() - c, len(sample)
print(json.dumps({"kernel run (fast.study_run)": cpu["kernel"] / n,
                  "the run's Python (objects, steps, drive kinematics, record)": (cpu["run"] - cpu["kernel"]) / n,
                  "indicators": cpu["indicators"] / n,
                  "row assembly": (total - cpu["run"] - cpu["indicators"]) / n, "per point": total / n}))
"""
FIXED_SCRIPT = CLOCKED + """
import json, sys, time
c0 = time.process_time()
from ballmill import cli
from ballmill.plotting import figures
from ballmill.sweep import engine, plots
clocked(engine, "setup", "setup")
clocked(engine.Executor, "run", "run")
clocked(engine, "_table", "table")
clocked(engine, "_write", "write")
clocked(figures, "subplots", "mpl", once=True)  # the first in this process: matplotlib's import
clocked(plots, "write", "plots")
if hasattr(plots, "jobs"):  # the PNGs as jobs on the workers: this process makes the jobs and hands them out
    clocked(plots, "jobs", "plots")
    clocked(engine.Executor, "call", "plots")
for owner, name, key in ((engine, "_warm", "warm"), (plots, "warm", "mpl_warm")):
    if hasattr(owner, name):  # imports in a thread while the workers compute: that thread's CPU
        def warming(*a, _f=getattr(owner, name), _key=key):
            c = time.thread_time()
            _f(*a)
            cpu[_key] = cpu.get(_key, 0.0) + time.thread_time() - c
        setattr(owner, name, warming)
imports = time.process_time() - c0
cli.main(["sweep", "fast_start", "--grid", "drive.t0=1:5:40", "--grid", "drive.n0=40:80:100", "--out", sys.argv[1],
          "--quiet"])
total = time.process_time() - c0
print(json.dumps({"imports before the command": imports, "checking the scenario, the evaluator (setup)": cpu["setup"],
                  "its share of the points (task graph, results as they come, parts)": cpu["run"] - cpu.get("warm", 0.0),
                  "results.parquet (Arrow table and file, parts included; pyarrow's import while the workers "
                  "compute)": cpu.get("table", 0.0) + cpu.get("write", 0.0) + cpu.get("warm", 0.0) - cpu.get("mpl_warm", 0.0),
                  "matplotlib's import (the first figure; or in a thread while the workers compute)":
                      cpu.get("mpl", 0.0) + cpu.get("mpl_warm", 0.0),
                  "the PNGs (drawing, encoding; or making them jobs and handing those to the workers)":
                      cpu.get("plots", 0.0) - cpu.get("mpl", 0.0),
                  "the command's CPU (its own, not its workers')": total}))
"""


def _script(script: str, out: Path, env: dict) -> dict:
    """One of the scripts above in a fresh process of env's tree (out: its folder): its JSON."""
    shutil.rmtree(out, ignore_errors=True)
    res = subprocess.run([sys.executable, "-c", script, str(out)], capture_output=True, text=True, env=env,
                         cwd=out.parent)
    if res.returncode != 0:
        raise RuntimeError(f"bench script failed ({res.returncode}): {res.stderr[-2000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def _run(args: list[str], out: Path, env: dict) -> dict:
    """The whole sweep command once (machine.whole_command): wall and CPU time, its summary."""
    from .machine import whole_command

    r = whole_command(["sweep", *GRID, *args], out, env)
    js = json.loads(r["stdout"])
    return {"wall": r["wall"], "cpu": r["cpu"], "points": js["points"], "plots": len(js["plots"]),
            "timing": r["timing"], "executor": js["executor"]}


def _baseline(root: Path, ref: str, work: Path) -> tuple[Path, str]:
    """The tree of git revision ref under work/, its kernel built: (path, the revision's hash)."""
    sha = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", ref], capture_output=True, text=True,
                         check=True).stdout.strip()
    dest = work / f"baseline-{sha}"
    dest.mkdir(parents=True)
    archive = subprocess.Popen(["git", "-C", str(root), "archive", ref], stdout=subprocess.PIPE)
    subprocess.run(["tar", "-x", "-C", str(dest)], stdin=archive.stdout, check=True)
    archive.wait()
    subprocess.run([sys.executable, "setup.py", "build_ext", "--inplace", "-q"], cwd=dest, check=True,
                   capture_output=True)
    return dest, sha


def measure(repeats: int, baseline: str | None = None, root: Path | None = None, progress=print) -> dict:
    from . import machine

    work = Path(tempfile.mkdtemp(prefix="ballmill-bench-sweep-grid-"))
    here = Path(__file__).resolve().parents[2]
    env = machine.command_env(here)
    variants = [(label, args, env) for label, args in VARIANTS]
    data = {"repeats": repeats, "load_start": machine.load(), "nproc": os.cpu_count(), "runs": {}, "fixed": {},
            "split": {}}
    try:
        shas = []
        for ref in (baseline.split(",") if baseline else []):
            progress(f"sweep-grid: extracting and building {ref}")
            tree, sha = _baseline(root or here, ref.strip(), work)
            shas.append(sha)
            variants.append((f"revision {sha} (its default)", [], machine.command_env(tree)))
        if shas:
            data["baseline"] = ",".join(shas)
        for k in range(repeats):
            for label, args, e in variants:
                progress(f"sweep-grid: round {k + 1}/{repeats}: {label}")
                data["runs"].setdefault(label, []).append(_run(args, work / "out", e))
            for label, args, e in variants:  # the current code's default and the baselines: their splits
                if args:
                    continue
                progress(f"sweep-grid: round {k + 1}/{repeats}: {label}: the command's and a worker's CPU split")
                data["fixed"].setdefault(label, []).append(_script(FIXED_SCRIPT, work / "out", e))
                data["split"].setdefault(label, []).append(_script(SPLIT_SCRIPT, work / "out", e))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    data["load_end"] = machine.load()
    return data


def _walls(runs: list[dict]) -> str:
    return ", ".join(f"{r['wall']:.1f}" for r in runs)


def _median(runs: list[dict], key) -> float:
    return statistics.median(key(r) for r in runs)


def report(data: dict) -> str:
    runs = data["runs"]
    first = next(iter(runs))
    L = [BEGIN, "## A study at 1000 points/s (`ballmill sweep` on the 4000-point grid, plots on)", ""]
    base = f" --baseline {data['baseline']}" if data.get("baseline") else ""
    L.append(f"Generated by `ballmill bench --section sweep-grid --repeats {data['repeats']}{base}` "
             f"(ballmill/bench/sweep_grid.py): `ballmill sweep {' '.join(GRID)} --out DIR --quiet` as a fresh "
             f"process into an empty folder (interpreter, imports, workers' start, 4000 points, results.parquet "
             f"and 8 PNGs), the variants interleaved, medians of {data['repeats']} rounds. CPU: the command's "
             f"and its workers' (user + system).")
    L.append("")
    L.append("| variant | executor | whole command [s] | points/s (whole command) | CPU [s] | CPU per point [ms] "
             "| the rounds' wall [s] |")
    L.append("|---|---|---|---|---|---|---|")
    for label, rs in runs.items():
        wall, cpu, n = _median(rs, lambda r: r["wall"]), _median(rs, lambda r: r["cpu"]), rs[0]["points"]
        L.append(f"| {label} | {rs[0]['executor']} | {wall:.2f} | {n / wall:.0f} | {cpu:.2f} | {1e3 * cpu / n:.3f} "
                 f"| {_walls(rs)} |")
    L.append("")
    w0 = _median(runs[first], lambda r: r["wall"])
    c0 = _median(runs[first], lambda r: r["cpu"])
    for label, rs in list(runs.items())[1:]:
        L.append(f"- {label}: {_median(rs, lambda r: r['wall']) / w0:.2f} x the default's wall time, "
                 f"{_median(rs, lambda r: r['cpu']) / c0:.2f} x its CPU time.")
    t = runs[first]
    L.append("")
    L.append("Where the default's time goes (timing.json, medians):")
    L.append("")
    L.append("| part | time [s] |")
    L.append("|---|---|")
    for key, label in (("prepare", "checking the scenario, listing the points"),
                       ("cluster_start", "starting a LocalCluster (forked workers start within the run)"),
                       ("run", "first task to last result"),
                       ("cluster_close", "stopping the workers"), ("write", "writing results.parquet"),
                       ("plots", "the PNGs")):
        L.append(f"| {label} | {_median(t, lambda r: r['timing'].get(key, 0.0)):.3f} |")
    n = t[0]["points"]
    for key, label in (("integration", "integration in the workers (kernel runs with the estimate)"),
                       ("indicators", "indicators in the workers"), ("task_cpu", "CPU of the workers' tasks")):
        v = _median(t, lambda r: r["timing"]["workers"].get(key, 0.0))
        L.append(f"| {label} | {v:.3f} ({1e3 * v / n:.3f} ms a point) |")
    for key, what, unit, scale in (
            ("fixed", "The command's own CPU time (not its workers'), part by part (the same command in one process, "
                      "its functions clocked; medians)", "s", 1.0),
            ("split", "A worker's CPU per point, part by part (every 10th point of the grid in one process, no Dask; "
                      "medians)", "ms", 1e3)):
        got = data.get(key) or {}
        if not got:
            continue
        labels = list(got)
        L.append("")
        L.append(what + ":")
        L.append("")
        L.append("| part | " + " | ".join(f"{lb} [{unit}]" for lb in labels) + " |")
        L.append("|---|" + "---|" * len(labels))
        for part in got[labels[0]][0]:
            L.append(f"| {part} | " + " | ".join(
                f"{scale * statistics.median(r[part] for r in got[lb]):.3f}" if part in got[lb][0] else "—"
                for lb in labels) + " |")
    ls, le = data.get("load_start"), data.get("load_end")
    if ls and le:
        L.append("")
        L.append(f"Load average (1, 5, 15 min) at the start: {ls[0]:.2f}, {ls[1]:.2f}, {ls[2]:.2f}; at the end: "
                 f"{le[0]:.2f}, {le[1]:.2f}, {le[2]:.2f} (on {data['nproc']} cores): other processes inflate the "
                 f"wall times; CPU per point is what the two cores must do.")
    L.append(END)
    return "\n".join(L) + "\n"


def run_section(out: Path, repeats: int, baseline: str | None = None, root: Path | None = None,
                progress=print) -> Path:
    data = measure(repeats, baseline, root, progress)
    splice_section(out, report(data), BEGIN, END)
    return out
