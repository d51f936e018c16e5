"""Machine and software description for the report."""
from __future__ import annotations

import datetime as _dt
import os
import platform
import shutil
import subprocess
import sys
from pathlib import Path


def _cmd(args, cwd=None):
    try:
        out = subprocess.run(args, capture_output=True, text=True, cwd=cwd, timeout=20)
        return out.stdout.strip() if out.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        return ""


def _cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def info(root: Path, cc: str = "gcc") -> list[tuple[str, str]]:
    import matplotlib
    import numpy
    import scipy

    nproc = _cmd(["nproc"]) or str(os.cpu_count())
    try:
        affinity = len(os.sched_getaffinity(0))
    except AttributeError:
        affinity = os.cpu_count()
    commit = _cmd(["git", "rev-parse", "--short", "HEAD"], cwd=root)
    dirty = _cmd(["git", "status", "--porcelain", "--", "ballmill"], cwd=root)
    rows = [
        ("date (UTC)", _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M")),
        ("nproc", f"{nproc} (usable by this process: {affinity})"),
        ("CPU", _cpu_model()),
        ("OS", f"{platform.system()} {platform.release()} ({platform.machine()})"),
        ("Python", f"{sys.version.split()[0]} ({platform.python_implementation()})"),
        ("numpy", numpy.__version__),
        ("scipy", scipy.__version__),
        ("matplotlib", matplotlib.__version__),
        ("C compiler", (_cmd([cc, "--version"]).splitlines() or ["not found"])[0] if shutil.which(cc) else "not found"),
        ("git", (commit + (" + uncommitted changes in ballmill/" if dirty else "")) if commit else "n/a"),
    ]
    return rows


def load():
    """1-, 5- and 15-minute load averages (None where unavailable)."""
    try:
        return os.getloadavg()
    except (AttributeError, OSError):
        return None


def whole_command(args: list[str], out: Path, env: dict) -> dict:
    """`python -m ballmill.cli ARGS --out OUT --quiet` once, as a fresh process: its wall and CPU
    time (its own and its children's: Dask's workers), its stdout and the timing.json it wrote.
    It runs in out's parent folder, so that ``python -m`` finds ballmill on env's PYTHONPATH
    (not in the current folder, which ``-m`` would search first)."""
    import json
    import resource
    import time

    def children_cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "ballmill.cli", *args, "--out", str(out), "--quiet"]
    c0, t0 = children_cpu(), time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=out.parent)
    wall, cpu = time.perf_counter() - t0, children_cpu() - c0
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr[-2000:]}")
    return {"wall": wall, "cpu": cpu, "stdout": res.stdout, "timing": json.loads((out / "timing.json").read_text())}


def command_env(tree: Path, **extra) -> dict:
    """The environment of a measured command run from the source tree ``tree``: this one's, with
    ``tree`` first on PYTHONPATH and without PYTHONDONTWRITEBYTECODE and BALLMILL_PHASES. A
    user's installed package keeps its bytecode cache (without one, every command compiles
    ballmill's modules again: 0.07 s of CPU for `ballmill run`'s alone), and the phases are
    clocked only where a measurement asks for them (``extra``)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "BALLMILL_PHASES")}
    return {**env, "PYTHONPATH": str(tree), **extra}

