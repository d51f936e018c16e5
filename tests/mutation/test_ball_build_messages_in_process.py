"""BallInShell's refusals at initialisation from its own checks (`BallInShell.build`), word for
word on the pythonfmu slave in this process (tests/mutation/inprocess.py), where mutmut sees
them: the rolling-resistance length beyond the ball's radius, the viscous drag beyond
1e4 m omega0, RK4's fixed step below max_step / 20000. Each is logged as fmi2Error and then
fmi2Fatal with the same text, and names the parameter, its value, its unit and the accepted
range with the reason. The physics' names are renamed to the FMU's (rolling_resistance ->
delta, drag -> c_drag) in messages from the library; the adapter's own texts must survive that
renaming intact (it once turned "a drag time m/c_drag" into "a c_drag time m/c_drag")."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import ERROR, FATAL, OK, InProcessFmu  # noqa: E402

from ballmill.physics import Ball  # noqa: E402


def _limits():
    """The ball's small-swing frequency omega0 = sqrt(g / ((1 + 2/5) (R - r))), the drag limit
    1e4 m omega0 and the default max_step, a twentieth of the small-swing period (computed in the
    tests, not at import: docs/mutation.md)."""
    ball = Ball()
    omega0 = (ball.g / (1.4 * (ball.R - ball.r))) ** 0.5
    assert abs(omega0 - ball.omega_small) <= 1e-12 * omega0
    return ball, 1e4 * ball.m * ball.omega_small, 0.05 * 2.0 * math.pi / ball.omega_small


CASES = {
    "delta": (dict(delta=0.03), "parameter delta = 0.03 m is outside its accepted range [0, r = 0.025] m (a "
                                "rolling-resistance length beyond the ball's radius)"),
    "c_drag": (dict(c_drag=1e6), "parameter c_drag = 1000000.0 N.s/m is outside its accepted range [0, {c_max:.6g}] "
                                 "N.s/m (1e4 m omega0: a viscous time constant m/c_drag below 1e-4/omega0 makes the "
                                 "equations too stiff for the explicit integrators)"),
    "h_fixed": (dict(integrator=3, max_step=0.5, h_fixed=1e-5), "parameter h_fixed = 1e-05 s is outside its "
                "accepted range [2.5e-05, inf) s (max_step / 20000 internal steps, max_step = 0.5 s)"),
    "h_fixed_default_max_step": (dict(integrator=3, h_fixed=1e-9), "parameter h_fixed = 1e-09 s is outside its "
                                 "accepted range [{h_min:.6g}, inf) s (max_step / 20000 internal steps, max_step = "
                                 "{max_step:.6g} s)"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_parameter_the_model_cannot_take_is_refused_with_the_reason(case):
    _, c_max, max_step = _limits()
    parameters, text = CASES[case]
    f = InProcessFmu("BallInShell", "bi", **parameters)
    assert f.init() == FATAL
    full = "BallInShell 'bi': initialisation failed: " + text.format(c_max=c_max, h_min=max_step / 20000,
                                                                     max_step=max_step)
    assert f.log == [(ERROR, full), (FATAL, full)]


def test_the_limits_themselves_are_accepted():
    ball, c_max, _ = _limits()
    assert c_max == pytest.approx(28489.3, rel=2e-6)
    for parameters in (dict(delta=ball.r), dict(c_drag=c_max), dict(integrator=3, max_step=0.5, h_fixed=2.5e-5),
                       dict(integrator=1, h_fixed=1e-9)):  # h_fixed matters to RK4 only
        f = InProcessFmu("BallInShell", "ok", **parameters)
        assert f.init() == OK, (parameters, f.messages())
