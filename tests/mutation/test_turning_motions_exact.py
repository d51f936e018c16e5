"""The chamber's prescribed motions (ballmill.physics.turning.motions) field by field against
an independent derivation: the Fig. 1 machine's centre, velocity and acceleration as matrix
products A = R(phi) a(psi), v = phi' R' a + psi' R a_psi, a = phi'' R' a + phi'^2 R'' a +
2 phi' psi' R' a_psi + psi'' R a_psi + psi'^2 R a_psipsi (R, R', R'' written out as matrices;
the module works with cross products in scalars), on both shafts and both arrangements with
both angle laws accelerating; the spin's orientation by Rodrigues' formula in matrix form; the
translation's drives; every default and every refusal word for word. Written for mutants that
the rest of the suite let through (docs/mutation.md); every value is computed inside a test."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import CrankStartup, Harmonic
from ballmill.physics.drives.crank import rise_angle
from ballmill.physics.errors import ParameterError
from ballmill.physics.turning.motions import (NSTATE, ChamberMotion, ChamberState, ConstantSpeed, Fig1Machine,
                                              SpeedRise, Spin, Translation)

# A ChamberState's fields by position (module docstring): A, vA, aA, Omega, Omega', Q, drive 1, drive 2
A_, VA, AA, OM, OMD, Q_ = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15), slice(15, 24)
D1, D2 = slice(24, 31), slice(31, 38)


def _raises(call, message):
    with pytest.raises(ParameterError) as e:
        call()
    assert str(e.value) == message


# ---------------------------------------------------------------------------- refusals
@pytest.mark.parametrize("call, message", [
    (lambda: Spin(Omega="ab"), "Omega must be 3 numbers, got 'ab'"),
    (lambda: Spin(Omega=3.0), "Omega must be 3 numbers, got 3.0"),
    (lambda: Spin(Omega=(1, 2)), "Omega must be 3 finite numbers, got Omega = (1, 2)"),
    (lambda: Spin(Omega=(1, 2, 3, 4)), "Omega must be 3 finite numbers, got Omega = (1, 2, 3, 4)"),
    (lambda: Spin(Omega=(0.0, math.nan, 1.0)), "Omega must be 3 finite numbers, got Omega = (0.0, nan, 1.0)"),
    (lambda: Spin(A=(0, 0, math.inf)), "A must be 3 finite numbers, got A = (0, 0, inf)"),
    (lambda: Spin(A=(None, 0, 0)), "A must be 3 numbers, got (None, 0, 0)"),
    (lambda: Fig1Machine(centre=[1, 2]), "centre must be 3 finite numbers, got centre = [1, 2]"),
    (lambda: ConstantSpeed(w=math.nan), "w must be a finite number, got w = nan rad/s"),
    (lambda: ConstantSpeed(w=None), "w must be a finite number, got w = None rad/s"),
    (lambda: ConstantSpeed(angle0=-math.inf), "angle0 must be a finite number, got angle0 = -inf rad"),
    (lambda: ConstantSpeed(angle0="x"), "angle0 must be a finite number, got angle0 = 'x' rad"),
    (lambda: ConstantSpeed(w=True), "w must be a finite number, got w = True rad/s"),
    (lambda: ConstantSpeed(angle0=False), "angle0 must be a finite number, got angle0 = False rad"),
    (lambda: SpeedRise(w=math.nan), "w must be a finite number, got w = nan rad/s"),
    (lambda: SpeedRise(w=True), "w must be a finite number, got w = True rad/s"),
    (lambda: SpeedRise(w="1"), "w must be a finite number, got w = '1' rad/s"),
    (lambda: SpeedRise(t0=math.inf), "t0 must be a finite number, got t0 = inf s"),
    (lambda: SpeedRise(t0=False), "t0 must be a finite number, got t0 = False s"),
    (lambda: SpeedRise(t0=0), "t0 must be positive, got t0 = 0 s"),
    (lambda: SpeedRise(t0=-1.5), "t0 must be positive, got t0 = -1.5 s"),
    (lambda: SpeedRise(law="cubic"), "law must be one of quadratic, linear, scurve, quintic, got law = 'cubic'"),
    (lambda: Fig1Machine(arrangement="diagonal"),
     "arrangement must be one of ('perpendicular', 'parallel'), got 'diagonal'"),
    (lambda: Fig1Machine(frame=3.0),
     "frame must be an angle law with angle(t) -> (angle, rate, acceleration), got 3.0"),
    (lambda: Fig1Machine(crank=Harmonic(0.1, 2.0)),
     "crank must be an angle law with angle(t) -> (angle, rate, acceleration), got "
     "Harmonic(x_amp=0.1, x_omega=2.0, y_amp=0.0, y_omega=0.0, x_phase=0.0, y_phase=0.0)"),
    (lambda: Fig1Machine(crank=ConstantSpeed(1.0)), "crank.l must be a non-negative length in m, got None"),
    (lambda: Fig1Machine(l=-0.1), "crank.l must be a non-negative length in m, got -0.1"),
    (lambda: Fig1Machine(l=math.nan), "crank.l must be a non-negative length in m, got nan"),
    (lambda: Fig1Machine(l="0.5"), "crank.l must be a non-negative length in m, got '0.5'"),
    (lambda: Fig1Machine(l=True), "crank.l must be a non-negative length in m, got True"),
    (lambda: Fig1Machine(shaft="y"), "shaft must be one of ('x', 'z'), got 'y'"),
])
def test_refusals_word_for_word(call, message):
    _raises(call, message)


def test_accepted_edges():
    assert Spin(Omega=[0, 0, 1], A=np.array([1.0, 2.0, 3.0])).A == (1.0, 2.0, 3.0)
    assert ConstantSpeed(-2, 3).angle(1.0) == (1, -2, 0.0)  # integers are numbers
    assert SpeedRise(w=-1, t0=1e-9, law="quintic").angle(1.0)[1] == -1.0
    assert Fig1Machine(l=0.0).l == 0.0 and type(Fig1Machine(l=1).l) is float
    assert Fig1Machine(crank=ConstantSpeed(1.0), l=0.2).l == 0.2


# ---------------------------------------------------------------------------- angle laws
def test_constant_speed():
    assert ConstantSpeed() == ConstantSpeed(0.5, 0.0)
    assert ConstantSpeed(0.7, 0.3).angle(2.0) == (0.3 + 0.7 * 2.0, 0.7, 0.0)
    assert ConstantSpeed(0.7, 0.3).angle(0.0) == (0.3, 0.7, 0.0)


@pytest.mark.parametrize("law", ["quadratic", "linear", "scurve", "quintic"])
def test_speed_rise_is_the_crank_law_s_rise(law):
    sr = SpeedRise(w=-1.3, t0=2.0, law=law)
    for t in (-0.5, 0.0, 0.4, 1.0, 1.9, 2.0, 3.7):
        assert sr.angle(t) == rise_angle(law, -1.3, 2.0, t)
    assert sr.angle(5.0)[1:] == (-1.3, 0.0)  # at the rate after the rise


def test_speed_rise_defaults():
    sr = SpeedRise()
    assert (sr.w, sr.t0, sr.law) == (0.5, 2.5, "quadratic")
    # the quadratic rise: rate w (1 - (1 - t/t0)^2), acceleration 2 w (1 - t/t0) / t0
    ang, rate, acc = sr.angle(1.25)
    assert rate == pytest.approx(0.5 * 0.75, abs=1e-15) and acc == pytest.approx(2 * 0.5 * 0.5 / 2.5, abs=1e-15)
    assert ang == pytest.approx(-0.5 * (1.25 - 2.5) ** 3 / (3 * 2.5 ** 2) + 0.5 * 1.25 - 0.5 * 2.5 / 3, abs=1e-15)


# ---------------------------------------------------------------------------- the base class
def test_chamber_motion_base():
    class Listed(ChamberMotion):
        def state(self, t):
            return ChamberState(*[float(i) + t for i in range(NSTATE)])

    assert Listed().accel(0.5) == tuple(float(i) + 0.5 for i in range(6, 15))
    assert Listed.rotates is True and ChamberMotion.rotates is True and Translation.rotates is False


# ---------------------------------------------------------------------------- translation
def test_translation_with_a_crank():
    crank = CrankStartup(l=0.4, n0=50.0, t0=2.0)
    mo = Translation(crank, zA=0.3)
    for t in (0.5, 1.7, 3.2):
        s = mo.state(t)
        x, y, vx, vy, ax, ay = crank.state(t)
        assert s[A_] == (x, y, 0.3) and s[VA] == (vx, vy, 0.0) and s[AA] == (ax, ay, 0.0)
        assert s[OM] == (0.0, 0.0, 0.0) and s[OMD] == (0.0, 0.0, 0.0)
        assert s[Q_] == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        # the crank: rate psi', a rotation about the vertical axis through O1 (v = e_z x X)
        assert s[D1] == (crank.angle(t)[1], 0.0, 0.0, 0.0, -y, x, 0.0)
        assert s[D2] == (0.0,) * 7
        assert mo.accel(t) == (ax, ay, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        assert mo.accel(t) == tuple(s[6:15])
    assert Translation().platform == CrankStartup() and Translation().zA == 0.25


def test_translation_without_a_crank():
    h = Harmonic(0.1, 3.0, 0.05, 5.0, 0.3, 0.1)
    mo = Translation(h)
    for t in (0.2, 1.1):
        s = mo.state(t)
        x, y, vx, vy, ax, ay = h.state(t)
        assert s[A_] == (x, y, 0.25) and s[VA] == (vx, vy, 0.0) and s[AA] == (ax, ay, 0.0)
        assert s[D1] == (vx, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0)  # the x motion: v_X = e_x per unit rate
        assert s[D2] == (vy, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        assert mo.accel(t) == (ax, ay, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# ---------------------------------------------------------------------------- spin
def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@pytest.mark.parametrize("Omega, A", [((0.3, -1.1, 2.0), (0.2, -0.1, 0.4)), ((0.0, 0.0, 3.0), (0.0, 0.0, 0.25)),
                                      ((-2.0, 0.5, 0.0), (1.0, 2.0, -3.0)), ((0.3, 0.4, 0.0), (0.0, 0.0, 0.0)),
                                      ((0.6, 0.0, -0.8), (0.1, 0.1, 0.1))])  # slow spins too
def test_spin_state(Omega, A):
    mo = Spin(Omega, A)
    rate = float(np.linalg.norm(Omega))
    e = np.array(Omega) / rate
    assert mo.rate == pytest.approx(rate, rel=1e-15) and np.allclose(mo.axis, e, rtol=0, atol=1e-15)
    assert mo.Omega == tuple(map(float, Omega)) and mo.A == tuple(map(float, A))
    for t in (0.0, 0.37, 2.9):
        s = mo.state(t)
        K = _skew(e)
        th = rate * t
        Q = np.eye(3) + math.sin(th) * K + (1.0 - math.cos(th)) * K @ K
        assert np.allclose(np.array(s[Q_]).reshape(3, 3), Q, rtol=0, atol=1e-14)
        assert np.allclose(np.array(mo.orientation(t)).reshape(3, 3), Q, rtol=0, atol=1e-14)
        assert s[A_] == mo.A and s[VA] == (0.0,) * 3 and s[AA] == (0.0,) * 3
        assert s[OM] == mo.Omega and s[OMD] == (0.0,) * 3
        # the spin drive: rate |Omega|, twist (e, A x e): v_X = |Omega| (e x X + A x e) = Omega x (X - A)
        assert s[24] == mo.rate and s[25:28] == mo.axis
        assert np.allclose(s[28:31], np.cross(A, mo.axis), rtol=0, atol=1e-15)
        assert s[D2] == (0.0,) * 7
        assert mo.accel(t) == (0.0, 0.0, 0.0, *mo.Omega, 0.0, 0.0, 0.0)


def test_spin_defaults_repr_and_rest():
    mo = Spin()
    assert mo.Omega == (0.0, 0.0, 3.0) and mo.A == (0.0, 0.0, 0.25) and mo.rate == 3.0 and mo.axis == (0.0, 0.0, 1.0)
    assert repr(Spin((0.3, -1.1, 2), (0.2, -0.1, 0.4))) == "Spin(Omega=(0.3, -1.1, 2.0), A=(0.2, -0.1, 0.4))"
    rest = Spin((0.0, 0.0, 0.0), (1.0, 2.0, 3.0))  # no rotation: the axis is e_z by convention
    assert rest.rate == 0.0 and rest.axis == (0.0, 0.0, 1.0)
    s = rest.state(5.0)
    assert s[Q_] == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert s[D1] == (0.0, 0.0, 0.0, 1.0, 2.0, -1.0, 0.0)  # A x e_z = (2, -1, 0)


# ---------------------------------------------------------------------------- the Fig. 1 machine
def _R(shaft, ph):
    c, s = math.cos(ph), math.sin(ph)
    if shaft == "x":
        R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        R1 = np.array([[0, 0, 0], [0, -s, -c], [0, c, -s]])
        R2 = np.array([[0, 0, 0], [0, -c, s], [0, -s, -c]])
    else:
        R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        R1 = np.array([[-s, -c, 0], [c, -s, 0], [0, 0, 0]])
        R2 = np.array([[-c, s, 0], [-s, -c, 0], [0, 0, 0]])
    return R.astype(float), R1.astype(float), R2.astype(float)


def _a(plane, centre, l, ps):
    """The crank circle in the frame's axes: a, da/dpsi, d2a/dpsi2."""
    c, s = math.cos(ps), math.sin(ps)
    if plane == "xy":
        u, up, upp = [c, s, 0.0], [-s, c, 0.0], [-c, -s, 0.0]
    else:
        u, up, upp = [0.0, c, s], [0.0, -s, c], [0.0, -c, -s]
    return np.array(centre) + l * np.array(u), l * np.array(up), l * np.array(upp)


