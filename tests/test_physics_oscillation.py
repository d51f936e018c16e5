"""Equilibrium at the bottom, small and large oscillations in a fixed chamber.

docs/design.md section 2: the bottom is an equilibrium, small oscillations have
omega^2 = 5 g / (7 (R - r)), large planar ones follow the exact pendulum
period with the reduced gravity g_red = 5 g / 7.
"""
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipk

from ballmill.physics import Ball, BallModel, Fixed, simulate

BALL = Ball()  # the paper's ball: r = 0.025 m, R = 0.25 m, steel, m = 0.5105 kg
FIXED = Fixed()


# --------------------------------------------------------------------------
# 1. the bottom is an equilibrium, kept to the bit
@pytest.mark.parametrize("formulation,method", [("vector", "DOP853"), ("vector", "RK4"),
                                                ("paper", "DOP853"), ("paper", "RK4")])
def test_rest_at_bottom_stays_exactly(formulation, method):
    model = BallModel(BALL, formulation, method=method, h_fixed=1e-2)
    traj = simulate(model, FIXED, t_end=5.0, dt=0.01)  # 500 intervals, >= 500 steps
    assert traj.success, traj.message
    assert len(traj.t) == 501
    # At n = (0, 0, -1), omega = 0 every term of the right-hand side is an exact
    # zero (products of zeros; g only enters through n x e_z = 0), and the
    # projection divides by sqrt(1) = 1: the state cannot move by even one ulp.
    # (-0.0 == 0.0 in the comparison below, which is what we want.)
    expected = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0] if formulation == "vector" else [0.0] * 5
    assert np.all(traj.y == np.array(expected)), np.abs(traj.y - expected).max()
    m, g = BALL.m, BALL.g
    # the outputs at rest: normal force carries the weight exactly
    assert np.all(traj["N"] == m * g)
    assert np.all(traj["Fz"] == -m * g)  # force of the ball ON the chamber: downwards
    assert np.all(traj["Fx"] == 0.0) and np.all(traj["Fy"] == 0.0)
    assert np.all(traj["zP"] == 0.0) and np.all(traj["xP"] == 0.0) and np.all(traj["yP"] == 0.0)
    # zC = R + d n_z = R - (R - r): one rounding in R - r, so to an ulp of R
    assert np.all(np.abs(traj["zC"] - BALL.r) <= 2 * np.spacing(BALL.R))
    assert np.all(traj["contact"] == 1.0) and np.all(traj["rolling"] == 1.0)
    assert np.all(traj["friction_ratio"] == 0.0)


# --------------------------------------------------------------------------
# helpers: accurate zero crossings of xC
def _xC(model, state):
    return model.outputs(state, 0.0, 0.0).xC


def zero_crossings(model, state, t_end, dt):
    """Times where xC changes sign, each located by brentq on the integrator itself
    (advance from the grid point before the crossing to the trial time), so the
    only errors are the integration tolerance and brentq's xtol."""
    accel = FIXED.accel
    times = []
    t, s = state.t, state
    x0 = _xC(model, s)
    while t < t_end - 1e-12:
        t1 = t + dt
        s1 = model.advance(s, t1, accel)
        x1 = _xC(model, s1)
        if x0 * x1 < 0.0:
            def xC_at(tt, left=s):
                return _xC(model, model.advance(left, tt, accel) if tt > left.t else left)
            times.append(brentq(xC_at, t, t1, xtol=1e-14, rtol=4 * np.finfo(float).eps))
        t, s, x0 = t1, s1, x1
    return np.array(times)


def measured_period(model, xC0, periods):
    T_guess = 2 * math.pi / BALL.omega_small
    state = model.initial(xC0=xC0)
    tc = zero_crossings(model, state, (periods + 0.6) * T_guess, dt=0.02)
    # consecutive crossings are half a period apart; average over all of them
    half = np.diff(tc)
    assert len(half) >= 2 * periods - 1
    return 2 * (tc[-1] - tc[0]) / len(half), half


