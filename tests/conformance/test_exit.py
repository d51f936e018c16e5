"""The exit crash: a process that instantiated InductionMotor.fmu (pythonfmu 0.7.0) aborts
at interpreter exit in a few % of runs ("corrupted double-linked list"). Cause (valgrind,
docs/OTHER_TOOLS.md): the library's destructor function finalizePythonInterpreter, run by
_dl_fini, assigns to the static std::shared_ptr pyState after exit() has already run the
C++ static destructors and freed its control block. The avoidance used by `ballmill`
(ballmill.cli.entry) and documented for hosts: free every instance, then leave with
os._exit, which runs neither. Each process here checks that it really instantiated,
initialised, stepped and freed the FMU before leaving.

The native flavours (FMI 2.0 and 3.0) leave normally, through exit(): their libraries
register no exit handler or destructor function and keep no mutable static data (all
their state is the instance's, freed by fmi2FreeInstance / fmi3FreeInstance), so a defect
of theirs at exit would show in every process, not in a few %: a few processes each suffice
there, the forty are pythonfmu's (its crash rate of a few % needs them)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from .conftest import ROOT

SCRIPT = r'''
import os, sys
sys.path.insert(0, sys.argv[1])
from tests.conformance.harness import driver
fmu = driver(int(sys.argv[4]))(sys.argv[2], "motor")
assert fmu.init() == 0 and fmu.step(1e-3) == 0, fmu.messages()
fmu.free()
print("freed", flush=True)
if sys.argv[3] == "os_exit":
    os._exit(0)
'''

RUNS = {"pythonfmu": 40}  # processes per flavour
NATIVE_RUNS = 4
AT_ONCE = 4  # processes started together (each one mostly waits on its own start-up)


def test_forty_processes_with_the_induction_motor_exit_cleanly(fmus, flavour):
    how = "os_exit" if flavour.name == "pythonfmu" else "normal"
    cmd = [sys.executable, "-c", SCRIPT, str(ROOT), str(fmus["InductionMotor"]), how, str(flavour.fmi)]
    failures, n = [], RUNS.get(flavour.name, NATIVE_RUNS)
    for first in range(0, n, AT_ONCE):
        procs = [(k, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT))
                 for k in range(first, min(n, first + AT_ONCE))]
        for k, proc in procs:
            out, err = proc.communicate(timeout=300)
            if proc.returncode != 0 or "freed" not in out:
                failures.append((k, proc.returncode, err[-300:]))
    assert failures == []


@pytest.mark.parametrize("command", [["ballmill", "run", "induction_start", "--quiet", "--set", "motor.model=1"]])
def test_the_ballmill_command_leaves_without_the_exit_handlers(tmp_path, command, fmu_build_dir):
    """`ballmill run` on an InductionMotor scenario: exit status 3 (the direct start leaves
    the model's validity at 10 ms), results written, no abort."""
    import shutil

    exe = shutil.which("ballmill", path=str(__import__("pathlib").Path(sys.executable).parent))
    proc = subprocess.run([exe] + command[1:] + ["--out", str(tmp_path), "--build-dir", str(fmu_build_dir)],
                          capture_output=True, text=True,
                          timeout=600, cwd=ROOT)
    assert proc.returncode == 3, proc.stderr[-2000:]
    assert (tmp_path / "summary.json").exists()
    assert "validity ended" in proc.stderr
