"""FMU state (docs/conformance.md, "FMU state"): a state restores the whole configuration
it was saved with (parameters validated, model rebuilt); a blob that does not fit is
refused and the instance keeps its state."""
from __future__ import annotations

import pytest

from host import run_host  # tests/host.py: results written before the host leaves

from .conftest import MODELS, OK, ROOT
from .inputs import feed, run_ball

H = 2e-3


def test_a_state_from_another_configuration_restores_that_configuration(open_fmu):
    a, _ = run_ball(open_fmu, [H] * 50, m=2.0)
    b, _ = run_ball(open_fmu, [H] * 50, m=0.51)
    s = a.get_state()
    assert b.set_state(s) == OK
    assert b.get("m") == 2.0
    assert b.get("N") == a.get("N")
    # and both continue identically
    for f in (a, b):
        feed(f, f.time)
        assert f.step(H) == OK
    assert b.get("N") == a.get("N") and b.get("xC") == a.get("xC")


def test_a_state_of_the_other_formulation_restores_that_formulation(open_fmu):
    a, _ = run_ball(open_fmu, [H] * 20, formulation=2)
    b, _ = run_ball(open_fmu, [H] * 20, formulation=1)
    assert b.set_state(a.get_state()) == OK
    assert b.get("formulation") == 2
    for f in (a, b):
        feed(f, f.time)
        assert f.step(H) == OK
    assert b.get("xC") == a.get("xC")


@pytest.mark.parametrize("model", MODELS)
def test_serialized_state_round_trip_is_exact(open_fmu, model):
    if model == "BallInShell":
        a, _ = run_ball(open_fmu, [H] * 10)
    else:
        a = open_fmu(model)
        assert a.init() == OK
        for _ in range(10):
            assert a.step(H) == OK
    s = a.get_state()
    blob = a.serialize(s)
    t_saved = a.time
    for _ in range(5):
        if model == "BallInShell":
            feed(a, a.time)
        assert a.step(H) == OK
    after = a.outputs()
    st, s2 = a.deserialize(blob)
    assert st == OK and a.set_state(s2) == OK
    a.time = t_saved
    for _ in range(5):
        if model == "BallInShell":
            feed(a, a.time)
        assert a.step(H) == OK
    assert a.outputs() == after


# Hand-made blobs: run in a host process (a crash while handling the blob must fail the test,
# not the session); the host writes its result and leaves before pythonfmu's exit defect
# (tests/host.py), which would otherwise fail the test at random after the work is done.
SCRIPT = r'''
import sys
import json
sys.path.insert(0, sys.argv[1])
from tests.conformance.harness import Fmu
from ballmill.fmi.slave import state_from_bytes, state_to_bytes
path, model, edit = sys.argv[2], sys.argv[3], sys.argv[4]
fmu = Fmu(path, "victim")
if model == "BallInShell":
    fmu.set(x1O=0.5)
assert fmu.init() == 0, fmu.messages()
for _ in range(3):
    assert fmu.step(1e-3) == 0
before = fmu.outputs()
blob = fmu.serialize(fmu.get_state())
state = state_from_bytes(blob)
exec(edit)  # edits the state (serialised again, with its checksum) or the bytes themselves
if not edit.startswith("blob"):
    blob = state_to_bytes(state)
st, s = fmu.deserialize(blob)
st2 = fmu.set_state(s) if st == 0 else None
alive = not fmu.dead
finish({"deserialize": st, "set": st2, "same": alive and fmu.outputs() == before,
        "step": fmu.step(1e-3) if alive else None, "log": fmu.messages()})
'''

EDITS = {
    "negative_r": ("BallInShell", "state['r'] = -1.0; state['R'] = float('nan')", "R = nan"),
    "bad_n": ("BallInShell", "state['__internal__']['state']['y'][0] = 5.0", "unit vector"),
    "short_state": ("BallInShell", "state['__internal__']['state']['y'] = [0.0, 0.0]", "expected 6 numbers"),
    "negative_r_only": ("BallInShell", "state['r'] = -1.0", "parameter r = -1.0 m is outside its accepted range"),
    "wrong_model": ("BallInShell", "state['__model__'] = 'MotorStartup'", "belongs to model"),
    "missing_variable": ("MotorStartup", "del state['l']", "variable l is missing"),
    "bad_type": ("InductionMotor", "state['model'] = 'dq'", "wrong type"),
    "drive_state": ("InductionMotor", "state['__internal__']['z'] = [0.0]", "drive state"),
    "nan_time": ("MotorStartup", "state['__time__'] = None", "time must be finite"),
    # the bytes themselves (every byte: tests/test_fmu_state_bytes.py)
    "flipped_bit": ("BallInShell", "blob = blob[:200] + bytes([blob[200] ^ 4]) + blob[201:]", "checksum mismatch"),
    "flipped_checksum": ("Structure", "blob = blob[:-1] + bytes([blob[-1] ^ 1])", "checksum mismatch"),
    "format_2": ("MotorStartup", "blob = json.dumps(dict(state, __format__=2)).encode()",
                 "format version 2, expected 6"),
}


@pytest.mark.parametrize("case", sorted(EDITS))
def test_an_invalid_state_blob_is_refused_and_the_instance_keeps_its_state(fmus, flavour, case,
                                                                           tmp_path):
    if flavour.name != "pythonfmu":
        pytest.skip("these edits are of pythonfmu's JSON state; the native flavours' binary states "
                    "(one fmu_state.c for FMI 2.0 and 3.0) are validated the same way in "
                    "tests/test_native_fmi.py (foreign, short, corrupted, impossible parameters, "
                    "impossible ball state), tests/test_fmu_state_bytes.py (every byte changed) and "
                    "tests/test_fmi3.py (FMI 3.0: a byte changed)")
    model, edit, expected = EDITS[case]
    res = run_host(SCRIPT, [ROOT, fmus[model], model, edit], tmp_path / "result.json", cwd=ROOT)
    assert res["deserialize"] == flavour.refusal or res["set"] == flavour.refusal, res
    assert expected in res["log"], res["log"]
    if flavour.usable_after_refusal:
        assert res["same"] and res["step"] == OK, res


@pytest.mark.parametrize("model", MODELS)
def test_a_restore_is_silent_and_the_restored_instance_steps_on_exactly(open_fmu, model):
    """fmi2SetFMUstate restores a state: it logs nothing, re-runs no start-up check (BallInShell
    saved at t = 2 s, where its inputs would make the start state slip, must not warn "slip at
    t = 0 s" nor latch valid = false), and the instance, the same one or a new one given the
    serialised state, steps on exactly as the original does (every output, every step)."""
    h = 0.01

    def run(fmu, steps):
        rows = []
        for _ in range(steps):
            if model == "BallInShell":
                feed(fmu, fmu.time)
            assert fmu.step(h) == OK, fmu.messages()
            rows.append(fmu.outputs())
        return rows

    a = open_fmu(model)
    if model == "BallInShell":
        feed(a, 0.0)
    assert a.init() == OK
    run(a, 200)
    t_saved, valid = a.time, a.outputs().get("valid")
    saved = a.get_state()
    blob = a.serialize(saved)
    reference = run(a, 5)
    n = len(a.log)
    assert a.set_state(saved) == OK
    assert a.log[n:] == []
    a.time = t_saved
    assert a.outputs().get("valid") == valid
    assert run(a, 5) == reference
    b = open_fmu(model)
    st, state = b.deserialize(blob)
    assert st == OK and b.set_state(state) == OK
    assert b.log == []
    b.time = t_saved
    assert run(b, 5) == reference
