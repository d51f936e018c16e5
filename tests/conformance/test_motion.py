"""BallInShell's chamber motion (issue 12) through the FMI API: the inputs of motion = 2 are
checked like the platform's (a non-finite value, an orientation that is not a rotation: the
step refused with the variable and value named, the state kept; at initialisation: refused),
motion = 2's configuration limits are refused with their reason, and FMU states carry
everything new (the chamber's input history, motion = 2's ball state) through get/set and
serialize, and fmi2Reset returns to motion = 1's defaults."""
from __future__ import annotations

import math

import pytest

from .conftest import DISCARD, OK

H = 2e-3
W = 0.5  # rad/s about z: the chamber spins, O stays where it is


def q_of(t):
    c, s = math.cos(W * t), math.sin(W * t)
    return dict(Q11=c, Q12=-s, Q13=0.0, Q21=s, Q22=c, Q23=0.0, Q31=0.0, Q32=0.0, Q33=1.0)


def feed(fmu, t, **override):
    values = dict(x1O=0.0, y1O=0.0, z1O=0.0, az1O=0.0, Omega_x=0.0, Omega_y=0.0, Omega_z=W, **q_of(t))
    values.update(override)
    assert fmu.set(**values) == OK


def spinning(open_fmu, steps, **parameters):
    fmu = open_fmu("BallInShell", motion=2, xC0=0.04, **parameters)
    feed(fmu, 0.0)
    assert fmu.init() == OK, fmu.messages()
    for k in range(steps):
        assert fmu.step(H) == OK, fmu.messages()
        feed(fmu, fmu.time)
    return fmu


@pytest.mark.parametrize("override, expected", [
    ({"Q12": -0.2}, "input Q is not a rotation matrix: row 1 . row 2"),
    ({"Q11": 1.0, "Q12": 0.0, "Q21": 0.0, "Q22": -1.0}, "det Q = -1.0, expected +1 (a reflection)"),
    ({"Omega_y": float("nan")}, "input Omega_y must be finite, got nan"),
    ({"az1O": float("inf")}, "input az1O must be finite, got inf"),
])
def test_a_bad_chamber_input_refuses_the_step_and_keeps_the_state(open_fmu, flavour, override, expected):
    fmu = spinning(open_fmu, 5)
    before, t = fmu.outputs(), fmu.time
    feed(fmu, fmu.time, **override)
    since = len(fmu.log)
    assert fmu.step(H) == DISCARD
    assert expected in fmu.messages(since), fmu.messages(since)
    assert fmu.outputs() == before and fmu.time == t
    feed(fmu, fmu.time)  # the good inputs again: the step goes on
    assert fmu.step(H) == OK


def test_a_bad_orientation_at_initialisation_is_refused(open_fmu, flavour):
    fmu = open_fmu("BallInShell", motion=2)
    feed(fmu, 0.0, Q33=-1.0)
    assert fmu.init() == flavour.refusal
    assert "initialisation failed: input Q is not a rotation matrix" in fmu.messages(), fmu.messages()


@pytest.mark.parametrize("parameters, expected", [
    ({"formulation": 2}, "motion = 2 needs formulation = 1"),
    ({"input_mode": 2}, "input_mode = 2 is not available with motion = 2"),
    ({"input_mode": 4}, "input_mode = 4 is not available with motion = 2"),
    ({"delta": 1e-4}, "motion = 2 is lossless: delta = 0.0001 m"),
    ({"motion": 3}, "parameter motion = 3 is outside its accepted range [1, 2]"),
])
def test_motion_2_configuration_limits_are_refused(open_fmu, flavour, parameters, expected):
    fmu = open_fmu("BallInShell", **{"motion": 2, **parameters})
    feed(fmu, 0.0)
    assert fmu.init() == flavour.refusal
    assert expected in fmu.messages(), fmu.messages()


def test_state_round_trip_with_motion_2(open_fmu):
    a = spinning(open_fmu, 20)
    s = a.get_state()
    blob = a.serialize(s)
    t_saved = a.time
    outs = []
    for _ in range(10):  # the continuation, once
        assert a.step(H) == OK
        feed(a, a.time)
        outs.append(a.outputs())
    assert a.set_state(s) == OK  # back, in memory
    a.time = t_saved
    for k in range(10):
        assert a.step(H) == OK
        feed(a, a.time)
        assert a.outputs() == outs[k]
    st, s2 = a.deserialize(blob)  # and from the serialised bytes
    assert st == OK and a.set_state(s2) == OK
    a.time = t_saved
    assert a.get("motion") == 2
    for k in range(10):
        assert a.step(H) == OK
        feed(a, a.time)
        assert a.outputs() == outs[k]
    assert outs[-1]["xP_ch"] != outs[0]["xP_ch"]  # the ball moves in the chamber


def test_a_motion_2_state_restores_motion_2_into_a_motion_1_instance(open_fmu):
    a = spinning(open_fmu, 10)
    b = open_fmu("BallInShell")
    assert b.set(x1O=0.0) == OK and b.init() == OK
    for _ in range(10):
        assert b.step(H) == OK
    assert b.set_state(a.get_state()) == OK
    assert b.get("motion") == 2
    for f in (a, b):
        assert f.step(H) == OK
    assert b.outputs() == a.outputs()


def test_reset_returns_to_motion_1_defaults(open_fmu):
    fmu = spinning(open_fmu, 5)
    assert fmu.reset() == OK
    assert fmu.init() == OK  # the defaults: a motion = 1 instance that initialises
    assert fmu.get("motion") == 1 and fmu.get("Omega_z") == 0.0 and fmu.get("Q11") == 1.0
    assert fmu.step(H) == OK


def test_a_jump_in_the_chamber_inputs_is_flagged_and_the_reconstruction_restarts(open_fmu):
    """Mode 1's consistency check on the chamber centre (docs/conformance.md): a master that
    sets the spin only from the second communication point on (the chamber's centre then
    jumps in velocity and acceleration: A - O turns at once) is flagged, valid latches false
    with that time, and the history restarts there; a consistent run is not flagged."""
    fmu = open_fmu("BallInShell", motion=2, xC0=0.04, R=0.25)
    feed(fmu, 0.0, Omega_z=0.0, Q33=1.0)
    fmu.set(Q11=1.0, Q12=0.0, Q21=0.0, Q22=1.0, x1O=0.1)
    assert fmu.init() == OK
    assert fmu.step(H) == OK
    fmu.set(Omega_x=2.0, Q22=math.cos(0.004), Q23=-math.sin(0.004), Q32=math.sin(0.004), Q33=math.cos(0.004))
    assert fmu.step(H) == OK
    log = fmu.messages()
    assert "the chamber centre A = O + Q (0, 0, R) of the inputs" in log, log
    assert "the reconstruction restarts at the newer sample" in log
    assert fmu.get("valid") is False and fmu.get("t_invalid") == H
    ok = spinning(open_fmu, 200)
    assert ok.get("valid") is True, ok.messages()


def test_motion_is_fixed_after_initialisation(open_fmu, flavour):
    fmu = spinning(open_fmu, 2)
    n = len(fmu.log)
    assert fmu.set(motion=1) == flavour.refusal
    assert "parameter motion is fixed" in fmu.messages(n) and "motion keeps 2" in fmu.messages(n)
    if flavour.usable_after_refusal:
        assert fmu.get("motion") == 2
