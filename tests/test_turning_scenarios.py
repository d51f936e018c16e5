"""The scenarios of a chamber that turns: spinning_bowl, tumbling_drum and
fig1_machine, Fig1Drive + BallInShell (motion = 2) through `ballmill run`, against the
library (simulate_chamber with Spin / Fig1Machine) and the closed forms; and the report's
shell summary and plot kinds on library data."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from ballmill import cli
from ballmill.physics import Ball
from ballmill.physics.turning.model import simulate_chamber
from ballmill.physics.turning.motions import ConstantSpeed, Fig1Machine, Spin
from ballmill.physics.drives.crank import CrankStartup
from ballmill.plotting import shell
from ballmill.scenario import spec
from ballmill.scenario.report import summarise, write_all
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import ScenarioError

BALL = Ball(r=0.025, R=0.25, m=0.5105088062083415, g=9.81, mu=0.3)
TURNING = ("spinning_bowl", "tumbling_drum", "fig1_machine")
# the library's scenes, as the scenario files define them (A at O1 for the drum: the shaft
# passes through O1; the ball's motion relative to A does not depend on where A is)
LIBRARY = {
    "spinning_bowl": (Spin((0.0, 0.0, 3.0), (0.0, 0.0, BALL.R)), 0.05),
    "tumbling_drum": (Spin((0.8, 0.0, 0.0), (0.0, 0.0, 0.0)), 0.0),
    "fig1_machine": (Fig1Machine(frame=ConstantSpeed(0.5), crank=CrankStartup(l=0.5, n0=60.0, t0=2.5)), 0.0),
}


def _library(name, t_end=10.0, dt=0.002):
    motion, xC0 = LIBRARY[name]
    tr = simulate_chamber(BALL, motion, t_end, dt, xC0=xC0, tol=1e-11)
    assert tr.success, tr.message
    return tr


def _fake_run(name, tr):
    """A RunResult with the ball's columns taken from a library trajectory."""
    sc = spec.load(name)
    cols = {"time": tr.t, "ball.xP_ch": tr["Pch_x"], "ball.yP_ch": tr["Pch_y"], "ball.zP_ch": tr["Pch_z"],
            "ball.N": tr["N"], "ball.Ft": tr["Ft"], "ball.friction_ratio": np.where(tr["N"] > 0, tr["friction_ratio"], 1e300),
            "ball.contact": tr["contact"], "ball.rolling": tr["rolling"], "drive.T_frame": -tr["M1"],
            "drive.T_crank": -tr["M2"]}
    sc.record = [tuple(k.split(".", 1)) for k in cols if k != "time"]
    return RunResult(sc, list(cols), np.column_stack(list(cols.values())), True, "completed")


def test_report_summarises_the_shell_and_draws_it(tmp_path):
    """On the library's Fig. 1 machine: the summary's visited fraction is the study's measure up to
    the first failure, its interpolated failure times are the library's (rolling 2.5081 s, contact
    2.5846 s, docs/fig1_machine.md), and the shell and slip-margin plots are drawn."""
    tr = _library("fig1_machine", t_end=4.0)
    res = _fake_run("fig1_machine", tr)
    out = write_all(res, {}, tmp_path)
    v = out["validity"]
    assert v["rolling"]["first_failure_interpolated_s"] == pytest.approx(2.5081, abs=2e-4)
    assert v["contact"]["first_failure_interpolated_s"] == pytest.approx(2.5846, abs=2e-4)
    u = shell.unit_vectors(tr["Pch_x"], tr["Pch_y"], tr["Pch_z"], BALL.R)
    assert out["shell"]["visited_fraction_all"] == shell.visited_fraction(u)
    k = int(np.searchsorted(tr.t, v["rolling"]["first_failure_s"]))
    # no `valid` column here: the valid span is the whole run (the FMU's latch shortens it)
    assert out["shell"]["visited_fraction_valid"] == shell.visited_fraction(u)
    assert 0.0 < shell.visited_fraction(u, k) < out["shell"]["visited_fraction_all"] <= 1.0
    for f in ("shell.png", "slip_margin.png", "N.png", "torques.png"):
        assert (tmp_path / f).stat().st_size > 10000, f


