"""InputReconstruction: the platform's acceleration between communication
points, rebuilt from samples. Orders of the extrapolation error, and bad
samples refused without damage."""
import math

import numpy as np
import pytest

from ballmill.physics import CrankStartup, InputError, InputReconstruction

CRANK = CrankStartup(t0=2.5)  # paper's fast start; steady circle after 2.5 s


def extrapolation_error(mode, H, t_points=np.arange(3.0, 4.0, 0.1)):
    """Largest error of the extrapolated acceleration over [t_k, t_k + H], for
    communication points t_k in the steady part; the reconstruction has seen
    the samples at t_k, t_k - H, ... (as many as it keeps)."""
    worst = 0.0
    for tk in t_points:
        rec = InputReconstruction(mode)
        for j in range(rec.points + 2, -1, -1):  # a few more than it keeps: oldest dropped
            t = tk - j * H
            rec.push(t, *CRANK.state(t))
        rec.prepare()
        for s in np.linspace(0.0, 1.0, 9)[1:]:
            t = tk + s * H
            a_true = np.array(CRANK.state(t)[4:])
            a_rec = np.array(rec.accel(t))
            worst = max(worst, np.abs(a_rec - a_true).max())
            # state() (which prepares itself) agrees with accel()
            assert rec.state(t)[4:] == pytest.approx(tuple(a_rec), rel=1e-12, abs=1e-12)
    return worst


@pytest.mark.parametrize("mode,order,window", [
    ("derivatives", 4, (10.0, 22.0)),  # quintic Hermite through (x, v, a) at 2 points
    ("positions", 4, (10.0, 22.0)),    # quintic through 6 positions
    ("hold", 1, (1.6, 2.5)),           # zero-order hold of a
])
def test_extrapolation_order(mode, order, window):
    Hs = [0.04, 0.02, 0.01]
    errs = [extrapolation_error(mode, H) for H in Hs]
    ratios = [errs[i] / errs[i + 1] for i in range(len(errs) - 1)]
    # the acceleration is ~20 m/s2 (l w0^2); the errors (derivatives 1.4e-2 ..
    # 5.6e-5, positions 0.35 .. 1.4e-3, hold 4.9 .. 1.2 m/s2) are far above
    # round-off (positions mode: eps x / H^2 x Lebesgue constant ~1e-10 m/s2),
    # so the ratio of the errors when H halves is 2^order (measured 16.0, 15.8, 2.0)
    lo, hi = window
    for r in ratios:
        assert lo < r < hi, (mode, errs, ratios)
    assert errs[-1] > 1e-9


def test_positions_mode_needs_enough_samples():
    # with only two samples the positions fit is a straight line: a = 0,
    # the full centripetal acceleration (l w0^2 = 19.7 m/s2) is missed
    rec = InputReconstruction("positions")
    H = 0.01
    for t in (3.0 - H, 3.0):
        rec.push(t, *CRANK.state(t)[:2])
    rec.prepare()
    a_true = np.array(CRANK.state(3.0)[4:])
    assert np.linalg.norm(np.array(rec.accel(3.0 + H)) - a_true) > 10.0
    # with six it is accurate to O(H^4): 1.3e-3 m/s2 here (7e-5 relative)
    for t in 3.0 + H * np.arange(1, 5):
        rec.push(t, *CRANK.state(t)[:2])
    rec.prepare()
    t_end = 3.0 + 4 * H
    assert np.abs(np.array(rec.accel(t_end + H)) - CRANK.state(t_end + H)[4:]).max() < 5e-3


def test_derivatives_mode_exact_for_quintic():
    # a polynomial of degree 5 in x is reproduced exactly (to round-off) from
    # two samples with (x, v, a): the fit is that quintic
    c = [0.1, -0.3, 0.7, 0.2, -0.05, 0.01]

    def motion(t):
        x = sum(ck * t**k for k, ck in enumerate(c))
        v = sum(k * ck * t ** (k - 1) for k, ck in enumerate(c) if k)
        a = sum(k * (k - 1) * ck * t ** (k - 2) for k, ck in enumerate(c) if k > 1)
        return x, -x, v, -v, a, -a
    rec = InputReconstruction("derivatives")
    rec.push(0.9, *motion(0.9))
    rec.push(1.0, *motion(1.0))
    rec.prepare()
    for t in (1.0, 1.05, 1.1):
        assert rec.accel(t) == pytest.approx(motion(t)[4:], rel=1e-10, abs=1e-10)


@pytest.mark.parametrize("mode", ["derivatives", "positions", "hold"])
@pytest.mark.parametrize("bad", ["x", "y", "vx", "vy", "ax", "ay", "t"])
def test_non_finite_sample_refused_without_damage(mode, bad):
    rec = InputReconstruction(mode)
    for t in (3.0, 3.01, 3.02):
        rec.push(t, *CRANK.state(t))
    rec.prepare()
    before = list(rec.samples)
    a_before = rec.accel(3.025)
    values = dict(zip(("t", "x", "y", "vx", "vy", "ax", "ay"), (3.03, *CRANK.state(3.03))))
    values[bad] = math.nan if bad != "ay" else math.inf
    with pytest.raises(InputError) as exc:
        rec.push(values["t"], values["x"], values["y"], values["vx"], values["vy"],
                 values["ax"], values["ay"])
    assert "finite" in str(exc.value)
    assert rec.samples == before
    rec.prepare()
    assert rec.accel(3.025) == a_before  # same fit, to the bit


def test_samples_out_of_time_order_refused():
    rec = InputReconstruction("derivatives")
    rec.push(1.0, *CRANK.state(1.0))
    before = list(rec.samples)
    with pytest.raises(InputError, match="time order"):
        rec.push(0.5, *CRANK.state(0.5))
    assert rec.samples == before


def test_state_roundtrip_and_bad_mode():
    rec = InputReconstruction("positions")
    for t in np.arange(3.0, 3.07, 0.01):
        rec.push(t, *CRANK.state(t)[:2])
    assert len(rec.nodes()) == 6  # the fit uses six of them
    other = InputReconstruction("positions")
    other.set_state(rec.get_state())
    assert other.state(3.08) == rec.state(3.08)
    with pytest.raises(ValueError, match="mode"):
        InputReconstruction("spline")
    with pytest.raises(InputError, match="no platform sample"):
        InputReconstruction().prepare()
