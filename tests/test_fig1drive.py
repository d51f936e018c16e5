"""The Fig. 1 machine's drives: the library (turning/motions.py Fig1Machine with both shafts
and the frame's start-up law, turning/drive.py Fig1Drive) against closed forms derived
here independently (rotation matrices and their derivatives), the drives' moments and
torques against power balances, and the Fig1Drive FMU (both flavours) against the
library at sample times."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import CrankStartup
from ballmill.physics.drives.crank import LAWS, rise_angle
from ballmill.physics.errors import ParameterError
from ballmill.physics.turning.drive import DriveOutputs, Fig1Drive
from ballmill.physics.turning.motions import ConstantSpeed, Fig1Machine, SpeedRise, Spin

R = 0.25


def _rot(axis, a):
    """R_e(a) and its first and second derivatives with respect to a (matrices)."""
    c, s = math.cos(a), math.sin(a)
    if axis == "x":
        M = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        D = np.array([[0, 0, 0], [0, -s, -c], [0, c, -s]])
        DD = np.array([[0, 0, 0], [0, -c, s], [0, -s, -c]])
    else:
        M = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        D = np.array([[-s, -c, 0], [c, -s, 0], [0, 0, 0]])
        DD = np.array([[-c, s, 0], [-s, -c, 0], [0, 0, 0]])
    return M, D, DD


def _circle(shaft, arrangement, psi, l):
    """u(psi) in the frame's axes and its derivatives: the crank axes perpendicular to the x1
    shaft or parallel to the z1 shaft put the circle in the frame's xy plane."""
    xy = (shaft == "x") == (arrangement == "perpendicular")
    c, s = math.cos(psi), math.sin(psi)
    u, du, ddu = (c, s), (-s, c), (-c, -s)
    emb = (lambda p: np.array([p[0], p[1], 0.0])) if xy else (lambda p: np.array([0.0, p[0], p[1]]))
    return l * emb(u), l * emb(du), l * emb(ddu)


def _closed_form(shaft, arrangement, frame, crank, l, c, t):
    """O, v_O, a_O, Omega, Omega', Q of O = R_e(phi) (c + l u(psi)) by the product rule."""
    ph, phd, phdd = frame.angle(t)
    ps, psd, psdd = crank.angle(t)
    M, D, DD = _rot(shaft, ph)
    a, da, dda = _circle(shaft, arrangement, ps, l)
    a = a + np.asarray(c)
    O = M @ a
    v = phd * (D @ a) + psd * (M @ da)
    acc = (phdd * (D @ a) + phd * phd * (DD @ a) + 2.0 * phd * psd * (D @ da)
           + psd * psd * (M @ dda) + psdd * (M @ da))
    e = np.array([1.0, 0.0, 0.0]) if shaft == "x" else np.array([0.0, 0.0, 1.0])
    return O, v, acc, phd * e, phdd * e, M


CASES = [(shaft, arr) for shaft in ("x", "z") for arr in ("perpendicular", "parallel")]


def test_rotation_helper_is_right():
    for axis in ("x", "z"):
        for a in (0.3, 2.1):
            h = 1e-5
            M, D, DD = _rot(axis, a)
            Mp, Mm = _rot(axis, a + h)[0], _rot(axis, a - h)[0]
            assert np.allclose((Mp - Mm) / (2 * h), D, atol=1e-9)
            assert np.allclose((Mp - 2 * M + Mm) / h ** 2, DD, atol=1e-5)


def test_rise_angle_is_crank_startup_and_speed_rise():
    """CrankStartup.angle and SpeedRise with w = w0 are the one function (bit for bit)."""
    for law in LAWS:
        cs = CrankStartup(l=0.5, n0=45.0, t0=1.7, law=law)
        sr = SpeedRise(cs.w0, 1.7, law)
        for t in (-1.0, 0.0, 0.3, 1.7, 1.70001, 5.0):
            assert cs.angle(t) == sr.angle(t) == rise_angle(law, cs.w0, 1.7, t)
    assert SpeedRise(-2.0, 1.0).angle(3.0)[1] == -2.0  # either sign
    for bad in (dict(t0=0.0), dict(w=float("nan")), dict(law="cubic")):
        with pytest.raises(ParameterError):
            SpeedRise(**{**dict(w=1.0, t0=1.0), **bad})


