"""BallInShell's chamber motion (motion = 2) through the FMI API: the inputs of motion = 2 are
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


def q_of(t, tilt=0.0):
    """Rz(W t) Rx(tilt): the chamber turned by tilt about its x axis, spinning about z1."""
    c, s = math.cos(W * t), math.sin(W * t)
    ca, sa = math.cos(tilt), math.sin(tilt)
    return dict(Q11=c, Q12=-s * ca, Q13=s * sa, Q21=s, Q22=c * ca, Q23=-c * sa, Q31=0.0, Q32=sa, Q33=ca)


def feed(fmu, t, tilt=0.0, **override):
    values = dict(x1O=0.0, y1O=0.0, z1O=0.0, az1O=0.0, Omega_x=0.0, Omega_y=0.0, Omega_z=W, **q_of(t, tilt))
    values.update(override)
    assert fmu.set(**values) == OK


def spinning(open_fmu, steps, tilt=0.0, **parameters):
    fmu = open_fmu("BallInShell", motion=2, xC0=0.04, **parameters)
    feed(fmu, 0.0, tilt)
    assert fmu.init() == OK, fmu.messages()
    for k in range(steps):
        assert fmu.step(H) == OK, fmu.messages()
        feed(fmu, fmu.time, tilt)
    return fmu


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


@pytest.mark.parametrize("change, tilt", [
    ({"az1O": 1.5}, 0.0), ({"ax1O": -0.8, "ay1O": 0.3}, 0.0), ({"Omega_dot_x": 0.7}, 0.0),
    ({"Omega_dot_z": 2.0}, 0.0), ({"az1O": 0.4, "Omega_dot_y": -1.1}, 0.0),
    # a tilted chamber: A - O has x and y components, so each of Omega' x (A - O)'s terms counts
    ({"Omega_dot_z": 2.0}, 0.3), ({"Omega_dot_y": -1.1, "Omega_dot_z": 0.6}, 0.3),
], ids=lambda c: ",".join(c) if isinstance(c, dict) else f"tilt{c:g}")
def test_the_load_on_the_chamber_follows_its_acceleration_without_a_step(open_fmu, change, tilt):
    """motion = 2 has the declared feedthrough too (the outputs were left as the step made
    them). Newton for the rolling ball, m a_C = F + m g, with the constraint's own part:
    changing the chamber centre's acceleration by da_A (= da_O + dOmega' x (A - O)) and the
    angular acceleration by dOmega' changes a_C by (da_A . n) n + c (da_A - (da_A . n) n)
    + c R dOmega' x n with c = I / (I + m r^2) = 2/7; the load on the chamber F_s = -F changes
    by -m da_C, N = m (g - a_C) . n by -m da_A . n, the moment about O1 by P x dF_s. n from the
    outputs: C - A = (R - r) n, A - O = R Q e3; O stays at the origin, so P - O is P."""
    fmu = spinning(open_fmu, 20, tilt)
    m, r, R = fmu.get("m"), fmu.get("r"), fmu.get("R")
    d, c = R - r, 0.4 / 1.4
    before = fmu.outputs()
    inputs = {k: fmu.get(k) for k in ("Q13", "Q23", "Q33", *change)}
    q3 = (inputs["Q13"], inputs["Q23"], inputs["Q33"])
    n = tuple((before[k] - R * e) / d for k, e in zip(("xC", "yC", "zC"), q3))
    assert fmu.set(**{k: inputs[k] + v for k, v in change.items()}) == OK
    after = fmu.outputs()
    da_o = tuple(change.get(k, 0.0) for k in ("ax1O", "ay1O", "az1O"))
    dp = tuple(change.get(k, 0.0) for k in ("Omega_dot_x", "Omega_dot_y", "Omega_dot_z"))
    da_a = tuple(a + b for a, b in zip(da_o, _cross(dp, tuple(R * e for e in q3))))
    normal = _dot(da_a, n)
    spin = _cross(dp, n)
    da_c = tuple(normal * ni + c * (a - normal * ni) + c * R * s for ni, a, s in zip(n, da_a, spin))
    dF = tuple(-m * a for a in da_c)
    assert after["N"] - before["N"] == pytest.approx(-m * normal, abs=1e-11)
    for k, v in zip(("Fx", "Fy", "Fz"), dF):
        assert after[k] - before[k] == pytest.approx(v, abs=1e-11), k
    P = (before["xP"], before["yP"], before["zP"])
    for k, v in zip(("MO1x", "MO1y", "MO1z"), _cross(P, dF)):
        assert after[k] - before[k] == pytest.approx(v, abs=1e-11), k
    assert after["M_reaction"] == after["MO1z"]
    for k in ("xP", "yP", "zP", "xC", "yC", "zC", "wx", "wy", "wz"):  # the state is untouched
        assert after[k] == before[k], k
    # back to the inputs the outputs were computed from: the same outputs, bit for bit
    assert fmu.set(**{k: inputs[k] for k in change}) == OK
    assert fmu.outputs() == before


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


def test_a_skewed_orientation_is_refused_showing_the_two_rows_that_disagree(open_fmu, flavour):
    """Rows 1 and 2 of Q no longer orthogonal: the message gives their product, what it should
    be, and both rows by element name, so the user sees which entries to check."""
    fmu = open_fmu("BallInShell", motion=2)
    feed(fmu, 0.0, Q12=-0.2)
    assert fmu.init() == flavour.refusal
    assert ("input Q is not a rotation matrix: row 1 . row 2 = -0.2, expected 0.0 within 1e-06 (Q11 = 1.0, "
            "Q12 = -0.2, Q13 = 0.0, Q21 = 0.0, Q22 = 1.0, Q23 = -0.0) at t = 0.0 s") in fmu.messages(), fmu.messages()


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


def test_a_rotation_that_permutes_the_axes_is_accepted(open_fmu, flavour):
    """Q = the cyclic permutation of the axes (a rotation by 120 degrees about (1, 1, 1): det Q = +1
    with zeros on the diagonal, so every term of the determinant's expansion counts) is a
    rotation: accepted at initialisation and in steps; two of its rows swapped (det -1) is
    refused as a reflection."""
    cyclic = dict(Q11=0.0, Q12=1.0, Q13=0.0, Q21=0.0, Q22=0.0, Q23=1.0, Q31=1.0, Q32=0.0, Q33=0.0)
    fmu = open_fmu("BallInShell", motion=2)
    assert fmu.set(**cyclic) == OK
    assert fmu.init() == OK, fmu.messages()
    for _ in range(3):
        assert fmu.step(H) == OK, fmu.messages()
    assert "rotation" not in fmu.messages()
    mirrored = open_fmu("BallInShell", motion=2)
    assert mirrored.set(**dict(cyclic, Q21=1.0, Q23=0.0, Q31=0.0, Q33=1.0)) == OK  # rows 2 and 3 swapped
    assert mirrored.init() == flavour.refusal
    assert "input Q is not a rotation matrix: det Q = -1.0, expected +1 (a reflection)" in mirrored.messages()
