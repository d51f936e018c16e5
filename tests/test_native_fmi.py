"""The native FMUs' FMI plumbing (fmu_src/native/fmu_instance.c under fmi2.c): the calls the FMI 2.0 standard
rules out for the instance's state, step sizes that are not steps, fixed parameters after
initialisation, FMU states that are not this instance's, bad parameters. Each refused
call returns the exact status with a message naming what was wrong, and leaves the
instance as it was (its outputs bit for bit, and its next steps).

(The conformance suite, tests/conformance/, covers both flavours; this file
pins what the native plumbing does on its own.)
"""
from __future__ import annotations

import ctypes
import math
import struct
import zlib

import pytest
from fmpy.fmi1 import FMICallException

from fmu_instance import Opened

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
MODELS = ("BallInShell", "MotorStartup", "InductionMotor", "Fig1Drive")
WATCH = {"BallInShell": "xC", "MotorStartup": "psi_dot", "InductionMotor": "psi_dot", "Fig1Drive": "z1O"}
H = 0.002
HEADER_BYTES = 160  # a native state's header (fmu_src/native/fmu_state.h)


@pytest.fixture
def opened():
    o = Opened()
    yield o.open
    o.close_all()


def _raw(inst, name, *args):
    """Call an fmi2 function directly: its status (fmpy would raise)."""
    f = getattr(inst.fmu.dll, name)
    return f(inst.fmu.component, *args)


def _start(opened, fmus_of, model, name=None, **parameters):
    if model == "BallInShell":
        parameters.setdefault("xC0", 0.05)
    inst = opened(fmus_of("native")[model], name or model.lower(), **parameters)
    inst.initialize()
    for k in range(3):
        inst.fmu.doStep(k * H, H)
    return inst


def _errors(inst):
    return [m for s, m in inst.messages if s == ERROR]


@pytest.mark.parametrize("model", MODELS)
def test_step_sizes_that_are_not_steps_are_refused_state_intact(opened, fmus_of, model):
    inst = _start(opened, fmus_of, model)
    ref = _start(opened, fmus_of, model, name="reference")
    before = inst.get(WATCH[model])
    for bad in (0.0, -H, math.nan, math.inf, -math.inf):
        status = _raw(inst, "fmi2DoStep", ctypes.c_double(3 * H), ctypes.c_double(bad), 1)
        assert status == ERROR, bad
        assert "communicationStepSize" in _errors(inst)[-1] and "must be positive and finite" in _errors(inst)[-1]
        assert inst.get(WATCH[model]) == before
    # not the instance's time: behind, ahead
    for t in (2 * H, 4 * H):
        assert _raw(inst, "fmi2DoStep", ctypes.c_double(t), ctypes.c_double(H), 1) == ERROR
        assert "currentCommunicationPoint" in _errors(inst)[-1] and "t = 0.006 s" in _errors(inst)[-1]
    # positive but too small to move the time: 0.006 + 1e-20 == 0.006 in double precision
    assert _raw(inst, "fmi2DoStep", ctypes.c_double(3 * H), ctypes.c_double(1e-20), 1) == ERROR
    assert "the step ends at 0.006 s, not after the FMU's time t = 0.006 s" in _errors(inst)[-1]
    assert inst.get(WATCH[model]) == before
    # and the instance carries on exactly like one that never saw them
    for k in range(3, 8):
        inst.fmu.doStep(k * H, H)
        ref.fmu.doStep(k * H, H)
    assert inst.get(WATCH[model]) == ref.get(WATCH[model])


@pytest.mark.parametrize("model", MODELS)
def test_calls_not_allowed_in_the_state_get_one_uniform_error(opened, fmus_of, model):
    inst = opened(fmus_of("native")[model], "s")
    # doStep before initialisation
    assert _raw(inst, "fmi2DoStep", ctypes.c_double(0.0), ctypes.c_double(H), 1) == ERROR
    assert _errors(inst)[-1].endswith("fmi2DoStep is not allowed in state instantiated")
    inst.initialize()
    assert _raw(inst, "fmi2EnterInitializationMode") == ERROR
    assert _errors(inst)[-1].endswith("fmi2EnterInitializationMode is not allowed in state stepComplete")
    inst.fmu.doStep(0.0, H)
    assert _raw(inst, "fmi2Terminate") == OK
    # doStep after terminate
    assert _raw(inst, "fmi2DoStep", ctypes.c_double(H), ctypes.c_double(H), 1) == ERROR
    assert _errors(inst)[-1].endswith("fmi2DoStep is not allowed in state terminated")
    # reset brings the instance back to instantiated, with the start values
    assert _raw(inst, "fmi2Reset") == OK
    inst.initialize()
    inst.fmu.doStep(0.0, H)


