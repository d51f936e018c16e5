"""The pythonfmu adapters at their edges, in-process (tests/mutation/inprocess.py), for the
mutants of fmi/slave.py, fmu_src/ballinshell_fmu.py and drive_models/inductionmotor_fmu.py that
the conformance suite and test_adapters_in_process.py let through (docs/mutation.md): calls in
the wrong phase and their messages, outputs set by the master, the contiguity tolerance and
the max_step margin exactly at their bounds, every Ball parameter reaching the model, the
loss parameters' limits at their edges, loss of contact at the start and at the end of a
step, and the induction motor's integrator settings."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import DISCARD, ERROR, FATAL, OK, open_fmu  # noqa: E402

from ballmill.fmi.slave import T_REL  # noqa: E402
from ballmill.physics import Ball, BallModel  # noqa: E402

H = 2e-3


def _call(fmu, call, *args):
    n = len(fmu.log)
    st, result = fmu._status(call, *args)
    return st, result, fmu.messages(n)


# -- fmi/slave.py: the phases -------------------------------------------------------
def test_calls_in_the_wrong_phase_are_refused_with_their_reason():
    fmu = open_fmu("BallInShell")
    s = fmu.slave
    st, done, msg = _call(fmu, s.do_step, 0.0, H)
    assert (st, done) == (OK, False)
    assert msg == ("BallInShell 'ballinshell': doStep(currentCommunicationPoint = 0.0 s, communicationStepSize "
                   "= 0.002 s) before fmi2ExitInitializationMode refused")
    st, _, msg = _call(fmu, s.exit_initialization_mode)
    assert st == FATAL and msg == ("BallInShell 'ballinshell': fmi2ExitInitializationMode outside "
                                   "initialisation mode (instantiated phase)")
    st, _, msg = _call(fmu, s.setup_experiment, math.inf, None, None)
    assert st == FATAL and msg == "BallInShell 'ballinshell': startTime = inf s refused: it must be finite"
    assert fmu.init() == OK
    st, _, msg = _call(fmu, s.setup_experiment, 0.0, None, None)
    assert st == FATAL and msg == ("BallInShell 'ballinshell': fmi2SetupExperiment is allowed only after "
                                   "fmi2Instantiate (or fmi2Reset), not in the stepping phase")
    st, _, msg = _call(fmu, s.enter_initialization_mode)
    assert st == FATAL and msg == ("BallInShell 'ballinshell': fmi2EnterInitializationMode is allowed only "
                                   "after fmi2Instantiate (or fmi2Reset), not in the stepping phase")
    assert fmu.terminate() == OK
    st, done, msg = _call(fmu, s.do_step, 0.0, H)
    assert (st, done) == (OK, False)
    assert msg.endswith("communicationStepSize = 0.002 s) after fmi2Terminate refused")


def test_without_setup_experiment_the_time_starts_at_zero():
    fmu = open_fmu("BallInShell")
    s = fmu.slave
    for call in (s.enter_initialization_mode, s.exit_initialization_mode):
        assert fmu._status(call)[0] == OK
    st, done, msg = _call(fmu, s.do_step, 0.0, H)
    assert (st, done, msg) == (OK, True, "")


def test_a_refused_initialisation_is_logged_as_an_error_then_fatal():
    fmu = open_fmu("BallInShell", delta=0.5)
    s = fmu.slave
    for call, args in ((s.setup_experiment, (0.0, None, None)), (s.enter_initialization_mode, ())):
        assert fmu._status(call, *args)[0] == OK
    n = len(fmu.log)
    assert fmu._status(s.exit_initialization_mode)[0] == FATAL
    (st1, m1), (st2, m2) = fmu.log[n:]
    assert st1 == ERROR and st2 == FATAL and m1 == m2
    assert "parameter delta = 0.5 m is outside its accepted range [0, r = " in m1


def test_in_initialisation_mode_a_get_sees_the_parameters_set_so_far():
    """Outputs read in initialisation mode are those of the parameters set so far (the slave
    initialises on the read)."""
    fmu = open_fmu("BallInShell", xC0=0.05)
    s = fmu.slave
    for call, args in ((s.setup_experiment, (0.0, None, None)), (s.enter_initialization_mode, ())):
        assert fmu._status(call, *args)[0] == OK
    assert fmu.get("xC") == 0.05
    assert fmu.set(xC0=0.07) == OK  # a fixed parameter may still be set in initialisation mode
    assert fmu.get("xC") == 0.07


def test_an_output_set_by_the_master_is_refused_with_its_unit():
    fmu = open_fmu("BallInShell")
    assert fmu.init() == OK
    before = fmu.outputs()
    n = len(fmu.log)
    assert fmu.set(xP=1.5) == FATAL
    assert fmu.messages(n) == "BallInShell 'ballinshell': xP is an output and cannot be set (got xP = 1.5 m)"
    n = len(fmu.log)
    assert fmu.set(friction_ratio=2.0) == FATAL  # unit "1": no unit in the text
    assert fmu.messages(n) == ("BallInShell 'ballinshell': friction_ratio is an output and cannot be set "
                               "(got friction_ratio = 2.0)")
    # an input and an output in one call: the output is still refused, nothing set
    vr_in, vr_out = fmu.vars["x1O"].valueReference, fmu.vars["xC"].valueReference
    st, _, msg = _call(fmu, fmu.slave.set_real, [vr_in, vr_out], [0.01, 0.3])
    assert st == FATAL and "xC is an output and cannot be set" in msg
    assert fmu.outputs() == before


# -- fmi/slave.py: the step-size policy at its bounds --------------------------------
def test_the_contiguity_tolerance_at_its_bounds():
    fmu = open_fmu("BallInShell")
    assert fmu.init() == OK
    s = fmu.slave
    st, done, msg = _call(fmu, s.do_step, T_REL, H)  # exactly T_REL away: accepted
    assert (st, done, msg) == (OK, True, "")
    fmu = open_fmu("BallInShell")
    assert fmu.init(1.5) == OK
    st, done, msg = _call(fmu, s.do_step if False else fmu.slave.do_step, 1.5 + 1.2 * T_REL, H)
    assert (st, done, msg) == (OK, True, "")  # within T_REL |t| = 1.5 T_REL
    fmu = open_fmu("BallInShell")
    assert fmu.init(1.5) == OK
    st, done, msg = _call(fmu, fmu.slave.do_step, 1.5 + 1.8 * T_REL, H)
    assert (st, done) == (OK, False) and "currentCommunicationPoint must equal the FMU's time" in msg
    fmu = open_fmu("BallInShell")
    assert fmu.init(4.0) == OK
    st, done, msg = _call(fmu, fmu.slave.do_step, 4.0 + 3.0 * T_REL, H)
    assert (st, done, msg) == (OK, True, "")  # within T_REL |t| = 4 T_REL


def test_a_step_too_short_to_move_the_time_is_refused():
    fmu = open_fmu("BallInShell")
    assert fmu.init(1e6) == OK
    st, done, msg = _call(fmu, fmu.slave.do_step, 1e6, 1e-12)
    assert (st, done) == (OK, False)
    assert msg.endswith("refused: the step ends at 1000000.0 s, not after the FMU's time t = 1000000.0 s; "
                        "state kept")
    assert fmu.log[-1][0] == ERROR


def test_the_default_max_step_and_its_margin():
    """max_step = 0 means 0.05 of the small-oscillation period 2 pi / omega0; a step up to a
    relative 1e-12 above it is taken, a longer one discarded naming the bound."""
    ball = Ball()
    limit = 0.05 * 2.0 * math.pi / ball.omega_small
    fmu = open_fmu("BallInShell")
    assert fmu.init() == OK
    assert fmu.step(limit * (1.0 + 1e-12)) == OK
    n = len(fmu.log)
    assert fmu.step(limit * (1.0 + 1e-9)) == DISCARD
    assert f"communicationStepSize exceeds max_step = {limit:.6g} s" in fmu.messages(n)


# -- fmu_src/ballinshell_fmu.py ------------------------------------------------------
def test_every_ball_parameter_reaches_the_model():
    """Non-default r, R, m, g and mu: the outputs at initialisation are the library's for
    that ball; a friction coefficient below the static need flags slip at t = 0."""
    p = dict(r=0.03, R=0.25, m=1.7, g=9.5, mu=0.05)
    xC0, yC0 = 0.08, -0.03
    fmu = open_fmu("BallInShell", xC0=xC0, yC0=yC0, **p)
    assert fmu.init() == OK
    model = BallModel(Ball(**p))
    ref = model.outputs(model.initial(xC0, yC0), 0.0, 0.0)
    got = fmu.outputs()
    for name in ref._fields:
        if name in got:
            assert got[name] == pytest.approx(float(getattr(ref, name)), rel=1e-12, abs=1e-15), name
    assert got["N"] == pytest.approx(float(ref.N)) and not got["rolling"] and got["contact"]
    assert "> mu = 0.05; the ball would slide" in fmu.messages()


def test_the_loss_parameters_at_their_limits():
    ball = Ball()
    assert open_fmu("BallInShell", delta=ball.r).init() == OK
    fmu = open_fmu("BallInShell", delta=np.nextafter(ball.r, 1.0))
    assert fmu.init() == FATAL and "parameter delta = " in fmu.messages()
    c_max = 1e4 * ball.m * ball.omega_small
    assert open_fmu("BallInShell", c_drag=c_max).init() == OK
    fmu = open_fmu("BallInShell", c_drag=np.nextafter(c_max, math.inf))
    assert fmu.init() == FATAL
    assert f"is outside its accepted range [0, {c_max:.6g}] N.s/m" in fmu.messages()


def test_rk4s_step_at_the_work_bound():
    max_step = 0.5
    h = max_step / 20000
    assert max_step / h == 20000.0
    fmu = open_fmu("BallInShell", integrator=3, max_step=max_step, h_fixed=h)
    assert fmu.init() == OK
    fmu = open_fmu("BallInShell", integrator=3, max_step=max_step, h_fixed=h * (1.0 - 1e-15))
    assert fmu.init() == FATAL
    assert f"is outside its accepted range [{h:.6g}, inf) s (max_step / 20000 internal steps" in fmu.messages()


def test_the_tolerance_reaches_the_ball_model():
    """A looser tolerance moves the contact point, by far less than the motion itself."""
    from conformance.inputs import run_ball
    a, _ = run_ball(open_fmu, [0.02] * 20, tolerance=1e-2, xC0=0.1)
    b, _ = run_ball(open_fmu, [0.02] * 20, tolerance=1e-12, xC0=0.1)
    da = abs(a.get("xP") - b.get("xP"))
    assert 1e-13 < da < 1e-3


def _contact_lost_run(jerk, steps, xC0_frac=math.sin(math.radians(60.0)), mu=10.0):
    """The ball released at rest 60 degrees up the wall, the chamber
    accelerated in +x with a constant jerk (consistent x, v, a: input mode 1); mu = 10: it does
    not slip before it leaves the wall."""
    d = Ball().d
    fmu = open_fmu("BallInShell", xC0=xC0_frac * d, mu=mu)

    def feed(t):
        assert fmu.set(x1O=jerk * t ** 3 / 6.0, vx1O=jerk * t ** 2 / 2.0, ax1O=jerk * t) == OK
    feed(0.0)
    assert fmu.init() == OK
    t = 0.0
    for _ in range(steps):
        if fmu.step(H, t) != OK:
            break
        t += H
        feed(t)
    return fmu


def test_contact_lost_at_the_start_is_reported_and_latched():
    d = Ball().d
    fmu = open_fmu("BallInShell", xC0=math.sin(math.radians(60.0)) * d, mu=1.0, ax1O=20.0)
    assert fmu.init() == OK
    out = fmu.outputs()
    assert out["contact"] is False and out["valid"] is False and out["t_invalid"] == 0.0
    assert out["N"] < 0.0 and out["friction_ratio"] == 1e300  # +inf published as 1e300
    msg = fmu.messages()
    assert (f"BallInShell 'ballinshell': contact lost at t = 0 s (N = {out['N']:.6g} N): the ball leaves the "
            f"wall and the rolling model no longer holds") in msg
    assert (f"valid = false from t = 0 s (latched until reset): contact lost (N = {out['N']:.6g} N)") in msg
    assert "slip" not in msg


def test_contact_lost_at_the_end_of_a_step_is_latched_there():
    """N > 0 at every communication point up to t_k, N < 0 at t_k + H (predicted): the latch
    names the step's end and the reason; the next point's report warns of the loss."""
    g = Ball().g
    a_crit = g / math.tan(math.radians(60.0))
    fmu = _contact_lost_run(jerk=a_crit / (1.5 * H), steps=3)
    msg = fmu.messages()
    first = next(m for _, m in fmu.log if "valid = false from t = " in m)
    t_inv = fmu.get("t_invalid")
    assert first.startswith(f"BallInShell 'ballinshell': valid = false from t = {t_inv:.9g} s (latched until "
                            f"reset): contact lost (N = ")
    assert first.endswith(" N) at the end of the step")
    assert "contact lost between t = " in msg and "slip" not in msg


# -- drive_models/inductionmotor_fmu.py ------------------------------------------------
@pytest.mark.parametrize("model, light", [(1, False), (2, False), (1, True)])
def test_the_motors_integration_carries_its_step_and_scales(model, light):
    """The motor's steps are DOP853 at the FMU's tolerance with the documented error scales
    (angle 1 rad, crank speed w_sync / i, dq fluxes U_peak / (2 pi f), energy
    max(1 J, J_total (w_sync / i)^2 / 2)) and the internal step carried from one doStep to the
    next: the published state is the library integrator's, bit for bit. `light`: a drive whose
    kinetic energy at synchronous speed is below 1 J (the energy scale's floor)."""
    from ballmill.physics.integrators import Integrator
    extra = dict(J_rotor=1e-5, J_crank=0.0, m_platform=0.0) if light else {}
    fmu = open_fmu("InductionMotor", model=model, tolerance=1e-6, M_reaction=-20.0 * (not light), **extra)
    assert fmu.init() == OK
    s = fmu.slave
    drive, motor = s._drive, s._drive.motor
    w_scale = motor.synchronous_speed / drive.i
    flux = motor.phase_voltage_peak / (2.0 * math.pi * motor.rated_frequency)
    scale = [1.0, w_scale] + ([flux] * 4 if drive.model == "dq" else []) \
        + [max(1.0, 0.5 * drive.J_total * w_scale ** 2)]
    if light:
        assert 0.5 * drive.J_total * w_scale ** 2 < 1.0
    ref = Integrator("DOP853", tol=1e-6, scale=scale, max_steps=20000)
    z, h, t = np.array(s._z), None, 0.0
    for _ in range(6):
        load = s._load([(t, -20.0 * (not light))])
        z, h, _ = ref.advance(s._rhs(load), t, z, t + 0.05, h)
        assert fmu.step(0.05, t) == OK
        t += 0.05
        assert fmu.get("psi") == float(z[0]) and fmu.get("psi_dot") == float(z[1])
        assert fmu.get("W_motor") == float(z[-1])


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_the_motors_refusals_name_the_input_and_the_output():
    fmu = open_fmu("InductionMotor", M_reaction=math.inf)
    assert fmu.init() == FATAL
    assert "input M_reaction must be finite, got inf N.m" in fmu.messages()
    fmu = open_fmu("InductionMotor")
    assert fmu.init() == OK and fmu.set(M_reaction=math.nan) == OK
    n = len(fmu.log)
    assert fmu.step(H) == DISCARD
    assert fmu.messages(n) == ("InductionMotor 'inductionmotor': input M_reaction must be finite, got nan N.m at "
                               "t = 0 s; step refused, last good state kept")
    fmu = open_fmu("InductionMotor", M_reaction=1e308, J_crank=0.0, m_platform=0.0, J_rotor=1e-3, i=1.0)
    assert fmu.init() == FATAL
    assert "output psi_ddot would be inf" in fmu.messages()


def test_the_loads_slope_takes_a_sample_exactly_half_a_step_back():
    """Steps of H, H/2, H (binary-exact times): the third step's slope comes from the sample at
    H, exactly half a step back, not the older one at 0; a quadratic load tells them apart."""
    h = 2.0 ** -9

    def M(t):
        return 30.0 + 4e5 * t * t
    fmu = open_fmu("InductionMotor", M_input=2, M_reaction=M(0.0))
    assert fmu.init() == OK
    t = 0.0
    for step in (h, 0.5 * h, h):
        assert fmu.step(step, t) == OK
        t += step
        assert fmu.set(M_reaction=M(t)) == OK
    s = fmu.slave
    t_k = 1.5 * h
    slope = (M(t_k) - M(h)) / (t_k - h)
    load_end = M(t_k) + slope * (t - t_k)
    got = s._drive.J_total * fmu.get("psi_ddot") - s._drive.i * fmu.get("T_motor")
    assert got == pytest.approx(load_end, rel=1e-12)


def test_slip_at_the_end_of_a_step_is_latched_there():
    """mu = 1: the friction ratio rises through mu between two points (N still > 0): the
    latch names the step's end and the reason."""
    g = Ball().g
    a_crit = g / math.tan(math.radians(60.0))
    fmu = _contact_lost_run(jerk=a_crit / (10 * H), steps=12, mu=1.0)
    first = next(m for _, m in fmu.log if "valid = false from t = " in m)
    t_inv = fmu.get("t_invalid")
    assert first.startswith(f"BallInShell 'ballinshell': valid = false from t = {t_inv:.9g} s (latched until "
                            f"reset): slip: |F_t|/N = ")
    assert first.endswith(" > mu = 1 at the end of the step")


def test_an_inconsistent_input_is_latched_with_its_description():
    from conformance.inputs import feed
    fmu = open_fmu("BallInShell")
    feed(fmu, 0.0)
    assert fmu.init() == OK
    t = 0.0
    for k in range(12):
        assert fmu.step(H, t) == OK
        t += H
        feed(fmu, t, noise=(lambda tt: {"vx1O": 1.0}) if k == 10 else None)
    warning = next(m for _, m in fmu.log if "flagged: valid = false (warned once)" in m)
    problem = warning.split(f"at t = {fmu.get('t_invalid'):.9g} s ", 1)[1].rsplit("; flagged", 1)[0]
    assert problem
    assert (f"valid = false from t = {fmu.get('t_invalid'):.9g} s (latched until reset): {problem}"
            in fmu.messages())


@pytest.mark.parametrize("mode", [2, 4])
def test_the_noise_sum_only_grows(mode):
    """The noise estimate is a running sum of squares: it never decreases, and it grows by
    more than the last term alone."""
    from test_adapters_in_process import _noisy_run

    from ballmill.fmi.slave import state_from_bytes
    sums = []
    for n in (20, 25, 30, 35, 40):
        fmu = _noisy_run(mode, 1, 1e-7, n=n)
        sums.append(state_from_bytes(fmu.serialize(fmu.get_state()))["__internal__"]["noise_sum"])
    assert sums[0] > 0.0
    assert all(b > a for a, b in zip(sums, sums[1:])), sums


@pytest.mark.parametrize("name, value, unit", [("Omega_z", 0.5, " rad/s"), ("Q12", 0.1, ""), ("z1O", 1e-3, " m"),
                                               ("Q11", 0.5, "")])
def test_motion_1_ignores_a_chamber_input_away_from_its_default(name, value, unit):
    """motion = 1 takes a horizontal translation only: any other input away from its default
    is ignored (the step as without it), named once, at the step or at the initialisation."""
    default = 1.0 if name == "Q11" else 0.0
    text = (f"input {name} = {value!r}{unit} (default {default!r}) is ignored: motion = 1 (horizontal "
            f"translation) uses x1O..ay1O only, not z1O..az1O, Omega, Omega_dot or Q; set motion = 2 for a "
            f"chamber that moves vertically or turns (said once)")
    plain = open_fmu("BallInShell")
    fmu = open_fmu("BallInShell")
    for f in (plain, fmu):
        assert f.init() == OK and f.step(H) == OK
    assert fmu.set(**{name: value}) == OK
    n = len(fmu.log)
    for _ in range(2):
        assert fmu.step(H) == OK and plain.step(H) == OK
    assert fmu.messages(n) == f"BallInShell 'ballinshell': at t = 0.002 s {text}"
    assert fmu.outputs() == plain.outputs()
    fmu = open_fmu("BallInShell", **{name: value})
    assert fmu.init() == OK and fmu.messages() == f"BallInShell 'ballinshell': at t = 0 s {text}"
