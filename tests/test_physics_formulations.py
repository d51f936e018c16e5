"""The vector and the paper formulation (closed form and Cramer's rule) agree;
the paper formulation refuses the equator with a clear message, never NaNs."""
import math

import numpy as np
import pytest

from ballmill.physics import (Ball, BallModel, CrankStartup, Fixed, FormulationLimitError,
                              PaperFormulation, ParameterError, VectorFormulation,
                              omega_dot_cramer, simulate)

BALL = Ball()


def contact_points(traj):
    return np.column_stack([traj["xP"], traj["yP"], traj["zP"]])


# --------------------------------------------------------------------------
# 5. agreement where both are valid
@pytest.fixture(scope="module")
def fast_start_runs():
    runs = {}
    for key, form, opts in (("vector", "vector", {}), ("paper", "paper", {}),
                            ("cramer", "paper", {"cramer": True})):
        model = BallModel(BALL, form, tol=1e-10, **opts)
        # dt = 0.05 s is coarser than DOP853's step here, so the tolerance (not
        # the output grid) sets the steps: the comparison sees the tolerance.
        runs[key] = simulate(model, CrankStartup(t0=2.5), t_end=10.0, dt=0.05)
    return runs


def test_fast_start_valid_for_both(fast_start_runs):
    for key, traj in fast_start_runs.items():
        assert traj.success, (key, traj.message)
        assert traj.t[-1] == pytest.approx(10.0)
        assert np.all(np.isfinite(traj.y))
    # the fast start lifts the ball high up the wall (zP up to 0.24 m of R = 0.25 m):
    # the comparison covers nearly the whole lower hemisphere
    assert fast_start_runs["vector"]["zP"].max() > 0.2


def test_formulations_agree_on_contact_point(fast_start_runs):
    P_vec = contact_points(fast_start_runs["vector"])
    P_pap = contact_points(fast_start_runs["paper"])
    P_cra = contact_points(fast_start_runs["cramer"])
    # Independent coordinates, independently integrated at tol 1e-10: each run's
    # global error is ~ (steps ~ 400) x (local error ~ tol x 0.225 m) <= 1e-8 m
    # (measured difference 7e-10 m; at tol 1e-8 it grows to 1e-8 m).
    assert np.abs(P_vec - P_pap).max() < 1e-7
    # Cramer's rule and the closed form give the same omega' up to round-off
    # (~1e-15 relative), the same step sequence, so the runs agree to ~1e-13 m.
    assert np.abs(P_pap - P_cra).max() < 1e-11
    # and the motion is not trivial: the contact point travels over ~0.5 m
    assert np.ptp(P_vec[:, 0]) > 0.3


def test_cramer_equals_closed_form_at_random_states():
    rng = np.random.default_rng(20240501)
    closed = PaperFormulation(BALL)
    d = BALL.d
    for _ in range(200):
        rho = d * math.sqrt(rng.uniform(0.0, 0.99))  # up to ~6 deg below the equator
        phi = rng.uniform(0, 2 * math.pi)
        xC, yC = rho * math.cos(phi), rho * math.sin(phi)
        w = rng.normal(scale=30.0, size=3)
        ax, ay = rng.normal(scale=20.0, size=2)
        wd_cramer = np.array(omega_dot_cramer(BALL, xC, yC, *w, ax, ay))
        wd_closed = np.array(closed.derivative([xC, yC, *w], ax, ay)[2:])
        # both are O(1e2..1e4) rad/s2 sums of products; determinants add a few
        # ulps per term: 1e-12 of the magnitude is round-off with a margin
        scale = np.abs(wd_closed).max()
        assert np.abs(wd_cramer - wd_closed).max() <= 1e-12 * scale, (xC, yC, w, ax, ay)


