"""Study specs (ballmill.sweep.spec) word for word: every problem a study can have, with its
file or option and the bad value; the defaults a study gets; grids and samples point by point;
point ids and context hashes pinned to their hash of a known text (a resume finds its points
by them); study files read with their overrides. Written for mutants that the rest of the
suite let through (docs/mutation.md); every value is computed inside a test."""
from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pytest

from ballmill.scenario.spec import ScenarioError
from ballmill.sweep import spec
from ballmill.sweep.spec import Indicator, Study, StudyError, build, load

DEFAULT_MODEL = {"kind": "auto", "method": "RK4", "h": 0.01, "tolerance": 1e-8, "dt": 0.01, "target_P": 1e-5,
                 "error": "one-pass"}
STATS_TEXT = "max, min, range, amplitude, rms, mean, abs_max, integral"
WINDOW_TEXT = "expected [from, to], each seconds, 'start', 'after', 'stop' or 'instance.parameter', got"


def _problems(**kw):
    kw.setdefault("scenario", "fast_start")
    with pytest.raises(StudyError) as e:
        build(kw.pop("scenario"), **kw)
    return e.value.problems


# ---------------------------------------------------------------------------- the error itself
def test_study_error_lists_its_problems():
    probs = ["a: one", "b: two"]
    e = StudyError(probs)
    assert str(e) == "2 problem(s) in the study:\n  - a: one\n  - b: two"
    probs.append("c")
    assert e.problems == ["a: one", "b: two"]  # a copy
    assert str(StudyError(["x"])) == "1 problem(s) in the study:\n  - x"
    assert isinstance(e, ValueError)


def test_indicator_to_dict():
    d = Indicator("a_b", "ball.N", "rms", ("after", 3.0)).to_dict()
    assert d == {"name": "a_b", "variable": "ball.N", "stat": "rms", "window": ["after", 3.0]}
    assert type(d["window"]) is list
    assert Indicator("x", "ball.N", "max").to_dict()["window"] == ["start", "stop"]


# ---------------------------------------------------------------------------- values
@pytest.mark.parametrize("text, value", [
    ("1", 1), (" 2.5 ", 2.5), ("true", True), ('"abc"', "abc"), ("abc", "abc"), ("  ab c ", "ab c"),
    ("1e3", 1000.0), ("-4", -4), ("[1, 2]", [1, 2]),
])
def test_scalar(text, value):
    got = spec._scalar(text)
    assert got == value and type(got) is type(value)


@pytest.mark.parametrize("given, values", [
    ([3, 1.5, "x"], [3, 1.5, "x"]),
    ({"start": 1, "stop": 2, "count": 3}, [1.0, 1.5, 2.0]),
    ("40:80:5", [40.0, 50.0, 60.0, 70.0, 80.0]),
    (" 1 : 2 : 2 ", [1.0, 2.0]),
    ("0.5:1.5:1", [0.5]),
    ("1,2.5,abc,true", [1, 2.5, "abc", True]),
    (",1,,2,", [1, 2]),
    ("7", [7]),
    (3.5, [3.5]),
    (True, [True]),
])
def test_grid_axes(given, values):
    got = spec.parse_values("drive.t0", given, "W")
    assert got == values
    assert [type(v) for v in got] == [type(v) for v in values]