@pytest.mark.parametrize("shaft, arrangement", CASES)
@pytest.mark.parametrize("frame", [ConstantSpeed(0.5), SpeedRise(-0.9, 1.5, "scurve")], ids=["const", "rise"])
def test_machine_state_is_the_closed_form(shaft, arrangement, frame):
    """Fig1Machine.state (both shafts, both arrangements, a constant and a rising frame speed)
    against the product-rule closed form; Q orthonormal with det 1 and Q' = [Omega]x Q (central
    differences, error ~ h^2 |Q'''| = 1e-8); a_A against differences of v_A too."""
    crank = SpeedRise(2.0 * math.pi, 2.5, "quadratic")
    c = (0.05, -0.1, -R)
    m = Fig1Machine(frame=frame, crank=crank, arrangement=arrangement, centre=c, l=0.5, shaft=shaft)
    for t in (0.0, 0.7, 1.2, 2.4, 3.3, 7.9):
        s = m.state(t)
        O, v, a, W, Wd, Q = _closed_form(shaft, arrangement, frame, crank, 0.5, c, t)
        assert np.allclose(s[0:3], O, rtol=0, atol=1e-14)
        assert np.allclose(s[3:6], v, rtol=0, atol=1e-13)
        assert np.allclose(s[6:9], a, rtol=0, atol=1e-12)
        assert np.allclose(s[9:12], W, rtol=0, atol=0) and np.allclose(s[12:15], Wd, rtol=0, atol=0)
        Qs = np.array(s[15:24]).reshape(3, 3)
        assert np.allclose(Qs, Q, atol=1e-15)
        assert np.allclose(Qs @ Qs.T, np.eye(3), atol=1e-15) and np.linalg.det(Qs) == pytest.approx(1.0, abs=1e-15)
        h = 1e-4
        dQ = (np.array(m.state(t + h)[15:24]) - np.array(m.state(t - h)[15:24])).reshape(3, 3) / (2 * h)
        Wx = np.array([[0, -W[2], W[1]], [W[2], 0, -W[0]], [-W[1], W[0], 0]])
        assert np.allclose(dQ, Wx @ Qs, atol=1e-7)
        if t > 2 * h and abs(t - 2.5) > 2 * h and abs(t - 1.5) > 2 * h:  # away from the laws' kinks
            dv = (np.array(m.state(t + h)[3:6]) - np.array(m.state(t - h)[3:6])) / (2 * h)
            assert np.allclose(dv, s[6:9], atol=1e-5)
        assert m.accel(t) == tuple(s[6:15])


def test_horizontal_shaft_default_is_unchanged():
    """The x1 shaft (default) is the machine the library always had: the kernel still runs it
    (`applicable` says ''), a vertical shaft or a non-quadratic CrankStartup is left to Python."""
    from ballmill.physics import Ball
    from ballmill.physics.turning import kernel
    from ballmill.physics.turning.model import ChamberModel

    model = ChamberModel(Ball(r=0.025, R=0.25, m=0.5105088062083415, mu=0.3))
    m = Fig1Machine()
    assert m.shaft == "x" and not m.vertical
    if kernel._lib() is None:
        pytest.skip("no compiled kernel")
    assert kernel.applicable(model, m) == ""
    assert "shaft" in kernel.applicable(model, Fig1Machine(shaft="z"))
    assert "quadratic" in kernel.applicable(model, Fig1Machine(crank=CrankStartup(law="scurve")))


def _drive(shaft="x", arrangement="perpendicular", **kw):
    p = dict(shaft=shaft, Omega_frame=0.7, frame_law="quadratic", t0_frame=1.5, l=0.4, n0=50.0, t0=2.0,
             law="quadratic", arrangement=arrangement, centre=(0.05, -0.1, -R), J_frame=2.0, J_crank=0.3,
             m_platform=12.0, g=9.81)
    p.update(kw)
    return Fig1Drive(**p)


@pytest.mark.parametrize("shaft, arrangement", CASES)
def test_reaction_moments_balance_the_power(shaft, arrangement):
    """M_frame phi' + M_crank psi' = F . v_P: the power the drives put into whatever exerts the
    wrench (F at P, M_O1 = P x F), v_P = v_O + Omega x (P - O) of the chamber's point at P."""
    rng = np.random.default_rng(5)
    d = _drive(shaft, arrangement)
    for t in (0.3, 1.1, 1.9, 4.0):
        P, F = rng.normal(size=3), rng.normal(size=3) * 10
        out = d.outputs(t, tuple(F), tuple(np.cross(P, F)))
        O = np.array([out.x1O, out.y1O, out.z1O])
        W = np.array([out.Omega_x, out.Omega_y, out.Omega_z])
        vP = np.array([out.vx1O, out.vy1O, out.vz1O]) + np.cross(W, P - O)
        lhs = out.M_frame * out.phi_dot + out.M_crank * out.psi_dot
        assert lhs == pytest.approx(F @ vP, rel=1e-12, abs=1e-12)
        # the torques are the inertial loads minus the reactions
        free = d.outputs(t)
        assert out.T_frame == pytest.approx(free.T_frame - out.M_frame, rel=1e-13, abs=1e-12)
        assert out.T_crank == pytest.approx(free.T_crank - out.M_crank, rel=1e-13, abs=1e-12)
        assert out.P_frame == out.T_frame * out.phi_dot and out.P_crank == out.T_crank * out.psi_dot


