"""Model Exchange calls a hostile importer tries, on the native FMUs that have Model
Exchange (docs/conformance.md): each refused with fmi2Error and a message naming the
call, the value and what was expected, the instance keeping its state; and the calls an
importer may make that change nothing (an event update with no event pending)."""
import ctypes

import numpy as np
import pytest

from .conftest import ERROR, OK, _native_paths
from .harness import Fmu, Fmu3

from .conftest import MODELS as ME_MODELS  # every model has Model Exchange
STATEFUL = ("BallInShell", "InductionMotor", "Structure")


@pytest.fixture(scope="module")
def native_paths():
    return _native_paths()


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def version(request):
    return request.param


@pytest.fixture(scope="module")
def me_paths(native_paths, version):
    """the archives of FMI version `version`: build/<Model>.fmu or build/fmi3/<Model>.fmu"""
    if version == 2:
        return native_paths
    return {name: path.parent / "fmi3" / path.name for name, path in native_paths.items()}


def _open(path, name, version, **parameters):
    return (Fmu if version == 2 else Fmu3)(path, name, interface="me", **parameters)


def _fn(version, name):
    """an FMI function's name and a state's, as the version's messages write them"""
    v3 = {"GetDerivatives": "GetContinuousStateDerivatives"}
    states = {"instantiated": "Instantiated", "eventMode": "Event Mode"}
    if version == 2:
        return f"fmi2{name}" if name[0].isupper() else name
    return f"fmi3{v3.get(name, name)}" if name[0].isupper() else states[name]


def _ptr(a):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _running(path, name="me", version=2, **parameters):
    """An ME instance after initialisation, in continuous-time mode"""
    f = _open(path, name, version, **parameters)
    assert f.init() == OK, f.messages()
    assert f.call("newDiscreteStates")[0] == OK
    assert f.call("enterContinuousTimeMode")[0] == OK
    return f


def _nx(f):
    return f.md.numberOfContinuousStates


def _states(f):
    x = np.zeros(_nx(f))
    assert f.call("getContinuousStates", _ptr(x), _nx(f))[0] == OK
    return x


@pytest.mark.parametrize("model", STATEFUL)
def test_get_derivatives_before_initialisation_is_refused(me_paths, version, model):
    f = _open(me_paths[model], "me", version)
    try:
        dx = np.zeros(_nx(f))
        assert f.call("getDerivatives", _ptr(dx), _nx(f))[0] == ERROR
        assert f"{_fn(version, 'GetDerivatives')} is not allowed in state {_fn(version, 'instantiated')}" \
            in f.messages()
        assert f.init() == OK  # the instance stays usable
    finally:
        f.free()


@pytest.mark.parametrize("model", ("BallInShell", "MotorStartup"))
def test_enter_event_mode_before_initialisation_is_refused(me_paths, version, model):
    f = _open(me_paths[model], "me", version)
    try:
        assert f.call("enterEventMode")[0] == ERROR
        assert f"{_fn(version, 'EnterEventMode')} is not allowed in state {_fn(version, 'instantiated')}" \
            in f.messages()
        assert f.init() == OK  # the instance stays usable
    finally:
        f.free()


@pytest.mark.parametrize("model", ME_MODELS)
def test_set_time_backwards_is_refused_and_time_kept(me_paths, version, model):
    f = _running(me_paths[model], version=version)
    try:
        assert f.call("setTime", 0.2)[0] == OK
        assert f.call("setTime", 0.15)[0] == OK  # within the step: a solver may go back
        assert f.call("setTime", 0.2)[0] == OK
        assert f.call("completedIntegratorStep")[0] == OK
        n = len(f.log)
        st, _ = f.call("setTime", 0.1)
        assert st == ERROR
        msg = f.messages(n)
        assert "time = 0.1 s refused" in msg and "before the last accepted time 0.2 s" in msg, msg
        st, _ = f.call("setTime", float("nan"))
        assert st == ERROR and "time = nan s refused: it must be finite" in f.messages(n)
    finally:
        f.free()


@pytest.mark.parametrize("model, k, text", [("BallInShell", 4, "w_y = nan rad/s refused"),
                                            ("InductionMotor", 1, "s_psi_dot = nan rad/s refused"),
                                            ("Structure", 6, "s_qd_x1 = nan m/s refused")])
def test_nan_continuous_state_is_refused_and_states_kept(me_paths, version, model, k, text):
    f = _running(me_paths[model], version=version)
    try:
        nx = _nx(f)
        before = _states(f)
        bad = before.copy()
        bad[k] = np.nan
        n = len(f.log)
        assert f.call("setContinuousStates", _ptr(bad), nx)[0] == ERROR
        msg = f.messages(n)
        assert text in msg and "must be finite" in msg, msg
        assert np.array_equal(_states(f), before)
        assert f.call("setContinuousStates", _ptr(before), nx - 1)[0] == ERROR
        assert f"nx = {nx - 1} refused: this FMU has {nx}" in f.messages(n)
    finally:
        f.free()


