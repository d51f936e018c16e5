"""The hybrid ball (rolling, sliding, flight, impacts) in the BallInShell FMU, contact_model = 2
(docs/design.md sections 14 and 15): the chamber along the input reconstruction, the library's
step from a state, and the FMU's outputs against the library's run, its balances, its refusals
and its states."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import CrankStartup, InputReconstruction
from ballmill.physics.drives.crank import Harmonic
from ballmill.physics.turning.reconstruction import ChamberReconstruction, ReconstructedChamber

H = 2e-3
FAST = CrankStartup(t0=0.5)  # the fast start: n0 = 60 1/min in 0.5 s, slips at once
SHAKE = Harmonic(x_amp=0.05, x_omega=25.0)  # with mu = 0.2: slip, flight, impacts (over 1 s)
HARD = Harmonic(x_amp=0.1, x_omega=30.0)  # with mu = 0.2: slip, flight, 5 impacts, rest (0.25 s)

# -- the chamber along the reconstruction (platform.ReconstructedPlatform) ------------------------
_GL = {2: ((-1 / math.sqrt(3), 1.0), (1 / math.sqrt(3), 1.0)),
       3: ((-math.sqrt(0.6), 5 / 9), (0.0, 8 / 9), (math.sqrt(0.6), 5 / 9))}


def _gauss(f, a, b, n):
    """Gauss-Legendre with n points on [a, b]: exact for polynomials of degree 2n - 1."""
    m, r = 0.5 * (a + b), 0.5 * (b - a)
    return r * sum(w * f(m + r * x) for x, w in _GL[n])


@pytest.mark.parametrize("mode", ["derivatives", "positions", "hold", "accelerations"])
def test_the_reconstructed_platform_is_its_acceleration_integrated_exactly(mode):
    """v_A(t) - v_A(t0) is the integral of the fitted acceleration (a cubic: 2-point Gauss is
    exact) and A(t) - A(t0) that of v_A (a quartic: 3 points), to round-off; at t0 the fit's own
    position and velocity; over the step within round-off of the reconstruction's own motion."""
    rec = InputReconstruction(mode)
    for k in range(8):
        rec.set_horizon(H)
        rec.push(k * H, *FAST.state(k * H))
    mot = rec.motion()
    t0 = 7 * H
    assert mot.state(t0)[:4] == rec.state(t0)[:4]
    for t in (t0 + 0.3 * H, t0 + H):
        s = mot.state(t)
        for i, (xi, vi, ai) in enumerate(((0, 2, 4), (1, 3, 5))):
            dv = _gauss(lambda u: mot.state(u)[ai], t0, t, 2)
            dx = _gauss(lambda u: mot.state(u)[vi], t0, t, 3)
            v0, x0 = mot.state(t0)[vi], mot.state(t0)[xi]
            assert abs((s[vi] - v0) - dv) <= 1e-15 * max(1.0, abs(v0)), (mode, t, i)
            assert abs((s[xi] - x0) - dx) <= 1e-15 * max(1.0, abs(x0)), (mode, t, i)
            assert s[ai] == rec.accel(t)[i]  # the rolling model's acceleration, the same floats
        ref = rec.state(t)
        assert np.allclose(s, ref, rtol=1e-12, atol=1e-15), (mode, t)
    rec.push(8 * H, *FAST.state(8 * H))  # frozen: a later sample does not move it
    assert mot.state(t0 + H) == s


def test_the_reconstructed_turning_chamber_is_the_fit_itself():
    from ballmill.physics.turning.motions import Fig1Machine

    fig1 = Fig1Machine()
    rec = ChamberReconstruction("derivatives", R=0.25)
    from ballmill.physics.turning.reconstruction import inputs_of
    for k in range(4):
        rec.set_horizon(H)
        rec.push(k * H, *inputs_of(fig1.state(k * H), 0.25))
    mot = rec.motion()
    assert isinstance(mot, ReconstructedChamber)
    for t in (3 * H, 3.5 * H, 4 * H):
        assert mot.state(t) == rec.state(t)
        assert mot.accel(t) == rec.accel_function()(t)


# -- the library's step from a state (HybridBall.resume) --------------------------------------
def test_resuming_a_run_step_by_step_is_the_run_bit_for_bit():
    """A run resumed at every grid point from (mode, y, h, bookkeeping) alone, the bookkeeping
    scrambled in between (so nothing survives in the system but what the state carries), is
    simulate_hybrid's run, every row and event time the same floats: slip, flight and an
    impact in a shaken chamber."""
    from ballmill.physics import Ball
    from ballmill.physics.hybrid import Contact, HybridBall, simulate_hybrid

    ball, contact, shake = Ball(mu=0.2), Contact(e_n=0.6, mu_k=0.15), SHAKE
    ref = simulate_hybrid(ball, shake, 0.5, 0.01, contact, kernel="python")
    kinds = {e.kind for e in ref.events}
    assert ref.success and {"slip", "leave", "impact"} <= kinds, kinds
    system = HybridBall(ball, shake, contact)
    t, mode, y = system.begin(0.0)
    h, book = None, system.bookkeeping()
    rows, events = [system.sample(mode, t, y)], []
    for k in range(1, len(ref.t)):
        system.set_bookkeeping((1.0, 7.0, 3.0, 0.5, 0.5, 2.0, 2.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.3, 0.01))  # scrambled
        run = system.resume(mode, t, y, h, book, float(ref.t[k]))
        assert run.success, run.message
        mode, t, y, h, book = run.mode, run.t_last, run.y, run.h, system.bookkeeping()
        rows.append(run.rows[-1])
        events += run.events
    assert [e.t for e in events] == [e.t for e in ref.events]
    assert [e.kind for e in events] == [e.kind for e in ref.events]
    got = np.array(rows, dtype=float)
    want = np.column_stack([ref.out[c] for c in HybridBall.COLUMNS])
    assert np.array_equal(got, want, equal_nan=True)


