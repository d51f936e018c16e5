"""The step-size policy (docs/conformance.md, "doStep"): any legal sequence of steps gives
what uniform steps give; a step that is not a step is refused with the state intact; the
work of one call is bounded."""
from __future__ import annotations

import math
import re
import time

import pytest

from .conftest import DISCARD, MODELS, OK
from .inputs import feed, run_ball

H = 2e-3  # the default communication step of the scenarios [s]
N_STEPS = 100


@pytest.fixture(scope="module")
def uniform(fmus, flavour):
    """N and xC after N_STEPS uniform steps (mode 1 and 2), the reference of the variable-step cases."""
    ref = {}
    for mode in (1, 2):
        opened = []

        def open_fmu(model, **p):
            opened.append(flavour.open(fmus[model], "ref", **p))
            return opened[-1]
        fmu, st = run_ball(open_fmu, [H] * N_STEPS, input_mode=mode)
        assert st == OK
        ref[mode] = (fmu.get("N"), fmu.get("xC"), fmu.time)
        for f in opened:
            f.free()
    return ref


# coupling error published for the default step (docs/usage.md, docs/coupling.md): N within 3e-4 N with
# derivative inputs; the variable-step runs may differ from the uniform one by that much
N_TOL = {1: 1e-3, 2: 5e-3}


@pytest.mark.parametrize("mode", [1, 2])
@pytest.mark.parametrize("tiny", [1e-3, 1e-4, 1e-6, 1e-12], ids=lambda f: f"first_step_{f:g}s")
def test_one_tiny_step_then_uniform_steps_agrees_with_uniform(open_fmu, uniform, mode, tiny):
    # the tiny step shifts the grid: compare at the uniform run's end time by a last step
    steps = [tiny] + [H] * (N_STEPS - 1) + [H - tiny]
    fmu, st = run_ball(open_fmu, steps, input_mode=mode)
    assert st == OK, fmu.messages()
    N, xC, t = uniform[mode]
    assert fmu.time == pytest.approx(t, abs=1e-12)
    assert abs(fmu.get("N") - N) < N_TOL[mode]
    assert abs(fmu.get("xC") - xC) < 1e-6


@pytest.mark.parametrize("pattern", ["alternating", "tiny_in_the_middle", "growing"])
def test_irregular_step_sequences_agree_with_uniform(open_fmu, uniform, pattern):
    if pattern == "alternating":
        steps = [H / 1000, H - H / 1000] * N_STEPS
    elif pattern == "tiny_in_the_middle":
        steps = [H] * 50 + [1e-9, H - 1e-9] + [H] * (N_STEPS - 51)
    else:
        steps = [H / 4] * 4 + [H / 2] * 2 + [H] * (N_STEPS - 2)
    fmu, st = run_ball(open_fmu, steps, input_mode=1)
    assert st == OK, fmu.messages()
    N, xC, t = uniform[1]
    assert fmu.time == pytest.approx(t, abs=1e-12)
    assert abs(fmu.get("N") - N) < N_TOL[1]
    assert abs(fmu.get("xC") - xC) < 1e-6


def test_long_and_short_steps_mixed_agree_with_uniform(open_fmu, uniform):
    """Steps of 20 ms (the contact point's published error there is 1e-6 m, N's 2e-3 N:
    docs/coupling.md) then 2 ms steps."""
    fmu, st = run_ball(open_fmu, [0.02] * 5 + [H] * (N_STEPS - 50), input_mode=1)
    assert st == OK, fmu.messages()
    N, xC, t = uniform[1]
    assert fmu.time == pytest.approx(t, abs=1e-12)
    assert abs(fmu.get("N") - N) < 5e-3
    assert abs(fmu.get("xC") - xC) < 1e-5


