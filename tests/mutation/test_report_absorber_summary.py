"""The tower engineer's summary of an absorber scenario (ballmill.scenario.report.absorber_summary
with _structure_data and _ball_parameter), every key and value, on small synthetic runs whose
numbers are worked out by hand below: which columns feed which statistic, the ball's angle
theta = arccos(1 - zP / R) from its height, R and mu from the scenario or else from the model
description, the window after [summary] after, and the comparison with the bare run (used only
when it completed on the same time grid, else a message saying why not). The scenario tests
reach this code only with built FMUs (docs/mutation.md); structure_summary's own arithmetic is
pinned by tests/mutation/test_absorber_summary.py.
"""
from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ballmill.scenario import report
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import Instance, Scenario

T = [0.0, 0.1, 0.2, 0.3, 0.4]  # [s]; the window after = 0.2 s holds the last three rows
# The structure at the absorber: before the window huge values (they must not count); in the
# window |(x, y)| = 0.5, 0, 0.3 m (a 3-4-5 triangle) and |(ax, ay)| = 5, 0, 0 m/s2.
TOWER = {"x_rel": [10.0, -10.0, 0.3, 0.0, -0.3], "y_rel": [10.0, 10.0, 0.4, 0.0, 0.0],
         "ax1O": [100.0, 100.0, 3.0, 0.0, 0.0], "ay1O": [-100.0, 100.0, -4.0, 0.0, 0.0]}


def own(scale=1.0, prefix=""):
    """The structure's statistics over the window (TOWER's numbers times scale), by hand."""
    return {f"{prefix}displacement_peak_m": 0.5 * scale,
            f"{prefix}displacement_rms_m": scale * math.sqrt((0.25 + 0.0 + 0.09) / 3.0),
            f"{prefix}displacement_x_peak_m": 0.3 * scale, f"{prefix}displacement_y_peak_m": 0.4 * scale,
            f"{prefix}acceleration_peak_m_s2": 5.0 * scale,
            f"{prefix}acceleration_rms_m_s2": scale * math.sqrt(25.0 / 3.0),
            f"{prefix}acceleration_x_peak_m_s2": 3.0 * scale, f"{prefix}acceleration_y_peak_m_s2": 4.0 * scale}


REDUCTIONS = {"reduction_displacement_peak_percent": 50.0, "reduction_displacement_rms_percent": 50.0,
              "reduction_acceleration_peak_percent": 50.0, "reduction_acceleration_rms_percent": 50.0}


def scenario(ball_parameters=None, with_ball=True, after=0.2):
    inst = {"tower": Instance("tower", fmu="Structure", parameters={"n_x": 1})}
    if with_ball:
        inst["ball"] = Instance("ball", fmu="BallInShell", parameters=dict(ball_parameters or {}))
    return Scenario(path=Path("absorber.toml"), name="absorber", description="synthetic absorber", start=0.0,
                    stop=0.4, step=0.1, instances=inst, connections=[], record=[], plots=[],
                    summary={"structure": "tower", "after": after})


def models(**starts):
    """Model descriptions: BallInShell's start values (a decoy first, so a lookup that takes the
    first variable or the wrong one shows)."""
    ball = [SimpleNamespace(name="decoy", start=123.0)] + [SimpleNamespace(name=k, start=v) for k, v in starts.items()]
    return {"BallInShell": SimpleNamespace(modelVariables=ball), "Structure": SimpleNamespace(modelVariables=[])}


def run(sc, tower, ball=None, success=True, message="completed", rows=None):
    cols = {f"tower.{k}": v for k, v in tower.items()}
    cols.update({f"ball.{k}": v for k, v in (ball or {}).items()})
    n = len(T) if rows is None else rows
    data = np.column_stack([np.asarray(T[:n], float)] + [np.asarray(v[:n], float) for v in cols.values()])
    return RunResult(scenario=sc, columns=["time", *cols], data=data, success=success, message=message)


def bare_run(sc, scale=2.0, **kw):
    return run(sc, {k: [scale * x for x in v] for k, v in TOWER.items()}, **kw)


def check(got, want):
    """Every key, no more no fewer, each value to rounding."""
    assert sorted(got) == sorted(want)
    for k, v in want.items():
        if isinstance(v, float) and not isinstance(v, bool):
            assert got[k] == pytest.approx(v, rel=1e-13, abs=1e-15), k
        else:
            assert got[k] == v and type(got[k]) is type(v), k


