"""The integrators: failure paths leave the input state untouched, and the
fixed-step RK4 converges at fourth order."""
import math

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, Fixed, Integrator, StepFailure

BALL = Ball()


class CallBudgetExceeded(Exception):
    """Raised by the test's input function when the integrator keeps calling it."""


def nan_accel(after=-math.inf, budget=20_000):
    """a_O that is NaN for t > after; fails the test (instead of hanging) when
    the integrator calls it more than ``budget`` times."""
    calls = [0]

    def accel(t):
        calls[0] += 1
        if calls[0] > budget:
            raise CallBudgetExceeded(f"integrator called the input {calls[0]} times")
        return (math.nan, 0.0) if t > after else (0.0, 0.0)
    accel.calls = calls
    return accel


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
@pytest.mark.parametrize("formulation", ["vector", "paper"])
@pytest.mark.parametrize("nan_after", [-1.0, 0.004], ids=["nan-from-start", "nan-later"])
@pytest.mark.parametrize("h0", [None, 2e-3], ids=["first-step", "carried-step"])
def test_step_failure_leaves_state_untouched(method, formulation, nan_after, h0):
    model = BallModel(BALL, formulation, method=method, tol=1e-9, h_fixed=1e-3)
    state = model.initial(xC0=0.05, yC0=-0.02, w0=(1.0, 2.0, 3.0))
    # h0 None: the adaptive methods choose their first step from f(t0, y0),
    # which is NaN here when the input is NaN from the start
    state.h = h0
    y_before = state.y.copy()
    y_id = id(state.y)
    accel = nan_accel(after=nan_after)
    with pytest.raises(ArithmeticError) as exc:
        model.advance(state, 0.01, accel)
    assert isinstance(exc.value, StepFailure)
    assert "non-finite" in str(exc.value)
    # the input state is exactly as it was, the same array object, bit for bit
    assert id(state.y) == y_id and state.t == 0.0 and state.h == h0
    assert np.array_equal(state.y, y_before)
    # and it gave up quickly: a NaN input is not retried a million times
    assert accel.calls[0] < 2_000


def test_integrator_does_not_modify_its_argument():
    integ = Integrator("DOP853", tol=1e-9)
    y0 = np.array([1.0, 0.0])
    y_copy = y0.copy()
    y1, h, stats = integ.advance(lambda t, y: np.array([y[1], -y[0]]), 0.0, y0, 1.0)
    assert np.array_equal(y0, y_copy)
    # harmonic oscillator: y(1) = (cos 1, -sin 1); tol 1e-9 -> ~1e-9 error
    np.testing.assert_allclose(y1, [math.cos(1.0), -math.sin(1.0)], atol=1e-8)
    assert stats.steps > 0 and h > 0


def test_integrator_rejects_bad_settings():
    with pytest.raises(ValueError, match="method"):
        Integrator("Euler")
    with pytest.raises(ValueError, match="tolerance"):
        Integrator("DOP853", tol=0.0)
    with pytest.raises(ValueError, match="h_fixed"):
        Integrator("RK4", h_fixed=-1e-3)


# --------------------------------------------------------------------------
# RK4 converges at fourth order
def swing_state(model):
    # a 40 deg non-planar swing with spin, fixed chamber
    return model.initial(xC0=BALL.d * math.sin(math.radians(40)), yC0=0.03, w0=(2.0, -1.0, 5.0))


def test_rk4_fourth_order():
    t_end = 1.0
    ref_model = BallModel(BALL, method="DOP853", tol=1e-13)
    ref = ref_model.advance(swing_state(ref_model), t_end, Fixed().accel)
    errors = []
    hs = [0.02, 0.01, 0.005]
    for h in hs:
        model = BallModel(BALL, method="RK4", h_fixed=h)
        out = model.advance(swing_state(model), t_end, Fixed().accel)
        assert model.info.steps == round(t_end / h)
        errors.append(np.abs(out.y - ref.y).max())
    ratios = [errors[i] / errors[i + 1] for i in range(len(errors) - 1)]
    # errors 1.7e-4, 1.1e-5, 7.4e-7 here (ratios 15.0, 15.5): far above the
    # DOP853 reference's error (~1e-11) and round-off, so the ratios show the
    # method's order, 2^4 = 16; a third-order method would give ~8
    assert errors[-1] > 1e-10
    for r in ratios:
        assert 10 < r < 22, (errors, ratios)


def test_rk4_last_step_lands_on_the_interval_end():
    model = BallModel(BALL, method="RK4", h_fixed=0.003)
    s = model.advance(swing_state(model), 0.01, Fixed().accel)  # 0.01 / 0.003 -> 4 steps of 0.0025
    assert s.t == 0.01 and model.info.steps == 4


def test_adaptive_error_follows_tolerance():
    t_end = 1.0
    ref_model = BallModel(BALL, tol=1e-13)
    ref = ref_model.advance(swing_state(ref_model), t_end, Fixed().accel)
    errs = {}
    for tol in (1e-6, 1e-9):
        model = BallModel(BALL, tol=tol)
        errs[tol] = np.abs(model.advance(swing_state(model), t_end, Fixed().accel).y - ref.y).max()
    # The tolerance is relative to each state's scale (1 for n, ~50 rad/s for
    # omega). Over this 1 s swing (7 .. 16 steps) the global error stays within
    # 10 tol of that scale (measured: 2 tol at 1e-6, 0.5 tol at 1e-9) and falls
    # with the tolerance (by 4500x here).
    w_scale = BALL.d * BALL.omega_small / BALL.r  # 50 rad/s
    for tol, err in errs.items():
        assert err < 10 * tol * w_scale, (tol, err)
    assert errs[1e-9] < errs[1e-6] / 100


@pytest.mark.parametrize("method, bound", [("DOP853", 1e-9), ("RK45", 1e-9), ("RK4", 1e-10)])
def test_a_system_above_the_generated_kernels_uses_the_numpy_step(method, bound):
    """20 uncoupled oscillators (40 states > SMALL_SYSTEM): x(t) = cos(w t) exactly.
    Bounds: tol 1e-10 (adaptive) and h = 1 ms RK4 (error ~ (w h)^4 w t / 120 ~ 1e-12)."""
    from ballmill.physics.integrators import SMALL_SYSTEM, Integrator
    w = np.linspace(1.0, 3.0, 20)
    assert 2 * w.size > SMALL_SYSTEM

    def f(t, y):
        return np.concatenate([y[20:], -w**2 * y[:20]])

    y0 = np.concatenate([np.ones(20), np.zeros(20)])
    y, _, stats = Integrator(method, tol=1e-10, h_fixed=1e-3).advance(f, 0.0, y0, 2.0, None)
    assert np.max(np.abs(y[:20] - np.cos(w * 2.0))) < bound
    assert stats.steps > 0 and y0[0] == 1.0  # input untouched