def test_paper_and_vector_derivatives_agree_pointwise():
    rng = np.random.default_rng(7)
    vec, pap = VectorFormulation(BALL), PaperFormulation(BALL)
    for _ in range(50):
        n = rng.normal(size=3)
        n[2] = -abs(n[2]) - 0.1
        n /= np.linalg.norm(n)
        w = rng.normal(scale=20.0, size=3)
        ax, ay = rng.normal(scale=10.0, size=2)
        dv = np.array(vec.derivative([*n, *w], ax, ay))
        dp = np.array(pap.derivative([BALL.d * n[0], BALL.d * n[1], *w], ax, ay))
        # (xC', yC') = d (n_x', n_y'); omega' identical
        np.testing.assert_allclose(dp[:2], BALL.d * dv[:2], rtol=1e-12, atol=1e-12 * np.abs(dv).max())
        np.testing.assert_allclose(dp[2:], dv[3:], rtol=1e-12, atol=1e-12 * np.abs(dv).max())


# --------------------------------------------------------------------------
# 6. the paper formulation stops before the equator, with a clear message
def assert_clear_limit_message(msg):
    assert "equator" in msg and "vector" in msg, msg
    assert "nan" not in msg.lower()


LIMIT_CASES = {
    # fixed chamber, released at 64 deg from the bottom with a push up the wall
    # (2 m/s: far more than the 1.2 m/s needed to reach the equator)
    "fixed-push": (Fixed(), dict(xC0=0.9 * BALL.d, w0=(0.0, 80.0, 0.0)), 2.0),
    # a crank start twice as fast as the paper's, to a higher speed
    "crank-n90-t1": (CrankStartup(n0=90, t0=1.0), dict(), 3.0),
}


@pytest.mark.parametrize("case", sorted(LIMIT_CASES))
def test_paper_formulation_stops_before_equator(case):
    motion, init, t_end = LIMIT_CASES[case]
    paper = BallModel(BALL, "paper", tol=1e-10)
    traj = simulate(paper, motion, t_end, 0.01, state=paper.initial(**init))
    assert traj.success is False
    assert traj.message.startswith("stopped at t = ")
    assert_clear_limit_message(traj.message)
    assert traj.t[-1] < t_end
    # never a NaN, and every recorded state is below the equator
    assert np.all(np.isfinite(traj.y))
    for name in ("xP", "yP", "zP", "N", "Fx", "Fy", "Fz", "M_reaction"):
        assert np.all(np.isfinite(traj[name])), name
    assert np.all(traj["zC"] < BALL.R)
    # ... and outside the formulation's safety margin (default: R - zC >= 0.02 d,
    # the ball's centre more than 1.15 deg below the equator), which is where
    # the paper's coordinates are still well conditioned
    assert np.all(BALL.R - traj["zC"] >= 0.02 * BALL.d)
    # the vector formulation runs the same case through, past the equator
    vec = BallModel(BALL, "vector", tol=1e-10)
    traj_v = simulate(vec, motion, t_end, 0.01, state=vec.initial(**init))
    assert traj_v.success, traj_v.message
    assert traj_v.t[-1] == pytest.approx(t_end)
    assert np.all(np.isfinite(traj_v.y))
    assert traj_v["zC"].max() > BALL.R  # it does cross the equator
    # up to where the paper formulation stopped both describe the same motion
    # (tol 1e-10, < 60 steps: ~1e-11 m measured; 1e-8 m allows for the steep
    # coordinates of the paper formulation near the equator)
    k = len(traj.t)
    assert np.abs(contact_points(traj) - contact_points(traj_v)[:k]).max() < 1e-8


def test_paper_advance_raises_limit_error_and_keeps_state():
    model = BallModel(BALL, "paper", tol=1e-10)
    state = model.initial(xC0=0.9 * BALL.d, w0=(0.0, 80.0, 0.0))
    y0 = state.y.copy()
    with pytest.raises(FormulationLimitError) as exc:
        model.advance(state, 1.0, Fixed().accel)
    assert_clear_limit_message(str(exc.value))
    assert np.array_equal(state.y, y0) and state.t == 0.0


def test_paper_refuses_a_start_at_the_equator():
    model = BallModel(BALL, "paper")
    with pytest.raises(ParameterError) as exc:
        model.initial(xC0=BALL.d * 0.99999)
    assert_clear_limit_message(str(exc.value))
    # the vector formulation takes it
    BallModel(BALL, "vector").initial(xC0=BALL.d * 0.99999)
