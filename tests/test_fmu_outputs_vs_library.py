"""Every output of every FMU against the library's value, in each mode.

The FMUs are driven through fmpy with ordinary call sequences (parameters before
initialisation, inputs set before each doStep, constant communication steps) and every
variable of causality output is compared with what the physics library computes for the
same case, independently of the adapter:

* MotorStartup: the crank law (CrankStartup) and the torque balance, exactly;
* InductionMotor, in each start mode (direct on line, voltage ramp, V/f ramp), both motor
  models (Kloss, dq) and both load extrapolations (hold, linear): the library's run-up
  (`simulate_runup`, scipy at rtol 1e-11) under the same load M_reaction(t), and the
  library's outputs of its states (CrankDrive.outputs, platform, kinetic energy);
* BallInShell, in each input mode (derivatives, positions only, hold) and both
  formulations: without the corrector, the library's own step (InputReconstruction +
  BallModel.advance + BallModel.outputs) to round-off; with it, the monolithic solution
  (`simulate` with the exact platform motion at tol 1e-12) to the coupling error measured
  for that mode.

The FMU paths come from one place, the ``fmu_path`` fixture.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.fmi.interface import BALL_HYBRID_OUTPUTS, BALL_MOTION_OUTPUTS
from ballmill.physics import Ball, BallModel, CrankStartup, InputReconstruction, simulate
from ballmill.fmi.slave import NEVER
from ballmill.physics.drives.induction import RPM, CrankDrive, InductionMotor, simulate_runup
from fmu_instance import Opened


@pytest.fixture
def fmu_path(built_fmus):
    """The FMU file of a model, by name (the one place to change for other FMU flavours)."""
    return lambda name: built_fmus[name]


@pytest.fixture
def opened():
    o = Opened()
    yield o
    o.close_all()


def outputs_of(inst) -> list[str]:
    return [v.name for v in inst.md.modelVariables if v.causality == "output"]


def read_all(inst, names) -> list[float]:
    return [float(inst.get(n)) for n in names]


def run(inst, H, n, inputs):
    """Initialise at t = 0 with inputs(0), then n doSteps of H with inputs(t_k) set before
    each; the outputs at every communication point, name -> array."""
    names = outputs_of(inst)
    inst.set(**inputs(0.0))
    inst.initialize()
    rows = [read_all(inst, names)]
    for k in range(n):
        t = k * H
        inst.set(**inputs(t))
        inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=H)
        rows.append(read_all(inst, names))
    arr = np.array(rows)
    return {name: arr[:, j] for j, name in enumerate(names)}


def assert_close(name, got, ref, rtol, atol=0.0):
    """|got - ref| <= rtol * max|ref| + atol over the whole array."""
    got, ref = np.asarray(got, dtype=float), np.asarray(ref, dtype=float)
    assert got.shape == ref.shape, name
    bound = rtol * float(np.max(np.abs(ref))) + atol
    err = float(np.max(np.abs(got - ref)))
    assert err <= bound, f"{name}: max |FMU - library| = {err:.3g} > {bound:.3g}"


# ---------------------------------------------------------------------------
# MotorStartup
def test_motorstartup_every_output(fmu_path, opened):
    l, n0, t0, m_pl, J = 0.4, 45.0, 1.5, 12.0, 0.3
    inst = opened.open(fmu_path("MotorStartup"), "drive", l=l, n0=n0, t0=t0, m_platform=m_pl, J_crank=J)
    H, n = 0.01, 250  # through t0 and beyond

    def load(t):
        return {"M_reaction": -0.7 + 0.4 * math.sin(3.0 * t)}
    out = run(inst, H, n, load)
    assert set(out) == {"psi", "psi_dot", "psi_ddot", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O",
                        "T_drive", "P_drive"}
    law = CrankStartup(l=l, n0=n0, t0=t0)
    t = H * np.arange(n + 1)
    ref = {k: [] for k in out}
    for k, tk in enumerate(t):
        psi, wd, wdd = law.angle(tk)
        x, y, vx, vy, ax, ay = law.state(tk)
        # T_drive after the doStep to t_k is computed with the input then current, M(t_(k-1))
        M = load(t[max(k - 1, 0)])["M_reaction"]
        T = (J + m_pl * l * l) * wdd - M
        for k, v in zip(("psi", "psi_dot", "psi_ddot", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O",
                         "T_drive", "P_drive"), (psi, wd, wdd, x, y, vx, vy, ax, ay, T, T * wd)):
            ref[k].append(v)
    for k in out:
        assert_close(k, out[k], ref[k], 1e-14, 1e-15)


# ---------------------------------------------------------------------------
# InductionMotor
MOTOR_CASES = {  # id: (start_mode, model, M_input)
    "dol-kloss-hold": (1, 1, 1),
    "voltage_ramp-kloss-linear": (2, 1, 2),
    "frequency_ramp-kloss-linear": (3, 1, 2),
    "frequency_ramp-dq-linear": (3, 2, 2),
    "dol-dq-hold": (1, 2, 1),
}
STARTS = {1: "dol", 2: "voltage_ramp", 3: "frequency_ramp"}
MODELS = {1: "kloss", 2: "dq"}


@pytest.mark.parametrize("case", list(MOTOR_CASES))
def test_inductionmotor_every_output(case, fmu_path, opened):
    start, model, m_input = MOTOR_CASES[case]
    ramp, H = 0.6, 2e-3
    n = 400 if model == 1 else 150  # 0.8 s (through the ramp's end), 0.3 s for dq
    params = dict(start_mode=start, model=model, M_input=m_input, ramp_time=ramp, u_start=0.35,
                  f_start=0.05, i=10.0, J_crank=0.2, m_platform=5.0, l=0.3)
    inst = opened.open(fmu_path("InductionMotor"), "motor", **params)
    if m_input == 1:
        def M(t):  # held over a step: a constant load is the only one held exactly
            return -1.5
    else:
        def M(t):  # extrapolated linearly from the last two points: exact for a linear load
            return -0.5 - 2.0 * t
    out = run(inst, H, n, lambda t: {"M_reaction": M(t)})

    drive = CrankDrive(motor=InductionMotor(start=STARTS[start], ramp_time=ramp, u_start=0.35,
                                            f_start=0.05),
                       i=10.0, J_crank=0.2, m_platform=5.0, l=0.3, model=MODELS[model])
    T_end = n * H

    def M_fmu(t):
        # what the FMU integrates: over the first step it has one sample only and holds it
        return M(0.0) if t <= H else M(t)
    res = simulate_runup(drive, T_end, load_torque=lambda t, psi, psid: M_fmu(t), rtol=1e-11, atol=1e-12,
                         n_out=n + 1)
    assert res.success
    t = res.t
    np.testing.assert_allclose(t, H * np.arange(n + 1), rtol=0, atol=1e-12)
    ref = {k: [] for k in out}
    for k, tk in enumerate(t):
        y = res.y[:, k]
        o = drive.outputs(y, tk, M_fmu(tk))
        x1, y1, vx, vy, ax, ay = drive.platform(y, tk, M_fmu(tk))
        T = o["T_motor"]
        values = dict(psi=o["psi"], psi_dot=o["psi_dot"], psi_ddot=o["psi_ddot"], x1O=x1, y1O=y1,
                      vx1O=vx, vy1O=vy, ax1O=ax, ay1O=ay, w_motor=o["w_motor"], n_motor=o["w_motor"] / RPM,
                      # the FMU reports 0 where the library says NaN: slip while the supply
                      # frequency is zero, current and electrical power of the Kloss model
                      slip=0.0 if math.isnan(o["slip"]) else o["slip"], T_motor=T,
                      I_motor=0.0 if model == 1 else o["I_motor"], P_el=0.0 if model == 1 else o["P_el"],
                      P_motor=T * o["w_motor"], W_motor=res["W_motor"][k], E_drive=drive.kinetic_energy(y))
        for name in ref:
            ref[name].append(values[name])
    assert set(out) == set(ref)
    # the FMU's DOP853 at tol 1e-9 (relative to each state's scale) against scipy at 1e-11:
    # measured agreement 5e-9 of each output's largest value or better (psi_ddot); 1e-6 leaves room
    for name in out:
        assert_close(f"{case}: {name}", out[name], ref[name], 1e-6, 1e-9)
    # and the run-up is under way: the motor turns, the ramps are in their middle at 0.3 s
    assert np.max(out["w_motor"]) > 10.0
    if start == 3:  # V/f: the supply frequency, hence the slip's denominator, changes
        k = int(round(0.3 / H))
        ws = (0.05 + 0.95 * 0.3 / ramp) * drive.motor.synchronous_speed
        assert math.isclose(out["slip"][k], (ws - out["w_motor"][k]) / ws, rel_tol=1e-6)


# ---------------------------------------------------------------------------
# BallInShell
BALL_OUTPUT_FIELDS = ("xP", "yP", "zP", "N", "Fx", "Fy", "Fz", "M_reaction", "MAx", "MAy", "MAz",
                      "xC", "yC", "zC", "wx", "wy", "wz", "Ft", "friction_ratio", "contact", "rolling",
                      "P_diss", "P_grind", "s_bed")
CRANK = CrankStartup(l=0.5, n0=60.0, t0=2.5)
START = dict(xC0=0.05, yC0=0.02, wx0=0.0, wy0=0.0, wz0=3.0)
FORMULATIONS = {1: "vector", 2: "paper"}
METHODS = {1: "DOP853", 2: "RK45", 3: "RK4"}
MODES = {1: "derivatives", 2: "positions", 3: "hold"}


def crank_inputs(mode):
    """The crank's platform motion as BallInShell inputs at t; with positions only, the
    derivative inputs carry a wrong constant that the FMU must not use."""
    def inputs(t):
        x, y, vx, vy, ax, ay = CRANK.state(t)
        if mode == 2:
            vx = vy = ax = ay = 123.0
        return dict(x1O=x, y1O=y, vx1O=vx, vy1O=vy, ax1O=ax, ay1O=ay)
    return inputs


def library_steps(ball, form, method, mode, tol, h_fixed, H, n):
    """The FMU's step without the corrector, by the library: push the inputs at t_k, advance
    along the reconstructed motion, evaluate the outputs at t_k + H with the reconstruction's
    platform motion there."""
    model = BallModel(ball, formulation=form, method=method, tol=tol, h_fixed=h_fixed)
    state = model.initial(START["xC0"], START["yC0"], (START["wx0"], START["wy0"], START["wz0"]))
    rec = InputReconstruction(mode)
    inputs = crank_inputs({"derivatives": 1, "positions": 2, "hold": 3}[mode])

    def sample(t_clock, t):
        u = inputs(t)
        return (t_clock, u["x1O"], u["y1O"], u["vx1O"], u["vy1O"], u["ax1O"], u["ay1O"])
    rec.push(*sample(0.0, 0.0))
    x, y, _, _, ax, ay = rec.state(0.0)
    outs = [model.outputs(state, ax, ay, x, y)]
    t_clock = 0.0  # the FMU's time: the end of its last step, (k - 1) H + H
    for k in range(n):
        t = k * H  # currentCommunicationPoint, where `run` evaluates the inputs
        # as the FMU's step (ballmill.fmi.slave.do_step + BallInShell.step): the
        # nodes are chosen for the coming step, the sample is recorded at the FMU's own time
        # (which may differ from k H in the last bit: the fit's Hermite position row turns
        # that into an acceleration difference ~ 6 v ulp(t) / H^2, which grows to ~1e-9 of N
        # over the run, too much for a round-off comparison), and the step ends at t + H
        rec.set_horizon(H)
        rec.push(*sample(t_clock, t))
        state = model.advance(state, t + H, rec.accel_function())
        t_clock = t + H
        x, y, _, _, ax, ay = rec.state(t_clock)
        outs.append(model.outputs(state, ax, ay, x, y))
    return {f: np.array([float(getattr(o, f)) for o in outs]) for f in outs[0]._fields}


def monolithic(ball, form, H, n):
    m = BallModel(ball, formulation=form, method="DOP853", tol=1e-12)
    tr = simulate(m, CRANK, n * H, H, state=m.initial(START["xC0"], START["yC0"],
                                                     (START["wx0"], START["wy0"], START["wz0"])),
                  kernel="python")
    assert tr.success
    return tr


def check_ball_outputs(out, ref, rtol, atol, window, what, H):
    new = {name for name, _, _ in BALL_MOTION_OUTPUTS}
    new |= set(BALL_HYBRID_OUTPUTS)
    assert set(out) == set(BALL_OUTPUT_FIELDS) | {"coupling_error", "valid", "t_invalid"} | new, \
        set(out) ^ (set(BALL_OUTPUT_FIELDS) | new)
    # contact_model = 1: the rolling model's mode, no slip, gap, impacts or losses, never a first slip
    for name, value in (("mode", 1), ("slip_speed", 0.0), ("gap", 0.0), ("n_impacts", 0), ("v_impact_max", 0.0),
                        ("E_friction", 0.0), ("E_impact", 0.0), ("t_first_slip", NEVER), ("t_first_flight", NEVER)):
        assert np.all(np.asarray(out[name]) == value), (what, name)
    check_mean_force(out, H, what)
    # motion = 1: the chamber's axes are the frame's, and the moment about O1 is
    # A x F + M_A: about the vertical through O1 the crank's torque plus MAz
    for a, b in (("xP_ch", "xP"), ("yP_ch", "yP"), ("zP_ch", "zP"), ("Fx_ch", "Fx"), ("Fy_ch", "Fy"),
                 ("Fz_ch", "Fz")):
        assert np.array_equal(out[a][window], out[b][window]), (what, a)
    assert np.array_equal(out["MO1z"][window], (out["M_reaction"] + out["MAz"])[window]), (what, "MO1z")
    # the latch: valid until the library's ball first loses contact or rolling, t_invalid unset
    held = np.logical_and.accumulate(np.asarray(ref["contact"], bool) & np.asarray(ref["rolling"], bool))
    assert np.array_equal(np.asarray(out["valid"], bool)[window], held[window]), (what, "valid")
    assert np.all(np.asarray(out["t_invalid"])[window][held[window]] == NEVER), (what, "t_invalid")
    for name in BALL_OUTPUT_FIELDS:
        got, want = out[name][window], np.asarray(ref[name], dtype=float)[window]
        if name in ("contact", "rolling"):
            assert np.array_equal(got, want), (what, name)
        else:
            assert_close(f"{what}: {name}", got, want, rtol, atol)


def check_mean_force(out, H, what, m=Ball().m, g=Ball().g):
    """Fx_mean..Fz_mean: the instantaneous force at the start, then the momentum balance
    m (g_vec - dv_C / h) of the published v_C (h = H up to the FMU's time arithmetic), and close
    to the step's trapezoidal mean of Fx..Fz (so v_C is right: within 2 % of the force's swing
    for this smooth rolling ball, an O(h^2) difference)."""
    for c, gc in (("x", 0.0), ("y", 0.0), ("z", -g)):
        F, Fm, v = (np.asarray(out[f"F{c}"]), np.asarray(out[f"F{c}_mean"]), np.asarray(out[f"v{c}C"]))
        assert Fm[0] == F[0], (what, c)
        assert_close(f"{what}: F{c}_mean", Fm[1:], m * (gc - (v[1:] - v[:-1]) / H), 1e-9)
        # from the 10th step: with positions alone the first fits (one, two samples) give the
        # platform's velocity only roughly, and v_C with it
        trap = 0.5 * (F[10:] + F[9:-1])
        swing = np.ptp(F)
        assert np.max(np.abs(Fm[10:] - trap)) < 0.02 * swing, (what, c, np.max(np.abs(Fm[10:] - trap)), swing)


NO_CORRECTOR_CASES = {  # id: (input_mode, formulation, integrator, step)
    "hold-vector-RK45": (3, 1, 2, 1e-3),
    "hold-paper-DOP853": (3, 2, 1, 1e-3),
    "derivatives-vector-RK4": (1, 1, 3, 2e-3),
    "positions-vector-RK45": (2, 1, 2, 1e-3),
    "positions-paper-RK45": (2, 2, 2, 1e-3),
}


@pytest.mark.parametrize("case", list(NO_CORRECTOR_CASES))
def test_ballinshell_every_output_against_the_librarys_step(case, fmu_path, opened):
    """Without the corrector (and in hold mode, which has none) the FMU's step is the
    library's step: the same numbers up to round-off."""
    mode, form, integ, H = NO_CORRECTOR_CASES[case]
    n = int(round(0.6 / H))
    inst = opened.open(fmu_path("BallInShell"), "ball", input_mode=mode, formulation=form, integrator=integ,
                       corrector=False, tolerance=1e-8, h_fixed=5e-4, **START)
    out = run(inst, H, n, crank_inputs(mode))
    ref = library_steps(Ball(), FORMULATIONS[form], METHODS[integ], MODES[mode], 1e-8, 5e-4, H, n)
    check_ball_outputs(out, ref, 1e-12, 1e-14, slice(None), case, H)
    assert np.all(out["coupling_error"] == 0.0)  # no corrector, no estimate
    assert np.ptp(out["zP"]) > 0.01  # the ball moved