@pytest.mark.parametrize("model,name,value,got", [
    ("MotorStartup", "psi", 1.0, "psi = 1.0 rad"), ("BallInShell", "N", 1.0, "N = 1.0 N"),
    # a Boolean's value is written as the number the plumbing holds (the pythonfmu flavour: False)
    ("BallInShell", "valid", False, "valid = 0.0"), ("BallInShell", "contact", True, "contact = 1.0"),
])
def test_an_output_cannot_be_set_before_or_after_initialisation(opened, fmus_of, model, name, value, got):
    kind = {float: "Real", bool: "Boolean"}[type(value)]
    fresh = opened(fmus_of("native")[model], "fresh")
    inst = _start(opened, fmus_of, model)
    for instance, state in ((fresh, "instantiated"), (inst, "stepComplete")):
        before = instance.get(name) if instance is inst else None
        with pytest.raises(FMICallException) as info:
            instance.set(**{name: value})
        assert info.value.status == ERROR
        assert _errors(instance)[-1] == (f"{model} '{instance.name}': fmi2Set{kind}: {name} cannot be set in "
                                         f"state {state}: {name} is an output and cannot be set (got {got})")
        if before is not None:
            assert instance.get(name) == before


_TYPES = {"Real": ("fmi2GetReal", "fmi2SetReal", ctypes.c_double),
          "Integer": ("fmi2GetInteger", "fmi2SetInteger", ctypes.c_int),
          "Boolean": ("fmi2GetBoolean", "fmi2SetBoolean", ctypes.c_int)}


def test_value_references_of_another_type_or_none_are_refused_by_name(opened, fmus_of):
    """A getter or setter of one type given a variable of another, or a value reference no
    variable has: fmi2Error naming the function, the reference, the variable and both types,
    and nothing read or written."""
    inst = _start(opened, fmus_of, "BallInShell")
    ref = _start(opened, fmus_of, "BallInShell", name="reference")
    for name in ("r", "input_mode", "valid"):  # a Real, an Integer and a Boolean variable
        var = inst.vars[name]
        for kind, (getter, setter, ctype) in _TYPES.items():
            if kind == var.type:
                continue
            vr = (ctypes.c_uint * 1)(var.valueReference)
            for function in (getter, setter):
                value = (ctype * 1)(7)
                assert _raw(inst, function, vr, ctypes.c_size_t(1), value) == ERROR, (function, name)
                assert _errors(inst)[-1] == (f"BallInShell 'ballinshell': {function}: value reference "
                                             f"{var.valueReference} is {name}, a {var.type}, not a {kind}")
                assert value[0] == 7  # nothing read into the caller's array
    n = len(inst.vars)
    for getter, setter, ctype in _TYPES.values():
        for function in (getter, setter):
            vr, value = (ctypes.c_uint * 1)(n), (ctype * 1)(7)
            assert _raw(inst, function, vr, ctypes.c_size_t(1), value) == ERROR
            assert _errors(inst)[-1] == f"BallInShell 'ballinshell': {function}: no variable has value reference {n}"
    # nothing was written: the instance steps on like one that never saw the calls
    for k in range(3, 8):
        inst.fmu.doStep(k * H, H)
        ref.fmu.doStep(k * H, H)
    assert [inst.get(v) for v in ("r", "input_mode", "valid", "xC")] == \
        [ref.get(v) for v in ("r", "input_mode", "valid", "xC")]


@pytest.mark.parametrize("model,name,value", [("BallInShell", "m", 2.0), ("BallInShell", "integrator", 1),
                                              ("MotorStartup", "t0", 1.0), ("InductionMotor", "model", 2)])
def test_fixed_parameters_cannot_change_after_initialisation(opened, fmus_of, model, name, value):
    inst = _start(opened, fmus_of, model)
    old = inst.get(name)
    with pytest.raises(FMICallException) as info:
        inst.set(**{name: value})
    assert info.value.status == ERROR
    assert f"{name} cannot be set in state stepComplete" in _errors(inst)[-1]
    assert inst.get(name) == old


