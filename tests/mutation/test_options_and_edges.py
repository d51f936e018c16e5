"""Options and edges the physics tests did not pin: ``kernel="python"`` really keeps the
compiled kernel out, `simulate`'s refusals and its grid from a later start, the validity
flags exactly at their edges (N = 0 at the equator, |F_t| = mu N), and the input
reconstruction's higher-degree fits (the Horner path). Written for mutants that survived
the physics tests (docs/mutation.md)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import (Ball, BallModel, CrankStartup, InputError, InputReconstruction, KERNEL_AVAILABLE,
                              KernelUnavailable, evaluate, fast, simulate)
from ballmill.physics import model as _model
from ballmill.physics.platform import HISTORY_EXTRA

BALL = Ball()
FAST = CrankStartup(l=0.5, n0=60.0, t0=2.5)


def no_kernel(*args, **kwargs):
    raise AssertionError("the compiled kernel was used")


def test_kernel_python_keeps_the_kernel_out(monkeypatch):
    monkeypatch.setattr(_model.fast, "simulate", no_kernel)
    monkeypatch.setattr(_model.fast, "outputs", no_kernel)
    monkeypatch.setattr(_model.fast, "advance", no_kernel)
    m = BallModel(BALL, kernel="python")
    tr = simulate(m, FAST, 0.05, 0.01, state=m.initial(xC0=0.05), kernel="python")
    assert tr.success and len(tr.t) == 6
    rec = InputReconstruction()
    rec.push(0.0, *FAST.state(0.0))
    m.advance(m.initial(xC0=0.05), 0.01, rec.accel_function())
    m.outputs(m.initial(xC0=0.05), 0.0, 0.0)


@pytest.mark.skipif(not KERNEL_AVAILABLE, reason="compiled kernel unavailable")
def test_kernel_auto_uses_it_for_outputs(monkeypatch):
    calls = []
    real = fast.outputs
    monkeypatch.setattr(_model.fast, "outputs", lambda *a: calls.append(1) or real(*a))
    m = BallModel(BALL)
    m.outputs(m.initial(xC0=0.05), 0.0, 0.0)
    assert calls == [1]


@pytest.mark.parametrize("dt", [0.0, -0.01, math.inf, math.nan])
def test_simulate_refuses_a_bad_output_step(dt):
    with pytest.raises(ValueError) as e:
        simulate(BallModel(BALL), FAST, 1.0, dt)
    assert str(e.value) == f"dt must be positive and finite, got {dt!r} s"


@pytest.mark.parametrize("formulation, size", [("vector", 6), ("paper", 5)])
def test_simulate_names_a_state_of_the_wrong_size(formulation, size):
    """A state of the other formulation is refused with both sizes named (it used to raise a bare
    IndexError deep in the equations, or run on a misread state)."""
    from ballmill.physics.errors import ParameterError
    from ballmill.physics.model import BallState
    m = BallModel(BALL, formulation=formulation)
    wrong = 11 - size
    with pytest.raises(ParameterError) as e:
        simulate(m, FAST, 0.1, 0.01, state=BallState(0.0, np.zeros(wrong)))
    assert f"the {size} coordinates of the {formulation!r} formulation" in str(e.value)
    assert f"got shape ({wrong},)" in str(e.value)
    assert simulate(m, FAST, 0.1, 0.01, state=m.initial(xC0=0.05)).success


def test_simulate_with_nothing_to_integrate():
    m = BallModel(BALL)
    s = m.initial(xC0=0.05, t0=1.0)
    tr = simulate(m, FAST, 1.0, 0.01, state=s)  # auto: Python returns the one point
    assert tr.success and tr.t.tolist() == [1.0] and np.array_equal(tr.y[0], s.y)
    if KERNEL_AVAILABLE:
        with pytest.raises(KernelUnavailable) as e:
            simulate(BallModel(BALL), FAST, 1.0, 0.01, state=s, kernel="c")
        assert str(e.value) == "simulate(kernel='c'): no interval to integrate"


@pytest.mark.parametrize("kernel", ["python", "auto"])
def test_simulate_grid_from_a_later_start(kernel):
    m = BallModel(BALL)
    tr = simulate(m, FAST, 1.5, 0.1, state=m.initial(xC0=0.05, t0=1.0), kernel=kernel)
    np.testing.assert_allclose(tr.t, 1.0 + 0.1 * np.arange(6), rtol=0, atol=1e-15)
    assert tr["N"].shape == (6,)


# ---------------------------------------------------------------------------
# validity flags at their edges
@pytest.mark.parametrize("ball", [BALL, Ball(rolling_resistance=1e-4, drag=0.3)], ids=["lossless", "lossy"])
def test_no_contact_when_the_normal_force_is_exactly_zero(ball):
    """At rest on the equator, without platform acceleration, the wall carries nothing."""
    o = evaluate(ball, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0)
    assert o.N == 0.0 and o.contact is False and o.rolling is False
    assert o.friction_ratio > 1e299  # 'infinite'


@pytest.mark.parametrize("lossy", [False, True])
def test_rolling_holds_up_to_and_including_mu_n(lossy):
    n = (0.3, 0.1, -math.sqrt(1 - 0.1))
    w, a = (2.0, -1.0, 3.0), (1.0, -2.0)
    base = Ball(rolling_resistance=1e-4, drag=0.3) if lossy else Ball()
    o = evaluate(base, n, w, *a)
    mu = o.Ft / o.N
    assert mu * o.N == o.Ft and 0.05 < mu < 0.5
    assert evaluate(base.with_(mu=mu), n, w, *a).rolling is True  # |F_t| = mu N: still rolling
    assert evaluate(base.with_(mu=math.nextafter(mu, 0.0)), n, w, *a).rolling is False


# ---------------------------------------------------------------------------
# input reconstruction: higher degrees and the empty case
def poly_motion(coefs_x, coefs_y):
    def state(t):
        def ev(c, d):
            return sum(math.perm(j, d) * c[j] * t ** (j - d) for j in range(d, len(c)))
        return ev(coefs_x, 0), ev(coefs_y, 0), ev(coefs_x, 1), ev(coefs_y, 1), ev(coefs_x, 2), ev(coefs_y, 2)
    return state


@pytest.mark.parametrize("mode, points, degree", [("positions", 8, 7), ("derivatives", 3, 8)])
def test_higher_degree_fits_reproduce_their_polynomials(mode, points, degree, monkeypatch):
    monkeypatch.setattr(InputReconstruction, "_ROWS", {})
    monkeypatch.setattr(InputReconstruction, "_INVERSES", {})
    rng = np.random.default_rng(7)
    motion = poly_motion(rng.normal(size=degree + 1) * 0.1, rng.normal(size=degree + 1) * 0.1)
    rec = InputReconstruction(mode, points=points)
    for k in range(points):
        rec.push(0.1 * k, *motion(0.1 * k))
    accel = rec.accel_function()
    assert not hasattr(accel, "poly")  # a(t) of degree > 3: the Horner path, not the kernel's cubic
    t_last = 0.1 * (points - 1)
    for t in (0.05, t_last, t_last + 0.05):
        want = motion(t)
        np.testing.assert_allclose(accel(t), want[4:], rtol=0, atol=1e-7)
        np.testing.assert_allclose(rec.state(t), want, rtol=0, atol=1e-7)


def test_no_sample_no_fit():
    with pytest.raises(InputError) as e:
        InputReconstruction().accel(0.0)
    assert str(e.value) == "no platform sample has been set yet"


def test_a_state_of_the_wrong_shape_stays_out_of_the_kernel():
    """A vector model handed a 5-component state: the kernel (which reads 6 doubles) must not
    take it (simulate refuses it before, test above; the kernel's own guard serves other callers)."""
    from ballmill.physics import BallState
    m = BallModel(BALL)
    assert _model.fast.applicable(m, FAST, BallState(0.0, np.array([0.0, 0.0, -1.0, 0.0, 0.0]))) \
        == "state of shape (5,)"
    assert _model.fast.applicable(m, FAST, m.initial(xC0=0.05)) == ""


@pytest.mark.parametrize("points", [0, 9, -1])
def test_reconstruction_window_bounds(points):
    with pytest.raises(ValueError) as e:
        InputReconstruction("positions", points=points)
    assert str(e.value) == f"points must be between 1 and 8, got {points!r}"


def test_reconstruction_window_of_one_and_eight():
    assert InputReconstruction("positions", points=8).points == 8
    r = InputReconstruction("positions", points=1)
    r.push(0.0, 0.3, -0.2, 5.0, 6.0, 7.0, 8.0)  # velocities and accelerations are not used
    # one position: the platform stands there
    assert r.state(0.5) == (0.3, -0.2, 0.0, 0.0, 0.0, 0.0)
    assert r.accel_function()(0.5) == (0.0, 0.0)


@pytest.mark.parametrize("index, name", list(enumerate(("t", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O"))))
def test_a_non_finite_input_is_named(index, name):
    values = [0.25, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    values[index] = math.inf
    r = InputReconstruction()
    with pytest.raises(InputError) as e:
        r.push(*values)
    assert str(e.value) == f"input {name} must be finite, got inf at t = {values[0]!r} s"
    assert r.samples == []


def test_quartic_acceleration_takes_the_horner_path():
    """Seven positions: a sextic in x, a quartic a(t) (5 coefficients), beyond the cubic closure."""
    motion = poly_motion([0.1, -0.2, 0.3, 0.05, -0.04, 0.02, 0.01], [0.0, 0.1, -0.1, 0.2, 0.03, -0.02, 0.015])
    rec = InputReconstruction("positions", points=7)
    for k in range(7):
        rec.push(0.1 * k, *motion(0.1 * k))
    accel = rec.accel_function()
    assert not hasattr(accel, "poly")
    np.testing.assert_allclose(accel(0.65), motion(0.65)[4:], rtol=0, atol=1e-7)


def test_samples_come_in_time_order_and_a_repeat_replaces():
    r = InputReconstruction("positions", points=3)
    r.push(0.1, 1.0, 2.0)
    with pytest.raises(InputError) as e:
        r.push(0.05, 1.0, 2.0)
    assert str(e.value) == "inputs must come in time order: got t = 0.05 s after t = 0.1 s"
    r.push(0.1, 3.0, 4.0)  # the same time again: replaces
    assert r.samples == [(0.1, 3.0, 4.0, 0.0, 0.0, 0.0, 0.0)]
    for k in range(2, 6):
        r.push(0.1 * k, float(k), 0.0)
    # the history keeps more than the fit's 3 points (for the node choice); the fit
    # takes the newest 3 samples at least h/2 apart, newest first (h: the coming step)
    assert [s[0] for s in r.samples] == [0.1, 0.2, 0.30000000000000004, 0.4, 0.5]
    assert [n[0] for n in r.nodes()] == [0.30000000000000004, 0.4, 0.5]  # h = 0: the newest 3
    r.set_horizon(0.3)  # nodes at least 0.15 s apart: every other sample
    assert [n[0] for n in r.nodes()] == [0.1, 0.30000000000000004, 0.5]
    assert r.window() == [0.1, 0.2, 0.30000000000000004, 0.4, 0.5]
    for k in range(6, 14):
        r.push(0.1 * k, float(k), 0.0)
    assert len(r.samples) == 3 + HISTORY_EXTRA  # the oldest leave the history
    assert r.samples[0][0] == pytest.approx(0.5)


@pytest.mark.skipif(not KERNEL_AVAILABLE, reason="compiled kernel unavailable")
def test_kernel_c_says_why_it_cannot_and_still_returns_when_nothing_is_left():
    rec = InputReconstruction()
    rec.push(0.0, *FAST.state(0.0))
    accel = rec.accel_function()
    m = BallModel(BALL, formulation="paper", kernel="c")
    with pytest.raises(KernelUnavailable) as e:
        m.advance(m.initial(xC0=0.05), 0.01, accel)
    assert str(e.value) == "BallModel(kernel='c').advance: formulation 'paper' (the kernel does 'vector' only)"
    v = BallModel(BALL, kernel="c")
    s = v.initial(xC0=0.05)
    with pytest.raises(KernelUnavailable) as e:
        v.advance(s, 1, accel)  # an int end time
    assert str(e.value) == "BallModel(kernel='c').advance: times that are not floats"
    with pytest.raises(KernelUnavailable) as e:
        v.advance(s, 0.01, FAST.accel)  # not the reconstruction's cubic
    assert str(e.value).startswith("BallModel(kernel='c').advance: platform acceleration without polynomial")
    same = v.advance(s, 0.0, accel)  # nothing to integrate: the kernel is not needed
    assert same.t == 0.0 and np.array_equal(same.y, s.y)
