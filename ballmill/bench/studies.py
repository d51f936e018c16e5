"""Benchmark of the study layer: the section "Design studies" of BENCHMARKS.md.

    ballmill bench --section studies [--quick]     run only this section and splice it into the report

What it measures, every study a fresh folder (no resume), each `ballmill sweep`
as a fresh process (``python -m ballmill.cli sweep ... --quiet --no-plots``) so
that the wall time includes interpreter start, imports, cluster start and
shutdown, and writing results.parquet:

1. the 4000-point fast-start study (t0 1.5-4 s x n0 50-70 1/min, 10 s
   simulated, every point's contact point within target_P = 1e-5 m by its own
   estimate) on 2 local worker processes: whole command wall time,
   sustained throughput (points over the time from the first task to the last
   result), and the split of the workers' time (integration, indicators, task
   overhead) and of the command's (cluster start/stop, writing);
2. against, in the same run: a plain Python loop over `simulate` (the same
   model setting, no indicators, no error estimate) and over `ballmill run`
   (one process and one co-simulation per point; a few points, extrapolated);
3. how the time grows with the number of points (1 and 2 local workers, and
   in this process without Dask) and what a scheduler reached by address adds
   (a `dask scheduler` and two `dask worker` processes on this machine,
   started beforehand: what a user's existing cluster looks like to the sweep);
4. the ball absorber's studies (ballmill.sweep.absorber): `absorber_frf` (steady
   states at 0.05 N, refined at the peaks) and `absorber_frf_nonlinear` (up and
   down sweeps at 1 N and 5 N) on 2 local workers with the compiled coupled model,
   and the FRF on a small grid once more with the kernel switched off
   (BALLMILL_NO_KERNEL=1: the pure-Python model). --quick: small grids only.

The section is delimited by HTML comments so that it can be replaced in a
BENCHMARKS.md written by the rest of `ballmill bench`.
"""
from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .report import splice_section

BEGIN, END = "<!-- section: studies -->", "<!-- end of section: studies -->"


