"""BallInShell's output publication and initial state, on the pythonfmu slave in this process
(tests/mutation/inprocess.py) so that mutmut sees it: `_values` names the output that would not
be finite (word for word, every output of both motions) and publishes friction_ratio = +inf
(contact lost) as 1e300; start() takes the initial angular velocity and the start time into the
state and names the initial state whose outputs are not finite; coupling_warn is a strict bound.

Closed forms: a ball at rest at the bottom of a chamber whose centre accelerates vertically by
a_z presses on it with N = m (g + a_z) (contact lost when a_z < -g); a chamber at x1O holds the
ball's contact point at P = (x1O, 0, 0), so the moment about O1 of the weight's reaction,
MO1y = -x1O F_z = x1O m g, is +inf for x1O = 1e308."""
from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import FATAL, OK, InProcessFmu  # noqa: E402

H = 0.01  # s


def _module():
    return importlib.import_module("fmu_src.ballinshell_fmu")


def _stepped(motion, **start):
    f = InProcessFmu("BallInShell", f"values{motion}", motion=motion, **start)
    assert f.init() == OK and f.step(H) == OK, f.messages()
    return f


def _names(out, motion):
    if motion == 2:
        return [n for n, _ in out.values]
    return [n for n, _, _ in _module().OUTPUTS] + ["P_diss", "P_grind", "s_bed"] + [n for n, _ in out.extra]


def _with(out, motion, name, value):
    """A copy of the outputs with one value replaced."""
    mod = _module()
    if motion == 2:
        g = mod._General()
        g.contact, g.rolling, g.N, g.friction_ratio = out.contact, out.rolling, out.N, out.friction_ratio
        g.values = tuple((n, value if n == name else v) for n, v in out.values)
        return g
    t = mod._Translated.__new__(mod._Translated)
    t.contact, t.rolling, t.N, t.friction_ratio = out.contact, out.rolling, out.N, out.friction_ratio
    t.out = out.out._replace(**{name: value}) if name in out.out._fields else out.out
    t.extra = tuple((n, value if n == name else v) for n, v in out.extra)
    return t


@pytest.mark.parametrize("motion", [1, 2])
def test_each_output_that_would_not_be_finite_is_named(motion):
    f = _stepped(motion)
    s = f.slave
    out = s._outputs_at(s._state, s._time)
    names = _names(out, motion)
    assert len(names) == 31 and len(set(names)) == 31
    good = dict(s._values(out))
    assert list(good) == names
    for name in names:
        for bad in (math.nan, math.inf, -math.inf):
            if name == "friction_ratio" and bad != bad:
                continue
            if name == "friction_ratio":  # +-inf is published as +-1e300 (N <= 0)
                values = dict(s._values(_with(out, motion, name, bad)))
                assert values == {**good, name: math.copysign(1e300, bad)}
                continue
            with pytest.raises(ArithmeticError) as e:
                s._values(_with(out, motion, name, bad))
            assert str(e.value) == f"output {name} would be {bad!r}", (name, str(e.value))
    with pytest.raises(ArithmeticError) as e:
        s._values(_with(out, motion, "friction_ratio", math.nan))
    assert str(e.value) == "output friction_ratio would be nan"


def test_motion2_contact_lost_between_steps_publishes_friction_ratio_as_1e300():
    f = _stepped(2)
    m, g = f.get("m"), f.get("g")
    assert f.set(az1O=-2.0 * g) == OK, f.messages()
    out = f.outputs()
    assert abs(out["N"] - m * (g - 2.0 * g)) <= 1e-12 * m * g
    assert out["friction_ratio"] == 1e300 and out["contact"] is False


def test_initial_outputs_not_finite_name_the_initial_state_and_the_output():
    f = InProcessFmu("BallInShell", "far", input_mode=3, x1O=1e308, xC0=0.01, wz0=0.5)
    assert f.init() == FATAL
    assert f.messages().endswith(
        "initialisation failed: the initial state (xC0 = 0.01 m, yC0 = 0.0 m, wx0 = 0.0, wy0 = 0.0, "
        "wz0 = 0.5 rad/s) gives non-finite outputs: output MO1y would be inf"), f.messages()


@pytest.mark.parametrize("motion", [1, 2])
def test_start_takes_the_spin_and_the_start_time(motion):
    """A spin about the vertical through the contact point at the bottom is compatible with
    rolling (it does not move the centre): wz = wz0 is published; the state starts at the FMU's
    start time."""
    f = InProcessFmu("BallInShell", f"spin{motion}", motion=motion, wz0=0.75)
    assert f.init(start=2.0) == OK, f.messages()
    assert f.get("wz") == 0.75 and f.get("wx") == 0.0 and f.get("wy") == 0.0
    assert f.get_state()["__internal__"]["state"]["t"] == 2.0
    assert f.step(H, t=2.0) == OK, f.messages()
    assert f.get_state()["__internal__"]["state"]["t"] == 2.0 + H


def test_coupling_warn_is_a_strict_bound():
    """Hold mode: no corrector, coupling_error stays 0, equal to coupling_warn = 0: no warning."""
    f = InProcessFmu("BallInShell", "warn0", input_mode=3, coupling_warn=0.0)
    assert f.init() == OK and f.step(H) == OK and f.step(H) == OK
    assert f.get("coupling_error") == 0.0
    assert f.log == [], f.log
