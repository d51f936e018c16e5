"""The input reconstruction's consistency check and state restore (ballmill.physics.platform,
docs/conformance.md "reconstruction"), at their thresholds and word for word. Written for
the mutants of the input reconstruction's rework that the rest of the suite let through (docs/mutation.md).

The residual r = x_q - x_p - H (v_p + v_q)/2 + H^2 (a_q - a_p)/12 vanishes for any motion
of degree <= 4 (the Euler-Maclaurin corrected trapezoidal rule), so a quartic plus an offset
d of the newer position has r = d exactly, and the accepted bound is
(a_tol + 0.01 |a|) H^2 / 6 + 8 ulp(max |x|)."""
from __future__ import annotations

import math

import pytest

from ballmill.physics import InputReconstruction
from ballmill.physics.errors import InputError
from ballmill.physics.platform import HISTORY_EXTRA

H = 0.5


def quartic(t, c=(0.0, 0.25, 0.5, 1.0, 0.125)):
    """(x, v, a) of x = c0 + c1 t + ... + c4 t^4."""
    x = sum(ci * t ** i for i, ci in enumerate(c))
    v = sum(i * ci * t ** (i - 1) for i, ci in enumerate(c) if i >= 1)
    a = sum(i * (i - 1) * ci * t ** (i - 2) for i, ci in enumerate(c) if i >= 2)
    return x, v, a


def sample(t, x=(0.0, 0.0, 0.0), y=(0.0, 0.0, 0.0), dx=0.0, dy=0.0):
    """(t, x, y, vx, vy, ax, ay) with offsets dx, dy on the positions."""
    return (t, x[0] + dx, y[0] + dy, x[1], y[1], x[2], y[2])


def test_a_quartic_motion_is_consistent():
    rec = InputReconstruction("derivatives", a_tol=1e-9)
    assert rec.inconsistency(sample(0.0, quartic(0.0), quartic(0.0, (1, 2, 3, 4, 5))),
                             sample(H, quartic(H), quartic(H, (1, 2, 3, 4, 5)))) is None
    assert rec._jump is False


def accelerating(t, d=0.0, a=3.0):
    """x = a t^2 / 2 (+ d on the position), y at rest."""
    return (t, 0.5 * a * t * t + d, 0.0, a * t, 0.0, a, 0.0)


def test_the_threshold_at_rest_to_the_last_ulp():
    """a = 0: accepted |r| <= a_tol H^2 / 6 + 8 ulp(max |x|): with a_tol = 0.75 and H = 0.5
    the first part is 2^-5 and an ulp there u = 2^-57, so r = 2^-5 + 8 u is the bound itself."""
    rec = InputReconstruction("derivatives", a_tol=0.75)
    bound, u = 2.0 ** -5, 2.0 ** -57
    p = sample(0.0)
    for r in (bound, -bound, bound + 8 * u, -(bound + 8 * u)):
        assert rec.inconsistency(p, sample(H, dx=r)) is None, r
        assert rec.inconsistency(p, sample(H, dy=r)) is None, r
    assert rec.inconsistency(p, sample(H, dx=bound + 9 * u)).startswith("inputs x1O, vx1O, ax1O disagree")
    assert rec.inconsistency(p, sample(H, dy=-bound - 9 * u)).startswith("inputs y1O, vy1O, ay1O disagree")


def test_the_message_word_for_word():
    rec = InputReconstruction("derivatives", a_tol=0.75)
    assert rec.inconsistency(accelerating(0.0), accelerating(H, 0.0625)) == (
        "inputs x1O, vx1O, ax1O disagree between t = 0.0 s (x1O = 0.0 m, vx1O = 0.0 m/s, ax1O = 3.0 m/s2) "
        "and t = 0.5 s (x1O = 0.4375 m, vx1O = 1.5 m/s, ax1O = 3.0 m/s2): position residual 0.0625 m, "
        "accepted |r| <= 0.0325 m (input_tol = 0.75 m/s2 + 0.01 |a| of acceleration)")
    assert rec._jump is False  # 6 r / H^2 = 1.5 m/s2 < a_tol + |a| = 3.75 m/s2
    # every value of both samples is named with its own name, on the y axis too
    p = (1.0, 0.5, -0.25, 2.0, -3.0, 0.125, 0.0625)
    q = (1.5, 0.5 + 1.0, -0.25 - 1.5 + 4.0, 2.0, -3.0, 0.125, 0.0625)
    msg = InputReconstruction("derivatives", a_tol=1e-9).inconsistency(p, q)
    assert ("inputs y1O, vy1O, ay1O disagree between t = 1.0 s (y1O = -0.25 m, vy1O = -3.0 m/s, "
            "ay1O = 0.0625 m/s2) and t = 1.5 s (y1O = 2.25 m, vy1O = -3.0 m/s, ay1O = 0.0625 m/s2)") in msg


