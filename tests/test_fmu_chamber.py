"""BallInShell with a chamber that moves in 3-D and turns (motion = 2, the FMU side), both
flavours (``built_fmus`` is parametrised over native and pythonfmu).

* motion = 1 with the new inputs at their defaults is the FMU of before bit for bit: the
  sha256 of every original output at every communication point of four runs (input modes
  1, 2, 3, the paper formulation with losses; 0.8 s at 2 ms) is pinned to the digests of
  the build before motion = 2 existed (commit 21eeab2, both flavours gave these same digests on
  x86_64 glibc); and new inputs away from their defaults are ignored (a master may set any
  input), named once.
* motion = 2 with translation-only inputs (Omega = 0, Q = I, z1O = 0) is motion = 1 to
  round-off (a different fit of the same quintic), M_reaction = MO1z = motion 1's crank
  torque + MAz.
* An in-test master (tests/chamber_master.py) feeds the FMU the exact inputs of
  motions.Spin and motions.Fig1Machine and compares with the library's simulate_chamber.
* Both flavours agree bit for bit on motion = 2.
* The power check: with a constant-speed spin the work of the drive, computed from the
  FMU's MO1 and F, is the ball's energy change, computed from its other outputs.
"""
from __future__ import annotations

import hashlib
import math
import struct

import numpy as np
import pytest

from ballmill.fmi.interface import BALL_MOTION_OUTPUTS, BALL_OUTPUTS
from ballmill.physics import Ball
from ballmill.physics.turning import Fig1Machine, Spin, simulate_chamber
from ballmill.physics.turning.motions import SpeedRise
from chamber_master import drive
from fmu_instance import Opened
from tests.conformance.inputs import INPUTS as CRANK_INPUTS
from tests.conformance.inputs import crank as crank_inputs

OUTPUTS = [name for name, _, _ in BALL_OUTPUTS] + ["P_diss", "coupling_error"] + \
    [name for name, _, _ in BALL_MOTION_OUTPUTS]
P_CH = ["xP_ch", "yP_ch", "zP_ch"]
R = 0.25


@pytest.fixture
def opened():
    o = Opened()
    yield o
    o.close_all()


def crank(t, t0=2.5, l=0.5, n0=60.0):
    """The crank start-up law's inputs x1O..ay1O at t, by name."""
    return dict(zip(CRANK_INPUTS, crank_inputs(t, t0, l, n0)))


def run_crank(inst, names, h=0.002, steps=400):
    """Crank-driven run (inputs set before each step); rows of `names` at every point, read
    right after the step (before the next inputs are set: motion = 1's forces feed through from
    x1O, y1O, ax1O, ay1O when they are set, motion = 2's do not)."""
    inst.set(**crank(0.0))
    inst.initialize()
    rows = [inst.reals(names)]
    for k in range(steps):
        inst.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        rows.append(inst.reals(names))
        inst.set(**crank((k + 1) * h))
    return np.array(rows)


# ------------------------------------------------------------------ motion = 1 unchanged
ORIGINAL = ("xP", "yP", "zP", "N", "Fx", "Fy", "Fz", "M_reaction", "MAx", "MAy", "MAz", "xC", "yC", "zC",
            "wx", "wy", "wz", "Ft", "friction_ratio", "P_diss", "coupling_error", "t_invalid")
BEFORE = {  # case: (parameters, the digest of the build before motion = 2)
    "default": ({}, "982a695b285e0a091bee5bb900a4f944"),
    # input_mode 2: every output as before motion = 2 but coupling_error, which since covers the
    # positions' round-off too (at most 0.05 % more here, |x1O| <= 0.5 m; was 528f0324ec81...)
    "positions": ({"input_mode": 2}, "ad53c2fff959a3dfd0778f93ead62b37"),
    "hold-RK4": ({"input_mode": 3, "integrator": 3}, "42a09dcaac7359c6412b75d885f18a4d"),
    "paper-losses": ({"formulation": 2, "integrator": 1, "delta": 1e-4, "c_drag": 0.05},
                     "a944740867d7965c3eef500cc5eb5964"),
}


