"""Order of accuracy of every integrator, on both paths, under a moving chamber.

With a fixed chamber the right-hand side does not depend on t, so the stage times
(the nodes c of a tableau) do not matter and a wrong node goes unseen; here the
platform moves (the crank law before t0, a two-axis harmonic shaking, and the BallInShell
FMU's cubic input reconstruction), and each method must show its order:

* the tableaus themselves: the order conditions of every rooted tree up to the method's
  order (and a residual at the next one), the nodes as row sums of A, and the error
  weights vanishing up to the embedded estimator's order;
* fixed steps h, h/2, h/4 (RK4 with ``h_fixed``; DOP853 and RK45 with ``h_max = h`` and a
  tolerance loose enough that every step is accepted, which the step counts confirm):
  the error against an independent reference (scipy's solve_ivp, DOP853 at rtol 1e-13)
  falls by 2^p per halving, in Python and in the compiled kernel;
* adaptive steps: the error follows the tolerance on the moving chamber;
* fixed steps across the material bed's surface: a run whose contact point crosses the
  band where the ground material's resistance blends in, and leaves the bed.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ballmill.physics import (KERNEL_AVAILABLE, KERNEL_REASON, Ball, BallModel, CrankStartup, Harmonic,
                              InputReconstruction, simulate)
from ballmill.physics.integrators import TABLEAUS

BALL = Ball()
# the crank law is smooth (polynomial in t inside cos/sin) for t < t0: the run stays before it
CRANK = CrankStartup(l=0.5, n0=60.0, t0=2.5)
SHAKE = Harmonic(x_amp=0.02, x_omega=9.0, y_amp=0.015, y_omega=6.5, x_phase=0.3, y_phase=-1.1)
MOTIONS = {"crank": CRANK, "harmonic": SHAKE}
T_END = 1.0
ORDER = {"RK4": 4, "RK45": 5, "DOP853": 8}
# step sizes in the asymptotic range of each method, with errors far above the reference's
# (~1e-13) and round-off: measured errors 7.5e-3 .. 5e-6 (RK4), 2.2e-6 .. 9e-10 (RK45),
# 3.4e-6 .. 5.8e-12 (DOP853)
STEPS = {"RK4": (0.04, 0.02, 0.01), "RK45": (0.025, 0.0125, 0.00625), "DOP853": (0.1, 0.05, 0.025)}
PATHS = ["python", pytest.param("c", marks=pytest.mark.skipif(
    not KERNEL_AVAILABLE, reason=f"compiled kernel unavailable: {KERNEL_REASON}"))]


def start(model):
    """A non-planar swing with spin, away from the bottom."""
    return model.initial(xC0=0.06, yC0=0.03, w0=(2.0, -1.0, 5.0))


def reference(accel) -> np.ndarray:
    """y(T_END) by scipy's own DOP853 at rtol 1e-13 (an implementation independent of ours)."""
    m = BallModel(BALL)
    r = solve_ivp(m.rhs(accel), (0.0, T_END), start(m).y, method="DOP853", rtol=1e-13, atol=1e-14)
    assert r.success
    return r.y[:, -1]


_REFS: dict = {}


def ref_of(name, accel):
    if name not in _REFS:
        _REFS[name] = reference(accel)
    return _REFS[name]


def fixed_step_model(method, h, kernel="auto"):
    if method == "RK4":
        return BallModel(BALL, method="RK4", h_fixed=h, kernel=kernel)
    # tol 0.1 (the largest allowed): every step of size h is accepted, so the run takes
    # exactly T/h steps of the propagating method
    return BallModel(BALL, method=method, tol=0.1, h_max=h, kernel=kernel)


def assert_order(errors, p, what):
    ratios = [errors[i] / errors[i + 1] for i in range(len(errors) - 1)]
    # 2^p per halving; the bounds 2^(p - 0.75) .. 2^(p + 0.6) hold the pre-asymptotic ratios
    # measured here (RK45 20.9 = 2^4.4 at its largest step, DOP853 296 = 2^8.2) and exclude
    # p - 1 and p + 1 (a method one order lower fails, and so does one with a wrong node: 2^1)
    for r in ratios:
        assert 2 ** (p - 0.75) < r < 2 ** (p + 0.6), (what, errors, ratios)


# ---------------------------------------------------------------------------
# the tableaus against the order conditions (Butcher's rooted trees)
@lru_cache(None)
def trees(n: int) -> tuple:
    """All rooted trees with n nodes, each a sorted tuple of its subtrees."""
    if n == 1:
        return ((),)
    grown = set()
    for t in trees(n - 1):
        grown.update(_grow(t))
    return tuple(sorted(grown))


def _grow(t):
    """t with one leaf added at each of its nodes."""
    yield tuple(sorted(t + ((),)))
    for i, child in enumerate(t):
        for g in _grow(child):
            yield tuple(sorted(t[:i] + (g,) + t[i + 1:]))