@pytest.mark.parametrize("shaft, arrangement", CASES)
def test_drive_torques_deliver_the_energy_of_the_machine(shaft, arrangement):
    """Without load the drives' power is the rate of the machine's energy:
    T_frame phi' + T_crank psi' = d/dt [1/2 J_frame phi'^2 + 1/2 J_crank (psi' + k_e phi')^2
    + 1/2 m_p |v_O|^2 + m_p g z_O] (central differences, h = 1e-4 s: error ~ h^2 E''' ~ 1e-6 W)."""
    d = _drive(shaft, arrangement)
    k_e = 1.0 if arrangement == "parallel" else 0.0

    def energy(t):
        o = d.outputs(t)
        return (0.5 * 2.0 * o.phi_dot ** 2 + 0.5 * 0.3 * (o.psi_dot + k_e * o.phi_dot) ** 2
                + 0.5 * 12.0 * (o.vx1O ** 2 + o.vy1O ** 2 + o.vz1O ** 2) + 12.0 * 9.81 * o.z1O)
    h = 1e-4
    for t in (0.4, 1.0, 1.8, 3.0, 6.2):
        o = d.outputs(t)
        dE = (energy(t + h) - energy(t - h)) / (2 * h)
        assert o.P_frame + o.P_crank == pytest.approx(dE, rel=1e-6, abs=1e-5)


def test_drive_parameters_are_checked():
    for bad, word in ((dict(l=-1.0), "l"), (dict(t0_frame=0.0), "t0_frame"), (dict(shaft="y"), "shaft"),
                      (dict(J_frame=float("nan")), "J_frame"), (dict(arrangement="oblique"), "arrangement")):
        with pytest.raises(ParameterError, match=word):
            _drive(**bad)


# ----------------------------------------------------------------------------- the FMU
PARAMS = {"shaft": 1, "Omega_frame": 0.7, "frame_law": 1, "t0_frame": 1.5, "l": 0.4, "n0": 50.0, "t0": 2.0,
          "law": 1, "arrangement": 1, "xc": 0.05, "yc": -0.1, "zc": -R, "J_frame": 2.0, "J_crank": 0.3,
          "m_platform": 12.0, "g": 9.81}
WRENCH = {"Fx": 1.5, "Fy": -2.0, "Fz": -5.0, "MO1x": 0.3, "MO1y": -0.7, "MO1z": 0.2}
VARIANTS = {
    "x_perpendicular_quadratic_rise": {},
    "z_parallel_scurve": {"shaft": 2, "arrangement": 2, "frame_law": 2, "law": 2},
    "x_parallel_linear_const": {"arrangement": 2, "frame_law": 0, "law": 3},
    "z_perpendicular_quintic": {"shaft": 2, "frame_law": 4, "law": 4, "Omega_frame": -1.1},
}
LAW = {0: 0, 1: "quadratic", 2: "scurve", 3: "linear", 4: "quintic"}


def _library(p):
    return Fig1Drive(shaft={1: "x", 2: "z"}[p["shaft"]], Omega_frame=p["Omega_frame"], frame_law=LAW[p["frame_law"]],
                     t0_frame=p["t0_frame"], l=p["l"], n0=p["n0"], t0=p["t0"], law=LAW[p["law"]],
                     arrangement={1: "perpendicular", 2: "parallel"}[p["arrangement"]],
                     centre=(p["xc"], p["yc"], p["zc"]), J_frame=p["J_frame"], J_crank=p["J_crank"],
                     m_platform=p["m_platform"], g=p["g"])


def _simulate(path, params, stop=3.0, step=0.25):
    from fmpy import simulate_fmu

    # the wrench as the inputs' start values: held exactly (fmpy's input table interpolates)
    return simulate_fmu(str(path), stop_time=stop, step_size=step, output_interval=step,
                        start_values={**params, **WRENCH})


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_fmu_outputs_are_the_library_s_and_flavours_agree(fmu_build_dir, variant):
    """Every output of both flavours at the sample times equals turning.drive.Fig1Drive's with
    the same wrench, bit for bit (the native C mirrors the Python operation for operation),
    over the frame's and the cranks' rise and after it."""
    from ballmill.fmi.build import fmu_path

    p = {**PARAMS, **VARIANTS[variant]}
    lib = _library(p)
    res = {f: _simulate(fmu_path("Fig1Drive", fmu_build_dir, f), p) for f in ("native", "pythonfmu")}
    for name in res["native"].dtype.names:
        assert np.array_equal(res["native"][name], res["pythonfmu"][name]), name
    r = res["native"]
    assert r["time"][-1] == pytest.approx(3.0)
    for row in r:
        ref = lib.outputs(float(row["time"]), tuple(WRENCH[k] for k in ("Fx", "Fy", "Fz")),
                          tuple(WRENCH[k] for k in ("MO1x", "MO1y", "MO1z")))
        for name in DriveOutputs._fields:
            assert row[name] == getattr(ref, name), (name, row["time"])


