"""Scenario files, the fmpy co-simulation runner and the `ballmill run` command.

Checks of scenario files (every mistake reported with file and key), the
outputs of a run (results.csv, summary.json, plots), the paper's findings for
the fast and slow start-up, the coupled run against the library's monolithic
solution, --set overrides, and a failing run that keeps its data.

The FMUs come from the session's temporary build (conftest.py); every run
writes into pytest's temporary folders.
"""
from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from ballmill import cli
from ballmill.physics import Ball, BallModel, CrankStartup, simulate
from ballmill.scenario import spec
from ballmill.scenario.spec import ScenarioError

SCENARIOS = Path(spec.SCENARIO_DIR)
SUMMARY_KEYS = ("N", "ring", "zP_max_m", "M_reaction_peak_abs_Nm", "validity", "wall_time_s")
PLOTS = ("zP.png", "ring.png", "N.png", "torque.png")


def run_cli(build_dir, scenario, out, *sets, flavour="native"):
    args = ["run", str(scenario), "--out", str(out), "--build-dir", str(build_dir), "--quiet",
            "--flavour", flavour]
    for s in sets:
        args += ["--set", s]
    return cli.main(args)


def read_csv(path):
    with open(path) as fh:
        header = fh.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def column(header, data, name):
    return data[:, header.index(name)]


def copy_scenario(tmp_path, name, **experiment):
    """A copy of scenarios/NAME.toml with some [experiment] values replaced."""
    text = (SCENARIOS / f"{name}.toml").read_text()
    for key, value in experiment.items():
        text, n = re.subn(rf"(?m)^{key}\s*=\s*[^#\n]+", f"{key} = {value!r} ", text)
        assert n == 1, key
    path = tmp_path / f"{name}_copy.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def models(built_fmus):
    return {name: read_model_description(str(p)) for name, p in built_fmus.items()}


@pytest.fixture(scope="module")
def fast_run(fmu_build_dir, fmu_flavour, tmp_path_factory):
    out = tmp_path_factory.mktemp("fast_start")
    t0 = time.perf_counter()
    rc = run_cli(fmu_build_dir, "fast_start", out, flavour=fmu_flavour)
    return rc, out, time.perf_counter() - t0


@pytest.fixture(scope="module")
def slow_run(fmu_build_dir, fmu_flavour, tmp_path_factory):
    # the full 40 s run with t0 = 30 s at the scenario's step (2 ms): about 5 s here
    out = tmp_path_factory.mktemp("slow_start")
    t0 = time.perf_counter()
    rc = run_cli(fmu_build_dir, "slow_start", out, flavour=fmu_flavour)
    return rc, out, time.perf_counter() - t0


# -- scenario files with mistakes ---------------------------------------------------
BAD_SCENARIO = """
description = "every kind of mistake at once"
connections = [
    "drive.x1O -> ball.x1O", "drive.y1O -> ball.y1O",
    "drive.psi -> ball.w1O",
    "drive.vx1O -> ball.ax1O",
    "ball.M_reaction -> drive.M_reaction",
]

[experiment]
start = 0.0
stop = 1.0
step = -0.002

[instances.drive]
fmu = "MotorStartup"
parameters = { l = 0.5, n0 = "fast", t0 = 2.5 }

[instances.ball]
fmu = "BallInShell"
parameters = { rr = 0.025, R = 0.25, formulation = 1.5 }
"""

# (key that must appear, a fragment of the explanation)
EXPECTED_PROBLEMS = [
    ("experiment.step", "must be in (0, stop - start"),
    ("instances.drive.parameters.n0", "expected a Real value, got 'fast'"),
    ("instances.ball.parameters.rr", "has no parameter 'rr'"),
    ("instances.ball.parameters.formulation", "expected a Integer value, got 1.5"),
    ("connections[2]", "'ball' has no input 'w1O'"),
    ("connections[3]", "unit mismatch, m/s -> m/s2"),
]


def test_scenario_mistakes_are_all_listed_with_file_and_key(tmp_path, models):
    path = tmp_path / "bad.toml"
    path.write_text(BAD_SCENARIO)
    with pytest.raises(ScenarioError) as info:
        spec.load(str(path), models=models)
    problems = info.value.problems
    assert len(problems) == len(EXPECTED_PROBLEMS), "\n".join(problems)
    for key, fragment in EXPECTED_PROBLEMS:
        hits = [p for p in problems if f": {key}" in p and fragment in p]
        assert len(hits) == 1, (key, fragment, problems)
        assert hits[0].startswith(path.as_posix() + ": ")
    assert all(p.startswith(path.as_posix()) for p in problems)