# -- the FMU, contact_model = 2 ---------------------------------------------------------------
# DOP853 at 1e-9: with RK45 at the FMU's default 1e-8 a slide that starts from zero slip (the
# fast start at 0.2687 s) takes tens of thousands of steps (the slip direction's seed threshold,
# 1e-3 slip_eps = 1e-9 m/s, is below RK45's error in the slip there): seconds for one 2 ms step
HYBRID = dict(contact_model=2, integrator=1, tolerance=1e-9)
SHAKEN = dict(mu=0.2, mu_k=0.15, e_n=0.6)  # Harmonic(0.1 m, 30 rad/s): slip, flight, 5 impacts, rest


def run_scene(fmus_of, flavour, motion, t_end, h=H, keep=False, on_step=None, **parameters):
    """BallInShell of `flavour` ("pythonfmu", "native") driven by a platform motion (inputs
    x1O..ay1O from motion.state at each communication point), steps of h to t_end: every output
    at every communication point (name -> array, and "time": the FMU's times) and, with keep,
    the open instance (the caller frees it). on_step(fmu, k) runs after step k."""
    from conformance.harness import driver

    fmu = driver(2)(fmus_of(flavour)["BallInShell"], "ball", **parameters)

    def feed(t):
        x, y, vx, vy, ax, ay = motion.state(t)
        assert fmu.set(x1O=x, y1O=y, vx1O=vx, vy1O=vy, ax1O=ax, ay1O=ay) == 0

    try:
        feed(0.0)
        assert fmu.init() == 0, fmu.messages()
        rows, times = [fmu.outputs()], [fmu.time]
        for k in range(int(round(t_end / h))):
            feed(fmu.time)
            assert fmu.step(h) == 0, fmu.messages()
            rows.append(fmu.outputs())
            times.append(fmu.time)
            if on_step:
                on_step(fmu, k)
    except BaseException:
        fmu.free()
        raise
    out = {name: np.array([r[name] for r in rows], dtype=float) for name in rows[0]}
    out["time"] = np.array(times)
    if keep:
        return out, fmu
    fmu.free()
    return out


def _balances(out, ball, motion):
    """(momentum residuals x, y, z [N s], energy residual [J], the chamber's work's range [J])
    from the outputs alone: sum F_mean h + m dv_C (- m g t in z), and E + E_friction + E_impact
    - W with E = m v_C^2 / 2 + I omega^2 / 2 + m g zC and W = -sum F_mean . v_A h the chamber's
    work on the ball (v_A the platform's velocity mean over the step: the product rule's
    error, O(h^2) on smooth parts and |J| |a_A| h / 2 at an impulse, is what the balance
    cannot close)."""
    h, m, t = np.diff(out["time"]), ball.m, out["time"]
    mom = [np.sum(out[f"F{c}_mean"][1:] * h) + m * (out[f"v{c}C"][-1] - out[f"v{c}C"][0]) for c in "xy"]
    mom.append(np.sum(out["Fz_mean"][1:] * h) + m * (out["vzC"][-1] - out["vzC"][0]) + m * ball.g * (t[-1] - t[0]))
    E = (0.5 * m * (out["vxC"] ** 2 + out["vyC"] ** 2 + out["vzC"] ** 2)
         + 0.5 * ball.I * (out["wx"] ** 2 + out["wy"] ** 2 + out["wz"] ** 2) + m * ball.g * out["zC"])
    vA = np.array([motion.state(s)[2:4] for s in t])
    vbar = 0.5 * (vA[1:] + vA[:-1])
    W = np.concatenate([[0.0], np.cumsum(-(out["Fx_mean"][1:] * vbar[:, 0] + out["Fy_mean"][1:] * vbar[:, 1]) * h)])
    res = E + out["E_friction"] + out["E_impact"] - W
    return mom, float(np.max(np.abs(res - res[0]))), float(np.ptp(W))


def _library(ball, motion, t_end, contact):
    from ballmill.physics.hybrid import simulate_hybrid

    ref = simulate_hybrid(ball, motion, t_end, H, contact, method="DOP853", tol=1e-9, kernel="python")
    assert ref.success
    return ref


def _contact_point_error(out, ref, R):
    return float(np.max(np.sqrt((out["xP"] - R * ref["nx"]) ** 2 + (out["yP"] - R * ref["ny"]) ** 2
                                + (out["zP"] - (R + R * ref["nz"])) ** 2)))