@pytest.mark.parametrize("case", list(BEFORE))
def test_motion_1_is_the_fmu_of_before_bit_for_bit(built_fmus, opened, case):
    parameters, before = BEFORE[case]
    inst = opened.open(built_fmus["BallInShell"], "m1" + case, **parameters)
    rows = run_crank(inst, list(ORIGINAL))
    sha = hashlib.sha256()
    for row in rows:
        sha.update(struct.pack(f"{len(row)}d", *row))
    assert sha.hexdigest()[:32] == before


@pytest.mark.parametrize("name, value", [("Omega_z", 0.5), ("Q12", 0.1), ("z1O", 1e-3), ("az1O", -9.81)])
def test_motion_1_ignores_new_inputs_away_from_their_defaults(built_fmus, opened, name, value):
    """A master may set any input: set before the initialisation and kept, an input of
    motion = 2 leaves the motion = 1 run as it is, bit for bit, and is named once."""
    plain = run_crank(opened.open(built_fmus["BallInShell"], "m1plain"), OUTPUTS, steps=20)
    inst = opened.open(built_fmus["BallInShell"], "m1ignore")
    inst.set(**{name: value})
    assert np.array_equal(run_crank(inst, OUTPUTS, steps=20), plain)
    text = " | ".join(m for _, m in inst.messages)
    assert text.count("is ignored") == 1 and f"input {name} = {value!r}" in text and "set motion = 2" in text, text


def test_motion_2_names_none_of_its_inputs_as_ignored(built_fmus, opened):
    """motion = 2 takes those inputs (here the chamber turning at Omega_z = 0.5 rad/s about its
    vertical axis, Q following it): none is named as ignored, at initialisation or at a step."""
    inst = opened.open(built_fmus["BallInShell"], "m2turns", motion=2)

    def turned(t):
        c, s = math.cos(0.5 * t), math.sin(0.5 * t)
        return dict(crank(t), Omega_z=0.5, Q11=c, Q12=-s, Q21=s, Q22=c)
    inst.set(**turned(0.0))
    inst.initialize()
    for k in range(10):
        inst.fmu.doStep(currentCommunicationPoint=k * 0.002, communicationStepSize=0.002)
        inst.set(**turned((k + 1) * 0.002))
    assert np.isfinite(inst.get("N")) and inst.get("valid")
    assert [m for _, m in inst.messages if "is ignored" in m] == []


_C, _S = math.cos(0.3), math.sin(0.3)


@pytest.mark.parametrize("tilted", [
    dict(Q22=_C, Q23=-_S, Q32=_S, Q33=_C),
    # a third of a turn about (1, -1, 1) / sqrt(3): the chamber's axes permuted with signs, every
    # cofactor of det Q in play (-Q12 Q23 (Q31 - Q23) = -2 would turn a wrong cofactor's det to -1)
    dict(Q11=0.0, Q12=-1.0, Q13=0.0, Q21=0.0, Q22=0.0, Q23=-1.0, Q31=1.0, Q32=0.0, Q33=0.0),
], ids=["about-x", "permuted"])
def test_a_tilted_chamber_starts_the_ball_where_the_python_flavour_does(fmus_of, opened, tilted):
    """motion = 2 at rest, the chamber tilted (by 0.3 rad about x: Q with every row mixed but the
    first; or its axes permuted): the initial state (xC0, yC0 in the chamber's axes) turned into
    the frame's, and the steps from it, in the native flavour equal the pythonfmu twin's bit for
    bit."""
    rows = {}
    for flavour in ("native", "pythonfmu"):
        inst = opened.open(fmus_of(flavour)["BallInShell"], f"tilted_{flavour}", motion=2, xC0=0.05, yC0=0.02)
        inst.set(**tilted)
        inst.initialize()
        rows[flavour] = [inst.reals(OUTPUTS)]
        for k in range(5):
            inst.fmu.doStep(currentCommunicationPoint=k * 0.002, communicationStepSize=0.002)
            inst.set(**tilted)
            rows[flavour].append(inst.reals(OUTPUTS))
    assert rows["native"] == rows["pythonfmu"]


