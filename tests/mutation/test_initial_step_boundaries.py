"""The starting step's branch conditions at their exact boundaries (Hairer, Norsett and
Wanner, Solving ODEs I, II.4, as scipy's select_initial_step): h0 = 1e-6 only when a scaled
norm d0 or d1 is *below* 1e-5, and the fallback h1 = max(1e-6, 1e-3 h0) only when d1 and
d2 are both *at most* 1e-15. tol = 0.1 with scale 5 makes the error scale exactly 1
(0.1 max(|y|, 5) + 0.1 5 = 0.5 + 0.5), so the norms are the values themselves and each
boundary is hit exactly (sqrt(x^2) = |x| in binary floating point)."""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.physics import Integrator

C_D2 = 1e-21 * (1 + 2 ** -52)  # f1 - f0 that makes d2 = |f1 - f0| / h0 exactly 1e-15 at h0 = 1e-6


def _step(y, f):
    integ = Integrator("RK45", tol=0.1, scale=np.array([5.0]))
    y = np.array([y])
    assert integ._scale(y, y)[0] == 1.0
    return integ, integ.initial_step(f, 0.0, y, np.asarray(f(0.0, y)), 1e9)


def test_d0_at_1e_5_is_not_below_it():
    """d0 = 1e-5, d1 = 1: h0 = 0.01 d0 / d1 = 1e-7, d2 = 0, so the step is 100 h0."""
    _, h = _step(1e-5, lambda t, y: np.array([1.0]))
    assert h == pytest.approx(1e-5, rel=1e-12)


def test_d1_at_1e_5_is_not_below_it():
    """d0 = 1, d1 = 1e-5: h0 = 0.01 / 1e-5 = 1000 s, d2 = 0: h1 = (0.01 / d1)^(1/order)."""
    integ, h = _step(1.0, lambda t, y: np.array([1e-5]))
    assert h == pytest.approx(1000.0 ** (1.0 / integ.tab.order), rel=1e-12)


@pytest.mark.parametrize("f", [
    lambda t, y: np.array([1e-15]),  # d1 = 1e-15, d2 = 0
    lambda t, y: np.array([C_D2 if t > 0.0 else 0.0]),  # d1 = 0, d2 = 1e-15
], ids=["d1", "d2"])
def test_norms_at_1e_15_take_the_fallback(f):
    """d1 < 1e-5: h0 = 1e-6; d1, d2 <= 1e-15: h1 = max(1e-6, 1e-3 h0) = 1e-6 (not
    (0.01 / max(d1, d2))^(1/order), which would give 100 h0 = 1e-4)."""
    _, h = _step(1.0, f)
    assert h == 1e-6