@pytest.mark.parametrize("model,parameters,fragments", [
    ("BallInShell", {"r": 0.3}, ["R must be larger than r", "r = 0.3 m"]),
    ("BallInShell", {"r": 0.25}, ["R must be larger than r", "r = 0.25 m, R = 0.25 m"]),  # r = R: no room
    ("BallInShell", {"tolerance": 1.0}, ["tolerance", "1.0", "[1e-15, 0.1]"]),
    ("BallInShell", {"coupling_warn": -1.0}, ["parameter coupling_warn = -1.0 m", "range [0, inf] m"]),
    ("MotorStartup", {"t0": 0.0}, ["parameter t0 = 0.0 s is outside its accepted range [0.001, 1e+06] s"]),
    ("MotorStartup", {"J_crank": math.nan}, ["parameter J_crank = nan kg.m2 is outside its accepted range"]),
    ("InductionMotor", {"cos_phi": 1.5}, ["parameter cos_phi = 1.5 is outside its accepted range [0, 1]"]),
    ("InductionMotor", {"cos_phi": 0.0}, ["cos_phi must lie in (0, 1]", "cos_phi = 0.0"]),
    ("InductionMotor", {"eta": 0.0}, ["eta must lie in (0, 1]", "eta = 0.0"]),
    ("BallInShell", {"input_mode": 3, "x1O": 1e308, "xC0": 0.01, "wz0": 0.5},
     ["the initial state (xC0 = 0.01 m, yC0 = 0.0 m, wx0 = 0.0, wy0 = 0.0, wz0 = 0.5 rad/s) gives non-finite "
      "outputs: output MO1y would be inf"]),
    ("InductionMotor", {"start_mode": 4}, ["parameter start_mode = 4 is outside its accepted range [1, 3]"]),
])
def test_bad_parameters_are_refused_at_exit_of_initialisation(opened, fmus_of, model, parameters, fragments):
    inst = opened(fmus_of("native")[model], "bad", **parameters)
    inst.fmu.setupExperiment(startTime=0.0)
    inst.fmu.enterInitializationMode()
    with pytest.raises(FMICallException) as info:
        inst.fmu.exitInitializationMode()
    assert info.value.status == ERROR
    msg = _errors(inst)[-1]
    assert "initialisation failed" in msg
    for fragment in fragments:
        assert fragment in msg, (fragment, msg)


def test_fmu_states_from_elsewhere_are_refused(opened, fmus_of):
    ball = _start(opened, fmus_of, "BallInShell")
    drive = _start(opened, fmus_of, "MotorStartup")
    blob = bytearray(ball.fmu.serializeFMUstate(ball.fmu.getFMUstate()))
    before = ball.get("xC")

    def refused(data, fragment, inst=ball):
        with pytest.raises(FMICallException) as info:
            inst.fmu.deSerializeFMUstate(bytes(data))
        assert info.value.status == ERROR
        assert fragment in _errors(inst)[-1], _errors(inst)[-1]

    refused(blob[:100], "size 100, shorter than a state header and its checksum (164 bytes)")
    bad = bytearray(blob)
    bad[0] ^= 0xFF
    refused(bad, "magic '?allmill', expected 'ballmill': not a ballmill FMU state")
    refused(blob, "model 'BallInShell', expected 'MotorStartup'", inst=drive)
    refused(blob + b"\0", f"size {len(blob) + 1}, expected {len(blob)} (the size its header gives)")
    assert ball.get("xC") == before


def test_a_state_with_its_reserved_header_field_set_is_refused(opened, fmus_of):
    """The header's reserved field is 0 in every state the plumbing writes: a state with it
    set (checksum made right) is refused at fmi2DeSerializeFMUstate naming the field and what
    was expected, and the instance keeps its state."""
    ball = _start(opened, fmus_of, "BallInShell")
    blob = bytearray(ball.fmu.serializeFMUstate(ball.fmu.getFMUstate()))
    reserved_at = HEADER_BYTES - 20  # int32 built, uint32 reserved, double t_start, double t
    assert struct.unpack_from("<iI", blob, reserved_at - 4) == (1, 0)
    struct.pack_into("<I", blob, reserved_at, 7)
    before = ball.get("xC")
    with pytest.raises(FMICallException) as info:
        ball.fmu.deSerializeFMUstate(_sealed(blob))
    assert info.value.status == ERROR
    assert _errors(ball)[-1] == ("BallInShell 'ballinshell': fmi2DeSerializeFMUstate: state refused: built flag 1 "
                                 "and reserved field 7, expected 0 or 1 and 0")
    assert ball.get("xC") == before


def _sealed(blob: bytearray) -> bytes:
    """A native state with its checksum made right again (docs/conformance.md: the CRC-32 of
    every byte before the last 4, little-endian), so that the check of what it holds is reached."""
    return bytes(blob[:-4]) + zlib.crc32(bytes(blob[:-4])).to_bytes(4, "little")


