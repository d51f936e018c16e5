"""The pythonfmu adapters' own arithmetic and memory, in-process (tests/mutation/inprocess.py),
for mutants the conformance suite and the outputs-against-library tests let through
(docs/mutation.md): the drive's torque balance with every inertia, the load's linear
extrapolation, and an FMU state that carries everything the coming steps depend on (the
noise estimate of the measured-motion modes, the warnings already given)."""
from __future__ import annotations

import json
import re
import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from conformance.inputs import crank, feed, run_ball  # noqa: E402
from inprocess import OK, open_fmu  # noqa: E402

from ballmill.fmi.slave import state_from_bytes  # noqa: E402
from ballmill.physics.drives.induction import CrankDrive, InductionMotor as MotorData  # noqa: E402

H = 2e-3


@pytest.mark.parametrize("J_crank, m_platform, l, i", [(3.0, 5.0, 0.3, 10.0), (0.0, 40.0, 0.7, 25.0)])
def test_the_motor_balances_torque_with_every_inertia(J_crank, m_platform, l, i):
    """J_total psi'' = i T_motor + M_reaction, J_total = J_crank + m_platform l^2 + i^2 J_rotor
    (the library's CrankDrive), at every communication point, with a load that rises linearly
    (M_input = 2: extrapolated linearly, so exact from the second step on)."""
    drive = CrankDrive(motor=MotorData(), i=i, J_crank=J_crank, m_platform=m_platform, l=l)
    assert drive.J_total == pytest.approx(J_crank + m_platform * l * l + i * i * MotorData().J_rotor, rel=1e-15)
    fmu = open_fmu("InductionMotor", J_crank=J_crank, m_platform=m_platform, l=l, i=i, M_input=2)

    def M(t):
        return 40.0 + 300.0 * t  # positive and above t: a filter on the wrong column would drop it
    assert fmu.set(M_reaction=M(0.0)) == OK and fmu.init() == OK
    t = 0.0
    for k in range(40):
        assert fmu.step(H, t) == OK
        t += H
        if k >= 1:
            lhs = drive.J_total * fmu.get("psi_ddot")
            rhs = i * fmu.get("T_motor") + M(t)
            assert lhs == pytest.approx(rhs, rel=1e-12, abs=1e-9), (k, lhs, rhs)
        assert fmu.set(M_reaction=M(t)) == OK


def _state_round_trip_is_exact(fmu, feed_at, n_after=8, h=H):
    """Save, go on n_after steps, restore the serialised state, go on again: bit for bit the
    same outputs and log."""
    blob = fmu.serialize(fmu.get_state())
    t0 = fmu.time
    n_log = len(fmu.log)

    def go_on():
        t = t0
        out = []
        for _ in range(n_after):
            feed_at(t)
            assert fmu.step(h, t) == OK, fmu.messages()
            t += h
            out.append(fmu.outputs())
        return out
    first = go_on()
    log_first = fmu.log[n_log:]
    st, s = fmu.deserialize(blob)
    assert st == OK and fmu.set_state(s) == OK, fmu.messages()
    n_log = len(fmu.log)
    assert go_on() == first
    assert fmu.log[n_log:] == log_first
    return first


@pytest.mark.parametrize("mode", [2, 4])
def test_a_state_carries_the_noise_estimate_of_the_measured_modes(mode):
    """Positions (2) and accelerations (4) with noisy inputs: the coupling error estimate sums
    the fit's changes (noise_sum); a restored state goes on with the same sum."""
    fmu = open_fmu("BallInShell", input_mode=mode, corrector=1, coupling_warn=1e9)

    def noisy(t):
        k = round(t / H)
        eps = 1e-9 * ((k * 7919) % 13 - 6)
        values = dict(zip(("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O"), crank(t)))
        values["x1O"] += eps
        values["ax1O"] += 1e3 * eps
        assert fmu.set(**values) == OK
    noisy(0.0)
    assert fmu.init() == OK
    t = 0.0
    for _ in range(30):
        assert fmu.step(H, t) == OK
        t += H
        noisy(t)
    assert fmu.get("coupling_error") > 0.0
    state = state_from_bytes(fmu.serialize(fmu.get_state()))
    assert state["__internal__"]["noise_sum"] > 0.0
    out = _state_round_trip_is_exact(fmu, noisy)
    assert out[-1]["coupling_error"] > 0.0
    # a state written before the noise estimate existed (no noise_sum): the sum starts at 0
    old = state_from_bytes(fmu.serialize(fmu.get_state()))
    del old["__internal__"]["noise_sum"]
    zero = json.loads(json.dumps(old))
    zero["__internal__"]["noise_sum"] = 0.0
    results = []
    t_saved = fmu.time
    for s in (old, zero):
        assert fmu.set_state(s) == OK
        t = fmu.time = t_saved
        for _ in range(5):
            noisy(t)
            assert fmu.step(H, t) == OK
            t += H
        results.append(fmu.outputs())
    assert results[0] == results[1]


