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
default variant's timing.json.
"""
from __future__ import annotations

import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .report import splice_section

BEGIN, END = "<!-- section: sweep-grid -->", "<!-- end of section: sweep-grid -->"
GRID = ["fast_start", "--grid", "drive.t0=1:5:40", "--grid", "drive.n0=40:80:100"]
VARIANTS = (("one-pass (default)", []), ("--error richardson", ["--error", "richardson"]),
            ("--error richardson --scheduler local", ["--error", "richardson", "--scheduler", "local"]))


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(args: list[str], out: Path, env: dict) -> dict:
    """The whole command once: wall and CPU time (its own and its children's), its summary.
    It runs in out's parent folder, so that ``python -m`` finds ballmill on env's PYTHONPATH
    (not in the current folder, which ``-m`` would search first)."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "ballmill.cli", "sweep", *GRID, *args, "--out", str(out), "--quiet"]
    c0, t0 = _children_cpu(), time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=out.parent)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr[-2000:]}")
    js = json.loads(res.stdout)
    timing = json.loads((out / "timing.json").read_text())
    return {"wall": wall, "cpu": cpu, "points": js["points"], "plots": len(js["plots"]), "timing": timing,
            "executor": js["executor"]}


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
    env = {**os.environ, "PYTHONPATH": str(here)}
    variants = [(label, args, env) for label, args in VARIANTS]
    data = {"repeats": repeats, "load_start": machine.load(), "nproc": os.cpu_count(), "runs": {}}
    try:
        shas = []
        for ref in (baseline.split(",") if baseline else []):
            progress(f"sweep-grid: extracting and building {ref}")
            tree, sha = _baseline(root or here, ref.strip(), work)
            shas.append(sha)
            variants.append((f"revision {sha} (its default)", [], {**env, "PYTHONPATH": str(tree)}))
        if shas:
            data["baseline"] = ",".join(shas)
        for k in range(repeats):
            for label, args, e in variants:
                progress(f"sweep-grid: round {k + 1}/{repeats}: {label}")
                data["runs"].setdefault(label, []).append(_run(args, work / "out", e))
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