# --------------------------------------------------- motion = 2 with a translation only
def test_motion_2_with_translation_only_inputs_is_motion_1(built_fmus, opened):
    """The same scene on both models: the contact point within 1e-12 m, forces within 1e-10 N
    over 0.8 s of the fast start (measured: 4e-15 m, 5e-12 N, 1.4e-12 rad/s; the fits are the same
    quintic, written differently, and the ball's swing does not amplify round-off here)."""
    a = run_crank(opened.open(built_fmus["BallInShell"], "m1"), OUTPUTS)
    b = run_crank(opened.open(built_fmus["BallInShell"], "m2", motion=2), OUTPUTS)
    col = {n: j for j, n in enumerate(OUTPUTS)}
    for name in OUTPUTS:
        if name == "M_reaction":
            continue
        tol = 1e-12 if name[0] in "xyz" or name in ("xP_ch", "yP_ch", "zP_ch") else 1e-10
        if name[0] == "w":
            tol = 1e-9  # rad/s: omega ~ 10 rad/s
        err = np.max(np.abs(a[:, col[name]] - b[:, col[name]]))
        assert err <= tol, (name, err)
    # M_reaction is the moment about the vertical axis through O1: with motion = 2 MO1z, the
    # crank's torque of motion = 1 plus the moment about A
    mr = a[:, col["M_reaction"]] + a[:, col["MAz"]]
    assert np.max(np.abs(b[:, col["M_reaction"]] - mr)) <= 1e-10
    assert np.array_equal(b[:, col["M_reaction"]], b[:, col["MO1z"]])


# ---------------------------------------------------------- against the library
def _library(motion, t_end, dt, **kw):
    tr = simulate_chamber(Ball(), motion, t_end=t_end, dt=dt, tol=1e-13, **kw)
    assert tr.success, tr.message
    return tr


def test_spinning_bowl_against_the_library(built_fmus, opened):
    """motions.Spin: Omega = (0, 0, 3) rad/s about the vertical through the fixed A, the ball
    at xC0 = 0.05 m co-rotating. The inputs are constant in the chamber's terms (O fixed, a_A = 0,
    Omega constant), so every fit is exact and the FMU is the library to its tolerance."""
    motion = Spin((0.0, 0.0, 3.0), (0.0, 0.0, R))
    ref = _library(motion, 2.0, 0.01, xC0=0.05)
    inst = opened.open(built_fmus["BallInShell"], "bowl", motion=2, xC0=0.05, integrator=1, tolerance=1e-12)
    times, rows, status = drive(inst, motion, R, 0.01, 2.0, P_CH + ["N", "wz"])
    assert status == 0
    rows = np.array(rows)
    err = np.max(np.linalg.norm(rows[:, :3] - np.c_[ref["Pch_x"], ref["Pch_y"], ref["Pch_z"]], axis=1))
    assert err < 1e-9, err
    assert np.max(np.abs(rows[:, 3] - ref["N"])) < 1e-8
    # the ball swings through the bowl's bottom: its contact point leaves the starting point
    assert np.ptp(rows[:, 0]) > 0.05
    # the chamber's fit is exact here: no warning about the positions' resolution (a translation's)
    assert [m for _, m in inst.log if "resolution" in m] == []


def test_fig1_machine_against_the_library_converges_at_fourth_order(built_fmus, opened):
    """motions.Fig1Machine (frame 0.5 rad/s about x1, the paper's crank start-up): the FMU sees
    the motion at communication points only. Over 0 - 2 s (smooth: before the crank law's kink at
    t0 = 2.5 s) the contact point's error against the library (DOP853 at 1e-13) falls by more than
    2^4 per halving of the step: the fit of a_A is a Hermite quintic through (A, v_A, a_A) at two
    nodes, a_A's extrapolation error O(h^4), and the corrector redoes each step along the
    interpolating fit (measured: 1.1e-6, 2.6e-10, 4.1e-12, 7.5e-14 m at h = 20, 10, 5, 2.5 ms)."""
    motion = Fig1Machine()
    ref = _library(motion, 2.0, 0.02)
    Pref = np.c_[ref["Pch_x"], ref["Pch_y"], ref["Pch_z"]]
    errs = []
    for h in (0.01, 0.005, 0.0025):
        inst = opened.open(built_fmus["BallInShell"], f"fig1_{h}", motion=2, integrator=1, tolerance=1e-12)
        _, rows, status = drive(inst, motion, R, h, 2.0, P_CH)
        assert status == 0
        rows = np.array(rows)[::int(round(0.02 / h))]
        errs.append(np.max(np.linalg.norm(rows - Pref, axis=1)))
    assert errs[1] < 1e-10, errs
    assert errs[0] / errs[1] > 16.0 and errs[1] / errs[2] > 16.0, errs


