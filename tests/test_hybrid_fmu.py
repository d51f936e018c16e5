"""The hybrid ball (rolling, sliding, flight, impacts) in the BallInShell FMU, contact_model = 2
(docs/design.md sections 14 and 15): the chamber along the input reconstruction, the library's
step from a state, and the FMU's outputs against the library's run, its balances, its refusals
and its states."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import CrankStartup, InputReconstruction
from ballmill.physics.turning.reconstruction import ChamberReconstruction, ReconstructedChamber

H = 2e-3
FAST = CrankStartup(t0=0.5)  # the fast start: n0 = 60 1/min in 0.5 s, slips at once

# -- the chamber along the reconstruction (platform.ReconstructedPlatform) ------------------------
_GL = {2: ((-1 / math.sqrt(3), 1.0), (1 / math.sqrt(3), 1.0)),
       3: ((-math.sqrt(0.6), 5 / 9), (0.0, 8 / 9), (math.sqrt(0.6), 5 / 9))}


def _gauss(f, a, b, n):
    """Gauss-Legendre with n points on [a, b]: exact for polynomials of degree 2n - 1."""
    m, r = 0.5 * (a + b), 0.5 * (b - a)
    return r * sum(w * f(m + r * x) for x, w in _GL[n])


@pytest.mark.parametrize("mode", ["derivatives", "positions", "hold", "accelerations"])
def test_the_reconstructed_platform_is_its_acceleration_integrated_exactly(mode):
    """v_A(t) - v_A(t0) is the integral of the fitted acceleration (a cubic: 2-point Gauss is
    exact) and A(t) - A(t0) that of v_A (a quartic: 3 points), to round-off; at t0 the fit's own
    position and velocity; over the step within round-off of the reconstruction's own motion."""
    rec = InputReconstruction(mode)
    for k in range(8):
        rec.set_horizon(H)
        rec.push(k * H, *FAST.state(k * H))
    mot = rec.motion()
    t0 = 7 * H
    assert mot.state(t0)[:4] == rec.state(t0)[:4]
    for t in (t0 + 0.3 * H, t0 + H):
        s = mot.state(t)
        for i, (xi, vi, ai) in enumerate(((0, 2, 4), (1, 3, 5))):
            dv = _gauss(lambda u: mot.state(u)[ai], t0, t, 2)
            dx = _gauss(lambda u: mot.state(u)[vi], t0, t, 3)
            v0, x0 = mot.state(t0)[vi], mot.state(t0)[xi]
            assert abs((s[vi] - v0) - dv) <= 1e-15 * max(1.0, abs(v0)), (mode, t, i)
            assert abs((s[xi] - x0) - dx) <= 1e-15 * max(1.0, abs(x0)), (mode, t, i)
            assert s[ai] == rec.accel(t)[i]  # the rolling model's acceleration, the same floats
        ref = rec.state(t)
        assert np.allclose(s, ref, rtol=1e-12, atol=1e-15), (mode, t)
    rec.push(8 * H, *FAST.state(8 * H))  # frozen: a later sample does not move it
    assert mot.state(t0 + H) == s


def test_the_reconstructed_turning_chamber_is_the_fit_itself():
    from ballmill.physics.turning.motions import Fig1Machine

    fig1 = Fig1Machine()
    rec = ChamberReconstruction("derivatives", R=0.25)
    from ballmill.physics.turning.reconstruction import inputs_of
    for k in range(4):
        rec.set_horizon(H)
        rec.push(k * H, *inputs_of(fig1.state(k * H), 0.25))
    mot = rec.motion()
    assert isinstance(mot, ReconstructedChamber)
    for t in (3 * H, 3.5 * H, 4 * H):
        assert mot.state(t) == rec.state(t)
        assert mot.accel(t) == rec.accel_function()(t)
