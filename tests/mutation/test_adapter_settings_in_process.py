"""What the pythonfmu adapters build from their parameters, and BallInShell's motion = 2 outputs
in the fixed axes, on the slaves in this process (tests/mutation/inprocess.py), where mutmut
sees the adapters:

* motion = 2 (`BallInShell._build_general`): the ChamberModel's integrator takes the method,
  tolerance, fixed step and work bound (MAX_INTERNAL_STEPS internal steps per doStep) of the
  parameters, the ChamberReconstruction the input mode, the chamber radius R and input_tol, and
  the corrector runs in input mode 1 only when switched on; likewise motion = 1's BallModel and
  InputReconstruction, and InductionMotor's DOP853 integrator;
* with a tilted chamber (Q away from the identity, the centre A = O + Q (0, 0, R) off O's
  vertical), P - O and C - O in the fixed axes follow from the chamber-axes outputs: P - O =
  Q P_ch (P_ch = Q^T (P - A) + (0, 0, R)) and C - A = (d / R) (P - A), d = R - r;
* P_diss is 0 with motion = 2 (no losses) even where motion = 1 with losses published a value
  before, in initialisation mode (parameters may change there and every read re-initialises).

The settings are read from the built library objects (their own attributes: Integrator.method,
tol, h_fixed, max_steps; the reconstructions' mode, R, a_tol): the behaviour each setting
selects is tested in the library's own tests."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import OK, InProcessFmu  # noqa: E402

WORK_BOUND = 20000  # internal steps of one doStep (docs: MAX_INTERNAL_STEPS of both adapters)


def _rotation(axis, angle):
    """Rodrigues: the rotation by angle (rad) about axis."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


# integrator, tolerance, h_fixed, input_mode, R, input_tol, corrector ->
# method, mode, whether the corrector runs
GENERAL = [
    (2, 1e-8, 1e-3, 1, 0.25, 1e-2, True, "RK45", "derivatives", True),  # the defaults
    (1, 1e-7, 2e-3, 1, 0.3, 0.05, False, "DOP853", "derivatives", False),
    (3, 1e-10, 5e-4, 3, 0.4, 0.2, True, "RK4", "hold", False),
    (2, 1e-6, 1e-4, 3, 0.2, 3e-3, False, "RK45", "hold", False),
]


@pytest.mark.parametrize("integrator,tol,h_fixed,input_mode,R,input_tol,corrector,method,mode,correct", GENERAL)
def test_motion_2_builds_the_integrator_and_reconstruction_its_parameters_name(
        integrator, tol, h_fixed, input_mode, R, input_tol, corrector, method, mode, correct):
    f = InProcessFmu("BallInShell", "general", motion=2, integrator=integrator, tolerance=tol, h_fixed=h_fixed,
                     input_mode=input_mode, R=R, input_tol=input_tol, corrector=corrector)
    assert f.init() == OK, f.messages()
    s = f.slave
    it = s._model.integrator
    assert (it.method, it.tol, it.h_fixed, it.max_steps) == (method, tol, h_fixed, WORK_BOUND)
    assert s._model.ball.R == R
    rec = s._inputs
    assert (type(rec).__name__, rec.mode, rec.R, rec.a_tol) == ("ChamberReconstruction", mode, R, input_tol)
    assert s._correct is correct


# motion = 1: the modes 1 - 4 and the corrector in modes 1, 2, 4 (not with hold)
TRANSLATION = [
    (1, 1e-7, 2e-3, 1, 0.05, True, "DOP853", "derivatives", True),
    (2, 1e-6, 1e-4, 2, 3e-3, True, "RK45", "positions", True),
    (3, 1e-9, 5e-4, 3, 0.2, True, "RK4", "hold", False),
    (2, 1e-8, 1e-3, 4, 1e-2, False, "RK45", "accelerations", False),
]