# Two balls: (scenario parameters, model start values, ball columns, expected ball keys).
# A: R from the scenario, mu from the model; theta 60 deg at zP = R / 2, and a zP a rounding
#    error below the lowest point (1 - zP / R just above 1: theta 0, not nan); N stays positive
#    (contact throughout), friction_ratio 0.3 > mu at t = 0.1 (slip then).
# B: R from the model, mu from the scenario; zP a rounding error above the top (1 - zP / R just
#    below -1: theta 180 deg, not nan); N <= 0 at t = 0.2 (contact lost), friction_ratio <= mu.
BALLS = {
    "A": ({"R": 0.5, "r": 0.05}, {"mu": 0.25, "R": 7.0},
          {"xP": [9.0, 9.0, 0.03, 0.0, -0.01], "yP": [9.0, 9.0, 0.04, 0.02, 0.0],
           "zP": [0.9, 0.9, 0.25, -1.2e-16, 0.25], "N": [1.0, 1.0, 3.0, 2.0, 4.0],
           "friction_ratio": [0.1, 0.3, 0.2, 0.1, 0.05]},
          {"ball_excursion_max_m": 0.05, "ball_angle_max_deg": 60.0, "N_min_N": 2.0, "friction_ratio_max": 0.2,
           "contact": True, "contact_lost_at_s": None, "mu": 0.25, "rolling": False, "slip_at_s": 0.1}),
    "B": ({"mu": 0.4, "r": 0.05}, {"R": 0.5, "mu": 9.0},
          {"xP": [0.0, 0.0, 0.0, 0.06, 0.0], "yP": [0.0, 0.0, 0.0, -0.08, 0.0],
           "zP": [0.0, 0.0, 0.25, 1.0000000000000002, 0.0], "N": [1.0, 1.0, -1.0, 2.0, 4.0],
           "friction_ratio": [0.1, 0.4, 0.2, 0.1, 0.05]},
          {"ball_excursion_max_m": 0.1, "ball_angle_max_deg": 180.0, "N_min_N": -1.0, "friction_ratio_max": 0.2,
           "contact": False, "contact_lost_at_s": 0.2, "mu": 0.4, "rolling": True, "slip_at_s": None}),
}


@pytest.mark.parametrize("case", sorted(BALLS))
def test_absorber_summary_with_the_ball_and_the_bare_structure(case):
    params, starts, ball, want_ball = BALLS[case]
    sc = scenario(params)
    res = run(sc, TOWER, ball)
    want = {"from_s": 0.2, "to_s": 0.4, **own(), **own(2.0, "bare_"), **REDUCTIONS, **want_ball}
    check(report.absorber_summary(res, models(**starts), bare_run(sc)), want)
    # without a bare run: the structure and the ball only, and no word about a bare run
    check(report.absorber_summary(res, models(**starts)), {"from_s": 0.2, "to_s": 0.4, **own(), **want_ball})
    # the window's start named as a parameter the model description holds (0.2 s)
    sc = scenario(params, after="ball.t_window")
    res = run(sc, TOWER, ball)
    check(report.absorber_summary(res, models(**starts, t_window=0.2)), {"from_s": 0.2, "to_s": 0.4, **own(), **want_ball})


def test_a_bare_run_that_cannot_be_compared_is_named_not_used():
    params, starts, ball, want_ball = BALLS["A"]
    sc = scenario(params)
    res = run(sc, TOWER, ball)
    mine = {"from_s": 0.2, "to_s": 0.4, **own(), **want_ball}
    # it failed (same length): not compared, its message given
    failed = bare_run(sc, success=False, message="step 3 refused: N < 0")
    check(report.absorber_summary(res, models(**starts), failed),
          {**mine, "bare_structure": "the bare run did not complete: step 3 refused: N < 0"})
    # it completed on another grid (fewer rows): not compared either
    short = bare_run(sc, rows=4, message="completed early")
    check(report.absorber_summary(res, models(**starts), short),
          {**mine, "bare_structure": "the bare run did not complete: completed early"})


def test_a_structure_without_a_ball():
    """No BallInShell in the scenario: the structure's statistics alone (no ball keys, no mu)."""
    sc = scenario(with_ball=False)
    res = run(sc, TOWER)
    check(report.absorber_summary(res, models(), bare_run(sc, scale=4.0)),
          {"from_s": 0.2, "to_s": 0.4, **own(), **own(4.0, "bare_"),
           **{k: 75.0 for k in REDUCTIONS}})


def test_structure_data_and_ball_parameter():
    """The columns behind xO, yO, axO, ayO; a ball parameter from the scenario, else the model's start."""
    sc = scenario({"R": 0.5})
    res = run(sc, TOWER)
    d = report._structure_data(res, "tower")
    assert list(d) == ["xO", "yO", "axO", "ayO"]
    for key, col in zip(d, ("x_rel", "y_rel", "ax1O", "ay1O")):
        assert np.array_equal(d[key], TOWER[col])
    assert report.STRUCTURE_RECORD == ("x_rel", "y_rel", "ax1O", "ay1O")
    m = models(mu=0.25, R=7.0)
    assert report._parameter(res, m, "ball", "R") == 0.5 and type(report._parameter(res, m, "ball", "R")) is float
    assert report._parameter(res, m, "ball", "mu") == 0.25
    with pytest.raises(KeyError, match="c_drag"):
        report._parameter(res, m, "ball", "c_drag")  # in neither


def test_a_run_that_stopped_before_the_window_has_no_statistics_and_says_why():
    """An FMU stopped the run at t = 0.2 s, before [summary] after = 0.3 s: no statistics (there
    is no sample to take them from), a reason instead of numpy's "zero-size array" error."""
    from ballmill.absorber.summary import structure_summary

    sc = scenario(with_ball=False, after=0.3)
    res = run(sc, TOWER, success=False, message="stopped", rows=3)
    assert report.absorber_summary(res, models()) == {
        "from_s": 0.3, "statistics": "none: no sample at or after t = 0.3 s: the results end at t = 0.2 s"}
    with pytest.raises(ValueError) as info:
        structure_summary(np.array([]), {k: np.array([]) for k in ("xO", "yO", "axO", "ayO")}, after=0.0)
    assert str(info.value) == "no sample at or after t = 0.0 s: there are no results"