def test_a_state_with_impossible_parameters_is_refused_instance_unchanged(opened, fmus_of):
    ball = _start(opened, fmus_of, "BallInShell")
    names = list(ball.vars)
    blob = bytearray(ball.fmu.serializeFMUstate(ball.fmu.getFMUstate()))
    # the values follow the header: find r (0.025) by its bytes and make it -1
    r = ctypes.c_double(ball.get("r"))
    at = bytes(blob).find(bytes(r))
    assert at > 0 and names.index("r") == 0
    blob[at:at + 8] = bytes(ctypes.c_double(-1.0))
    with pytest.raises(FMICallException):  # a changed byte: the checksum refuses it
        ball.fmu.deSerializeFMUstate(bytes(blob))
    assert "checksum mismatch" in _errors(ball)[-1]
    state = ball.fmu.deSerializeFMUstate(_sealed(blob))  # the format is right: it loads
    before = ball.get("xC")
    with pytest.raises(FMICallException) as info:
        ball.fmu.setFMUstate(state)
    assert info.value.status == ERROR
    assert any("parameter r = -1.0 m is outside its accepted range" in m for m in _errors(ball))
    assert ball.get("xC") == before and ball.get("r") == 0.025
    ball.fmu.doStep(3 * H, H)  # and it carries on


def test_a_paper_formulation_state_beyond_the_equator_is_refused(opened, fmus_of):
    """The paper's formulation holds the ball centre's (x, y), which must lie inside the
    circle of radius d = R - r: a state whose y is moved to 0.3 m (> d = 0.225 m; x stays
    0.05 m) is refused by name, and the instance keeps its state."""
    ball = opened(fmus_of("native")["BallInShell"], "paper", formulation=2, xC0=0.05, yC0=0.03)
    ball.initialize()
    for k in range(3):
        ball.fmu.doStep(k * H, H)
    blob = bytearray(ball.fmu.serializeFMUstate(ball.fmu.getFMUstate()))
    # the values (the output yC first) come before the model's data, which holds the state's
    # y, equal to yC to round-off
    yc = ball.get("yC")
    found = [i for i in range(len(blob) - 7)
             if abs(ctypes.c_double.from_buffer_copy(blob, i).value - yc) <= 1e-12 * abs(yc)]
    assert len(found) >= 2 and found[0] < 8 * len(ball.vars) + 200
    for at in found[1:]:
        blob[at:at + 8] = bytes(ctypes.c_double(0.3))
    state = ball.fmu.deSerializeFMUstate(_sealed(blob))  # its checksum made anew: the model's check
    # is the one under test
    before = ball.get("yC")
    with pytest.raises(FMICallException) as info:
        ball.fmu.setFMUstate(state)
    assert info.value.status == ERROR
    assert _errors(ball)[-2].endswith("FMU state refused: its ball centre lies at or beyond the chamber's equator")
    assert ball.get("yC") == before
    ball.fmu.doStep(3 * H, H)  # and it carries on


@pytest.mark.parametrize("model", MODELS)
def test_string_access_is_refused_by_name_and_the_logger_gets_the_hosts_environment(opened, fmus_of, model):
    """No model has String variables: fmi2GetString and fmi2SetString with a reference are
    refused (fmi2Error) with a message naming the instance, the function and why, and with
    none they do nothing (fmi2OK). Every message reaches the logger with the
    componentEnvironment the host gave fmi2Instantiate (FMI 2.0.4, 2.1.5), here a pointer
    value no allocator returns."""
    env = 0xBA11_0000
    inst = opened(fmus_of("native")[model], "strings", environment=env)
    inst.initialize()
    inst.fmu.getString([])
    inst.fmu.setString([], [])
    for call, args in (("getString", ([0],)), ("setString", ([0], ["x"]))):
        with pytest.raises(FMICallException) as info:
            getattr(inst.fmu, call)(*args)
        assert info.value.status == ERROR
        assert _errors(inst)[-1] == f"{model} 'strings': fmi2{call[0].upper()}{call[1:]}: this FMU has no String variables"
    assert inst.environments and set(inst.environments) == {env}, inst.environments


@pytest.mark.parametrize("model", MODELS + ("Structure",))
def test_a_state_taken_right_after_initialisation_restores(opened, fmus_of, model):
    """The state at the start time, taken after fmi2ExitInitializationMode and before the first
    step, is a state like any other: set back after three steps, the instance steps again
    exactly as it did from there (every output of the three steps, bit for bit)."""
    inst = opened(fmus_of("native")[model], "start", **({"xC0": 0.05} if model == "BallInShell" else {}))
    inst.initialize()
    state = inst.fmu.getFMUstate()
    outputs = [n for n, v in inst.vars.items() if v.causality == "output" and v.type == "Real"]
    runs = []
    for _ in range(2):
        rows = []
        for k in range(3):
            inst.fmu.doStep(k * H, H)
            rows.append(inst.reals(outputs))
        runs.append(rows)
        inst.fmu.setFMUstate(state)
    assert runs[0] == runs[1]
    inst.fmu.freeFMUstate(state)