@pytest.mark.parametrize("h", [1e-5, 1e-7])
def test_many_tiny_steps_agree_with_one_step(open_fmu, h):
    """Uniform steps too short for the positions' resolution (6 ulp(x) / h^2 > 1e-6 m/s2): the
    fit takes velocities and accelerations; the result agrees with one 2 ms step."""
    n = int(round(2e-4 / h))
    fine, st = run_ball(open_fmu, [h] * n)
    assert st == OK, fine.messages()
    coarse, st = run_ball(open_fmu, [2e-4])
    assert st == OK
    assert abs(fine.get("xC") - coarse.get("xC")) < 1e-12
    assert abs(fine.get("N") - coarse.get("N")) < 1e-6
    said = re.search(r"at t = (\S+) s the positions \(\|x1O\|, \|y1O\| up to (\S+) m, resolution (\S+) m\) over a "
                     r"window of (\S+) s would give acceleration errors above 1e-6 m/s2: the reconstruction uses the "
                     r"velocity and acceleration inputs there \(warned once\)", fine.messages())
    assert said, fine.messages()
    t, X, resolution, window = (float(x) for x in said.groups())
    assert 0.0 < t <= 2e-4 and window <= 2 * h * (1 + 1e-9)  # within the run, over a couple of steps
    assert X == pytest.approx(0.5, abs=1e-3)  # the crank's x1O = l cos(psi), l = 0.5 m
    assert resolution == pytest.approx(X * 2.0 ** -52, rel=1e-2)


@pytest.mark.parametrize("factor,warned", [(0.992, True), (1.008, False)], ids=["below", "above"])
def test_the_positions_are_fit_down_to_their_resolution_bound(open_fmu, factor, warned):
    """The fit takes the position inputs while their round-off, 6 ulp(X) / w^2 (X the largest
    |x1O|, |y1O| of its nodes, ulp(X) = X 2^-52, w its window), stays within 1e-6 m/s2 of
    acceleration. A chamber at rest at x1O = 3000 m, stepped with h 0.8 % below and above
    the bound's h* = sqrt(6 ulp(X) / 1e-6 m/s2) = 2.0 ms (the smallest window is one step):
    below, warned once with the window and the resolution; above, nothing said."""
    X = 3000.0
    rest = dict(x1O=X, y1O=0.0, vx1O=0.0, vy1O=0.0, ax1O=0.0, ay1O=0.0)
    h = factor * math.sqrt(6.0 * X * 2.0 ** -52 / 1e-6)
    fmu = open_fmu("BallInShell", input_mode=1)
    fmu.set(**rest)
    assert fmu.init() == OK, fmu.messages()
    t = 0.0
    for _ in range(8):
        assert fmu.step(h, t) == OK, fmu.messages()
        t += h
        fmu.set(**rest)
    said = re.findall(r"the positions \(\|x1O\|, \|y1O\| up to (\S+) m, resolution (\S+) m\) over a window of (\S+) s "
                      r"would give acceleration errors above 1e-6 m/s2", fmu.messages())
    if warned:
        assert len(said) == 1, fmu.messages()
        x, resolution, window = (float(v) for v in said[0])
        assert x == X and resolution == pytest.approx(X * 2.0 ** -52, rel=1e-2)
        assert window == pytest.approx(h, rel=1e-2)
    else:
        assert said == [], fmu.messages()


def test_the_positions_resolution_is_that_of_the_largest_position_of_the_fit(open_fmu):
    """The positions' resolution is judged on the largest |x1O|, |y1O| of the fit's nodes, not on
    one node's: a chamber moving away from the origin at 50 m/s from x1O = 3000 m, stepped with
    h = 1 ms (half the bound's 2.0 ms there). At the first fit of two nodes (t = h) the warning
    names the newer node's x1O, 3000.05 m (printed to 6 digits), not the older one's 3000 m."""
    X0, v, h = 3000.0, 50.0, 1e-3
    fmu = open_fmu("BallInShell", input_mode=1)
    fmu.set(x1O=X0, y1O=0.0, vx1O=v, vy1O=0.0, ax1O=0.0, ay1O=0.0)
    assert fmu.init() == OK, fmu.messages()
    for k in range(3):
        assert fmu.step(h, k * h) == OK, fmu.messages()
        fmu.set(x1O=X0 + v * (k + 1) * h)
    said = re.findall(r"at t = (\S+) s the positions \(\|x1O\|, \|y1O\| up to (\S+) m, resolution (\S+) m\)",
                      fmu.messages())
    assert len(said) == 1, fmu.messages()
    t, x, resolution = (float(s) for s in said[0])
    assert t == pytest.approx(h, rel=1e-9)
    assert x == float(f"{X0 + v * h:.6g}") == 3000.05
    assert resolution == pytest.approx(x * 2.0 ** -52, rel=1e-2)
    assert fmu.get("valid")


