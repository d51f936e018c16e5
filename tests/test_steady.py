"""The quasi-static calculator (ballmill.physics.steady) against simulation, the start-up
laws, and the d-only dependence of a ball started without spin."""
import math

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, Circle, CrankStartup, simulate
from ballmill.physics.drives.crank import LAWS
from ballmill.physics.steady import equilibrium, limits

M_PAPER = 0.5105088062083415
BALL = Ball(m=M_PAPER)


def _start_at(eq, ball=BALL, perturb=None, tol=1e-12):
    model = BallModel(ball, tol=tol)
    n, om = np.array(eq.n), np.array(eq.omega)
    if perturb is not None:
        n = n + perturb[:3]
        n /= np.linalg.norm(n)
        om = om + perturb[3:]
    return model, model.initial(ball.d * n[0], ball.d * n[1], tuple(om))


def _theta(tr, ball=BALL):
    return np.degrees(np.arctan2(np.hypot(tr["xC"], tr["yC"]), ball.R - tr["zC"]))


def test_anchors():
    eq = equilibrium(BALL, 0.5, 60.0)
    assert eq.theta_deg == pytest.approx(72.761777, abs=1e-6)
    assert eq.N == pytest.approx(15.244943, abs=1e-6)
    assert eq.ring_frequencies == pytest.approx((11.388, 7.170), abs=1e-3)
    assert eq.rolling and eq.friction_ratio < BALL.mu
    # the lossless ball sits in the crank's vertical plane: no torque on the crank
    assert abs(eq.phi_deg) < 1e-9 and abs(eq.M_reaction) < 1e-9
    assert eq.rho_P == pytest.approx(BALL.R * math.sin(math.radians(eq.theta_deg)), rel=1e-12)


def test_equilibrium_is_a_solution_of_the_equations_of_motion():
    """Started exactly at the relative equilibrium, the simulated ball keeps its polar
    angle and N for 20 s (4 x 20 crank turns would show any drift)."""
    eq = equilibrium(BALL, 0.5, 60.0)
    model, st = _start_at(eq)
    tr = simulate(model, Circle(0.5, 2 * math.pi), 20.0, 0.01, state=st)
    assert tr.success
    assert np.abs(_theta(tr) - eq.theta_deg).max() < 1e-7
    assert np.abs(tr["N"] - eq.N).max() < 1e-7
    assert np.abs(tr["friction_ratio"] - eq.friction_ratio).max() < 1e-8


def test_ring_frequencies_against_simulation():
    """A small perturbation oscillates at the two computed frequencies: theta(t) - theta_e
    (the polar angle does not depend on the turning frame) is fitted by two sinusoids at
    exactly those frequencies, and clearly worse by ones 1 % off."""
    eq = equilibrium(BALL, 0.5, 60.0)
    rng = np.random.default_rng(1)
    dy = 1e-5 * rng.standard_normal(6)
    dy[3:] *= 10.0
    model, st = _start_at(eq, perturb=dy)
    tr = simulate(model, Circle(0.5, 2 * math.pi), 12.0, 0.005, state=st)
    x = _theta(tr) - eq.theta_deg
    t = tr.t

    def misfit(freqs):
        A = np.column_stack([f(w * t) for w in freqs for f in (np.cos, np.sin)] + [np.ones_like(t)])
        coef, *_ = np.linalg.lstsq(A, x, rcond=None)
        return np.abs(A @ coef - x).max() / np.abs(x).max()

    w1, w2 = eq.ring_frequencies
    good = misfit((w1, w2))
    assert good < 2e-3  # what is left is the nonlinearity (amplitude ~1e-4 rad)
    assert misfit((1.01 * w1, w2)) > 10 * good and misfit((w1, 1.01 * w2)) > 10 * good


def test_slow_start_settles_near_the_equilibrium():
    eq = equilibrium(BALL, 0.5, 60.0)
    tr = simulate(BallModel(BALL, method="RK4", h_fixed=0.005), CrankStartup(0.5, 60.0, 30.0), 40.0, 0.01)
    late = tr.t >= 30.0
    th = _theta(tr)[late]
    assert abs(0.5 * (th.max() + th.min()) - eq.theta_deg) < 0.1
    assert th.max() - th.min() < 2.0  # docs/usage.md: ring 0.2376 - 0.2399 m (71.9 - 73.6 deg) after a 30 s start
    assert abs(np.mean(tr["N"][late]) - eq.N) < 0.1


def test_limits_on_the_branch():
    lim = limits(BALL, 0.5, n_max=120.0, dn=4.0)
    # the paper's mill: rolling and contact hold at every steady speed; the friction ratio peaks
    assert lim["rolling_lost_n0"] is None and lim["contact_lost_n0"] is None
    peak = lim["friction_ratio_peak"]
    assert 0.03 < peak < 0.06
    # with mu below that peak, rolling is lost at the speed where friction_ratio = mu
    slippery = BALL.with_(mu=0.6 * peak)
    n_lost = limits(slippery, 0.5, n_max=120.0, dn=4.0)["rolling_lost_n0"]
    assert n_lost is not None
    assert equilibrium(slippery, 0.5, n_lost).friction_ratio == pytest.approx(slippery.mu, rel=1e-6)
    assert equilibrium(slippery, 0.5, n_lost * 0.98).rolling and not equilibrium(slippery, 0.5, n_lost * 1.02).rolling