def test_unit_vectors_put_the_lowest_point_at_the_bottom():
    u = shell.unit_vectors([0.0, 0.25, 0.0], [0.0, 0.0, 0.0], [0.0, 0.25, 0.5], 0.25)
    assert np.allclose(u, [[0, 0, -1], [1, 0, 0], [0, 0, 1]])


def test_a_shell_plot_needs_the_chamber_outputs(tmp_path, built_fmus):
    """A shell plot whose contact point is not recorded, and an unknown plot kind, are refused
    with the file and the plot's key."""
    models = {name: read_model_description(str(p)) for name, p in built_fmus.items()}
    text = (spec.SCENARIO_DIR / "spinning_bowl.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[summary]", '[record]\nvariables = ["ball.N", "ball.Ft", "ball.friction_ratio", '
                                '"drive.T_frame"]\n\n[summary]')
                   + '\n[[plots]]\nkind = "pie"\nfile = "p.png"\n')
    with pytest.raises(ScenarioError) as e:
        spec.load(str(bad), models=models)
    problems = e.value.problems
    assert len(problems) == 2, problems
    assert problems[0].endswith("plots[0]: a shell plot needs ball.xP_ch, ball.yP_ch, ball.zP_ch recorded "
                                "(BallInShell with motion = 2 has them)"), problems
    assert problems[1].endswith("plots[4].kind: expected one of series, shell, slip_margin, got 'pie'"), problems
    assert all(p.startswith(bad.as_posix() + ": ") for p in problems)


# ----------------------------------------------------------------------------- the FMU runs
@pytest.fixture(scope="module")
def turning_runs(fmu_build_dir, tmp_path_factory):
    runs = {}
    for name in TURNING:
        out = tmp_path_factory.mktemp(name)
        rc = cli.main(["run", name, "--out", str(out), "--build-dir", str(fmu_build_dir), "--quiet"])
        runs[name] = rc, out
    return runs


def _results(out: Path):
    with open(out / "results.csv") as fh:
        header = fh.readline().strip().split(",")
    data = np.loadtxt(out / "results.csv", delimiter=",", skiprows=1, ndmin=2)
    return {h: data[:, i] for i, h in enumerate(header)}


# largest differences from the library accepted while the model is valid: contact point [m], N [N].
# Bowl and drum turn at a constant Omega about a fixed A: the ball's input reconstruction is exact
# (measured 2.5e-13 m, 6e-12 N; 5.8e-13 m, 5.4e-12 N). The Fig. 1 machine: the contact point to
# 1.1e-9 m; N (a predictor output, docs/usage.md's known limits) is off at the first step, where the
# reconstruction has one sample only (3.8e-3 N at 2 ms), and one step after the crank law's kink
# at t0 (1.0e-3 N at 2.502 s), both in proportion to the 2 ms step; 1.5e-8 N elsewhere.
TOLERANCE = {"spinning_bowl": (1e-11, 1e-10, 1e-10), "tumbling_drum": (1e-11, 1e-10, 1e-10),
             "fig1_machine": (1e-8, 1e-2, 1e-6)}  # (P, N anywhere, N away from t = 0 and t0)


