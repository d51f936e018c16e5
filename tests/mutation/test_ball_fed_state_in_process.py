"""BallInShell's feedthrough bookkeeping (`inputs_set`, `_published_inputs`, the FMU state's 'fed'
entry), on the pythonfmu slave in this process (tests/mutation/inprocess.py) so that mutmut sees
it: an input set back to what the step's outputs were computed from brings the step's values
back; the same values again change nothing (bit for bit); the inputs of the last refresh travel
in the FMU state and a malformed 'fed' entry is refused word for word; motion = 2 refuses to
refresh from a chamber orientation that is not a rotation.

Closed form (tests/mutation/test_ball_feedthrough_in_process.py): a ball at rest at the bottom of
a chamber accelerating horizontally by a pushes on it with F = (-(2/7) m a_x, -(2/7) m a_y, -m g),
N = m g."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import OK, InProcessFmu  # noqa: E402

from ballmill.fmi.interface import BALL_ALL_INPUTS, BALL_FEEDTHROUGH, BALL_INPUTS  # noqa: E402

H = 0.01  # s
X, Y, AX, AY = 0.1, -0.05, 0.7, -0.4  # m, m/s2
ZERO = dict(x1O=0.0, y1O=0.0, vx1O=0.0, vy1O=0.0, ax1O=0.0, ay1O=0.0)
REFUSED = "FMU state refused, the instance keeps its state: "


def _close(a, b, tol=1e-12):
    return abs(a - b) <= tol * max(1.0, abs(b))


def _stepped(motion, mode=1, **start):
    f = InProcessFmu("BallInShell", f"fed{motion}{mode}", input_mode=mode, motion=motion, **start)
    assert f.init() == OK and f.step(H) == OK, f.messages()
    return f


@pytest.mark.parametrize("motion", [1, 2])
def test_fed_inputs_travel_in_the_fmu_state_and_an_input_set_back_restores_the_step(motion):
    f = _stepped(motion)
    m, g = f.get("m"), f.get("g")
    stepped = f.outputs()
    assert f.get_state()["__internal__"]["fed"] is None  # nothing refreshed since the step
    assert f.set(x1O=X, y1O=Y, ax1O=AX, ay1O=AY) == OK, f.messages()
    refreshed = f.outputs()
    assert _close(refreshed["Fx"], -2.0 / 7.0 * m * AX) and _close(refreshed["Fy"], -2.0 / 7.0 * m * AY)
    saved = f.get_state()
    names = BALL_ALL_INPUTS if motion == 2 else BALL_INPUTS
    expected_fed = [H] + [float(f.get(n)) for n in names]
    assert saved["__internal__"]["fed"] == expected_fed
    assert len(expected_fed) == (25 if motion == 2 else 7)
    # back to the inputs the step took (they differ from those of the last refresh): the step's
    # values again (to rounding)
    assert f.set(**ZERO) == OK
    back = f.outputs()
    for name in BALL_FEEDTHROUGH:
        assert _close(float(back[name]), float(stepped[name])), (name, back[name], stepped[name])
    assert back["Fx"] == 0.0 and back["Fy"] == 0.0 and _close(back["Fz"], -m * g)
    # the saved state brings back the refreshed outputs and what they came from: setting the
    # step's inputs again refreshes again
    assert f.set_state(saved) == OK, f.messages()
    assert f.outputs() == refreshed
    assert f.get_state()["__internal__"]["fed"] == expected_fed
    assert f.set(**ZERO) == OK
    again = f.outputs()
    assert again["Fx"] == 0.0 and again["Fy"] == 0.0 and again["MO1z"] == 0.0
    for name in BALL_FEEDTHROUGH:
        assert _close(float(again[name]), float(stepped[name])), (name, again[name], stepped[name])
    # a step clears it
    assert f.step(H) == OK and f.get_state()["__internal__"]["fed"] is None


@pytest.mark.parametrize("motion", [1, 2])
def test_the_steps_own_sample_set_again_changes_nothing(motion):
    """From rest at constant acceleration a: the step's outputs at H use the inputs extrapolated
    to H (x1O = a H^2 / 2); the sample it took (t = 0: x1O = 0) set again is nothing new, and a
    refresh with it would move the moments about O1 by x1O F_z."""
    f = _stepped(motion, ax1O=AX, ay1O=AY)
    stepped = f.outputs()
    R, x = f.get("R"), 0.5 * AX * H * H  # MO1 = A x F + M_A with A = (x1O, y1O, R) at H
    assert _close(stepped["MO1y"], R * stepped["Fx"] - x * stepped["Fz"] + stepped["MAy"], 1e-13)
    assert abs(x * stepped["Fz"]) > 1e-4
    for _ in range(2):
        assert f.set(x1O=0.0, y1O=0.0, vx1O=0.0, vy1O=0.0, ax1O=AX, ay1O=AY) == OK
        assert f.outputs() == stepped
        assert f.get_state()["__internal__"]["fed"] is None


def test_motion2_a_chamber_orientation_that_is_no_rotation_refreshes_nothing():
    f = _stepped(2)
    before = f.outputs()
    assert f.set(Q11=2.0, ax1O=AX) == OK, f.messages()  # Q is not orthogonal: left to the next step
    assert f.outputs() == before
    assert f.get_state()["__internal__"]["fed"] is None


@pytest.mark.parametrize("motion, fed, shown", [
    (1, [1.0, 2.0, 3.0], "[1.0, 2.0, 3.0]"),
    (1, (0.01, 0.0, 0.0, 0.0, 0.0, 0.7, 0.0), "(0.01, 0.0, 0.0, 0.0, 0.0, 0.7, 0.0)"),
    (1, [0.01, 0.0, 0.0, 0.0, 0.0, float("nan"), 0.0], "[0.01, 0.0, 0.0, 0.0, 0.0, nan, 0.0]"),
    (1, [0.01, 0.0, 0.0, 0.0, 0.0, "0.7", 0.0], "[0.01, 0.0, 0.0, 0.0, 0.0, '0.7', 0.0]"),
    (1, "abcdefg", "'abcdefg'"),
    (2, [0.0] * 7, "[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]"),
])
def test_a_malformed_fed_entry_is_refused_word_for_word(motion, fed, shown):
    f = _stepped(motion)
    n = 25 if motion == 2 else 7
    good = f.get_state()
    bad = f.get_state()
    bad["__internal__"]["fed"] = fed
    assert f.set(ax1O=AX) == OK
    refreshed = f.outputs()
    since = len(f.log)
    assert f.set_state(bad) != OK
    assert f.messages(since).endswith(
        f"{REFUSED}fed = {shown}: expected null or {n} finite numbers (the inputs of the last "
        f"feedthrough refresh)"), f.messages(since)
    assert f.outputs() == refreshed
    good["__internal__"]["fed"] = [H] + [0.0] * (n - 1)
    if motion == 2:
        for i in (16, 20, 24):  # Q = I
            good["__internal__"]["fed"][i] = 1.0
    assert f.set_state(good) == OK, f.messages()
    assert f.get_state()["__internal__"]["fed"] == good["__internal__"]["fed"]
