"""MotorStartup (pythonfmu flavour, in this process): a step whose end overflows to t = inf.

Two finite numbers can add up to infinity: from t = 1e308 s a step of 1e308 s ends at t = inf,
which fmi2DoStep's checks let through (the step size is finite and positive, the end lies after
the FMU's time). With n0 = 0 the crank law's angle there is 0 inf = nan, the cosine of which is
nan without an error, so the step reaches the output check: it is refused naming the output
(psi) and its value, every output stays, and the FMU keeps its time. (With n0 > 0 the angle
overflows already at t = 1e308 s, where Python's cosine refuses it: test_motorstartup_in_process.py.)"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import DISCARD, OK, InProcessFmu  # noqa: E402


@pytest.mark.parametrize("law", [1, 2, 3, 4])
def test_a_step_that_ends_at_infinity_is_refused_naming_the_output(law):
    f = InProcessFmu("MotorStartup", "ms", l=0.4, n0=0.0, t0=1.5, J_crank=0.3, m_platform=2.0, law=law,
                     M_reaction=0.5)
    assert f.init(1e308) == OK, f.messages()
    out = f.outputs()
    assert (out["psi"], out["psi_dot"], out["psi_ddot"], out["x1O"], out["T_drive"]) == (0.0, 0.0, 0.0, 0.4, -0.5)
    n = len(f.log)
    assert f.step(1e308) == DISCARD
    assert f.messages(n) == "MotorStartup 'ms': step to t = inf s refused, last good state kept: output psi would be nan"
    assert f.outputs() == out
    assert f.slave._time == 1e308  # the FMU's time is where it was