def size(t) -> int:
    return 1 + sum(size(c) for c in t)


def density(t) -> int:
    """gamma(t): the tree's size times the densities of its subtrees."""
    g = size(t)
    for c in t:
        g *= density(c)
    return g


def stage_weights(t, A) -> np.ndarray:
    """The vector whose dot product with b is t's elementary weight (leaf: all ones)."""
    v = np.ones(A.shape[0])
    for c in t:
        v = v * (A @ stage_weights(c, A))
    return v


def residual(A, b, p) -> float:
    """The largest |b . Phi(t) - 1/gamma(t)| over the trees of size p."""
    return max(abs(float(b @ stage_weights(t, A)) - 1.0 / density(t)) for t in trees(p))


def test_tree_counts():
    # the number of rooted trees of each size (OEIS A000081): 200 conditions for order 8
    assert [len(trees(n)) for n in range(1, 9)] == [1, 1, 2, 4, 9, 20, 48, 115]
    assert {density(t) for t in trees(3)} == {3, 6}


@pytest.mark.parametrize("method", list(TABLEAUS))
def test_tableau_satisfies_the_order_conditions(method):
    tab = TABLEAUS[method]
    A, b, c, p = tab.A, tab.B, tab.C, ORDER[method]
    # nodes: the stage times are the row sums of A (a wrong node breaks order 2 at t-dependence)
    np.testing.assert_allclose(c, A.sum(axis=1), rtol=0, atol=1e-15)
    # A strictly lower triangular (explicit)
    assert np.all(np.triu(A) == 0.0)
    for q in range(1, p + 1):
        assert residual(A, b, q) < 1e-13, (method, q, residual(A, b, q))
    # and no more: the method is exactly of order p (DOP853's order-9 residual is 2.7e-5)
    assert residual(A, b, p + 1) > 1e-6


@pytest.mark.parametrize("method, name, q", [("RK45", "E", 4), ("DOP853", "E", 5), ("DOP853", "E3", 3)])
def test_error_weights_are_an_embedded_estimate(method, name, q):
    """The error weights (on the stages plus the FSAL stage f(t + h, y_new)) are b - b_hat
    with b_hat of order q: they annihilate every tree up to size q and not at q + 1."""
    tab = TABLEAUS[method]
    n = tab.n_stages
    E = getattr(tab, name)
    assert E.shape == (n + 1,)
    Ae = np.zeros((n + 1, n + 1))  # the FSAL stage is the step's result: row b
    Ae[:n, :n] = tab.A
    Ae[n, :n] = tab.B
    for k in range(1, q + 1):
        worst = max(abs(float(E @ stage_weights(t, Ae))) for t in trees(k))
        assert worst < 1e-13, (method, name, k, worst)
    assert max(abs(float(E @ stage_weights(t, Ae))) for t in trees(q + 1)) > 1e-5
    # the controller's exponent is -1/tab.order: RK45 5 (its estimate is O(h^5)); DOP853 8
    # (scipy's choice for its combined 5th/3rd-order estimate)
    assert tab.order == {"RK45": 5, "DOP853": 8}[method]


# ---------------------------------------------------------------------------
# fixed steps under a moving chamber: monolithic runs (simulate), Python and kernel
@pytest.mark.parametrize("kernel", PATHS)
@pytest.mark.parametrize("method", list(ORDER))
@pytest.mark.parametrize("motion", list(MOTIONS))
def test_fixed_step_order_under_a_moving_chamber(motion, method, kernel):
    mot = MOTIONS[motion]
    ref = ref_of(motion, mot.accel)
    errors = []
    for h in STEPS[method]:
        m = fixed_step_model(method, h)
        s = start(m)
        s.h = h
        tr = simulate(m, mot, T_END, T_END, state=s, outputs=False, kernel=kernel)
        assert tr.success
        # the step counts show that h was the step: no rejection, T/h steps
        assert (m.info.steps, m.info.rejected) == (round(T_END / h), 0)
        errors.append(float(np.max(np.abs(tr.y[-1] - ref))))
    assert_order(errors, ORDER[method], (motion, method, kernel))


# the FMU's path: BallModel.advance with InputReconstruction's cubic closure (in the kernel
# when it is there: fast.advance, the motion BM_POLY)
def cubic_input():
    rec = InputReconstruction()
    rec.push(0.0, *CRANK.state(0.0))
    rec.push(T_END, *CRANK.state(T_END))
    return rec.accel_function()


@pytest.mark.parametrize("kernel", PATHS)
@pytest.mark.parametrize("method", list(ORDER))
def test_fixed_step_order_with_the_fmus_cubic_input(method, kernel):
    accel = cubic_input()
    assert hasattr(accel, "poly")  # the kernel's case
    ref = ref_of("cubic", accel)
    errors = []
    for h in STEPS[method]:
        m = fixed_step_model(method, h, kernel=kernel)
        s = start(m)
        s.h = h
        out = m.advance(s, T_END, accel)
        assert (m.info.steps, m.info.rejected) == (round(T_END / h), 0)
        errors.append(float(np.max(np.abs(out.y - ref))))
    assert_order(errors, ORDER[method], (method, kernel))