def test_the_acceleration_widens_the_threshold_by_one_percent_of_the_larger_magnitude():
    """x = j t^3 / 6 (a cubic: r = 0) with a_x from 0 to j H, and y = 3.5 t^2: the bound uses
    |a| of both axes (hypot) of whichever sample has the larger one."""
    a_tol = 0.5
    for j in (48.0, -48.0):
        a_mag = math.hypot(j * H, 7.0)  # 25
        bound = (a_tol + 0.01 * a_mag) * H * H / 6.0

        def newer(t, d):  # |a| largest on the newer sample
            return (t, j * t ** 3 / 6.0 + d, 3.5 * t * t, j * t * t / 2.0, 7.0 * t, j * t, 7.0)

        def older(t, d):  # |a| largest on the older sample
            s = H - t
            return (t, -j * s ** 3 / 6.0 + d, 3.5 * t * t, j * s * s / 2.0, 7.0 * t, -j * s, 7.0)
        rec = InputReconstruction("derivatives", a_tol=a_tol)
        for smp in (newer, older):
            assert rec.inconsistency(smp(0.0, 0.0), smp(H, 0.0)) is None
            assert rec.inconsistency(smp(0.0, 0.0), smp(H, 0.999 * bound)) is None
            assert rec.inconsistency(smp(0.0, 0.0), smp(H, 1.001 * bound)) is not None
            assert rec.inconsistency(smp(0.0, 0.0), smp(H, -1.001 * bound)) is not None


def test_the_worse_axis_is_reported():
    rec = InputReconstruction("derivatives", a_tol=0.75)
    p = sample(0.0)
    assert "inputs y1O" in rec.inconsistency(p, sample(H, dx=0.04, dy=0.05))
    assert "inputs x1O" in rec.inconsistency(p, sample(H, dx=0.05, dy=0.04))
    assert "inputs x1O" in rec.inconsistency(p, sample(H, dx=0.05, dy=0.05))  # a tie: the first
    assert "residual -0.05 m" in rec.inconsistency(p, sample(H, dx=0.04, dy=-0.05))


def test_a_jump_restarts_the_history_and_says_so():
    """A jump: 6 |r| / H^2 > a_tol + |a| (here 0.75 + 3 m/s2, r > 0.15625 m)."""
    rec = InputReconstruction("derivatives", a_tol=0.75)
    r = (0.75 + 3.0) * H * H / 6.0
    below = rec.inconsistency(accelerating(0.0), accelerating(H, 0.99 * r))
    assert below.endswith("of acceleration)") and rec._jump is False
    # exactly at the edge (6 r / H^2 = 3.75 m/s2, all exact in binary): not a jump
    assert r == 0.15625
    assert rec.inconsistency(accelerating(0.0), accelerating(H, r)).endswith("of acceleration)")
    assert rec._jump is False
    above = rec.inconsistency(accelerating(0.0), accelerating(H, 1.01 * r))
    assert above.endswith("of acceleration); the reconstruction restarts at the newer sample")
    assert rec._jump is True
    assert rec.inconsistency(accelerating(0.0), accelerating(H, -1.01 * r)).endswith("at the newer sample")
    # at rest every flagged inconsistency is a jump
    assert "restarts" in rec.inconsistency(sample(0.0), sample(H, dx=0.04))
    # push: a jump keeps only the newer sample, a smaller inconsistency keeps the history
    rec = InputReconstruction("derivatives", a_tol=0.75)
    assert rec.push(*accelerating(0.0)) is None
    assert rec.push(*accelerating(H, 0.0625)) is not None and len(rec.samples) == 2
    assert rec.push(*accelerating(2 * H, 0.0625 + 0.25)) is not None
    assert rec.samples == [accelerating(2 * H, 0.3125)]
    assert rec.push(*accelerating(3 * H, 0.3125)) is None and rec._jump is False


