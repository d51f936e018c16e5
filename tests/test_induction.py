"""The induction motor that feels the ball: InductionMotor FMU and the coupled reference.

- ballmill.physics.drives.coupled: the algebraic loop solved exactly, the energy
  balance motor work = drive + ball energy + dissipation, a hand computation
  of the direct-on-line start, and the drive part against simulate_runup;
- the InductionMotor FMU through fmpy: model description, run-up against
  simulate_runup, refused non-finite input, state save/restore, bad
  parameters named, and the co-simulation with BallInShell against the
  monolithic solution within the coupling error measured in
  docs/induction_motor.md.

The FMUs come from the session's temporary build (conftest.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from ballmill.physics import Ball, evaluate
from ballmill.physics.drives.coupled import simulate_coupled
from ballmill.physics.drives.induction import CrankDrive, InductionMotor, simulate_runup
from fmu_instance import Opened

DISCARD, ERROR = 2, 3
KLOSS_DOL = CrankDrive()


# -- the monolithic reference -------------------------------------------------------------
@pytest.fixture(scope="module")
def dol_run():
    return simulate_coupled(KLOSS_DOL, Ball(), t_end=0.7, dt=1e-3)


def test_algebraic_loop_is_solved_exactly(dol_run):
    """At every output point J psi'' = i T + M_reaction, with M_reaction the ball's output
    at the platform acceleration that psi'' gives (M is affine in psi'')."""
    sys = dol_run.system
    drive = sys.drive
    assert dol_run.success, dol_run.message
    for k in range(0, len(dol_run.t), 50):
        t, z = dol_run.t[k], dol_run.y[:, k]
        yd = z[:sys.nd]
        n, w = sys.form.to_nw(z[sys.nd:sys.nd + sys.nb])
        psi_ddot, M, plat, A, B = sys.solve_loop(t, yd, n, w)
        o = evaluate(sys.ball, n, w, plat[4], plat[5], plat[0], plat[1])
        assert o.M_reaction == pytest.approx(M, rel=1e-12, abs=1e-12)
        assert drive.J_total * psi_ddot == pytest.approx(drive.i * drive.motor_torque(yd, t) + M, rel=1e-12)
        assert B < 0.0  # the ball adds inertia to the platform, at most its mass m l^2
        assert B > -sys.ball.m * drive.l ** 2 * (1 + 1e-9)


def test_direct_on_line_start_by_hand(dol_run):
    """At t = 0 the ball rests at the bottom and the platform accelerates at a = l psi''.
    Rolling, the ball's centre follows with 2/7 a (I = 2/5 m r^2), so the friction is
    2/7 m a and the ratio 2/7 a / g; the ball's force on the chamber is -2/7 m a, its
    torque on the crank -2/7 m l^2 psi'', so psi''(0) = i T(0) / (J_total + 2/7 m l^2)."""
    m, g, l = Ball().m, Ball().g, KLOSS_DOL.l
    T0 = KLOSS_DOL.motor.torque(0.0, 0.0)
    psi_ddot0 = KLOSS_DOL.i * T0 / (KLOSS_DOL.J_total + 2 / 7 * m * l ** 2)
    assert dol_run["psi_ddot"][0] == pytest.approx(psi_ddot0, rel=1e-12)
    assert dol_run["M_reaction"][0] == pytest.approx(-2 / 7 * m * l ** 2 * psi_ddot0, rel=1e-12)
    assert dol_run["friction_ratio"][0] == pytest.approx(2 / 7 * l * psi_ddot0 / g, rel=1e-12)
    # 0.293 at once, and the motor's torque rises towards breakdown: slip within 20 ms
    assert 0.29 < dol_run["friction_ratio"][0] < 0.3
    assert np.any(dol_run["friction_ratio"][:20] > Ball().mu)


@pytest.mark.parametrize("model", ["kloss", "dq"])
@pytest.mark.parametrize("losses", [False, True])
def test_energy_balance_of_the_coupled_run(model, losses):
    """W_motor = change of (1/2 J_total psi'^2 + ball energy) + W_diss, to integrator accuracy
    (rtol 1e-10: the residual is 1e-10 of the work here; tolerance 1e-8)."""
    ball = Ball(rolling_resistance=1e-3, drag=0.5) if losses else Ball()
    res = simulate_coupled(CrankDrive(model=model), ball, t_end=0.8, dt=2e-3)
    assert res.success, res.message
    W = res["W_motor"][-1]
    assert W > 50.0
    if losses:
        assert res["W_diss"][-1] > 0.05
    else:
        assert np.all(res["W_diss"] == 0.0)
    assert np.max(np.abs(res.energy_residual)) < 1e-8 * W
    assert np.max(np.abs(res["n_norm_error"])) < 1e-8
    if model == "dq":  # the electrical side too: input = mechanical + copper losses + field energy
        assert np.max(np.abs(res["W_el"] - res["W_motor"] - res["W_cu"] - res["W_mag"])) < 1e-8 * res["W_el"][-1]


def test_a_feather_light_ball_leaves_the_drive_as_simulate_runup_has_it():
    drive = CrankDrive(motor=InductionMotor(start="frequency_ramp", ramp_time=0.5))
    res = simulate_coupled(drive, Ball(m=1e-9), t_end=1.0, dt=5e-3)
    ref = simulate_runup(drive, 1.0, n_out=201, rtol=1e-11, atol=1e-12)
    assert np.max(np.abs(res["psi_dot"] - ref["psi_dot"])) < 1e-7
    assert np.max(np.abs(res["W_motor"] - ref["W_motor"])) < 1e-6


# -- the FMU ---------------------------------------------------------------------------------
@pytest.fixture
def motor_instance(built_fmus):
    opened = Opened()
    yield lambda name="motor", **parameters: opened.open(built_fmus["InductionMotor"], name, **parameters)
    opened.close_all()


OUT = ("psi", "psi_dot", "psi_ddot", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O", "w_motor", "T_motor",
       "I_motor", "P_el", "W_motor")


def test_model_description_validates(built_fmus):
    path = built_fmus["InductionMotor"]
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.coSimulation.modelIdentifier == "InductionMotor"
    assert md.coSimulation.canGetAndSetFMUstate
    variables = {v.name: v for v in md.modelVariables}
    for name, unit in (("P_rated", "W"), ("n_rated", "1/min"), ("U_rated", "V"), ("f_rated", "Hz"),
                       ("J_rotor", "kg.m2"), ("M_reaction", "N.m"), ("n_motor", "1/min"),
                       ("w_motor", "rad/s"), ("I_motor", "A"), ("P_el", "W"), ("ax1O", "m/s2")):
        assert variables[name].unit == unit, name
    for name in ("pole_pairs", "model", "start_mode", "M_input"):
        assert variables[name].type == "Integer"
    # (the native flavour adds Model Exchange's states and derivatives: local, left out here)
    deps = {u.variable.name: sorted(d.name for d in (u.dependencies or [])) for u in md.initialUnknowns
            if u.variable.causality != "local"}
    assert {o.variable.name for o in md.outputs} == set(deps)
    assert deps["psi_ddot"] == deps["ax1O"] == deps["ay1O"] == ["M_reaction"]
    assert deps["psi"] == deps["T_motor"] == []
    for o in md.outputs:  # outputs at t_k + H from the state and the extrapolated load: no input
        assert not [d for d in (o.dependencies or []) if d.causality == "input"]
    assert "0 with Kloss" in variables["I_motor"].description


@pytest.mark.parametrize("model", [1, 2])
def test_fmu_runup_matches_simulate_runup(built_fmus, model):
    """A constant load (no coupling error): the FMU's internal DOP853 (tolerance 1e-9)
    against solve_ivp at 1e-11."""
    res = simulate_fmu(str(built_fmus["InductionMotor"]), stop_time=0.6, output_interval=2e-3,
                       start_values={"model": model, "M_reaction": -20.0}, output=list(OUT))
    drive = CrankDrive(model={1: "kloss", 2: "dq"}[model])
    ref = simulate_runup(drive, 0.6, load_torque=-20.0, n_out=301, rtol=1e-11, atol=1e-12)
    assert np.max(np.abs(res["psi_dot"] - ref["psi_dot"])) < 1e-7
    assert np.max(np.abs(res["psi"] - ref["psi"])) < 1e-8
    assert np.max(np.abs(res["T_motor"] - ref["T_motor"])) < 1e-5
    assert np.max(np.abs(res["W_motor"] - ref["W_motor"])) < 1e-5
    assert np.allclose(res["w_motor"], 24.0 * res["psi_dot"], rtol=1e-14)
    assert np.allclose(res["psi_ddot"], (24.0 * res["T_motor"] - 20.0) / drive.J_total, rtol=1e-12, atol=1e-12)
    if model == 1:
        assert np.all(res["I_motor"] == 0.0) and np.all(res["P_el"] == 0.0)
    else:
        assert np.max(np.abs(res["I_motor"] - ref["I_motor"])) < 1e-5
        assert np.max(np.abs(res["P_el"] - ref["P_el"])) < 1e-3


def test_non_finite_load_is_refused_and_the_state_kept(motor_instance):
    ref, motor = motor_instance("reference"), motor_instance("motor")
    H = 0.01
    for inst in (ref, motor):
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        inst.fmu.exitInitializationMode()
    expected, got = [], []
    for k in range(10):
        ref.set(M_reaction=-5.0 - k)
        ref.fmu.doStep(k * H, H)
        expected.append(ref.reals(OUT))
    for k in range(10):
        motor.set(M_reaction=-5.0 - k)
        if k == 4:
            before = motor.reals(OUT)
            motor.set(M_reaction=float("nan"))
            with pytest.raises(FMICallException) as info:
                motor.fmu.doStep(k * H, H)
            assert info.value.status == DISCARD
            msgs = [m for s, m in motor.messages if s == DISCARD]
            assert len(msgs) == 1 and "M_reaction must be finite" in msgs[0] and "nan" in msgs[0]
            assert motor.reals(OUT) == before
            motor.set(M_reaction=-5.0 - k)
        motor.fmu.doStep(k * H, H)
        got.append(motor.reals(OUT))
    assert got == expected  # bitwise: the refused step left no trace, load history included


def test_fmu_state_save_restore_is_bitwise(motor_instance):
    motor = motor_instance(model=2)  # dq: fluxes, step size and load history are internal state
    motor.fmu.setupExperiment(startTime=0.0)
    motor.fmu.enterInitializationMode()
    motor.fmu.exitInitializationMode()
    H = 0.005

    def step(k, load=lambda t: -10.0 * math.sin(7.0 * t)):
        motor.set(M_reaction=load(k * H))
        motor.fmu.doStep(k * H, H)
        return motor.reals(OUT)

    for k in range(20):
        step(k)
    saved = motor.fmu.getFMUstate()
    first = [step(k) for k in range(20, 30)]
    motor.fmu.setFMUstate(saved)
    assert [step(k, lambda t: 30.0) for k in range(20, 30)] != first
    motor.fmu.setFMUstate(saved)
    assert [step(k) for k in range(20, 30)] == first
    blob = motor.fmu.serializeFMUstate(saved)
    motor.fmu.freeFMUstate(saved)
    restored = motor.fmu.deSerializeFMUstate(blob)
    motor.fmu.setFMUstate(restored)
    motor.fmu.freeFMUstate(restored)
    assert [step(k) for k in range(20, 30)] == first


@pytest.mark.parametrize("start_values, fragment", [
    ({"n_rated": 1500.0}, "n_rated = 1500.0"),
    ({"P_rated": 0.75}, "P_rated = 0.75"),
    ({"start_mode": 4}, "parameter start_mode = 4 is outside its accepted range [1, 3]"),
    ({"Tb_ratio": 1.0}, "Tb_ratio"),
])
def test_bad_parameters_are_named_with_the_fmu_names(built_fmus, start_values, fragment):
    messages = []
    with pytest.raises(FMICallException) as info:
        simulate_fmu(str(built_fmus["InductionMotor"]), stop_time=0.01, output_interval=1e-3,
                     start_values=start_values, debug_logging=True,
                     logger=lambda env, inst, status, cat, msg: messages.append((status, msg.decode())))
    assert info.value.function == "fmi2ExitInitializationMode"
    errors = [m for s, m in messages if s == ERROR and "initialisation failed" in m]
    assert len(errors) == 1 and fragment in errors[0], messages


# -- the co-simulation against the monolithic solution --------------------------------------
# measured in docs/induction_motor.md (DOL, Kloss, 0.7 s, H = 1 ms, Jacobi):
#   linear extrapolation of M_reaction: max |d psi'| 2.9e-5 rad/s, |dP| 5.0e-5 m, |dN| 7.6e-3 N
#   held M_reaction:                    max |d psi'| 4.8e-4 rad/s, |dP| 1.2e-3 m, |dN| 0.20 N
@pytest.mark.parametrize("m_input, bounds", [
    (2, {"psi_dot": 6e-5, "P": 1e-4, "N": 1.5e-2}),
    (1, {"psi_dot": 1e-3, "P": 2.5e-3, "N": 0.4}),
])
def test_cosimulated_dol_start_matches_the_coupled_solution(fmu_build_dir, fmu_flavour, dol_run, m_input,
                                                            bounds):
    from ballmill.scenario import runner
    sc, models, paths = runner.prepare("induction_start", [f"motor.M_input={m_input}"], fmu_build_dir,
                                       log=lambda m: None, flavour=fmu_flavour)
    sc.stop, sc.step = 0.7, 1e-3
    res = runner.run(sc, models, paths, progress=False, echo=False)
    assert res.success, res.message
    t = res.column("time")
    assert np.allclose(t, dol_run.t, atol=1e-12)
    err = {"psi_dot": np.max(np.abs(res.column("motor.psi_dot") - dol_run["psi_dot"])),
           "P": np.max(np.sqrt(sum((res.column(f"ball.{c}") - dol_run[c]) ** 2 for c in ("xP", "yP", "zP")))),
           "N": np.max(np.abs(res.column("ball.N") - dol_run["N"]))}
    for key, bound in bounds.items():
        assert err[key] < bound, (key, err[key])
    if m_input == 1:  # holding the load is measurably worse than extrapolating it (the crank
        # speed shows it; the ball's corrector hides most of it in the contact point)
        assert err["psi_dot"] > 1e-4
    # and the co-simulation tells the same story: the ball slides within the first 20 ms
    assert np.any(res.column("ball.rolling")[:20] < 0.5)