def test_fit_nodes_closer_than_the_fit_resolves_refuse_the_step_state_intact(open_fmu):
    """input_mode 2 fits the positions of up to 6 samples at least half a step apart, their
    offsets in units of the newest spacing rounded to 12 decimals: after a 1e-15 s step, a 2 ms
    one and another 1e-15 s one, two nodes are 1e-15 s / 2 ms = 5e-13 apart and round to one
    offset, which determines no fit. The step is refused (fmi2Discard) saying so, with the
    outputs kept; a 2 ms step from there goes on."""
    fmu, st = run_ball(open_fmu, [H] * 6 + [1e-15, H], input_mode=2, xC0=0.03)
    assert st == OK, fmu.messages()
    t = 0.0
    for h in [H] * 6 + [1e-15, H]:
        t += h  # the communication point as run_ball added it up
    before = fmu.outputs()
    n = len(fmu.log)
    assert fmu.step(1e-15, t) == DISCARD
    assert "the input samples do not determine the reconstruction" in fmu.messages(n), fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(H, t) == OK, fmu.messages(n)


def test_a_step_longer_than_the_time_so_far_after_a_full_history(open_fmu):
    """input_mode 2 keeps up to 12 input samples: twelve 0.1 ms steps from t = 0 fill the
    history, and the next step, 2 ms long from t = 1.2 ms (longer than all the time before it),
    is a step like any other: the ball's centre agrees with a run whose first step is 1.2 ms
    within 1e-8 m (measured 5.9e-10 m)."""
    fine, st = run_ball(open_fmu, [1e-4] * 12 + [H] * 10, input_mode=2, xC0=0.03)
    assert st == OK, fine.messages()
    coarse, st = run_ball(open_fmu, [1.2e-3] + [H] * 10, input_mode=2, xC0=0.03)
    assert st == OK, coarse.messages()
    assert fine.time == pytest.approx(coarse.time, abs=1e-15)
    assert abs(fine.get("xC") - coarse.get("xC")) < 1e-8


def _started(open_fmu, model):
    if model == "BallInShell":
        fmu, st = run_ball(open_fmu, [H] * 5)
        assert st == OK
        return fmu
    fmu = open_fmu(model)
    assert fmu.init() == OK
    for _ in range(5):
        assert fmu.step(H) == OK
    return fmu


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("h", [0.0, -1e-3, math.nan, math.inf, -math.inf], ids=str)
def test_a_step_size_that_is_not_a_step_is_refused_state_intact(open_fmu, flavour, model, h):
    fmu = _started(open_fmu, model)
    before = fmu.outputs()
    n = len(fmu.log)
    assert fmu.step(h) == flavour.step_refusal
    assert "communicationStepSize" in fmu.messages(n) and "positive and finite" in fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(H) == OK  # and the instance carries on from where it was


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("where", ["back", "ahead", "nan"])
def test_a_non_contiguous_step_is_refused_state_intact(open_fmu, flavour, model, where):
    fmu = _started(open_fmu, model)
    before = fmu.outputs()
    t = {"back": fmu.time - H, "ahead": fmu.time + H, "nan": math.nan}[where]
    n = len(fmu.log)
    assert fmu.step(H, t=t) == flavour.step_refusal
    assert "currentCommunicationPoint must equal the FMU's time" in fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(H) == OK


