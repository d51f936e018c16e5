"""Two behaviours of the native FMUs that only their Python twins had pinned (docs/mutation.md,
"The C"):

* an FMU state taken in initialisation mode of an instance started at t = 1 s (not 0):
  restored, into the same instance after it has stepped on or into a fresh one through the
  serialised bytes, the instance steps from 1 s exactly like one never restored, and the
  restored instance's state serialises to the same bytes;
* BallInShell's input-consistency threshold (input_mode = 1, platform.worst_residual):
  one x1O sample off by 0.75 of the accepted residual keeps `valid`, by 1.5 of it clears
  `valid` at that sample, with the chamber at rest and with it accelerating.

The accepted residual of two samples H apart, per axis, is
    |r| <= (input_tol + 0.01 max|a|) H^2 / 6 + 8 ulp(max |x|),
    r = x_q - x_p - H (v_p + v_q) / 2 + H^2 (a_q - a_p) / 12,
which vanishes for a motion of degree <= 4: a quadratic x(t) = a t^2 / 2 plus an offset d of
one position has r = d on the pair that ends at it and -d on the pair that starts there.
"""
from __future__ import annotations

import math

import pytest

from conformance.harness import Fmu
from conformance.inputs import feed

OK = 0
T_START = 1.0
H = 2e-3


@pytest.fixture
def native(fmus_of):
    fmus = fmus_of("native")
    opened = []

    def open_(model, name, **parameters):
        opened.append(Fmu(fmus[model], name, **parameters))
        return opened[-1]
    yield open_
    for f in opened:
        f.free()


# ----------------------------------------------------------------------------- FMU state at 1 s
def _enter(fmu, model):
    """setupExperiment(startTime = 1 s), enterInitializationMode and, for the ball, the
    crank's inputs at 1 s."""
    fmu.fmu.setupExperiment(startTime=T_START)
    fmu.fmu.enterInitializationMode()
    if model == "BallInShell":
        feed(fmu, T_START)


def _steps(fmu, model, n=25):
    """exitInitializationMode, then n steps of H from 1 s: every output after each step."""
    fmu.fmu.exitInitializationMode()
    fmu.time = T_START
    rows = []
    for _ in range(n):
        assert fmu.step(H) == OK, fmu.messages()
        if model == "BallInShell":
            feed(fmu, fmu.time)
        rows.append(fmu.outputs())
    return rows


@pytest.mark.parametrize("model", ["MotorStartup", "BallInShell"])
def test_a_state_taken_in_initialisation_at_one_second_restores_that_start(native, model):
    params = {"xC0": -0.05} if model == "BallInShell" else {}  # rolls without slip from 1 s on
    ref = native(model, "never_restored", **params)
    _enter(ref, model)
    expected = _steps(ref, model)
    if model == "BallInShell":
        assert expected[-1]["valid"] and expected[0]["xC"] != expected[-1]["xC"], ref.messages()
    # the steps start from 1 s: MotorStartup's crank angle is the start-up law's at 1 s + k H
    # (the quadratic law, psi_dot = w0 (1 - (1 - t/t0)^2), is not constant there)
    if model == "MotorStartup":
        assert expected[0]["psi"] != expected[-1]["psi"]
        assert expected[1]["psi_dot"] > expected[0]["psi_dot"] > 0.0

    a = native(model, "restored", **params)
    _enter(a, model)
    state = a.get_state()
    blob = a.serialize(state)
    _steps(a, model, n=10)  # the instance moves on (to 1.02 s, initialised) ...
    assert a.set_state(state) == OK, a.messages()  # ... and goes back to initialisation at 1 s
    assert a.serialize(a.get_state()) == blob
    assert _steps(a, model) == expected

    fresh = native(model, "deserialised", **params)  # never set up: its own start time is 0 s
    st, s2 = fresh.deserialize(blob)
    assert st == OK and fresh.set_state(s2) == OK, fresh.messages()
    assert fresh.serialize(fresh.get_state()) == blob
    assert _steps(fresh, model) == expected


# ----------------------------------------------------------------------------- the input threshold
INPUT_TOL = 0.01  # m/s2, so that 0.01 |a| (a = 3 m/s2) is three quarters of the accelerating case's bound
K_OFF = 6  # the sample that is off: t = K_OFF H


def _ulp(x):
    return 2.0 ** -52 * max(abs(x), 1e-300)


def _chamber(t, a):
    """x1O..ay1O of x = a t^2 / 2 (a = 0: at rest at the origin), y at rest."""
    return dict(x1O=0.5 * a * t * t, y1O=0.0, vx1O=a * t, vy1O=0.0, ax1O=a, ay1O=0.0)


