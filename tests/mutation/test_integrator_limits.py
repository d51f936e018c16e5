"""The integrator's limits, word for word and at their edges (ballmill.physics.integrators):
RK4's step budget (max_steps steps are allowed, one more is refused before any step, with
the numbers in the message), DOP853's error norm when only the third-order estimate
vanishes, and a solution that leaves the float range within the interval (refused on both
step paths, never returned as inf). Written for mutants the rest of the suite let through
(docs/mutation.md)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import Integrator
from ballmill.physics import integrators as _integ
from ballmill.physics.errors import StepFailure


@pytest.mark.parametrize("n", [2, 17], ids=["kernel", "numpy"])
def test_rk4_takes_exactly_max_steps_and_refuses_one_more(n):
    """1 s at h_fixed = 0.1 s is 10 steps: allowed with max_steps = 10 (y' = 1: y = y0 + 1),
    refused with 9, before any evaluation beyond the first, the input untouched."""
    y0 = np.zeros(n)
    y, h, stats = Integrator("RK4", h_fixed=0.1, max_steps=10).advance(lambda t, y: 1.0, 0.0, y0, 1.0)
    assert (stats.steps, stats.nfev, h) == (10, 40, 0.1)
    np.testing.assert_allclose(y, 1.0, rtol=0, atol=1e-15)
    with pytest.raises(StepFailure) as info:
        Integrator("RK4", h_fixed=0.1, max_steps=9).advance(lambda t, y: 1.0, 0.0, y0, 1.0)
    assert str(info.value) == "RK4: 1 s at h_fixed = 0.1 s needs 10 steps, more than 9"
    with pytest.raises(StepFailure) as info:
        Integrator("RK4", h_fixed=1e-3, max_steps=2499).advance(lambda t, y: 1.0, 0.5, y0, 3.0)
    assert str(info.value) == "RK4: 2.5 s at h_fixed = 0.001 s needs 2500 steps, more than 2499"
    assert not y0.any()


def test_dop853_error_norm_with_a_vanishing_third_order_estimate():
    """Hairer's DOP853 norm err = |h| e5n / sqrt((e5n + 0.01 e3n) n) is 0 only when both
    estimates vanish. Stages 9 and 10 chosen so that the third-order estimate cancels
    (E3_9 E3_10 - E3_10 E3_9: zero, or one product's rounding ~1e-18, whose square over
    sc^2 = 1e298 underflows to 0) leave err = |h| |e5| / sc with
    e5 = E5_9 E3_10 - E5_10 E3_9 on every component."""
    integ = Integrator("DOP853", tol=0.1)
    E5, E3 = _integ._DOP853_E5, _integ._DOP853_E3
    n = 3
    K = np.zeros((13, n))
    K[9], K[10] = E3[10], -E3[9]
    y = np.full(n, 1e150)
    sc = 0.1 * 1e150 + 1e-12
    e5 = abs(E5[9] * E3[10] - E5[10] * E3[9])
    assert e5 > 0.07
    for h in (0.5, -0.25):
        err = integ._error_norm(K, h, y, y)
        assert err > 0.0 and err == pytest.approx(abs(h) * e5 / sc, rel=1e-12, abs=0.0)
    assert integ._error_norm(np.zeros((13, n)), 0.5, y, y) == 0.0  # both vanish: 0, not 0/0


@pytest.mark.parametrize("method", ["DOP853", "RK45"])
@pytest.mark.parametrize("n", [2, 17], ids=["kernel", "numpy"])
def test_a_solution_that_overflows_is_refused_not_returned_as_inf(method, n):
    """y' = 1e307 from y0 = 1.7e308 passes the largest double (1.797e308) at t = 0.977 s:
    the step that overflows has finite stages (the right-hand side is constant) and a zero
    error estimate (its scale is inf), yet its state is not finite: it is retried smaller
    until the step underflows, and advance raises StepFailure; up to 0.9 s it integrates."""
    y0 = np.full(n, 1.7e308)
    f = lambda t, y: np.full(n, 1e307)  # noqa: E731
    with np.errstate(over="ignore", invalid="ignore"):
        y, _, _ = Integrator(method, tol=1e-6).advance(f, 0.0, y0, 0.9)
        np.testing.assert_allclose(y, 1.7e308 + 0.9e307, rtol=1e-12)
        with pytest.raises(StepFailure) as info:
            Integrator(method, tol=1e-6).advance(f, 0.0, y0, 1.0)
    msg = str(info.value)
    assert msg.startswith(f"{method}: non-finite values at t = 0.97693") and "even with step" in msg
    t_fail = float(msg.split("t = ")[1].split(" s")[0])
    assert math.isclose(t_fail, (1.7976931348623157e308 - 1.7e308) / 1e307, rel_tol=1e-8)


# -- the step-size driver's edges: an explicit first step `h` puts a step exactly on them --------
ADAPTIVE = ["DOP853", "RK45"]


@pytest.mark.parametrize("method", ADAPTIVE)
def test_a_step_ending_within_1e_12_of_the_end_is_stretched_onto_it(method):
    """y' = 0: every step is accepted (err = 0). A step from t that reaches
    t_last = t_end - 1e-12 max(1, |t_end|) (or beyond) lands on t_end: one step; a step that
    ends before t_last is taken as it is and a second, short one follows."""
    def steps(t_end, h):
        return Integrator(method).advance(lambda t, y: (0.0, 0.0), 0.0, [1.0, 2.0], t_end, h)[2].steps
    assert steps(1.0, 1.0 - 1e-12) == 1  # exactly t_last
    assert steps(1.0, 1.0 - 1.5e-12) == 2
    assert steps(1000.0, 1000.0 - 5e-10) == 1  # the snap scales with |t_end| (1e-9 s here)
    assert steps(1000.0, 1000.0 - 2e-9) == 2


def _nan_after_start(t, y):
    return (0.0, 0.0) if t == 0.0 else (math.nan, 0.0)


def _jump_after_start(t, y):
    return (0.0, 0.0) if t == 0.0 else (1e30, 1e30)


@pytest.mark.parametrize("method", ADAPTIVE)
@pytest.mark.parametrize("t_end, h0, last", [
    (1.0, 1.0, "1.05e-14"),  # 0.2^20 = 1.05e-14 >= 1e-14 is tried, 0.2^21 is not
    (1000.0, 1.0, "3.28e-11"),  # the floor scales with |t_end|: 1e-11 here (0.2^15 tried)
    (1.0, 4.9999999999999995e-14, "1e-14"),  # 0.2 h0 is exactly 1e-14: still tried
])
def test_the_smallest_step_tried(method, t_end, h0, last):
    """A right-hand side that is finite at the start only (non-finite values), or that jumps
    there by 1e30 (an error estimate ~1e-3 / tol at any step: the controller's cut is its
    floor 0.2): the step is cut by 5 until it falls below 1e-14 max(1, |t_end|); the
    message names the last step tried."""
    with pytest.raises(StepFailure) as info:
        Integrator(method).advance(_nan_after_start, 0.0, [0.0, 0.0], t_end, h0)
    assert str(info.value) == f"{method}: non-finite values at t = 0 s even with step {last} s"
    with pytest.raises(StepFailure) as info:
        Integrator(method, tol=1e-12).advance(_jump_after_start, 0.0, [0.0, 0.0], t_end, h0)
    assert str(info.value) == (f"{method}: step size underflow at t = 0 s (tolerance 1e-12 not met with "
                               f"step {last} s)")


def test_advance_refuses_a_state_that_is_not_one_dimensional():
    with pytest.raises(ValueError) as info:
        Integrator().advance(lambda t, y: y, 0.0, [[1.0, 2.0]], 1.0)
    assert str(info.value) == "the state must be a 1-D sequence of floats, got shape (1, 2)"


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_an_empty_or_backward_interval_returns_the_state_as_floats(method):
    integ = Integrator(method)
    for t_end in (1.0, 0.5):
        y, h, stats = integ.advance(lambda t, y: 1.0, 1.0, [1, 2], t_end, 0.25)
        assert y.dtype == np.float64 and y.tolist() == [1.0, 2.0]
        assert h == 0.25 and (stats.steps, stats.rejected, stats.nfev) == (0, 0, 0)
    # from a negative time: y' = 1 over 3 s
    y, _, stats = integ.advance(lambda t, y: 1.0, -2.0, [0.0], 1.0, 0.5)
    assert y.tolist() == pytest.approx([3.0], abs=1e-11) and stats.steps >= 1  # RK4: 3000 steps of round-off


@pytest.mark.parametrize("kwargs, message", [
    ({"tol": 0.5}, "tolerance must be within [1e-15, 0.1], got 0.5"),
    ({"tol": 1e-16}, "tolerance must be within [1e-15, 0.1], got 1e-16"),
    ({"h_fixed": 0.0}, "fixed step h_fixed must be positive and finite, got 0.0 s"),
    ({"h_fixed": -1e-3}, "fixed step h_fixed must be positive and finite, got -0.001 s"),
    ({"h_fixed": math.inf}, "fixed step h_fixed must be positive and finite, got inf s"),
])
def test_the_integrator_refuses_its_settings_word_for_word(kwargs, message):
    with pytest.raises(ValueError) as info:
        Integrator("RK4", **kwargs)
    assert str(info.value) == message
    assert Integrator("RK4", tol=0.1, h_fixed=5e-324).tol == 0.1  # the edges themselves are taken