@pytest.mark.parametrize("model", MODELS)
def test_boolean_status_answers_terminated_only(opened, fmus_of, model):
    """fmi2GetBooleanStatus (co-simulation): fmi2Terminated is answered (fmi2OK, false: these
    FMUs never end a simulation themselves); the other kinds have no Boolean answer (fmi2Discard,
    as FMI 2.0.4, 4.2.3 allows)."""
    inst = _start(opened, fmus_of, model)
    assert inst.fmu.getBooleanStatus(3) == 0  # fmi2Terminated = 3: false
    for kind in (0, 1, 2):  # fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime
        with pytest.raises(FMICallException) as info:
            inst.fmu.getBooleanStatus(kind)
        assert info.value.status == DISCARD


@pytest.mark.parametrize("model", MODELS)
def test_status_answers_the_step_status_only(opened, fmus_of, model):
    """fmi2GetStatus: fmi2DoStepStatus is answered (fmi2OK: steps are synchronous, never
    pending); the other kinds, and a number no fmi2StatusKind has, get fmi2Discard."""
    inst = _start(opened, fmus_of, model)
    assert inst.fmu.getStatus(0) == 0  # fmi2DoStepStatus: fmi2OK
    for kind in (1, 2, 3, -1, 4):  # pending, last successful time, terminated; not a kind at all
        with pytest.raises(FMICallException) as info:
            inst.fmu.getStatus(kind)
        assert info.value.status == DISCARD, kind


def test_getters_and_setters_take_any_number_of_references(opened, fmus_of):
    """A getter or setter takes nvr references in one call, any number, the same one repeated
    too: 150 (more than the plumbing's chunks of 64) of each type read back as the value one
    reference gives, and 150 set leave the last value."""
    ball = _start(opened, fmus_of, "BallInShell")
    v = {n: ball.vars[n].valueReference for n in ("xC", "valid", "x1O")}
    assert ball.get("valid") is True  # (a value the zeros of an unwritten buffer are not)
    assert ball.fmu.getReal([v["xC"]] * 150) == [ball.get("xC")] * 150
    assert ball.fmu.getBoolean([v["valid"]] * 150) == [ball.fmu.getBoolean([v["valid"]])[0]] * 150
    ints = [n for n, var in ball.vars.items() if var.type == "Integer"]
    vi = ball.vars[ints[0]].valueReference
    assert ball.fmu.getInteger([vi] * 150) == [ball.fmu.getInteger([vi])[0]] * 150
    ball.fmu.setReal([v["x1O"]] * 150, [1e-4 * i for i in range(150)])
    assert ball.get("x1O") == 1e-4 * 149


def _refusals_of_forged_states(inst, blob, good, fmt, value):
    """{the model's reason: [offsets]}: the state `blob` with the field of struct format `fmt`
    at each offset of the model's data (after the header and the values) set to `value`, its
    checksum made right, set into `inst` (put back to `good` when it is accepted)."""
    size, found = struct.calcsize(fmt), {}
    for at in range(HEADER_BYTES + 8 * len(inst.vars), len(blob) - 4 - size + 1, size):
        forged = bytearray(blob)
        forged[at:at + size] = struct.pack(fmt, value)
        if forged == blob:
            continue
        state = inst.fmu.deSerializeFMUstate(_sealed(forged))
        n = len(inst.messages)
        try:
            inst.fmu.setFMUstate(state)
            inst.fmu.setFMUstate(good)
        except FMICallException:
            why = [m.split("FMU state refused: ", 1)[1] for s, m in inst.messages[n:] if "FMU state refused: " in m]
            if why:
                found.setdefault(why[0], []).append(at)
        inst.fmu.freeFMUstate(state)
    return found


def test_impossible_dynamic_states_are_refused_and_a_missing_step_size_is_chosen(opened, fmus_of):
    """BallInShell checks the dynamic part of a state it is given (docs/conformance.md, "FMU
    state"). Where each field lies is found by setting every int, then every double, of the
    model's data in turn (checksum made right): with input_mode 1 (2 fit points, up to 6 more
    samples kept) an input history of 9 samples, a negative coupling-error sum (a sum of
    squares) and an input sample that is NaN are each refused with their reason, and the
    instance keeps its state. The ball state's step size h just before the history's count (the
    struct's order) is not checked: NaN means "choose one", and so must 0 (no step is 0 long):
    a state with h = 0 steps on exactly like the same state with h = NaN."""
    ball = opened(fmus_of("native")["BallInShell"], "forged", xC0=0.05, input_mode=1)
    ball.initialize()
    for k in range(6):
        ball.set(x1O=0.001 * k * k)
        ball.fmu.doStep(k * H, H)
    good = ball.fmu.getFMUstate()
    blob = bytes(ball.fmu.serializeFMUstate(good))
    before = ball.reals(("xC", "yC", "N"))
    count = _refusals_of_forged_states(ball, blob, good, "<i", 2 + 6 + 1)
    assert list(count.get("its input history has a wrong number of samples", [])) != [], count
    negative = _refusals_of_forged_states(ball, blob, good, "<d", -0.5)
    assert "its coupling-error sums are not finite" in negative, negative
    nan = _refusals_of_forged_states(ball, blob, good, "<d", float("nan"))
    assert "an input sample is not finite" in nan, nan
    assert len(nan.get("its mid-interval acceleration is not finite", [])) == 3, nan  # its (t, ax, ay)
    assert ball.reals(("xC", "yC", "N")) == before  # every refusal kept the state
    # the step size: the double before the history's count
    h_at = count["its input history has a wrong number of samples"][0] - 8
    runs = []
    for h in (float("nan"), 0.0):
        forged = bytearray(blob)
        forged[h_at:h_at + 8] = struct.pack("<d", h)
        inst = opened(fmus_of("native")["BallInShell"], f"h{h}", xC0=0.05, input_mode=1)
        inst.fmu.setFMUstate(inst.fmu.deSerializeFMUstate(_sealed(forged)))
        rows = []
        for k in range(6, 12):
            inst.set(x1O=0.001 * k * k)
            inst.fmu.doStep(k * H, H)
            rows.append(inst.reals(("xC", "yC", "N", "wz")))
        runs.append(rows)
    assert runs[0] == runs[1]