def _accepted(t, a, d):
    """The accepted |r| of the pair (t - H, t) whose newer x1O is off by d."""
    x_p, x_q = 0.5 * a * (t - H) ** 2, 0.5 * a * t * t + d
    return (INPUT_TOL + 0.01 * abs(a)) * H * H / 6.0 + 8.0 * _ulp(max(abs(x_p), abs(x_q)))


@pytest.mark.parametrize("a", [0.0, 3.0], ids=["at_rest", "accelerating"])
@pytest.mark.parametrize("sign", [1.0, -1.0], ids=["above", "below"])
@pytest.mark.parametrize("factor,valid", [(0.75, True), (1.5, False)])
def test_one_x1O_sample_off_by_a_fraction_of_the_accepted_residual(native, a, sign, factor, valid):
    fmu = native("BallInShell", "threshold", xC0=0.0, input_mode=1, input_tol=INPUT_TOL)
    fmu.set(**_chamber(0.0, a))
    assert fmu.init() == OK, fmu.messages()
    times = [0.0]
    for _ in range(12):
        times.append(times[-1] + H)  # the communication points as the FMU adds them up
    t_off = times[K_OFF]
    limit = _accepted(t_off, a, 0.0)
    assert limit > 1e5 * _ulp(0.5 * a * t_off * t_off + 1e-300)  # the ulp term is a rounding margin here
    d = sign * factor * limit
    for k in range(12):
        t = times[k]
        values = _chamber(t, a)
        if k == K_OFF:
            values["x1O"] += d
        fmu.set(**values)
        assert fmu.step(H, t) == OK, fmu.messages()
        if k < K_OFF:
            assert fmu.get("valid"), (k, fmu.messages())
        elif valid:
            assert fmu.get("valid") and fmu.get("t_invalid") == 1e300, (k, fmu.messages())
        else:  # flagged at the sample it is off, with the residual and the bound in the message
            assert not fmu.get("valid") and fmu.get("t_invalid") == t_off, (k, fmu.messages())
    if not valid:
        assert "inputs x1O, vx1O, ax1O disagree" in fmu.messages()
        assert f"accepted |r| <= {limit:.3g} m (input_tol = {INPUT_TOL:g} m/s2" in fmu.messages()
    else:
        assert "disagree" not in fmu.messages()
    assert math.isfinite(fmu.get("N"))


# ------------------------------------------------------------- steps equal up to round-off
def test_steps_equal_but_for_a_trillionth_reconstruct_as_the_python_flavour(fmus_of):
    """A master whose steps differ by about 1e-12 of their size (times accumulated in decimal,
    or a step size computed per step) gives the reconstruction sample offsets a hair from
    whole numbers of steps: both flavours round them to 12 decimals (Python's round(tau, 12),
    platform._inverse), so the natives's outputs equal the pythonfmu twin's bit for bit; offsets
    a quarter of 1e-12 and more from a whole number keep their 12th decimal."""
    fmus = {f: Fmu(fmus_of(f)["BallInShell"], f"jitter_{f}", xC0=0.03, input_mode=2) for f in ("native", "pythonfmu")}
    rows = {f: [] for f in fmus}
    for f, fmu in fmus.items():
        feed(fmu, 0.0)
        assert fmu.init() == OK, fmu.messages()
        for k in range(12):
            h = H * (1.0 + (0.4e-12, 0.9e-12, -0.6e-12, 1.1e-12)[k % 4])
            assert fmu.step(h) == OK, fmu.messages()
            feed(fmu, fmu.time)
            rows[f].append(fmu.outputs())
        fmu.free()
    assert rows["native"] == rows["pythonfmu"]


@pytest.mark.parametrize("input_mode", [1, 2])
def test_growing_and_shrinking_steps_keep_the_python_flavour_s_history(fmus_of, input_mode):
    """Steps that grow and shrink move the reconstruction's oldest node back to samples kept
    from earlier windows (the corrected states at the history's sample times): both flavours
    keep the same ones, so the native outputs equal the pythonfmu twin's bit for bit."""
    fmus = {f: Fmu(fmus_of(f)["BallInShell"], f"grow_{f}", xC0=0.03, input_mode=input_mode)
            for f in ("native", "pythonfmu")}
    rows = {f: [] for f in fmus}
    for f, fmu in fmus.items():
        feed(fmu, 0.0)
        assert fmu.init() == OK, fmu.messages()
        for factor in (1, 1, 1, 1, 2, 3, 4, 1, 1, 5, 0.5, 0.5, 6, 1):
            assert fmu.step(H * factor) == OK, fmu.messages()
            feed(fmu, fmu.time)
            rows[f].append(fmu.outputs())
        fmu.free()
    assert rows["native"] == rows["pythonfmu"]