def test_a_flag_is_cleared_by_a_consistent_pair():
    rec = InputReconstruction("derivatives", a_tol=0.75)
    assert "restarts" in rec.inconsistency(sample(0.0), sample(H, dx=1.0))
    assert rec._jump is True
    assert rec.inconsistency(sample(0.0), sample(H)) is None
    assert rec._jump is False


# -- state restore ------------------------------------------------------------------------
def _filled(n=4):
    """x = t^2 / 2 + t, y = t: n samples 0.1 s apart."""
    rec = InputReconstruction("derivatives")
    for k in range(n):
        t = 0.1 * k
        rec.push(t, 0.5 * t * t + t, t, t + 1.0, 1.0, 1.0, 0.0)
    return rec


def test_a_state_round_trip_gives_the_same_fit():
    a = _filled()
    a.set_horizon(0.1)
    b = InputReconstruction("derivatives")
    b.push(5.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0)
    b.set_horizon(0.1)
    b.accel(5.0)  # a fit of b's own samples, to be replaced
    b.set_state(a.get_state())
    for t in (0.3, 0.35, 0.4):
        assert b.accel(t) == a.accel(t)
        assert b.state(t) == a.state(t)
    assert b.samples == a.samples and all(type(s) is tuple for s in b.samples)


@pytest.mark.parametrize("edit, message", [
    (lambda s: s.update(mode="positions"),
     "input reconstruction state for mode 'positions' with 2 points, expected 'derivatives' with 2"),
    (lambda s: s.update(points=3),
     "input reconstruction state for mode 'derivatives' with 3 points, expected 'derivatives' with 2"),
    (lambda s: s.update(samples=[]), f"input history of 0 samples, expected 1 to {2 + HISTORY_EXTRA}"),
    (lambda s: s.update(samples=[[0.01 * k] + [0.0] * 6 for k in range(2 + HISTORY_EXTRA + 1)]),
     f"input history of {3 + HISTORY_EXTRA} samples, expected 1 to {2 + HISTORY_EXTRA}"),
    (lambda s: s["samples"][1].pop(), "input sample (0.1, 0.10500000000000001, 0.1, 1.1, 1.0, 1.0): "
                                      "expected 7 finite values"),
    (lambda s: s["samples"][1].__setitem__(3, math.inf), "expected 7 finite values"),
    (lambda s: s["samples"][1].__setitem__(0, math.nan), "expected 7 finite values"),
    (lambda s: s["samples"][2].__setitem__(0, 0.1), "input samples are not in increasing time order"),
    (lambda s: s["samples"][2].__setitem__(0, 0.05), "input samples are not in increasing time order"),
])
def test_a_state_that_does_not_fit_is_refused_state_kept(edit, message):
    a = _filled()
    state = a.get_state()
    edit(state)
    b = _filled(n=2)
    before = (list(b.samples), b.accel(0.1))
    with pytest.raises(ValueError) as info:
        b.set_state(state)
    assert message in str(info.value)
    if message == "input samples are not in increasing time order":
        assert str(info.value) == message
    assert (b.samples, b.accel(0.1)) == before


@pytest.mark.parametrize("n", [1, 2 + HISTORY_EXTRA])
def test_a_state_of_one_or_of_the_most_samples_is_taken(n):
    b = InputReconstruction("derivatives")
    b.set_state({"mode": "derivatives", "points": 2,
                 "samples": [[0.01 * k, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0] for k in range(n)]})
    assert len(b.samples) == n


def test_two_samples_at_one_time_are_refused_by_the_fit():
    with pytest.raises(InputError) as info:
        InputReconstruction._inverse(((0, 0.0), (0, 0.0)))
    assert str(info.value) == ("the input samples do not determine the reconstruction "
                               "(two samples at the same time?)")


