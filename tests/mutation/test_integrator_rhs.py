"""What `Integrator.advance` accepts from a right-hand side (ballmill.physics.integrators):
a tuple, a list, an array, or a scalar broadcast to every state ("an array, a list or a
scalar to broadcast: n floats", `_advance`), the same on the generated kernels (n <= 16)
and the numpy step (n > 16).

y' = 3 t^2, the same scalar for every state, has y = y0 + t^3: each method integrates a
cubic in t exactly (RK4's weights are Simpson's rule, RK45 and DOP853 have higher order),
so the end state is exact up to round-off (a few ulp of the final value, tolerance 1e-12)
for every step size the controller picks."""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.physics import Integrator
from ballmill.physics import integrators as _integ

RETURNS = {
    "float": lambda t: 3.0 * t * t,
    "0-d array": lambda t: np.asarray(3.0 * t * t),
    "numpy float": lambda t: np.float64(3.0 * t * t),
}


@pytest.mark.parametrize("kind", sorted(RETURNS))
@pytest.mark.parametrize("n", [3, 17], ids=["kernel", "numpy"])
@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_a_scalar_right_hand_side_is_broadcast_to_every_state(monkeypatch, method, n, kind):
    monkeypatch.setattr(_integ, "_KERNELS", {})  # generated within the test (docs/mutation.md)
    value = RETURNS[kind]
    y0 = np.linspace(-1.0, 1.0, n)
    integ = Integrator(method, tol=1e-10, h_fixed=0.05)
    y, h, stats = integ.advance(lambda t, y: value(t), 0.5, y0, 1.5)
    assert y.shape == (n,)
    np.testing.assert_allclose(y, y0 + (1.5 ** 3 - 0.5 ** 3), rtol=0, atol=1e-12)
    assert stats.steps >= 1 and stats.rejected == 0
    if method == "RK4":
        assert (stats.steps, stats.nfev, h) == (20, 80, 0.05)  # 1 s in 20 steps of 0.05 s
    # the same steps on the other path (the arithmetic differs only in summation order)
    monkeypatch.setattr(_integ, "SMALL_SYSTEM", 16 if n > 16 else -1)
    y2, h2, stats2 = Integrator(method, tol=1e-10, h_fixed=0.05).advance(lambda t, y: value(t), 0.5, y0, 1.5)
    assert (stats2.steps, stats2.rejected, stats2.nfev) == (stats.steps, stats.rejected, stats.nfev)
    np.testing.assert_allclose(y2, y, rtol=0, atol=1e-13)


@pytest.mark.parametrize("n", [3, 17], ids=["kernel", "numpy"])
@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_a_right_hand_side_of_the_wrong_length_is_refused(method, n):
    with pytest.raises(ValueError):
        Integrator(method).advance(lambda t, y: np.ones(n + 1), 0.0, np.zeros(n), 1.0)