def test_calculator_refuses_bad_input():
    from ballmill.physics import ParameterError

    with pytest.raises(ParameterError, match="n0"):
        equilibrium(BALL, 0.5, -1.0)
    with pytest.raises(ParameterError, match="l must"):
        equilibrium(BALL, float("nan"), 60.0)


# ----------------------------------------------------------------------------
def test_motion_depends_on_r_only_through_d_and_N_scales_with_m():
    """With u = r omega the equations read n' = (1/d) n x u, u' = n x (a - g + n' x u) / (1 + I/(m r^2)):
    r and m are gone. Two balls with the same d = R - r and no initial spin follow the same
    n(t); N and the forces scale with m; the contact point scales with R."""
    a = Ball(r=0.025, R=0.25, m=M_PAPER)
    b = Ball(r=0.06, R=0.285, m=3.0)  # d = 0.225 m as well
    drive = CrankStartup(0.5, 60.0, 2.5)
    ta = simulate(BallModel(a, tol=1e-12), drive, 10.0, 0.01)
    tb = simulate(BallModel(b, tol=1e-12), drive, 10.0, 0.01)
    na = np.column_stack([ta["xC"], ta["yC"], ta["zC"] - a.R]) / a.d
    nb = np.column_stack([tb["xC"], tb["yC"], tb["zC"] - b.R]) / b.d
    assert np.abs(na - nb).max() < 1e-8
    assert np.abs(ta["N"] / a.m - tb["N"] / b.m).max() < 1e-7
    assert np.abs(ta["M_reaction"] / a.m - tb["M_reaction"] / b.m).max() < 1e-7
    assert np.abs(ta["zP"] / a.R - tb["zP"] / b.R).max() < 1e-8
    # a ball of another d moves differently
    c = simulate(BallModel(Ball(r=0.06, R=0.25, m=M_PAPER), tol=1e-12), drive, 10.0, 0.01)
    assert np.abs(c["zC"] - ta["zC"]).max() > 1e-3


# ----------------------------------------------------------------------------
@pytest.mark.parametrize("law", LAWS)
def test_start_laws(law):
    d = CrankStartup(0.5, 60.0, 2.5, law)
    w0 = d.w0
    # continuous at t0 in psi and psi', w0 reached, at rest at 0
    assert d.angle(0.0)[:2] == pytest.approx((0.0, 0.0), abs=1e-15)
    below, above = d.angle(2.5 - 1e-9), d.angle(2.5 + 1e-9)
    assert below[0] == pytest.approx(above[0], abs=2e-8) and below[1] == pytest.approx(w0, abs=1e-7)
    # psi' and psi'' are the derivatives of psi and psi'
    for t in (0.3, 1.1, 2.2, 4.0):
        e = 1e-6
        p0, pp, pm = d.angle(t), d.angle(t + e), d.angle(t - e)
        assert (pp[0] - pm[0]) / (2 * e) == pytest.approx(p0[1], abs=1e-6)
        assert (pp[1] - pm[1]) / (2 * e) == pytest.approx(p0[2], abs=1e-6)
    # the array form is the scalar one
    t = np.linspace(-0.5, 6.0, 301)
    ref = np.array([d.angle(x) for x in t]).T
    assert np.allclose(np.array(d.angles(t)), ref, rtol=0, atol=1e-12)
    if law in ("scurve", "quintic"):  # zero acceleration at both ends
        assert d.angle(0.0)[2] == 0.0 and abs(d.angle(2.5)[2]) < 1e-12


@pytest.mark.parametrize("law", LAWS)
def test_start_laws_in_the_kernel_are_bit_identical(law):
    from ballmill.physics import KERNEL_AVAILABLE

    if not KERNEL_AVAILABLE:
        pytest.skip("compiled kernel not built")
    d = CrankStartup(0.5, 60.0, 2.5, law)
    a = simulate(BallModel(BALL, method="RK4", h_fixed=0.01), d, 10.0, 0.01, kernel="c")
    b = simulate(BallModel(BALL, method="RK4", h_fixed=0.01), d, 10.0, 0.01, kernel="python")
    assert np.array_equal(a.y, b.y) and np.array_equal(a["N"], b["N"])


def test_s_curve_start_cuts_the_N_swing():
    """The S-curve (zero acceleration at both ends) against the paper's quadratic rise
    at t0 = 2.5 s: the variation of N after t0 drops from 8.48 N to about 6.4 N."""
    def swing(law):
        tr = simulate(BallModel(BALL, method="RK4", h_fixed=0.002), CrankStartup(0.5, 60.0, 2.5, law), 10.0, 0.002)
        late = tr.t >= 2.5
        return np.ptp(tr["N"][late])
    assert swing("quadratic") == pytest.approx(8.48, abs=0.01)
    assert swing("scurve") == pytest.approx(6.42, abs=0.02)


def test_law_is_checked():
    from ballmill.physics import ParameterError

    with pytest.raises(ParameterError, match="law must be one of"):
        CrankStartup(law="cubic")