def test_the_fast_start_through_the_fmu_is_the_librarys_hybrid_ball(fmus_of):
    """CrankStartup(t0 = 0.5 s) with 2 ms steps: slides at once, rolls from 0.073 s, slides again
    from 0.269 s. Against simulate_hybrid on the crank itself: the same mode at every point,
    the contact point within 1e-6 m (measured 3.7e-8 m: the coupling error of the
    reconstructed motion over 2 ms with derivative inputs and the corrector), E_friction
    within 1e-5 relative (measured 2e-7), the first slip at 0; valid all along. Momentum:
    sum F_mean h = -m dv_C (+ m g t in z) to round-off; energy: closes to 1e-3 of the
    chamber's work (measured 2.6e-5: the work's product rule, see _balances)."""
    from ballmill.physics import Ball
    from ballmill.physics.hybrid import Contact

    ball = Ball()
    out = run_scene(fmus_of, "pythonfmu", FAST, 0.4, **HYBRID)
    ref = _library(ball, FAST, 0.4, Contact(e_n=0.5))
    assert np.array_equal(out["mode"], ref["mode"])
    assert set(out["mode"]) == {1.0, 2.0}
    assert _contact_point_error(out, ref, ball.R) < 1e-6
    assert out["E_friction"][-1] == pytest.approx(ref["E_friction"][-1], rel=1e-5) and out["E_friction"][-1] > 0.05
    assert out["t_first_slip"][-1] == 0.0 and out["t_first_flight"][-1] == 1e300 and out["n_impacts"][-1] == 0
    assert np.all(out["valid"] == 1.0) and np.all(out["t_invalid"] == 1e300)
    assert np.all(out["slip_speed"][out["mode"] == 1] == 0.0) and np.max(out["slip_speed"]) > 0.03
    mom, res, work = _balances(out, ball, FAST)
    assert max(abs(v) for v in mom) < 1e-12, mom
    assert res < 1e-3 * work, (res, work)


# R = 1e3 m (the FMU's largest chamber), mu = mu_k = 0.3, shaken along x at 2 Hz: the amplitude at
# which the rolling model's peak friction demand is mu N (1 + 5e-5), found by root finding on the
# rolling model (simulate at tol 1e-12; the peak located by a bounded minimisation)
GRAZE = Harmonic(x_amp=0.06523769338945387, x_omega=4 * math.pi)


def test_a_grazing_slide_ends_inside_its_step_alike_in_both_flavours(fmus_of):
    """GRAZE: a slide from zero slip at 0.12419 s whose slip never reaches slip_eps (5.5e-7 m/s at
    its end), ended by the grip guard where the rolling demand falls back to mu N 1.6 ms later,
    inside one 2 ms step (docs/design.md section 14, the grazing slide). Both flavours: every
    output bit for bit, rolling at every communication point, valid; the first slip within
    1e-8 s of simulate_hybrid's on the motion itself (measured 1.3e-9 s: the reconstruction)
    and E_friction within 1e-4 of its (measured 9e-7; the library's ends the slide too, at the
    rolling model's root: tests/test_hybrid.py). Before, the slide never ended: the native
    flavour was still sliding at 0.13 s, its slip chattering about zero."""
    from ballmill.physics import Ball
    from ballmill.physics.hybrid import Contact, simulate_hybrid

    ball, t_end = Ball(R=1e3, mu=0.3), 0.13
    runs = {f: run_scene(fmus_of, f, GRAZE, t_end, **HYBRID, R=1e3) for f in ("native", "pythonfmu")}
    differ = [n for n in runs["native"] if not np.array_equal(runs["native"][n], runs["pythonfmu"][n], equal_nan=True)]
    assert not differ, differ
    out = runs["native"]
    ref = simulate_hybrid(ball, GRAZE, t_end, H, Contact())
    slip, stick = ref.events
    assert stick.kind == "stick" and stick.details["slip_removed"] < 1e-6 and stick.t - slip.t < H
    assert np.all(out["mode"] == 1.0) and np.all(out["valid"] == 1.0) and out["n_impacts"][-1] == 0
    assert out["t_first_slip"][-1] == pytest.approx(slip.t, abs=1e-8)
    assert out["E_friction"][-1] == pytest.approx(ref["E_friction"][-1], rel=1e-4) and out["E_friction"][-1] > 0.0


def test_creep_eps_0_gives_the_librarys_unreduced_model_in_both_flavours(fmus_of):
    """creep_eps = 0, the unreduced Coulomb model, on the fast start to 0.28 s (a slide from 0, a
    stick at 0.073 s, a slide from zero slip at 0.2687 s, stiff without the creeping slide).
    Both flavours give every output bit for bit; against simulate_hybrid's unreduced run on the
    crank itself the same modes, the contact point within 1e-6 m (measured 3.7e-8 m) and
    E_friction within 1e-6 (measured 3.0e-7: the unreduced slide's stiff start makes its
    integration error follow the 3.7e-8 m the reconstruction moves the ball); the default
    creeping slide's run differs from the unreduced one by 4.0e-6 there, so the bound fails
    if creep_eps does not reach the model."""
    from ballmill.physics import Ball
    from ballmill.physics.hybrid import Contact, simulate_hybrid

    ball, t_end = Ball(), 0.28
    runs = {f: run_scene(fmus_of, f, FAST, t_end, **HYBRID, creep_eps=0.0) for f in ("native", "pythonfmu")}
    differ = [n for n in runs["native"] if not np.array_equal(runs["native"][n], runs["pythonfmu"][n], equal_nan=True)]
    assert not differ, differ
    out = runs["native"]
    ref = {ce: simulate_hybrid(ball, FAST, t_end, H, Contact(e_n=0.5, creep_eps=ce), method="DOP853", tol=1e-9)
           for ce in (0.0, 1e-3)}
    assert [e.kind for e in ref[0.0].events] == ["stick", "slip"]
    assert np.array_equal(out["mode"], ref[0.0]["mode"]) and out["mode"][-1] == 2
    assert _contact_point_error(out, ref[0.0], ball.R) < 1e-6
    assert out["E_friction"][-1] == pytest.approx(ref[0.0]["E_friction"][-1], rel=1e-6)
    assert abs(ref[1e-3]["E_friction"][-1] / ref[0.0]["E_friction"][-1] - 1) > 3e-6