def _sweep(args: list[str], out: Path, env=None) -> tuple[float, dict]:
    """(wall time of the whole command, its JSON summary)."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "ballmill.cli", "sweep", *args, "--out", str(out), "--quiet", "--no-plots"]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr[-2000:]}")
    return wall, json.loads(res.stdout)


def _split(out: Path) -> dict:
    return json.loads((out / "timing.json").read_text())


def _grid(n_points: int) -> list[str]:
    """A t0 x n0 grid of about n_points fast starts (t0 1.5-4 s, n0 50-70 1/min)."""
    a = max(1, int(round((n_points / 1.6) ** 0.5 * 1.6 ** 0.5)))
    b = max(1, n_points // a)
    return ["fast_start", "--grid", f"drive.t0=1.5:4:{a}", "--grid", f"drive.n0=50:70:{b}"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _remote(n_workers: int):
    """A `dask scheduler` and n `dask worker` processes on this machine: (address, processes)."""
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    procs = [subprocess.Popen(dask + ["--host", "127.0.0.1", "--port", str(port), "--dashboard-address", ":0"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    worker = [sys.executable, "-m", "distributed.cli.dask_worker", addr, "--nthreads", "1",
              "--no-dashboard", "--nworkers", str(n_workers)]
    procs.append(subprocess.Popen(worker, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    from dask.distributed import Client

    deadline = time.time() + 60
    while time.time() < deadline:
        try:
            with Client(addr, timeout=5) as c:
                if len(c.scheduler_info(n_workers=-1)["workers"]) >= n_workers:
                    return addr, procs
        except OSError:
            pass
        time.sleep(0.5)
    _stop(procs)
    raise RuntimeError("the local dask scheduler/workers did not come up within 60 s")


def _stop(procs):
    for p in reversed(procs):
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()


def _simulate_loop(n: int) -> float:
    """Points per second of a plain loop over `simulate` (RK4 h = 0.005 s, outputs every 0.01 s)."""
    import numpy as np

    from ballmill.physics import Ball, BallModel, CrankStartup, simulate

    t0s = np.linspace(1.5, 4.0, n)
    simulate(BallModel(Ball(), method="RK4", h_fixed=0.005), CrankStartup(0.5, 60.0, 2.5), 10.0, 0.01)
    t, c = time.perf_counter(), time.process_time()
    for t0 in t0s:
        simulate(BallModel(Ball(), method="RK4", h_fixed=0.005), CrankStartup(0.5, 60.0, float(t0)), 10.0, 0.01)
    return n / (time.perf_counter() - t), (time.process_time() - c) / n


def _run_loop(n: int, build_dir: Path) -> float:
    """Points per second of a plain loop over `ballmill run` (a process and a co-simulation a point)."""
    t = time.perf_counter()
    for k in range(n):
        subprocess.run([sys.executable, "-m", "ballmill.cli", "run", "fast_start", "--quiet", "--build-dir",
                        str(build_dir), "--out", str(build_dir / f"run{k}"), "--set", f"drive.t0={2.0 + 0.1 * k}"],
                       capture_output=True, check=True)
    return n / (time.perf_counter() - t)


def measure(quick: bool, progress=print, root: Path | None = None) -> dict:
    from . import machine

    work = Path(tempfile.mkdtemp(prefix="ballmill-bench-studies-"))
    env = dict(os.environ)
    data = {"quick": quick, "load_start": machine.load(), "nproc": os.cpu_count()}
    try:
        main_n = 800 if quick else 4000
        progress(f"studies: {main_n}-point fast-start study on 2 local workers")
        wall, js = _sweep(_grid(main_n) + ["--workers", "2"], work / "main", env)
        data["main"] = {"wall": wall, **js, "split": _split(work / "main")}
        progress("studies: plain loops over simulate and ballmill run")
        data["loop_simulate"], data["loop_simulate_cpu"] = _simulate_loop(100 if quick else 400)
        from ballmill.fmi import build as _build

        bdir = work / "fmus"
        _build.build_all(bdir, log=lambda m: None)
        data["loop_run"] = _run_loop(1 if quick else 3, bdir)
        sizes = (200, 800) if quick else (500, 1000, 2000, 4000)
        data["scaling"] = []
        for n in sizes:
            for label, extra in (("in process", ["--in-process"]), ("1 local worker", ["--workers", "1"]),
                                 ("2 local workers", ["--workers", "2"])):
                progress(f"studies: {n} points, {label}")
                wall, js = _sweep(_grid(n) + extra, work / f"s{n}", env)
                data["scaling"].append({"n": js["points"], "label": label, "wall": wall, **js,
                                        "split": _split(work / f"s{n}")})
        progress("studies: a scheduler reached by address (dask scheduler + 2 dask worker processes here)")
        try:
            addr, procs = _remote(2)
            try:
                for n in sizes[-1:]:
                    wall, js = _sweep(_grid(n) + ["--scheduler", addr], work / f"r{n}", env)
                    data["scaling"].append({"n": js["points"], "label": "scheduler by address, 2 workers",
                                            "wall": wall, **js, "split": _split(work / f"r{n}")})
            finally:
                _stop(procs)
        except RuntimeError as e:
            data["remote_error"] = str(e)
        data["absorber"] = _absorber(quick, work, env, progress)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    data["load_end"] = machine.load()
    return data


ABSORBER_SMALL = ["--grid", "excitation.frequency=0.70:0.90:11"]  # 0.02 Hz, refined at the peaks
NONLINEAR_SMALL = ["--grid", "excitation.F0=1.0", "--grid", "excitation.frequency=0.70:0.90:11"]


def _absorber(quick: bool, work: Path, env: dict, progress=print) -> list[dict]:
    """The absorber studies: [{label, wall, points, split}, ...]."""
    runs = [("absorber_frf, 0.02 Hz start grid over 0.70-0.90 Hz, 0.05 N", ["absorber_frf", *ABSORBER_SMALL], env),
            ("the same, pure Python (BALLMILL_NO_KERNEL=1)", ["absorber_frf", *ABSORBER_SMALL],
             {**env, "BALLMILL_NO_KERNEL": "1"}),
            ("absorber_frf_nonlinear, 1 N only, 0.02 Hz over 0.70-0.90 Hz, up and down",
             ["absorber_frf_nonlinear", *NONLINEAR_SMALL], env)]
    if not quick:
        runs += [("absorber_frf (the study file: 61 points over 0.5-1.1 Hz, refined)", ["absorber_frf"], env),
                 ("absorber_frf_nonlinear (the study file: 1 N and 5 N, 61 frequencies, up and down)",
                  ["absorber_frf_nonlinear"], env)]
    out = []
    for k, (label, args, e) in enumerate(runs):
        progress(f"studies: {label}")
        wall, js = _sweep([*args, "--workers", "2"], work / f"a{k}", e)
        out.append({"label": label, "wall": wall, "points": js["points"], "split": _split(work / f"a{k}")})
    return out


def _f(v, d=3):
    return "—" if v is None else f"{v:.{d}g}"


def report(data: dict) -> str:
    m = data["main"]
    sp = m["split"]
    L = [BEGIN, "## Design studies (`ballmill sweep`)", ""]
    L.append(f"Generated by `ballmill bench --section studies{' --quick' if data['quick'] else ''}` "
             f"(ballmill/bench/studies.py). Each study runs as a fresh `python -m ballmill.cli sweep ... --quiet "
             f"--no-plots` process into an empty folder, so its wall time includes the interpreter, the imports, "
             f"the start and stop of the workers and writing results.parquet. The fast start: 10 s simulated, "
             f"every point in the compiled kernel (RK4 from h = 0.01 s, halved per point until the run's own "
             f"estimate of the contact-point error is below 0.8 x 1e-5 m, no second run; outputs every 0.01 s), "
             f"the indicators of `ballmill.sweep.indicators`, and each point ending where the model stops "
             f"holding.")
    L.append("")
    n = m["points"]
    sustained = sp.get("sustained_points_per_s")
    L.append(f"- **{n}-point study, 2 local worker processes: {m['wall']:.2f} s** for the whole command "
             f"(target: 4000 points within 8 s); sustained **{_f(sustained, 4)} points/s** from the first task to "
             f"the last result (target: at least 1000 points/s on 2 cores).")
    L.append(f"- plain Python loop over `simulate` (same RK4 h = 0.005 s, no indicators, no error estimate, one "
             f"core): {data['loop_simulate']:.0f} points/s ({1e3 * data['loop_simulate_cpu']:.3f} ms CPU a point); "
             f"over `ballmill run` (a process and a co-simulation "
             f"through the FMUs per point): {data['loop_run']:.2f} points/s.")
    L.append("")
    L.append("Where the time of that study goes:")
    L.append("")
    L.append("| part | time [s] |")
    L.append("|---|---|")
    inside = sum(sp.get(k, 0.0) for k in ("prepare", "cluster_start", "run", "cluster_close", "write"))
    sp = {**sp, "setup": m["wall"] - inside}
    for key, label in (("setup", "process start, imports, reading the study, plots off (the rest of the command)"),
                       ("prepare", "checking the scenario, listing the points"),
                       ("cluster_start", "starting a Dask LocalCluster (0 on the default scheduler: its forked workers start inside the run)"),
                       ("run", "from the first task to the last result"),
                       ("cluster_close", "stopping the workers"),
                       ("write", "writing results.parquet")):
        if key in sp:
            L.append(f"| {label} | {sp[key]:.3f} |")
    L.append(f"| whole command (measured outside) | {m['wall']:.3f} |")
    L.append("")
    w = sp.get("workers", {})
    if w:
        tot = w.get("task", 0.0)
        L.append("Summed over the workers' tasks (CPU seconds of both workers together):")
        L.append("")
        L.append("| part | time [s] | per point [ms] |")
        L.append("|---|---|---|")
        for key, label in (("integration", "integration (kernel runs incl. the error estimate's)"),
                           ("indicators", "indicators"),):
            L.append(f"| {label} | {w.get(key, 0):.3f} | {1e3 * w.get(key, 0) / n:.3f} |")
        other = tot - w.get("integration", 0) - w.get("indicators", 0)
        L.append(f"| task overhead inside the worker (parameters, records, rows) | {other:.3f} | {1e3 * other / n:.3f} |")
        L.append(f"| all tasks | {tot:.3f} | {1e3 * tot / n:.3f} |")
        cpu = w.get("task_cpu")
        if cpu:
            L.append(f"| all tasks, CPU time of the threads that ran them | {cpu:.3f} | {1e3 * cpu / n:.3f} |")
            L.append("")
            L.append(f"CPU time per point in the workers: {1e3 * cpu / n:.3f} ms, so two cores given wholly to the "
                     f"workers would sustain about {2 * n / cpu:.0f} points/s (an estimate that load from other "
                     f"processes does not inflate; the wall-clock numbers above are what this run saw).")
        L.append("")
    L.append("How the time grows with the number of points and workers:")
    L.append("")
    L.append("| points | how | whole command [s] | cluster start [s] | first task to last result [s] | sustained "
             "[points/s] | CPU per point in the workers [ms] | batch |")
    L.append("|---|---|---|---|---|---|---|---|")
    for r in data["scaling"]:
        s = r["split"]
        cpu = s.get("workers", {}).get("task_cpu")
        L.append(f"| {r['n']} | {r['label']} | {r['wall']:.2f} | {s.get('cluster_start', 0):.2f} | {s.get('run', 0):.2f} | "
                 f"{_f(s.get('sustained_points_per_s'), 4)} | {_f(1e3 * cpu / r['n'] if cpu else None)} | "
                 f"{r.get('batch', '')} |")
    if data.get("remote_error"):
        L.append("")
        L.append(f"Scheduler by address: not measured ({data['remote_error']}).")
    if data.get("absorber"):
        L.append("")
        L.append("The ball absorber's studies (`ballmill sweep absorber_frf`, `absorber_frf_nonlinear`; "
                 "ballmill.sweep.absorber): each point a steady state of the coupled structure + ball model, "
                 "integrated until the amplitude settles to 1e-3 (DOP853, tol 1e-9); the FRF refined at its "
                 "peaks in rounds, the sweeps one chain (direction and force) per task; 2 local workers.")
        L.append("")
        L.append("| study | points | whole command [s] | first task to last result [s] | integration in the "
                 "workers [s] | CPU of the workers' tasks [s] |")
        L.append("|---|---|---|---|---|---|")
        for r in data["absorber"]:
            s_ = r["split"]
            w = s_.get("workers", {})
            L.append(f"| {r['label']} | {r['points']} | {r['wall']:.2f} | {s_.get('run', 0):.2f} | "
                     f"{w.get('integration', 0):.2f} | {_f(w.get('task_cpu'))} |")
    L.append("")
    ls, le = data.get("load_start"), data.get("load_end")
    if ls and le:
        L.append(f"Load average (1, 5, 15 min) at the start: {ls[0]:.2f}, {ls[1]:.2f}, {ls[2]:.2f}; at the end: "
                 f"{le[0]:.2f}, {le[1]:.2f}, {le[2]:.2f} (on {data['nproc']} cores). Other processes inflate these "
                 f"times; the sweep is CPU-bound, so on a loaded machine the workers share the cores.")
    L.append(END)
    return "\n".join(L) + "\n"


def splice(path: Path, section: str):
    """Put the section into the report at path (replacing an earlier one, else appended)."""
    splice_section(path, section, BEGIN, END)


def run_section(out: Path, quick: bool, progress=print) -> Path:
    data = measure(quick, progress)
    splice(out, report(data))
    return out
