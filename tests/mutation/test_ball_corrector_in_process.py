"""BallInShell's predictor-corrector bookkeeping, on the pythonfmu slave in this process
(tests/mutation/inprocess.py) so that mutmut sees it: coupling_error is R |n_predicted -
n_corrected| at the step's start (input mode 1: no input-noise drift), computed here from the
saved states of two FMU states; the history of corrected states holds exactly one state per
sample of the reconstruction (with or without the corrector); a history that lacks the window's
oldest state makes the step use the prediction as it is (documented in `_corrected_history`)."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import OK, InProcessFmu  # noqa: E402

from ballmill.physics import BallState  # noqa: E402

A, W, H = 0.02, 8.0, 0.02  # m, rad/s, s: the chamber's orbit x = A sin(W t), y = (A/2) cos(W t)


def _inputs(t):
    return dict(x1O=A * math.sin(W * t), vx1O=A * W * math.cos(W * t), ax1O=-A * W * W * math.sin(W * t),
                y1O=0.5 * A * math.cos(W * t), vy1O=-0.5 * A * W * math.sin(W * t),
                ay1O=-0.5 * A * W * W * math.cos(W * t))


def _fmu(name, **parameters):
    """The ball off the bottom (n has a vertical error component of its own)."""
    f = InProcessFmu("BallInShell", name, input_mode=1, xC0=0.05, yC0=0.03, **parameters)
    assert f.set(**_inputs(0.0)) == OK and f.init() == OK, f.messages()
    return f


def test_coupling_error_is_the_contact_points_prediction_error():
    f = _fmu("coupling")
    R, nw = f.get("R"), f.slave._model.nw
    seen = 0
    for k in range(5):
        f.set(**_inputs(f.time))
        predicted = f.get_state()["__internal__"]["state"]
        assert f.step(H) == OK, f.messages()
        corrected = [d for d in f.get_state()["__internal__"]["history"] if d["t"] == predicted["t"]]
        assert len(corrected) == 1
        p, q = nw(BallState.from_dict(predicted))[0], nw(BallState.from_dict(corrected[0]))[0]
        e = R * math.sqrt(sum((a - b) ** 2 for a, b in zip(p, q)))
        assert abs(f.get("coupling_error") - e) <= 1e-12 * e + 1e-300, (k, f.get("coupling_error"), e)
        seen += e > 1e-10 and abs(p[2] - q[2]) > 0.1 * abs(p[0] - q[0])
    assert seen >= 2  # the vertical component weighs in


@pytest.mark.parametrize("corrector", [True, False])
def test_the_history_holds_one_state_per_sample(corrector):
    f = _fmu(f"history{corrector}", corrector=corrector)
    for k in range(12):
        t = f.time
        f.set(**_inputs(t))
        assert f.step(H) == OK, f.messages()
        times = [d["t"] for d in f.get_state()["__internal__"]["history"]]
        samples = [smp[0] for smp in f.slave._inputs.samples]
        assert times == samples, (k, times, samples)
        assert times[-1] == t


def test_a_history_without_the_windows_oldest_state_uses_the_prediction():
    f = _fmu("oldest")
    for k in range(6):
        f.set(**_inputs(f.time))
        assert f.step(H) == OK, f.messages()
    state = f.get_state()
    state["__internal__"]["history"] = []  # (mode 1's window: the last two samples)
    assert f.set_state(state) == OK, f.messages()
    predicted = f.get_state()["__internal__"]["state"]
    error = f.get("coupling_error")  # no new estimate without a corrected state: it stays
    f.set(**_inputs(f.time))
    assert f.step(H) == OK, f.messages()
    history = f.get_state()["__internal__"]["history"]
    assert history == [predicted] and f.get("coupling_error") == error


@pytest.mark.parametrize("mode", [2, 4])
def test_noise_sum_adds_the_fits_change_of_acceleration_mid_way_times_the_step_squared(mode):
    """Measured-motion modes: each step adds ((a_x,old - a_x,new)^2 + (a_y,old - a_y,new)^2) (t_k -
    t_k-1)^2 at the previous interval's midpoint tm, where the old fit's a is the state's a_mid and
    the new fit is the reconstruction after the step's sample; positions with a little 'noise'
    (a deterministic saw of 1e-7 m) so that the fits move."""
    f = InProcessFmu("BallInShell", f"noise{mode}", input_mode=mode, xC0=0.05, yC0=0.03)
    assert f.set(**_inputs(0.0)) == OK and f.init() == OK, f.messages()
    checked = 0
    for k in range(14):
        t = f.time
        values = _inputs(t)
        values["x1O"] += 1e-7 * (-1) ** k
        values["ax1O"] += 1e-3 * (-1) ** k
        f.set(**values)
        before = f.get_state()["__internal__"]
        assert f.step(H) == OK, f.messages()
        after = f.get_state()["__internal__"]
        if before["a_mid"] is None or after["noise_sum"] == before["noise_sum"]:
            continue
        tm, ox, oy = before["a_mid"]
        nx, ny = f.slave._inputs.accel_function()(tm)
        added = ((ox - nx) ** 2 + (oy - ny) ** 2) * (t - before["t_prev"]) ** 2
        assert abs(after["noise_sum"] - (before["noise_sum"] + added)) <= 1e-12 * after["noise_sum"], k
        assert added > 1e-3 * after["noise_sum"]
        checked += 1
    assert checked >= 5
