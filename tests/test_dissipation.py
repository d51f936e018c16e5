"""Losses to the ground material: rolling resistance (delta) and viscous drag (c).

Each check compares the library with something derived independently: a
Newton-Euler solve with the contact force as unknown, the energy argument
for the swing's loss of amplitude, the log decrement of the linearised
equation, and the steady orbit in a chamber moving on a circle.
"""
import math
import re

import numpy as np
import pytest
from scipy.optimize import fsolve

from ballmill.physics import (Ball, BallModel, Circle, Fixed, ParameterError, PaperFormulation,
                              VectorFormulation, evaluate, simulate)
from ballmill.physics.equations import ROLLING_EPS

BALL = Ball()


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


# -- parameters and the default path --------------------------------------------
@pytest.mark.parametrize("kwargs, text", [
    (dict(rolling_resistance=-1e-4), "rolling_resistance = -0.0001"),
    (dict(drag=float("nan")), "drag = nan"),
    (dict(drag="thick"), "'thick'"),
])
def test_bad_loss_parameters_are_named(kwargs, text):
    with pytest.raises(ParameterError, match=re.escape(text)):
        Ball(**kwargs)


def test_default_ball_keeps_the_lossless_equations():
    assert BALL.rolling_resistance == 0.0 and BALL.drag == 0.0
    for form in (VectorFormulation(BALL), PaperFormulation(BALL)):
        assert "derivative" not in vars(form)  # the class's lossless right-hand side, unchanged
    lossy = VectorFormulation(BALL.with_(drag=0.1))
    assert "derivative" in vars(lossy)
    o = evaluate(BALL, (0.3, 0.1, -math.sqrt(0.9)), (1.0, -2.0, 0.5), 0.7, -0.2, 0.5, 0.0)
    assert o.P_diss == 0.0
    with pytest.raises(ValueError, match="cramer"):
        PaperFormulation(BALL.with_(drag=0.1), cramer=True)


# -- the derivation, checked against Newton-Euler with F unknown ------------------
@pytest.mark.parametrize("formulation", ["vector", "paper"])
def test_equations_match_newton_euler_with_the_contact_force_unknown(formulation):
    """Unknowns omega' and the contact force F (6): m (a_O + r (n' x w + n x w')) = F + m g + F_d,
    I w' = r n x F + M with M = -delta N w_t / sqrt(|w_t|^2 + eps^2), N = -F . n (so M is
    linear in F too). Solved as one linear system, no elimination by hand."""
    ball = BALL.with_(rolling_resistance=1e-3, drag=0.7)
    model = BallModel(ball, formulation=formulation)
    rng = np.random.default_rng(7)
    d, r, m, I, lam = ball.d, ball.r, ball.m, ball.I, ball.lam
    for _ in range(6):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        n[2] = -abs(n[2]) - 0.3
        n /= np.linalg.norm(n)
        w = rng.normal(size=3) * 4.0
        ax, ay = rng.normal(size=2) * 3.0
        nd = lam * np.cross(n, w)
        g = np.array([0.0, 0.0, -ball.g])
        a_O = np.array([ax, ay, 0.0])
        F_d = -ball.drag * d * nd
        wt = w - (w @ n) * n
        u = wt / math.sqrt(wt @ wt + ROLLING_EPS ** 2)
        A = np.zeros((6, 6))
        b = np.zeros(6)
        A[:3, :3] = m * r * skew(n)
        A[:3, 3:] = -np.eye(3)
        b[:3] = m * g + F_d - m * (a_O + r * np.cross(nd, w))
        A[3:, :3] = I * np.eye(3)
        A[3:, 3:] = -r * skew(n) - ball.rolling_resistance * np.outer(u, n)
        x = np.linalg.solve(A, b)
        wd_ref, F_ref = x[:3], x[3:]
        state = model.initial(d * n[0], d * n[1], tuple(w))
        deriv = np.array(model.form.derivative(state.y.tolist(), ax, ay))
        assert np.max(np.abs(deriv[-3:] - wd_ref)) < 1e-11 * max(1.0, np.max(np.abs(wd_ref)))
        o = model.outputs(state, ax, ay)
        assert o.N == pytest.approx(-F_ref @ n, rel=1e-12)
        # the whole load on chamber + material is -(F + F_d); P_diss = -M . w - F_d . v_rel
        assert np.allclose([o.Fx, o.Fy, o.Fz], -(F_ref + F_d), rtol=1e-11, atol=1e-11)
        M = -ball.rolling_resistance * (-F_ref @ n) * u
        assert o.P_diss == pytest.approx(-(M @ w) - F_d @ (d * nd), rel=1e-11)


def test_ball_at_rest_at_the_bottom_stays_at_rest():
    model = BallModel(BALL.with_(rolling_resistance=1e-3, drag=0.5))
    tr = simulate(model, Fixed(), 2.0, 0.1)
    assert tr.success
    assert np.all(tr.y == model.initial().y)  # exactly: the regularised moment vanishes at w_t = 0
    assert np.all(tr["P_diss"] == 0.0)