# (shaft, arrangement) -> the plane of the crank circle in the frame's axes (module docstring)
PLANES = {("x", "perpendicular"): "xy", ("x", "parallel"): "yz", ("z", "perpendicular"): "yz",
          ("z", "parallel"): "xy"}


@pytest.mark.parametrize("shaft, arrangement", list(PLANES))
def test_fig1_machine_against_matrix_kinematics(shaft, arrangement):
    frame = SpeedRise(w=0.8, t0=3.0, law="scurve")
    crank = CrankStartup(l=0.35, n0=70.0, t0=2.0)
    centre = (0.1, -0.2, 0.3)
    mo = Fig1Machine(frame=frame, crank=crank, arrangement=arrangement, centre=centre, shaft=shaft)
    axis = np.array([1.0, 0.0, 0.0] if shaft == "x" else [0.0, 0.0, 1.0])
    for t in (0.3, 1.1, 1.9, 2.6, 4.0):  # both laws accelerating, then one, then neither
        ph, phd, phdd = frame.angle(t)
        ps, psd, psdd = crank.angle(t)
        R, R1, R2 = _R(shaft, ph)
        a, ap, app = _a(PLANES[shaft, arrangement], centre, 0.35, ps)
        A = R @ a
        vA = phd * R1 @ a + psd * R @ ap
        aA = phdd * R1 @ a + phd * phd * R2 @ a + 2.0 * phd * psd * R1 @ ap + psdd * R @ ap + psd * psd * R @ app
        s = mo.state(t)
        assert np.allclose(s[A_], A, rtol=0, atol=1e-15)
        assert np.allclose(s[VA], vA, rtol=0, atol=1e-14)
        assert np.allclose(s[AA], aA, rtol=0, atol=1e-13)
        assert np.allclose(s[OM], phd * axis, rtol=0, atol=0) and np.allclose(s[OMD], phdd * axis, rtol=0, atol=0)
        assert np.allclose(np.array(s[Q_]).reshape(3, 3), R, rtol=0, atol=1e-16)
        # drive 1, the frame: rate phi', a rotation about the shaft through O1; drive 2, the
        # cranks: rate psi', a translation along R da/dpsi
        assert s[24] == phd and s[25:28] == tuple(axis) and s[28:31] == (0.0, 0.0, 0.0)
        assert s[31] == psd and s[32:35] == (0.0, 0.0, 0.0)
        assert np.allclose(s[35:38], R @ ap, rtol=0, atol=1e-15)
        assert mo.accel(t) == tuple(s[6:15])
        assert isinstance(s, ChamberState) and len(s) == NSTATE