@pytest.mark.parametrize("integrator,tol,h_fixed,input_mode,input_tol,corrector,method,mode,correct", TRANSLATION)
def test_motion_1_builds_the_integrator_and_reconstruction_its_parameters_name(
        integrator, tol, h_fixed, input_mode, input_tol, corrector, method, mode, correct):
    f = InProcessFmu("BallInShell", "translation", integrator=integrator, tolerance=tol, h_fixed=h_fixed,
                     input_mode=input_mode, input_tol=input_tol, corrector=corrector)
    assert f.init() == OK, f.messages()
    s = f.slave
    it = s._model.integrator
    assert (it.method, it.tol, it.h_fixed, it.max_steps) == (method, tol, h_fixed, WORK_BOUND)
    rec = s._inputs
    assert (type(rec).__name__, rec.mode, rec.a_tol) == ("InputReconstruction", mode, input_tol)
    assert s._correct is correct


@pytest.mark.parametrize("model,tol", [(1, 1e-9), (2, 1e-6)])
def test_induction_motor_integrates_with_dop853_at_its_tolerance_and_work_bound(model, tol):
    f = InProcessFmu("InductionMotor", "motor", model=model, tolerance=tol)
    assert f.init() == OK, f.messages()
    it = f.slave._integrator
    assert (it.method, it.tol, it.max_steps) == ("DOP853", tol, WORK_BOUND)
    assert len(it.scale) == (7 if model == 2 else 3)  # crank angle, speed, (4 fluxes,) W_motor


def test_motion_2_contact_point_and_centre_in_fixed_axes_with_a_tilted_chamber():
    Q = _rotation((1.0, -2.0, 0.5), 0.4)
    assert abs(Q[0, 2]) > 0.1 and abs(Q[1, 2]) > 0.1  # A is off O's vertical in x and y
    f = InProcessFmu("BallInShell", "tilted", motion=2, xC0=0.04, yC0=-0.03, x1O=0.3, y1O=-0.2, z1O=0.1,
                     **{f"Q{i + 1}{j + 1}": float(Q[i, j]) for i in range(3) for j in range(3)})
    assert f.init() == OK, f.messages()
    R, d = f.get("R"), f.get("R") - f.get("r")
    e = Q @ np.array([0.0, 0.0, R])  # A - O
    for when in ("start", "after a step"):
        o = f.outputs()
        P = np.array([o["xP"], o["yP"], o["zP"]])
        P_ch = np.array([o["xP_ch"], o["yP_ch"], o["zP_ch"]])
        C = np.array([o["xC"], o["yC"], o["zC"]])
        F = np.array([o["Fx"], o["Fy"], o["Fz"]])
        F_ch = np.array([o["Fx_ch"], o["Fy_ch"], o["Fz_ch"]])
        assert np.max(np.abs(P - Q @ P_ch)) < 1e-14, (when, P, Q @ P_ch)
        assert abs(np.linalg.norm(P - e) - R) < 1e-14, when  # P on the sphere about A
        assert np.max(np.abs(C - (e + d / R * (P - e)))) < 1e-14, (when, C)
        assert np.max(np.abs(F - Q @ F_ch)) < 1e-12, (when, F, F_ch)
        assert np.linalg.norm(P_ch[:2]) > 0.01 and o["contact"] and o["valid"], when  # away from the bottom
        assert f.step(0.01) == OK, f.messages()


def test_p_diss_is_zero_with_motion_2_after_motion_1_with_losses_published_it():
    f = InProcessFmu("BallInShell", "p_diss", delta=1e-3, c_drag=0.5, wx0=3.0, wy0=-2.0, xC0=0.05)
    assert f._status(f.slave.setup_experiment, 0.0, None, None)[0] == OK
    assert f._status(f.slave.enter_initialization_mode)[0] == OK
    assert f.get("P_diss") > 1e-3  # rolling resistance and drag take power from the rolling ball
    assert f.set(motion=2, delta=0.0, c_drag=0.0) == OK, f.messages()
    assert f.get("P_diss") == 0.0
    assert f._status(f.slave.exit_initialization_mode)[0] == OK, f.messages()
    assert f.step(0.01) == OK and f.get("P_diss") == 0.0