def test_small_oscillation_frequency_is_5g_over_7d():
    # omega^2 = 5 g / (7 (R - r)): written out here, not taken from Ball.omega_small
    omega_th = math.sqrt(5 * BALL.g / (7 * (BALL.R - BALL.r)))
    assert BALL.omega_small == pytest.approx(omega_th, rel=1e-15)
    T0 = 2 * math.pi / omega_th
    theta0 = math.asin(1e-3)  # release at xC0 = 1e-3 d, at rest
    model = BallModel(BALL, tol=1e-12)
    T, half = measured_period(model, 1e-3 * BALL.d, periods=10)
    # small-amplitude expansion of the pendulum period: T0 (1 + theta0^2/16 + 11 theta0^4/3072)
    T_corr = T0 * (1 + theta0**2 / 16)
    # Errors: tol 1e-12 on n (|n| = 1, amplitude 1e-3) gives a position error
    # ~1e-12 at the crossing, i.e. ~2e-10 s in time (speed 5.6e-3 /s in n);
    # averaged over 10 periods that is ~2e-11 relative (measured: 5e-15); the dropped term is
    # 4e-15. 1e-10 leaves a margin yet is 600x smaller than the correction
    # theta0^2/16 = 6.25e-8, so the test sees the amplitude dependence.
    assert abs(T / T_corr - 1) < 1e-10, (T, T_corr, T / T0 - 1)
    assert abs(T / T0 - 1) < 1e-6  # the brief's headline number
    # every half period alike (linear oscillator): spread limited by the crossing accuracy
    assert np.ptp(half) < 1e-9


@pytest.mark.parametrize("formulation", ["vector", "paper"])
def test_large_swing_exact_pendulum_period(formulation):
    theta0 = math.radians(60.0)
    g_red = 5.0 * BALL.g / 7.0  # reduced gravity of a rolling solid ball
    d = BALL.R - BALL.r
    # exact period; scipy's ellipk takes the parameter m = k^2 = sin^2(theta0/2)
    T_exact = 4.0 * math.sqrt(d / g_red) * ellipk(math.sin(theta0 / 2) ** 2)
    model = BallModel(BALL, formulation, tol=1e-12)
    T, half = measured_period(model, d * math.sin(theta0), periods=5)
    # release without spin: the motion stays planar (y, and omega_x, omega_z, stay 0)
    # Tolerance: tol 1e-12 gives crossing times good to ~1e-11 s (speed at the
    # bottom 1.2 m/s; measured 5e-14 relative); 1e-10 is 10x looser than the
    # estimate and 7e8 times tighter than
    # the difference from the small-amplitude period (7.3 %).
    assert abs(T / T_exact - 1) < 1e-10, (T, T_exact)
    T_small = 2 * math.pi * math.sqrt(d / g_red)
    assert T / T_small - 1 > 0.07


def test_large_swing_stays_planar():
    model = BallModel(BALL, tol=1e-10)
    theta0 = math.radians(60.0)
    traj = simulate(model, FIXED, 3.0, 0.01, state=model.initial(xC0=BALL.d * math.sin(theta0)))
    # planar by symmetry: y = 0 and omega has only a y component, exactly
    # (every term feeding them is a product with an exact zero)
    assert np.all(traj["yC"] == 0.0)
    assert np.all(traj["wx"] == 0.0) and np.all(traj["wz"] == 0.0)
    # Half an exact period later it is at the opposite turning point, at the
    # release height. At a turning point xC' = 0, so a timing error only enters
    # at second order: what is left is the integration error (~1e-10 relative).
    g_red = 5.0 * BALL.g / 7.0
    T_exact = 4.0 * math.sqrt(BALL.d / g_red) * ellipk(math.sin(theta0 / 2) ** 2)
    s_half = model.advance(model.initial(xC0=BALL.d * math.sin(theta0)), T_exact / 2, FIXED.accel)
    o = model.outputs(s_half, 0.0, 0.0)
    assert o.xC == pytest.approx(-BALL.d * math.sin(theta0), rel=1e-8)
    assert o.zC == pytest.approx(BALL.R - BALL.d * math.cos(theta0), rel=1e-8)
    assert abs(o.wy) < 1e-6  # at rest there (omega ~ 7 rad/s at the bottom)