def test_a_shaken_chamber_slides_flies_and_strikes_through_the_fmu_as_in_the_library(fmus_of):
    """Harmonic(0.1 m, 30 rad/s), mu = 0.2, mu_k = 0.15, e_n = 0.6: slides from 2.5 ms, leaves
    the wall at 0.129 s, strikes it 5 times, comes to rest. Against simulate_hybrid: the same
    mode at every point and the same impacts, the contact point within 1e-4 m (measured
    2.9e-6 m: in flight the ball's path carries the reconstruction's error of where the
    chamber was when it left), E_impact and E_friction within 1e-6 relative, the first slip
    and flight within 1e-8 s (measured 1e-12 and 1.6e-10 s). Momentum to round-off with the
    impulses in F_mean; energy within 5 % of the chamber's work (measured 0.12 %: at each
    impulse the product rule errs by up to |J| |a_A| h / 2)."""
    from ballmill.physics import Ball
    from ballmill.physics.hybrid import Contact

    ball = Ball(mu=0.2)
    out = run_scene(fmus_of, "pythonfmu", HARD, 0.26, **HYBRID, **SHAKEN)
    ref = _library(ball, HARD, 0.26, Contact(e_n=0.6, mu_k=0.15))
    assert np.array_equal(out["mode"], ref["mode"]) and set(out["mode"]) == {0.0, 1.0, 2.0}
    assert np.array_equal(out["n_impacts"], ref["n_impacts"]) and out["n_impacts"][-1] == 5
    assert _contact_point_error(out, ref, ball.R) < 1e-4
    for name in ("E_impact", "E_friction", "v_impact_max"):
        assert out[name][-1] == pytest.approx(ref[name][-1], rel=1e-6), name
    assert out["t_first_slip"][-1] == pytest.approx(ref.t_first_slip, abs=1e-8)
    assert out["t_first_flight"][-1] == pytest.approx(ref.t_first_flight, abs=1e-8)
    flight = out["mode"] == 0
    assert np.all(out["N"][flight] == 0.0) and np.all(out["Fx"][flight] == 0.0) and np.all(out["gap"][flight] >= 0.0)
    assert np.max(out["gap"]) == pytest.approx(np.max(ref["gap"]), rel=1e-4) and np.max(out["gap"]) > 0.01
    assert np.all(out["contact"][flight] == 0.0) and np.all(out["rolling"][out["mode"] != 1] == 0.0)
    assert np.all(out["friction_ratio"][flight] == 1e300)
    sliding = out["mode"] == 2
    assert np.allclose(out["Ft"][sliding], 0.15 * out["N"][sliding], rtol=1e-12)
    assert np.all(out["valid"] == 1.0)
    mom, res, work = _balances(out, ball, HARD)
    assert max(abs(v) for v in mom) < 1e-12, mom
    assert res < 0.05 * work, (res, work)


def _rolling_means(motion, t_end, k=8):
    """The rolling model's M_reaction averaged over each step of H (simulate on the motion itself
    at H / k, tol 1e-11; composite Simpson per step: its error, (H / k)^4 max|M^(4)| / 180, is
    below 1e-13 N.m here)."""
    from ballmill.physics import Ball, BallModel, simulate

    M = simulate(BallModel(Ball(), tol=1e-11), motion, t_end, H / k).out["M_reaction"]
    seg = M[:-1].reshape(-1, k)
    ends = np.append(seg[1:, 0], M[-1])
    return (seg[:, 0] + ends + 4.0 * seg[:, 1::2].sum(axis=1) + 2.0 * seg[:, 2::2].sum(axis=1)) / (3.0 * k)


def test_a_scene_that_keeps_rolling_gives_contact_model_1s_numbers_bit_for_bit(fmus_of):
    """The default start (t0 = 2.5 s) rolls: with contact_model = 2 (the FMU's default integrator
    and corrector) every output is contact_model = 1's, bit for bit, but M_reaction_mean: with
    contact_model = 1 M_reaction itself (the rolling model carries no torque quadrature), with
    contact_model = 2 the rolling model's mean over each step, within 1e-8 N.m of a Simpson
    quadrature of the library's rolling run on the crank itself (measured 6e-11 N.m: the FMU sees
    the reconstructed motion) after the first step (which carries the start-up reconstruction's
    error, 7e-5 N.m), where the torque changes by up to 4.6e-3 N.m over a step and the
    instantaneous value at the step's end is off by more than 1e-4 N.m (measured 2.3e-3)."""
    one = run_scene(fmus_of, "pythonfmu", CrankStartup(), 0.2)
    two = run_scene(fmus_of, "pythonfmu", CrankStartup(), 0.2, contact_model=2)
    assert np.all(two["mode"] == 1) and np.ptp(one["yP"]) > 1e-4
    for name in one:
        if name != "M_reaction_mean":
            assert np.array_equal(one[name], two[name]), name
    assert np.array_equal(one["M_reaction_mean"], one["M_reaction"])
    assert two["M_reaction_mean"][0] == two["M_reaction"][0]  # at the start: the instantaneous value
    mean = _rolling_means(CrankStartup(), 0.2)
    err = np.abs(two["M_reaction_mean"][1:] - mean)
    assert np.max(err[1:]) < 1e-8, np.max(err[1:])
    assert np.max(np.abs(two["M_reaction"][2:] - mean[1:])) > 1e-4  # the instantaneous value is not it


