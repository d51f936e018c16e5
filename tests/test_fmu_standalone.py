"""The built pythonfmu FMUs carry their own copy of the physics: they run in a Python that
has numpy, scipy and fmpy but no ballmill, one after another in one process (fmpy
deletes each FMU's extracted folder after its run).

The hosts write their results before they exit and leave with os._exit (tests/host.py):
pythonfmu 0.7.0's exit defect is asserted on its own, `test_host_exits_cleanly`."""
import json
import subprocess
import sys
import textwrap

import pytest

from host import PROLOGUE, run_host

SCRIPT = textwrap.dedent("""
    import json, sys
    # hide the installed (editable) ballmill: only the FMUs' bundled copies may be used
    sys.meta_path[:] = [f for f in sys.meta_path if "ballmill" not in str(getattr(f, "__module__", ""))
                        and "ballmill" not in type(f).__module__]
    import os
    sys.path[:] = [p for p in sys.path if p not in ("", ".")
                   and not os.path.isfile(os.path.join(p, "ballmill", "__init__.py"))]
    for name in [n for n in sys.modules if n.split(".")[0] == "ballmill"]:
        del sys.modules[name]
    try:
        import ballmill  # noqa: F401
        hidden = False
    except ImportError:
        hidden = True
    from fmpy import simulate_fmu
    fmus = json.loads(sys.argv[1])
    out = {"hidden": hidden}
    r = simulate_fmu(fmus["BallInShell"], stop_time=0.5, output_interval=1e-3,
                     start_values={"xC0": 0.05})
    out["ball_xC_min"] = float(r["xC"].min())
    out["ball_from"] = sys.modules["ballmill"].__file__
    r = simulate_fmu(fmus["InductionMotor"], stop_time=0.2, output_interval=1e-3)
    out["motor_psi_dot_end"] = float(r["psi_dot"][-1])
    r = simulate_fmu(fmus["MotorStartup"], stop_time=1.0, output_interval=1e-2)
    out["startup_psi_dot_end"] = float(r["psi_dot"][-1])
    finish(out)
""")


def test_fmus_run_without_an_installed_ballmill(fmus_of, tmp_path):
    fmus = {name: str(path) for name, path in fmus_of("pythonfmu").items()}
    out = run_host(SCRIPT, [json.dumps(fmus)], tmp_path / "result.json", cwd=tmp_path, timeout=120)
    assert out["hidden"], "the installed ballmill was still importable: the test proves nothing"
    assert "resources" in out["ball_from"]  # the physics came from the FMU's own resources
    # the ball swings from xC0 = 0.05 m to about -0.05 m in half a period (0.56 s > 0.5 s)
    assert -0.051 < out["ball_xC_min"] < -0.045
    assert out["motor_psi_dot_end"] > 1.0  # the induction motor has started the crank
    # the start-up law reaches psi' = w0 (1 - (1 - t/t0)^2) = 2 pi * 0.64 at t = 1 s, t0 = 2.5 s
    assert abs(out["startup_psi_dot_end"] - 2 * 3.141592653589793 * 0.64) < 1e-9


EXIT_SCRIPT = textwrap.dedent("""
    import json, sys
    from fmpy import simulate_fmu
    fmus = json.loads(sys.argv[1])
    out = {}
    for name, path in sorted(fmus.items()):
        r = simulate_fmu(path, stop_time=0.1, output_interval=1e-2)  # frees its instance
        out[name] = len(r)
    with open(sys.argv[-1], "w") as fh:
        json.dump(out, fh)
    # and now the ordinary exit, through the interpreter's finalisation
""")


KNOWN_EXIT_DEFECT = (
    "known defect of pythonfmu 0.7.0: at interpreter exit its library destructor reads a freed "
    "shared_ptr and the host can abort after its work is done ('free(): corrupted unsorted chunks'), "
    "at random; every other host test leaves with os._exit (tests/host.py). Remove this allowance "
    "when the FMUs no longer carry pythonfmu's binary")


def test_host_exits_cleanly(built_fmus, fmu_flavour, tmp_path):
    """A Python that ran each FMU (each instance freed by fmpy) and exits through the
    interpreter's finalisation. Its work is asserted strictly. The native flavour must exit
    with status 0; for the pythonfmu flavour a crash at exit (a signal, after the work was
    written) is the known defect and makes the test xfail; any other non-zero exit fails it."""
    fmus = {name: str(path) for name, path in built_fmus.items()}
    result = tmp_path / "result.json"
    proc = subprocess.run([sys.executable, "-c", EXIT_SCRIPT, json.dumps(fmus), str(result)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.exists(), f"the host did not finish its work (exit status {proc.returncode}):\n" \
                            f"{proc.stderr[-3000:]}"
    assert json.loads(result.read_text()) == {name: 11 for name in fmus}
    if fmu_flavour == "native":
        assert proc.returncode == 0, (proc.returncode, proc.stderr[-3000:])
    elif proc.returncode != 0:
        # a Python error exits with 1; the defect kills the process with a signal (SIGABRT, SIGSEGV)
        assert proc.returncode < 0, (proc.returncode, proc.stderr[-3000:])
        pytest.xfail(f"{KNOWN_EXIT_DEFECT} (exit status {proc.returncode}: {proc.stderr.strip()[-200:]})")


def test_host_results_do_not_depend_on_the_exit(tmp_path):
    """run_host reads the result file written before os._exit, and a host that dies before
    writing it fails the test with its stderr (the harness itself, without an FMU)."""
    assert run_host("finish({'x': 1.5})", [], tmp_path / "a.json") == {"x": 1.5}
    with pytest.raises(AssertionError, match="wrote no result"):
        run_host("import os; os.abort()", [], tmp_path / "b.json")
    assert "os._exit(0)" in PROLOGUE