def test_a_state_remembers_the_warnings_already_given():
    """The resolution and inconsistency warnings are given once; a restored state does not
    give them again."""
    fmu, st = run_ball(open_fmu, [1e-6] * 3)  # steps too short for the positions: warned
    assert st == OK and "the reconstruction uses the velocity and acceleration inputs" in fmu.messages()
    _state_round_trip_is_exact(fmu, lambda t: feed(fmu, t), n_after=3, h=1e-6)
    assert fmu.messages().count("the reconstruction uses the velocity and acceleration inputs") == 1
    # a state from before the flag existed: the warning is given again
    old = fmu.get_state()
    del old["__internal__"]["resolution_warned"]
    assert fmu.set_state(old) == OK
    t = fmu.time
    feed(fmu, t)
    assert fmu.step(1e-6, t) == OK
    assert fmu.messages().count("the reconstruction uses the velocity and acceleration inputs") == 2
    fmu, st = run_ball(open_fmu, [H] * 5)
    t = fmu.time
    feed(fmu, t, offset=1.0)  # a jump: warned once
    assert fmu.step(H, t) == OK and "flagged: valid = false (warned once)" in fmu.messages()
    state = fmu.get_state()
    n = len(fmu.log)
    t += H
    feed(fmu, t, offset=2.0)  # another jump: not warned again
    assert fmu.step(H, t) == OK
    assert "warned once" not in fmu.messages(n)
    assert fmu.set_state(state) == OK
    n = len(fmu.log)
    feed(fmu, t, offset=2.0)
    assert fmu.step(H, t) == OK
    assert "warned once" not in fmu.messages(n)
    assert math.isfinite(fmu.get("t_invalid"))