def test_a_drive_receives_the_torques_integral_through_impacts(fmus_of):
    """A circling chamber (Circle(0.05 m, 20 rad/s), mu = 0.1, mu_k = 0.08, e_n = 0.6, 2 ms steps,
    native): the ball leaves the wall and strikes it 6 times. A drive that sums M_reaction_mean h
    receives the library's torque impulse (simulate_hybrid's M_impulse on the circle itself, an
    angular-momentum balance checked against a Stieltjes sum in tests/test_hybrid.py) within 2e-6
    N.m.s at every communication point (measured 4.3e-7, of a range of 0.029: the FMU sees the
    reconstructed motion); the trapezoid of the instantaneous M_reaction, which misses the impulses,
    errs by more than 1e-3 N.m.s (measured 7.3e-3)."""
    from ballmill.physics import Ball, Circle
    from ballmill.physics.hybrid import Contact, simulate_hybrid

    motion = Circle(l=0.05, w=20.0)
    out = run_scene(fmus_of, "native", motion, 0.5, mu=0.1, mu_k=0.08, e_n=0.6, **HYBRID)
    ref = simulate_hybrid(Ball(mu=0.1), motion, 0.5, H, Contact(e_n=0.6, mu_k=0.08))
    assert np.array_equal(out["mode"], ref["mode"]) and out["n_impacts"][-1] == 6
    received = np.concatenate([[0.0], np.cumsum(out["M_reaction_mean"][1:] * H)])
    assert np.max(np.abs(received - ref["M_impulse"])) < 2e-6
    assert np.ptp(ref["M_impulse"]) > 0.02
    held = np.concatenate([[0.0], np.cumsum(0.5 * (out["M_reaction"][1:] + out["M_reaction"][:-1]) * H)])
    assert np.max(np.abs(held - ref["M_impulse"])) > 1e-3


def test_fmu_states_in_sliding_and_in_flight_round_trip(fmus_of):
    """In the shaken chamber, a state got while sliding (t = 0.05 s) and one in flight after
    the first impact (t = 0.2 s: its count and loss in the bookkeeping): stepping on from a
    state set back gives the same outputs as the first time, and a state serialised,
    deserialised and serialised again gives the same bytes."""
    from ballmill.fmi.slave import state_from_bytes, state_to_bytes

    saved = {}

    def on_step(fmu, k):
        if k in (24, 99):  # ends at 0.05 s (sliding) and 0.2 s (flight)
            saved[k] = (fmu.time, fmu.get_state(), fmu.get("mode"))

    out, fmu = run_scene(fmus_of, "pythonfmu", HARD, 0.21, keep=True, on_step=on_step, **HYBRID, **SHAKEN)
    try:
        assert [saved[k][2] for k in (24, 99)] == [2, 0] and out["n_impacts"][100] == 1
        for k, (t, state, _) in saved.items():
            assert fmu.set_state(state) == 0
            fmu.time = t
            for j in range(3):
                x, y, vx, vy, ax, ay = HARD.state(fmu.time)
                fmu.set(x1O=x, y1O=y, vx1O=vx, vy1O=vy, ax1O=ax, ay1O=ay)
                assert fmu.step(H) == 0, fmu.messages()
                again = fmu.outputs()
                assert all(again[n] == out[n][k + 2 + j] for n in again), (k, j)
            blob = fmu.serialize(state)
            st, restored = fmu.deserialize(blob)
            assert st == 0 and fmu.serialize(restored) == blob
        # the states' format is the bumped one (they carry the hybrid's mode and bookkeeping): the
        # previous format is refused by name (pythonfmu: fmi2Fatal, the last call here)
        old = state_from_bytes(blob)
        old["__format__"] = 5
        old_blob = state_to_bytes(old).replace(b"format 6\n", b"format 5\n", 1)
        n = len(fmu.log)
        st, _ = fmu.deserialize(old_blob)
        assert st != 0 and "format version 5, expected 6" in fmu.messages(n)
    finally:
        fmu.free()


def test_a_turning_chamber_through_the_fmu_is_the_librarys_hybrid_ball(fmus_of):
    """motion = 2: a chamber spun at 12 rad/s about a horizontal axis (mu = 0.05): the ball slips,
    rolls, slides again and leaves the wall at 0.237 s. Against simulate_hybrid on the Spin itself
    (the FMU sees it through the turning reconstruction): the same mode at every point, omega and
    v_C within 1e-9 (measured 4e-12 rad/s, 4e-13 m/s), E_friction within 1e-9 relative (2e-15)."""
    from ballmill.physics import Ball
    from ballmill.physics.hybrid import Contact, simulate_hybrid
    from ballmill.physics.turning.motions import Spin
    from ballmill.physics.turning.reconstruction import NAMES, inputs_of

    spin, ball = Spin(Omega=(12.0, 0, 0), A=(0, 0, 0.25)), Ball(mu=0.05)

    class Inputs:  # the FMU's 24 motion inputs from the spin, as a platform motion's state gives 6
        @staticmethod
        def state(t):
            return inputs_of(spin.state(t), ball.R)

    from conformance.harness import driver

    fmu = driver(2)(fmus_of("pythonfmu")["BallInShell"], "ball", motion=2, mu=0.05, e_n=0.5, **HYBRID)
    try:
        rows = []
        for k in range(131):
            assert fmu.set(**dict(zip(NAMES, Inputs.state(fmu.time)))) == 0
            assert (fmu.init() if k == 0 else fmu.step(H)) == 0, fmu.messages()
            rows.append(fmu.outputs())
    finally:
        fmu.free()
    out = {name: np.array([r[name] for r in rows], dtype=float) for name in rows[0]}
    ref = simulate_hybrid(ball, spin, 0.26, H, Contact(e_n=0.5), method="DOP853", tol=1e-9, kernel="python")
    assert np.array_equal(out["mode"], ref["mode"]) and set(out["mode"]) == {0.0, 1.0, 2.0}
    for a, b in (("wx", "wx"), ("wy", "wy"), ("wz", "wz"), ("vxC", "vCx"), ("vyC", "vCy"), ("vzC", "vCz")):
        assert np.max(np.abs(out[a] - ref[b])) < 1e-9, a
    assert out["E_friction"][-1] == pytest.approx(ref["E_friction"][-1], rel=1e-9) and out["E_friction"][-1] > 0.01
    assert np.all(out["valid"] == 1.0)