# -- rolling resistance: a fixed loss of amplitude per half swing ----------------
def _turning_amplitudes(tr):
    """|theta| at the turning points of a swing in the x-z plane (parabola through
    the three samples around each maximum of |theta|)."""
    th = np.abs(np.arctan2(tr.y[:, 0], -tr.y[:, 2]))
    out = []
    for k in range(1, len(th) - 1):
        if th[k] >= th[k - 1] and th[k] > th[k + 1]:
            y0, y1, y2 = th[k - 1], th[k], th[k + 1]
            x = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
            out.append(y1 - 0.25 * (y0 - y2) * x)
    return np.array(out)


@pytest.mark.parametrize("delta", [2.5e-4, 1.25e-4])
def test_rolling_resistance_swing_loses_the_predicted_amplitude(delta):
    """Energy argument. Between two turning points (at rest, angles theta_A, theta_B)
    the potential energy lost, m g d (cos theta_B - cos theta_A), is the work of the
    rolling resistance, int delta N |w_t| dt = (delta d / r) int N dtheta (rolling:
    r |w_t| = d |theta'|). To first order in delta, N along the half swing is the
    lossless one, N = m g (17 cos theta - 10 cos theta_m) / 7 for amplitude theta_m,
    so int N dtheta = m g (34 sin theta_m - 20 theta_m cos theta_m) / 7 and

        theta_A - theta_B = (delta / r) (34/7 - 20/7 theta_m cot theta_m),

    2 delta / r for small swings (a Coulomb-damped oscillator). Taking theta_m as the
    mean of theta_A and theta_B, the neglected terms are of relative order
    (delta / r)^2: tolerance (delta / r)^2 (the deviation found is 0.32 (delta/r)^2
    and quarters when delta halves, as second-order terms do). The small-swing value
    2 delta / r would be 4 % off at this amplitude."""
    ball = BALL.with_(rolling_resistance=delta)
    model = BallModel(ball, tol=1e-11)
    th0 = 0.3
    tr = simulate(model, Fixed(), 3.0, 2e-4, state=model.initial(xC0=ball.d * math.sin(th0)), outputs=False)
    A = np.r_[th0, _turning_amplitudes(tr)]
    assert len(A) >= 6
    loss = -np.diff(A)
    mean = 0.5 * (A[:-1] + A[1:])
    expected = delta / ball.r * (34 / 7 - 20 / 7 * mean / np.tan(mean))
    assert np.max(np.abs(loss / expected - 1.0)) < (delta / ball.r) ** 2
    assert np.max(np.abs(loss / (2 * delta / ball.r) - 1.0)) > 0.03  # the amplitude term matters


# -- viscous drag: the damping ratio of the linearised equation --------------------
def test_viscous_drag_log_decrement():
    """Planar, linearised: (1 + kappa) m d theta'' = -m g theta - c d theta' (the drag
    -c v_C,rel acts on the centre, v_C,rel = d theta'), so theta'' + 2 zeta w0 theta'
    + w0^2 theta = 0 with w0^2 = g / ((1 + kappa) d), zeta = c / (2 (1 + kappa) m w0).
    Log decrement between successive maxima 2 pi zeta / sqrt(1 - zeta^2), period
    2 pi / (w0 sqrt(1 - zeta^2)). Amplitude 0.02 rad: the neglected sin(theta) - theta
    terms are of relative order theta^2 / 8 = 5e-5; tolerance 2e-4."""
    zeta = 0.05
    c = 2 * zeta * (1 + BALL.inertia_factor) * BALL.m * BALL.omega_small
    ball = BALL.with_(drag=c)
    model = BallModel(ball, tol=1e-11)
    th0, dt = 0.02, 1e-3
    tr = simulate(model, Fixed(), 5.0, dt, state=model.initial(xC0=ball.d * math.sin(th0)))
    th = np.arctan2(tr.y[:, 0], -tr.y[:, 2])
    peaks, times = [], []
    for k in range(1, len(th) - 1):
        if th[k] > th[k - 1] and th[k] >= th[k + 1]:
            y0, y1, y2 = th[k - 1], th[k], th[k + 1]
            x = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
            peaks.append(y1 - 0.25 * (y0 - y2) * x)
            times.append(tr.t[k] + x * dt)
    assert len(peaks) >= 4
    lam_meas = np.log(np.array(peaks[:-1]) / np.array(peaks[1:]))
    lam_ref = 2 * math.pi * zeta / math.sqrt(1 - zeta ** 2)
    assert np.max(np.abs(lam_meas / lam_ref - 1.0)) < 2e-4
    period = 2 * math.pi / (ball.omega_small * math.sqrt(1 - zeta ** 2))
    assert np.max(np.abs(np.diff(times) / period - 1.0)) < 2e-4
    # the dissipated power is c |v_C,rel|^2, and the energy goes exactly there
    E = np.array([model.energy(type(model.initial())(t, y)) for t, y in zip(tr.t, tr.y)])
    v2 = np.array([np.sum((ball.d * ball.lam * np.cross(y[:3], y[3:])) ** 2) for y in tr.y])
    assert np.allclose(tr["P_diss"], c * v2, rtol=1e-12, atol=1e-15)
    W = np.concatenate([[0.0], np.cumsum(0.5 * (tr["P_diss"][1:] + tr["P_diss"][:-1]) * dt)])
    assert np.max(np.abs(E[0] - E - W)) < 1e-5 * (E[0] - E[-1])  # trapezoid's error, O(dt^2)