# -- MotorStartup ------------------------------------------------------------------------------
@pytest.mark.parametrize("law", [1, 2, 3, 4])
def test_the_drive_follows_the_chosen_law(law):
    from ballmill.physics import CrankStartup
    from drive_models.motorstartup_fmu import LAWS
    ref = CrankStartup(l=0.4, n0=45.0, t0=1.5, law=LAWS[law])
    fmu = open_fmu("MotorStartup", l=0.4, n0=45.0, t0=1.5, law=law)
    assert fmu.init() == OK
    t = 0.0
    for _ in range(10):
        assert fmu.step(0.1, t) == OK
        t += 0.1
        psi, wd, wdd = ref.angle(t)
        assert (fmu.get("psi"), fmu.get("psi_dot"), fmu.get("psi_ddot")) == (psi, wd, wdd)
        assert tuple(fmu.get(n) for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")) == ref.state(t)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_load_is_refused_state_kept(bad):
    fmu = open_fmu("MotorStartup")
    assert fmu.init() == OK and fmu.step(0.1) == OK
    before = fmu.outputs()
    assert fmu.set(M_reaction=bad) == OK  # an input may be anything; the step refuses it
    n = len(fmu.log)
    assert fmu.step(0.1) == 2  # fmi2Discard
    assert fmu.messages(n) == (f"MotorStartup 'motorstartup': input M_reaction must be finite, got {bad!r} N.m at "
                               f"t = 0.1 s; step refused, last good state kept")
    assert fmu.outputs() == before
    assert fmu.set(M_reaction=0.0) == OK and fmu.step(0.1) == OK


def test_an_output_that_would_overflow_refuses_the_step_state_kept():
    """M_reaction = -1e308 N.m at rest (psi' = 0: P_drive = 0) then a step to where psi' = 4 rad/s:
    the drive power T_drive psi' is beyond the largest double; the step is refused and every
    output stays where it was."""
    fmu = open_fmu("MotorStartup")
    assert fmu.init() == OK and fmu.set(M_reaction=-1e308) == OK
    kinematics = ("psi", "psi_dot", "psi_ddot", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O", "T_drive", "P_drive")
    before = [fmu.get(k) for k in kinematics]
    n = len(fmu.log)
    assert fmu.step(1.0) == 2
    assert fmu.messages(n) == ("MotorStartup 'motorstartup': step to t = 1 s refused, last good state kept: "
                               "output P_drive would be inf")
    assert [fmu.get(k) for k in kinematics] == before
    # the torque and power keep what they were before the step: set with M_reaction (feedthrough,
    # T_drive = 0 psi'' + 1e308 N.m at rest, P_drive = T_drive 0 rad/s)
    assert fmu.get("T_drive") == 1e308 and fmu.get("P_drive") == 0.0
    assert fmu.set(M_reaction=0.0) == OK and fmu.step(1.0) == OK and fmu.get("psi_dot") > 3.9


# -- the slave base class (ballmill.fmi.slave) ---------------------------------------------------
def test_a_range_without_a_bound_reads_minus_or_plus_infinity():
    from inprocess import slave_class
    slave = slave_class("MotorStartup")(instance_name="r")
    slave.add("q", "parameter", 1.0, "q", "m", vmax=2.0)
    slave.add("w", "parameter", 1.0, "w", "1", vmin=0.5)
    slave.q = 3.0
    with pytest.raises(ValueError) as info:
        slave.check_parameters()
    assert str(info.value) == "parameter q = 3.0 m is outside its accepted range [-inf, 2] m"
    slave.q, slave.w = 1.0, 0.25
    with pytest.raises(ValueError) as info:
        slave.check_parameters()
    assert str(info.value) == "parameter w = 0.25 is outside its accepted range [0.5, inf]"


def test_a_refused_step_is_logged_as_an_error():
    fmu = open_fmu("MotorStartup")
    assert fmu.init() == OK
    n = len(fmu.log)
    assert fmu.step(-1.0) == 2
    assert [st for st, _ in fmu.log[n:]] == [3]  # fmi2Error
    fmu2 = open_fmu("BallInShell", max_step=0.01)
    fmu2.set(x1O=0.5)
    assert fmu2.init() == OK
    n = len(fmu2.log)
    assert fmu2.step(0.02) == 2
    assert [st for st, _ in fmu2.log[n:]] == [2]  # fmi2Discard: longer than max_step


def test_a_state_saved_after_terminate_restores_the_model():
    a = open_fmu("InductionMotor")
    assert a.init() == OK
    for _ in range(5):
        assert a.step(1e-3) == OK
    assert a.terminate() == OK
    s = a.get_state()
    assert s["__phase__"] == "terminated" and s["__internal__"] is not None
    b = open_fmu("InductionMotor")
    assert b.init() == OK and b.step(1e-3) == OK
    assert b.set_state(s) == OK, b.messages()
    assert b.get_state()["__internal__"] == s["__internal__"] and b.outputs() == a.outputs()
    assert b.step(1e-3) == 2  # refused after fmi2Terminate (fmi2Discard, logged as an error)
    assert "after fmi2Terminate" in b.messages()


def test_a_state_saved_in_initialisation_mode_is_taken():
    fmu = open_fmu("MotorStartup")
    slave = fmu.slave
    slave.setup_experiment(0.0, None, None)
    slave.enter_initialization_mode()
    s = fmu.get_state()
    assert s["__phase__"] == "initialisation" and s["__internal__"] is None
    assert fmu.set_state(s) == OK
    slave.exit_initialization_mode()
    assert fmu.step(0.1) == OK


def test_a_state_that_is_not_a_mapping_is_refused():
    fmu = open_fmu("MotorStartup")
    assert fmu.init() == OK
    n = len(fmu.log)
    assert fmu.set_state(["not", "a", "dict"]) == 4
    assert fmu.messages(n) == ("MotorStartup 'motorstartup': FMU state refused, the instance keeps its state: "
                               "an FMU state must be a mapping, got list")


def test_an_input_may_be_anything_in_a_state():
    fmu, st = run_ball(open_fmu, [1e-3] * 3)
    s = fmu.get_state()
    s["x1O"] = math.nan  # inputs are checked when a step uses them, not when a state is restored
    assert fmu.set_state(s) == OK, fmu.messages()
    s["xC"] = math.nan  # an output is not
    assert fmu.set_state(s) == 4 and "variable xC = nan is not finite" in fmu.messages()


def test_a_slave_without_outputs_or_model():
    from ballmill.fmi.slave import Slave

    class Bare(Slave):
        def __init__(self, **kw):
            super().__init__(**kw)
            self.add("p", "parameter", 1.0, "p", "m")
    bare = Bare(instance_name="bare")
    root = bare.to_xml()
    structure = root.find("ModelStructure")
    assert structure.find("Outputs") is None and structure.find("InitialUnknowns") is None
    bare.setup_experiment(0.0, None, None)
    bare.enter_initialization_mode()
    bare.exit_initialization_mode()
    assert bare.do_step(0.0, 0.5) is True and bare._time == 0.5  # the base step accepts


@pytest.mark.parametrize("f_start, slip", [(0.002, 1.0), (0.0, 0.0), (0.05, 1.0)])
def test_slip_at_rest_on_a_slow_supply(f_start, slip):
    """At rest slip = (ws - 0) / ws = 1 for any supply frequency above zero (here down to
    0.1 Hz: ws = 0.31 rad/s); with no supply frequency at all it is reported as 0."""
    fmu = open_fmu("InductionMotor", start_mode=3, f_start=f_start)
    assert fmu.init() == OK
    assert fmu.get("slip") == slip


def test_the_coupling_warning_is_remembered_and_old_states_warn_again():
    fmu, st = run_ball(open_fmu, [H] * 5, coupling_warn=0.0)
    assert st == OK and fmu.messages().count("(warned once)") == 1
    state = fmu.get_state()
    assert state["__internal__"]["warned"] is True
    t = fmu.time
    _state_round_trip_is_exact(fmu, lambda tt: feed(fmu, tt), n_after=3)
    assert fmu.messages().count("off by") == 1
    # a state from before the resolution and inconsistency flags existed: both start false
    fmu, st = run_ball(open_fmu, [H] * 5)
    t = fmu.time
    feed(fmu, t, offset=1.0)
    assert fmu.step(H, t) == OK and fmu.messages().count("flagged: valid = false (warned once)") == 1
    old = fmu.get_state()
    assert old["__internal__"]["inconsistency_warned"] is True
    del old["__internal__"]["inconsistency_warned"], old["__internal__"]["resolution_warned"]
    assert fmu.set_state(old) == OK
    fmu.time = t + H
    feed(fmu, fmu.time, offset=2.0)
    assert fmu.step(H) == OK
    assert fmu.messages().count("flagged: valid = false (warned once)") == 2


@pytest.mark.parametrize("t_end, offset, ok", [
    (0.006, 0.5e-9, True), (0.006, -0.9e-9, True), (0.006, 1.5e-9, False), (0.006, -1.5e-9, False),
    (2.0, 1.5e-9, True), (2.0, -1.9e-9, True), (2.0, 2.5e-9, False),  # beyond 1 s: 1e-9 |t|
])
def test_the_ball_states_time_must_be_the_fmus(t_end, offset, ok):
    h = 0.006 if t_end < 1 else 0.04
    fmu, st = run_ball(open_fmu, [h] * round(t_end / h), max_step=0.05)
    assert st == OK
    s = fmu.get_state()
    s["__internal__"]["state"]["t"] += offset
    assert (fmu.set_state(s) == OK) is ok, fmu.messages()
    if not ok:
        assert "the ball state is at t = " in fmu.messages()


@pytest.mark.parametrize("stretch, ok", [(1 + 0.5e-6, True), (1 - 0.9e-6, True), (1 + 2e-6, False),
                                         (1 - 2e-6, False)])
def test_the_ball_states_direction_must_be_a_unit_vector(stretch, ok):
    fmu, st = run_ball(open_fmu, [H] * 3)
    s = fmu.get_state()
    y = s["__internal__"]["state"]["y"]
    y[:3] = [v * stretch for v in y[:3]]
    assert (fmu.set_state(s) == OK) is ok, fmu.messages()
    if not ok:
        assert "n = y[0:3] must be a unit vector" in fmu.messages()


# -- InductionMotor: every datasheet value reaches the motor, and the work bound -------------------
DATASHEET = dict(P_rated=1100.0, n_rated=1140.0, U_rated=380.0, f_rated=60.0, pole_pairs=3, I_rated=2.6,
                 cos_phi=0.8, eta=0.79, Tb_ratio=2.9, J_rotor=0.004, Rs_share=0.35)
LIBRARY_NAMES = dict(P_rated="rated_power", n_rated="rated_speed", U_rated="rated_voltage",
                     f_rated="rated_frequency", pole_pairs="pole_pairs", I_rated="rated_current",
                     cos_phi="power_factor", eta="efficiency", Tb_ratio="breakdown_ratio", J_rotor="J_rotor",
                     Rs_share="stator_copper_share")


@pytest.mark.parametrize("start_mode, model, extra", [
    (1, 1, {}), (2, 1, dict(u_start=0.45, ramp_time=0.3)), (3, 1, dict(f_start=0.1, ramp_time=0.3)),
    (1, 2, {}), (3, 2, dict(f_start=0.2, ramp_time=0.2, u_start=0.5)),
])
def test_every_datasheet_value_reaches_the_motor(start_mode, model, extra):
    """A motor unlike the default one in every datasheet value, against the library's run-up
    (scipy at rtol 1e-11) of the same motor: the motor's torque and speed after 0.1 s."""
    from ballmill.physics.drives.induction import simulate_runup
    from drive_models.inductionmotor_fmu import MODELS, STARTS
    H, n, M = 2e-3, 50, -0.8
    fmu = open_fmu("InductionMotor", start_mode=start_mode, model=model, tolerance=1e-11, **DATASHEET, **extra)
    assert fmu.set(M_reaction=M) == OK and fmu.init() == OK
    for k in range(n):
        assert fmu.step(H, k * H) == OK, fmu.messages()
    lib_extra = {k: v for k, v in extra.items()}
    motor = MotorData(start=STARTS[start_mode], **{LIBRARY_NAMES[k]: v for k, v in DATASHEET.items()}, **lib_extra)
    drive = CrankDrive(motor=motor, model=MODELS[model])
    res = simulate_runup(drive, n * H, load_torque=lambda t, psi, psid: M, rtol=1e-11, atol=1e-12, n_out=2)
    o = drive.outputs(res.y[:, -1], n * H, M)
    for name in ("psi_dot", "w_motor", "T_motor"):
        assert fmu.get(name) == pytest.approx(o[name], rel=1e-6, abs=1e-9), name


def test_the_tolerance_reaches_the_integrator():
    """The motor's run-up at tolerance 1e-3 is further from the library's (rtol 1e-11) than at
    1e-11, and at 1e-11 within 1e-8."""
    from ballmill.physics.drives.induction import simulate_runup
    H, n = 2e-3, 50
    errors = []
    drive = CrankDrive(motor=MotorData(), model="dq")
    res = simulate_runup(drive, n * H, load_torque=lambda t, psi, psid: 0.0, rtol=1e-11, atol=1e-12, n_out=2)
    ref = drive.outputs(res.y[:, -1], n * H, 0.0)["psi_dot"]
    for tol in (1e-3, 1e-11):
        fmu = open_fmu("InductionMotor", model=2, tolerance=tol)
        assert fmu.init() == OK
        for k in range(n):
            assert fmu.step(H, k * H) == OK
        errors.append(abs(fmu.get("psi_dot") - ref))
    assert errors[1] < 1e-8 * abs(ref) and errors[0] > 10 * errors[1], errors


def test_the_loads_slope_comes_from_a_sample_half_a_step_back():
    """M_input = 2 with a quadratic load and irregular steps: the load over a step is the line
    through the last sample at least half the step back (or, if none, the last one before) and
    the present one, from the samples kept (the last three before the present)."""
    from ballmill.physics.drives.induction import CrankDrive as CD
    fmu = open_fmu("InductionMotor", M_input=2)
    drive = CD(motor=MotorData())

    def M(t):
        return 2.0 + 40.0 * t * t
    steps = [H, H, H, 0.1 * H, 0.1 * H, 0.1 * H, 0.1 * H, H, 0.3 * H, H, H]
    assert fmu.set(M_reaction=M(0.0)) == OK and fmu.init() == OK
    t, kept = 0.0, []
    for h in steps:
        assert fmu.set(M_reaction=M(t)) == OK
        assert fmu.step(h, t) == OK
        older = [s for s in kept if s <= t - 0.5 * h] or [s for s in kept if s < t]
        if older:
            s = older[-1]
            load_end = M(t) + (M(t) - M(s)) / (t - s) * h
        else:
            load_end = M(t)
        kept = [s for s in kept if s < t][-3:] + [t]
        t += h
        got = drive.J_total * fmu.get("psi_ddot") - drive.i * fmu.get("T_motor")
        assert got == pytest.approx(load_end, rel=1e-12, abs=1e-9), (t, got, load_end)


# -- BallInShell: messages and the coupling estimate -------------------------------------------------
def _noisy_run(mode, corrector, amplitude, n=40):
    fmu = open_fmu("BallInShell", input_mode=mode, corrector=corrector, coupling_warn=1e9)

    def noisy(t):
        k = round(t / H)
        eps = amplitude * ((k * 7919) % 13 - 6) / 6.0
        values = dict(zip(("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O"), crank(t)))
        values["x1O"] += eps
        values["ax1O"] += 1e3 * eps
        assert fmu.set(**values) == OK
    noisy(0.0)
    assert fmu.init() == OK
    t = 0.0
    for _ in range(n):
        assert fmu.step(H, t) == OK, fmu.messages()
        t += H
        noisy(t)
    return fmu


@pytest.mark.parametrize("mode", [2, 4])
def test_the_coupling_estimate_is_dominated_by_the_noise_drift(mode):
    """With noisy measured inputs the estimate's drift part R (5/7) sqrt(noise_sum) / (d omega0)
    (noise_sum from the FMU's own state) dominates: the published coupling_error is the
    quadrature sum of it and a much smaller step error; without the corrector it is 0."""
    from ballmill.physics import Ball
    fmu = _noisy_run(mode, 1, 1e-7)
    ns = state_from_bytes(fmu.serialize(fmu.get_state()))["__internal__"]["noise_sum"]
    ball = Ball()
    drift = ball.R * (5.0 / 7.0) * math.sqrt(ns) / (ball.d * ball.omega_small)
    assert drift > 0.0
    assert drift <= fmu.get("coupling_error") <= 1.05 * drift
    assert _noisy_run(mode, 0, 1e-7).get("coupling_error") == 0.0


def test_a_step_the_physics_refuses_is_discarded_with_the_reason():
    """The paper formulation driven hard climbs to the equator: the step is discarded, the
    message says which step and why, the state is the last good one."""
    fmu = open_fmu("BallInShell", formulation=2)
    t, t0 = 0.0, 1.0
    feed(fmu, 0.0, t0=t0)
    assert fmu.init() == OK
    for _ in range(1000):
        before = fmu.outputs()
        n = len(fmu.log)
        st = fmu.step(H, t)
        if st:
            break
        t += H
        for k, v in zip(("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O"), crank(t, t0=t0, n0=90.0)):
            fmu.set(**{k: v})
    assert st == 2
    msg = fmu.messages(n)
    assert msg.startswith(f"BallInShell 'ballinshell': step from t = {t:.9g} s refused, last good state kept: ")
    assert "equator" in msg and "XX" not in msg
    assert fmu.outputs() == before


def test_validity_messages_name_the_interval_and_the_reason():
    fmu, st = run_ball(open_fmu, [], t0=0.5)
    t = 0.0
    for _ in range(1000):
        assert fmu.step(H, t) == OK
        t += H
        feed(fmu, t, t0=0.5)
    msg = fmu.messages()
    first = next(m for _, m in fmu.log if "valid = false from t = " in m)
    assert first.startswith(f"BallInShell 'ballinshell': valid = false from t = {fmu.get('t_invalid'):.9g} s "
                            f"(latched until reset): ")
    assert first.split("(latched until reset): ")[1].startswith(("slip: |F_t|/N = ", "contact lost (N = "))
    assert "slip at t = 0 s: |F_t|/N = 0.366 > mu = 0.3; the ball would slide" in msg
    assert re.search(r"slip between t = [0-9.]+ s and [0-9.]+ s: \|F_t\|/N = ", msg)


def test_the_resolution_warning_names_the_positions_and_their_resolution():
    fmu, st = run_ball(open_fmu, [1e-6] * 3)
    msg = fmu.messages()
    assert "the positions (|x1O|, |y1O| up to 0.5 m, resolution 1.11e-16 m) over a window of" in msg