def test_a_sliding_balls_force_follows_the_inputs_set_between_steps(fmus_of):
    """Direct feedthrough off rolling: sliding (the fast start at 0.05 s), the platform
    acceleration set 1 m/s2 higher in y without a step changes N by -m n_y (section 14's N,
    n_y = yC / (R - r) from the outputs) and the friction with it (Ft = mu_k N)."""
    from ballmill.physics import Ball

    ball = Ball()
    out, fmu = run_scene(fmus_of, "pythonfmu", FAST, 0.05, keep=True, **HYBRID)
    try:
        assert fmu.get("mode") == 2
        x, y, vx, vy, ax, ay = FAST.state(fmu.time)
        N0 = fmu.get("N")
        ny = fmu.get("yC") / ball.d
        assert fmu.set(x1O=x, y1O=y, vx1O=vx, vy1O=vy, ax1O=ax, ay1O=ay + 1.0) == 0
        N1 = fmu.get("N")
        assert N1 - N0 == pytest.approx(-ball.m * ny, rel=1e-6) and abs(ny) > 0.01
        assert fmu.get("Ft") == pytest.approx(ball.mu * N1, rel=1e-12)  # mu_k = -1: mu
    finally:
        fmu.free()


# -- a Zeno sequence: the ball held on the wall ---------------------------------------------------------
def _dropped_chamber(t, a0=1.5 * 9.81, T=0.04):
    """(z1O, vz1O, az1O) of a chamber (motion = 2) pulled down by az = -a0 sin^2(pi t / T) over T,
    then moving on at constant speed: a0 > g lifts the ball off the wall for a bounce sequence."""
    w = 2.0 * math.pi / T
    if t < T:
        return (-a0 / 2 * (t * t / 2 + (math.cos(w * t) - 1) / w ** 2), -a0 / 2 * (t - math.sin(w * t) / w),
                -a0 / 2 * (1 - math.cos(w * t)))
    return (-a0 / 2 * T * T / 2 - a0 / 2 * T * (t - T), -a0 / 2 * T, 0.0)


@pytest.mark.parametrize("flavour", ["native", "pythonfmu"])
def test_a_chamber_pulled_down_faster_than_g_leaves_the_ball_in_flight(fmus_of, flavour):
    """The chamber (motion = 2) pulled down at up to 3 g, the ball started 1e-7 m off the bottom:
    the wall stops pressing where az1O = -g, 1 - cos(2 pi t/T) = 2/3, t = T acos(1/3)/(2 pi) =
    7.8365 ms (within 1e-7 s: the chamber is the inputs' reconstruction). There rolling's slip
    guard reaches 0 with N; the ball must fly (mode 0, N = 0, the gap opening), not slide on with
    N < 0 and valid true."""
    from conformance.harness import driver

    fmu = driver(2)(fmus_of(flavour)["BallInShell"], "ball", contact_model=2, motion=2, xC0=1e-7, e_n=0.5,
                    integrator=1, tolerance=1e-9)

    def feed(t):
        z, vz, az = _dropped_chamber(t, a0=3.0 * 9.81)
        assert fmu.set(z1O=z, vz1O=vz, az1O=az) == 0

    try:
        feed(0.0)
        assert fmu.init() == 0, fmu.messages()
        rows = []
        while fmu.time < 0.03 - 1e-12:
            feed(fmu.time)
            assert fmu.step(0.002) == 0, fmu.messages()
            rows.append(fmu.outputs())
    finally:
        fmu.free()
    t_off = 0.04 * math.acos(1.0 / 3.0) / (2.0 * math.pi)
    last = rows[-1]
    assert last["t_first_flight"] == pytest.approx(t_off, abs=1e-7) and last["t_first_slip"] == 1e300
    assert min(r["N"] for r in rows) >= 0.0 and last["gap"] > 1e-3 and all(r["valid"] for r in rows)
    assert [r["mode"] for r in rows[4:]] == [0] * len(rows[4:])  # from 8 ms on


def _zeno_hold(fmus_of, flavour, step=0.04, n=8, saved_at=6):
    """The bounce scene of `test_a_zeno_sequence_holds_the_ball_...` stepped n times: (the outputs
    at the start and after each step, each step's status and its log [(status, message)], the
    outputs of the last two steps again from the FMU state got after step saved_at)."""
    from conformance.harness import driver

    fmu = driver(2)(fmus_of(flavour)["BallInShell"], "ball", contact_model=2, motion=2, xC0=0.02, e_n=0.94,
                    v_rest=1e-6, integrator=1, tolerance=1e-9)

    def feed(t):
        z, vz, az = _dropped_chamber(t)
        assert fmu.set(z1O=z, vz1O=vz, az1O=az) == 0

    try:
        feed(0.0)
        assert fmu.init() == 0, fmu.messages()
        rows, statuses, logs, saved = [fmu.outputs()], [], [], None
        for k in range(1, n + 1):
            feed(fmu.time)
            before = len(fmu.log)
            statuses.append(fmu.step(step))
            logs.append(fmu.log[before:])
            rows.append(fmu.outputs())
            if k == saved_at:
                saved = (fmu.time, fmu.get_state())
        t, state = saved
        assert fmu.set_state(state) == 0
        fmu.time, again = t, []
        while fmu.time < n * step - 1e-12:
            feed(fmu.time)
            assert fmu.step(step) == 0, fmu.messages()
            again.append(fmu.outputs())
        return rows, statuses, logs, again
    finally:
        fmu.free()