@pytest.mark.parametrize("flavour", ["native", "pythonfmu"])
def test_fmu_drives_the_chamber_of_the_library_scenes(fmu_build_dir, flavour):
    """The chamber the FMU describes (A = O + Q (0, 0, R)) is the library's: the Fig. 1 machine
    (zc = -R: A = Rx(phi) (l cos psi, l sin psi, 0), the default Fig1Machine), the spinning bowl
    (shaft z, l = 0: Spin((0, 0, 3), A = (0, 0, R))) and the tumbling drum (shaft x through A,
    l = 0, zc = -R: Spin((0.8, 0, 0), A = 0))."""
    from ballmill.fmi.build import fmu_path

    scenes = {
        "fig1": ({"shaft": 1, "Omega_frame": 0.5, "frame_law": 0, "l": 0.5, "n0": 60.0, "t0": 2.5, "zc": -R},
                 Fig1Machine()),
        "bowl": ({"shaft": 2, "Omega_frame": 3.0, "frame_law": 0, "l": 0.0}, Spin((0.0, 0.0, 3.0), (0.0, 0.0, R))),
        "drum": ({"shaft": 1, "Omega_frame": 0.8, "frame_law": 0, "l": 0.0, "zc": -R},
                 Spin((0.8, 0.0, 0.0), (0.0, 0.0, 0.0))),
    }
    for name, (params, motion) in scenes.items():
        r = _simulate(fmu_path("Fig1Drive", fmu_build_dir, flavour), params, stop=5.0, step=0.5)
        for row in r:
            cs = motion.state(float(row["time"]))
            Q = np.array([row[f"Q{i}{j}"] for i in (1, 2, 3) for j in (1, 2, 3)]).reshape(3, 3)
            A = np.array([row["x1O"], row["y1O"], row["z1O"]]) + Q @ np.array([0.0, 0.0, R])
            assert np.allclose(A, cs[0:3], atol=1e-14), name
            assert np.allclose(Q.ravel(), cs[15:24], atol=1e-14), name
            assert np.allclose([row["Omega_x"], row["Omega_y"], row["Omega_z"]], cs[9:12], atol=0), name
            vA = np.array([row["vx1O"], row["vy1O"], row["vz1O"]]) + np.cross(cs[9:12], Q @ [0.0, 0.0, R])
            assert np.allclose(vA, cs[3:6], atol=1e-13), name


@pytest.mark.parametrize("flavour", ["native", "pythonfmu"])
def test_a_non_finite_wrench_is_refused_state_kept(fmu_build_dir, flavour):
    """A step with a non-finite input is refused (fmi2Discard) naming the input, its value and
    unit; the outputs keep the last good state and the next good step continues as if the
    refused one had never been asked for."""
    import ctypes

    from ballmill.fmi.build import fmu_path
    from fmu_instance import Opened

    opened = Opened()
    try:
        a = opened.open(fmu_path("Fig1Drive", fmu_build_dir, flavour), f"fig1_{flavour}", **WRENCH)
        a.initialize()
        a.fmu.doStep(0.0, 0.01)
        before = a.reals(list(DriveOutputs._fields))
        a.set(MO1y=float("nan"))
        st = a.fmu.dll.fmi2DoStep(a.fmu.component, ctypes.c_double(0.01), ctypes.c_double(0.01), 1)
        assert st == 2  # fmi2Discard
        msg = "\n".join(m for _, m in a.messages)
        assert "input MO1y must be finite, got nan N.m at t = 0.01 s; step refused, last good state kept" in msg
        assert a.reals(list(DriveOutputs._fields)) == before
        a.set(MO1y=WRENCH["MO1y"])
        a.fmu.doStep(0.01, 0.01)
        ref = Fig1Drive().outputs(0.02, (WRENCH["Fx"], WRENCH["Fy"], WRENCH["Fz"]),
                                  (WRENCH["MO1x"], WRENCH["MO1y"], WRENCH["MO1z"]))
        assert a.reals(list(DriveOutputs._fields)) == list(ref)
    finally:
        opened.close_all()