def test_scenario_mistakes_through_the_command_line(tmp_path, fmu_build_dir, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(BAD_SCENARIO)
    assert run_cli(fmu_build_dir, path, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert f"{len(EXPECTED_PROBLEMS)} problem(s)" in err
    for key, _ in EXPECTED_PROBLEMS:
        assert key in err
    assert not (tmp_path / "out").exists()  # nothing ran


def test_bad_experiment_values_are_reported_not_raised(tmp_path, models):
    path = tmp_path / "bad_experiment.toml"
    path.write_text(BAD_SCENARIO.replace("stop = 1.0", 'stop = "one second"')
                    .replace("step = -0.002", "step = 0.002"))
    with pytest.raises(ScenarioError) as info:
        spec.load(str(path), models=models)
    stop = [p for p in info.value.problems if "experiment.stop" in p]
    assert len(stop) == 1 and "'one second'" in stop[0]
    assert any("instances.ball.parameters.rr" in p for p in info.value.problems)


# -- a complete run -------------------------------------------------------------------
def test_fast_start_run_writes_results_summary_and_plots(fast_run, models):
    rc, out, wall = fast_run
    assert rc == 0
    header, data = read_csv(out / "results.csv")
    assert header[0] == "time"
    outputs = {f"{inst}.{v.name}" for inst, model in (("drive", "MotorStartup"), ("ball", "BallInShell"))
               for v in models[model].modelVariables if v.causality == "output"}
    assert set(header[1:]) == outputs  # default record: every output, as instance.variable
    assert data.shape == (5001, len(header))
    np.testing.assert_allclose(data[:, 0], np.linspace(0.0, 10.0, 5001), atol=1e-9)
    assert np.all(np.isfinite(data))

    summary = json.loads((out / "summary.json").read_text())
    for key in SUMMARY_KEYS:
        assert key in summary, key
    assert summary["success"] is True and summary["message"] == "completed"
    assert summary["validity"]["contact"]["held_throughout"] is True
    assert summary["wall_time_s"] > 0
    assert summary["zP_max_m"] == pytest.approx(column(header, data, "ball.zP").max(), rel=1e-9)
    assert summary["M_reaction_peak_abs_Nm"] == pytest.approx(
        np.abs(column(header, data, "ball.M_reaction")).max(), rel=1e-9)
    assert summary["after_s"] == 2.5
    for name in PLOTS:
        png = out / name
        assert png.is_file() and png.stat().st_size > 5000, name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(summary["plots"]) == sorted(PLOTS)
    print(f"fast_start: {wall:.2f} s through the CLI, summary wall_time_s = {summary['wall_time_s']}")


def test_paper_findings_fast_versus_slow_start(fast_run, slow_run):
    (rc_f, out_f, wall_f), (rc_s, out_s, wall_s) = fast_run, slow_run
    assert rc_f == 0 and rc_s == 0
    fast = json.loads((out_f / "summary.json").read_text())
    slow = json.loads((out_s / "summary.json").read_text())
    assert slow["after_s"] == 30.0 and fast["after_s"] == 2.5
    n_fast, n_slow = fast["N"]["after"]["range"], slow["N"]["after"]["range"]
    ring_fast, ring_slow = fast["ring"]["width_m"], slow["ring"]["width_m"]
    print(f"N variation after t0: fast {n_fast:.3f} N, slow {n_slow:.3f} N; ring width: fast "
          f"{ring_fast * 1e3:.2f} mm, slow {ring_slow * 1e3:.2f} mm; CLI wall time: fast {wall_f:.1f} s, "
          f"slow {wall_s:.1f} s")
    # the paper: about 9 N of pressure variation after a fast start, almost none after a slow one
    assert 7.5 <= n_fast <= 10.5
    assert n_slow < 1.0
    # and a wider ring of the contact point after the fast start
    assert ring_fast > 5.0 * ring_slow > 0.0
    # the summary agrees with the data it was computed from
    header, data = read_csv(out_s / "results.csv")
    late = column(header, data, "time") >= 30.0 - 1e-9
    assert np.ptp(column(header, data, "ball.N")[late]) == pytest.approx(n_slow, rel=1e-8, abs=1e-9)
    rho = np.hypot(column(header, data, "ball.xP"), column(header, data, "ball.yP"))[late]
    assert rho.max() - rho.min() == pytest.approx(ring_slow, rel=1e-8, abs=1e-12)
    assert slow["validity"]["contact"]["held_throughout"] is True


def test_coupled_run_matches_the_monolithic_solution(fast_run):
    rc, out, _ = fast_run
    assert rc == 0
    header, data = read_csv(out / "results.csv")
    t = column(header, data, "time")
    ref = simulate(BallModel(Ball(), tol=1e-12), CrankStartup(l=0.5, n0=60.0, t0=2.5),
                   t_end=10.0, dt=0.002)
    assert ref.success and len(ref.t) == len(t)
    np.testing.assert_allclose(t, ref.t, atol=1e-9)
    err_p = max(np.max(np.abs(column(header, data, f"ball.{v}P") - ref[f"{v}P"])) for v in "xyz")
    err_n = np.max(np.abs(column(header, data, "ball.N") - ref["N"]))
    err_m = np.max(np.abs(column(header, data, "ball.M_reaction") - ref["M_reaction"]))
    print(f"coupled (H = 2 ms) vs monolithic: contact point {err_p:.3g} m, N {err_n:.3g} N, "
          f"M_reaction {err_m:.3g} N m")
    assert err_p <= 1e-5
    assert err_n <= 1e-3
    # the drive's platform signals are the exact crank law
    x_ref = np.array([CrankStartup(l=0.5, n0=60.0, t0=2.5).state(float(s))[0] for s in t])
    assert np.max(np.abs(column(header, data, "drive.x1O") - x_ref)) < 1e-10


# -- overrides --------------------------------------------------------------------------
def test_set_overrides_reach_the_fmus(tmp_path, fmu_build_dir, fmu_flavour):
    scenario = copy_scenario(tmp_path, "fast_start", stop=2.0)
    out = tmp_path / "out"
    assert run_cli(fmu_build_dir, scenario, out, "drive.t0=1.0", "drive.n0=30", "ball.mu=0.5",
                   flavour=fmu_flavour) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["drive"]["t0"] == 1.0 and summary["parameters"]["drive"]["n0"] == 30
    assert summary["parameters"]["ball"]["mu"] == 0.5
    assert summary["after_s"] == 1.0  # after = "drive.t0" follows the override
    header, data = read_csv(out / "results.csv")
    t, w = column(header, data, "time"), column(header, data, "drive.psi_dot")
    assert data[-1, 0] == pytest.approx(2.0)
    # after t0 = 1 s the crank turns at n0 = 30 1/min = pi rad/s
    assert np.allclose(w[t >= 1.0], math.pi, rtol=1e-12)
    assert w[np.argmin(np.abs(t - 0.5))] == pytest.approx(math.pi * 0.75, rel=1e-9)


@pytest.mark.parametrize("override,fragment", [
    ("nosuch.r=0.02", "no instance 'nosuch'"),
    ("ball.rr=0.02", "--set ball.rr=0.02: BallInShell has no parameter 'rr'"),
    ("ball.formulation=vector", "expected a Integer value, got 'vector'"),
    ("t0=3", "expected instance.parameter=value"),
])
def test_bad_set_is_reported(tmp_path, fmu_build_dir, capsys, override, fragment):
    out = tmp_path / "out"
    assert run_cli(fmu_build_dir, "fast_start", out, override) == 2
    err = capsys.readouterr().err
    assert fragment in err
    assert not out.exists()


# -- a failing run keeps its data --------------------------------------------------------
def test_failing_run_keeps_the_rows_up_to_the_failure(tmp_path, fmu_build_dir, fmu_flavour):
    # the paper formulation driven hard (n0 = 90 1/min reached in 1 s) climbs to the equator
    scenario = copy_scenario(tmp_path, "fast_start", stop=1.5)
    out = tmp_path / "out"
    rc = run_cli(fmu_build_dir, scenario, out, "ball.formulation=2", "drive.n0=90", "drive.t0=1",
                 flavour=fmu_flavour)
    assert rc == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] is False
    assert "ball refused the step" in summary["message"] and "equator" in summary["message"]
    assert any(m["status"] == "discard" and "equator" in m["message"] for m in summary["log"])
    header, data = read_csv(out / "results.csv")
    t = column(header, data, "time")
    assert 0.3 < t[-1] < 1.5
    assert len(t) == round(t[-1] / 0.002) + 1  # every row up to the last good point
    np.testing.assert_allclose(np.diff(t), 0.002, atol=1e-9)
    assert np.all(np.isfinite(data))
    assert f"t = {t[-1]:.6g} s" in summary["message"]
    assert summary["steps"] == len(t) - 1
    assert column(header, data, "ball.zP")[-1] > 0.9 * 0.25  # it got close to the equator
