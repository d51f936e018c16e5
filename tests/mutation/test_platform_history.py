"""The input reconstruction's history and resolution rules at their edges
(ballmill.physics.platform, module docstring and docs/conformance.md "reconstruction"):
the constructor's defaults and refusals word for word; a sample replaced at the same
time is checked against the one before it; every mode keeps close samples; the node
choice takes an older sample exactly h/2 before; the fit's data switch exactly at
6 ulp(X) / w^2 = 1e-6 m/s2 and 4 ulp(V) / w = 1e-6 m/s2; a restored state's samples are
checked by the subclass's own rule. Written for mutants the rest of the suite let through
(docs/mutation.md)."""
from __future__ import annotations

import math

import pytest

from ballmill.physics import InputReconstruction
from ballmill.physics.platform import A_RES, ulp
from ballmill.physics.turning.reconstruction import ChamberReconstruction


@pytest.fixture
def fresh(monkeypatch):
    """Empty caches of inverses, so that this test computes them (docs/mutation.md)."""
    monkeypatch.setattr(InputReconstruction, "_ROWS", {})
    monkeypatch.setattr(InputReconstruction, "_INVERSES", {})


# -- constructor ------------------------------------------------------------------------
def test_the_defaults():
    rec = InputReconstruction()
    assert (rec.mode, rec.points, rec.a_tol) == ("derivatives", 2, 0.01)
    assert rec.dropped is None and rec.samples == [] and rec.h_next == 0.0
    assert InputReconstruction("positions").points == 6
    assert InputReconstruction("accelerations", points=3, a_tol=1e-300).a_tol == 1e-300


@pytest.mark.parametrize("a_tol", [0.0, -0.0, -1.0, -math.inf, math.inf, math.nan])
def test_an_a_tol_that_is_not_positive_and_finite_is_refused(a_tol):
    with pytest.raises(ValueError) as info:
        InputReconstruction("derivatives", a_tol=a_tol)
    assert str(info.value) == f"a_tol must be positive and finite, got {a_tol!r} m/s2"


# -- a second sample at the same time ----------------------------------------------------------
def accelerating(t, d=0.0):
    """x = 1.5 t^2 (a = 3 m/s2) with d added to the position, y at rest."""
    return (t, 1.5 * t * t + d, 0.0, 3.0 * t, 0.0, 3.0, 0.0)


MESSAGE = ("inputs x1O, vx1O, ax1O disagree between t = {p} s (x1O = {xp} m, vx1O = {vp} m/s, "
           "ax1O = 3.0 m/s2) and t = {q} s (x1O = {xq} m, vx1O = {vq} m/s, ax1O = 3.0 m/s2): position "
           "residual 0.0625 m, accepted |r| <= 0.0325 m (input_tol = 0.75 m/s2 + 0.01 |a| of acceleration)")


def test_a_replaced_sample_is_checked_against_the_one_before_it():
    """The residual of x = 1.5 t^2 + d against the sample 0.5 s before is d (a quadratic has
    r = 0); the bound is (0.75 + 0.03) 0.5^2 / 6 = 0.0325 m, so d = 0.0625 m is flagged (not
    a jump: 6 d / H^2 = 1.5 < 3.75 m/s2) and the history keeps the replaced sample."""
    rec = InputReconstruction("derivatives", a_tol=0.75)
    assert rec.push(*accelerating(0.0)) is None and rec.push(*accelerating(0.5)) is None
    assert rec.push(*accelerating(0.5, 0.0625)) == MESSAGE.format(p=0.0, xp=0.0, vp=0.0, q=0.5, xq=0.4375,
                                                                   vq=1.5)
    assert rec.samples == [accelerating(0.0), accelerating(0.5, 0.0625)]
    assert rec.push(*accelerating(0.5)) is None  # replaced again by a consistent one
    assert rec.samples == [accelerating(0.0), accelerating(0.5)]
    assert rec.push(*accelerating(1.0)) is None
    assert rec.push(*accelerating(1.0, 0.0625)) == MESSAGE.format(p=0.5, xp=0.375, vp=1.5, q=1.0,
                                                                   xq=1.5625, vq=3.0)
    assert rec.samples == [accelerating(0.0), accelerating(0.5), accelerating(1.0, 0.0625)]
    # a jump (6 d / H^2 = 24 m/s2 > 3.75 m/s2) on a replacement restarts the history there
    assert rec.push(*accelerating(1.0, 1.0)).endswith("; the reconstruction restarts at the newer sample")
    assert rec.samples == [accelerating(1.0, 1.0)]
    assert rec.push(*accelerating(1.0, 5.0)) is None  # nothing before it: nothing to check
    assert rec.samples == [accelerating(1.0, 5.0)]


