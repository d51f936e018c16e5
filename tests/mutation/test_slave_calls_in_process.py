"""The FMI call semantics of ballmill.fmi.slave.Slave (docs/conformance.md) word for word on the
pythonfmu slaves in this process (tests/mutation/inprocess.py), where mutmut sees `do_step` and
`_check_set`: each refused doStep's status and full message, the tolerances at the edges of the
step-size policy (the communication point within 1e-13 max(1 s, |t|) of the FMU's time, a step
within 1e-12 relative of max_step), and each refused fmi2SetReal/SetInteger with the variable,
the value, its unit (none for "1" and Integers) and what it keeps. The tests in
tests/conformance/ check the same refusals on both flavours by key phrases (the native FMUs
word them alike); here the pythonfmu text is pinned."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import DISCARD, ERROR, FATAL, OK, InProcessFmu  # noqa: E402

POSITIVE = ("refused: communicationStepSize must be positive and finite, accepted range (0, inf] s; state kept "
            "at t = 0.5 s")


@pytest.mark.parametrize("h, t, text", [
    (0.0, 0.5, f"doStep(currentCommunicationPoint = 0.5 s, communicationStepSize = 0.0 s) {POSITIVE}"),
    (-1.0, 0.5, f"doStep(currentCommunicationPoint = 0.5 s, communicationStepSize = -1.0 s) {POSITIVE}"),
    (math.nan, 0.5, f"doStep(currentCommunicationPoint = 0.5 s, communicationStepSize = nan s) {POSITIVE}"),
    (math.inf, 0.5, f"doStep(currentCommunicationPoint = 0.5 s, communicationStepSize = inf s) {POSITIVE}"),
    (0.1, 0.2, "doStep(currentCommunicationPoint = 0.2 s, communicationStepSize = 0.1 s) refused: "
               "currentCommunicationPoint must equal the FMU's time t = 0.5 s (steps are contiguous; restore an "
               "FMU state to go back); state kept"),
    (0.1, math.nan, "doStep(currentCommunicationPoint = nan s, communicationStepSize = 0.1 s) refused: "
                    "currentCommunicationPoint must equal the FMU's time t = 0.5 s (steps are contiguous; restore "
                    "an FMU state to go back); state kept"),
    (1e-14, 0.5 - 5e-14, "doStep(currentCommunicationPoint = 0.49999999999995 s, communicationStepSize = 1e-14 s) "
                         "refused: the step ends at 0.49999999999996 s, not after the FMU's time t = 0.5 s; "
                         "state kept"),
])
def test_a_refused_step_says_why_and_keeps_the_state(h, t, text):
    f = InProcessFmu("MotorStartup", "sm")
    assert f.init() == OK and f.step(0.5) == OK
    before = f.outputs()
    n = len(f.log)
    assert f.step(h, t) == DISCARD
    assert f.log[n:] == [(ERROR, f"MotorStartup 'sm': {text}")]
    assert f.outputs() == before and f.slave._time == 0.5
    assert f.step(0.25, 0.5) == OK and f.slave._time == 0.75


@pytest.mark.parametrize("t_c", [0.5, 100.0])
def test_the_communication_point_may_differ_from_the_fmus_time_by_1e_13_relative(t_c):
    tol = 1e-13 * max(1.0, t_c)
    for offset, status in ((0.6 * tol, OK), (-0.6 * tol, OK), (1.6 * tol, DISCARD), (-1.6 * tol, DISCARD)):
        f = InProcessFmu("MotorStartup", "sm")
        assert f.init(t_c) == OK
        assert f.step(0.25, t_c + offset) == status, (t_c, offset)
        if status == OK:  # the step ends at the master's point plus the step
            assert f.slave._time == t_c + offset + 0.25


def test_a_step_longer_than_max_step_is_discarded_beyond_a_relative_1e_12():
    f = InProcessFmu("BallInShell", "b", max_step=0.01)
    assert f.init() == OK
    n = len(f.log)
    assert f.step(0.02) == DISCARD
    assert f.log[n:] == [(DISCARD, "BallInShell 'b': doStep(currentCommunicationPoint = 0.0 s, communicationStepSize "
                                   "= 0.02 s) refused: communicationStepSize exceeds max_step = 0.01 s, accepted range "
                                   "(0, 0.01] s; state kept at t = 0.0 s")]
    assert f.step(0.01 * (1.0 + 2e-12)) == DISCARD
    assert f.step(0.01 * (1.0 + 0.5e-12)) == OK
    assert f.step(0.01) == OK


@pytest.mark.parametrize("model, values, text", [
    ("MotorStartup", dict(psi=1.0), "psi is an output and cannot be set (got psi = 1.0 rad)"),
    ("MotorStartup", dict(l=2.0), "parameter l is fixed: it can be set only before fmi2ExitInitializationMode; "
                                  "l = 2.0 m refused, l keeps 0.4 m"),
    ("MotorStartup", dict(law=2), "parameter law is fixed: it can be set only before fmi2ExitInitializationMode; "
                                  "law = 2 refused, law keeps 1"),
    ("BallInShell", dict(mu=0.5), "parameter mu is fixed: it can be set only before fmi2ExitInitializationMode; "
                                  "mu = 0.5 refused, mu keeps 0.3"),
    ("BallInShell", dict(coupling_warn=-1.0), "tunable parameter coupling_warn = -1.0 m refused: accepted range "
                                              "[0, inf] m; coupling_warn keeps 0.0001 m"),
    ("BallInShell", dict(coupling_warn=math.nan), "tunable parameter coupling_warn = nan m refused: accepted range "
                                                  "[0, inf] m; coupling_warn keeps 0.0001 m"),
    ("BallInShell", dict(N=1.0), "N is an output and cannot be set (got N = 1.0 N)"),
    ("BallInShell", dict(friction_ratio=1.0), "friction_ratio is an output and cannot be set (got "
                                              "friction_ratio = 1.0)"),
])
def test_a_refused_set_names_the_variable_its_value_and_what_it_keeps(model, values, text):
    f = InProcessFmu(model, "s", **({"l": 0.4} if model == "MotorStartup" else {}))
    assert f.init() == OK
    (name, value), = values.items()
    old = f.get(name)
    n = len(f.log)
    assert f.set(**values) == FATAL
    assert f.log[n:] == [(FATAL, f"{model} 's': {text}")]
    assert f.get(name) == old


def test_what_may_be_set_is_taken():
    f = InProcessFmu("BallInShell", "s")
    # before and during initialisation every parameter takes a value within its range
    assert f.set(mu=0.5) == OK and f._status(f.slave.setup_experiment, 0.0, None, None)[0] == OK
    assert f._status(f.slave.enter_initialization_mode)[0] == OK and f.set(mu=0.4) == OK
    assert f._status(f.slave.exit_initialization_mode)[0] == OK and f.get("mu") == 0.4
    # then tunable parameters within their range, at their bounds too, and inputs with any value
    for v in (1e-3, 0.0):
        assert f.set(coupling_warn=v) == OK and f.get("coupling_warn") == v
    assert f.set(x1O=1e3, ax1O=-1e3) == OK and f.get("x1O") == 1e3
    # an output is refused before initialisation as well
    g = InProcessFmu("MotorStartup", "o")
    assert g.set(T_drive=1.0) == FATAL and g.get("T_drive") == 0.0