def test_a_hybrid_state_with_impossible_bookkeeping_is_refused(opened, fmus_of):
    """contact_model = 2 keeps the run's bookkeeping in the state: the impact energy (J), the
    impact count and the largest impact speed (m/s), each >= 0 and the count whole, and the first
    slip and first flight times (s), each NaN (not yet) or finite. A ball rolled up the fixed
    chamber (wx0 = 96 rad/s, mu = 0.3) slips at 0.18 s and is sliding at 0.2 s, not yet flown: its
    state with the energy -1 J, the count 0.5, the speed -1 m/s, or either time +inf or -inf (in
    every copy the state holds, found as t_first_slip's bytes followed by a NaN; checksum made
    right), the rebound or W-lost flag 0.5, or the Zeno hold's time (NaN: not held) or its window
    infinite or the time finite without its window, is refused naming the bookkeeping, and the instance keeps its state and steps on."""
    ball = opened(fmus_of("native")["BallInShell"], "hybrid", contact_model=2, wx0=96.0, mu=0.3)
    ball.initialize()
    for k in range(100):
        ball.fmu.doStep(k * H, H)
    t_slip = ball.get("t_first_slip")
    assert ball.get("mode") == 2 and 0.1 < t_slip < 0.19 and ball.get("t_first_flight") == 1e300  # never (yet)
    good = ball.fmu.getFMUstate()
    blob = bytes(ball.fmu.serializeFMUstate(good))
    data = HEADER_BYTES + 8 * len(ball.vars)  # the model's data, after the header and the values
    slots = [at for at in range(data, len(blob) - 4 - 16 + 1)
             if struct.unpack_from("<d", blob, at)[0] == t_slip and math.isnan(struct.unpack_from("<d", blob, at + 8)[0])]
    assert slots
    before = ball.reals(("xC", "yC", "zC", "N"))
    # the state at the instance's time names the bookkeeping; a copy in the corrector's history
    # is refused as a corrected state
    book = "FMU state refused: its hybrid bookkeeping (impacts, losses, first times, seed, flags, hold) is not valid"
    reasons = {book, "FMU state refused: a corrected state is not one it can continue from"}
    # ((offset from t_first_slip, value), ...): E_impact, n_impacts, v_impact_max, t_first_slip, t_first_flight;
    # the rebound and W-lost flags not 0 or 1; the Zeno hold's time t_held infinite, or finite without its
    # window (NaN: not held), and either of the two infinite with the other finite
    forgeries = [((-24, -1.0),), ((-16, 0.5),), ((-8, -1.0),), ((0, math.inf),), ((0, -math.inf),), ((8, math.inf),),
                 ((8, -math.inf),), ((56, 0.5),), ((64, 0.5),), ((72, math.inf),), ((72, 0.1),),
                 ((72, math.inf), (80, 0.01)), ((72, 0.1), (80, math.inf))]
    said = {}
    for at in slots:
        for forgery in forgeries:
            forged = bytearray(blob)
            for field, value in forgery:
                struct.pack_into("<d", forged, at + field, value)
            state = ball.fmu.deSerializeFMUstate(_sealed(forged))
            n = len(ball.messages)
            with pytest.raises(FMICallException) as info:
                ball.fmu.setFMUstate(state)
            assert info.value.status == ERROR
            why = [m.split("': ", 1)[1] for s, m in ball.messages[n:] if s == ERROR and "FMU state refused: " in m]
            assert len(why) == 1 and why[0] in reasons, (forgery, ball.messages[n:])
            said.setdefault(forgery, set()).add(why[0])
            ball.fmu.freeFMUstate(state)
    assert len(said) == len(forgeries) and all(book in r for r in said.values()), said  # named for each
    assert ball.reals(("xC", "yC", "zC", "N")) == before
    ball.fmu.doStep(100 * H, H)  # and it carries on
    assert ball.get("mode") == 2


