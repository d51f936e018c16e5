"""MotorStartup (drive_models/motorstartup_fmu.py) on the pythonfmu slave in this process
(tests/mutation/inprocess.py), where mutmut sees it, against the library and the closed forms
of its docstring: the kinematics are CrankStartup's at every communication point (also from a
start time other than 0), T_drive = J_total psi'' - M_reaction with J_total = J_crank +
m_platform l^2 and P_drive = T_drive psi'; both follow M_reaction set between steps (direct
feedthrough) and stay as they were when the new value is not finite or would give a non-finite
torque or power (the next step refuses the input or the step)."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import DISCARD, OK, InProcessFmu  # noqa: E402

from ballmill.physics import CrankStartup  # noqa: E402

L, N0, T0, J_CRANK, M_PLATFORM = 0.4, 45.0, 1.5, 0.3, 2.0
KIN = ("psi", "psi_dot", "psi_ddot", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
LAWS = {1: "quadratic", 2: "scurve", 3: "linear", 4: "quintic"}


def _open(law=1, **kw):
    p = dict(l=L, n0=N0, t0=T0, J_crank=J_CRANK, m_platform=M_PLATFORM, law=law)
    p.update(kw)
    return InProcessFmu("MotorStartup", "ms", **p)


def _drive(psi_ddot, psi_dot, m_r):
    j_total = J_CRANK + M_PLATFORM * L * L
    t = j_total * psi_ddot - m_r
    return t, t * psi_dot


def _close(a, b):
    return abs(a - b) <= 1e-14 * max(1.0, abs(b))


@pytest.mark.parametrize("law", [1, 2, 3, 4])
def test_kinematics_torque_and_power_follow_the_law_and_the_load(law):
    ref = CrankStartup(l=L, n0=N0, t0=T0, law=LAWS[law])
    f = _open(law, M_reaction=0.25)
    start = 0.7  # mid-rise: psi'' != 0 for every law
    assert f.init(start) == OK, f.messages()
    t = start
    for k in range(6):
        out = f.outputs()
        psi, wd, wdd = ref.angle(t)
        assert tuple(out[n] for n in KIN) == (psi, wd, wdd) + tuple(ref.state(t)), (law, t)
        m_r = f.get("M_reaction")
        T, P = _drive(wdd, wd, m_r)
        assert _close(out["T_drive"], T) and _close(out["P_drive"], P), (law, t, out["T_drive"], T)
        assert abs(out["T_drive"] + m_r) > 1e-3  # the inertia's share is visible
        assert f.set(M_reaction=0.25 - 0.1 * k) == OK
        assert f.step(0.1) == OK, f.messages()  # up to 1.3 s < t0: still rising
        t = f.time  # the FMU's time, t_k + h as the slave sums it


def test_a_load_set_between_steps_updates_torque_and_power_at_once():
    f = _open(3, M_reaction=0.0)
    assert f.init() == OK and f.step(0.5) == OK
    out = f.outputs()
    assert f.set(M_reaction=1.5) == OK
    new = f.outputs()
    T, P = _drive(out["psi_ddot"], out["psi_dot"], 1.5)
    assert _close(new["T_drive"], T) and _close(new["P_drive"], P)
    assert new["T_drive"] != out["T_drive"] and new["P_drive"] != out["P_drive"]
    assert all(new[n] == out[n] for n in KIN)  # the kinematics do not depend on the load


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_load_between_steps_leaves_torque_and_power(bad):
    f = _open(3, M_reaction=0.5)
    assert f.init() == OK and f.step(0.5) == OK
    out = f.outputs()
    assert f.set(M_reaction=bad) == OK
    assert {n: v for n, v in f.outputs().items()} == out
    n = len(f.log)
    assert f.step(0.5) == DISCARD
    assert f.messages(n) == (f"MotorStartup 'ms': input M_reaction must be finite, got {bad!r} N.m at t = 0.5 s; "
                             f"step refused, last good state kept")
    assert f.outputs() == out


def test_a_load_that_would_overflow_the_power_between_steps_leaves_torque_and_power():
    """psi' > 1 rad/s at t = 1 s: M_reaction = -1e308 N.m gives a finite T_drive (1e308 + J psi'')
    but P_drive = T_drive psi' beyond the largest double: neither output changes."""
    f = _open(3, M_reaction=0.5)
    assert f.init() == OK and f.step(1.0) == OK
    out = f.outputs()
    assert out["psi_dot"] > 1.5
    n = len(f.log)
    assert f.set(M_reaction=-1e308) == OK and f.log[n:] == []
    assert f.outputs() == out
    # a finite power again: both follow
    assert f.set(M_reaction=-1e300) == OK
    T, P = _drive(out["psi_ddot"], out["psi_dot"], -1e300)
    assert f.get("T_drive") == T and f.get("P_drive") == P


def test_a_start_before_zero_is_at_rest_and_a_zero_inertia_leaves_minus_the_load():
    f = _open(1, M_reaction=0.75, J_crank=0.0, m_platform=0.0)
    assert f.init(-1.0) == OK, f.messages()
    out = f.outputs()
    assert (out["psi"], out["psi_dot"], out["psi_ddot"]) == (0.0, 0.0, 0.0)
    assert out["T_drive"] == -0.75 and out["P_drive"] == 0.0
    assert (out["x1O"], out["y1O"]) == CrankStartup(l=L, n0=N0, t0=T0).state(-1.0)[:2]


def test_a_non_finite_load_at_initialisation_is_left_to_the_first_step():
    """An input may be anything until a step uses it: with M_reaction = nan at the exit of
    initialisation mode T_drive and P_drive keep their start values, and the first step is
    refused naming the input."""
    f = _open(2, M_reaction=math.nan)
    assert f.init(0.5) == OK, f.messages()
    assert f.get("T_drive") == 0.0 and f.get("P_drive") == 0.0
    assert f.get("psi_dot") == CrankStartup(l=L, n0=N0, t0=T0, law="scurve").angle(0.5)[1]
    n = len(f.log)
    assert f.step(0.1) == DISCARD
    assert f.messages(n) == ("MotorStartup 'ms': input M_reaction must be finite, got nan N.m at t = 0.5 s; "
                             "step refused, last good state kept")


def test_a_step_to_where_the_angle_overflows_is_refused_state_kept():
    """psi = w0 (t - t0 / 3) beyond the largest double at t = 1e308 s: the platform position
    cos(psi) has no value, the step is refused naming the output psi (as the native flavour does;
    it was Python's bare "math domain error") and every output stays."""
    f = _open(1, M_reaction=0.5)
    assert f.init() == OK and f.step(1.0) == OK
    out = f.outputs()
    n = len(f.log)
    assert f.step(1e308) == DISCARD
    assert f.messages(n) == ("MotorStartup 'ms': step to t = 1e+308 s refused, last good state kept: "
                             "output psi would be inf")
    assert f.outputs() == out and f.step(1.0) == OK
