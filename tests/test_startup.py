"""What the `ballmill` command costs and says before and around a run: the modules a plain
import (and `--help`) loads, the first build's announcement, what an up-to-date build
rebuilds (nothing), and `--quiet` (nothing on success, errors on stderr).

No timing assertions: the cost is held by what is imported, and by what is built."""
from __future__ import annotations

import contextlib
import io
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from ballmill import cli
from ballmill.fmi import build

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"
# what a command must not import before it needs it (each costs 0.1 to 0.7 s of start-up)
HEAVY = ("scipy", "matplotlib", "dask", "distributed", "fmpy", "pandas", "pyarrow")
# the physics library's own simulators (about 40 ms of imports together), which a scenario run on
# FMUs does not use: importing a module of ballmill.physics does not import them all
SIMULATORS = ("ballmill.physics.hybrid", "ballmill.physics.fast", "ballmill.physics.model",
              "ballmill.physics.integrators", "ballmill.physics.platform", "ballmill.physics.turning")

BUDGET_SCRIPT = """
import importlib, json, sys
heavy = {heavy!r}
found = {{}}
for module in {modules!r}:
    importlib.import_module(module)
    found[module] = sorted(m for m in heavy if m in sys.modules)
from ballmill import cli
for argv in (["--help"], ["run", "--help"]):
    try:
        cli.main(argv)
    except SystemExit:
        pass
    found["ballmill " + " ".join(argv)] = sorted(m for m in heavy if m in sys.modules)
print(json.dumps(found))
"""


def _python(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT)


def test_import_budget():
    """A plain import of the command, of the FMU interface declaration and of what `ballmill
    run` needs before its first plot loads none of scipy, matplotlib, dask or fmpy, nor the
    physics library's simulators; nor does `ballmill --help` or `ballmill run --help`."""
    modules = ["ballmill.cli", "ballmill.fmi.interface", "ballmill.fmi.build", "ballmill.scenario.spec",
               "ballmill.scenario.runner", "ballmill.scenario.report"]
    proc = _python(BUDGET_SCRIPT.format(heavy=HEAVY + SIMULATORS, modules=modules))
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    assert found == {k: [] for k in found}, f"imported too early: {found}"
    assert len(found) == len(modules) + 2


def _short_scenario(tmp_path, name="fast_start", stop=0.2) -> Path:
    """A copy of scenarios/NAME.toml that stops at `stop` [s] (the command, not the physics,
    is under test)."""
    text = (SCENARIOS / f"{name}.toml").read_text()
    text, n = re.subn(r"(?m)^stop\s*=\s*[^#\n]+", f"stop = {stop!r} ", text)
    assert n == 1
    path = tmp_path / f"{name}_short.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def first_build(tmp_path_factory):
    """`ballmill run` (pythonfmu flavour: the same build steps as native, without a compiler's
    seconds) on an empty build folder: (build folder, the run's arguments, its stderr)."""
    tmp = tmp_path_factory.mktemp("first_build")
    bdir, scenario = tmp / "build", _short_scenario(tmp)
    args = ["run", str(scenario), "--flavour", "pythonfmu", "--build-dir", str(bdir), "--out", str(tmp / "out")]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(args) == 0
    return bdir, args, err.getvalue()


