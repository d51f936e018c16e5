"""What the master keeps between runs (ballmill.scenario.fmucache): keyed by content, never
stale, and invisible in the results: a run on cached FMUs equals a cold one bit for bit."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from ballmill.scenario import fmucache, runner
from host import run_host


def _fast_start(flavour="native", stop=0.2):
    sc, models, paths = runner.prepare("fast_start", [], log=lambda m: None, flavour=flavour)
    sc.stop = stop
    sc.record = [("ball", "xP"), ("ball", "zP"), ("ball", "N"), ("drive", "psi_dot"), ("ball", "valid")]
    return sc, models, paths


@pytest.mark.parametrize("flavour", ["native", "pythonfmu"])
def test_cached_runs_equal_a_cold_run(flavour):
    fmucache.clear()
    sc, models, paths = _fast_start(flavour)
    cold = runner.run(sc, models, paths, progress=False, echo=False)
    warm = [runner.run(sc, models, paths, progress=False, echo=False) for _ in range(2)]
    assert cold.success and all(w.success for w in warm)
    for w in warm:
        assert np.array_equal(w.data, cold.data)  # same calls, same binary: bit for bit
    # the second run reused the extracted files and the loaded library: nothing was re-extracted
    assert len(fmucache._folders) == 2 and sum(len(p) for p in fmucache._idle.values()) == 2


def test_content_keys_and_what_is_extracted(tmp_path):
    fmucache.clear()
    sc, models, paths = _fast_start()
    ball = paths["BallInShell"]
    copy = tmp_path / "BallInShell.fmu"
    shutil.copy2(ball, copy)
    # the same content under another name: the same entry
    assert fmucache.digest(copy) == fmucache.digest(ball)
    folder = fmucache.extracted(ball)
    assert fmucache.extracted(copy) == folder
    assert (folder / "modelDescription.xml").is_file()
    assert (folder / "binaries").is_dir() and not (folder / "sources").exists()
    # other content (a rewritten file): another digest, another folder, never the stale one
    with open(copy, "ab") as f:
        f.write(b"\0")  # a zip with trailing bytes still opens
    assert fmucache.digest(copy) != fmucache.digest(ball)
    assert fmucache.extracted(copy) != folder
    root = folder.parent
    fmucache.clear()
    assert not root.exists()


def test_two_instances_of_one_fmu_get_their_own_slaves():
    fmucache.clear()
    sc, models, paths = _fast_start()
    path, md = paths["MotorStartup"], models["MotorStartup"]
    a = fmucache.take(path, md, "a")
    b = fmucache.take(path, md, "b")
    assert a is not b and (a.instanceName, b.instanceName) == ("a", "b")
    for s in (a, b):
        s.instantiate()
        s.fmi2FreeInstance(s.component)
        fmucache.give_back(path, s)
    assert fmucache.take(path, md, "c").instanceName == "c"


@pytest.mark.skipif(not os.path.exists("/proc/sys/kernel/pid_max"), reason="needs Linux's pid_max")
def test_folders_of_ended_processes_are_removed():
    fmucache.clear()
    parent = fmucache._ROOT_PARENT
    parent.mkdir(mode=0o700, exist_ok=True)
    # a pid that cannot be running: above the kernel's pid_max
    with open("/proc/sys/kernel/pid_max") as f:
        dead = int(f.read()) + 1
    stale = parent / f"pid-{dead}-x"
    stale.mkdir()
    fmucache.extracted(_fast_start()[2]["MotorStartup"])
    assert not stale.exists()
    assert fmucache._root.name.startswith(f"pid-{os.getpid()}-")


PYTHONFMU_AFTER_A_RUN = """
import sys
from pathlib import Path
from ballmill.scenario import runner
sc, models, paths = runner.prepare("fast_start", [], sys.argv[1], log=lambda m: None, flavour="pythonfmu")
sc.stop = 0.02
assert runner.run(sc, models, paths, progress=False, echo=False).success
import pythonfmu
finish({"pythonfmu": str(Path(pythonfmu.__file__).parent)})
"""


def test_a_pythonfmu_run_leaves_the_installed_pythonfmu_in_use(fmu_build_dir, tmp_path):
    """A pythonfmu FMU run in process puts its resources/ first on sys.path; the pythonfmu that
    the process imports afterwards (e.g. to build FMUs) is still the installed one, with its
    binaries (the FMU's bundled copy has none, and builds from it would have none either)."""
    info = run_host(PYTHONFMU_AFTER_A_RUN, [fmu_build_dir], tmp_path / "info.json")
    assert (Path(info["pythonfmu"]) / "resources" / "binaries").is_dir(), info


def test_a_pythonfmu_without_binaries_builds_nothing(tmp_path, monkeypatch):
    import sys
    import types

    from ballmill.fmi import build

    fake = types.ModuleType("pythonfmu")
    fake.__file__ = str(tmp_path / "pythonfmu" / "__init__.py")
    monkeypatch.setitem(sys.modules, "pythonfmu", fake)
    script = build.ROOT / "drive_models" / "motorstartup_fmu.py"
    with pytest.raises(build.BuildError, match=r"motorstartup_fmu.py: the pythonfmu package imported from "
                                               r".*pythonfmu has no resources/binaries"):
        build.build_one(script, tmp_path / "out")
    assert not (tmp_path / "out").exists()
