"""Direct feedthrough (docs/conformance.md): Structure's accelerations and BallInShell's force
follow an input set between steps, at once and without a step, state untouched; what a master
needs to iterate the algebraic loop of a ball in a structure that feels it. Also the Structure
FMU's refused steps and its FMU state with the input history."""
from __future__ import annotations

import math

import pytest

PARAMS = dict(n_x=2, M_x1=120.0, f_x1=0.6, zeta_x1=0.02, phi_x1=1.0, psi_x1=0.7, L_x1=90.0,
              M_x2=80.0, f_x2=2.1, zeta_x2=0.03, phi_x2=-0.6, psi_x2=0.4, L_x2=-20.0,
              n_y=1, M_y1=150.0, f_y1=0.9, zeta_y1=0.01, phi_y1=1.0, psi_y1=1.0, L_y1=150.0,
              F0_x=3.0, F0_y=2.0, ag0_x=0.05, ag0_y=0.04, f_exc=0.7, sweep_rate=0.01, phase_y=0.5, h_max=1e-3)


def test_structure_accelerations_follow_the_ball_force_without_a_step(open_fmu):
    """ax1O = a_g + sum phi_j q_j'': setting Fx_ball by dF changes ax1O by G dF with
    G = sum phi_j^2 / M_j (and ax_load by sum phi psi / M dF), at once, state untouched."""
    fmu = open_fmu("Structure", **PARAMS)
    assert fmu.init() == 0
    for _ in range(50):
        assert fmu.step(0.01) == 0
    before = fmu.outputs()
    dF = 2.5
    assert fmu.set(Fx_ball=dF) == 0
    after = fmu.outputs()
    G = 1.0 ** 2 / 120.0 + 0.6 ** 2 / 80.0
    assert after["ax1O"] - before["ax1O"] == pytest.approx(G * dF, rel=1e-9)
    assert after["ax_load"] - before["ax_load"] == pytest.approx((0.7 / 120.0 - 0.6 * 0.4 / 80.0) * dF, rel=1e-9)
    assert after["ay1O"] == before["ay1O"]
    for name in ("x1O", "vx1O", "x_rel", "q_x1", "E", "W_exc"):  # the state is untouched
        assert after[name] == before[name], name
    # reading between set and step changes nothing: a twin that never read gives the same step
    twin = open_fmu("Structure", **PARAMS)
    assert twin.init() == 0
    for _ in range(50):
        assert twin.step(0.01) == 0
    assert twin.set(Fx_ball=dF) == 0
    assert fmu.step(0.01) == 0 and twin.step(0.01) == 0
    assert fmu.outputs() == twin.outputs()


def test_ball_force_follows_the_chamber_acceleration_without_a_step(open_fmu):
    """At rest at the bottom the rolling ball's load on the chamber is F = -(2/7) m a_O
    (its instantaneous effective mass): setting ax1O recomputes Fx at once (input_mode 1)."""
    m = 2.0
    fmu = open_fmu("BallInShell", m=m, r=0.025, R=0.3)
    assert fmu.init() == 0
    assert fmu.step(0.002) == 0
    fx0 = fmu.get("Fx")
    assert fmu.set(ax1O=0.1) == 0
    assert fmu.get("Fx") - fx0 == pytest.approx(-2.0 / 7.0 * m * 0.1, rel=1e-9)
    assert fmu.set(ay1O=-0.3) == 0
    assert fmu.get("Fy") == pytest.approx(-2.0 / 7.0 * m * -0.3, rel=1e-9)
    assert fmu.get("N") == pytest.approx(m * 9.81, rel=1e-9)


def test_ball_outputs_stay_when_no_feedthrough_input_changes(open_fmu):
    """After a step the ball's outputs come from the reconstruction's inputs at the new time; an
    input set that leaves x1O, y1O, ax1O, ay1O as the step took them (the same values again, or
    another input) changes no output: only the declared feedthrough recomputes them."""
    fmu = open_fmu("BallInShell", xC0=0.05)
    assert fmu.set(ax1O=0.2, vx1O=0.01) == 0
    assert fmu.init() == 0
    for _ in range(5):
        assert fmu.step(0.002) == 0
    before = fmu.outputs()
    assert fmu.set(x1O=0.0, y1O=0.0, ax1O=0.2, ay1O=0.0, vy1O=0.0, Omega_z=0.0, Q11=1.0) == 0
    assert fmu.outputs() == before
    assert fmu.set(ax1O=0.25) == 0  # a new value: the force follows at once
    assert fmu.get("Fx") != before["Fx"] and fmu.get("xC") == before["xC"]


@pytest.mark.parametrize("steps", [0, 1, 5])
def test_ball_outputs_follow_inputs_that_all_return_to_zero(open_fmu, steps):
    """After initialisation or steps that took ax1O = 0.2, setting it to 0 leaves all four
    feedthrough inputs (x1O, y1O, ax1O, ay1O) at zero, the value of an input sample never taken
    (nor of the empty slots of a young input history): the outputs must follow it like any other
    change. The load is linear in the chamber's acceleration, so Fx moves by as much from 0.2 to
    0 as from 0 to -0.2."""
    fmu = open_fmu("BallInShell", xC0=0.05)
    assert fmu.set(ax1O=0.2, vx1O=0.01) == 0
    assert fmu.init() == 0
    for _ in range(steps):
        assert fmu.step(0.002) == 0
    published = fmu.outputs()
    assert fmu.set(ax1O=0.0) == 0
    zero = fmu.outputs()
    assert fmu.set(ax1O=-0.2) == 0
    minus = fmu.outputs()
    assert zero["xC"] == published["xC"]
    assert zero["Fx"] - published["Fx"] == pytest.approx(minus["Fx"] - zero["Fx"], rel=1e-9)
    assert abs(zero["Fx"] - published["Fx"]) > 0.05 * 0.2  # about (2/7) m 0.2 = 0.057 N