def test_a_state_whose_newest_input_sample_is_at_its_time_is_refused(opened, fmus_of):
    """A step pushes the inputs at its start and ends later, so in every state BallInShell
    writes after a step the newest input sample is older than the state's time (only
    initialisation's one sample is at it). A history of several samples whose newest is moved
    to the state's time (checksum made right), which a step would then replace, with the one
    before it as the input-consistency check's previous sample (input_mode 1), is refused by
    name, and the instance keeps its state."""
    ball = opened(fmus_of("native")["BallInShell"], "newest", xC0=0.05, input_mode=1)
    ball.initialize()
    t = 0.0
    for k in range(6):  # consistent inputs (x = 1.5 t^2 m): the history keeps every sample
        ball.set(x1O=1.5 * t * t, vx1O=3.0 * t, ax1O=3.0)
        ball.fmu.doStep(t, H)
        newest = t  # the newest sample's time: the last step's start
        t += H
    assert ball.get("valid")
    good = ball.fmu.getFMUstate()
    blob = bytes(ball.fmu.serializeFMUstate(good))
    before = ball.reals(("xC", "yC", "N"))
    found = _refusals_of_forged_states(ball, blob, good, "<d", t)
    reason = "its newest input sample is not before its time (only a history of one sample may end there)"
    assert reason in found, found
    # the field refused for it is the newest sample's time, not another double of the data
    assert [struct.unpack_from("<d", blob, at)[0] for at in found[reason]] == [newest], found[reason]
    assert ball.reals(("xC", "yC", "N")) == before
    ball.set(x1O=1.5 * t * t, vx1O=3.0 * t, ax1O=3.0)
    ball.fmu.doStep(t, H)  # and it carries on
    assert ball.get("valid")


@pytest.mark.parametrize("model", MODELS + ("Structure",))
def test_a_state_built_before_initialisation_is_refused(opened, fmus_of, model):
    """A state taken in the instantiated state holds no configuration (the model is set up
    when initialisation ends): one whose built flag says otherwise (checksum made right) is
    refused naming the flag and the state, and the instance keeps its state; the same state with
    the flag 0 is accepted."""
    inst = opened(fmus_of("native")[model], "unbuilt")
    blob = bytearray(inst.fmu.serializeFMUstate(inst.fmu.getFMUstate()))
    built_at = HEADER_BYTES - 24  # int32 built, uint32 reserved, double t_start, double t
    assert struct.unpack_from("<i", blob, built_at)[0] == 0
    inst.fmu.setFMUstate(inst.fmu.deSerializeFMUstate(_sealed(blob)))
    struct.pack_into("<i", blob, built_at, 1)
    state = inst.fmu.deSerializeFMUstate(_sealed(blob))
    with pytest.raises(FMICallException) as info:
        inst.fmu.setFMUstate(state)
    assert info.value.status == ERROR
    assert _errors(inst)[-1] == (f"{model} 'unbuilt': fmi2SetFMUstate: state refused, instance unchanged: built "
                                 "flag 1 in state instantiated, expected 0 (the model is set up when "
                                 "initialisation ends)")
    inst.initialize()  # and it carries on
    inst.fmu.doStep(0.0, H)


def test_an_induction_motor_state_with_more_load_samples_than_it_keeps_is_refused(opened, fmus_of):
    """InductionMotor keeps the last four load samples (M_reaction at the communication points):
    a state whose sample count, found by setting every int of the model's data to 5 in turn
    (checksum made right), says five is refused with the model's reason, instance unchanged."""
    motor = _start(opened, fmus_of, "InductionMotor")
    good = motor.fmu.getFMUstate()
    blob = bytes(motor.fmu.serializeFMUstate(good))
    before = motor.get("psi_dot")
    found = _refusals_of_forged_states(motor, blob, good, "<i", 5)
    assert "its drive state or load samples are not valid" in found, found
    assert motor.get("psi_dot") == before


