"""What a scenario run reports (ballmill.scenario.report), the parts tests/mutation/test_report_files.py
leaves open: the first failures of contact and rolling interpolated between samples (every
branch, at hand-computed times), the summary's validity, shell and absorber sections and its
edges (the window's 1e-12 s tolerance, the 1e299 "infinite" cut, a named ball, a dotted
parameter, the log's 50 entries), results.csv's number format, write_all with a bare run,
and every figure: the series plots, the shell and slip-margin kinds and the bare-structure
comparison (texts, data, styles, the PNG's pixel size), on small synthetic results.
"""
from __future__ import annotations

import json
import math
import struct
from pathlib import Path
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest

from ballmill.absorber.summary import structure_summary
from ballmill.plotting import shell
from ballmill.scenario import report
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import Instance, Scenario

matplotlib.use("Agg")

R, MU = 0.25, 0.5  # the model's start values below; a scenario may set others


def _models(R_start=R, mu_start=MU):
    """A BallInShell description: only name and start are read; other variables first, so that
    picking the wrong one shows."""
    ball = [SimpleNamespace(name=n, start=s) for n, s in (("m", 9.0), ("r", 7.0), ("R", R_start),
                                                           ("mu", mu_start), ("t0", 0.3))]
    return {"BallInShell": SimpleNamespace(modelVariables=ball),
            "Structure": SimpleNamespace(modelVariables=[SimpleNamespace(name="m", start=1.0)])}


def _scenario(instances=None, plots=(), summary=None, start=0.0):
    inst = instances if instances is not None else {"ball": Instance("ball", fmu="BallInShell")}
    return Scenario(path=Path("synthetic.toml"), name="synthetic", description="d", start=start, stop=1.0,
                    step=0.1, instances=inst, connections=[], record=[], plots=list(plots),
                    summary={} if summary is None else summary)


def _result(sc, t, columns: dict, success=True, message="completed", messages=()):
    names = ["time"] + list(columns)
    data = np.column_stack([np.asarray(t, float)] + [np.asarray(v, float) for v in columns.values()])
    return RunResult(scenario=sc, columns=names, data=data, success=success, message=message,
                     messages=list(messages), wall_time=0.5, init_time=0.1, steps=len(t) - 1)


T6 = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]


def _ball_columns(**over):
    """N and Ft give the margins N and mu N - Ft (mu = 0.5): rolling's [1.5, 1, 0.5, -1, -1, -2]
    crosses zero at 0.2 + 0.1 * 0.5 / 1.5, contact's [4, 3, 2, 1, -1, -2] at 0.3 + 0.1 * 1 / 2."""
    cols = {"ball.N": [4.0, 3.0, 2.0, 1.0, -1.0, -2.0], "ball.Ft": [0.5, 0.5, 0.5, 1.5, 0.0, 0.0],
            "ball.contact": [1, 1, 1, 1, 0, 0], "ball.rolling": [1, 1, 1, 0, 0, 0]}
    cols.update(over)
    return {k: v for k, v in cols.items() if v is not None}