def test_first_build_announces_itself_and_builds_only_what_the_run_needs(first_build, capfd):
    """`ballmill run` on an empty build folder says that it builds, how many FMUs and about how
    long, then one line per FMU, before the run starts; it builds the models the scenario
    uses, in the flavour it runs, only; the next run builds nothing and says nothing about
    building."""
    bdir, args, err = first_build
    names = ["BallInShell", "MotorStartup"]  # what fast_start instantiates
    lines = err.splitlines()
    head = lines.index(next(line for line in lines if line.startswith("building ")))
    assert re.fullmatch(rf"building {len(names)} FMUs in {re.escape(str(bdir))} "
                        rf"\(first build; about \d+ s on \d+ free cores?\)\.\.\.", lines[head]), lines[head]
    progress = [re.fullmatch(rf"  \[(\d+)/{len(names)}\] {re.escape(str(bdir / 'pythonfmu'))}/(\w+)\.fmu: built "
                             rf"and validated in \d+\.\d s.*", line) for line in lines[head + 1:head + 1 + len(names)]]
    assert all(progress), lines[head + 1:head + 1 + len(names)]
    assert [int(m.group(1)) for m in progress] == list(range(1, len(names) + 1))
    assert sorted(m.group(2) for m in progress) == names
    assert re.fullmatch(rf"built {len(names)} FMUs in \d+\.\d s", lines[head + 1 + len(names)])
    assert lines.index(next(line for line in lines if line.startswith("running "))) > head + len(names)
    assert sorted(p.stem for p in (bdir / "pythonfmu").glob("*.fmu")) == names  # not the other models
    assert not list(bdir.glob("*.fmu"))  # no native FMU: this run did not need one
    assert cli.main(args) == 0
    err = capfd.readouterr().err
    assert "building" not in err and "up to date" not in err and err.startswith("running "), err


def test_a_changed_source_rebuilds_its_fmus_and_a_touched_one_nothing(first_build):
    """The build decides by content: a source whose modification time changed but whose content
    did not (a checkout, an editor's save) rebuilds nothing; a source whose content differs from
    what an FMU was built from rebuilds exactly the FMUs built from it. (The checkout's files
    are not touched: the build's stamp is edited to say what they were.)"""
    bdir = first_build[0]
    stamp_path = bdir / build.STAMP
    script = str(ROOT / "drive_models" / "motorstartup_fmu.py")

    def build_log() -> list[str]:
        said = []
        build.build_all(bdir, log=said.append, flavour="pythonfmu", only=True, names=["BallInShell", "MotorStartup"])
        return said
    stamp = json.loads(stamp_path.read_text())
    for rec in stamp["files"].values():  # every source seen at another time: as after a fresh checkout
        rec[0] -= 10 ** 9
    stamp_path.write_text(json.dumps(stamp))
    assert build_log() == []
    stamp = json.loads(stamp_path.read_text())  # rewritten with the times as they are
    assert stamp["files"][script][0] == os.stat(script).st_mtime_ns
    stamp["fmus"]["pythonfmu/MotorStartup"]["sources"][script] = "0" * 64  # built from other content
    stamp_path.write_text(json.dumps(stamp))
    said = build_log()
    assert len(said) == 3 and said[0].startswith(f"building 1 FMU in {bdir} (1 with changed sources; about "), said
    assert re.fullmatch(rf"  \[1/1\] {re.escape(str(bdir / 'pythonfmu' / 'MotorStartup.fmu'))}: built and "
                        rf"validated in \d+\.\d s.*", said[1]), said
    assert build_log() == []


def test_quiet_prints_nothing_on_success(fmu_build_dir, tmp_path, capfd):
    """`ballmill run --quiet`: exit status 0 and not a byte on stdout or stderr (no build lines,
    no progress, no summary), the results written all the same."""
    out = tmp_path / "out"
    rc = cli.main(["run", str(_short_scenario(tmp_path, "spinning_bowl", 1.0)), "--quiet",
                   "--build-dir", str(fmu_build_dir), "--out", str(out)])
    captured = capfd.readouterr()
    assert (rc, captured.out, captured.err) == (0, "", "")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] is True and summary["plots"]
    assert all((out / p).is_file() for p in summary["plots"])


@pytest.mark.parametrize("argv, status, says", [
    (["run", "no_such_scenario"], 2, "no_such_scenario"),
    (["run", "fast_start", "--set", "drive.t00=1"], 2, "t00"),
])
def test_quiet_still_reports_errors(fmu_build_dir, tmp_path, capfd, argv, status, says):
    """--quiet keeps the errors: on stderr, with the exit status, nothing on stdout."""
    rc = cli.main(argv + ["--quiet", "--build-dir", str(fmu_build_dir), "--out", str(tmp_path / "out")])
    captured = capfd.readouterr()
    assert rc == status and captured.out == ""
    assert captured.err.startswith("ballmill run: ") and says in captured.err, captured.err