def test_a_state_from_another_configuration_restores_that_configuration(opened, fmus_of):
    """A state carries its parameters: set into an instance with other parameters, the
    configuration is rebuilt from the state's (checked like at initialisation) and the
    instance continues exactly like the one the state came from."""
    heavy = _start(opened, fmus_of, "BallInShell", name="heavy", m=2.0, input_mode=2)
    light = _start(opened, fmus_of, "BallInShell", name="light", m=0.51)
    blob = heavy.fmu.serializeFMUstate(heavy.fmu.getFMUstate())
    state = light.fmu.deSerializeFMUstate(blob)
    light.fmu.setFMUstate(state)
    assert light.get("m") == 2.0 and light.get("input_mode") == 2
    for k in range(3, 10):
        x = 0.01 * math.sin(5.0 * k * H)
        for inst in (heavy, light):
            inst.set(x1O=x)
            inst.fmu.doStep(k * H, H)
    assert light.reals(("N", "xC", "M_reaction")) == heavy.reals(("N", "xC", "M_reaction"))
    # the heavy ball, off-centre (xC0 = 0.05 m of R - r = 0.225 m): N near m g cos(12.8 deg)
    assert light.get("N") == pytest.approx(2.0 * 9.81 * math.cos(math.asin(0.05 / 0.225)), rel=0.02)


def test_serialising_into_a_short_buffer_is_refused_naming_the_size_asked_for(opened, fmus_of):
    """fmi2SerializeFMUstate with a buffer one byte shorter than fmi2SerializedFMUstateSize
    said, or none, is refused with the sizes and the function to ask, and writes nothing."""
    inst = _start(opened, fmus_of, "MotorStartup")
    state = inst.fmu.getFMUstate()
    size = ctypes.c_size_t()
    assert _raw(inst, "fmi2SerializedFMUstateSize", state, ctypes.byref(size)) == 0
    buf = ctypes.create_string_buffer(b"\xaa" * size.value, size.value)
    assert _raw(inst, "fmi2SerializeFMUstate", state, buf, ctypes.c_size_t(size.value - 1)) == ERROR
    assert _errors(inst)[-1] == (f"MotorStartup 'motorstartup': fmi2SerializeFMUstate: the buffer has "
                                 f"{size.value - 1} bytes, fewer than fmi2SerializedFMUstateSize = {size.value}")
    assert buf.raw == b"\xaa" * size.value
    assert _raw(inst, "fmi2SerializeFMUstate", state, None, size) == ERROR
    assert _errors(inst)[-1].endswith("fmi2SerializeFMUstate: no buffer given")
    inst.fmu.freeFMUstate(state)


def test_a_structure_state_with_a_nan_anywhere_is_refused_or_steps_to_finite_outputs(opened, fmus_of):
    """Every double of the Structure's data (its configuration, modal state, input samples) set
    to NaN in turn, the checksum made right: fmi2SetFMUstate either refuses the state (the modal
    state and the input samples are checked) or the instance steps on to finite outputs (what
    the configuration holds is rebuilt from the parameters); never a NaN answered with fmi2OK."""
    s = opened(fmus_of("native")["Structure"], "nan_state", F0_x=10.0)
    s.initialize()
    for k in range(4):
        s.set(Fx_ball=0.5 * k)
        s.fmu.doStep(k * H, H)
    good = s.fmu.getFMUstate()
    blob = bytes(s.fmu.serializeFMUstate(good))
    outputs = [n for n, v in s.vars.items() if v.causality == "output" and v.type == "Real"]
    refused = 0
    for at in range(HEADER_BYTES + 8 * len(s.vars), len(blob) - 4 - 8 + 1, 8):
        forged = bytearray(blob)
        forged[at:at + 8] = struct.pack("<d", float("nan"))
        state = s.fmu.deSerializeFMUstate(_sealed(forged))
        try:
            s.fmu.setFMUstate(state)
        except FMICallException:
            refused += 1
            assert any("its modal state or input samples are not valid" in m for _, m in s.messages[-2:])
        else:
            s.fmu.doStep(4 * H, H)
            values = s.reals(outputs)
            assert all(math.isfinite(x) for x in values), (at, dict(zip(outputs, values)))
        finally:
            s.fmu.setFMUstate(good)
            s.fmu.freeFMUstate(state)
    assert refused > 0


def test_a_wrong_guid_is_refused_naming_both(fmus_of):
    """fmi2Instantiate with another GUID than the binary's: refused (NULL), the message names
    FMI 2.0's GUID, the one given and the binary's."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    from fmpy.logging import addLoggerProxy

    path = fmus_of("native")["MotorStartup"]
    md = read_model_description(str(path))
    said = []
    callbacks = fmi2CallbackFunctions()
    logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, message: said.append(message.decode()))
    callbacks.logger = logger
    addLoggerProxy(ctypes.byref(callbacks))
    fmu = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=extract(str(path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="guid")
    with pytest.raises(Exception):
        fmu.instantiate(callbacks=callbacks, loggingOn=True)
    assert said == [f"MotorStartup 'guid': fmi2Instantiate: GUID {{00000000-0000-0000-0000-000000000000}} does not "
                    f"match this binary's {md.guid}"], said