# -- first failures ----------------------------------------------------------------------------
@pytest.mark.parametrize("columns, params, expected", [
    # both cross zero between samples: interpolated
    ({}, {}, {"contact": 0.35, "rolling": 0.2 + 0.1 / 3}),
    # mu from the scenario instead of the model: rolling margin 0.2 N - Ft = [0.3, 0.1, -0.1, ...]
    ({"ball.rolling": [1, 1, 0, 0, 0, 0]}, {"mu": 0.2}, {"contact": 0.35, "rolling": 0.1 + 0.1 * 0.1 / 0.2}),
    # no N: the sample's time, for both flags
    ({"ball.N": None, "ball.Ft": None}, {}, {"contact": 0.4, "rolling": 0.3}),
    # N but no Ft: rolling has no margin
    ({"ball.Ft": None}, {}, {"contact": 0.35, "rolling": 0.3}),
    # no contact flag: rolling alone; no flags at all: nothing
    ({"ball.contact": None}, {}, {"rolling": 0.2 + 0.1 / 3}),
    ({"ball.contact": None, "ball.rolling": None}, {}, {}),
    # a flag that holds: None, and the other one is still looked at
    ({"ball.contact": [1] * 6}, {}, {"contact": None, "rolling": 0.2 + 0.1 / 3}),
    # where N = 0 the rolling margin is N itself (0), not mu N - Ft (-0.2): the crossing's time is t[i]
    ({"ball.N": [4.0, 3.0, 2.0, 0.0, -1.0, -2.0], "ball.Ft": [0.5, 0.5, 0.5, 0.2, 0, 0],
      "ball.contact": [1] * 6}, {}, {"contact": None, "rolling": 0.2 + 0.1 * 0.5 / 0.5}),
    # a margin already <= 0 before the flag turns: the flag's sample
    ({"ball.N": [4.0, 3.0, 2.0, 0.0, -1.0, -2.0], "ball.Ft": [0.5] * 6, "ball.contact": [1, 1, 1, 1, 1, 0],
      "ball.rolling": [1] * 6}, {}, {"contact": 0.5, "rolling": None}),
    # failing at the second sample (the last row's margin is negative): interpolated
    ({"ball.N": [4.0, -4.0, 2.0, 1.0, 1.0, -2.0], "ball.contact": [1, 0, 1, 1, 1, 0],
      "ball.rolling": [1] * 6}, {}, {"contact": 0.05, "rolling": None}),
    # failing at the first sample while the last row's margin is positive: the first sample's time
    ({"ball.N": [-1.0, 3.0, 2.0, 1.0, 1.0, 2.0], "ball.contact": [0, 1, 1, 1, 1, 1],
      "ball.rolling": [1] * 6}, {}, {"contact": 0.0, "rolling": None}),
    # the margin exactly 0 at the sample before the flag turns: that sample is not a crossing
    ({"ball.N": [4.0, 3.0, 0.0, -1.0, -1.0, -2.0], "ball.Ft": [0.0] * 6, "ball.contact": [1, 1, 1, 0, 0, 0],
      "ball.rolling": [1] * 6}, {}, {"contact": 0.3, "rolling": None}),
])
def test_first_failures(columns, params, expected):
    sc = _scenario({"ball": Instance("ball", fmu="BallInShell", parameters=dict(params))})
    got = report._failures(_result(sc, T6, _ball_columns(**columns)), _models(), "ball")
    assert got.keys() == expected.keys()
    for k, v in expected.items():
        assert (got[k] is None) if v is None else got[k] == pytest.approx(v, rel=1e-12, abs=1e-15), (k, got)


# -- the summary -------------------------------------------------------------------------------
def _shell_columns():
    """Contact points in the chamber's axes: bottom, +x equator, +y equator, top, bottom."""
    return {"ball.xP_ch": [0.0, R, 0.0, 0.0, 0.0, 0.0], "ball.yP_ch": [0.0, 0.0, R, 0.0, 0.0, 0.0],
            "ball.zP_ch": [0.0, R, R, 2 * R, 0.0, 0.0]}


def test_summary_of_validity_and_the_shell():
    cols = _ball_columns(**{"ball.valid": [1, 1, 0, 0, 0, 0], "ball.friction_ratio": [0.1, 1e299, 0.3, 1e300, 0, 0]})
    cols.update(_shell_columns())
    res = _result(_scenario(summary={"after": 0.1}), T6, cols)
    s = report.summarise(res, _models())
    assert s["validity"] == {
        "contact": {"held_throughout": False, "first_failure_s": 0.4, "first_failure_interpolated_s": pytest.approx(0.35)},
        "rolling": {"held_throughout": False, "first_failure_s": 0.3,
                    "first_failure_interpolated_s": pytest.approx(0.2 + 0.1 / 3)},
        "friction_ratio_max": 0.3,  # 1e299 and above stand for "infinite"
    }
    # shell: the valid span (two rows) visits the bottom and +x cells, the whole run four cells
    assert s["shell"] == {
        "visited_fraction_valid": 2 / 1280, "visited_fraction_all": 4 / 1280, "cells": 1280,
        "measure": ("fraction of 1280 equal-area cells of the chamber's sphere that the contact point "
                    "(chamber axes) visits at the recorded samples; 'valid': over the model's valid span, "
                    "'all': over the whole run (not physical after it)"),
        "z_ch_max_valid_m": R,
    }
    # invalid from the first row: nothing over the valid span
    cols["ball.valid"] = [0] * 6
    s = report.summarise(_result(_scenario(), T6, cols), _models())
    assert s["shell"]["visited_fraction_valid"] is None and s["shell"]["z_ch_max_valid_m"] is None
    assert s["shell"]["visited_fraction_all"] == 4 / 1280


