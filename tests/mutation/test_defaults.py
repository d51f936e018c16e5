"""The documented defaults of the physics API: an omitted argument means what the docstring
says (a platform at the crank axis, a state at rest at the bottom, the paper's 0.02 margin,
DOP853 at 1e-9), checked against the explicit call. Written for default-value mutants that
the rest of the suite let through (docs/mutation.md)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import (Ball, BallModel, CrankStartup, InputReconstruction, Integrator, energy, evaluate,
                              simulate)
from ballmill.physics.equations import PaperFormulation, VectorFormulation

BALL = Ball()
LOSSY = Ball(rolling_resistance=1e-4, drag=0.3)
N_VEC = (0.3, 0.1, -math.sqrt(0.9))
W = (2.0, -1.0, 3.0)


def test_outputs_default_to_a_platform_at_the_crank_axis():
    for ball in (BALL, LOSSY):
        assert evaluate(ball, N_VEC, W, 1.0, -2.0) == evaluate(ball, N_VEC, W, 1.0, -2.0, 0.0, 0.0)
        # and the position matters (the torque about the crank axis): the default is not just any value
        assert evaluate(ball, N_VEC, W, 1.0, -2.0, 0.4, 0.0).M_reaction != evaluate(ball, N_VEC, W, 1.0, -2.0).M_reaction
        assert evaluate(ball, N_VEC, W, 1.0, -2.0, 0.0, 0.4).M_reaction != evaluate(ball, N_VEC, W, 1.0, -2.0).M_reaction
    for kernel in ("python", "auto"):
        m = BallModel(BALL, kernel=kernel)
        s = m.initial(xC0=0.05, yC0=0.02, w0=W)
        assert m.outputs(s, 1.0, -2.0) == m.outputs(s, 1.0, -2.0, 0.0, 0.0)
        assert m.outputs(s, 1.0, -2.0).M_reaction != m.outputs(s, 1.0, -2.0, 0.0, 0.3).M_reaction


def test_energy_defaults_to_a_platform_at_rest():
    m = BallModel(BALL)
    s = m.initial(xC0=0.05, w0=W)
    n, w = m.nw(s)
    assert energy(BALL, n, w) == energy(BALL, n, w, 0.0, 0.0) == m.energy(s) == m.energy(s, 0.0, 0.0)
    assert m.energy(s, 0.0, 0.5) != m.energy(s)


def test_initial_state_defaults_to_rest_at_the_bottom():
    m = BallModel(BALL)
    s = m.initial()
    assert s.t == 0.0 and s.h is None
    assert s.y.tolist() == [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]


def test_model_defaults():
    m = BallModel(BALL)
    assert m.formulation == "vector" and isinstance(m.form, VectorFormulation)
    integ = m.integrator
    assert (integ.method, integ.tol, integ.h_fixed, integ.h_max, integ.max_steps) == \
        ("DOP853", 1e-9, 1e-3, math.inf, 1_000_000)
    assert m.kernel == "auto"
    p = BallModel(BALL, formulation="paper")
    assert p.form.equator_margin == 0.02 and p.form.cramer is False


def test_paper_formulation_defaults():
    f = PaperFormulation(BALL)
    assert f.equator_margin == 0.02 and f.cramer is False


def test_integrator_defaults():
    i = Integrator()
    assert (i.method, i.tol, i.scale, i.h_fixed, i.h_max, i.max_steps) == ("DOP853", 1e-9, None, 1e-3, math.inf,
                                                                           1_000_000)
    y = np.array([1.0, 2.0])
    assert i.project(y) is y and i.check(y) is None  # the hooks do nothing by default
    # advance without a step size chooses one
    _, h, st = i.advance(lambda t, y: -y, 0.0, y, 0.5)
    assert h > 0.0 and st.nfev == 1 + 1 + 12 * (st.steps + st.rejected)


def test_reconstruction_defaults():
    r = InputReconstruction()
    assert (r.mode, r.points) == ("derivatives", 2)
    assert InputReconstruction("positions").points == 6 and InputReconstruction("hold").points == 1
    r.push(0.0, 0.1, 0.2)  # velocity and acceleration default to zero
    assert r.samples == [(0.0, 0.1, 0.2, 0.0, 0.0, 0.0, 0.0)]


def test_simulate_defaults():
    m = BallModel(BALL)
    tr = simulate(m, CrankStartup(), 0.02, 0.01)
    assert tr.success and tr.t.tolist() == [0.0, 0.01, 0.02]  # from the model's initial state
    assert set(tr.out) >= {"N", "zP", "contact"}  # with outputs
    assert np.array_equal(tr.y[0], m.initial().y)


def test_paper_options_reach_the_formulation():
    m = BallModel(BALL, formulation="paper", equator_margin=0.1, cramer=True)
    assert m.form.equator_margin == 0.1 and m.form.cramer is True
    from ballmill.physics.equations import make_formulation
    f = make_formulation("paper", BALL, equator_margin=0.05, cramer=True)
    assert isinstance(f, PaperFormulation) and f.equator_margin == 0.05 and f.cramer is True
    with pytest.raises(ValueError) as e:
        make_formulation("spherical", BALL)
    assert str(e.value) == "formulation must be one of ['paper', 'vector'], got 'spherical'"


def test_losses_are_read_from_any_ball_like_object():
    from types import SimpleNamespace

    from ballmill.physics.equations import _lossy
    assert _lossy(SimpleNamespace()) is False  # no such attributes: lossless
    assert _lossy(SimpleNamespace(drag=0.2)) is True
    assert _lossy(SimpleNamespace(rolling_resistance=1e-4)) is True
    assert _lossy(BALL) is False and _lossy(LOSSY) is True