def test_the_library_says_where_validity_ended_as_the_fmu_does(built_fmus, opened):
    """The Fig. 1 machine slips at 2.508 s and leaves the wall at 2.585 s: the library's
    simulate_chamber says so (t_first_slip, t_first_flight, interpolated between its 10 ms
    samples), and the FMU at 10 ms communication steps latches valid = false at the end of the
    step in which the slip began and names the step in which contact was lost: the library's
    times lie within those steps."""
    import re

    h = 0.01
    lib = simulate_chamber(Ball(), Fig1Machine(), 10.0, h)
    assert lib.success and not lib.valid
    inst = opened.open(built_fmus["BallInShell"], "validity", motion=2)
    _, rows, status = drive(inst, Fig1Machine(), R, h, 2.7, ["t_invalid"])
    assert status == 0
    t_invalid = rows[-1][0]
    assert t_invalid - h < lib.t_invalid == lib.t_first_slip <= t_invalid
    text = " | ".join(m for _, m in inst.messages)
    a, b = map(float, re.search(r"contact lost between t = (\S+) s and (\S+) s", text).groups())
    assert a < lib.t_first_flight <= b and b - a == pytest.approx(h)


@pytest.mark.parametrize("parameters, motion", [
    ({}, Fig1Machine()), ({"integrator": 1, "tolerance": 1e-10}, Fig1Machine()),
    ({"integrator": 3, "input_mode": 3}, Fig1Machine()), ({"corrector": False}, Fig1Machine()),
    # Omega with two components about a tilted axis: every term of the centre's acceleration
    # Omega x (Omega x R Q e3) (the Fig. 1 machine turns about x only)
    ({}, Spin((0.0, 1.0, 2.0), (0.0, 0.0, R))),
    # the frame's rate rising (quadratic law, to 0.5 rad/s in 0.6 s): Omega's fit between samples
    # has quadratic and cubic terms, which the turned angle and the chamber's orientation at
    # the step's end integrate (the other cases turn at constant rates, where they are 0)
    ({}, Fig1Machine(frame=SpeedRise(0.5, 0.6))),
], ids=["RK45", "DOP853", "RK4-hold", "no-corrector", "RK45-tilted-spin", "RK45-frame-rising"])
def test_flavours_agree_bit_for_bit_on_motion_2(fmus_of, opened, parameters, motion):
    got = []
    for flavour in ("native", "pythonfmu"):
        inst = opened.open(fmus_of(flavour)["BallInShell"], f"bits_{flavour}", motion=2, xC0=0.03,
                           wz0=1.0, **parameters)
        _, rows, status = drive(inst, motion, R, 0.004, 1.0, OUTPUTS)
        assert status == 0
        got.append(np.array(rows))
    assert np.array_equal(got[0], got[1]), np.max(np.abs(got[0] - got[1]), axis=0)