@pytest.mark.parametrize("model", MODELS)
def test_do_step_after_terminate_is_refused(open_fmu, flavour, model):
    fmu = _started(open_fmu, model)
    before = fmu.outputs()
    assert fmu.terminate() == OK
    n = len(fmu.log)
    assert fmu.step(H) == flavour.step_refusal
    msg = fmu.messages(n)
    assert f"after {flavour.fn('Terminate')} refused" in msg, msg
    if flavour.name.startswith("native"):  # the C plumbing names the state too (pythonfmu's the call only)
        assert f"is not allowed in state {flavour.fn('terminated')}" in msg, msg
    assert fmu.outputs() == before


def test_a_step_to_where_the_crank_angle_overflows_is_refused_naming_psi(open_fmu):
    """MotorStartup's psi = w0 (t - t0 / 3) exceeds the largest double at t = 1e308 s (w0 = 2 pi
    rad/s): no platform position exists there, so both flavours refuse the step naming the
    output psi (the pythonfmu flavour gave Python's bare "math domain error") and keep the
    state."""
    fmu = _started(open_fmu, "MotorStartup")
    before = fmu.outputs()
    n = len(fmu.log)
    assert fmu.step(1e308) == DISCARD  # the step is legal, its result is not
    assert "output psi would be inf" in fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(H) == OK


def test_a_step_longer_than_max_step_is_discarded_state_intact(open_fmu):
    fmu, st = run_ball(open_fmu, [H] * 5, max_step=0.01)
    before = fmu.outputs()
    n = len(fmu.log)
    assert fmu.step(0.0101) == DISCARD
    assert "exceeds max_step = 0.01 s" in fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(0.01) == OK


def test_the_step_time_tolerance_is_relative(open_fmu):
    """A master's own time arithmetic (t = k h instead of t += h) is accepted."""
    fmu, st = run_ball(open_fmu, [0.1] * 3, max_step=0.1)
    assert st == OK
    t_master = 3 * 0.1  # 0.30000000000000004 vs 0.1 + 0.1 + 0.1
    feed(fmu, t_master)
    assert fmu.step(0.1, t=t_master) == OK


@pytest.mark.parametrize("parameters, name", [
    ({"integrator": 3, "h_fixed": 1e-22}, "h_fixed"),
    ({"integrator": 3, "h_fixed": 1e-11}, "h_fixed"),
    ({"delta": 1e300}, "delta"),
    ({"c_drag": 1e300}, "c_drag"),
    ({"c_drag": 1e6}, "c_drag"),
    ({"delta": 0.03}, "delta"),
])
def test_parameters_that_make_the_work_unbounded_are_refused_at_initialisation(open_fmu, flavour, parameters,
                                                                               name):
    fmu = open_fmu("BallInShell", **parameters)
    feed(fmu, 0.0)
    t = time.perf_counter()
    assert fmu.init() == flavour.refusal
    assert time.perf_counter() - t < 5.0  # generous: the point is "not 12 s" on a busy machine
    msg = fmu.messages()
    assert f"parameter {name} = " in msg and "accepted range" in msg


def test_the_work_of_one_step_is_bounded(open_fmu):
    """The tightest tolerance the FMU accepts with the stiffest drag it accepts: every
    step either completes or is discarded after at most MAX_INTERNAL_STEPS internal steps."""
    fmu, st = run_ball(open_fmu, [H] * 3, tolerance=1e-15, integrator=1, c_drag=28000.0)
    assert st in (OK, DISCARD)
    if st == DISCARD:
        assert "more than 20000 internal steps" in fmu.messages()


def test_a_long_step_of_the_induction_motor_is_bounded(open_fmu):
    fmu = open_fmu("InductionMotor", model=2)
    assert fmu.init() == OK
    st = fmu.step(1e4)
    assert st in (OK, DISCARD)
    if st == DISCARD:
        assert "more than 20000 internal steps" in fmu.messages()
        assert fmu.step(1e-3) == OK