def test_a_zeno_sequence_holds_the_ball_on_the_wall_and_latches_valid_in_both_flavours(fmus_of):
    """The chamber (motion = 2) pulled down at up to 1.5 g for 40 ms lifts the ball (started at
    xC0 = 0.02 m) off the wall; it falls back and bounces with e_n = 0.94, v_rest = 1e-6 m/s. The
    last 100 hops of such a sequence last 2 v (1 - e_n^100) / (g (1 - e_n)), under the driver's
    10 ms once the rebound speed v is below 2.9e-3 m/s, while rest is further than 100 hops away
    (e_n^100 v = 6e-6 m/s > v_rest, a hop of 1.8e-12 m the gap still resolves): the Zeno guard
    fires inside the step from 0.16 s of 40 ms steps (its 100th event within 9.68 ms at
    0.179059087 s). The step completes: valid latches false with t_invalid the stop's time, one
    warning naming the Zeno sequence, its count and window; the ball is held on the wall from
    there (gap 0, mode 1, N the rolling ball's normal force m (-g n_z + |v_C - v_A|^2 / d) in the
    chamber that now moves at constant speed), the steps after it fmi2OK without a message, the
    counts and losses frozen; E + E_friction + E_impact in the chamber's frame (it moves at
    constant speed from 40 ms on: no work) constant through the bounces, the hold and the rolling
    after it, from 0.12 s (the first step whose fit is the constant speed) to 1e-9 of the energy
    the losses took (measured 4e-15 J of 5e-4 J); the pythonfmu flavour's outputs and messages the
    native one's bit for bit; a state got after the hold steps on bit for bit."""
    import re

    from ballmill.physics import Ball

    runs = {f: _zeno_hold(fmus_of, f) for f in ("native", "pythonfmu")}
    rows, statuses, logs, again = runs["native"]
    assert statuses == [0] * 8, (statuses, logs)
    k = next(i for i, r in enumerate(rows) if not r["valid"])  # the step that latched: from 0.16 s
    t0, t1 = 0.04 * (k - 1), 0.04 * k
    assert k == 5 and rows[k - 1]["valid"] and rows[k - 1]["n_impacts"] > 10 and rows[k - 1]["mode"] == 0
    assert [len(log) for log in logs[k - 1:]] == [1, 0, 0, 0], logs  # (before: a coupling warning at 40 ms)
    (status, text), = logs[k - 1]
    assert status == 1  # fmi2Warning
    found = re.fullmatch(r"BallInShell 'ball': valid = false from t = ([0-9.e-]+) s \(latched until reset\): Zeno "
                         r"sequence: 100 events within ([0-9.e-]+) s before t = ([0-9.e-]+) s, more than the allowed "
                         r"rate 10000 events/s: the ball is held on the wall from there, rolling only \(as "
                         r"contact_model = 1 after its latch; a larger v_rest ends a bounce sequence sooner\)", text)
    assert found, text
    stop, within, last = found.groups()
    t_inv = rows[k]["t_invalid"]
    assert stop == last == f"{t_inv:.9g}" and t0 < t_inv < t1 and float(within) < 0.01
    ball = Ball()
    vz = _dropped_chamber(1.0)[1]
    for r in rows[k:]:
        assert (r["valid"], r["t_invalid"], r["mode"], r["gap"], r["slip_speed"]) == (False, t_inv, 1, 0.0, 0.0)
        assert (r["n_impacts"], r["E_impact"], r["E_friction"]) == \
            (rows[k]["n_impacts"], rows[k]["E_impact"], rows[k]["E_friction"])
        vrel = (r["vxC"], r["vyC"], r["vzC"] - vz)
        nz = (r["zC"] - ball.R) / ball.d
        N = ball.m * (-ball.g * nz + sum(v * v for v in vrel) / ball.d)
        assert r["N"] == pytest.approx(N, rel=1e-9) and r["N"] > 0.0

    def energy(r):  # in the frame of the chamber, which moves at vz from 40 ms on
        v2 = r["vxC"] ** 2 + r["vyC"] ** 2 + (r["vzC"] - vz) ** 2
        w2 = r["wx"] ** 2 + r["wy"] ** 2 + r["wz"] ** 2
        return 0.5 * ball.m * v2 + 0.5 * ball.I * w2 + ball.m * ball.g * r["zC"] + r["E_friction"] + r["E_impact"]
    e = [energy(r) for r in rows[3:]]  # from 0.12 s: the fits before 80 ms extrapolate the pull
    moved = rows[-1]["E_impact"] + rows[-1]["E_friction"]
    assert max(e) - min(e) < 1e-9 * moved, (e, moved)
    assert again == rows[-2:]
    assert runs["pythonfmu"] == runs["native"]