# ------------------------------------------------------------------ power check
def test_drive_power_from_MO1_and_F_is_the_balls_energy_change(built_fmus, opened):
    """A tumbling drum (Omega = (0.8, 0, 0) rad/s about x through the fixed A): the spin's drive
    (twist w = Omega/|Omega|, v = A x w, rate |Omega|) feels M = w . MO1 + v . F, so it delivers
    the power P = -(Omega . MO1 + (A x Omega) . F) to the ball. Its integral (trapezoid over the
    2 ms communication points) must equal the ball's energy change E(t) - E(0), with E from the
    FMU's other outputs: E = 1/2 m |v_C|^2 + 1/2 I |omega|^2 + m g zC, v_C = d n' and
    n' = (R/d) Omega x n + (r/d) n x omega. The ball's energy swings by 0.015 J; the
    trapezoid's error, T h^2 max|P''| / 12 ~ 2 s (2 ms)^2 (6 W/s^2) / 12 ~ 4e-6 J at most,
    bounds the tolerance (measured: 1.5e-7 J); a wrong sign or lever arm in MO1 or F would
    miss by ~1e-2 J."""
    ball = Ball()
    Om = np.array([0.8, 0.0, 0.0])
    A = np.array([0.0, 0.0, R])
    motion = Spin(tuple(Om), tuple(A))
    inst = opened.open(built_fmus["BallInShell"], "drum", motion=2, integrator=1, tolerance=1e-12)
    names = ["xC", "yC", "zC", "wx", "wy", "wz", "Fx", "Fy", "Fz", "MO1x", "MO1y", "MO1z"]
    times, rows, status = drive(inst, motion, R, 0.002, 2.0, names)
    assert status == 0
    rows, times = np.array(rows), np.array(times)
    e = np.array([[R * q[2], R * q[5], R * q[8]] for q in (motion.orientation(t) for t in times)])
    n = (rows[:, 0:3] - e) / ball.d  # C - O = d n + Q (0, 0, R)
    w = rows[:, 3:6]
    nd = (R / ball.d) * np.cross(Om, n) + ball.lam * np.cross(n, w)
    E = (0.5 * ball.m * ball.d ** 2 * np.sum(nd * nd, axis=1) + 0.5 * ball.I * np.sum(w * w, axis=1)
         + ball.m * ball.g * (A[2] + ball.d * n[:, 2]))
    F, MO1 = rows[:, 6:9], rows[:, 9:12]
    P = -(MO1 @ Om + F @ np.cross(A, Om))
    work = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(times))])
    assert np.ptp(E) > 0.01  # the drum lifts the ball: a real exchange of energy
    assert np.max(np.abs((E - E[0]) - work)) < 1e-6, np.max(np.abs((E - E[0]) - work))


def test_spinning_bowl_small_oscillations_through_the_fmu_match_the_closed_form(built_fmus, opened):
    """The closed-form anchor of the turning chamber through the FMU: in a bowl spinning at Omega about the
    vertical through its fixed centre, small swings z = n_x + i n_y are A+ exp(i s+ t) + A-
    exp(i s- t) with s+- = beta/2 +- sqrt(beta^2/4 + w0^2), beta = Omega (2/5)/(7/5)
    (ballmill.studies.fig1.bowl_frequencies; the ball starts at rest relative to the bowl,
    z(0) = z0, z'(0) = i Omega z0). At xC0 = 1 mm (eps = 4.4e-3 rad) the neglected terms are
    O(eps^2) = 2e-5 relative; over 10 s (60 rad of the fast mode) a phase error ~1e-3: bound
    3e-3 of the amplitude. A ball that ignored the spin (beta = 0) would be off by > 0.3."""
    from ballmill.studies.fig1 import bowl_frequencies

    ball, Om = Ball(), 3.0
    motion = Spin((0.0, 0.0, Om), (0.0, 0.0, R))
    inst = opened.open(built_fmus["BallInShell"], "bowl_small", motion=2, xC0=0.001, integrator=1,
                       tolerance=1e-11)
    times, rows, status = drive(inst, motion, R, 0.01, 10.0, ["xC", "yC"])
    assert status == 0
    t, rows = np.array(times), np.array(rows)
    z = (rows[:, 0] + 1j * rows[:, 1]) / ball.d  # C - O = d n + (0, 0, R)
    sp_, sm = bowl_frequencies(Om)
    z0 = 0.001 / ball.d
    zl = z0 * ((Om - sm) * np.exp(1j * sp_ * t) + (sp_ - Om) * np.exp(1j * sm * t)) / (sp_ - sm)
    assert np.abs(z - zl).max() / z0 <= 3e-3
    w0 = ball.omega_small  # without the spin's coupling
    still = z0 * (np.cos(w0 * t) + 1j * (Om / w0) * np.sin(w0 * t))
    assert np.abs(z - still).max() / z0 > 0.3