def test_summary_of_flags_that_hold_and_a_ratio_that_is_only_infinite():
    cols = {"ball.N": [1.0] * 3, "ball.contact": [1, 1, 1], "ball.rolling": [1, 1, 1],
            "ball.friction_ratio": [1e299, math.inf, 1e300]}
    s = report.summarise(_result(_scenario(), T6[:3], cols), _models())
    assert s["validity"] == {"contact": {"held_throughout": True, "first_failure_s": None,
                                         "first_failure_interpolated_s": None},
                             "rolling": {"held_throughout": True, "first_failure_s": None,
                                         "first_failure_interpolated_s": None},
                             "friction_ratio_max": None}


def test_summary_window_tolerance_named_ball_and_log():
    """A sample 1e-12 s before 'after' counts as after; [summary] ball names the ball when two
    are there; the log keeps the first 50 messages that are not ok."""
    t = [0.0, 0.2 - 1e-12, 0.3]
    inst = {"b1": Instance("b1", fmu="BallInShell"), "b2": Instance("b2", fmu="BallInShell")}
    sc = _scenario(inst, summary={"after": 0.2, "ball": "b2"})
    msgs = [{"status": "warning", "message": f"w{i}"} for i in range(60)] + [{"status": "ok", "message": "x"}]
    res = _result(sc, t, {"b1.N": [9.0, 9.0, 9.0], "b2.N": [5.0, 3.0, 4.0]}, messages=msgs)
    s = report.summarise(res, _models())
    assert s["N"] == {"all": {"min": 3.0, "max": 5.0, "range": 2.0}, "after": {"min": 3.0, "max": 4.0, "range": 1.0}}
    assert s["log"] == msgs[:50]
    assert report._ball_instance(res) == "b2"


def test_summary_with_a_ball_without_n():
    s = report.summarise(_result(_scenario(), T6[:2], {"ball.zP": [0.0, 0.1]}), _models())
    assert "N" not in s and "validity" not in s and "zP_max_m" not in s


def test_the_window_start_from_a_dotted_parameter_name():
    inst = {"ball": Instance("ball", fmu="BallInShell", parameters={"x.t0": 0.2})}
    res = _result(_scenario(inst, summary={"after": "ball.x.t0"}), T6[:4], {"ball.N": [4.0, 3.0, 2.0, 1.0]})
    assert report._after_time(res, _models()) == 0.2
    assert report.summarise(res, _models())["N"]["after"] == {"min": 1.0, "max": 2.0, "range": 1.0}


def test_stats_of_nothing():
    assert report._stats(np.array([])) is None
    assert report._stats(np.array([2.0, -1.0])) == {"min": -1.0, "max": 2.0, "range": 3.0}


# -- the absorber summary ----------------------------------------------------------------------
T5 = [0.0, 0.1, 0.2, 0.3, 0.4]
STRUCT = {"tower.x_rel": [0.0, 0.01, -0.02, 0.015, -0.005], "tower.y_rel": [0.0, 0.002, 0.001, -0.003, 0.0],
          "tower.ax1O": [0.0, 1.0, -2.0, 1.5, -0.5], "tower.ay1O": [0.0, 0.2, 0.1, -0.3, 0.0]}
BARE = {"tower.x_rel": [0.0, 0.03, -0.04, 0.05, -0.02], "tower.y_rel": [0.0, 0.0, 0.0, 0.0, 0.0],
        "tower.ax1O": [0.0, 3.0, -4.0, 5.0, -2.0], "tower.ay1O": [0.0, 0.0, 0.0, 0.0, 0.0]}