# -- every mode keeps close samples, positions far from the origin included ---------------------
@pytest.mark.parametrize("mode", ["derivatives", "positions", "hold", "accelerations"])
@pytest.mark.parametrize("x", [0.0, 1e6])
def test_every_mode_keeps_close_samples(mode, x):
    """No sample leaves the history for being close to its predecessor, whatever the
    positions' magnitude (removing those closer than sqrt(187 ulp(X) / 1e-6 m/s2), 0.2 s at
    1e6 m, would widen mode "positions"' window to a second: platform.py's docstring)."""
    rec = InputReconstruction(mode, a_tol=1e300)
    for t in (10.0, 10.1, 10.10001, 10.2, 10.20001, 10.3):
        rec.push(t, x, 0.0)
    assert [s[0] for s in rec.samples] == [10.0, 10.1, 10.10001, 10.2, 10.20001, 10.3], mode


# -- node choice ----------------------------------------------------------------------------
def test_a_node_exactly_half_a_step_back_is_taken():
    rec = InputReconstruction("derivatives", points=2)
    for t in (0.0, 0.5, 1.0):
        rec.push(t, 0.0, 0.0)
    rec.set_horizon(1.0)
    assert [n[0] for n in rec.nodes()] == [0.5, 1.0]
    assert rec.window() == [0.5, 1.0]
    rec.set_horizon(math.nextafter(1.0, 2.0))
    assert [n[0] for n in rec.nodes()] == [0.0, 1.0]
    assert rec.window() == [0.0, 0.5, 1.0]


# -- the fit's data at the resolution thresholds -----------------------------------------------
def test_positions_are_used_up_to_exactly_the_resolution_threshold(fresh):
    """w = 1 s: 6 ulp(X) / w^2 equals 1e-6 m/s2 for X = 750599937.8950826 m: positions are used
    (dropped None); 1e-7 relatively larger they are left out (dropped = (X, w))."""
    X = 750599937.8950826
    assert 6.0 * ulp(X) / (1.0 * 1.0) == A_RES
    for x, dropped in ((X, None), (X * (1 + 1e-7), (X * (1 + 1e-7), 1.0))):
        rec = InputReconstruction("derivatives", a_tol=1e300)
        rec.push(0.0, x, -1.0, 0.0, 0.0, 0.0, 0.0)
        rec.push(1.0, x, -1.0, 0.0, 0.0, 0.0, 0.0)
        rec.set_horizon(1.0)
        assert rec.accel(1.5) == pytest.approx((0.0, 0.0), abs=1e-6)
        assert rec.dropped == dropped


def test_velocities_are_used_up_to_exactly_the_resolution_threshold(fresh):
    """Positions left out (X = 1e9 m over w = 1 s), |v| up to V = 1125899906.842624 m/s where
    4 ulp(V) / w equals 1e-6 m/s2: the fit takes v at both nodes ("va", a quartic in
    tau = t - 1 s). With a = 0 at both nodes and v rising by 6 m/s the quartic has
    c4 = (v0 - v1) / 2 = -3, c3 = 2 c4, c2 = 0: a(tau) = -36 tau - 36 tau^2, -27 m/s2 at
    t = 1.5 s. Beyond V the older velocity is left out too ("a": a cubic, a = 0)."""
    V = 1125899906.842624
    assert 4.0 * ulp(V) / 1.0 == A_RES
    for v1, want in ((V, -27.0), (V * (1 + 1e-7), 0.0)):
        rec = InputReconstruction("derivatives", a_tol=1e300)
        rec.push(0.0, 1e9, 0.0, v1 - 6.0, 0.0, 0.0, 0.0)
        rec.push(1.0, 1e9, 0.0, v1, 0.0, 0.0, 0.0)
        rec.set_horizon(1.0)
        ax, ay = rec.accel(1.5)
        assert ax == pytest.approx(want, abs=1e-5) and ay == 0.0
        assert rec.accel(1.0)[0] == pytest.approx(0.0, abs=1e-5)
        assert rec.dropped == (1e9, 1.0)


# -- a restored state: the subclass's sample check -------------------------------------------
@pytest.mark.parametrize("q, problem", [
    ((1.5, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
     "input Q is not a rotation matrix: row 1 . row 1 = 2.25, expected 1.0 within 1e-06 "
     "(Q11 = 1.5, Q12 = 0.0, Q13 = 0.0)"),
    ((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0),
     "input Q is not a rotation matrix: det Q = -1.0, expected +1 (a reflection)"),
])
def test_a_restored_sample_is_checked_by_the_subclass_rule(q, problem):
    rec = ChamberReconstruction("derivatives")
    good = [0.25, 7.0] + [0.0] * 14 + [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    rec.set_state({"mode": "derivatives", "points": 2, "samples": [good]})
    before = list(rec.samples)
    bad = [0.5, 7.0] + [0.0] * 14 + list(q)
    with pytest.raises(ValueError) as info:
        rec.set_state({"mode": "derivatives", "points": 2, "samples": [good, bad]})
    assert str(info.value) == f"input sample at t = 0.5 s: {problem}"
    assert rec.samples == before