# ---------------------------------------------------------------------------
# adaptive steps under a moving chamber
@pytest.mark.parametrize("kernel", PATHS)
@pytest.mark.parametrize("method", ["DOP853", "RK45"])
@pytest.mark.parametrize("motion", list(MOTIONS))
def test_adaptive_error_follows_the_tolerance_under_a_moving_chamber(motion, method, kernel):
    mot = MOTIONS[motion]
    ref = ref_of(motion, mot.accel)
    w_scale = BALL.d * BALL.omega_small / BALL.r  # the scale of the angular velocity states
    errs = {}
    for tol in (1e-6, 1e-9):
        m = BallModel(BALL, method=method, tol=tol)
        tr = simulate(m, mot, T_END, T_END, state=start(m), outputs=False, kernel=kernel)
        assert tr.success
        errs[tol] = float(np.max(np.abs(tr.y[-1] - ref)))
    # the tolerance is relative to each state's scale (1 for n, ~50 rad/s for omega): the
    # global error over this 1 s stays within 10 tol of that scale and falls with it (by
    # more than 100x for a 1000x tighter tolerance)
    for tol, err in errs.items():
        assert err < 10 * tol * w_scale, (tol, errs)
    assert errs[1e-9] < errs[1e-6] / 100, errs
    assert math.isfinite(errs[1e-9]) and errs[1e-9] > 0.0


# ---------------------------------------------------------------------------
# across the material bed's surface: the resistance's share (equations.bed_share) blends
# from 0 at the surface to 1 at w_bed below it, C-infinity, so every method keeps its order
# on a run whose contact point crosses the band and leaves the bed. Drag alone: the rolling
# resistance's regularisation has a relaxation time of its own ((I + m r^2) eps / (delta N))
# that a fixed step must resolve, unrelated to the bed.
BED_BALL = Ball(drag=2.0, bed_depth=0.05, bed_band=0.05)
# the band must be resolved: the contact point crosses its 50 mm at up to 0.67 m/s here, and
# the asymptotic range starts near h ~ w / |zP'| / 8; measured ratios 2^3.9 .. 2^4.0 (RK4),
# 2^5.6 .. 2^5.9 (RK45), 2^7.4 .. 2^7.9 (DOP853), errors 6e-6 .. 2e-11. The pre-asymptotic
# ratio of RK45 stays within 2^(p + 1); a blend with a kink (a linear ramp in its place) fails
# the lower bound for all three methods
BED_STEPS = {"RK4": (0.01, 0.005, 0.0025), "RK45": (0.01, 0.005, 0.0025), "DOP853": (0.02, 0.01, 0.005)}


@lru_cache(None)
def bed_reference() -> np.ndarray:
    m = BallModel(BED_BALL)
    r = solve_ivp(m.rhs(CRANK.accel), (0.0, T_END), start(m).y, method="DOP853", rtol=2.5e-14, atol=1e-15)
    assert r.success
    return r.y[:, -1]


def test_the_order_run_crosses_the_bed_surface_and_its_band():
    m = BallModel(BED_BALL)
    tr = simulate(m, CRANK, T_END, 0.001, state=start(m))
    share = tr["s_bed"]
    assert np.mean(share == 0.0) > 0.05  # above the surface: no resistance at all
    assert np.mean((share > 0.0) & (share < 1.0)) > 0.5  # in the band
    assert np.all(tr["P_grind"][share == 0.0] == 0.0) and np.all(tr["P_grind"][share > 0.0] > 0.0)


@pytest.mark.parametrize("kernel", PATHS)
@pytest.mark.parametrize("method", list(ORDER))
def test_fixed_step_order_across_the_bed_surface(method, kernel):
    ref = bed_reference()
    errors = []
    for h in BED_STEPS[method]:
        m = (BallModel(BED_BALL, method="RK4", h_fixed=h) if method == "RK4"
             else BallModel(BED_BALL, method=method, tol=0.1, h_max=h))
        s = start(m)
        s.h = h
        tr = simulate(m, CRANK, T_END, T_END, state=s, outputs=False, kernel=kernel)
        assert tr.success
        assert (m.info.steps, m.info.rejected) == (round(T_END / h), 0)
        errors.append(float(np.max(np.abs(tr.y[-1] - ref))))
    p = ORDER[method]
    ratios = [errors[i] / errors[i + 1] for i in range(len(errors) - 1)]
    for r in ratios:
        assert 2 ** (p - 0.75) < r < 2 ** (p + 1), (method, kernel, errors, ratios)
