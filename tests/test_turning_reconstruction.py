"""ballmill.physics.turning.reconstruction: the chamber's motion between communication points
(BallInShell with motion = 2), and ChamberModel.advance along it in the kernel.

* The Hermite fits are exact for the polynomials they can represent: A(t) a quintic (through
  A, v_A, a_A at two nodes), Omega(t) a cubic (through Omega, Omega'), to round-off.
* inputs_of and centre are inverses (the chamber's centre from O and the rotation).
* Q over a step: for a constant Omega, Rodrigues' rotation by Omega s is the exact
  orientation (motions.Spin's).
* The kernel's bmg_advance_poly gives ChamberModel's Python path bit for bit.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import Ball
from ballmill.physics.errors import InputError
from ballmill.physics.turning import Fig1Machine, Spin
from ballmill.physics.turning import kernel as fast_turning
from ballmill.physics.turning.model import ChamberModel
from ballmill.physics.turning.reconstruction import ChamberReconstruction, centre, inputs_of

I3 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
C = (0.3, -0.2, 0.7, 1.1, -0.4, 0.25)  # a quintic A_x(t)
G = (0.5, 0.3, -0.2, 0.1)  # a cubic Omega_x(t)


def poly(c, t, der=0):
    return sum(math.perm(j, der) * cj * t ** (j - der) for j, cj in enumerate(c) if j >= der)


def test_hermite_fits_reproduce_a_quintic_centre_and_a_cubic_rotation_rate():
    rec = ChamberReconstruction("derivatives", R=0.0)  # R = 0: A = O, whatever the rotation
    for t in (0.1, 0.13):
        rec.push(t, poly(C, t), 0.0, poly(C, t, 1), 0.0, poly(C, t, 2), 0.0, 0.0, 0.0, 0.0,
                 poly(G, t), 0.0, 0.0, poly(G, t, 1), 0.0, 0.0, *I3)
    rec.set_horizon(0.03)
    kin = rec.accel_function()
    for t in (0.1, 0.115, 0.13, 0.145, 0.16):  # inside the window and extrapolated over the next step
        k = kin(t)
        assert k[0] == pytest.approx(poly(C, t, 2), abs=1e-11)
        assert k[3] == pytest.approx(poly(G, t), abs=1e-14)
        assert k[6] == pytest.approx(poly(G, t, 1), abs=1e-13)
        s = rec.state(t)
        assert s[0] == pytest.approx(poly(C, t), abs=1e-14) and s[3] == pytest.approx(poly(C, t, 1), abs=1e-13)
    # the coefficients the kernel takes are the closure's
    assert len(kin.poly) == 34 and kin.poly[0] == 0.13


def test_inputs_of_and_centre_are_inverses():
    cs = Fig1Machine().state(1.3)
    smp = (1.3,) + inputs_of(cs, 0.25)
    A, vA, aA = centre(smp, 0.25)
    assert np.allclose(A, cs[0:3], atol=1e-15, rtol=0) and np.allclose(vA, cs[3:6], atol=1e-14, rtol=0)
    assert np.allclose(aA, cs[6:9], atol=1e-13, rtol=0)


def test_orientation_over_a_step_for_a_constant_spin_is_exact():
    spin = Spin((0.3, -0.4, 1.2), (0.0, 0.0, 0.25))
    rec = ChamberReconstruction("derivatives", R=0.25)
    for t in (0.0, 0.01):
        rec.push(t, *inputs_of(spin.state(t), 0.25))
    rec.set_horizon(0.01)
    for t in (0.01, 0.015, 0.02):
        assert np.allclose(rec.state(t)[15:24], spin.orientation(t), atol=1e-15, rtol=0)


def test_a_sample_that_is_not_a_rotation_is_refused_and_the_history_kept():
    rec = ChamberReconstruction("hold", R=0.25)
    rec.push(0.0, *(0.0,) * 15, *I3)
    bad = list(I3)
    bad[1] = 1e-3
    with pytest.raises(InputError, match=r"row 1 \. row 2 = 0\.001, expected 0\.0 within 1e-06"):
        rec.push(0.01, *(0.0,) * 15, *bad)
    assert len(rec.samples) == 1


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_kernel_advance_is_the_python_path_bit_for_bit(method):
    if fast_turning._lib() is None:
        pytest.skip("compiled kernel not built")
    motion = Fig1Machine()
    rec = ChamberReconstruction("derivatives", R=0.25)
    py = ChamberModel(Ball(), method=method, kernel="python")
    c = ChamberModel(Ball(), method=method)
    s_py = s_c = py.initial(motion, 0.03, 0.0)

    class Kin:
        pass
    for k in range(40):
        t = 0.004 * k
        rec.set_horizon(0.004)
        rec.push(t, *inputs_of(motion.state(t), 0.25))
        m = Kin()
        m.accel = rec.accel_function()
        s_py, s_c = py.advance(s_py, t + 0.004, m), c.advance(s_c, t + 0.004, m)
        assert np.array_equal(s_py.y, s_c.y) and s_py.h == s_c.h
    assert "_fast_poly" in c.__dict__ and py.info == c.info
