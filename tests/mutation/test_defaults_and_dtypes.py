"""Defaults a caller may omit, and the dtype of arrays handed to numpy users.

* `LinearAbsorber.response(f)` without a load is the response to a force at psi, the
  same as `response(f, "force")` (and not the ground's, which differs by the mass row).
* `CrankStartup.angles` returns float64 arrays for every law: an object array (what
  `np.full_like(None, x)` gives) holds the same numbers, but `np.isfinite` and most ufuncs
  refuse it, so a study that checks its samples would fail.
"""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.absorber.linear import LinearAbsorber
from ballmill.absorber.structure import Mode, StructureAxis
from ballmill.physics import Ball
from ballmill.physics.drives.crank import LAWS, CrankStartup


def test_response_defaults_to_a_force_at_psi():
    axis = StructureAxis(modes=(Mode(mass=100.0, frequency=0.8, damping=0.01),))
    la = LinearAbsorber(axis, Ball(r=0.025, R=0.325, m=2.0, drag=0.6))
    f = np.array([0.5, 0.74, 1.1])
    default = la.response(f)
    assert np.array_equal(default, la.response(f, "force"))
    assert not np.allclose(default, la.response(f, "ground"))


@pytest.mark.parametrize("law", LAWS)
def test_crank_angles_are_float64_arrays(law):
    crank = CrankStartup(l=0.5, n0=60.0, t0=2.0, law=law)
    t = np.array([-1.0, 0.0, 0.5, 2.0, 3.0])
    for a in crank.angles(t):
        assert a.dtype == np.float64
        assert np.isfinite(a).all()
    psi, wd, wdd = crank.angles(t)
    w0 = 2 * np.pi
    assert wd[-1] == pytest.approx(w0, rel=1e-15) and wdd[-1] == 0.0
    assert psi[0] == wd[0] == wdd[0] == 0.0
