"""Induction motor drive: Kloss curve, dq model, run-up, energy, parameters.

Reference values are computed here from the datasheet numbers and textbook
formulas, independently of ballmill.physics.drives.induction where that is possible.
"""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from ballmill.physics.errors import ParameterError
from ballmill.physics.drives.induction import (CrankDrive, DqParameters, InductionMotor, platform_state,
                                    simulate_runup)

# datasheet of the default motor (WAT MTF3 0.75 kW 4-pole 80M)
PN, NN, FN, P, KB = 750.0, 1445.0, 50.0, 2, 3.4
W_SYNC = 2 * math.pi * FN / P
WN = NN * 2 * math.pi / 60
SN = (W_SYNC - WN) / W_SYNC
TN = PN / WN
SB = SN * (KB + math.sqrt(KB * KB - 1))


def kloss_ref(w):
    """Kloss torque at motor speed w, written out from the datasheet."""
    s = (W_SYNC - w) / W_SYNC
    return 2 * KB * TN / (s / SB + SB / s)


@pytest.fixture(scope="module")
def motor():
    return InductionMotor()


def test_rated_slip_from_kloss_parameters(motor):
    assert motor.rated_slip == pytest.approx(SN, rel=1e-12)
    # slip where Kloss's curve (built from Tb and sb only) delivers Tn
    s = brentq(lambda s: motor.kloss_torque(s) - motor.rated_torque, 1e-6, motor.breakdown_slip,
               xtol=1e-15, rtol=4 * np.finfo(float).eps)
    assert abs(s - SN) < 1e-9


def test_kloss_breakdown_point(motor):
    assert motor.breakdown_slip == pytest.approx(SB, rel=1e-12)
    assert motor.breakdown_torque == pytest.approx(KB * TN, rel=1e-12)
    assert motor.kloss_torque(motor.breakdown_slip) == pytest.approx(motor.breakdown_torque, rel=1e-12)
    # and it is the maximum
    for f in (0.99, 1.01):
        assert motor.kloss_torque(f * motor.breakdown_slip) < motor.breakdown_torque
    # generator branch is the mirror image
    assert motor.kloss_torque(-0.1) == pytest.approx(-motor.kloss_torque(0.1), rel=1e-14)


def test_dq_steady_torque_at_rated_slip(motor):
    """Integrate the 4 flux ODEs at fixed rated speed from zero flux until steady;
    the torque must equal Kloss's Tn (stated tolerance 1e-6 relative)."""
    w = motor.rated_angular_speed
    sol = solve_ivp(lambda t, x: motor.dq_rhs(t, x, w), (0.0, 2.0), np.zeros(4), method="DOP853",
                    rtol=1e-11, atol=1e-12)
    x = sol.y[:, -1]
    T, I, P = motor.dq_outputs(2.0, x)
    assert abs(T / kloss_ref(w) - 1) < 1e-6
    # same steady state as the phasor solution used for the fit
    ss = motor.dq_steady_state(SN)
    assert I == pytest.approx(ss["current"], rel=1e-6)
    assert P == pytest.approx(ss["P_el"], rel=1e-6)
    assert ss["power_factor"] == pytest.approx(motor.power_factor, rel=1e-9)


def test_dq_curve_close_to_kloss(motor):
    # stated closeness with the default stator_copper_share = 0.25
    assert motor.dq_kloss_deviation() < 0.03  # 0 < s <= sb
    assert motor.dq_kloss_deviation(1.0) < 0.08  # up to standstill
    T_max = max(motor.dq_steady_state(s)["torque"] for s in np.linspace(0.01, 1.0, 4000))
    assert T_max == pytest.approx(motor.breakdown_torque, rel=1e-4)
    # without stator resistance the dq steady state IS Kloss's curve
    ideal = motor.with_(stator_copper_share=0.0)
    assert ideal.dq.Rs == 0.0
    assert ideal.dq_kloss_deviation(1.0) < 1e-9


@pytest.mark.parametrize("M_load", [0.0, -30.0])
def test_runup_time_against_quadrature(M_load):
    drive = CrankDrive()
    J_m = (0.2 + 30.0 * 0.5**2 + 24.0**2 * 0.00261) / 24.0**2  # referred to the motor shaft
    w_target = WN  # rated speed
    # dt = J_m dw / (T(w) + M / i)
    t_ref, _ = quad(lambda w: J_m / (kloss_ref(w) + M_load / 24.0), 0.0, w_target,
                    epsabs=0.0, epsrel=1e-12, limit=200)
    res = simulate_runup(drive, 3 * t_ref, load_torque=M_load)
    assert res.success, res.message
    t_sim = res.time_to_speed(w_target / drive.i)
    assert abs(t_sim / t_ref - 1) < 1e-3


