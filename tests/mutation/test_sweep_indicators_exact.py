"""The sweep's indicators (ballmill.sweep.indicators) on small records built by hand: every
builtin indicator's value, key and order, the windows' edges (the 1e-9 relative slack, the
valid span), each statistic on a few samples, the parabola refinement of an extremum against
the vertex of the parabola through three samples, the window references ("after+10",
"stop - 5", parameters) and the errors' texts word for word. Written for mutants that the
rest of the suite let through (docs/mutation.md); every value is computed inside a test."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.sweep import indicators as ind
from ballmill.sweep.spec import Indicator

# t: 11 samples 0 .. 5 s, dt = 0.5 s; "after" = 2.5 s is sample 5
T11 = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0)


def _vertex(ts, ys):
    """The extreme value of the parabola through three points (numpy's fit, not the module's formula)."""
    a, b, c = np.polyfit(np.asarray(ts, float), np.asarray(ys, float), 2)
    return c - b * b / (4.0 * a)


def _rec(drive=True, mu=0.3, **over):
    """A record whose extrema sit at interior samples with equal neighbours (the refined
    value is the sample itself) unless a test says otherwise."""
    t = np.array(T11)
    s = {
        # max 9 at 1.0 s (before "after"); after 2.5 s: max 7 at 3.5 s, min 3 at 4.5 s
        # min 3 at 4.5 s with neighbours 5 and 4: refined (3 - 0.25/6, tested below)
        "ball.N": np.array([5.0, 6.0, 9.0, 6.0, 5.0, 4.0, 5.0, 7.0, 5.0, 3.0, 4.0]),
        "ball.friction_ratio": np.array([0.1, 0.1, 0.1, 0.2, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]),
        # contact point radius in Oxy: 3-4-5 triangles; after 2.5 s min 0.5 at 3.0 s, max 1.0 at 4.0 s
        "ball.xP": np.array([0.3, 0.3, 0.3, 0.3, 0.3, 0.6, 0.3, 0.6, 0.6, 0.6, 0.6]),
        "ball.yP": np.array([0.4, 0.4, 0.4, 0.4, 0.4, 0.8, 0.4, 0.8, 0.8, 0.8, 0.8]),
        "ball.zP": np.array([0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        "ball.xC": np.zeros(11),
        "ball.yC": np.zeros(11),
        "ball.zC": np.full(11, 0.5),
    }
    # theta = atan2(rhoP, zC - zP): rhoP 0.5 at zC - zP = 0.5 gives 45 deg
    if drive:
        # |T| peaks at the negative side: -8 at 2.0 s; +6 at 1.0 s
        s["drive.T_drive"] = np.array([0.0, 1.0, 6.0, 1.0, -8.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        s["drive.P_drive"] = np.array([2.0, 2.0, 2.0, 2.0, 2.0, 2.0, 7.0, 7.0, 7.0, 7.0, 7.0])
    s.update(over)
    refs = {"start": 0.0, "stop": 5.0, "after": 2.5, "drive.t0": 2.5, "drive.n0": 60.0}
    return ind.Record(t, s, "ball", "drive" if drive else None, mu, refs)


# ---------------------------------------------------------------------------- derived variables
def test_record_get_series_derived_and_cached():
    rec = _rec()
    assert rec.get("ball.N") is rec.series["ball.N"]
    rho = rec.get("ball.rhoP")
    assert np.allclose(rho, [0.5, 0.5, 0.5, 0.5, 0.5, 1.0, 0.5, 1.0, 1.0, 1.0, 1.0], rtol=0, atol=1e-15)
    assert rec.derived["ball.rhoP"] is rho and rec.get("ball.rhoP") is rho  # computed once
    th = rec.get("ball.theta_deg")
    assert rec.derived["ball.theta_deg"] is th
    # rhoP 0.5 at height 0.5 below the centre: 45 deg; rhoP 1.0: atan(2)
    assert th[0] == pytest.approx(45.0, abs=1e-12)
    assert th[5] == pytest.approx(math.degrees(math.atan(2.0)), abs=1e-12)
    # the centre's offset counts: P - C, not P
    off = _rec(**{"ball.xC": np.full(11, 0.3), "ball.yC": np.full(11, 0.4)})
    assert off.get("ball.theta_deg")[0] == pytest.approx(0.0, abs=1e-12)
    # zC - zP: the contact point 0.01 m higher at 1.5 s
    assert th[3] == pytest.approx(math.degrees(math.atan2(0.5, 0.49)), abs=1e-12)


def test_record_get_unknown_variable_names_what_is_recorded():
    rec = _rec(drive=False)
    with pytest.raises(KeyError) as e:
        rec.get("ball.nothing")
    assert e.value.args[0] == (
        "no recorded variable 'ball.nothing' (recorded: ball.N, ball.friction_ratio, ball.xC, ball.xP, "
        "ball.yC, ball.yP, ball.zC, ball.zP, ball.rhoP, ball.theta_deg, ball.slip_margin)")
    # the derived names belong to the record's ball instance only
    with pytest.raises(KeyError):
        rec.get("other.rhoP")
    assert "other.rhoP" not in rec.derived


# ---------------------------------------------------------------------------- window references
@pytest.mark.parametrize("ref, seconds", [
    (3, 3.0), (2.25, 2.25), (-1.5, -1.5),
    ("start", 0.0), ("stop", 5.0), ("after", 2.5), ("drive.n0", 60.0),
    ("after+10", 12.5), ("after + 10", 12.5), ("stop-5", 0.0), ("stop - 0.5", 4.5),
    ("drive.t0+0.25", 2.75), ("after+1e1", 12.5), ("after-2.5E-1", 2.25), ("stop+3.", 8.0),
])
def test_time_of_references(ref, seconds):
    got = _rec().time_of(ref)
    assert type(got) is float and got == seconds


@pytest.mark.parametrize("ref", ["later", "after*2", "later+1", True, "+5"])
def test_time_of_refuses_unknown_references(ref):
    with pytest.raises(KeyError) as e:
        _rec().time_of(ref)
    assert e.value.args[0] == (
        f"window reference {ref!r}: not a number of seconds, 'start', 'after', 'stop' or a parameter "
        f"of the scenario, optionally +- seconds (known: after, drive.n0, drive.t0, start, stop)")


# ---------------------------------------------------------------------------- validity
@pytest.mark.parametrize("N, fr, expected", [
    ([1.0, 2.0, 3.0], [0.1, 0.3, 0.0], (True, None, 3)),          # |F_t| = mu N is still rolling
    ([1.0, 0.0, 3.0], [0.1, 0.1, 0.1], (False, 0.5, 1)),          # N = 0: contact lost
    ([1.0, 2.0, -3.0], [0.1, 0.1, 0.1], (False, 1.0, 2)),
    ([1.0, 2.0, 3.0], [0.1, 0.1, 0.30000001], (False, 1.0, 2)),   # slip
    ([1.0, 2.0, 3.0], [-0.1, math.nan, 0.1], (False, 0.5, 1)),    # NaN is never valid
    ([math.nan, 2.0, 3.0], [0.1, 0.1, 0.1], (False, 0.0, 0)),
    ([1.0, 0.0, 3.0], [0.1, 0.1, 0.5], (False, 0.5, 1)),          # the first bad sample of either kind
    ([1, 2, 3], [0, 0, 0], (True, None, 3)),                       # integers are numbers too
])
def test_validity(N, fr, expected):
    got = ind.validity([0.0, 0.5, 1.0], N, fr, 0.3)
    assert got == expected
    assert type(got[0]) is bool and type(got[2]) is int
    if got[1] is not None:
        assert type(got[1]) is float


# ---------------------------------------------------------------------------- refinement and windows
def test_refine_is_the_vertex_of_the_parabola_through_three_samples():
    t = np.array([0.0, 0.25, 0.5, 0.75])
    x = 1.0 - (t - 0.3) ** 2  # a parabola: its vertex 1.0 at t = 0.3, between samples
    assert ind._refine(t, x, 1, 1) == pytest.approx(1.0, abs=1e-15)
    y = np.array([5.0, 3.0, 4.0, 9.0])  # a minimum at sample 1, neighbours 5 and 4
    assert ind._refine(t, y, 1, -1) == pytest.approx(_vertex(t[:3], y[:3]), abs=1e-14)
    assert ind._refine(t, y, 1, -1) == pytest.approx(3.0 - 0.25 / 6.0, abs=1e-15)
    # the wrong bend, a flat line, the ends: the sample itself
    assert ind._refine(t, y, 1, 1) == 3.0
    assert ind._refine(t, np.array([2.0, 2.0, 2.0, 2.0]), 1, 1) == 2.0
    assert ind._refine(t, np.array([2.0, 2.0, 2.0, 2.0]), 1, -1) == 2.0
    assert ind._refine(t, y, 0, -1) == 5.0 and ind._refine(t, y, 3, 1) == 9.0
    # uneven or repeated times: the sample itself; even to 1e-9 relative: refined
    for tt in ([0.0, 0.25, 0.5 + 1e-6, 0.75], [0.0, 0.0, 0.5, 0.75], [0.0, 0.5, 0.5, 0.75],
               [0.0, 0.3, 0.4, 0.75]):
        assert ind._refine(np.array(tt), y, 1, -1) == 3.0
    near = np.array([0.0, 0.25, 0.5 + 4e-10, 0.75])
    assert ind._refine(near, y, 1, -1) == pytest.approx(3.0 - 0.25 / 6.0, abs=1e-15)
    # 1e-9 s apart at h0 + h1 = 0.5 s: beyond 1e-9 (h0 + h1), the sample itself
    assert ind._refine(np.array([0.0, 0.25, 0.5 + 1e-9, 0.75]), y, 1, -1) == 3.0
    # exactly at the threshold (|h0 - h1| = 2^-30 = 1e-9 (h0 + h1) in floating point): refined
    edge = np.array([0.0, 0.46566128684207797, 0.9313225746154785, 1.5])
    h0, h1 = edge[1] - edge[0], edge[2] - edge[1]
    assert abs(h0 - h1) == 1e-9 * (h0 + h1)
    assert ind._refine(edge, y, 1, -1) == pytest.approx(3.0 - 0.25 / 6.0, abs=1e-15)
    assert type(ind._refine(t, np.array([1, 4, 2, 0]), 1, 1)) is float


def test_window_edges():
    rec = _rec()
    assert ind._window(rec, 1.0, 2.0, 11) == slice(2, 5)
    assert ind._window(rec, "after", "stop", 11) == slice(5, 11)
    assert ind._window(rec, "after", "stop", 10) is None  # reaches past the valid span
    assert ind._window(rec, "start", "after", 6) == slice(0, 6)  # ends exactly at it
    assert ind._window(rec, 2.0, 1.0, 11) is None  # empty
    assert ind._window(rec, 1.2, 1.3, 11) is None  # no sample inside
    assert ind._window(rec, 1.3, 1.5, 11) == slice(3, 4)
    # a sample within 1e-9 max(1, |b|) of an edge is inside
    assert ind._window(rec, 0.5 + 0.9e-9, 1.0, 11) == slice(1, 3)
    assert ind._window(rec, 0.5 + 1.1e-9, 1.0, 11) == slice(2, 3)
    assert ind._window(rec, 0.0, 1.0 - 0.9e-9, 11) == slice(0, 3)
    assert ind._window(rec, 0.0, 1.0 - 1.1e-9, 11) == slice(0, 2)
    assert ind._window(rec, 0.5 + 1.1e-9, 1.0 - 1.1e-9, 11) is None
    # b + slack lands exactly on the sample at 1 s: it is inside (searchsorted side="right")
    assert (1.0 - 1e-9) + 1e-9 == 1.0
    assert ind._window(rec, 0.0, 1.0 - 1e-9, 11) == slice(0, 3)
    assert ind._window(rec, 1.5 + 1.9e-9, 2.0, 11) == slice(3, 5)  # 2e-9 at b = 2 s
    assert ind._window(rec, 1.5 + 2.1e-9, 2.0, 11) == slice(4, 5)
    t = np.array([0.0, 0.5, 1.0 + 1.5e-9])
    small = ind.Record(t, {}, "ball", None, 0.3, {})
    assert ind._window(small, 0.0, 1.0, 3) == slice(0, 2)  # 1.5e-9 past an edge of 1 s: outside
    big = ind.Record(np.array([0.0, 1000.0, 1000.0 + 5e-7, 2000.0]), {}, "ball", None, 0.3, {})
    assert ind._window(big, 0.0, 1000.0, 4) == slice(0, 3)  # slack 1e-6 at 1000 s
    assert ind._window(big, 0.0, 1000.0 - 9e-7, 4) == slice(0, 2)
    assert ind._window(big, 0.0, 1000.0 - 1.1e-6, 4) == slice(0, 1)
    assert ind._window(big, 1000.0 + 1.9e-6, 2000.0, 4) == slice(1, 4)  # slack 2e-6 at b = 2000 s
    assert ind._window(big, 1000.0 + 2.1e-6, 2000.0, 4) == slice(2, 4)


@pytest.mark.parametrize("stat, window, expected", [
    ("max", ("start", "stop"), 9.0), ("min", ("start", "stop"), 3.0 - 0.25 / 6.0),
    ("max", ("after", "stop"), 7.0), ("min", (0.0, 2.5), 4.0),
    ("range", ("after", "stop"), 7.0 - (3.0 - 0.25 / 6.0)),
    ("amplitude", ("after", "stop"), 0.5 * (7.0 - (3.0 - 0.25 / 6.0))),
    ("abs_max", ("start", "stop"), 9.0),
    ("mean", ("after", "stop"), (4.0 + 5.0 + 7.0 + 5.0 + 3.0 + 4.0) / 6.0),
    ("rms", (3.0, 4.0), math.sqrt((25.0 + 49.0 + 25.0) / 3.0)),
    ("integral", (1.0, 2.0), 0.5 * (0.5 * (9.0 + 6.0) + 0.5 * (6.0 + 5.0))),
    ("integral", (1.0, 1.0), 0.0),
    ("max", (0.0, 1.5), 9.0), ("max", (0.0, 1.0), 9.0),  # the peak at the window's end: the sample
    ("min", (3.5, 4.25), 5.0),  # the window's own end, though the series falls further
    ("max", ("after", "after+0.25"), 4.0),
])
def test_statistics_of_n(stat, window, expected):
    rec = _rec()
    got = ind.statistic(rec, rec.get("ball.N"), stat, window, 11)
    assert type(got) is float
    assert got == pytest.approx(expected, rel=0, abs=1e-14)


def test_statistics_edge_cases():
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    rec = ind.Record(t, {}, "ball", None, 0.3, {"start": 0.0, "stop": 4.0})
    x = np.array([0.0, -5.0, 0.0, 2.0, 0.0])  # |min| > max
    assert ind.statistic(rec, x, "abs_max", ("start", "stop"), 5) == 5.0
    assert ind.statistic(rec, -x, "abs_max", ("start", "stop"), 5) == 5.0
    assert ind.statistic(rec, x, "abs_max", (2.0, 4.0), 5) == 2.0
    # an extremum at an interior sample of the window, refined with the samples beyond it
    y = np.array([0.0, 3.0, 4.0, 3.0, 0.0])
    assert ind.statistic(rec, y, "max", (1.0, 3.0), 5) == 4.0
    z = np.array([0.0, 3.0, 4.0, 2.0, 0.0])
    assert ind.statistic(rec, z, "max", (1.0, 3.0), 5) == pytest.approx(_vertex([1, 2, 3], [3, 4, 2]), abs=1e-14)
    assert ind.statistic(rec, -z, "min", (1.0, 3.0), 5) == pytest.approx(-_vertex([1, 2, 3], [3, 4, 2]), abs=1e-14)
    # ... but not when it sits at the window's edge, even inside the run
    assert ind.statistic(rec, z, "max", (2.0, 4.0), 5) == 4.0
    assert ind.statistic(rec, z, "max", (0.0, 2.0), 5) == 4.0
    assert ind.statistic(rec, z, "min", (0.0, 1.0), 5) == 0.0
    # one sample: its value for every extremum, zero for the integral
    for stat, v in (("max", 3.0), ("min", 3.0), ("range", 0.0), ("amplitude", 0.0), ("mean", 3.0),
                    ("rms", 3.0), ("integral", 0.0), ("abs_max", 3.0)):
        assert ind.statistic(rec, y, stat, (1.0, 1.0), 5) == v
    # trapezoids on uneven steps
    tu = np.array([0.0, 1.0, 3.0])
    ru = ind.Record(tu, {}, "ball", None, 0.3, {})
    assert ind.statistic(ru, np.array([2.0, 4.0, 0.0]), "integral", (0.0, 3.0), 3) == 3.0 + 4.0
    assert ind.statistic(ru, np.array([2.0, 4.0, 0.0]), "integral", (1.0, 3.0), 3) == 4.0
    # not reported over an invalid span or an empty window
    assert ind.statistic(rec, y, "max", (0.0, 4.0), 4) is None
    assert ind.statistic(rec, y, "mean", (2.5, 2.7), 5) is None
    with pytest.raises(ValueError) as e:
        ind.statistic(rec, y, "median", (0.0, 4.0), 5)
    assert str(e.value) == "unknown statistic 'median'"
    assert ind._stat(t, y, "median", None) is None


# ---------------------------------------------------------------------------- builtin and evaluate
def test_builtin_indicators_exact():
    rec = _rec()
    out = ind.builtin(rec, 11)
    assert list(out) == list(ind.BUILTIN)
    n_min_after = 3.0 - 0.25 / 6.0
    expected = {
        "N_max": 9.0, "N_range_after": 7.0 - n_min_after,
        "ring_inner": 0.5, "ring_outer": 1.0, "ring_width": 0.5,
        "theta_min_deg": 45.0, "theta_max_deg": math.degrees(math.atan(2.0)),
        "zP_max": 0.01, "friction_ratio_max": 0.2,
        "T_drive_peak": 8.0, "T_drive_rms": math.sqrt((1 + 36 + 1 + 64 + 1) / 11.0),
        # P_drive = 2 W over [0, 2.5] s
        "E_startup": 5.0,
    }
    for k, v in expected.items():
        assert out[k] == pytest.approx(v, rel=0, abs=1e-12), k
        assert type(out[k]) is float, k


def test_builtin_without_a_drive_or_its_torque():
    for rec in (_rec(drive=False), ind.Record(np.array(T11), _rec(drive=False).series, "ball", "drive", 0.3,
                                               {"start": 0.0, "stop": 5.0, "after": 2.5})):
        out = ind.builtin(rec, 11)
        assert list(out) == list(ind.BUILTIN)
        assert out["T_drive_peak"] is None and out["T_drive_rms"] is None and out["E_startup"] is None
        assert out["N_max"] == 9.0 and out["ring_width"] == 0.5


def test_builtin_windows_past_the_valid_span():
    rec = _rec()
    out = ind.builtin(rec, 6)  # valid up to and including "after"
    assert out["N_range_after"] is None and out["ring_inner"] is None and out["ring_outer"] is None
    assert out["ring_width"] is None and out["theta_min_deg"] is None and out["theta_max_deg"] is None
    assert out["N_max"] is None and out["zP_max"] is None and out["T_drive_peak"] is None
    assert out["E_startup"] == 5.0  # [start, after] is inside the valid span
    assert ind.builtin(rec, 5)["E_startup"] is None


def test_evaluate_orders_builtin_custom_validity():
    rec = _rec()
    custom = [Indicator("late_rms", "ball.N", "rms", (3.0, 4.0)),
              Indicator("rho_max", "ball.rhoP", "max", ("start", "after")),
              Indicator("n_int", "ball.N", "integral", ("after", "after+0.5"))]
    out = ind.evaluate(rec, custom)
    assert list(out) == list(ind.BUILTIN) + ["late_rms", "rho_max", "n_int", "valid", "t_invalid"]
    assert out["late_rms"] == pytest.approx(math.sqrt(99.0 / 3.0), abs=1e-14)
    assert out["rho_max"] == pytest.approx(1.0, abs=1e-15)
    assert out["n_int"] == pytest.approx(0.5 * (4.0 + 5.0) / 2.0, abs=1e-15)
    assert out["valid"] is True and out["t_invalid"] is None
    assert ind.evaluate(rec)["valid"] is True
    # the record's mu decides: |F_t|/N = 0.2 at 1.5 s
    low = _rec(mu=0.15)
    out = ind.evaluate(low, custom)
    assert out["valid"] is False and out["t_invalid"] == 1.5
    assert out["N_max"] is None and out["late_rms"] is None and out["rho_max"] is None
    # contact lost at 3.0 s: the windows up to 2.5 s still count
    n = _rec().series["ball.N"].copy()
    n[6] = 0.0
    lost = _rec(**{"ball.N": n})
    out = ind.evaluate(lost, custom)
    assert (out["valid"], out["t_invalid"]) == (False, 3.0)
    assert out["rho_max"] == pytest.approx(1.0, abs=1e-15)
    assert out["E_startup"] == 5.0 and out["n_int"] is None


@pytest.mark.parametrize("v, expected", [
    (None, None), (math.nan, None), (math.inf, None), (-math.inf, None), (3, 3.0), (-2.5, -2.5),
    (np.float64(1.25), 1.25), (np.int64(4), 4.0), (0.0, 0.0),
])
def test_clean(v, expected):
    got = ind.clean(v)
    assert got == expected
    if expected is not None:
        assert type(got) is float
