"""BallModel and BallState where only the FMU or a rare kernel hand-over reached them:
the state's copy and dictionary round trip (FMU state save/restore), the energy with a
moving platform, the message of a run that stops, and the Python interval that the
compiled kernel hands back (`record_python`). Written for mutants that survived the
physics tests (docs/mutation.md)."""
from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, BallState, CrankStartup, energy, simulate
from ballmill.physics.model import record_python

BALL = Ball()
FAST = CrankStartup(l=0.5, n0=60.0, t0=2.5)


def test_state_copy_is_independent():
    s = BallState(0.25, np.array([0.1, 0.2, -0.97, 1.0, 2.0, 3.0]), 1e-3)
    c = s.copy()
    assert (c.t, c.h) == (0.25, 1e-3) and np.array_equal(c.y, s.y) and c.y is not s.y
    c.y[0] = 9.0
    assert s.y[0] == 0.1


@pytest.mark.parametrize("h", [None, 2.5e-3])
def test_state_dictionary_round_trip(h):
    s = BallState(1.5, np.array([0.1, -0.2, -0.97, 4.0, -5.0, 6.5]), h)
    d = s.to_dict()
    assert d == {"t": 1.5, "y": [0.1, -0.2, -0.97, 4.0, -5.0, 6.5], "h": h}
    assert all(type(v) is float for v in d["y"])  # JSON-ready
    r = BallState.from_dict(d)
    assert (r.t, r.h) == (1.5, h) and r.y.dtype == np.float64 and np.array_equal(r.y, s.y)
    r2 = BallState.from_dict({"t": 2, "y": [1, 0, 0, 0, 0, 0], "h": h})
    assert type(r2.t) is float and r2.y.dtype == np.float64


def test_energy_with_a_moving_platform():
    """E = 1/2 m |v_O + d n'|^2 + 1/2 I |w|^2 + m g zC, with n' from the equations of motion
    (an independent route to the centre's velocity) and zC = R + d n_z."""
    m = BallModel(BALL)
    s = m.initial(xC0=0.08, yC0=-0.05, w0=(3.0, -2.0, 7.0))
    n, w = m.nw(s)
    nd = m.form.derivative(s.y.tolist(), 0.0, 0.0)[:3]
    vx, vy = 0.7, -1.3
    v = np.array([vx, 0.0 + vy, 0.0]) + BALL.d * np.array(nd)
    want = 0.5 * BALL.m * v @ v + 0.5 * BALL.I * np.dot(w, w) + BALL.m * BALL.g * (BALL.R + BALL.d * n[2])
    assert m.energy(s, vx, vy) == pytest.approx(want, rel=1e-12)
    assert m.energy(s, vx, vy) == energy(BALL, n, w, vx, vy)
    assert m.energy(s, vx, 0.0) != pytest.approx(m.energy(s, 0.0, vy), rel=1e-6)


@pytest.mark.parametrize("kernel", ["python", "auto"])
def test_a_stopped_run_names_its_last_good_time(kernel):
    """The paper formulation climbs to the equator in the fast start and stops there."""
    m = BallModel(BALL, formulation="paper", method="RK45", tol=1e-8)
    tr = simulate(m, FAST, 4.0, 0.01, state=m.initial(xC0=0.05, yC0=0.02), kernel=kernel)
    assert not tr.success and 0.5 < tr.t[-1] < 4.0
    assert tr.message.startswith(f"stopped at t = {tr.t[-1]:.6g} s: paper formulation"), tr.message


def test_record_python_records_the_interval_as_simulate_does():
    m = BallModel(BALL, method="RK45", tol=1e-9, kernel="python")
    ref = simulate(m, FAST, 0.2, 0.1, state=m.initial(xC0=0.05), kernel="python")
    m2 = BallModel(BALL, method="RK45", tol=1e-9, kernel="python")
    times = ref.t
    ys = np.zeros((3, 6))
    outs = np.zeros((3, len(ref.out)))
    state = m2.initial(xC0=0.05)
    for i in (1, 2):
        ok, message, state = record_python(m2, FAST, times, state, i, ys, outs)
        assert (ok, message) == (True, "completed") and state.t == times[i]
    assert np.array_equal(ys[1:], ref.y[1:])
    for j, name in enumerate(ref.out):
        assert np.array_equal(outs[1:, j], ref.out[name][1:]), name
    # without outputs only the state is recorded
    ys2 = np.zeros((3, 6))
    ok, _, _ = record_python(BallModel(BALL, method="RK45", tol=1e-9), FAST, times,
                             BallModel(BALL).initial(xC0=0.05), 1, ys2, None)
    assert ok and np.array_equal(ys2[1], ref.y[1])


def test_record_python_reports_a_failure_with_the_state_unchanged():
    m = BallModel(BALL, formulation="paper", method="RK4", h_fixed=1e-3)
    s = m.initial(xC0=0.2)  # near the paper formulation's limit
    times = np.array([0.0, 50.0])
    ys = np.zeros((2, 5))
    bad = CrankStartup(l=0.5, n0=200.0, t0=0.1)  # flings the ball over the equator
    ok, message, state = record_python(m, bad, times, s, 1, ys, None)
    assert not ok and message.startswith("stopped at t = 0 s: ") and state is s
    assert np.array_equal(ys, np.zeros((2, 5)))


def test_copies_and_pickles_leave_the_kernel_buffers_behind():
    m = BallModel(BALL)
    m.__dict__["_fast_advance"] = object()  # stands for the kernel's buffers (addresses)
    assert "_fast_advance" not in m.__getstate__()
    assert "_fast_advance" in m.__dict__  # the model itself keeps them
    for other in (copy.deepcopy(m), pickle.loads(pickle.dumps(m))):
        assert "_fast_advance" not in other.__dict__
    m2 = BallModel(BALL)
    assert "_fast_advance" not in m2.__getstate__()  # nothing to leave behind: no error
    assert math.isfinite(m2.energy(m2.initial()))
