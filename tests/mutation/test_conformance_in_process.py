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
from conformance.test_parameters import *  # noqa: E402,F401,F403
from conformance.test_state import *  # noqa: E402,F401,F403
from conformance.test_state import EDITS  # noqa: E402
from conformance.test_steps import *  # noqa: E402,F401,F403
from conformance.test_validity import *  # noqa: E402,F401,F403
from inprocess import InProcessFmu, write_model_descriptions  # noqa: E402

# the host-process version of the blob test is replaced by the in-process one below
del test_an_invalid_state_blob_is_refused_and_the_instance_keeps_its_state  # noqa: F821

H = 2e-3
N_STEPS = 100
IN_PROCESS = Flavour("in-process", lambda: {}, refusal=FATAL, step_refusal=DISCARD, usable_after_refusal=True)


@pytest.fixture(scope="module")
def flavour():
    return IN_PROCESS


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """model -> its modelDescription.xml (for the tests that read the declaration)."""
    return write_model_descriptions(tmp_path_factory.mktemp("md"))


@pytest.fixture
def open_fmu():
    def open_(model, /, **parameters):
        return InProcessFmu(model, model.lower(), **parameters)
    return open_


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


@pytest.mark.parametrize("case", sorted(EDITS))
def test_an_invalid_state_blob_is_refused_in_process_state_kept(open_fmu, case):
    model, edit, expected = EDITS[case]
    fmu = open_fmu(model)
    if model == "BallInShell":
        fmu.set(x1O=0.5)
    assert fmu.init() == OK, fmu.messages()
    for _ in range(3):
        assert fmu.step(1e-3) == OK
    before = fmu.outputs()
    state = json.loads(fmu.serialize(fmu.get_state()).decode())
    exec(edit, {"state": state})
    n = len(fmu.log)
    st, s = fmu.deserialize(json.dumps(state).encode())
    st2 = fmu.set_state(s) if st == OK else None
    assert FATAL in (st, st2)
    assert expected in fmu.messages(n)
    assert "FMU state refused, the instance keeps its state" in fmu.messages(n)
    assert fmu.outputs() == before
    assert fmu.step(1e-3) == OK