CORRECTOR_CASES = {  # id: (input_mode, formulation, integrator, step, losses, rtol after 0.1 s)
    # measured (with the input reconstruction of docs/conformance.md, both flavours): 1.8e-8 (derivatives; 2.2e-8 with the
    # losses), 1.1e-8 (positions) of each output's largest value after 0.1 s
    "derivatives-vector-RK45": (1, 1, 2, 2e-3, False, 1e-6),
    "derivatives-paper-DOP853": (1, 2, 1, 2e-3, False, 1e-6),
    "derivatives-vector-RK45-losses": (1, 1, 2, 2e-3, True, 1e-6),
    "positions-vector-RK45": (2, 1, 2, 1e-3, False, 1e-6),
}


@pytest.mark.parametrize("case", list(CORRECTOR_CASES))
def test_ballinshell_every_output_against_the_monolithic_solution(case, fmu_path, opened):
    """With the corrector the FMU follows the monolithic solution to its coupling error. In
    the first 0.1 s the input window is still filling (the crank starts from rest with a
    jump in acceleration at t = 0), so the bound applies after it."""
    mode, form, integ, H, losses, rtol = CORRECTOR_CASES[case]
    n = int(round(1.0 / H))
    extra = dict(delta=2e-4, c_drag=0.8) if losses else {}
    inst = opened.open(fmu_path("BallInShell"), "ball", input_mode=mode, formulation=form, integrator=integ,
                       **START, **extra)
    out = run(inst, H, n, crank_inputs(mode))
    ball = Ball(rolling_resistance=2e-4, drag=0.8) if losses else Ball()
    tr = monolithic(ball, FORMULATIONS[form], H, n)
    late = tr.t >= 0.1 - 1e-12
    check_ball_outputs(out, tr.out, rtol, 1e-12, late, case, H)
    if losses:
        assert np.min(out["P_diss"][late]) > 0.0
    else:
        assert np.all(out["P_diss"] == 0.0)
    # coupling_error estimates the error of the published contact point: over the run its
    # largest value is that of the measured error to within a factor 2 (docs/usage.md: 10 %)
    err = np.sqrt(sum((out[c] - tr.out[c]) ** 2 for c in ("xP", "yP", "zP")))
    est = out["coupling_error"]
    assert np.all(est >= 0.0) and est[0] == 0.0
    assert 0.5 < np.max(est) / np.max(err) < 2.0, (np.max(est), np.max(err))
