"""BallInShell's direct feedthrough between steps (`BallInShell.inputs_set`, motion = 1), on the
pythonfmu slave in this process (tests/mutation/inprocess.py), where mutmut sees it: after a
step, fmi2SetReal of x1O, y1O, ax1O, ay1O (motion = 2: also the chamber's vertical motion,
angular velocity and acceleration and orientation) recomputes the outputs of
interface.BALL_FEEDTHROUGH at the FMU's time on the published state, without stepping (input
modes 1, 3, 4); with positions alone (mode 2) nothing is refreshed (the acceleration is
reconstructed at the next step).

The reference values are closed forms. A ball at rest at the bottom of a chamber that
accelerates horizontally by a: in the chamber's frame it is a pendulum of length d = R - r whose
rolling makes the inertia 7/5 m (m r^2 (2/5) about C plus m r^2 about the contact), so its swing
starts with d theta'' = -(5/7) a and its centre's absolute acceleration is a - (5/7) a = (2/7) a.
The ball's force on the chamber is then F = (-(2/7) m a_x, -(2/7) m a_y, -m g), N = m g, the
friction force (2/7) m |a|; the contact point is P = O = (x1O, y1O, 0) with the chamber centre
A = (x1O, y1O, R) right above it, so M_A = (P - A) x F = (R F_y, -R F_x, 0) and
M_O1 = A x F + M_A = P x F = (y1O F_z, -x1O F_z, x1O F_y - y1O F_x), M_reaction = MO1z."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import OK, InProcessFmu  # noqa: E402

from ballmill.fmi.interface import BALL_FEEDTHROUGH  # noqa: E402

H = 0.01  # s, one communication step
X, Y, AX, AY = 0.1, -0.05, 0.7, -0.4  # the chamber's new position (m) and acceleration (m/s2)


def _close(a, b, tol=1e-12):
    return abs(a - b) <= tol * max(1.0, abs(b))


def _at_rest_after_one_step(mode, motion=1):
    """A ball at rest at the bottom of a chamber at rest, one step later (still at rest)."""
    f = InProcessFmu("BallInShell", f"feed{mode}", input_mode=mode, motion=motion)
    assert f.init() == OK, f.messages()
    assert f.step(H) == OK, f.messages()
    return f


@pytest.mark.parametrize("mode, motion", [(1, 1), (3, 1), (4, 1), (1, 2), (3, 2)])
def test_new_chamber_inputs_between_steps_refresh_the_force_and_moments(mode, motion):
    """(With motion = 2 the chamber does not turn here, Q = I: the same closed form.)"""
    f = _at_rest_after_one_step(mode, motion)
    m, g, R = f.get("m"), f.get("g"), f.get("R")
    before = f.outputs()
    assert before["Fx"] == 0.0 and before["Fy"] == 0.0 and _close(before["Fz"], -m * g)
    assert f.set(x1O=X, y1O=Y, ax1O=AX, ay1O=AY) == OK, f.messages()
    out = f.outputs()
    Fx, Fy, Fz = -2.0 / 7.0 * m * AX, -2.0 / 7.0 * m * AY, -m * g
    ft = 2.0 / 7.0 * m * math.hypot(AX, AY)
    expected = {"Fx": Fx, "Fy": Fy, "Fz": Fz, "N": m * g, "Ft": ft, "friction_ratio": ft / (m * g),
                "MAx": R * Fy, "MAy": -R * Fx, "MAz": 0.0,
                "MO1x": Y * Fz, "MO1y": -X * Fz, "MO1z": X * Fy - Y * Fx, "M_reaction": X * Fy - Y * Fx,
                "Fx_ch": Fx, "Fy_ch": Fy, "Fz_ch": Fz, "P_diss": 0.0, "P_grind": 0.0, "contact": True, "rolling": True}
    assert set(expected) == set(BALL_FEEDTHROUGH)
    for name, value in expected.items():
        assert _close(out[name], value), (mode, name, out[name], value)
    # what does not depend on the chamber's acceleration at this instant stays as published
    for name in set(before) - set(BALL_FEEDTHROUGH):
        assert out[name] == before[name], (mode, name, before[name], out[name])
    assert out["valid"] is True and f.time == H
    # a non-finite input is left to the next step (which refuses it): the outputs stay
    assert f.set(ax1O=math.nan) == OK
    assert f.outputs() == out


def test_positions_alone_refresh_nothing_between_steps():
    f = _at_rest_after_one_step(2)
    before = f.outputs()
    assert f.set(x1O=X, y1O=Y, ax1O=AX, ay1O=AY) == OK, f.messages()
    assert f.outputs() == before


def test_inputs_set_again_unchanged_keep_the_steps_outputs_and_its_prediction_reproduces_them():
    """A chamber at constant acceleration a from rest: x1O = a t^2 / 2, v = a t. The step's outputs
    at t = H use the inputs extrapolated to H (exact for this quadratic). Setting again the values of
    the last sample (t = 0: nothing new from the master) leaves them bit for bit; setting the
    values at H, which the step extrapolated, gives them again to rounding; a new acceleration
    changes the force."""
    f = InProcessFmu("BallInShell", "feed_same", input_mode=1, ax1O=AX, ay1O=AY)
    assert f.init() == OK and f.step(H) == OK, f.messages()
    stepped = f.outputs()
    assert f.set(x1O=0.0, y1O=0.0, vx1O=0.0, vy1O=0.0, ax1O=AX, ay1O=AY) == OK
    assert f.outputs() == stepped
    assert f.set(x1O=0.5 * AX * H * H, y1O=0.5 * AY * H * H, vx1O=AX * H, vy1O=AY * H) == OK
    again = f.outputs()
    for name in BALL_FEEDTHROUGH:
        assert _close(float(again[name]), float(stepped[name]), 1e-10), (name, again[name], stepped[name])
    # the moments about O1 see the chamber's displacement since the sample at t = 0
    assert abs(stepped["MO1x"] - 0.0) > 1e-6 and abs(stepped["MO1y"]) > 1e-6
    assert f.set(ax1O=2.0 * AX) == OK
    changed = f.outputs()
    assert changed["Fx"] < stepped["Fx"] - 0.1 * f.get("m") * AX
    assert changed["Fy"] == pytest.approx(stepped["Fy"], rel=1e-2)
