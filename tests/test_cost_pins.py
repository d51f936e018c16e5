"""Cost pins: the exact work (accepted steps, rejected steps, right-hand-side evaluations)
of a few reference settings.

The integrators are deterministic, so these counts are exact; a change in the step-size
control (its exponent, safety factor, limits, the initial step), in a tableau's stage
count or in how evaluations are counted changes them. A pin that fails is not
necessarily a bug: if the change in work is intended, measure the new counts and update
them here, with the reason in the commit. Python and the compiled kernel must do the same
work (their bit-identity is tested elsewhere; here both are held to the same numbers).

The settings avoid the output grid limiting the steps (long output intervals), and include
the crank law's kink at t0 = 2.5 s, where the controllers reject steps.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import (KERNEL_AVAILABLE, KERNEL_REASON, Ball, BallModel, CrankStartup,
                              InputReconstruction, Integrator, simulate)

BALL = Ball()
FAST_START = CrankStartup(l=0.5, n0=60.0, t0=2.5)
PATHS = ["python", pytest.param("c", marks=pytest.mark.skipif(
    not KERNEL_AVAILABLE, reason=f"compiled kernel unavailable: {KERNEL_REASON}"))]
SETTINGS = {  # id: (method, options)
    "DOP853-1e-9": ("DOP853", {"tol": 1e-9}),
    "RK45-1e-6": ("RK45", {"tol": 1e-6}),
    "RK45-1e-8": ("RK45", {"tol": 1e-8}),
    "RK4-10ms": ("RK4", {"h_fixed": 1e-2}),
}


def work(model):
    return model.info.steps, model.info.rejected, model.info.nfev


# the fast start from xC0 = 0.05 m, yC0 = 0.02 m to 4 s, output every 0.5 s (vector formulation)
MONOLITHIC = {"DOP853-1e-9": (83, 9, 1113), "RK45-1e-6": (112, 2, 693), "RK45-1e-8": (276, 0, 1665),
              "RK4-10ms": (400, 0, 1600)}


@pytest.mark.parametrize("kernel", PATHS)
@pytest.mark.parametrize("setting", list(SETTINGS))
def test_monolithic_fast_start_work(setting, kernel):
    method, opts = SETTINGS[setting]
    m = BallModel(BALL, method=method, **opts)
    tr = simulate(m, FAST_START, 4.0, 0.5, state=m.initial(xC0=0.05, yC0=0.02), outputs=False, kernel=kernel)
    assert tr.success
    assert work(m) == MONOLITHIC[setting]
    # how the evaluations add up: RK4 4 a step; the adaptive methods n_stages per attempted
    # step (FSAL: the last stage is the next step's first), one f(t, y) at the start of each
    # of the 8 output intervals and one for the initial step size
    steps, rejected, nfev = work(m)
    if method == "RK4":
        assert nfev == 4 * steps
    else:
        assert nfev == {"DOP853": 12, "RK45": 6}[method] * (steps + rejected) + 8 + 1


# the paper formulation (Python only), the same start to 1.5 s
PAPER = {"DOP853-1e-9": (28, 7, 424), "RK45-1e-6": (38, 4, 256), "RK45-1e-8": (94, 0, 568),
         "RK4-10ms": (150, 0, 600)}


@pytest.mark.parametrize("setting", list(SETTINGS))
def test_paper_formulation_work(setting):
    method, opts = SETTINGS[setting]
    m = BallModel(BALL, formulation="paper", method=method, **opts)
    tr = simulate(m, FAST_START, 1.5, 0.5, state=m.initial(xC0=0.05, yC0=0.02), outputs=False)
    assert tr.success
    assert work(m) == PAPER[setting]


# the BallInShell FMU's path: 100 communication steps of 20 ms, each with the cubic input
# reconstructed from the crank's (x, v, a) at the communication points, the step size carried.
# The carried step sizes of DOP853-1e-9 (was 0.10024120811441384) and RK45-1e-8 (was
# 0.013510929512541485) moved with the input reconstruction's rework (positions fitted relative
# to the newest node, the fit's inverse exact for the float matrix): its cubic differs from the
# old one in round-off only (the state after the 100 steps by 2.4e-11 against 2.9e-3 for the
# extrapolation error both share), which the step-size controller sees in err^(-1/8); the
# work counts did not move, and python and the kernel agree bit for bit on the new values.
# DOP853's carried step: 0.10024122246497066 until the crank law's angle was computed as
# w0 t0 s^2 (1 - s/3) (exactly 0 at t = 0; positions change in the last bits), which moves
# this controller proposal, set by an error estimate near round-off, by a relative 1.3e-7
FMU_PATH = {"DOP853-1e-9": ((100, 0, 1301), 0.1002412095044415),
            "RK45-1e-6": ((100, 0, 701), 0.07199918611825604),
            "RK45-1e-8": ((163, 1, 1085), 0.013510929512282279),
            "RK4-10ms": ((200, 0, 800), 0.01)}


@pytest.mark.parametrize("kernel", PATHS)
@pytest.mark.parametrize("setting", list(SETTINGS))
def test_communication_steps_work(setting, kernel):
    method, opts = SETTINGS[setting]
    m = BallModel(BALL, method=method, kernel=kernel, **opts)
    s = m.initial(xC0=0.05, yC0=0.02)
    rec = InputReconstruction()
    H = 0.02
    for i in range(100):
        rec.set_horizon(H)  # as the FMU's step does: the nodes are chosen for the coming step
        rec.push(i * H, *FAST_START.state(i * H))
        s = m.advance(s, (i + 1) * H, rec.accel_function())
    counts, h_next = FMU_PATH[setting]
    assert work(m) == counts
    # the step size carried to the next interval: deterministic too (a relative 1e-9 leaves
    # room for a libm whose pow differs in the last bit)
    assert math.isclose(s.h, h_next, rel_tol=1e-9), s.h


# the integrator alone: a harmonic oscillator over 10 s at tol 1e-8 (h_fixed 10 ms for RK4)
OSCILLATOR = {"DOP853": (22, 0, 266), "RK45": (130, 11, 848), "RK4": (1000, 0, 4000)}


@pytest.mark.parametrize("method", list(OSCILLATOR))
def test_integrator_work_on_an_oscillator(method):
    integ = Integrator(method, tol=1e-8, h_fixed=0.01)
    y, h, st = integ.advance(lambda t, y: np.array([y[1], -y[0]]), 0.0, np.array([1.0, 0.0]), 10.0)
    assert (st.steps, st.rejected, st.nfev) == OSCILLATOR[method]
    # and the answer is still the oscillator's: cos 10, -sin 10 (global error ~ 10 tol)
    assert np.max(np.abs(y - [math.cos(10.0), -math.sin(10.0)])) < 1e-6