@pytest.mark.parametrize("given, message", [
    ("1:2", "W: drive.t0: expected start:stop:count, got '1:2'"),
    ("1:2:3:4", "W: drive.t0: expected start:stop:count, got '1:2:3:4'"),
    ([], "W: drive.t0: no values"),
    ("", "W: drive.t0: no values"),
    (" , ", "W: drive.t0: no values"),
    ([1.0, math.nan], "W: drive.t0: values must be finite, got nan"),
    ([math.inf], "W: drive.t0: values must be finite, got inf"),
    ("1,-inf", "W: drive.t0: values must be finite, got -inf"),
    ([1, 2, 1], "W: drive.t0: repeated values in [1, 2, 1]"),
    ("a,b,a", "W: drive.t0: repeated values in ['a', 'b', 'a']"),
    ("1:2:0", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:2:0"),
    ("1:2:-3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:2:-3"),
    ("1:2:2.0", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:2:2.0"),
    ("1:2:true", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:2:True"),
    ("true:2:3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got True:2:3"),
    ("1:false:3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:False:3"),
    ("a:2:3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 'a':2:3"),
    ("1:b:3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:'b':3"),
    ("inf:2:3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got inf:2:3"),
    ("1:nan:3", "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:nan:3"),
    ({"start": 1, "stop": 2, "count": 0},
     "W: drive.t0: start:stop:count needs two finite numbers and a count >= 1, got 1:2:0"),
    ("2:1:3", "W: drive.t0: start:stop:count needs start < stop (a reversed range; list the values to sweep "
              "downwards), got 2:1:3"),
    ({"start": 1.5, "stop": 1.5, "count": 2}, "W: drive.t0: start:stop:count needs start < stop (an empty range; "
                                              "list the values to sweep downwards), got 1.5:1.5:2"),
])
def test_grid_axis_refusals(given, message):
    with pytest.raises(StudyError) as e:
        spec.parse_values("drive.t0", given, "W")
    assert e.value.problems == [message]


def test_a_dict_axis_needs_exactly_start_stop_count():
    assert spec.parse_values("k.p", {"start": 1}, "W") == [{"start": 1}]  # a single (odd) value
    assert spec.parse_values("k.p", {"start": 0, "stop": 1, "count": 2, "x": 1}, "W") == [
        {"start": 0, "stop": 1, "count": 2, "x": 1}]


def test_linspace_values():
    got = spec._linspace("k.p", 0, 1, 5, "W")
    assert got == [0.0, 0.25, 0.5, 0.75, 1.0] and all(type(v) is float for v in got)
    assert spec._linspace("k.p", 3, 9, 1, "W") == [3.0] and type(spec._linspace("k.p", 3, 9, 1, "W")[0]) is float
    with pytest.raises(StudyError):
        spec._linspace("k.p", 1.0, 1.0, 2, "W")
    assert spec._linspace("k.p", -1, 1, 3, "W") == [-1.0, 0.0, 1.0]


@pytest.mark.parametrize("key, ok", [
    ("drive.t0", True), ("a.b.c", True), ("nodot", False), ("drive.", False), (".t0", False),
    (".", False), (3, False), (None, False), (".drive.t0", False),
    # the instance ends at the first dot; the parameter is the rest, whatever it is (the
    # scenario's checker knows the model's names)
    ("drive.t0.", True), ("drive..t0", True),
])
def test_check_key(key, ok):
    problems = []
    assert spec._check_key(key, "W", problems) is ok
    assert problems == ([] if ok else [f"W: {key!r}: expected instance.parameter, e.g. drive.t0"])


@pytest.mark.parametrize("w, ok", [
    (["start", "stop"], True), ((0, 2.5), True), ([1, "after+1"], True), ([True, 1], False),
    ([1, None], False), ([1], False), ([1, 2, 3], False), ("ab", False), (None, False), ({1: 2, 3: 4}, False),
])
def test_window_ok(w, ok):
    assert spec._window_ok(w) is ok


# ---------------------------------------------------------------------------- build: defaults and fields
def test_build_defaults_and_fields():
    st = build("fast_start")
    assert st == Study(name="fast_start", scenario="fast_start", description="", set=[], grid={}, sample=None,
                       model=DEFAULT_MODEL, indicators=[], source=None, stop=None, case=None, mode=None)
    assert st.points() == [{}] and st.swept == []
    st = build("scenarios/fast_start.toml", name="mine", description="d", set_=("ball.mu=0.4",),
               grid={"drive.t0": [1, 2]}, model={"method": "DOP853", "tolerance": 1e-10},
               indicators=[{"name": "n_late", "variable": "ball.N", "stat": "max"},
                           Indicator("z", "ball.zP", "mean", (1.0, "stop"))],
               source=Path("x.toml"), stop=12)
    assert st.name == "mine" and st.scenario == "scenarios/fast_start.toml" and st.description == "d"
    assert st.set == ["ball.mu=0.4"] and type(st.set) is list
    assert st.grid == {"drive.t0": [1, 2]} and st.sample is None
    assert st.model == {**DEFAULT_MODEL, "method": "DOP853", "tolerance": 1e-10}
    assert st.indicators == [Indicator("n_late", "ball.N", "max", ("start", "stop")),
                             Indicator("z", "ball.zP", "mean", (1.0, "stop"))]
    assert st.source == Path("x.toml") and st.stop == 12.0 and type(st.stop) is float
    assert st.case is None and st.mode is None
    assert build("scenarios/fast_start.toml").name == "fast_start"  # the file's stem
    assert build(Path("a/b/other.toml")).scenario == "a/b/other.toml"


def test_build_model_values_at_their_edges():
    st = build("fast_start", model={"h": 1e-300, "tolerance": 1, "dt": 2.5, "target_P": 3, "method": "RK45",
                                    "kind": "cosim"})
    assert st.model == {"kind": "cosim", "method": "RK45", "h": 1e-300, "tolerance": 1, "dt": 2.5, "target_P": 3,
                        "error": "one-pass"}
    assert build("fast_start", stop=1e-9).stop == 1e-9


@pytest.mark.parametrize("kw, problems", [
    ({"stop": 0}, ["W: stop: expected a positive number of seconds, got 0"]),
    ({"stop": -1.0}, ["W: stop: expected a positive number of seconds, got -1.0"]),
    ({"stop": math.inf}, ["W: stop: expected a positive number of seconds, got inf"]),
    ({"stop": math.nan}, ["W: stop: expected a positive number of seconds, got nan"]),
    ({"stop": True}, ["W: stop: expected a positive number of seconds, got True"]),
    ({"stop": "5"}, ["W: stop: expected a positive number of seconds, got '5'"]),
    ({"mode": "up"}, ["W: mode: only a study of a built-in case (case = ...) has a mode"]),
    ({"model": {"h": 0}}, ["W: model.h: expected a positive number, got 0"]),
    ({"model": {"tolerance": -1e-8}}, ["W: model.tolerance: expected a positive number, got -1e-08"]),
    ({"model": {"dt": math.inf}}, ["W: model.dt: expected a positive number, got inf"]),
    ({"model": {"target_P": True}}, ["W: model.target_P: expected a positive number, got True"]),
    ({"model": {"h": "0.1"}}, ["W: model.h: expected a positive number, got '0.1'"]),
    ({"model": {"method": "Euler"}}, ["W: model.method: expected RK4, RK45 or DOP853, got 'Euler'"]),
    ({"model": {"error": "embedded"}}, ["W: model.error: expected one-pass or richardson, got 'embedded'"]),
    ({"model": {"order": 4, "h": math.nan}}, [
        "W: model.order: unknown key (known: kind, method, h, tolerance, dt, target_P, error)",
        "W: model.h: expected a positive number, got nan"]),
    ({"grid": {"nodot": [1], "drive.t0": "1:2", "drive.n0": [60]}}, [
        "W: 'nodot': expected instance.parameter, e.g. drive.t0",
        "W: drive.t0: expected start:stop:count, got '1:2'"]),
    ({"set_": ["nodot=1", "drive.t0=3", "ball.mu=0.2"], "grid": {"drive.t0": [1, 2]}}, [
        "--set 'nodot=1': expected instance.parameter=value, e.g. drive.t0=30",
        "W: --set drive.t0=3: drive.t0 is also swept"]),
    ({"set_": ["drive.n0=3"], "sample": {"ranges": {"drive.n0": [1, 2]}, "points": 2}}, [
        "W: --set drive.n0=3: drive.n0 is also swept"]),
])
def test_build_problems(kw, problems):
    assert _problems(where="W", **kw) == problems


@pytest.mark.parametrize("sample, problems", [
    ({"method": "sobol", "points": 3, "ranges": {"drive.t0": [1, 2]}},
     ["W: sample.method: expected one of ('lhs', 'random'), got 'sobol'"]),
    ({"ranges": {"drive.t0": [1, 2]}}, ["W: sample.points: expected a positive integer, got None"]),
    ({"points": 0, "ranges": {"drive.t0": [1, 2]}}, ["W: sample.points: expected a positive integer, got 0"]),
    ({"points": 2.0, "ranges": {"drive.t0": [1, 2]}}, ["W: sample.points: expected a positive integer, got 2.0"]),
    ({"points": True, "ranges": {"drive.t0": [1, 2]}}, ["W: sample.points: expected a positive integer, got True"]),
    ({"points": 2, "seed": 1.5, "ranges": {"drive.t0": [1, 2]}},
     ["W: sample.seed: expected an integer, got 1.5"]),
    ({"points": 2, "seed": False, "ranges": {"drive.t0": [1, 2]}},
     ["W: sample.seed: expected an integer, got False"]),
    ({"points": 2}, ["W: sample.ranges: a sample needs at least one range, e.g. drive.t0 = [0.5, 30]"]),
    ({"points": 2, "ranges": {}}, ["W: sample.ranges: a sample needs at least one range, e.g. drive.t0 = [0.5, 30]"]),
    ({"points": 2, "ranges": {"t0": [1, 2]}}, [
        "W: 't0': expected instance.parameter, e.g. drive.t0",
        "W: sample.ranges: a sample needs at least one range, e.g. drive.t0 = [0.5, 30]"]),
    ({"points": 2, "ranges": {"drive.t0": [2, 1], "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got [2, 1]"]),
    ({"points": 2, "ranges": {"drive.t0": [1, 1], "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got [1, 1]"]),
    ({"points": 2, "ranges": {"drive.t0": [1, 2, 3], "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got [1, 2, 3]"]),
    ({"points": 2, "ranges": {"drive.t0": [True, 2], "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got [True, 2]"]),
    ({"points": 2, "ranges": {"drive.t0": [1, math.inf], "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got [1, inf]"]),
    ({"points": 2, "ranges": {"drive.t0": ["a", 2], "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got ['a', 2]"]),
    ({"points": 2, "ranges": {"drive.t0": "3:1", "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got [3, 1]"]),
    ({"points": 2, "ranges": {"drive.t0": 5, "drive.n0": [1, 2]}},
     ["W: sample.ranges.drive.t0: expected [low, high] with low < high, got 5"]),
])
def test_sample_problems(sample, problems):
    assert _problems(where="W", sample=sample) == problems


def test_every_problem_is_kept():
    # a bad override after other problems, a bad range key before a good range, two bad indicators
    assert _problems(stop=-1, set_=["nodot=1", "drive.x=2"], grid={"nodot": [1]}) == [
        "study: stop: expected a positive number of seconds, got -1",
        "study: 'nodot': expected instance.parameter, e.g. drive.t0",
        "--set 'nodot=1': expected instance.parameter=value, e.g. drive.t0=30"]
    assert _problems(sample={"points": 2, "ranges": {"t0": [1, 2], "drive.n0": [1, 2]}}) == [
        "study: 't0': expected instance.parameter, e.g. drive.t0"]
    assert _problems(sample={"points": 2, "ranges": {"drive.t0": [2, 1], "drive.l": [0, 1], "drive.n0": 3}}) == [
        "study: sample.ranges.drive.t0: expected [low, high] with low < high, got [2, 1]",
        "study: sample.ranges.drive.n0: expected [low, high] with low < high, got 3"]
    assert _problems(indicators=[3, "x", {"name": "a", "variable": "ball.N", "stat": "max", "window": [1]},
                                 {"name": "b", "variable": "ball.N", "stat": "max", "window": 2},
                                 {"name": "c", "variable": "N", "stat": "max"}]) == [
        "study: indicators[0]: expected a table with name, variable, stat, window",
        "study: indicators[1]: expected a table with name, variable, stat, window",
        f"study: indicators[2].window: {WINDOW_TEXT} [1]",
        f"study: indicators[3].window: {WINDOW_TEXT} 2",
        "study: indicators[4].variable: expected instance.variable, got 'N'"]


def test_a_grid_and_a_sample_together():
    assert _problems(where="W", grid={"drive.t0": [1], "ball.mu": [0.2]},
                     sample={"points": 2, "ranges": {"drive.n0": [1, 2], "drive.l": [0.1, 0.2]}}) == [
        "W: a study has either a grid or a sample, not both (grid keys ['ball.mu', 'drive.t0'], "
        "sample ranges ['drive.l', 'drive.n0'])"]


def test_sample_settings_kept_and_defaulted():
    st = build("fast_start", sample={"points": 4, "ranges": {"drive.t0": "1:3", "drive.n0": (30, 90)}})
    assert st.sample == {"points": 4, "method": "lhs", "ranges": {"drive.t0": (1.0, 3.0), "drive.n0": (30.0, 90.0)}}
    assert all(type(v) is float for r in st.sample["ranges"].values() for v in r)
    assert st.swept == ["drive.t0", "drive.n0"] and st.grid == {}
    st = build("fast_start", sample={"method": "random", "points": 1, "seed": 7, "ranges": {"drive.t0": [1, 2]}})
    assert st.sample == {"method": "random", "points": 1, "seed": 7, "ranges": {"drive.t0": (1.0, 2.0)}}


@pytest.mark.parametrize("indicators, problems", [
    ([3], ["W: indicators[0]: expected a table with name, variable, stat, window"]),
    ([{"name": "a", "variable": "ball.N", "stat": "max", "unit": "N", "color": 1}],
     ["W: indicators[0]: unknown key(s) ['color', 'unit']"]),
    ([{"name": "1a", "variable": "ball.N", "stat": "max"}],
     ["W: indicators[0].name: expected an identifier, got '1a'"]),
    ([{"variable": "ball.N", "stat": "max"}], ["W: indicators[0].name: expected an identifier, got None"]),
    ([{"name": "a", "variable": "ball.N", "stat": "max"}, {"name": "b", "variable": "ball.N", "stat": "min"},
      {"name": "a", "variable": "ball.zP", "stat": "min"}],
     ["W: indicators[2].name: 'a' is defined twice"]),
    ([{"name": "a", "variable": "N", "stat": "max"}],
     ["W: indicators[0].variable: expected instance.variable, got 'N'"]),
    ([{"name": "a", "variable": 3, "stat": "max"}], ["W: indicators[0].variable: expected instance.variable, got 3"]),
    ([{"name": "a", "variable": "ball.N", "stat": "median"}],
     [f"W: indicators[0].stat: expected one of {STATS_TEXT}, got 'median'"]),
    ([{"name": "a", "variable": "ball.N", "stat": "max", "window": [0, 1, 2]}],
     [f"W: indicators[0].window: {WINDOW_TEXT} [0, 1, 2]"]),
    ([{"name": "a", "variable": "ball.N", "stat": "max", "window": "after"}],
     [f"W: indicators[0].window: {WINDOW_TEXT} 'after'"]),
    ([{"name": "a", "variable": "ball.N", "stat": "max"}, {"name": "b", "variable": "ball.N", "stat": "max",
                                                              "window": [None, 1]}],
     [f"W: indicators[1].window: {WINDOW_TEXT} [None, 1]"]),
])
def test_indicator_problems(indicators, problems):
    assert _problems(where="W", indicators=indicators) == problems


def test_indicators_built_in_order():
    st = build("fast_start", indicators=[{"name": "b", "variable": "ball.N", "stat": "integral", "window": (0, 2)},
                                         {"name": "a", "variable": "drive.T_drive", "stat": "abs_max"}])
    assert st.indicators == [Indicator("b", "ball.N", "integral", (0, 2)),
                             Indicator("a", "drive.T_drive", "abs_max", ("start", "stop"))]
    assert all(type(i.window) is tuple for i in st.indicators)


# ---------------------------------------------------------------------------- build: a built-in case
def test_case_study_defaults():
    st = build("absorber", case="absorber", grid={"excitation.frequency": "0.5:1.1:3"})
    assert st.case == "absorber" and st.mode == "steady" and st.sample is None
    assert st.model == {"kind": "auto", "tolerance": 1e-9, "rtol": 1e-3, "max_periods": 400, "refine_rounds": 8,
                        "refine_rtol": 0.003, "df_min": 2e-4}
    assert st.grid == {"excitation.frequency": [0.5, 0.8, 1.1]}  # rounded to 9 digits, no direction
    st = build("absorber", case="absorber", grid={"excitation.frequency": [0.7, 0.9]}, mode="both",
               model={"rtol": 1e-4})
    assert list(st.grid) == ["sweep.direction", "excitation.frequency"]
    assert st.grid["sweep.direction"] == ["up", "down"] and st.mode == "both"
    assert st.model["rtol"] == 1e-4 and st.model["tolerance"] == 1e-9


class _FakeCase:
    """A registered case (evaluators.CASES) that records what build asks of it."""

    MODES = ("fast", "slow")
    MODEL = {"kind": "fake", "eps": 0.5}
    POSITIVE = ("eps",)

    def __init__(self):
        self.calls = []

    def check_study(self, grid, model, mode, where):
        self.calls.append(("check", dict(grid), dict(model), mode, where))
        return [f"{where}: fake says {mode}"] if mode == "slow" else []

    def study_grid(self, grid, mode):
        self.calls.append(("grid", dict(grid), mode))
        return {"fake.mode": [mode], **grid}


def test_a_registered_case_is_asked_with_the_study_s_values(monkeypatch):
    from ballmill.sweep import evaluators

    fake = _FakeCase()
    monkeypatch.setitem(evaluators.CASES, "fake", fake)
    st = build("fake", case="fake", grid={"a.b": [1, 2]}, model={"eps": 2.0})
    assert fake.calls == [("check", {"a.b": [1, 2]}, {"kind": "fake", "eps": 2.0}, "fast", "study"),
                          ("grid", {"a.b": [1, 2]}, "fast")]
    assert st.grid == {"fake.mode": ["fast"], "a.b": [1, 2]} and st.mode == "fast"
    assert st.model == {"kind": "fake", "eps": 2.0}
    assert _problems(scenario="fake", case="fake", mode="slow", where="W", model={"eps": 0}) == [
        "W: model.eps: expected a positive number, got 0", "W: fake says slow"]
    with pytest.raises(StudyError) as e:
        build("x", case="nothing")
    assert e.value.problems == ["study: case 'nothing': no such case (known: absorber, fake)"]


def test_case_study_problems():
    with pytest.raises(StudyError) as e:
        build("x", case="nothing", where="W", stop=-1)
    assert e.value.problems == ["W: case 'nothing': no such case (known: absorber)"]
    assert _problems(scenario="absorber", where="W", case="absorber", stop=3.0, mode="sideways",
                     grid={"excitation.frequency": [0.8]},
                     sample={"points": 3, "ranges": {"a.b": [1, 2]}},
                     indicators=[{"name": "a", "variable": "ball.N", "stat": "max"}],
                     model={"tolerance": 0, "zzz": 1, "method": "RK4"}) == [
        "W: stop: does not apply to case 'absorber' (its points run until they settle)",
        "W: sample: case 'absorber' takes a [grid]",
        "W: indicators: case 'absorber' has its own indicators only",
        "W: mode: expected one of steady, up, down, both, got 'sideways'",
        "W: a study has either a grid or a sample, not both (grid keys ['excitation.frequency'], "
        "sample ranges ['a.b'])",
        "W: model.zzz: unknown key (known: kind, tolerance, rtol, max_periods, refine_rounds, refine_rtol, df_min)",
        "W: model.method: unknown key (known: kind, tolerance, rtol, max_periods, refine_rounds, refine_rtol, "
        "df_min)",
        "W: model.tolerance: expected a positive number, got 0"]
    # the case's own checks, and none of the FMU study's (h, dt, target_P, method)
    assert _problems(scenario="absorber", where="W", case="absorber", grid={"drive.t0": [1]},
                     model={"max_periods": 3}) == [
        'W: grid: an absorber study sweeps excitation.frequency (e.g. "excitation.frequency" = "0.5:1.1:61" [Hz])',
        "W: grid: the absorber case has no parameter drive.t0",
        "W: model.max_periods: expected an integer >= 4 (excitation periods), got 3"]
    assert _problems(scenario="absorber", where="W", case="absorber", grid={"excitation.frequency": [0.8]},
                     model={"df_min": -1.0}) == ["W: model.df_min: expected a positive number, got -1.0"]


# ---------------------------------------------------------------------------- points
def test_grid_points_in_order():
    st = build("fast_start", grid={"drive.t0": [1, 2.5], "drive.n0": "40:60:3", "ball.mu": "0.2,0.3"})
    pts = st.points()
    assert len(pts) == 12
    assert pts[0] == {"drive.t0": 1, "drive.n0": 40.0, "ball.mu": 0.2}
    assert pts[1] == {"drive.t0": 1, "drive.n0": 40.0, "ball.mu": 0.3}  # the last key fastest
    assert pts[2] == {"drive.t0": 1, "drive.n0": 50.0, "ball.mu": 0.2}
    assert pts[6] == {"drive.t0": 2.5, "drive.n0": 40.0, "ball.mu": 0.2}
    assert pts[11] == {"drive.t0": 2.5, "drive.n0": 60.0, "ball.mu": 0.3}
    assert type(pts[0]["drive.t0"]) is int and list(pts[0]) == ["drive.t0", "drive.n0", "ball.mu"]
    one = build("fast_start", grid={"drive.t0": [4.0]}).points()
    assert one == [{"drive.t0": 4.0}]


def test_sample_points_from_the_seed():
    ranges = {"drive.t0": [1.0, 3.0], "drive.n0": [30.0, 90.0], "drive.l": [0.3, 0.7]}
    n = 40
    rnd = build("fast_start", sample={"method": "random", "points": n, "seed": 5, "ranges": ranges}).points()
    u = np.random.default_rng(5).random((n, 3))  # the documented recipe: uniform, row by row
    lo, hi = np.array([1.0, 30.0, 0.3]), np.array([3.0, 90.0, 0.7])
    assert np.array_equal(np.array([[p[k] for k in ranges] for p in rnd]), lo + u * (hi - lo))
    assert all(type(v) is float for p in rnd for v in p.values()) and list(rnd[0]) == list(ranges)
    lhs = build("fast_start", sample={"points": n, "seed": 5, "ranges": ranges}).points()
    assert len(lhs) == n
    # each point lies at random inside its stratum: its offset there differs from point to point
    for key, (a, b) in ranges.items():
        offsets = {round((p[key] - a) / (b - a) * n % 1.0, 9) for p in lhs}
        assert len(offsets) == n
    for key, (a, b) in ranges.items():
        vals = [p[key] for p in lhs]
        assert all(a <= v <= b for v in vals)
        assert sorted(int((v - a) / (b - a) * n) for v in vals) == list(range(n))  # one in each stratum
    # the strata are shuffled independently per axis: the axes are not in step
    order = [np.argsort([p[k] for p in lhs]).tolist() for k in ranges]
    assert order[0] != order[1] and order[1] != order[2]
    # no seed is seed 0; another seed gives other points
    s0 = build("fast_start", sample={"points": 5, "ranges": ranges}).points()
    assert s0 == build("fast_start", sample={"points": 5, "seed": 0, "ranges": ranges}).points()
    assert s0 != build("fast_start", sample={"points": 5, "seed": 1, "ranges": ranges}).points()
    r0 = build("fast_start", sample={"method": "random", "points": 5, "ranges": ranges}).points()
    assert np.array_equal(np.array([[p[k] for k in ranges] for p in r0]),
                          lo + np.random.default_rng(0).random((5, 3)) * (hi - lo))


def test_lhs_points_of_one_axis_and_one_point():
    pts = build("fast_start", sample={"points": 1, "seed": 2, "ranges": {"drive.t0": [2.0, 4.0]}}).points()
    rng = np.random.default_rng(2)
    first = rng.random((1, 1))  # the shuffle's keys, then the position inside the stratum
    assert first.shape == (1, 1)
    assert pts == [{"drive.t0": 2.0 + 2.0 * float(rng.random((1, 1))[0, 0])}]


# ---------------------------------------------------------------------------- ids and contexts
def test_point_id_pinned():
    text = '{"ball.mu": 0.3, "drive.t0": 2.0, "drive.x": "(1+2j)", "drive.y": true}'
    expected = hashlib.sha256(text.encode()).hexdigest()[:16]
    p = {"drive.t0": 2, "ball.mu": 0.3, "drive.y": True, "drive.x": complex(1, 2)}
    assert spec.point_id(p) == expected
    assert spec.point_id({"drive.t0": 2}) == spec.point_id({"drive.t0": 2.0})
    assert spec.point_id({"drive.t0": True}) != spec.point_id({"drive.t0": 1.0})
    assert spec.point_id({}) == hashlib.sha256(b"{}").hexdigest()[:16]
    # the same values in another order, also inside a table value: the same id
    assert spec.point_id({"a.b": {"y": 1, "x": 2}, "a.a": 1}) == spec.point_id({"a.a": 1, "a.b": {"x": 2, "y": 1}})
    assert len(spec.point_id({"a.b": 1})) == 16


def test_context_and_its_hash():
    st = build("fast_start", set_=["drive.n0=50", "ball.mu=0.2"], grid={"drive.t0": [1, 2]},
               model={"method": "RK45"}, stop=8.0,
               indicators=[{"name": "a", "variable": "ball.N", "stat": "max", "window": [0, "after"]}])
    ctx = st.context("text of the scenario", "crank-kernel")
    assert ctx == {
        "scenario": "fast_start",
        "scenario_sha256": hashlib.sha256(b"text of the scenario").hexdigest(),
        "stop": 8.0, "set": ["ball.mu=0.2", "drive.n0=50"],
        "model": {"dt": 0.01, "error": "one-pass", "h": 0.01, "kind": "auto", "method": "RK45", "target_P": 1e-5,
                  "tolerance": 1e-8},
        "evaluator": "crank-kernel",
        "indicators": [{"name": "a", "variable": "ball.N", "stat": "max", "window": [0, "after"]}],
    }
    assert list(ctx["model"]) == sorted(ctx["model"])
    cst = build("absorber", case="absorber", grid={"excitation.frequency": [0.8]}, mode="up")
    cctx = cst.context("t", "absorber")
    assert cctx["case"] == "absorber" and cctx["mode"] == "up" and cctx["stop"] is None
    assert list(cctx) == ["scenario", "scenario_sha256", "stop", "set", "model", "evaluator", "indicators",
                          "case", "mode"]
    assert spec.context_hash({"b": [1, 2.5], "a": "x"}) == hashlib.sha256(
        b'{"a": "x", "b": [1, 2.5]}').hexdigest()[:16]


# ---------------------------------------------------------------------------- options
@pytest.mark.parametrize("v, text", [(True, "true"), (False, "false"), ("a\"b", '"a\\"b"'), (2.5, "2.5"),
                                     (3, "3"), ([1, 2], "[1, 2]")])
def test_toml_value(v, text):
    assert spec._toml_value(v) == text


def test_grid_option():
    assert spec.parse_grid_option(" drive.t0 = 1,2=3 ") == ("drive.t0", "1,2=3")
    with pytest.raises(StudyError) as e:
        spec.parse_grid_option("drive.t0")
    assert e.value.problems == ["--grid 'drive.t0': expected instance.parameter=values, e.g. drive.t0=1,2,2.5 "
                                "or drive.n0=40:80:5"]


@pytest.mark.parametrize("text, out", [
    ("lhs:10", {"method": "lhs", "points": 10}), ("random:5:3", {"method": "random", "points": 5, "seed": 3}),
    ("sobol:2", {"method": "sobol", "points": 2}),
])
def test_sample_option(text, out):
    assert spec.parse_sample_option(text) == out


@pytest.mark.parametrize("text", ["lhs", "lhs:x", "lhs:1:2:3", "lhs:2:y", ""])
def test_sample_option_refusals(text):
    with pytest.raises(StudyError) as e:
        spec.parse_sample_option(text)
    assert e.value.problems == [f"--sample {text!r}: expected lhs:N[:SEED] or random:N[:SEED]"]
    assert e.value.__suppress_context__


# ---------------------------------------------------------------------------- study files
def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_load_finds_the_scenario_next_to_the_study(tmp_path):
    _write(tmp_path / "plain", "")  # a scenario file without the .toml suffix
    f = _write(tmp_path / "a.toml", 'scenario = "plain"\n')
    assert load(str(f)).scenario == str(tmp_path / "plain")
    _write(tmp_path / "mine.toml", "")
    g = _write(tmp_path / "b.toml", 'scenario = "mine.toml"\n')
    assert load(str(g)).scenario == str(tmp_path / "mine.toml")


def test_resolve_study_relative_to_the_working_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path / "here.toml", 'scenario = "fast_start"\n')
    assert spec.resolve_study("here.toml") == Path("here.toml")
    _write(tmp_path / "bare", 'scenario = "fast_start"\n')
    assert spec.resolve_study("bare") is None  # a name without .toml is looked for in scenarios/studies
    assert spec.resolve_study("t0_n0") == spec.STUDY_DIR / "t0_n0.toml"


def test_resolve_study(tmp_path):
    f = _write(tmp_path / "s.toml", 'scenario = "fast_start"\n')
    assert spec.resolve_study(str(f)) == f
    c = _write(tmp_path / "c.toml", 'case = "absorber"\n')
    assert spec.resolve_study(str(c)) == c
    assert spec.resolve_study(str(_write(tmp_path / "n.toml", 'stop = 3\n'))) is None  # no study
    assert spec.resolve_study(str(tmp_path / "missing.toml")) is None
    assert spec.resolve_study("fast_start") is None  # a scenario, not a study
    assert spec.resolve_study("t0_n0") == spec.STUDY_DIR / "t0_n0.toml"
    assert spec.resolve_study("t0_n0.toml") == spec.STUDY_DIR / "t0_n0.toml"
    assert spec.resolve_study(str(tmp_path / "s")) == f  # an absolute path finds its .toml too
    bad = _write(tmp_path / "bad.toml", "scenario = \n")
    with pytest.raises(StudyError) as e:
        spec.resolve_study(str(bad))
    assert len(e.value.problems) == 1
    assert e.value.problems[0].startswith(f"{bad}: not valid TOML: ")
    assert e.value.__suppress_context__


def test_load_a_study_file(tmp_path):
    _write(tmp_path / "mine.toml", "")  # a scenario next to the study file, named without .toml
    f = _write(tmp_path / "st.toml", """
description = "a study"
scenario = "mine"
stop = 7.5
set = { "ball.mu" = 0.4, "drive.law" = "scurve", "ball.on" = true }
[grid]
"drive.t0" = [1.0, 2.0]
[model]
method = "DOP853"
[[indicators]]
name = "late"
variable = "ball.N"
stat = "rms"
window = ["after", "stop"]
""")
    st = load(str(f), set_=["drive.n0=50"], model={"tolerance": 1e-9})
    assert st.name == "st" and st.description == "a study" and st.source == f
    assert st.scenario == str(tmp_path / "mine.toml")
    assert st.stop == 7.5
    assert st.set == ["ball.mu=0.4", 'drive.law="scurve"', "ball.on=true", "drive.n0=50"]
    assert st.grid == {"drive.t0": [1.0, 2.0]} and st.sample is None
    assert st.model == {**DEFAULT_MODEL, "method": "DOP853", "tolerance": 1e-9}
    assert st.indicators == [Indicator("late", "ball.N", "rms", ("after", "stop"))]
    assert st.case is None and st.mode is None
    # command-line grid axes join the file's; a stop given replaces the file's
    st = load(str(f), grid={"drive.n0": "40:60:2"}, stop=3.0)
    assert st.grid == {"drive.t0": [1.0, 2.0], "drive.n0": [40.0, 60.0]} and st.stop == 3.0
    # a sample given replaces the file's grid
    st = load(str(f), sample={"points": 3, "ranges": {"drive.n0": [40, 60]}})
    assert st.grid == {} and st.sample["ranges"] == {"drive.n0": (40.0, 60.0)} and st.sample["points"] == 3
    # problems are named with the file
    with pytest.raises(StudyError) as e:
        load(str(f), model={"h": -1})
    assert e.value.problems == [f"{f.as_posix()}: model.h: expected a positive number, got -1"]


def test_load_a_sample_study_with_options(tmp_path):
    f = _write(tmp_path / "lhs.toml", """
scenario = "fast_start"
[sample]
points = 4
seed = 3
ranges = { "drive.t0" = [1.0, 2.0] }
""")
    st = load(str(f))
    assert st.scenario == "fast_start"  # no such file next to the study: the scenario's name
    assert st.description == "" and st.stop is None and st.set == [] and st.indicators == []
    assert st.sample == {"points": 4, "seed": 3, "method": "lhs", "ranges": {"drive.t0": (1.0, 2.0)}}
    st = load(str(f), sample={"points": 6, "ranges": {"drive.n0": [30, 90]}})
    assert st.sample == {"points": 6, "seed": 3, "method": "lhs",
                         "ranges": {"drive.t0": (1.0, 2.0), "drive.n0": (30.0, 90.0)}}
    st = load(str(f), sample={"method": "random"})
    assert st.sample["method"] == "random" and st.sample["ranges"] == {"drive.t0": (1.0, 2.0)}
    st = load(str(f), grid={"drive.n0": [50]})  # a grid given drops the file's sample
    assert st.sample is None and st.grid == {"drive.n0": [50]}
    with pytest.raises(StudyError) as e:  # both given: build says so
        load(str(f), grid={"drive.n0": [50]}, sample={"points": 2, "ranges": {"drive.l": [0.3, 0.4]}})
    assert e.value.problems == [f"{f.as_posix()}: a study has either a grid or a sample, not both "
                                f"(grid keys ['drive.n0'], sample ranges ['drive.l', 'drive.t0'])"]


def test_load_a_case_study(tmp_path):
    f = _write(tmp_path / "abs.toml", """
case = "absorber"
mode = "up"
[grid]
"excitation.frequency" = [0.7, 0.9]
""")
    st = load(str(f))
    assert st.case == "absorber" and st.mode == "up" and st.scenario == "absorber" and st.name == "abs"
    assert st.grid == {"sweep.direction": ["up"], "excitation.frequency": [0.7, 0.9]}
    assert load(str(f), mode="down").mode == "down"
    both = _write(tmp_path / "both.toml", 'case = "absorber"\nscenario = "fast_start"\n')
    with pytest.raises(StudyError) as e:
        load(str(both))
    assert e.value.problems == [f"{both.as_posix()}: a study has a scenario or a case, not both"]


def test_load_refusals(tmp_path):
    f = _write(tmp_path / "odd.toml", 'scenario = "fast_start"\ncolour = 1\nsize = 2\n')
    with pytest.raises(StudyError) as e:
        load(str(f))
    assert e.value.problems == [f"{f.as_posix()}: unknown key(s) ['colour', 'size']; expected description, "
                                f"scenario (or case and mode), stop, set, grid, sample, model, contact, indicators"]
    with pytest.raises(StudyError) as e:
        load("fast_start", mode="up")
    assert e.value.problems == ["--mode up: only a study of a built-in case (case = ...) has a mode"]
    with pytest.raises(ScenarioError):
        load("no_such_scenario_or_study")


def test_load_a_scenario_with_options():
    st = load("fast_start", set_=("ball.mu=0.3",), grid={"drive.t0": "1,2"}, model={"dt": 0.02}, stop=4)
    assert st.name == "fast_start" and st.scenario == "fast_start" and st.source is None
    assert st.set == ["ball.mu=0.3"] and st.grid == {"drive.t0": [1, 2]}
    assert st.model == {**DEFAULT_MODEL, "dt": 0.02} and st.stop == 4.0
    st = load("fast_start", sample={"points": 2, "ranges": {"drive.t0": [1, 2]}})
    assert st.sample["points"] == 2 and st.grid == {}
    with pytest.raises(StudyError) as e:
        load("fast_start", model={"h": 0})
    assert e.value.problems == ["command line: model.h: expected a positive number, got 0"]
