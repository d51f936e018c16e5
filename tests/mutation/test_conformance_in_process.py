"""The conformance suite (tests/conformance/, docs/conformance.md) on the pythonfmu
flavour's slaves in this process (tests/mutation/inprocess.py), plus the hand-made state
blobs that tests/conformance/test_state.py sends through a host.

The same tests run on the built FMUs of both flavours in tests/conformance/; here they pin
the Python adapters' logic (ballmill/fmi/slave.py, fmu_src/ballinshell_fmu.py,
drive_models/*_fmu.py) where mutmut can reach it (docs/mutation.md). The flavour is
"in-process": a refusal is fmi2Fatal (any call but fmi2DoStep) or fmi2Discard (fmi2DoStep),
as in a built pythonfmu FMU, and the instance stays usable, so every refused call is also
checked to have kept the state."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from conformance.conftest import FATAL, DISCARD, MODELS, OK, Flavour  # noqa: E402
from conformance.inputs import run_ball  # noqa: E402
from conformance.test_inputs import *  # noqa: E402,F401,F403
from conformance.test_motion import *  # noqa: E402,F401,F403
from conformance.test_parameters import *  # noqa: E402,F401,F403
from conformance.test_state import *  # noqa: E402,F401,F403
from conformance.test_state import EDITS  # noqa: E402
from conformance.test_steps import *  # noqa: E402,F401,F403
from conformance.test_validity import *  # noqa: E402,F401,F403
from inprocess import InProcessFmu, open_fmu as open_fmu_in_process, write_model_descriptions  # noqa: E402

from ballmill.fmi.slave import state_from_bytes, state_to_bytes  # noqa: E402

# the host-process version of the blob test is replaced by the in-process one below
del test_an_invalid_state_blob_is_refused_and_the_instance_keeps_its_state  # noqa: F821

H = 2e-3
N_STEPS = 100
IN_PROCESS = Flavour("in-process", lambda build_dir: {}, refusal=FATAL, step_refusal=DISCARD, usable_after_refusal=True)


@pytest.fixture(scope="module")
def flavour():
    return IN_PROCESS


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """model -> its modelDescription.xml (for the tests that read the declaration)."""
    return write_model_descriptions(tmp_path_factory.mktemp("md"))


@pytest.fixture
def open_fmu():
    return open_fmu_in_process


def _ref_open(model, **p):
    return InProcessFmu(model, "ref", **p)


@pytest.fixture(scope="module")
def uniform():
    ref = {}
    for mode in (1, 2):
        fmu, st = run_ball(_ref_open, [H] * N_STEPS, input_mode=mode)
        assert st == OK
        ref[mode] = (fmu.get("N"), fmu.get("xC"), fmu.time)
    return ref


@pytest.fixture(scope="module")
def base():
    fmu, st = run_ball(_ref_open, [H] * 100)
    assert st == OK
    return fmu.outputs()


def _stepped_state(open_fmu, model):
    """An instance of `model` three steps in (BallInShell off centre), its outputs, and its
    FMU state as the JSON dict pythonfmu serialises."""
    fmu = open_fmu(model)
    if model == "BallInShell":
        fmu.set(x1O=0.5)
    assert fmu.init() == OK, fmu.messages()
    for _ in range(3):
        assert fmu.step(1e-3) == OK
    return fmu, fmu.outputs(), fmu.serialize(fmu.get_state())


@pytest.mark.parametrize("case", sorted(EDITS))
def test_an_invalid_state_blob_is_refused_in_process_state_kept(open_fmu, case):
    model, edit, expected = EDITS[case]
    fmu, before, blob = _stepped_state(open_fmu, model)
    scope = {"state": state_from_bytes(blob), "blob": blob, "json": json}
    exec(edit, scope)
    blob = scope["blob"] if edit.startswith("blob") else state_to_bytes(scope["state"])
    n = len(fmu.log)
    st, s = fmu.deserialize(blob)
    st2 = fmu.set_state(s) if st == OK else None
    assert FATAL in (st, st2)
    assert expected in fmu.messages(n)
    assert "FMU state refused, the instance keeps its state" in fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(1e-3) == OK



# more hand-made blobs: every check of the adapters' internal state (in-process only)
MORE_EDITS = {
    "ball_time": ("BallInShell", "state['__internal__']['state']['t'] = 99.0",
                  "the ball state is at t = 99.0 s but the FMU time is 0.003 s"),
    "ball_h": ("BallInShell", "state['__internal__']['state']['h'] = -1.0", ("ball state {", "is not finite")),
    "ball_h_zero": ("BallInShell", "state['__internal__']['state']['h'] = 0.0", ("ball state {", "is not finite")),
    "ball_nan": ("BallInShell", "state['__internal__']['state']['y'][3] = float('nan')",
                ("ball state {", "is not finite")),
    "ball_text": ("BallInShell", "state['__internal__']['state']['y'][3] = 'x'",
                  "expected 6 numbers for formulation 1 (motion = 1)"),
    "history": ("BallInShell", "state['__internal__']['history'][0]['y'] = [0.0] * 5",
                "ball state [0.0, 0.0, 0.0, 0.0, 0.0]: expected 6 numbers for formulation 1 (motion = 1)"),
    "confirmed_one": ("BallInShell", "state['__internal__']['confirmed'] = [True]",
                      "confirmed flags [True]: expected two Booleans"),
    "confirmed_ints": ("BallInShell", "state['__internal__']['confirmed'] = [1, 0]",
                       "confirmed flags [1, 0]: expected two Booleans"),
    "confirmed_tuple": ("BallInShell", "state['__internal__']['confirmed'] = 'ab'",
                        "confirmed flags 'ab': expected two Booleans"),
    "t_prev": ("BallInShell", "state['__internal__']['t_prev'] = 'x'",
               "t_prev = 'x': expected a finite time or null"),
    "t_prev_inf": ("BallInShell", "state['__internal__']['t_prev'] = float('inf')",
                   "t_prev = inf: expected a finite time or null"),
    "noise_negative": ("BallInShell", "state['__internal__']['noise_sum'] = -1.0",
                       "noise_sum = -1.0: expected a finite number >= 0"),
    "noise_text": ("BallInShell", "state['__internal__']['noise_sum'] = 'x'",
                   "noise_sum = 'x': expected a finite number >= 0"),
    "noise_inf": ("BallInShell", "state['__internal__']['noise_sum'] = float('inf')",
                  "noise_sum = inf: expected a finite number >= 0"),
    "a_mid_short": ("BallInShell", "state['__internal__']['a_mid'] = [1.0, 2.0]",
                    "a_mid = [1.0, 2.0]: expected null or three finite numbers"),
    "a_mid_nan": ("BallInShell", "state['__internal__']['a_mid'] = [1.0, 2.0, float('nan')]",
                  "expected null or three finite numbers"),
    "a_mid_text": ("BallInShell", "state['__internal__']['a_mid'] = [1.0, 2.0, 'x']",
                   "expected null or three finite numbers"),
    "a_mid_dict": ("BallInShell", "state['__internal__']['a_mid'] = {'a': 1}",
                   "expected null or three finite numbers"),
    "inputs": ("BallInShell", "state['__internal__']['inputs']['mode'] = 'hold'",
               "input reconstruction state for mode 'hold' with 2 points, expected 'derivatives' with 2"),
    "internal_missing": ("MotorStartup", "state['__internal__'] = None", "the internal state is missing"),
    "phase": ("MotorStartup", "state['__phase__'] = 'running'", "unknown phase 'running'"),
    "not_a_mapping": ("MotorStartup", "state.clear(); state['x'] = 1",
                      "the state belongs to model None with format None, expected 'MotorStartup' with format 6"),
    "format": ("MotorStartup", "state['__format__'] = 1",
               "the state belongs to model 'MotorStartup' with format 1, expected 'MotorStartup' with format 6"),
    "bool_type": ("MotorStartup", "state['law'] = True", "variable law = True has the wrong type (expected int)"),
    "int_as_bool": ("BallInShell", "state['valid'] = 1", "variable valid = 1 has the wrong type (expected bool)"),
    "real_as_bool": ("MotorStartup", "state['l'] = False", "variable l = False has the wrong type (expected float)"),
    "real_nan": ("MotorStartup", "state['psi'] = float('nan')", "variable psi = nan is not finite"),
    "z_short": ("InductionMotor", "state['__internal__']['z'] = [0.0, 0.0]",
                "drive state [0.0, 0.0]: expected 3 finite numbers for model 'kloss'"),
    "z_nan": ("InductionMotor", "state['__internal__']['z'][1] = float('nan')",
              ("drive state [", "expected 3 finite numbers for model 'kloss'")),
    "z_text": ("InductionMotor", "state['__internal__']['z'][1] = 'x'",
               ("drive state [", "expected 3 finite numbers for model 'kloss'")),
    "h_zero": ("InductionMotor", "state['__internal__']['h'] = 0.0",
               "internal step h = 0.0: expected a positive finite number or null"),
    "time_text": ("MotorStartup", "state['__time__'] = 'x'", "time must be finite, got 'x'"),
    "int_as_real": ("MotorStartup", "state['law'] = 2.5", "variable law = 2.5 has the wrong type (expected int)"),
    "h_negative": ("InductionMotor", "state['__internal__']['h'] = -1e-3",
                   "internal step h = -0.001: expected a positive finite number or null"),
    "h_inf": ("InductionMotor", "state['__internal__']['h'] = float('inf')",
              "internal step h = inf: expected a positive finite number or null"),
    "h_text": ("InductionMotor", "state['__internal__']['h'] = 'x'", "expected a positive finite number or null"),
    "samples_empty": ("InductionMotor", "state['__internal__']['samples'] = []",
                      "M_reaction samples []: expected (t, M) pairs of finite numbers"),
    "samples_triple": ("InductionMotor", "state['__internal__']['samples'] = [[0.0, 1.0, 2.0]]",
                       "M_reaction samples [[0.0, 1.0, 2.0]]: expected (t, M) pairs of finite numbers"),
    "samples_nan": ("InductionMotor", "state['__internal__']['samples'] = [[0.0, float('nan')]]",
                    "expected (t, M) pairs of finite numbers"),
}


@pytest.mark.parametrize("case", sorted(MORE_EDITS))
def test_every_internal_state_check_refuses_state_kept(open_fmu, case):
    model, edit, expected = MORE_EDITS[case]
    fmu, before, blob = _stepped_state(open_fmu, model)
    state = state_from_bytes(blob)
    exec(edit, {"state": state})
    n = len(fmu.log)
    assert fmu.set_state(state) == FATAL
    msg = fmu.messages(n)
    assert msg.startswith(f"{model} '{model.lower()}': FMU state refused, the instance keeps its state: "), msg
    reason = msg.split("keeps its state: ", 1)[1]
    start, end = expected if isinstance(expected, tuple) else ("", expected)
    assert reason.startswith(start) and reason.endswith(end), msg
    assert "XX" not in reason, msg
    assert fmu.outputs() == before
    assert fmu.step(1e-3) == OK
    assert fmu.time == pytest.approx(4e-3, abs=1e-15)


@pytest.mark.parametrize("model", MODELS)
def test_a_state_saved_before_initialisation_restores_the_instantiated_phase(open_fmu, model):
    fmu = open_fmu(model)
    early = fmu.get_state()
    assert early["__internal__"] is None and early["__phase__"] == "instantiated"
    if model == "BallInShell":
        fmu.set(x1O=0.5)
    assert fmu.init() == OK
    assert fmu.step(1e-3) == OK
    assert fmu.set_state(early) == OK
    assert fmu.step(1e-3) == DISCARD  # not initialised again yet
    assert "before fmi2ExitInitializationMode" in fmu.messages()
    if model == "BallInShell":
        fmu.set(x1O=0.5)
    assert fmu.init() == OK and fmu.step(1e-3) == OK


def test_a_state_with_nulls_where_allowed_is_taken(open_fmu):
    fmu, st = run_ball(open_fmu, [1e-3] * 3)
    state = state_from_bytes(fmu.serialize(fmu.get_state()))
    state["__internal__"].update(t_prev=None, a_mid=None, noise_sum=0)
    state["__internal__"]["state"]["h"] = None
    assert fmu.set_state(state) == OK, fmu.messages()
    motor = open_fmu("InductionMotor")
    assert motor.init() == OK and motor.step(1e-3) == OK
    state = state_from_bytes(motor.serialize(motor.get_state()))
    state["__internal__"]["h"] = None
    assert motor.set_state(state) == OK, motor.messages()
    assert motor.step(1e-3) == OK