# -- the fit's paths: exact on the polynomials each one is built for ---------------------
@pytest.fixture
def fresh(monkeypatch):
    """Empty caches of inverses, so that this test computes them (docs/mutation.md)."""
    monkeypatch.setattr(InputReconstruction, "_ROWS", {})
    monkeypatch.setattr(InputReconstruction, "_INVERSES", {})


def poly(c, t):
    """(x, v, a) of sum c_i t^i."""
    x = sum(ci * t ** i for i, ci in enumerate(c))
    v = sum(i * ci * t ** (i - 1) for i, ci in enumerate(c) if i)
    a = sum(i * (i - 1) * ci * t ** (i - 2) for i, ci in enumerate(c) if i > 1)
    return x, v, a


@pytest.mark.parametrize("X", [0.0, 1e6])
def test_the_fit_with_or_without_positions_reproduces_a_quartic(fresh, X):
    """Mode "derivatives", two nodes 0.01 s apart: at |x| ~ 1 the fit takes x, v, a at both
    (a quintic); at |x| ~ 1e6 the positions' round-off (6 ulp(X) / w^2 = 1.3e-5 m/s2) is above
    1e-6 m/s2 and the older position is left out ("va": a quartic). Both reproduce a quartic
    motion's acceleration, and `dropped` says which was used."""
    cx, cy = (X, 0.5, 2.0, -3.0, 4.0), (-X, 0.25, -1.0, 2.0, 1.5)
    rec = InputReconstruction("derivatives", a_tol=1e3)
    t0, t1 = 10.0, 10.01
    for t in (t0, t1):
        (x, vx, ax), (y, vy, ay) = poly(cx, t - t0), poly(cy, t - t0)
        rec.push(t, x, y, vx, vy, ax, ay)
    rec.set_horizon(0.01)
    for t in (t1, t1 + 0.005, t1 + 0.01):
        want = (poly(cx, t - t0)[2], poly(cy, t - t0)[2])
        got = rec.accel(t)
        assert abs(got[0] - want[0]) < 1e-7 and abs(got[1] - want[1]) < 1e-7, (t, got, want)
    if X:
        assert rec.dropped == (max(abs(v) for smp in rec.nodes() for v in smp[1:3]), t1 - t0)
    else:
        assert rec.dropped is None


def test_only_accelerations_when_velocities_are_unresolved_too(fresh):
    """|v| ~ 1e12 over 1 ms: 4 ulp(V) / w = 1e-3 m/s2 > 1e-6: kind "a" (a at both nodes, x and v
    at the newest): a cubic's acceleration is a line through the two samples' a."""
    rec = InputReconstruction("derivatives", a_tol=1e30)
    V = 1e12
    rec.push(0.0, 1.0, 2.0, V, -V, 3.0, -1.0)
    rec.push(1e-3, 1.0 + V * 1e-3, 2.0 - V * 1e-3, V, -V, 5.0, 1.0)
    rec.set_horizon(1e-3)
    for t, want in ((1e-3, (5.0, 1.0)), (1.5e-3, (6.0, 2.0)), (2e-3, (7.0, 3.0))):
        got = rec.accel(t)
        assert got[0] == pytest.approx(want[0], abs=1e-9) and got[1] == pytest.approx(want[1], abs=1e-9)
    assert rec.dropped[1] == 1e-3


def test_the_accelerations_mode_interpolates_the_measured_accelerations(fresh):
    """Positions and velocities that disagree with a are not used: a(t) is the line through
    the last two samples' a."""
    rec = InputReconstruction("accelerations")
    rec.push(0.0, 0.3, -0.2, 0.0, 0.0, 1.0, -2.0)
    rec.push(0.5, 0.0, 0.0, 0.0, 0.0, 2.0, -1.0)
    rec.set_horizon(0.5)
    assert rec.accel(0.25) == pytest.approx((1.5, -1.5), abs=1e-12)
    assert rec.accel(1.0) == pytest.approx((3.0, 0.0), abs=1e-12)
    assert rec.dropped is None


