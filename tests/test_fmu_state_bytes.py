"""Serialised FMU states, byte by byte (docs/conformance.md, "FMU state"): every byte of a
serialised state of every model changed (one bit, a different bit from byte to byte) is
refused at fmi2DeSerializeFMUstate with a message naming what failed, and the instance keeps
its state; an intact state round-trips bit for bit and the instance steps on exactly like
the one it came from.

The native flavour through fmpy on the built FMUs; the pythonfmu flavour's serialised form
(`Slave._fmu_state_to_bytes` / `_fmu_state_from_bytes`, what pythonfmu's C wrapper calls)
on its slaves in this process (tests/mutation/inprocess.py), where a refusal does not end
the instance: the built pythonfmu FMUs refuse a changed byte in tests/conformance/test_state.py.
The checksum is checked against zlib.crc32, independently of the FMUs' own code.
"""
from __future__ import annotations

import sys
import zlib
from collections import Counter
from pathlib import Path

import pytest
from fmpy.fmi1 import FMICallException

from fmu_instance import Opened

sys.path.insert(0, str(Path(__file__).parent / "mutation"))
from inprocess import FATAL, OK, open_fmu as open_in_process  # noqa: E402

ERROR = 3
MODELS = ("BallInShell", "MotorStartup", "InductionMotor", "Fig1Drive", "Structure")
START = {"BallInShell": {"xC0": 0.05}}  # off-centre: the ball rolls, its state changes every step
H = 0.002
HEADER = 160  # the native header's bytes (fmu_src/native/fmu_state.h)


@pytest.fixture
def opened():
    o = Opened()
    yield o.open
    o.close_all()


def _flipped(blob: bytes, i: int) -> bytes:
    b = bytearray(blob)
    b[i] ^= 1 << (i % 8)
    return bytes(b)


def _checksum_text(blob: bytes) -> str:
    stored, computed = int.from_bytes(blob[-4:], "little"), zlib.crc32(blob[:-4])
    assert stored != computed
    return f"checksum mismatch: stored 0x{stored:08x}, computed 0x{computed:08x}"


def _native_reason(blob: bytes, bad: bytes, i: int) -> str:
    """What the native check must say for byte i changed (fmu_state.c: magic, format and FMI
    version, then the size its header gives, then the checksum over everything)."""
    if i < 8:
        shown = "".join(chr(c) if 0x20 <= c < 0x7F else "?" for c in bad[:8])
        return f"magic '{shown}', expected 'ballmill': not a ballmill FMU state"
    if i < 12:
        return f"format version {int.from_bytes(bad[8:12], 'little')}, expected 5"
    if i < 16:
        return f"written by the FMI {int.from_bytes(bad[12:16], 'little')} plumbing, expected FMI 2"
    if 32 <= i < 40:
        return f"size {len(bad)}, expected {int.from_bytes(bad[32:40], 'little')} (the size its header gives)"
    return _checksum_text(bad)


def _native_outputs(inst):
    return {n: inst.get(n) for n, v in inst.vars.items() if v.causality in ("output", "parameter", "input")}


def _native_started(opened, fmus_of, model, name, **extra):
    inst = opened(fmus_of("native")[model], name, **{**START.get(model, {}), **extra})
    inst.initialize()
    for k in range(3):
        inst.fmu.doStep(k * H, H)
    return inst


@pytest.mark.parametrize("model", MODELS)
def test_every_changed_byte_of_a_native_state_is_refused_named_and_the_instance_kept(opened, fmus_of, model):
    inst = _native_started(opened, fmus_of, model, "victim")
    ref = _native_started(opened, fmus_of, model, "reference")
    saved = inst.fmu.getFMUstate()
    blob = bytes(inst.fmu.serializeFMUstate(saved))
    assert blob[:8] == b"ballmill" and blob[-4:] == zlib.crc32(blob[:-4]).to_bytes(4, "little")
    before = _native_outputs(inst)
    prefix = f"{model} 'victim': fmi2DeSerializeFMUstate: state refused: "
    accepted, kinds = [], Counter()
    for i in range(len(blob)):
        bad = _flipped(blob, i)
        try:
            state = inst.fmu.deSerializeFMUstate(bad)
        except FMICallException as e:
            assert e.status == ERROR and inst.messages[-1][0] == ERROR
            message = inst.messages[-1][1]
            assert message == prefix + _native_reason(blob, bad, i) + (
                " (the state was changed after it was serialised)" if "checksum" in message else ""), (i, message)
            kinds[message[len(prefix):].split(" ", 1)[0]] += 1
            continue
        accepted.append(i)
        inst.fmu.setFMUstate(state)
        inst.fmu.freeFMUstate(state)
    assert accepted == [], f"{len(accepted)} of {len(blob)} changed bytes accepted, e.g. at {accepted[:10]}"
    assert kinds["checksum"] == len(blob) - 24 and kinds["magic"] == 8, kinds
    # the refusals changed nothing: same values, and the instance steps on exactly like one
    # that never saw them
    assert _native_outputs(inst) == before
    for k in range(3, 8):
        inst.fmu.doStep(k * H, H)
        ref.fmu.doStep(k * H, H)
    assert _native_outputs(inst) == _native_outputs(ref)
    inst.fmu.freeFMUstate(saved)


