"""summary.json on small synthetic results whose extremes sit exactly at the window edges.

In the shipped scenarios the extremes never fall on the first sample after t0 or on the
last sample of the run, so a window that loses its first or last sample passes there.
Here every statistic of `report.summarise` has its extreme on an edge: the first sample
of the 'after' window (t = after exactly, and a time a round-off below it), the last
sample of the run, the first sample of the run; and the sample just before the window
holds a value that must not count.
"""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ballmill.scenario import report
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import Instance, Scenario

T = 0.1 * np.arange(11)  # 0 .. 1 s; T[5] == 0.5 exactly


def scenario(after, parameters=None) -> Scenario:
    return Scenario(path=Path("synthetic.toml"), name="synthetic", description="edges", start=0.0,
                    stop=1.0, step=0.1,
                    instances={"ball": Instance("ball", fmu="BallInShell"),
                               "drive": Instance("drive", fmu="MotorStartup", parameters=parameters or {})},
                    connections=[], record=[], plots=[], summary={"ball": "ball", "after": after})


def result(sc, t=T, **cols) -> RunResult:
    names = ["time"] + [f"ball.{k}" for k in cols]
    data = np.column_stack([t] + [np.asarray(v, dtype=float) for v in cols.values()])
    return RunResult(scenario=sc, columns=names, data=data, success=True, message="completed",
                     messages=[{"status": "warning", "message": "w"}, {"status": "ok", "message": "o"}])


def models(t0_default=2.5):
    md = SimpleNamespace(modelVariables=[SimpleNamespace(name="t0", start=t0_default)])
    # the ball's mu: the summary's indicators judge the rolling margin with it
    return {"MotorStartup": md, "BallInShell": SimpleNamespace(modelVariables=[SimpleNamespace(name="mu", start=0.3)])}


# N: overall min at the run's first sample, overall max just before the window (t = 0.4),
# the window's max on its first sample (t = 0.5) and its min on the run's last sample
N = [-3.0, 1.0, 2.0, 2.0, 99.0, 50.0, 10.0, 11.0, 12.0, 13.0, 4.0]
# the contact point's ring: outside radii before the window, the window's inner radius on
# its first sample and its outer radius on the last
XP = [0.30, 0.1, 0.1, 0.1, 0.01, 0.15, 0.18, 0.18, 0.18, 0.18, 0.22]
YP = [0.0] * 11
ZP = [0.24, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]  # highest on the first sample
MR = [0.5, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -2.0]  # peak |M| on the last sample
FR = [0.3, 0.1, 1e300, np.nan, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]  # largest finite on the first


def full(after=0.5, t=T):
    sc = scenario(after)
    return report.summarise(result(sc, t=t, N=N, xP=XP, yP=YP, zP=ZP, M_reaction=MR,
                                   contact=[1] * 10 + [0], rolling=[0] + [1] * 10, friction_ratio=FR),
                            models())


def test_after_window_starts_on_its_first_sample():
    s = full()
    assert s["after_s"] == 0.5
    assert s["N"]["all"] == {"min": -3.0, "max": 99.0, "range": 102.0}
    # 50 at t = 0.5 is in the window, 99 at t = 0.4 is not; 4 on the last sample is its min
    assert s["N"]["after"] == {"min": 4.0, "max": 50.0, "range": 46.0}
    assert s["ring"]["inner_radius_m"] == pytest.approx(0.15, abs=0)
    assert s["ring"]["outer_radius_m"] == pytest.approx(0.22, abs=0)
    assert s["ring"]["width_m"] == pytest.approx(0.07, rel=1e-12)


def test_whole_run_extremes_on_the_first_and_last_samples():
    s = full()
    assert s["zP_max_m"] == 0.24
    assert s["M_reaction_peak_abs_Nm"] == 2.0
    v = s["validity"]
    # the interpolated time is the sample's where the margin (N here) does not change sign there
    assert v["contact"] == {"held_throughout": False, "first_failure_s": 1.0, "first_failure_interpolated_s": 1.0}
    assert v["rolling"] == {"held_throughout": False, "first_failure_s": 0.0, "first_failure_interpolated_s": 0.0}
    # 1e300 stands for 'no contact' and NaN is no number: the largest real ratio, 0.3 at t = 0
    assert v["friction_ratio_max"] == 0.3
    assert s["log"] == [{"status": "warning", "message": "w"}]  # 'ok' messages are left out


def test_window_start_a_round_off_below_after():
    """A sample time that the grid's arithmetic puts 1e-15 s below 'after' is in the window."""
    t = T.copy()
    t[5] = 0.5 - 1e-15
    s = full(t=t)
    assert s["N"]["after"]["max"] == 50.0 and s["ring"]["inner_radius_m"] == 0.15


def test_window_start_between_samples_and_at_the_end():
    s = full(after=0.45)  # the window starts at the first sample after 0.45: the same as 0.5
    assert s["N"]["after"] == {"min": 4.0, "max": 50.0, "range": 46.0}
    s = full(after=0.35)  # now 99 at t = 0.4 is in
    assert s["N"]["after"]["max"] == 99.0 and s["ring"]["inner_radius_m"] == 0.01
    s = full(after=1.0)  # the last sample alone
    assert s["N"]["after"] == {"min": 4.0, "max": 4.0, "range": 0.0}
    assert s["ring"] == {"inner_radius_m": 0.22, "outer_radius_m": 0.22, "width_m": 0.0}
    s = full(after=1.5)  # after the run: an empty window
    assert s["N"]["after"] is None
    assert s["ring"] == {"inner_radius_m": None, "outer_radius_m": None, "width_m": None}
    s = full(after=0.0)  # the whole run
    assert s["N"]["after"] == s["N"]["all"]


def test_after_from_a_parameter_or_its_default():
    sc = scenario("drive.t0", parameters={"t0": 0.5})
    s = report.summarise(result(sc, N=N), models(t0_default=9.0))
    assert s["after_s"] == 0.5 and s["N"]["after"]["max"] == 50.0
    sc = scenario("drive.t0")  # not set in the scenario: the FMU's start value
    s = report.summarise(result(sc, N=N), models(t0_default=0.5))
    assert s["after_s"] == 0.5 and s["N"]["after"] == {"min": 4.0, "max": 50.0, "range": 46.0}
    # and only what was recorded is summarised
    assert "ring" not in s and "zP_max_m" not in s and s["validity"] == {}


def test_the_ball_instance_is_found_without_a_summary_key():
    sc = scenario(0.5)
    sc.summary = {"after": 0.5}
    s = report.summarise(result(sc, N=N), models())
    assert s["N"]["after"]["max"] == 50.0