def test_a_sliding_balls_outputs_after_inputs_set_between_steps_are_the_flavours_same(fmus_of):
    """Direct feedthrough off rolling, every output: sliding (the fast start at 0.05 s), the
    platform moved 1 mm in x and its acceleration set 1 m/s2 higher in y without a step. The
    force and moments are recomputed (N changes); the force in the chamber's axes equals the
    force (with motion = 1 the chamber does not turn), and every native output equals the
    pythonfmu flavour's bit for bit."""
    after, before = {}, {}
    for flavour in ("native", "pythonfmu"):
        out, fmu = run_scene(fmus_of, flavour, FAST, 0.05, keep=True, **HYBRID)
        try:
            assert fmu.get("mode") == 2
            x, y, vx, vy, ax, ay = FAST.state(fmu.time)
            before[flavour] = fmu.outputs()
            assert fmu.set(x1O=x + 1e-3, y1O=y, vx1O=vx, vy1O=vy, ax1O=ax, ay1O=ay + 1.0) == 0
            after[flavour] = fmu.outputs()
        finally:
            fmu.free()
    assert before["native"] == before["pythonfmu"]
    assert after["native"]["N"] != before["native"]["N"]
    for f in ("x", "y", "z"):
        assert after["native"][f"F{f}_ch"] == after["native"][f"F{f}"] != before["native"][f"F{f}"], f
    differ = {n: (after["native"][n], after["pythonfmu"][n]) for n in after["native"]
              if after["native"][n] != after["pythonfmu"][n]}
    assert not differ, differ


@pytest.mark.parametrize("h, t_end, wz0", [(H, 0.04, 0.0), (0.04, 0.2, 5.0)])
def test_a_ball_that_slides_from_the_start_is_the_pythonfmu_flavours_bit_for_bit(fmus_of, h, t_end, wz0):
    """A ball set down at rest on the fixed chamber's wall off the bottom (xC0 = 0.1 m, where the
    slope 0.49 exceeds mu = 0.05) cannot roll: it starts sliding, its friction along the
    direction the start chose, into the state's bookkeeping. Every output of the native flavour
    at every communication point equals the pythonfmu flavour's bit for bit.
    With 2 ms steps the sliding mode's first internal step (the Hairer-Wanner choice) is cut to
    the step and leaves no trace; with 0.04 s steps (under max_step, 0.056 s) it is taken: about
    0.0273 s at tolerance 1e-9 on DOP853, chosen from all eleven controlled values of the free
    state (C, v_C, omega, W, E_friction; Lq is outside the error norm) with numpy's summation,
    as the library chooses it. The ball spins about the vertical (wz0 = 5 rad/s) so that omega_z
    and its rate, the ninth value, are not 0 (from rest W, E_friction and omega_z are all 0)."""

    class Fixed:
        @staticmethod
        def state(t):
            return (0.0,) * 6

    runs = {f: run_scene(fmus_of, f, Fixed, t_end, h=h, contact_model=2, integrator=1, tolerance=1e-9, xC0=0.1,
                         mu=0.05, wz0=wz0) for f in ("native", "pythonfmu")}
    assert runs["native"]["mode"][1] == 2 and runs["native"]["xC"][-1] < 0.1  # sliding down
    assert np.all(runs["native"]["mode"] == 2) and runs["native"]["wz"][0] == wz0
    differ = [n for n in runs["native"] if not np.array_equal(runs["native"][n], runs["pythonfmu"][n], equal_nan=True)]
    assert not differ, differ


def test_a_slip_the_predictor_makes_and_the_corrector_undoes_leaves_a_small_coupling_error(fmus_of):
    """The chamber at rest, then accelerating at a1 = 3.3 m/s2 from t0 = 20 ms (the inputs x1O,
    vx1O, ax1O of that motion, input_mode 1, the corrector on): below the slip threshold of a
    ball rolling at the bottom, 3.5 mu g = 3.43 m/s2 with mu = 0.1 (friction ratio 2 a1 / (7 g)
    = 0.96 mu). Over the step from t0 the predictor extrapolates the fit of the samples at t0 - H
    and t0, the acceleration's jump, beyond the threshold: the ball slips 9 us after t0 and the
    step ends sliding. The next step's corrector, with the sample at t0 + H (a1 constant), keeps
    the ball rolling through [t0, t0 + H]. So the coupling error at t0 + H compares a sliding
    predicted state with a rolling corrected one: R/(R - r) times the distance of their ball
    centres, 8.6e-8 m measured, under what a slide of less than one step at an extra
    acceleration below a1 could make, a1 H^2 / 2 = 6.6e-6 m, and under coupling_warn (1e-4 m):
    no warning. Every output of the native flavour equals the pythonfmu flavour's bit for bit."""
    a1, k0 = 3.3, 10
    t0 = k0 * H

    class Jump:
        @staticmethod
        def state(t):
            if t < t0 - 1e-12:
                return (0.0,) * 6
            s = t - t0
            return (0.5 * a1 * s * s, 0.0, a1 * s, 0.0, a1, 0.0)

    runs, logs = {}, {}
    for f in ("native", "pythonfmu"):
        runs[f], fmu = run_scene(fmus_of, f, Jump, t0 + 4 * H, keep=True, contact_model=2, mu=0.1)
        logs[f] = fmu.messages()
        fmu.free()
    out = runs["native"]
    assert list(out["mode"][k0:k0 + 4]) == [1, 2, 1, 1]  # the predicted slide, then rolling again
    assert 0.0 < out["coupling_error"][k0 + 2] < a1 * H ** 2 / 2
    assert "predicted over the last step" not in logs["native"], logs["native"]
    differ = [n for n in out if not np.array_equal(out[n], runs["pythonfmu"][n], equal_nan=True)]
    assert not differ, differ