def _absorber(params=None, bare=None, bare_ok=True, summary_after=0.1):
    inst = {"tower": Instance("tower", fmu="Structure"),
            "ball": Instance("ball", fmu="BallInShell", parameters=dict(params or {}))}
    sc = _scenario(inst, summary={"structure": "tower", "after": summary_after})
    zP = [0.01, -1e-9, 0.02, 2 * 0.25 + 1e-9, 0.01]  # numerical overshoot below 0 and above 2R: clipped
    cols = dict(STRUCT, **{"ball.xP": [0.0, 0.01, 0.03, -0.02, 0.0], "ball.yP": [0.0, 0.0, 0.04, 0.0, 0.0],
                           "ball.zP": zP, "ball.N": [5.0, 4.0, 3.0, -1.0, 2.0],
                           "ball.friction_ratio": [0.1, 0.2, 0.6, 0.3, 0.1]})
    res = _result(sc, T5, cols)
    b = None
    if bare is not None:
        bsc = _scenario({"tower": Instance("tower", fmu="Structure")}, summary=sc.summary)
        b = _result(bsc, T5[:bare], {k: v[:bare] for k, v in BARE.items()}, success=bare_ok, message="it broke")
    return res, b


def _expected(bare=True, mu=MU, R_=R):
    data = {"xO": np.array(STRUCT["tower.x_rel"]), "yO": np.array(STRUCT["tower.y_rel"]),
            "axO": np.array(STRUCT["tower.ax1O"]), "ayO": np.array(STRUCT["tower.ay1O"]),
            "xP": np.array([0.0, 0.01, 0.03, -0.02, 0.0]), "yP": np.array([0.0, 0.0, 0.04, 0.0, 0.0]),
            "N": np.array([5.0, 4.0, 3.0, -1.0, 2.0]), "friction_ratio": np.array([0.1, 0.2, 0.6, 0.3, 0.1]),
            "theta": np.array([math.acos(1 - 0.01 / R_), 0.0, math.acos(1 - 0.02 / R_), math.pi,
                               math.acos(1 - 0.01 / R_)])}
    base = {"xO": np.array(BARE["tower.x_rel"]), "yO": np.zeros(5), "axO": np.array(BARE["tower.ax1O"]),
            "ayO": np.zeros(5)} if bare else None
    return structure_summary(np.array(T5), data, base, mu=mu, after=0.1)


def test_absorber_summary_with_the_bare_run():
    res, bare = _absorber(bare=5)
    got = report.absorber_summary(res, _models(), bare)
    assert got == _expected()
    assert got["ball_angle_max_deg"] == 180.0 and got["slip_at_s"] == 0.2 and got["contact_lost_at_s"] == 0.3
    assert got["reduction_displacement_peak_percent"] == pytest.approx(100 * (1 - math.hypot(0.02, 0.001) / 0.05), rel=1e-12)
    # through the summary: under "structure", and no mill's ring or torque
    s = report.summarise(res, _models(), bare)
    assert s["structure"] == _expected() and "ring" not in s


def test_absorber_summary_reads_r_and_mu_from_the_scenario_first():
    res, _ = _absorber(params={"R": 0.2, "mu": 0.15})
    assert report.absorber_summary(res, _models()) == _expected(bare=False, mu=0.15, R_=0.2)
    assert report._parameter(res, _models(), "ball", "R") == 0.2
    assert report._parameter(res, _models(), "ball", "t0") == 0.3


@pytest.mark.parametrize("rows, ok", [(5, False), (4, True)])
def test_absorber_summary_when_the_bare_run_is_unusable(rows, ok):
    res, bare = _absorber(bare=rows, bare_ok=ok)
    got = report.absorber_summary(res, _models(), bare)
    want = _expected(bare=False)
    want["bare_structure"] = "the bare run did not complete: it broke"
    assert got == want


def test_absorber_summary_without_a_ball():
    sc = _scenario({"tower": Instance("tower", fmu="Structure")}, summary={"structure": "tower"})
    res = _result(sc, T5, dict(STRUCT))
    data = {"xO": np.array(STRUCT["tower.x_rel"]), "yO": np.array(STRUCT["tower.y_rel"]),
            "axO": np.array(STRUCT["tower.ax1O"]), "ayO": np.array(STRUCT["tower.ay1O"])}
    assert report.absorber_summary(res, _models()) == structure_summary(np.array(T5), data, None, after=0.0)


# -- files ---------------------------------------------------------------------------------------
def _png_size(path):
    with open(path, "rb") as fh:
        head = fh.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


