"""The coupled structure + ball model in the compiled kernel (ballmill.absorber.kernel) against
the Python path (StructureBall.rhs, simulate_absorber(kernel="python")): the right-hand side bit
for bit, whole runs with the same steps, the same states, and the fall-back where it does not apply."""
import math

import numpy as np
import pytest

from ballmill.absorber import kernel as K
from ballmill.absorber import linear as lin
from ballmill.absorber.model import StructureBall, simulate_absorber
from ballmill.absorber.response import AbsorberCase, steady_state
from ballmill.absorber.structure import (GroundRecord, HarmonicForce, HarmonicGround, Mode, Structure,
                                         StructureAxis)
from ballmill.physics import Ball
from ballmill.physics.fast import KernelUnavailable
from ballmill.physics.integrators import Integrator

pytestmark = pytest.mark.skipif(K._lib() is None, reason="compiled kernel without the absorber functions")

R_TUNED = lin.cavity_radius(0.8, 0.025)
TWO_MODES = StructureAxis((Mode(100.0, 0.8, 0.01), Mode(40.0, 2.3, 0.02, shape=-0.6, force_shape=0.3,
                                                       participation=-11.0)))
SYSTEMS = {
    "lossless, force in x and y": StructureBall(
        Structure.single(100.0, 0.8, 0.01), Ball(r=0.025, R=R_TUNED, m=2.0),
        HarmonicForce(1.0, 0.75, amplitude_y=0.4, phase=0.3, phase_y=1.1)),
    "drag and rolling resistance, ground in x only, chirp": StructureBall(
        Structure(Structure.single(100.0, 0.8, 0.01).x, None),
        Ball(r=0.025, R=R_TUNED, m=2.0, drag=1.5, rolling_resistance=2e-4),
        HarmonicGround(0.3, 0.7, sweep_rate=0.01, t0=0.5)),
    "two modes in x, one in y, drag": StructureBall(
        Structure(TWO_MODES, Structure.single(80.0, 0.9, 0.02).x), Ball(r=0.025, R=R_TUNED, m=2.0, drag=0.8),
        HarmonicForce(2.0, 0.85, amplitude_y=1.0, phase_y=0.5)),
}


def _integ(system, x_ref=1e-3):
    return Integrator("DOP853", tol=1e-9, scale=system.scale(x_ref), project=system.project)


def _states(system, rng, count=40):
    base = system.initial(xC0=0.03, yC0=-0.02, w0=(0.2, -0.4, 0.1)).z
    for _ in range(count):
        z = base + rng.normal(0.0, 0.02, base.size)
        ib = system.ib
        z[ib:ib + 3] /= np.linalg.norm(z[ib:ib + 3])
        yield float(rng.uniform(0.0, 30.0)), z


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_rhs_bit_for_bit(name):
    system = SYSTEMS[name]
    integ = _integ(system)
    assert K.applicable(system, integ) == ""
    A = K.problem(system, integ)
    rng = np.random.default_rng(7)
    for t, z in _states(system, rng):
        assert K.eval_rhs(A, t, z) == system.rhs(t, z)  # tuples of floats, every bit


def test_projection_bit_for_bit():
    """model.py normalises n with z ** 2 (libm's pow), which rounds differently from z * z
    about once in a thousand: the kernel must do the same (a sweep diverged at 1e-17 m after
    2000 s before it did)."""
    system = SYSTEMS["lossless, force in x and y"]
    A = K.problem(system, _integ(system))
    rng = np.random.default_rng(3)
    ib = system.ib
    for _ in range(20000):
        z = rng.normal(0.0, 1.0, system.n_states)
        z[ib:ib + 3] *= 1.0 + rng.normal(0.0, 1e-9)
        assert K.eval_project(A, z) == system.project(z.tolist())


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_runs_are_the_python_runs(name):
    system = SYSTEMS[name]
    st = system.initial(xC0=0.03, w0=(0.0, 0.3, 0.0))
    py = simulate_absorber(system, 12.0, 0.05, state=st, record="motion", kernel="python")
    c = simulate_absorber(system, 12.0, 0.05, state=st, record="motion", kernel="c")
    assert py.success and c.success
    assert (c.steps, c.nfev) == (py.steps, py.nfev)
    assert np.array_equal(c.z, py.z) and c.state.h == py.state.h
    # a run continued from a state (its step carried) in C is the Python one
    half = simulate_absorber(system, 6.0, 0.05, state=st, record="motion", kernel="c")
    rest_c = simulate_absorber(system, 12.0, 0.05, state=half.state, record="motion", kernel="c")
    rest_py = simulate_absorber(system, 12.0, 0.05, state=half.state, record="motion", kernel="python")
    assert np.array_equal(rest_c.z, rest_py.z) and rest_c.steps == rest_py.steps


def test_a_steady_state_point_is_the_same_with_either_path(monkeypatch):
    case = AbsorberCase(Structure.single(100.0, 0.8, 0.01), Ball(r=0.025, R=R_TUNED, m=2.0), 1.0)
    fast_p = steady_state(case, 0.76)
    import ballmill.absorber.response as resp

    orig = resp.simulate_absorber
    monkeypatch.setattr(resp, "simulate_absorber", lambda *a, **kw: orig(*a, kernel="python", **kw))
    slow_p = steady_state(case, 0.76)
    assert fast_p.amplitude_m == slow_p.amplitude_m and fast_p.periods == slow_p.periods
    assert fast_p.friction_ratio_max == slow_p.friction_ratio_max


def test_where_the_kernel_does_not_apply_python_runs():
    rec = GroundRecord((0.0, 1.0, 2.0), (0.0, 0.5, 0.0), (0.0, 0.0, 0.0))
    system = StructureBall(Structure.single(100.0, 0.8, 0.01), Ball(r=0.025, R=R_TUNED, m=2.0), rec)
    with pytest.raises(KernelUnavailable, match="GroundRecord"):
        simulate_absorber(system, 2.0, 0.1, kernel="c")
    res = simulate_absorber(system, 2.0, 0.1)  # auto: Python
    assert res.success and math.isfinite(res["xO"][-1])
    wide = StructureBall(Structure(TWO_MODES, TWO_MODES), Ball(r=0.025, R=R_TUNED, m=2.0), HarmonicForce(1.0, 0.8))
    assert "17 states" in K.applicable(wide, _integ(wide))  # above the Python integrator's SMALL_SYSTEM
    many = StructureAxis(tuple(Mode(100.0, 0.8 + 0.3 * j, 0.01) for j in range(K.MODES + 1)))
    big = StructureBall(Structure(many, None), Ball(r=0.025, R=R_TUNED, m=2.0), HarmonicForce(1.0, 0.8))
    assert "modes on an axis" in K.applicable(big, _integ(big))
    with pytest.raises(ValueError, match="kernel must be"):
        simulate_absorber(big, 1.0, 0.1, kernel="fortran")
