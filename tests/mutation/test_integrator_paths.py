"""The integrator's two step functions, the input reconstruction's fits, and the state
they carry, each built afresh (with empty caches) and checked against an independent one.

`Integrator` steps small systems with scalar kernels generated from the tableau (cached per
method and dimension in ``integrators._KERNELS``) and larger ones with numpy; both follow
one contract and the same arithmetic up to summation order, so on the same problem they
take the same steps (counts exact) to the same states (to round-off). The moving chamber
makes the right-hand side time-dependent, so every stage time counts. InputReconstruction
caches the inverses of its constraint matrices; a fit from empty caches must reproduce a
motion that its polynomial can represent exactly.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, CrankStartup, InputReconstruction, Integrator
from ballmill.physics import integrators as _integ
from ballmill.physics.platform import HISTORY_EXTRA

BALL = Ball()
CRANK = CrankStartup(l=0.5, n0=60.0, t0=2.5)


@pytest.fixture
def fresh(monkeypatch):
    """Empty caches: kernels are generated and inverses computed within the test."""
    monkeypatch.setattr(_integ, "_KERNELS", {})
    monkeypatch.setattr(InputReconstruction, "_ROWS", {})
    monkeypatch.setattr(InputReconstruction, "_INVERSES", {})
    return monkeypatch


def run(method, numpy_path, monkeypatch, scaled=True, tol=1e-7, t_end=3.0):
    """The ball under the crank law (through its kink at t0) from an off-centre start."""
    monkeypatch.setattr(_integ, "SMALL_SYSTEM", -1 if numpy_path else 16)
    m = BallModel(BALL, method=method, tol=tol, h_fixed=5e-3, kernel="python")
    if not scaled:
        m.integrator.scale = None
    s = m.initial(xC0=0.05, yC0=0.02, w0=(1.0, -2.0, 3.0))
    for t in np.arange(1, 7) * (t_end / 6):  # six intervals, the step carried across
        s = m.advance(s, float(t), CRANK.accel)
    return s, (m.info.steps, m.info.rejected, m.info.nfev)


@pytest.mark.parametrize("scaled", [True, False], ids=["scaled", "unscaled"])
@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_generated_kernels_and_numpy_step_agree(method, scaled, fresh):
    a, work_a = run(method, False, fresh, scaled)
    assert (method, 6, scaled) in _integ._KERNELS  # generated here, not taken from a cache
    b, work_b = run(method, True, fresh, scaled)
    assert work_a == work_b  # the same steps, rejections and evaluations
    assert work_a[0] > 30
    np.testing.assert_allclose(a.y, b.y, rtol=1e-12, atol=1e-14)
    assert (a.h == b.h) if method == "RK4" else math.isclose(a.h, b.h, rel_tol=1e-9)


@pytest.mark.parametrize("numpy_path", [False, True], ids=["kernel", "numpy"])
@pytest.mark.parametrize("method", ["DOP853", "RK45"])
def test_a_zero_error_estimate_grows_the_step_tenfold(method, numpy_path, fresh):
    """y' = 0: every stage is zero, the error estimate exactly 0, and the controller grows
    the step by its largest factor, 10, from the initial 1e-6 s: 1e-6, 1e-5, ... 1 s reach
    1.111111 s after 7 steps, and the 8th is clipped to land on 2 s."""
    fresh.setattr(_integ, "SMALL_SYSTEM", -1 if numpy_path else 16)
    y, h, st = Integrator(method, tol=1e-6).advance(lambda t, y: np.zeros(2), 0.0, np.array([1.0, 2.0]), 2.0)
    assert (st.steps, st.rejected) == (8, 0)
    assert np.array_equal(y, [1.0, 2.0])
    assert math.isclose(h, 10.0, rel_tol=1e-12)  # the controller's step, not the clipped one


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_forced_oscillator_on_both_paths(method, fresh):
    """x'' = -x + cos(2 t), x(0) = 1, x'(0) = 0: x = (4/3) cos t - (1/3) cos 2t. The
    forcing depends on t alone, so a wrong stage or FSAL time shows at once."""
    def f(t, y):
        return np.array([y[1], -y[0] + math.cos(2.0 * t)])

    exact = [4 / 3 * math.cos(3.0) - math.cos(6.0) / 3, -4 / 3 * math.sin(3.0) + 2 * math.sin(6.0) / 3]
    for small in (16, -1):
        fresh.setattr(_integ, "SMALL_SYSTEM", small)
        y, _, st = Integrator(method, tol=1e-10, h_fixed=1e-3).advance(f, 0.0, np.array([1.0, 0.0]), 3.0)
        # tol 1e-10 (adaptive): global error ~ 1e-9; RK4 at 1 ms: ~ h^4 t / 100 ~ 3e-14
        assert np.max(np.abs(y - exact)) < 1e-8, (small, y - exact)


# ---------------------------------------------------------------------------
# input reconstruction from empty caches
def quintic(t):
    """A motion the quintic fits represent exactly: (x, y, vx, vy, ax, ay)."""
    cx = (0.1, -0.4, 0.3, 0.2, -0.15, 0.05)
    cy = (-0.2, 0.3, -0.1, 0.25, 0.1, -0.07)

    def ev(c, d):
        return sum(math.perm(j, d) * c[j] * t ** (j - d) for j in range(d, 6))
    return ev(cx, 0), ev(cy, 0), ev(cx, 1), ev(cy, 1), ev(cx, 2), ev(cy, 2)


@pytest.mark.parametrize("mode, samples", [("derivatives", (0.3, 0.5)),
                                           ("positions", (0.0, 0.1, 0.2, 0.3, 0.4, 0.5))])
def test_fits_reproduce_a_quintic_motion(mode, samples, fresh):
    rec = InputReconstruction(mode)
    for t in samples:
        rec.push(t, *quintic(t))
    assert InputReconstruction._ROWS == {}
    accel = rec.accel_function()
    assert InputReconstruction._ROWS  # computed here
    for t in (0.3, 0.45, 0.5, 0.55, 0.6):  # inside the window and extrapolated beyond it
        want = quintic(t)
        np.testing.assert_allclose(rec.state(t), want, rtol=0, atol=1e-9)
        np.testing.assert_allclose(accel(t), want[4:], rtol=0, atol=1e-9)


def test_hold_keeps_the_last_acceleration(fresh):
    rec = InputReconstruction("hold")
    rec.push(0.0, *quintic(0.0))
    rec.push(0.2, *quintic(0.2))
    x, y, vx, vy, ax, ay = quintic(0.2)
    assert rec.accel_function()(0.7) == (ax, ay)
    # position and velocity follow the held acceleration from the last sample
    assert rec.state(0.7) == pytest.approx((x + 0.5 * vx + 0.125 * ax, y + 0.5 * vy + 0.125 * ay,
                                            vx + 0.5 * ax, vy + 0.5 * ay, ax, ay), abs=1e-15)


def test_state_restores_mode_points_and_samples():
    """get_state/set_state carry the mode, the points and the whole history (the
    history keeps `points` + HISTORY_EXTRA samples for the node choice; a state of another
    mode or number of points is refused, naming both)."""
    a = InputReconstruction("positions", points=4)
    for t in (0.0, 0.1, 0.2, 0.3, 0.4):
        a.push(t, *quintic(t))
    with pytest.raises(ValueError) as e:
        InputReconstruction().set_state(a.get_state())  # derivatives, 2 points
    assert str(e.value) == ("input reconstruction state for mode 'positions' with 4 points, "
                            "expected 'derivatives' with 2")
    with pytest.raises(ValueError):
        InputReconstruction("positions", points=3).set_state(a.get_state())
    b = InputReconstruction("positions", points=4)
    b.set_state(a.get_state())
    assert (b.mode, b.points) == ("positions", 4)
    assert b.samples == a.samples and len(b.samples) == 5
    assert b.state(0.45) == a.state(0.45)
    assert [n[0] for n in b.nodes()] == [0.1, 0.2, 0.3, 0.4]  # the fit takes the newest 4
    for k in range(5, 15):
        b.push(0.1 * k, *quintic(0.1 * k))
    # the history keeps points + HISTORY_EXTRA = 10 samples, the fit the newest 4 of them
    assert len(b.samples) == 4 + HISTORY_EXTRA == 10
    assert b.samples[0][0] == pytest.approx(0.5) and b.samples[-1][0] == pytest.approx(1.4)
    assert [n[0] for n in b.nodes()] == [smp[0] for smp in b.samples[-4:]]
    c = InputReconstruction("positions", points=4)
    c.set_state(b.get_state())
    assert c.samples == b.samples and c.state(1.45) == b.state(1.45)


@pytest.mark.parametrize("numpy_path", [False, True], ids=["kernel", "numpy"])
@pytest.mark.parametrize("method", ["DOP853", "RK45"])
def test_a_right_hand_side_that_turns_nan_is_reported_as_such(method, numpy_path, fresh):
    """f is finite up to t = 0.3 s and NaN after: the step that reaches beyond (its last
    stage, or only the FSAL evaluation at t + h) is retried smaller until it gives up,
    saying why, on both step functions."""
    fresh.setattr(_integ, "SMALL_SYSTEM", -1 if numpy_path else 16)

    def f(t, y):
        return np.array([y[1], -y[0]]) if t <= 0.3 else np.array([math.nan, math.nan])
    with pytest.raises(ArithmeticError) as e:
        Integrator(method, tol=1e-8).advance(f, 0.0, np.array([1.0, 0.0]), 1.0)
    assert "non-finite values at t = " in str(e.value), str(e.value)


def test_square_builds_the_strictly_lower_triangular_matrix():
    """`_square` (run at import to build the tableaus, where a mutation tool cannot reach it)."""
    A = _integ._square([[0.5], [0.0, 0.5], [0.0, 0.0, 1.0]], 4)
    assert A.tolist() == [[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1.0, 0]]
    assert np.array_equal(_integ._square(_integ._RK45_A, 6), _integ.TABLEAUS["RK45"].A)
    assert np.array_equal(_integ._square(_integ._DOP853_A, 12), _integ.TABLEAUS["DOP853"].A)


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_a_scalar_equation(method, fresh):
    """n = 1: the generated kernel unpacks one state (y' = -y, y = e^-t)."""
    y, _, st = Integrator(method, tol=1e-10, h_fixed=1e-3).advance(lambda t, y: -y, 0.0, np.array([1.0]), 1.0)
    assert (1, False) in _integ._KERNELS or (method, 1, False) in _integ._KERNELS
    assert abs(y[0] - math.exp(-1.0)) < 1e-9 and st.steps > 0


def test_kernels_are_generated_up_to_small_system_only(fresh):
    def osc(n):
        return lambda t, y: np.concatenate([y[n // 2:], -y[:n // 2]])
    for n in (16, 18):
        Integrator("RK45", tol=1e-6).advance(osc(n), 0.0, np.ones(n), 0.1)
    assert ("RK45", 16, False) in _integ._KERNELS and ("RK45", 18, False) not in _integ._KERNELS


@pytest.mark.parametrize("method", ["DOP853", "RK45"])
def test_a_zero_step_size_is_no_step_size(method):
    f = lambda t, y: np.array([y[1], -y[0]])  # noqa: E731
    a = Integrator(method, tol=1e-8).advance(f, 0.0, np.array([1.0, 0.0]), 1.0, 0.0)
    b = Integrator(method, tol=1e-8).advance(f, 0.0, np.array([1.0, 0.0]), 1.0, None)
    assert np.array_equal(a[0], b[0]) and a[1] == b[1] and a[2] == b[2]


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_one_integrator_reused_across_sizes_and_scales(method):
    """The step function and scale tuples an Integrator keeps are rebuilt when the system
    size, the tolerance or the scale changes: the results are those of fresh integrators."""
    def osc(n):
        return lambda t, y: np.concatenate([y[n // 2:], -2.0 * y[:n // 2]])

    def fresh_run(n, tol, scale):
        return Integrator(method, tol=tol, scale=scale, h_fixed=1e-2).advance(osc(n), 0.0, np.ones(n), 0.5)

    reused = Integrator(method, tol=1e-7, scale=None, h_fixed=1e-2)
    for n, tol, scale in ((2, 1e-7, None), (4, 1e-7, None), (4, 1e-9, None), (4, 1e-9, [1.0, 1.0, 50.0, 50.0]),
                          (4, 1e-9, [1.0, 1.0, 0.01, 0.01]), (2, 1e-9, None)):
        reused.tol = tol
        reused.scale = None if scale is None else np.array(scale)
        got = reused.advance(osc(n), 0.0, np.ones(n), 0.5)
        want = fresh_run(n, tol, None if scale is None else np.array(scale))
        assert np.array_equal(got[0], want[0]) and got[2] == want[2], (n, tol, scale)


def test_rk4_takes_one_step_over_a_short_interval():
    y, h, st = Integrator("RK4", h_fixed=1e-2).advance(lambda t, y: -y, 0.0, np.array([1.0]), 1e-3)
    assert st.steps == 1 and st.nfev == 4 and h == 1e-2
    assert abs(y[0] - math.exp(-1e-3)) < 1e-15


@pytest.mark.parametrize("numpy_path", [False, True], ids=["kernel", "numpy"])
@pytest.mark.parametrize("method, work", [("DOP853", (23, 3, 313)), ("RK45", (81, 3, 505))])
def test_recovery_from_non_finite_trial_steps(method, work, numpy_path, fresh):
    """y' = -50 y, with f undefined (NaN) beyond |y| = 2, started with a carried step of 1 s:
    the first trial steps are unstable and leave the domain, are rejected and retried at a
    fifth of the size until one stays finite; then the controller takes over. The run
    succeeds with the rejections counted (pinned: deterministic)."""
    fresh.setattr(_integ, "SMALL_SYSTEM", -1 if numpy_path else 16)

    def f(t, y):
        return np.array([-50.0 * y[0]]) if abs(y[0]) <= 2.0 else np.array([math.nan])
    y, _, st = Integrator(method, tol=1e-6).advance(f, 0.0, np.array([1.0]), 0.5, 1.0)
    assert (st.steps, st.rejected, st.nfev) == work
    assert y[0] == pytest.approx(math.exp(-25.0), rel=2e-3)


def test_the_last_step_lands_on_the_end_time_exactly():
    """y' = 0 from t = 0.1: the step grows tenfold per step and the last one is clipped to the
    end; the driver then stands exactly at t_end, so no sliver step follows (6 to 8 steps
    for ends between 0.2 and 10.1 s, never more)."""
    for te in np.linspace(0.1, 10.0, 397):
        t_end = float(te) + 0.1
        _, _, st = Integrator("RK45", tol=1e-6).advance(lambda t, y: np.zeros(1), 0.1, np.array([1.0]), t_end)
        # steps from 1e-6 s growing tenfold: k steps cover 1.111...e-6 (10^k - 1) s
        need = next(k for k in range(1, 20) if 1e-6 * (10 ** k - 1) / 9 >= (t_end - 0.1) * (1 - 1e-12))
        assert st.steps == need, (t_end, st.steps, need)