def test_csv_number_format(tmp_path):
    res = _result(_scenario(), [0.0, 1.0], {"ball.N": [1.5e-20, math.inf], "ball.x": [math.nan, -2.0e30]})
    report.write_csv(res, tmp_path / "r.csv")
    assert (tmp_path / "r.csv").read_text() == "time,ball.N,ball.x\n0,1.5e-20,nan\n1,inf,-2e+30\n"


def test_write_all_with_a_bare_run(tmp_path, figures):
    plots = [{"kind": "slip_margin", "file": "m.png"}]
    res, bare = _absorber(bare=5)
    res.scenario.plots = plots
    res.columns.append("ball.Ft")
    res.data = np.column_stack([res.data, np.zeros(5)])
    summary = report.write_all(res, _models(), tmp_path, bare)
    assert summary["plots"] == ["m.png", "structure_x_with_without_ball.png"]
    assert summary["structure"]["reduction_displacement_peak_percent"] == pytest.approx(100 * (1 - math.hypot(0.02, 0.001) / 0.05), rel=1e-12)
    assert (tmp_path / "bare.csv").read_text().splitlines()[:2] == [
        "time,tower.x_rel,tower.y_rel,tower.ax1O,tower.ay1O", "0,0,0,0,0"]
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["plots"] == summary["plots"] and on_disk["structure"]["contact"] is False
    # two rows make plots; a bare run of two rows is written; of one row it is not
    res2, bare2 = _absorber(bare=2)
    res2.data, res2.scenario.plots = res2.data[:2], [{"y": ["tower.x_rel"], "file": "x.png"}]
    out = tmp_path / "two"
    assert report.write_all(res2, _models(), out, bare2)["plots"] == ["x.png", "structure_x_with_without_ball.png"]
    assert (out / "bare.csv").exists()
    res1, bare1 = _absorber(bare=1, summary_after=0.0)
    res1.data, res1.scenario.plots = res1.data[:1], []
    out = tmp_path / "one"
    assert report.write_all(res1, _models(), out, bare1)["plots"] == []
    assert not (out / "bare.csv").exists()


def test_write_all_serialises_numpy_values(tmp_path):
    inst = {"ball": Instance("ball", fmu="BallInShell", parameters={"n": np.int64(3), "ok": np.bool_(True)})}
    res = _result(_scenario(inst), T6[:2], {"ball.N": [1.0, 2.0]})
    report.write_all(res, _models(), tmp_path)
    assert json.loads((tmp_path / "summary.json").read_text())["parameters"] == {"ball": {"n": 3, "ok": True}}


# -- figures --------------------------------------------------------------------------------------
def test_series_plot_edges(tmp_path, figures):
    t = np.linspace(0.0, 1.0, 2000)
    y = np.where(np.arange(2000) == 5, 1e299, t)
    plots = [{"y": ["ball.N"], "file": "a.png"}, {"x": "ball.N", "y": ["ball.N"], "file": "b.png", "aspect": "equal"}]
    res = _result(_scenario(plots=plots), t, {"ball.N": y})
    assert report.plot(res, tmp_path) == [tmp_path / "a.png", tmp_path / "b.png"]
    a, b = (fig.axes[0] for fig in figures)
    line = a.get_lines()[0]
    assert line.get_linewidth() == 1.2  # 2000 samples: not yet thinner
    assert math.isnan(line.get_ydata()[5]) and line.get_ydata()[6] == t[6]  # 1e299 is "infinite"
    assert a.get_title() == "" and a.xaxis.get_gridlines()[0].get_alpha() == 0.3
    assert b.get_adjustable() == "datalim" and a.get_adjustable() == "box"
    assert _png_size(tmp_path / "a.png") == (825, 528) and _png_size(tmp_path / "b.png") == (704, 704)


def _turning(params=None, plots=(), **over):
    cols = _ball_columns(**over)
    cols.update(_shell_columns())
    cols["ball.friction_ratio"] = [0.1, 0.2, 1e299, 0.7, 1e300, 0.0]
    sc = _scenario({"drive": Instance("drive", fmu="MotorStartup"),
                    "ball": Instance("ball", fmu="BallInShell", parameters=dict(params or {}))}, plots=plots)
    return _result(sc, T6, cols)