# -- the damped steady orbit in a chamber moving on a circle ------------------------
def steady_orbit(ball, l, W):
    """(alpha, beta) of the steady orbit: n = (sin a cos(Wt + b), sin a sin(Wt + b), -cos a).

    With the spin zero (it is conserved, and the ball starts at rest), rolling gives
    omega = (W / lambda) (n_z n - z), omega' = (W^2 n_z / lambda) z x n, and n' x omega
    is parallel to n. The equation for omega' then reduces to
        n x (a_O + G z) + D (z - n_z n) = 0,  G = g - W^2 d (1 + kappa) cos a,
        D = c d W / m + delta N / (m r sin a),  N = m (d W^2 sin^2 a + W^2 l sin a cos b + g cos a),
    with a_O = -W^2 l (cos Wt, sin Wt, 0). Its components along (cos Wt, sin Wt, 0) and z:
        sin b G + D cos a cos b = 0,   W^2 l sin b + D sin a = 0."""
    m, d, r, g, kap, c, delta = ball.m, ball.d, ball.r, ball.g, ball.inertia_factor, ball.drag, \
        ball.rolling_resistance

    def eqs(x):
        a, b = x
        s, ca = math.sin(a), math.cos(a)
        G = g - W ** 2 * d * (1 + kap) * ca
        N = m * (d * W ** 2 * s * s + W ** 2 * l * s * math.cos(b) + g * ca)
        D = c * d * W / m + delta * N / (s * m * r)
        return [math.sin(b) * G + D * ca * math.cos(b), math.sin(b) * W ** 2 * l + D * s]

    sol, info, ok, msg = fsolve(eqs, [0.03, -0.3], xtol=1e-14, full_output=True)
    assert ok == 1, msg
    return sol


@pytest.mark.parametrize("delta", [0.0, 2e-5])
def test_damped_steady_orbit_on_a_circle(delta):
    """Chamber on a circle of l = 10 mm at W = 4 rad/s (below the ball's resonance
    5.58 rad/s), drag with zeta = 0.2: after the transient (decays as exp(-zeta w0 t),
    1e-10 by t = 20 s) the ball runs on a circle of constant tilt alpha, lagging the
    platform by -beta. Tolerance 1e-6 relative: the regularisation changes the rolling
    moment by (eps / |w_t|)^2 / 2 = 5e-7 here (|w_t| = 1 rad/s)."""
    zeta = 0.2
    c = 2 * zeta * (1 + BALL.inertia_factor) * BALL.m * BALL.omega_small
    ball = BALL.with_(drag=c, rolling_resistance=delta)
    l, W = 0.01, 4.0
    alpha, beta = steady_orbit(ball, l, W)
    assert 0.0 < alpha < 0.1 and -math.pi / 2 < beta < 0.0  # below resonance: a lag under 90 deg
    motion = Circle(l=l, w=W)
    model = BallModel(ball, tol=1e-11)
    tr = simulate(model, motion, 25.0, 0.05)
    last = tr.t > 22.0
    n = tr.y[last, :3]
    a_sim = np.arccos(-n[:, 2])
    b_sim = np.angle(np.exp(1j * (np.arctan2(n[:, 1], n[:, 0]) - W * tr.t[last])))
    assert np.max(np.abs(a_sim / alpha - 1.0)) < 1e-6
    assert np.max(np.abs(b_sim / beta - 1.0)) < 1e-6
    # radius of the ring of contact points, R sin(alpha)
    rho = np.hypot(tr["xP"][last], tr["yP"][last])
    assert np.max(np.abs(rho / (ball.R * math.sin(alpha)) - 1.0)) < 1e-6
    # steady state: the power the chamber gives the ball is what the ground material takes
    x, y, vx, vy, _, _ = zip(*(motion.state(t) for t in tr.t[last]))
    p_in = -(tr["Fx"][last] * np.array(vx) + tr["Fy"][last] * np.array(vy))
    assert np.allclose(p_in, tr["P_diss"][last], rtol=1e-6)
    if delta:  # the rolling resistance changes the orbit (more lag) beyond the tolerance
        a0, b0 = steady_orbit(ball.with_(rolling_resistance=0.0), l, W)
        assert abs(b0 / beta - 1.0) > 1e-2 and abs(a0 / alpha - 1.0) > 1e-2