@pytest.mark.parametrize("model", MODELS)
def test_a_native_state_round_trips_bit_for_bit_and_steps_on_identically(opened, fmus_of, model):
    source = _native_started(opened, fmus_of, model, "source")
    blob = bytes(source.fmu.serializeFMUstate(source.fmu.getFMUstate()))
    # into a fresh instance (other parameters for the ball): the state brings its configuration
    fresh = opened(fmus_of("native")[model], "fresh", **({"m": 2.0} if model == "BallInShell" else {}))
    fresh.initialize()
    state = fresh.fmu.deSerializeFMUstate(blob)
    assert bytes(fresh.fmu.serializeFMUstate(state)) == blob
    fresh.fmu.setFMUstate(state)
    fresh.fmu.freeFMUstate(state)
    # header and every variable as saved; the model's configuration is rebuilt from the
    # parameters (BallInShell's holds caches that start empty), its dynamic state taken over
    values = HEADER + 8 * len(fresh.vars)
    assert bytes(fresh.fmu.serializeFMUstate(fresh.fmu.getFMUstate()))[:values] == blob[:values]
    for k in range(3, 10):
        source.fmu.doStep(k * H, H)
        fresh.fmu.doStep(k * H, H)
    assert _native_outputs(fresh) == _native_outputs(source)
    # and the whole state, caches included, is the source's again, byte for byte
    assert bytes(fresh.fmu.serializeFMUstate(fresh.fmu.getFMUstate())) == \
        bytes(source.fmu.serializeFMUstate(source.fmu.getFMUstate()))


def _python_started(model):
    fmu = open_in_process(model, **START.get(model, {}))
    assert fmu.init() == OK, fmu.messages()
    for _ in range(3):
        assert fmu.step(H) == OK, fmu.messages()
    return fmu


def _python_reason(bad: bytes, i: int, line: int) -> str:
    """What state_from_bytes must say for byte i changed: in the header line, not a ballmill
    state or another format; anywhere else, the checksum."""
    magic = b"ballmill FMU state, format "
    if i < len(magic):
        return f"it begins with {bad[:len(magic)]!r}, expected {magic!r}: not a ballmill FMU state"
    if i < line:
        head = bad.split(b"\n", 1)[0][len(magic):]
        return f"format version {head[:20].decode('ascii', 'replace')}, expected 6"
    return _checksum_text(bad)


@pytest.mark.parametrize("model", MODELS)
def test_every_changed_byte_of_a_pythonfmu_state_is_refused_named_and_the_instance_kept(model):
    fmu = _python_started(model)
    ref = _python_started(model)
    blob = fmu.serialize(fmu.get_state())
    line = blob.index(b"\n") + 1
    assert blob[:line] == b"ballmill FMU state, format 6\n"
    assert blob[-4:] == zlib.crc32(blob[:-4]).to_bytes(4, "little")
    before = fmu.outputs()
    prefix = f"{model}: fmi2DeSerializeFMUstate: FMU state refused, the instance keeps its state: "
    accepted = []
    for i in range(len(blob)):
        bad = _flipped(blob, i)
        n = len(fmu.log)
        st, state = fmu.deserialize(bad)
        if st == OK:
            accepted.append(i)
            continue
        assert st == FATAL
        message = fmu.messages(n)
        expected = _python_reason(bad, i, line)
        assert message.startswith(prefix + expected), (i, message)
    assert accepted == [], f"{len(accepted)} of {len(blob)} changed bytes accepted, e.g. at {accepted[:10]}"
    assert fmu.outputs() == before
    # an intact state round-trips bit for bit, into the same instance, and it steps on like
    # one that never saw the refused ones
    st, state = fmu.deserialize(blob)
    assert st == OK and fmu.set_state(state) == OK
    assert fmu.serialize(fmu.get_state()) == blob
    for _ in range(5):
        assert fmu.step(H) == OK and ref.step(H) == OK
    assert fmu.outputs() == ref.outputs()


def test_a_state_whose_parameters_break_the_model_s_rules_is_refused_at_set_and_the_instance_kept(opened, fmus_of):
    """A state with an intact checksum whose parameters pass their declared ranges but not the
    model's own rules (r = 0.3 m > R = 0.25 m: r's declared range allows it) is refused when it
    is set, as the same values are at initialisation, and the instance steps on unchanged."""
    import struct

    inst = _native_started(opened, fmus_of, "BallInShell", "victim")
    ref = _native_started(opened, fmus_of, "BallInShell", "reference")
    saved = inst.fmu.getFMUstate()
    blob = bytearray(inst.fmu.serializeFMUstate(saved))
    at = HEADER + 8 * inst.vars["r"].valueReference
    assert struct.unpack_from("<d", blob, at)[0] == inst.get("r") == 0.025
    struct.pack_into("<d", blob, at, 0.3)
    blob[-4:] = zlib.crc32(bytes(blob[:-4])).to_bytes(4, "little")
    state = inst.fmu.deSerializeFMUstate(bytes(blob))  # the bytes are whole: only the physics is wrong
    before = _native_outputs(inst)
    with pytest.raises(FMICallException) as e:
        inst.fmu.setFMUstate(state)
    assert e.value.status == ERROR
    said = " | ".join(m for _, m in inst.messages[-2:])
    assert "fmi2SetFMUstate: state refused" in said and "instance unchanged" in said
    assert "R must be larger than r" in said and "r = 0.3 m" in said, said
    assert _native_outputs(inst) == before
    for k in range(3, 6):
        inst.fmu.doStep(k * H, H)
        ref.fmu.doStep(k * H, H)
    assert _native_outputs(inst) == _native_outputs(ref)
    inst.fmu.freeFMUstate(state)
    inst.fmu.freeFMUstate(saved)
