"""The built pythonfmu FMUs carry their own copy of the physics: they run in a Python that
has numpy, scipy and fmpy but no ballmill, one after another in one process (fmpy
deletes each FMU's extracted folder after its run)."""
import json
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import json, sys
    # hide the installed (editable) ballmill: only the FMUs' bundled copies may be used
    sys.meta_path[:] = [f for f in sys.meta_path if "ballmill" not in str(getattr(f, "__module__", ""))
                        and "ballmill" not in type(f).__module__]
    sys.path[:] = [p for p in sys.path if p not in ("", ".") and not p.endswith("/main")]
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
    print(json.dumps(out))
""")


def test_fmus_run_without_an_installed_ballmill(fmus_of, tmp_path):
    fmus = {name: str(path) for name, path in fmus_of("pythonfmu").items()}
    proc = subprocess.run([sys.executable, "-c", SCRIPT, json.dumps(fmus)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["hidden"], "the installed ballmill was still importable: the test proves nothing"
    assert "resources" in out["ball_from"]  # the physics came from the FMU's own resources
    # the ball swings from xC0 = 0.05 m to about -0.05 m in half a period (0.56 s > 0.5 s)
    assert -0.051 < out["ball_xC_min"] < -0.045
    assert out["motor_psi_dot_end"] > 1.0  # the induction motor has started the crank
    # the start-up law reaches psi' = w0 (1 - (1 - t/t0)^2) = 2 pi * 0.64 at t = 1 s, t0 = 2.5 s
    assert abs(out["startup_psi_dot_end"] - 2 * 3.141592653589793 * 0.64) < 1e-9
