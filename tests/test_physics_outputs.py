"""Outputs (docs/design.md section 3): normal force, forces on the chamber,
reaction torque, friction ratio and the validity flags, against hand
computations."""
import math

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, CrankStartup, Outputs, evaluate

BALL = Ball()
M, G = BALL.m, BALL.g


def test_outputs_at_rest_bottom():
    o = evaluate(BALL, (0.0, 0.0, -1.0), (0.0, 0.0, 0.0), 0.0, 0.0)
    assert isinstance(o, Outputs)
    assert o.N > 0 and o.N == M * G
    assert o.Fz == -M * G and o.Fx == 0.0 and o.Fy == 0.0
    assert (o.xP, o.yP, o.zP) == (0.0, 0.0, 0.0)
    assert o.contact and o.rolling and o.friction_ratio == 0.0
    assert (o.MAx, o.MAy, o.MAz) == (0.0, 0.0, 0.0)  # the weight points through A


@pytest.mark.parametrize("theta_deg,rolling", [(30.0, True), (60.0, False)])
def test_released_on_the_wall_hand_computation(theta_deg, rolling):
    """Ball at rest at angle theta from the bottom in a fixed chamber (x-z plane).

    By hand: it starts to roll down with tangential acceleration 5/7 g sin(theta)
    and no normal acceleration (no speed yet), so the chamber pushes with
    N = m g cos(theta) and the friction must supply m (5/7 - 1) g sin(theta):
    |F_t| = 2/7 m g sin(theta), ratio 2/7 tan(theta); rolling needs mu >= that
    (mu = 0.3: up to 46.4 deg)."""
    th = math.radians(theta_deg)
    n = (math.sin(th), 0.0, -math.cos(th))
    o = evaluate(BALL, n, (0.0, 0.0, 0.0), 0.0, 0.0)
    # pure arithmetic on exact formulas: only a few ulps of round-off
    assert o.N == pytest.approx(M * G * math.cos(th), rel=1e-14)
    assert o.Ft == pytest.approx(2 / 7 * M * G * math.sin(th), rel=1e-14)
    assert o.friction_ratio == pytest.approx(2 / 7 * math.tan(th), rel=1e-14)
    # the definition: |F_t| / N, with F_t = F + N n and F = -(Fx, Fy, Fz) on the ball
    F = -np.array([o.Fx, o.Fy, o.Fz])
    N_hand = -F @ np.array(n)
    Ft_hand = np.linalg.norm(F + N_hand * np.array(n))
    assert o.N == pytest.approx(N_hand, rel=1e-14)
    assert o.friction_ratio == pytest.approx(Ft_hand / N_hand, rel=1e-14)
    # Newton by hand: a_C = 5/7 g sin(theta) down the slope, i.e. along
    # -(cos, 0, sin), so the force on the ball F = m (a_C + g e_z) is
    sn, cs = math.sin(th), math.cos(th)
    F_hand = M * G * np.array([-5 / 7 * sn * cs, 0.0, 1 - 5 / 7 * sn * sn])
    np.testing.assert_allclose(F, F_hand, rtol=1e-14, atol=1e-14 * M * G)
    assert o.contact is True
    assert o.rolling is rolling
    assert (o.friction_ratio <= BALL.mu) is rolling
    # contact point and centre
    assert o.xP == pytest.approx(BALL.R * math.sin(th), rel=1e-15)
    assert o.zP == pytest.approx(BALL.R * (1 - math.cos(th)), rel=1e-14)
    assert o.zC == pytest.approx(BALL.R - BALL.d * math.cos(th), rel=1e-14)


def test_moment_about_the_chamber_centre():
    rng = np.random.default_rng(2)
    for _ in range(10):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        w = rng.normal(scale=10, size=3)
        o = evaluate(BALL, n, w, *rng.normal(size=2))
        Fs = np.array([o.Fx, o.Fy, o.Fz])
        MA = np.cross(BALL.R * n, Fs)  # the force acts at P = A + R n
        np.testing.assert_allclose([o.MAx, o.MAy, o.MAz], MA, rtol=1e-13, atol=1e-13 * np.abs(MA).max())


def test_no_contact_above_the_equator_at_low_speed():
    # above the equator (n_z = 0.8 > 0), at rest: gravity pulls the ball off the
    # wall. By hand: N = -m g n_z = -0.8 m g < 0.
    n = (0.0, 0.6, 0.8)
    o = evaluate(BALL, n, (0.0, 0.0, 0.0), 0.0, 0.0)
    assert o.N == pytest.approx(-0.8 * M * G, rel=1e-14)
    assert o.N < 0
    assert o.contact is False
    assert o.rolling is False
    assert o.friction_ratio == math.inf
    # at the equator exactly (n_z = 0, at rest) N is 0 and that is no contact either
    o0 = evaluate(BALL, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0)
    assert o0.N == 0.0 and o0.contact is False and o0.rolling is False


def test_fast_enough_ball_keeps_contact_above_equator():
    # same place, but rolling fast along the wall: the centripetal demand
    # m v^2 / d exceeds the pull of gravity off the wall, N > 0 again
    n = np.array([0.0, 0.6, 0.8])
    e = np.array([1.0, 0.0, 0.0])  # a tangent direction
    v = 3.0  # m/s: m v^2/d = 20 N > 0.8 m g = 4 N
    # rolling without slip: v_C = r n x omega, so omega = (e x n) v / r gives v_C = v e
    w = np.cross(e, n) * v / BALL.r
    o = evaluate(BALL, tuple(map(float, n)), tuple(map(float, w)), 0.0, 0.0)
    vC = BALL.d * BALL.lam * np.cross(n, w)
    np.testing.assert_allclose(vC, v * e, rtol=1e-14, atol=1e-14)
    # normal direction by hand: the centre moves on its sphere of radius d, so its
    # acceleration along -n is at least v^2/d, exactly v^2/d (the normal part of
    # a_C . n = -|v_C|^2 / d for any motion on the sphere). N = -F . n with
    # F = m (a_C + g e_z): N = m v^2 / d - m g n_z
    assert o.N == pytest.approx(M * v * v / BALL.d - M * G * n[2], rel=1e-12)
    assert o.contact is True


def test_reaction_torque_negative_at_fast_start():
    motion = CrankStartup(t0=2.5)
    model = BallModel(BALL, tol=1e-10)
    t = 1e-3
    state = model.advance(model.initial(), t, motion.accel)
    x, y, vx, vy, ax, ay = motion.state(t)
    o = model.outputs(state, ax, ay, x, y)
    assert o.M_reaction < 0  # the ball resists the drive
    # by hand at t -> 0: the platform is at (l, 0) accelerating along +y with
    # a = l psi''(0) = l 2 w0 / t0; a ball at rest rolling on a nearly flat bottom
    # takes 2/7 of that acceleration (rolling on an accelerated plane), so
    # F_y(on ball) = 2/7 m a and M = x F_s,y = -l 2/7 m a. At t = 1e-3 s the
    # terms left out are O(t / t0, w0^2 t^2, ball's excursion ~1e-7 m): 1e-3 relative.
    l, w0, t0 = motion.l, motion.w0, motion.t0
    M_hand = -l * 2 / 7 * M * l * 2 * w0 / t0
    assert o.M_reaction == pytest.approx(M_hand, rel=2e-3)
    # definition: M = x1O F_s,y - y1O F_s,x
    assert o.M_reaction == pytest.approx(x * o.Fy - y * o.Fx, rel=1e-15)
    # the drive's power on the ball, -M psi', is positive
    assert -o.M_reaction * motion.angle(t)[1] > 0