@pytest.mark.parametrize("model", STATEFUL)
def test_states_set_in_event_mode_are_refused(me_paths, version, model):
    f = _running(me_paths[model], version=version)
    try:
        before = _states(f)
        assert f.call("enterEventMode")[0] == OK
        x = before + 0.01
        n = len(f.log)
        assert f.call("setContinuousStates", _ptr(x), _nx(f))[0] == ERROR
        assert f"{_fn(version, 'SetContinuousStates')} is not allowed in state {_fn(version, 'eventMode')}" \
            in f.messages(n)
        assert np.array_equal(_states(f), before)
    finally:
        f.free()


@pytest.mark.parametrize("model", ME_MODELS)
def test_event_update_with_no_event_changes_nothing(me_paths, version, model):
    f = _running(me_paths[model], version=version)
    try:
        assert f.call("setTime", 0.3)[0] == OK
        before = f.outputs()
        assert f.call("enterEventMode")[0] == OK
        st, info = f.call("newDiscreteStates")
        assert st == OK
        assert not info[0]  # newDiscreteStatesNeeded / discreteStatesNeedUpdate
        assert f.outputs() == before
        assert [m for s, m in f.log if s > OK] == []
    finally:
        f.free()


def test_non_finite_input_refuses_the_evaluation(native_paths):
    f = _running(native_paths["BallInShell"], xC0=0.05)
    try:
        dx = np.zeros(6)
        assert f.call("getDerivatives", _ptr(dx), 6)[0] == OK
        good = dx.copy()
        assert f.set(ax1O=float("inf")) == OK
        n = len(f.log)
        assert f.call("getDerivatives", _ptr(dx), 6)[0] == ERROR
        assert "input ax1O = inf refused at t = 0.0 s: it must be finite" in f.messages(n)
        assert f.set(ax1O=0.0) == OK
        assert f.call("getDerivatives", _ptr(dx), 6)[0] == OK and np.array_equal(dx, good)
    finally:
        f.free()


@pytest.mark.parametrize("parameters, expected", [
    (dict(input_mode=2), "input_mode = 2"), (dict(input_mode=3), "input_mode = 3"),
    (dict(formulation=2), "formulation = 2"), (dict(motion=2, input_mode=3), "motion = 2")])
def test_configurations_me_cannot_run_are_refused_at_initialisation(me_paths, version, parameters, expected):
    f = _open(me_paths["BallInShell"], "me", version, **parameters)
    try:
        assert f.init() == ERROR
        assert "Model Exchange" in f.messages() and expected in f.messages()
    finally:
        f.free()


def test_me_variables_are_not_read_in_co_simulation(native_paths):
    f = Fmu(native_paths["BallInShell"], "cs")
    try:
        assert f.init() == OK
        v = f.vars["der(w_x)"]
        st, _ = f.call("getReal", [v.valueReference])
        assert st == ERROR
        assert "der(w_x) is a Model Exchange variable" in f.messages()
    finally:
        f.free()


def test_a_serialised_me_state_with_a_byte_changed_is_refused(native_paths):
    f = _running(native_paths["BallInShell"], xC0=0.05)
    g = None
    try:
        assert f.call("setTime", 0.1)[0] == OK
        x = _states(f) * 1.001
        assert f.call("setContinuousStates", _ptr(x), 6)[0] == OK
        blob = f.serialize(f.get_state())
        ok, restored = f.deserialize(blob)
        assert ok == OK
        assert f.call("setContinuousStates", _ptr(x * 0.5), 6)[0] == OK
        assert f.set_state(restored) == OK and np.array_equal(_states(f), x)
        flipped = bytearray(blob)
        flipped[200] ^= 0x01
        n = len(f.log)
        status, _ = f.deserialize(bytes(flipped))
        assert status == ERROR and "checksum mismatch" in f.messages(n)
        # a state of a Model Exchange instance does not fit a co-simulation instance (opened
        # last: fmpy's logger proxy reports to the newest instance's log)
        g = Fmu(native_paths["BallInShell"], "cs")
        assert g.init() == OK
        status, _ = g.deserialize(blob)
        assert status == ERROR and "state refused" in g.messages()
    finally:
        f.free()
        if g is not None:
            g.free()


@pytest.mark.parametrize("model, text", [("MotorStartup", "input M_reaction must be finite, got nan N.m"),
                                         ("InductionMotor", "input M_reaction must be finite, got nan N.m"),
                                         ("Fig1Drive", "input Fx must be finite, got nan N"),
                                         ("Structure", "input Fx_ball must be finite, got nan")])
def test_a_non_finite_input_is_refused_at_the_next_read(me_paths, version, model, text):
    f = _running(me_paths[model], version=version)
    try:
        name = text.split()[1]
        good = f.outputs()
        assert f.set(**{name: float("nan")}) == OK
        n = len(f.log)
        v = next(v for v in f.vars.values() if v.causality == "output" and v.type in ("Real", "Float64"))
        assert f.call("getReal", [v.valueReference])[0] == ERROR
        assert text in f.messages(n), f.messages(n)
        assert f.set(**{name: 0.0}) == OK
        assert f.outputs() == good
    finally:
        f.free()