@pytest.mark.parametrize("name", TURNING)
def test_scenario_runs_as_the_library(turning_runs, name):
    """The co-simulated contact point (chamber axes) and N against the monolithic library run
    (DOP853 at 1e-11), while the model is valid, within TOLERANCE (justified there)."""
    rc, out = turning_runs[name]
    summary = json.loads((out / "summary.json").read_text())
    r = _results(out)
    tr = _library(name)
    n = min(len(tr.t), len(r["time"]))
    t = r["time"][:n]
    assert np.allclose(t, tr.t[:n], atol=1e-9)
    valid = r["ball.valid"][:n] > 0.5
    dP = max(float(np.max(np.abs(r[f"ball.{c}P_ch"][:n][valid] - tr[f"Pch_{c}"][:n][valid]))) for c in "xyz")
    eN = np.abs(r["ball.N"][:n] - tr["N"][:n])
    dN = float(np.max(eN[valid]))
    smooth = valid & (t > 0.0021) & ((t < 2.4999) | (t > 2.5021))
    dN_smooth = float(np.max(eN[smooth]))
    tol_P, tol_N, tol_N_smooth = TOLERANCE[name]
    assert dP < tol_P and dN < tol_N and dN_smooth < tol_N_smooth, (dP, dN, dN_smooth)
    for plot in ("shell.png", "N.png", "slip_margin.png", "torques.png"):
        assert (out / plot).stat().st_size > 10000
    assert 0.0 < summary["shell"]["visited_fraction_valid"] <= summary["shell"]["visited_fraction_all"]
    if name != "fig1_machine":
        assert rc == 0 and summary["left_validity"] is False
    # the drive reads the ball's wrench at the communication points (Jacobi exchange): its moments
    # at t_k are those of the ball's outputs at t_(k-1), exactly (as MotorStartup's T_drive)
    e = "MO1z" if name == "spinning_bowl" else "MO1x"
    assert np.array_equal(r["drive.M_frame"][1:], r[f"ball.{e}"][:-1])
    assert np.array_equal(r["drive.T_frame"][1:], -r[f"ball.{e}"][:-1])  # no inertias in the scenario
    if name != "fig1_machine":  # a constant spin: the drive's power is the library's P_ball one step late
        P = -(r["drive.T_frame"] * r["drive.phi_dot"])[1:n]
        assert np.allclose(P, -tr["P_ball"][:n - 1], rtol=0, atol=1e-9 * np.abs(tr["P_ball"]).max())


def test_bowl_oscillates_at_the_closed_form_frequencies(fmu_build_dir):
    """The spinning bowl from xC0 = 1 mm (small oscillations): n = (C - A)/d in the fixed frame,
    from the FMU run's contact point and the drive's Q; the fit of A+ exp(i s+ t) +
    A- exp(i s- t) to n_x + i n_y over 4 s gives the closed form's s+- = beta/2 +-
    sqrt(beta^2/4 + w0^2), beta = 2 Omega/7 (the nonlinear shift ~ amplitude^2 = 2e-5 rad^2)."""
    from ballmill.scenario import runner
    from ballmill.studies import fig1

    sc, models, paths = runner.prepare("spinning_bowl", ["ball.xC0=0.001"], fmu_build_dir, log=lambda m: None)
    sc.stop = 4.0
    res = runner.run(sc, models, paths, progress=False, echo=False)
    assert res.success, res.message
    col = res.column
    Q = np.stack([col(f"drive.Q{i}{j}") for i in (1, 2, 3) for j in (1, 2, 3)], axis=1).reshape(-1, 3, 3)
    u = shell.unit_vectors(col("ball.xP_ch"), col("ball.yP_ch"), col("ball.zP_ch"), BALL.R)
    nvec = np.einsum("kij,kj->ki", Q, u)
    sp, sm, misfit = fig1.measured_bowl_frequencies(col("time"), nvec)
    cp, cm = fig1.bowl_frequencies(3.0)
    beta = 2.0 * 3.0 / 7.0
    assert cp == pytest.approx(beta / 2 + math.sqrt(beta ** 2 / 4 + BALL.omega_small ** 2), rel=1e-12)
    assert cm == pytest.approx(beta / 2 - math.sqrt(beta ** 2 / 4 + BALL.omega_small ** 2), rel=1e-12)
    print(f"s+ {sp:.7f} closed {cp:.7f}; s- {sm:.7f} closed {cm:.7f}; misfit {misfit:.1e}")
    assert sp == pytest.approx(cp, rel=1e-4) and sm == pytest.approx(cm, rel=1e-4) and misfit < 1e-3


def test_fig1_machine_fails_when_the_library_says(turning_runs):
    """Rolling first fails at 2.5081 s and contact at 2.5846 s in the library; the FMU run's
    interpolated times agree within 2 ms (one communication step)."""
    rc, out = turning_runs["fig1_machine"]
    v = json.loads((out / "summary.json").read_text())["validity"]
    assert v["rolling"]["first_failure_interpolated_s"] == pytest.approx(2.5081, abs=2e-3)
    assert v["contact"]["first_failure_interpolated_s"] == pytest.approx(2.5846, abs=2e-3)
    assert rc == 3  # ran, left the model's validity