@pytest.mark.parametrize("model", ["kloss", "dq"])
def test_runup_energy_balance(model):
    """Motor mechanical work = kinetic energy of the drive + work against the load."""
    drive = CrankDrive(model=model)

    def load(t, psi, psi_dot):  # viscous + crank-angle dependent, resisting
        return -(8.0 * psi_dot + 15.0 * (1.0 + math.sin(psi)))

    res = simulate_runup(drive, 0.6, load_torque=load)
    assert res.success, res.message
    W_m, E, W_l = res["W_motor"][-1], res["E_kin"][-1], res["W_load"][-1]
    assert W_m > 100.0 and W_l > 1.0
    assert abs(W_m - E - W_l) < 1e-7 * W_m
    if model == "dq":  # electrical side: input = mechanical + copper losses + field energy
        W_el, W_cu, W_mag = res["W_el"][-1], res["W_cu"][-1], res["W_mag"][-1]
        assert abs(W_el - W_m - W_cu - W_mag) < 1e-7 * W_el


def test_soft_starts(motor):
    vr = motor.with_(start="voltage_ramp", u_start=0.4, ramp_time=2.0)
    # torque scales with (U/Un)^2, Kloss curve unchanged otherwise
    assert vr.torque(0.0, 0.0) == pytest.approx(0.16 * kloss_ref(0.0), rel=1e-12)
    assert vr.torque(50.0, 1.0) == pytest.approx(0.7**2 * kloss_ref(50.0), rel=1e-12)
    assert vr.torque(50.0, 5.0) == pytest.approx(kloss_ref(50.0), rel=1e-12)
    fr = motor.with_(start="frequency_ramp", f_start=0.0, ramp_time=2.0)
    # at half frequency: half synchronous speed, same breakdown torque at the same slip speed
    assert fr.synchronous_speed_at(1.0) == pytest.approx(W_SYNC / 2, rel=1e-12)
    w_b = W_SYNC / 2 - SB * W_SYNC
    assert fr.torque(w_b, 1.0) == pytest.approx(KB * TN, rel=1e-12)
    assert fr.torque(W_SYNC / 2, 1.0) == 0.0
    assert motor.torque(0.0, -0.1) == 0.0  # switched off before t = 0


def test_drive_inertia_and_gear():
    drive = CrankDrive()
    assert drive.J_total == pytest.approx(0.2 + 30.0 * 0.25 + 24.0**2 * 0.00261, rel=1e-14)
    assert abs(NN / drive.i - 60.0) < 1.0  # about the paper's n0 = 60 1/min at rated speed
    y = drive.initial_state()
    assert drive.psi_ddot(y, 0.0, -10.0) == pytest.approx((24.0 * kloss_ref(0.0) - 10.0) / drive.J_total)


def test_platform_kinematics_exact():
    l = 0.5

    def psi(t):
        return 0.3 * t**3 + 2.0 * t + 0.1, 0.9 * t**2 + 2.0, 1.8 * t

    h = 1e-5
    for t in (0.0, 0.7, 2.3):
        x = platform_state(l, *psi(t))
        xp, xm = platform_state(l, *psi(t + h)), platform_state(l, *psi(t - h))
        for k in range(4):  # position -> velocity, velocity -> acceleration
            assert (xp[k] - xm[k]) / (2 * h) == pytest.approx(x[k + 2], abs=1e-7)
        assert x[0] == pytest.approx(l * math.cos(psi(t)[0]))


@pytest.mark.parametrize("kwargs, names", [
    (dict(rated_power=-750.0), "rated_power = -750.0"),
    (dict(rated_power=0.75), "rated_power = 0.75"),  # kW given as W
    (dict(breakdown_ratio=0.9), "breakdown_ratio = 0.9"),
    (dict(rated_speed=1500.0), "rated_speed = 1500.0"),
    (dict(pole_pairs=2.5), "pole_pairs = 2.5"),
    (dict(power_factor=1.2), "power_factor = 1.2"),
    (dict(efficiency=0.0), "efficiency = 0.0"),
    (dict(J_rotor=float("nan")), "J_rotor = nan"),
    (dict(start="star_delta"), "start = 'star_delta'"),
    (dict(ramp_time=0.0), "ramp_time = 0.0"),
    (dict(u_start=1.5), "u_start = 1.5"),
    (dict(f_start=1.0), "f_start = 1.0"),
])
def test_bad_motor_parameters(kwargs, names):
    with pytest.raises(ParameterError, match=names.replace("(", r"\(").replace(".", r"\.")):
        InductionMotor(**kwargs)


@pytest.mark.parametrize("kwargs, names", [
    (dict(i=0.0), "i = 0.0"),
    (dict(l=-0.5), "l = -0.5"),
    (dict(m_platform=-1.0), "m_platform = -1.0"),
    (dict(J_crank="heavy"), "J_crank = 'heavy'"),
    (dict(model="vf"), "model = 'vf'"),
])
def test_bad_drive_parameters(kwargs, names):
    with pytest.raises(ParameterError, match=names.replace(".", r"\.")):
        CrankDrive(**kwargs)


def test_bad_dq_parameters():
    with pytest.raises(ParameterError, match=r"Lm = 0\.0"):
        DqParameters(Rs=1.0, Rr=1.0, Ls_sigma=0.01, Lr_sigma=0.01, Lm=0.0)
    with pytest.raises(ParameterError, match=r"Rs = -1\.0"):
        DqParameters(Rs=-1.0, Rr=1.0, Ls_sigma=0.01, Lr_sigma=0.01, Lm=0.5)