def test_fig1_machine_defaults_and_flags():
    mo = Fig1Machine()
    assert mo.frame == ConstantSpeed(0.5, 0.0) and mo.crank == CrankStartup(l=0.5, n0=60.0, t0=2.5)
    assert (mo.arrangement, mo.shaft, mo.centre, mo.l) == ("perpendicular", "x", (0.0, 0.0, 0.0), 0.5)
    assert mo.vertical is False and mo.parallel is False
    for (shaft, arrangement), plane in PLANES.items():
        m = Fig1Machine(arrangement=arrangement, shaft=shaft)
        assert m.vertical is (shaft == "z") and m.parallel is (plane == "yz")
    # an explicit crank length wins over the law's own
    m = Fig1Machine(crank=CrankStartup(l=0.5), l=0.2, frame=ConstantSpeed(0.0))
    assert m.l == 0.2 and np.allclose(m.state(0.0)[A_], (0.2, 0.0, 0.0), rtol=0, atol=1e-15)
    assert Fig1Machine(crank=CrankStartup(l=0.7)).l == 0.7


def test_fig1_machine_repr():
    assert repr(Fig1Machine()) == (
        "Fig1Machine(frame=ConstantSpeed(w=0.5, angle0=0.0), crank=CrankStartup(l=0.5, n0=60.0, t0=2.5, "
        "law='quadratic'), arrangement='perpendicular', centre=(0.0, 0.0, 0.0))")
    assert repr(Fig1Machine(frame=ConstantSpeed(1.0), arrangement="parallel", centre=(1, 2, 3), shaft="z")) == (
        "Fig1Machine(frame=ConstantSpeed(w=1.0, angle0=0.0), crank=CrankStartup(l=0.5, n0=60.0, t0=2.5, "
        "law='quadratic'), arrangement='parallel', centre=(1.0, 2.0, 3.0), shaft='z')")