def test_shell_and_slip_margin_plots_through_plot(tmp_path, figures, monkeypatch):
    calls = []
    draw = shell.draw_hemispheres
    monkeypatch.setattr(report.shell, "draw_hemispheres", lambda *a, **k: calls.append((a, k)) or draw(*a, **k))
    plots = [{"kind": "shell", "file": "s.png"}, {"kind": "slip_margin", "file": "m.png", "ball": "ball"},
             {"kind": "shell", "file": "t.png", "title": "Path"}]
    res = _turning(plots=plots)
    assert report.plot(res, tmp_path, _models()) == [tmp_path / "s.png", tmp_path / "m.png", tmp_path / "t.png"]
    assert None not in figures and len(figures) == 3
    assert _png_size(tmp_path / "s.png") == (990, 539) and _png_size(tmp_path / "m.png") == (825, 528)
    s, m, t = figures
    assert len(s.axes) == 3 and len(m.axes) == 1  # two hemispheres and a colour bar; one axes
    assert s._suptitle.get_text() == f"Contact point on the shell\n({shell.CAPTION})"
    assert t._suptitle.get_text() == f"Path\n({shell.CAPTION})" and s._suptitle.get_fontsize() == 10
    # the hemispheres get the unit vectors (R from the model), the times, the first failure of either flag
    (axes, u, tt, t_fail, t_end), kw = calls[0]
    assert list(axes) == s.axes[:2]
    assert np.allclose(u, [[0, 0, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [0, 0, -1]], atol=1e-15)
    assert np.array_equal(tt, T6) and t_fail == pytest.approx(0.2 + 0.1 / 3) and t_end == t_fail
    assert kw == {"fail_label": "rolling or contact fails"}
    assert s.axes[2].get_ylabel() == "time [s]"


def test_shell_plot_layout_and_a_run_without_failure(tmp_path, figures, monkeypatch):
    import matplotlib.figure
    bars = []
    colorbar = matplotlib.figure.Figure.colorbar
    monkeypatch.setattr(matplotlib.figure.Figure, "colorbar",
                        lambda self, sm, **k: bars.append((sm, k)) or colorbar(self, sm, **k))
    calls = []
    draw = shell.draw_hemispheres
    monkeypatch.setattr(report.shell, "draw_hemispheres", lambda *a, **k: calls.append(a) or draw(*a, **k))
    res = _turning(params={"R": 0.4}, plots=[{"kind": "shell", "file": "s.png", "ball": "ball"}],
                   **{"ball.contact": [1] * 6, "ball.rolling": [1] * 6})
    report.plot(res, tmp_path, _models())
    fig = figures[0]
    assert tuple(fig.get_size_inches()) == (9.0, 4.9)
    assert type(fig.get_layout_engine()).__name__ == "ConstrainedLayoutEngine"
    (sm, kw), = bars
    assert sm is not None and set(kw) == {"ax", "shrink", "label"}
    assert kw["shrink"] == 0.7 and kw["label"] == "time [s]"
    assert list(kw["ax"]) == fig.axes[:2]
    axes, u, tt, t_fail, t_end = calls[0]
    assert t_fail is None and t_end == 0.5
    assert np.allclose(u[1], [0.25 / math.hypot(0.25, 0.15), 0, -0.15 / math.hypot(0.25, 0.15)])  # R = 0.4


def test_slip_margin_plot(tmp_path, figures):
    plots = [{"kind": "slip_margin", "file": "m.png"},
             {"kind": "slip_margin", "file": "n.png", "title": "T", "ylabel": "Y"}]
    res = _turning(plots=plots)
    report.plot(res, tmp_path, _models())
    ax = figures[0].axes[0]
    assert tuple(figures[0].get_size_inches()) == (7.5, 4.8)
    curve, zero, roll, contact = ax.get_lines()
    y = curve.get_ydata()
    assert np.array_equal(curve.get_xdata(), T6)
    assert list(y[[0, 1, 3, 5]]) == pytest.approx([0.4, 0.3, -0.2, 0.5]) and math.isnan(y[2]) and math.isnan(y[4])
    assert curve.get_linewidth() == 1.2 and curve.get_label() == "mu - friction_ratio (mu = 0.5)"
    assert list(zero.get_ydata()) == [0.0, 0.0] and zero.get_color() == "k" and zero.get_linewidth() == 0.6
    assert ax.get_ylim() == pytest.approx((-0.5, 0.525))
    assert roll.get_xdata()[0] == pytest.approx(0.2 + 0.1 / 3) and roll.get_linestyle() == ":"
    assert contact.get_xdata()[0] == pytest.approx(0.35) and contact.get_linestyle() == "--"
    for ln in (roll, contact):
        assert ln.get_color() == "tab:red" and ln.get_linewidth() == 1.0
    assert [roll.get_label(), contact.get_label()] == ["rolling first fails, t = 0.2333 s",
                                                       "contact first fails, t = 0.3500 s"]
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "slip margin mu - F_t / N [1] (cut at -mu)"
    assert ax.get_title() == "Slip margin: the ball rolls while positive"
    assert ax.get_legend().get_texts()[0].get_fontsize() == 8
    assert ax.xaxis.get_gridlines()[0].get_alpha() == 0.3
    other = figures[1].axes[0]
    assert other.get_title() == "T" and other.get_ylabel() == "Y"


@pytest.mark.parametrize("n, lw", [(2000, 1.2), (2001, 0.8)])
def test_slip_margin_of_a_long_run_and_mu_from_the_scenario(tmp_path, figures, n, lw):
    t = np.linspace(0.0, 1.0, n)
    sc = _scenario({"ball": Instance("ball", fmu="BallInShell", parameters={"mu": 0.2})},
                   plots=[{"kind": "slip_margin", "file": "m.png"}])
    res = _result(sc, t, {"ball.N": np.ones(n), "ball.Ft": np.zeros(n), "ball.friction_ratio": np.full(n, 0.05),
                          "ball.rolling": np.ones(n)})
    report.plot(res, tmp_path, _models())
    ax = figures[0].axes[0]
    assert len(ax.get_lines()) == 2  # nothing fails: no vertical line
    assert ax.get_lines()[0].get_linewidth() == lw and ax.get_lines()[0].get_label() == "mu - friction_ratio (mu = 0.2)"
    assert np.allclose(ax.get_lines()[0].get_ydata(), 0.15)


def test_bare_structure_plots(tmp_path, figures):
    res, bare = _absorber(bare=5)
    files = report.plot_bare(res, bare, tmp_path)  # y_rel of the bare run is all zero: no y plot
    assert files == [tmp_path / "structure_x_with_without_ball.png"]
    assert _png_size(files[0]) == (825, 528)
    ax = figures[0].axes[0]
    b, w = ax.get_lines()
    assert np.array_equal(b.get_xdata(), T5) and np.array_equal(b.get_ydata(), BARE["tower.x_rel"])
    assert np.array_equal(w.get_xdata(), T5) and np.array_equal(w.get_ydata(), STRUCT["tower.x_rel"])
    assert (b.get_color(), b.get_linewidth(), b.get_label()) == ("tab:red", 0.8, "bare structure")
    assert (w.get_color(), w.get_linewidth(), w.get_label()) == ("tab:blue", 0.8, "with the ball absorber")
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "displacement x at the absorber [m]"
    assert ax.get_title() == "Structure displacement x, with and without the ball"
    assert ax.get_legend() is not None and ax.xaxis.get_gridlines()[0].get_alpha() == 0.3
    assert tuple(figures[0].get_size_inches()) == (7.5, 4.8)
    # x all zero, y moving: only y; a bare run without y_rel: nothing for y
    bare.data[:, 1] = 0.0
    bare.data[:, 2] = [0.0, 0.01, 0.0, -0.01, 0.0]
    assert report.plot_bare(res, bare, tmp_path) == [tmp_path / "structure_y_with_without_ball.png"]
    ax = figures[-1].axes[0]
    assert ax.get_ylabel() == "displacement y at the absorber [m]"
    assert ax.get_title() == "Structure displacement y, with and without the ball"
    bare.columns = ["time", "tower.x_rel", "tower.ax1O"]
    bare.data = bare.data[:, [0, 1, 3]]
    assert report.plot_bare(res, bare, tmp_path) == []