def test_ball_outputs_follow_an_input_set_back_to_the_value_the_step_took(open_fmu):
    """A master iterating a loop may set ax1O to a trial value and then back to the value the
    last step took: the outputs must follow both sets (they were left at the trial value's).
    The load on the chamber is linear in the chamber's acceleration, so with the trial values
    a0 + 1 and a0 + 2 the change of Fx and N over the second unit equals that over the first.
    An FMU state saved after a refresh carries what the outputs were computed from."""
    fmu = open_fmu("BallInShell", xC0=0.05)
    assert fmu.set(ax1O=0.2, vx1O=0.01) == 0
    assert fmu.init() == 0
    for _ in range(5):
        assert fmu.step(0.002) == 0
    published = fmu.outputs()
    assert fmu.set(ax1O=1.2) == 0
    trial = fmu.outputs()
    state = fmu.get_state()
    assert fmu.set(ax1O=0.2) == 0  # back to the value the step took
    back = fmu.outputs()
    assert back["Fx"] != trial["Fx"] and back["xC"] == published["xC"]
    assert fmu.set(ax1O=2.2) == 0
    two = fmu.outputs()
    for name in ("Fx", "N", "M_reaction"):
        assert two[name] - trial[name] == pytest.approx(trial[name] - back[name], rel=1e-9, abs=1e-12), name
    assert fmu.set_state(state) == 0
    assert fmu.outputs() == trial
    assert fmu.set(ax1O=0.2) == 0  # from the restored state: again the value the step took
    assert fmu.outputs() == back


def test_a_non_finite_input_refuses_the_step_and_keeps_the_state(open_fmu, flavour):
    fmu = open_fmu("Structure", F0_x=1.0)
    assert fmu.init() == 0
    for _ in range(10):
        assert fmu.step(0.01) == 0
    before = fmu.outputs()
    assert fmu.set(Fx_ball=math.nan) == 0
    n = len(fmu.log)
    assert fmu.step(0.01) == 2  # fmi2Discard in both flavours
    assert "input Fx_ball must be finite, got nan" in fmu.messages(n)
    if flavour.usable_after_refusal:
        assert fmu.outputs() == {k: v for k, v in before.items()}
    assert fmu.set(Fx_ball=0.0) == 0
    assert fmu.step(0.01) == 0


def test_motor_startup_torque_follows_the_ball_torque_without_a_step(open_fmu):
    """T_drive = J_total psi'' - M_reaction and P_drive = T_drive psi' (declared feedthrough from
    M_reaction): setting M_reaction between steps recomputes both at once, the crank's motion
    untouched; the next step is the same as a twin's that never read."""
    fmu, twin = open_fmu("MotorStartup", J_crank=0.3, m_platform=2.0), open_fmu("MotorStartup", J_crank=0.3,
                                                                                   m_platform=2.0)
    for f in (fmu, twin):
        assert f.init() == 0
        for _ in range(30):
            assert f.step(0.01) == 0
    before = fmu.outputs()
    assert fmu.set(M_reaction=1.5) == 0 and twin.set(M_reaction=1.5) == 0
    after = fmu.outputs()
    j_total = 0.3 + 2.0 * 0.5 ** 2
    assert after["T_drive"] == j_total * before["psi_ddot"] - 1.5
    assert after["P_drive"] == after["T_drive"] * before["psi_dot"]
    assert after["T_drive"] != before["T_drive"]
    assert {k: after[k] for k in after if k not in ("T_drive", "P_drive", "M_reaction")} == \
        {k: before[k] for k in before if k not in ("T_drive", "P_drive", "M_reaction")}
    assert fmu.step(0.01) == 0 and twin.step(0.01) == 0
    assert fmu.outputs() == twin.outputs()


def test_motor_startup_refuses_a_torque_whose_power_overflows(open_fmu, flavour):
    """M_reaction = -1e308 N.m is finite, but T_drive psi' is not: the step is refused
    (fmi2Discard, both flavours) and every output keeps its last good value (the pythonfmu
    flavour raised out of the step: fmi2Fatal)."""
    fmu = open_fmu("MotorStartup")
    assert fmu.init() == 0
    for _ in range(100):
        assert fmu.step(0.01) == 0
    before = fmu.outputs()
    assert before["psi_dot"] > 1.0  # 1 s into the paper's start-up: 4.0 rad/s
    assert fmu.set(M_reaction=-1e308) == 0
    n = len(fmu.log)
    assert fmu.step(0.002) == 2
    assert "P_drive" in fmu.messages(n)
    if flavour.usable_after_refusal:
        after = fmu.outputs()
        assert {k: after[k] for k in after if k != "M_reaction"} == \
            {k: before[k] for k in before if k != "M_reaction"}
        assert fmu.set(M_reaction=0.0) == 0
        assert fmu.step(0.002) == 0


def test_fmu_state_restores_the_input_history(open_fmu):
    """A state saved mid-run and restored gives the same next steps (the extrapolation's
    samples are part of the state)."""
    fmu = open_fmu("Structure", F0_x=1.0)
    assert fmu.init() == 0
    for k in range(10):
        fmu.set(Fx_ball=0.1 * k)
        assert fmu.step(0.01) == 0
    saved, t_saved = fmu.get_state(), fmu.time
    runs = []
    for _ in range(2):
        assert fmu.set_state(saved) == 0
        fmu.time = t_saved
        for k in range(10, 15):
            fmu.set(Fx_ball=0.1 * k * k)
            assert fmu.step(0.01) == 0
        runs.append(fmu.outputs())
    assert runs[0] == runs[1]
