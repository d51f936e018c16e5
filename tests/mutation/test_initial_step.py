"""The adaptive methods' starting step (Hairer, Norsett and Wanner, Solving ODEs I, II.4)
against scipy's implementation of the same algorithm, in every branch: states and
derivatives of ordinary size, tiny ones (each norm between 1e-5 and 1), a derivative that
vanishes at the start, a constant one, a step capped by h_max, and one capped at 100 h0.
Written for mutants of `Integrator.initial_step` that the rest of the suite let through."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate._ivp.common import select_initial_step

from ballmill.physics import Integrator

CASES = {  # id: (y0, f, tol, h_max)
    "oscillator": ([1.0, 0.0], lambda t, y: np.array([y[1], -y[0]]), 1e-8, None),
    "oscillator-capped": ([1.0, 0.0], lambda t, y: np.array([y[1], -y[0]]), 1e-8, 2e-5),
    "tiny-state": ([5e-13, 8e-13], lambda t, y: np.array([-0.3 * y[0], -0.3 * y[1]]), 1e-6, None),
    "nonlinear": ([0.3, -0.2], lambda t, y: np.array([y[1] ** 2 + 1.0, math.sin(y[0]) * 5.0]), 1e-7, None),
    "starts-at-rest": ([1.0, 1.0], lambda t, y: np.array([t, 2.0 * t]), 1e-6, None),
    "constant-slow": ([1.0, 1.0], lambda t, y: np.array([1e-9, 1e-9]), 1e-6, None),
    "starts-at-rest-slowly": ([1.0, 1.0], lambda t, y: np.array([1e-10 * t, 0.0]), 1e-6, None),
    "zero-state": ([0.0, 0.0], lambda t, y: np.array([1e-14, 1e-14]), 1e-6, None),
}


@pytest.mark.parametrize("method, order", [("RK45", 4), ("DOP853", 7)])
@pytest.mark.parametrize("case", list(CASES))
def test_initial_step_is_hairer_wanners(case, method, order):
    y0, f, tol, h_max = CASES[case]
    y0 = np.array(y0)
    integ = Integrator(method, tol=tol, h_max=h_max)
    f0 = np.asarray(f(0.0, y0))
    # scipy: rtol = tol, atol = 1e-12 (our unscaled tolerance), an interval too long to bind
    want = select_initial_step(f, 0.0, y0, 1e9, math.inf if h_max is None else h_max, f0, 1.0, order,
                               tol, 1e-12)
    got = integ.initial_step(f, 0.0, y0, f0, 1e9)
    assert got == pytest.approx(want, rel=1e-13), (case, got, want)


def test_the_cases_reach_every_branch():
    """The scaled norms of the cases fall where the branches of the algorithm switch."""
    def norms(y0, f, tol):
        y0 = np.array(y0)
        sc = tol * np.abs(y0) + 1e-12
        f0 = np.asarray(f(0.0, y0))
        return math.sqrt(np.mean((y0 / sc) ** 2)), math.sqrt(np.mean((f0 / sc) ** 2))
    d0, d1 = norms(*CASES["tiny-state"][:3])
    assert 1e-5 < d0 < 1.0 and 1e-5 < d1 < 1.0
    d0, d1 = norms(*CASES["starts-at-rest"][:3])
    assert d1 == 0.0
    d0, d1 = norms(*CASES["constant-slow"][:3])
    assert 1e-15 < d1 < 1.0
    d0, d1 = norms(*CASES["zero-state"][:3])
    assert d0 == 0.0
    h = Integrator("RK45", tol=1e-6).initial_step(CASES["zero-state"][1], 0.0, np.zeros(2),
                                                   np.full(2, 1e-14), 1e9)
    assert h == pytest.approx(1e-4, rel=1e-12)  # 100 h0 with h0 = 1e-6
    h = Integrator("RK45", tol=1e-8, h_max=2e-5).initial_step(CASES["oscillator"][1], 0.0,
                                                               np.array([1.0, 0.0]), np.array([0.0, -1.0]), 1e9)
    assert h == 2e-5
