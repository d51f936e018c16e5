"""What a scenario run writes (ballmill.scenario.report): results.csv, summary.json with its
validity span, and the plots (the figures are inspected before they are closed), on small
synthetic results. tests/test_summary_windows.py pins the statistics' windows; this file
pins the rest, for the mutants tests/test_scenarios.py reaches only with built FMUs
(docs/mutation.md)."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest

from ballmill.scenario import report
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import Instance, Scenario

matplotlib.use("Agg")


def scenario(plots=(), summary=None, ball_name="ball"):
    return Scenario(path=Path("synthetic.toml"), name="synthetic", description="a test", start=0.0, stop=0.4,
                    step=0.1, instances={ball_name: Instance(ball_name, fmu="BallInShell", parameters={"mu": 0.3})},
                    connections=[], record=[], plots=list(plots),
                    summary={"after": 0.2} if summary is None else summary)


MODELS = {"BallInShell": SimpleNamespace(modelVariables=[])}


def result(sc, valid=(1, 1, 1, 1, 1), t_invalid=None, ball="ball", rows=5, **extra):
    t = 0.1 * np.arange(rows)
    cols = {"N": [5.0, 4.0, 3.0, 2.0, 1.0], "xP": [0.1, 0.2, 0.3, 0.2, 0.1], "yP": [0.0] * 5,
            "zP": [0.5, 0.1, 0.2, 0.3, 0.4], "M_reaction": [-1.0, 0.5, 3.0, -4.0, 0.0],
            "valid": list(valid), "friction_ratio": [0.1, 1e300, 0.2, 0.4, math.inf]}
    if t_invalid is not None:
        cols["t_invalid"] = t_invalid
    cols.update(extra)
    names = ["time"] + [f"{ball}.{k}" for k in cols]
    data = np.column_stack([t] + [np.asarray(v[:rows], dtype=float) for v in cols.values()])
    return RunResult(scenario=sc, columns=names, data=data, success=True, message="completed",
                     messages=[{"status": "ok", "message": "o"}, {"status": "error", "message": "e"}],
                     wall_time=1.23456, init_time=0.01234, steps=4)


def test_a_valid_run_is_summarised_over_the_whole_run():
    s = report.summarise(result(scenario()), MODELS)
    assert s["scenario"] == "synthetic" and s["description"] == "a test"
    assert s["success"] is True and s["message"] == "completed" and s["steps"] == 4
    assert s["wall_time_s"] == 1.2346 and s["startup_time_s"] == 0.0123 and s["communication_step_s"] == 0.1
    assert s["parameters"] == {"ball": {"mu": 0.3}}
    assert s["left_validity"] is False
    assert s["statistics_over"] == "the whole run (the model stayed valid throughout)"
    assert s["valid_span_s"] == [0.0, 0.4]
    assert s["N"]["all"] == {"min": 1.0, "max": 5.0, "range": 4.0}
    assert s["zP_max_m"] == 0.5 and s["M_reaction_peak_abs_Nm"] == 4.0
    assert s["validity"] == {"friction_ratio_max": 0.4}
    assert s["log"] == [{"status": "error", "message": "e"}]


def test_statistics_stop_where_the_model_left_validity():
    """valid drops at t = 0.3: N, ring, zP and M over t < 0.3 only; t_invalid as published."""
    s = report.summarise(result(scenario(), valid=(1, 1, 1, 0, 1), t_invalid=[1e300, 1e300, 1e300, 0.25, 0.25]),
                         MODELS)
    assert s["left_validity"] is True and s["t_invalid_s"] == 0.25
    assert s["statistics_over"] == (
        "the valid span only, t < 0.3 s: the model's validity ended at t_invalid = 0.25 s (loss of contact, "
        "slip or inconsistent inputs; see log); later rows are in results.csv but not in these statistics")
    assert s["valid_span_s"] == [0.0, 0.2]
    assert s["N"]["all"] == {"min": 3.0, "max": 5.0, "range": 2.0}
    assert s["N"]["after"] == {"min": 3.0, "max": 3.0, "range": 0.0}
    assert s["ring"] == {"inner_radius_m": 0.3, "outer_radius_m": 0.3, "width_m": 0.0}
    assert s["zP_max_m"] == 0.5 and s["M_reaction_peak_abs_Nm"] == 3.0
    # without a t_invalid column the time of the first invalid row stands for it
    s = report.summarise(result(scenario(), valid=(1, 1, 1, 0, 1)), MODELS)
    assert s["t_invalid_s"] == 3 * 0.1 and "t_invalid = 0.3 s" in s["statistics_over"]
    # invalid from the first row: nothing to summarise
    s = report.summarise(result(scenario(), valid=(0, 1, 1, 1, 1)), MODELS)
    assert s["valid_span_s"] is None and s["N"] == {"all": None, "after": None}
    assert s["zP_max_m"] is None and s["M_reaction_peak_abs_Nm"] is None


def test_no_ball_no_statistics():
    sc = scenario(summary={}, ball_name="drive")
    sc.instances["drive"].fmu = "MotorStartup"
    s = report.summarise(result(sc, ball="drive"), MODELS)
    assert "N" not in s and "validity" not in s and s["log"] == [{"status": "error", "message": "e"}]
    # found by its model when the summary does not name it
    s = report.summarise(result(scenario(summary={"after": 0.2}, ball_name="b2"), ball="b2"), MODELS)
    assert s["N"]["after"] == {"min": 1.0, "max": 3.0, "range": 2.0}
    s = report.summarise(result(scenario(summary={}), ball="ball"), MODELS)  # after: the start
    assert s["after_s"] == 0.0 and s["N"]["after"] == s["N"]["all"]


def test_friction_ratio_only_infinite_gives_none():
    s = report.summarise(result(scenario(), friction_ratio=[1e300, math.inf, 1e300, 1e300, 1e300]), MODELS)
    assert s["validity"]["friction_ratio_max"] is None


def test_results_csv_round_trip(tmp_path):
    res = result(scenario())
    res.data[1, 1] = 1.0 / 3.0
    report.write_csv(res, tmp_path / "r.csv")
    rows = list(csv.reader((tmp_path / "r.csv").open()))
    assert rows[0] == res.columns
    assert rows[2][1] == "0.333333333333"  # 12 significant digits
    back = np.array(rows[1:], dtype=float)
    assert back.shape == res.data.shape
    assert np.allclose(back, res.data, rtol=1e-11, atol=0)


def test_write_all_files(tmp_path, monkeypatch):
    plots = [{"y": ["ball.N"], "file": "N.png"}]
    res = result(scenario(plots=plots), friction_ratio=[0.1, 0.2, 0.3, 0.4, math.nan])
    out = tmp_path / "deep" / "out"
    summary = report.write_all(res, MODELS, out)
    assert sorted(p.name for p in out.iterdir()) == ["N.png", "results.csv", "summary.json"]
    on_disk = json.loads((out / "summary.json").read_text())
    assert on_disk["plots"] == ["N.png"] == summary["plots"]
    assert on_disk["N"] == summary["N"] and on_disk["wall_time_s"] == 1.2346
    assert (out / "summary.json").read_text().startswith('{\n  "scenario": "synthetic"')
    # one row: no plots
    res1 = result(scenario(plots=plots), rows=1)
    assert report.write_all(res1, MODELS, tmp_path / "one")["plots"] == []
    assert not (tmp_path / "one" / "N.png").exists()


def test_json_of_numpy_and_non_finite_values():
    assert json.dumps({"a": np.float64(2.5), "b": np.int64(3), "c": math.inf, "d": math.nan},
                      default=report._json_default) == '{"a": 2.5, "b": 3, "c": Infinity, "d": NaN}'
    assert report._json_default(math.inf) is None and report._json_default(-math.inf) is None
    assert report._json_default(math.nan) is None
    assert report._json_default(np.float32(0.5)) == 0.5 and type(report._json_default(np.int64(3))) is int
    with pytest.raises(TypeError) as info:
        report._json_default({1, 2})
    assert str(info.value) == "not JSON serialisable: {1, 2}"
    with pytest.raises(TypeError):
        report._json_default(2.5)  # a finite float never comes here; refused all the same


def test_plot_contents(tmp_path, figures):
    plots = [
        {"y": ["ball.N", "ball.zP"], "file": "a.png", "title": "T", "vlines": [0.15, 0.25]},
        {"x": "ball.xP", "y": ["ball.friction_ratio"], "file": "b.png", "aspect": "equal",
         "xlabel": "xP [m]", "ylabel": "ratio"},
    ]
    res = result(scenario(plots=plots))
    files = report.plot(res, tmp_path)
    assert files == [tmp_path / "a.png", tmp_path / "b.png"] and all(f.stat().st_size > 0 for f in files)
    a, b = (fig.axes[0] for fig in figures)
    assert tuple(figures[0].get_size_inches()) == (7.5, 4.8) and tuple(figures[1].get_size_inches()) == (6.4, 6.4)
    # first: two curves against time, labelled in words with units (BallInShell's declaration),
    # legend, title, dashed grey lines labelled with their times; the model stayed valid: no span
    assert [ln.get_label() for ln in a.get_lines()[:2]] == [
        "Normal force of the chamber on the ball, N [N]",
        "Contact point P, height above the chamber's lowest point O, zP [m]"]
    assert np.array_equal(a.get_lines()[0].get_xdata(), res.column("time"))
    assert np.array_equal(a.get_lines()[0].get_ydata(), res.column("ball.N"))
    assert a.get_lines()[0].get_linewidth() == 1.2
    assert a.get_xlabel() == "time [s]" and a.get_ylabel() == "N [N], zP [m]" and a.get_title() == "T"
    assert a.get_legend() is not None and list(a.patches) == []
    vl = a.get_lines()[2:]
    assert [tuple(ln.get_xdata()) for ln in vl] == [(0.15, 0.15), (0.25, 0.25)]
    assert [ln.get_label() for ln in vl] == ["t = 0.15 s", "t = 0.25 s"]
    assert all(ln.get_linestyle() == "--" and ln.get_color() == "grey" and ln.get_linewidth() == 0.8 for ln in vl)
    # second: a path against xP, the start-up (t < after = 0.2 s) and the rest in two colours,
    # 1e300 and inf not drawn, the labels given, equal aspect, the phases in the legend
    before, rest = b.get_lines()
    assert np.array_equal(before.get_xdata(), res.column("ball.xP")[:2])
    assert np.array_equal(rest.get_xdata(), res.column("ball.xP")[2:])
    y = np.r_[before.get_ydata(), rest.get_ydata()]
    assert y[0] == 0.1 and math.isnan(y[1]) and y[2] == 0.2 and y[3] == 0.4 and math.isnan(y[4])
    assert (before.get_color(), rest.get_color()) == ("tab:orange", "tab:blue")
    assert b.get_xlabel() == "xP [m]" and b.get_ylabel() == "ratio" and b.get_title() == ""
    assert b.get_aspect() == 1.0
    assert [t.get_text() for t in b.get_legend().get_texts()] == ["start-up, t < 0.2 s",
                                                                  "after the start-up, t \u2265 0.2 s"]
    assert a.get_aspect() == "auto"
    # a plot with an x that is not time and no label: the variable's name
    res = result(scenario(plots=[{"x": "ball.xP", "y": ["ball.N"], "file": "c.png"}]))
    report.plot(res, tmp_path)
    assert figures[-1].axes[0].get_xlabel() == "Contact point P, x in the chamber frame Oxyz, xP [m]"


def test_long_series_are_drawn_thinner(tmp_path, figures):
    n = 2001
    t = np.linspace(0.0, 1.0, n)
    sc = scenario(plots=[{"y": ["ball.N"], "file": "n.png"}])
    res = RunResult(scenario=sc, columns=["time", "ball.N"], data=np.column_stack([t, t]), success=True,
                    message="")
    report.plot(res, tmp_path)
    assert figures[-1].axes[0].get_lines()[0].get_linewidth() == 0.8


def test_write_all_reads_the_window_start_from_the_models(tmp_path):
    """after = "ball.t0" with t0 not set in the scenario: the model description's start."""
    sc = scenario(summary={"after": "ball.t0"})
    models = {"BallInShell": SimpleNamespace(modelVariables=[SimpleNamespace(name="t0", start=0.3)])}
    summary = report.write_all(result(sc), models, tmp_path)
    assert summary["after_s"] == 0.3 and summary["N"]["after"] == {"min": 1.0, "max": 2.0, "range": 1.0}