def test_hold_with_more_points_still_holds(fresh):
    rec = InputReconstruction("hold", points=3)
    for k, a in enumerate((1.0, 2.0, 4.0)):
        rec.push(0.1 * k, 0.1 * k, 0.0, 1.0, 0.0, a, -a)
    rec.set_horizon(0.1)
    for t in (0.2, 0.25, 0.3):
        assert rec.accel(t) == (4.0, -4.0)
    assert rec.state(0.3)[:2] == pytest.approx((0.2 + 0.1 + 0.5 * 4.0 * 0.01, -0.5 * 4.0 * 0.01), abs=1e-15)


def test_a_new_horizon_refits_with_its_nodes(fresh):
    """Samples at 0, 0.9 and 1 s of x = t^6 (not reproduced by a quintic): for h = 0.1 s the
    fit uses the nodes 0.9 and 1 s, for h = 1 s the nodes 0 and 1 s."""
    def push_all(rec):
        for t in (0.0, 0.9, 1.0):
            rec.push(t, t ** 6, 0.0, 6 * t ** 5, 0.0, 30 * t ** 4, 0.0)
    a = InputReconstruction("derivatives", a_tol=1e6)
    push_all(a)
    a.set_horizon(0.1)
    near = a.accel(1.05)
    assert [n[0] for n in a.nodes()] == [0.9, 1.0]
    a.set_horizon(1.0)
    far = a.accel(1.05)
    assert [n[0] for n in a.nodes()] == [0.0, 1.0]
    b = InputReconstruction("derivatives", a_tol=1e6)
    push_all(b)
    b.set_horizon(1.0)
    assert far == b.accel(1.05) and far != near
    a.set_horizon(1.0)  # the same horizon again: the same fit
    assert a.accel(1.05) == far


def test_ulp_is_relative_with_a_floor():
    from ballmill.physics.platform import ulp
    assert ulp(1.0) == 2.0 ** -52 and ulp(-8.0) == 2.0 ** -49 and ulp(0.0) == 2.0 ** -52 * 1e-300


def _kind(w, x=0.0, y=0.0, vx=0.0, vy=0.0, ax=0.0, ay=0.0):
    """The data a derivatives fit through two samples w apart takes (the resolution rule of
    the module docstring), read from the fresh cache of inverses: "xva", "va" or "a"."""
    rec = InputReconstruction("derivatives", a_tol=1e300)
    rec.push(0.0, x, y, vx, vy, ax, ay)
    rec.push(w, x, y, vx, vy, ax, ay)
    rec.set_horizon(w)
    rec.accel(w)
    (kind,) = {k[0] for k in InputReconstruction._ROWS}
    return kind, rec.dropped


@pytest.mark.parametrize("w, values, kind", [
    # positions: 6 ulp(X) / w^2 <= 1e-6 m/s2, X = 2^20 m (ulp 2^-32): w >= 0.0374 s
    (0.039, {"x": 2.0 ** 20}, "xva"),
    (0.037, {"x": 2.0 ** 20}, "va"),
    (0.037, {"y": -2.0 ** 20}, "va"),
    (0.037, {"vx": 1e6, "vy": -1e6, "ax": 1e9, "ay": 1e9}, "xva"),  # X is of x and y only
    # velocities: 4 ulp(V) / w <= 1e-6 m/s2, V = 2^30 m/s (ulp 2^-22): w >= 0.95 s
    (0.037, {"x": 2.0 ** 20, "vx": 2.0 ** 30}, "a"),
    (0.037, {"x": 2.0 ** 20, "vy": 2.0 ** 30}, "a"),
    (0.037, {"x": 2.0 ** 20, "ax": 2.0 ** 40, "ay": 2.0 ** 40}, "va"),  # V is of vx and vy only
    (1.0, {"x": 2.0 ** 30, "vx": 2.0 ** 30}, "va"),
    (0.9, {"x": 2.0 ** 30, "vx": 2.0 ** 30}, "a"),
])
def test_the_resolution_rule_chooses_the_data(fresh, w, values, kind):
    got, dropped = _kind(w, **values)
    assert got == kind
    if kind == "xva":
        assert dropped is None
    else:
        assert dropped == (max(abs(values.get("x", 0.0)), abs(values.get("y", 0.0))), w)
