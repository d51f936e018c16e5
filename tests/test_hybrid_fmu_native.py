"""The hybrid ball (contact_model = 2) in the native BallInShell FMU, what only the native flavour
has or what is checked on it alone (the flavours' agreement: tests/test_flavours.py; the library
against the FMU, its balances and refusals: tests/test_hybrid_fmu.py):

* a scene that keeps rolling gives contact_model = 1's numbers, every output bit for bit (while
  the ball rolls, the hybrid runs the rolling model without the work quadrature);
* FMU states in sliding and in flight: restored, the instance steps on to the same outputs; the
  serialised bytes round-trip identically (mode, state and bookkeeping are in them), and a fresh
  instance that takes them steps on to the same outputs;
* Model Exchange refuses contact_model = 2, naming it;
* FMI 3.0 (built from the same model file) returns early at the mode switch, at the time the
  hybrid driver located it.

The valgrind run of the C host with contact_model = 2 is in tests/test_native_hosts.py.

The scene off rolling: a fixed chamber (inputs 0), the ball started at the bottom rolling at
|v_C| = r wx0 = 2.4 m/s, between sqrt(10 g d / 7) = 1.8 and sqrt(27 g d / 7) = 2.9 m/s: it rolls
up the wall, slips at 0.18 s (mu = 0.3), leaves the wall above the equator at 0.25 s and flies.
"""
from __future__ import annotations

import shutil
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description

from fmu_instance import Opened

H = 0.002
UP = dict(contact_model=2, wx0=96.0, mu=0.3)  # rolls up the fixed chamber, slips, flies


@pytest.fixture
def opened():
    o = Opened()
    yield o.open
    o.close_all()


def _outputs(inst):
    return {n: inst.get(n) for n, v in inst.vars.items() if v.causality == "output"}


def _run(name, build_dir, overrides, stop):
    from ballmill.scenario import runner

    sc, models, paths = runner.prepare(name, list(overrides), build_dir, log=lambda m: None, flavour="native")
    sc.stop = min(sc.stop, sc.start + stop)
    return runner.run(sc, models, paths, progress=False, echo=False)


def test_a_scene_that_keeps_rolling_gives_contact_model_1s_numbers(fmu_build_dir):
    """The fast start at t0 = 2.5 s (the crank's reaction torque fed back to the drive) rolls
    throughout: every column of the coupled run, the ball's new outputs included (mode 1, no slip,
    gap, impacts or losses, first times never), bit for bit."""
    a = _run("fast_start", fmu_build_dir, ("ball.contact_model=1",), 1.0)
    b = _run("fast_start", fmu_build_dir, ("ball.contact_model=2",), 1.0)
    assert a.success and b.success, (a.message, b.message)
    assert a.columns == b.columns and a.data.shape == b.data.shape and len(a.data) == 501
    for j, name in enumerate(a.columns):
        assert np.array_equal(a.data[:, j], b.data[:, j]), (name, float(np.max(np.abs(a.data[:, j] - b.data[:, j]))))
    mode = b.data[:, b.columns.index("ball.mode")]
    assert np.all(mode == 1) and np.all(b.data[:, b.columns.index("ball.valid")] == 1)


def _stepped_to(opened, fmus_of, name, t_stop):
    inst = opened(fmus_of("native")["BallInShell"], name, **UP)
    inst.initialize()
    t = 0.0
    while t < t_stop - 1e-12:
        inst.fmu.doStep(t, H)
        t += H
    return inst, t


@pytest.mark.parametrize("t_stop, mode", [(0.2, 2), (0.3, 0)], ids=["sliding", "flight"])
def test_a_state_in_sliding_and_in_flight_restores_and_round_trips_its_bytes(opened, fmus_of, t_stop, mode):
    """get, 5 steps, set, the same 5 steps: the same outputs; the state serialised, deserialised
    in a fresh instance and serialised again: the same bytes; set there, the header and every
    variable as saved, and that instance steps on to the same outputs too (the mode, the free
    state and the bookkeeping travel in the bytes)."""
    inst, t = _stepped_to(opened, fmus_of, "src", t_stop)
    assert inst.get("mode") == mode and inst.get("valid") and inst.get("t_first_slip") < 0.19
    saved = inst.fmu.getFMUstate()
    blob = bytes(inst.fmu.serializeFMUstate(saved))

    def five(i, t0):
        outs = []
        for k in range(5):
            i.fmu.doStep(t0 + k * H, H)
            outs.append(_outputs(i))
        return outs

    first = five(inst, t)
    inst.fmu.setFMUstate(saved)
    assert five(inst, t) == first
    other = opened(fmus_of("native")["BallInShell"], "dst", **UP)
    other.initialize()
    state = other.fmu.deSerializeFMUstate(blob)
    assert bytes(other.fmu.serializeFMUstate(state)) == blob
    other.fmu.setFMUstate(state)
    other.fmu.freeFMUstate(state)
    values = 160 + 8 * len(other.vars)  # the header and every variable as saved (the configuration is rebuilt)
    assert bytes(other.fmu.serializeFMUstate(other.fmu.getFMUstate()))[:values] == blob[:values]
    assert five(other, t) == first
    assert all(o["mode"] == mode for o in first) and first[0]["zC"] != first[-1]["zC"]  # the ball moves on
    inst.fmu.freeFMUstate(saved)


def test_model_exchange_refuses_the_hybrid_ball_naming_contact_model(fmus_of):
    """Model Exchange integrates the rolling ball's (n, omega): contact_model = 2 is refused at
    the exit of initialisation, the message naming the parameter, its value and what is supported."""
    from fmpy import simulate_fmu

    msgs = []

    def logger(env, name, status, category, message):
        msgs.append(message.decode())

    with pytest.raises(Exception):
        simulate_fmu(str(fmus_of("native")["BallInShell"]), fmi_type="ModelExchange", stop_time=0.1,
                     start_values={"contact_model": 2}, logger=logger)
    text = " ".join(msgs)
    assert "contact_model = 2 (supported: contact_model = 1" in text, text


def test_fmi3_returns_early_at_the_slip_the_hybrid_driver_located(fmus_of, fmu_build_dir, tmp_path):
    """FMI 3.0 co-simulation (the C host, tests/hosts/fmi_host.c, with early return and event
    mode) on the scene that rolls up the wall: the step that meets the slip returns early, within
    1e-9 s of t_first_slip, the time the FMI 2.0 instance's driver located the slip at."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler (cc)")
    from ballmill.fmi import native
    from ballmill.fmi.interface import BALL_IN_SHELL as B

    from fmu_instance import Instance

    ref = Instance(fmus_of("native")["BallInShell"], "ref2", **UP)
    try:
        ref.initialize()
        for k in range(100):
            ref.fmu.doStep(k * H, H)
        t_slip = ref.get("t_first_slip")
    finally:
        ref.close()
    host = tmp_path / "fmi3_host"
    proc = subprocess.run(["cc", "-O2", "-Wall", "-Wextra", "-Werror", "-DFMI_VERSION=3", "-I",
                           str(native.fmi_headers_dir()), str(native.ROOT / "tests" / "hosts" / "fmi_host.c"),
                           "-o", str(host), "-ldl"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    path = fmu_build_dir / "fmi3" / "BallInShell.fmu"
    md = read_model_description(str(path))
    d = tmp_path / "fmu3"
    zipfile.ZipFile(path).extractall(d)
    binary = d / "binaries" / native.platform_dir_fmi3() / f"BallInShell{native.shared_suffix()}"
    vr = B.value_reference
    cmd = [str(host), str(binary), md.guid, str(d / "resources") + "/", "100", repr(H), "1",
           str(vr("t_first_slip")), f"I{vr('contact_model')}=2", f"R{vr('wx0')}=96.0", f"R{vr('mu')}=0.3"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr[-3000:]
    first, second = proc.stdout.splitlines()
    _, _, early, *times = second.split()
    assert early == "early" and times, second
    assert 0.17 < t_slip < 0.19 and abs(float(times[0]) - t_slip) < 1e-9, (times, t_slip)
    assert float(first.split()[0]) == pytest.approx(t_slip, abs=1e-9)


def test_a_zeno_sequence_refuses_the_step_with_the_whole_message(opened, fmus_of):
    """Bounces that accumulate (e_n = 0.97, v_rest = 1e-12 m/s: the ball thrown up the fixed
    chamber falls back and hops ever lower) pass the event-rate guard's 100 events within
    100 / (1e4 events/s) = 10 ms in flight at 13.666 s: that step is refused (fmi2Discard) with
    the whole message (the mode, the time, the count and window, the last event, the allowed
    rate), and the instance keeps the last good state."""
    import re

    from fmpy.fmi1 import FMICallException

    inst = opened(fmus_of("native")["BallInShell"], "zeno", **dict(UP, e_n=0.97, v_rest=1e-12))
    inst.initialize()
    t = 0.0
    with pytest.raises(FMICallException) as info:
        while t < 20.0:
            inst.fmu.doStep(t, H)
            t += H
    assert info.value.status == 2 and 13.0 < t < 14.5, (t, info.value)  # fmi2Discard
    said = inst.messages[-1][1]
    m = re.fullmatch(r"BallInShell 'zeno': step from t = (\S+) s refused, last good state kept: the hybrid ball could "
                     r"not be followed from t = (\S+) s in mode flight: stopped at t = (\S+) s: Zeno sequence: 100 "
                     r"events within (\S+) s before t = (\S+) s \(the last: 'impact'\), more than the allowed rate "
                     r"10000 events/s", said)
    assert m, said
    t_from, t_from2, t_stop, window, t_last = (float(x) for x in m.groups())
    assert t_from == t_from2 == t_stop == pytest.approx(t, abs=1e-9)
    assert 0.0 < window <= 0.01 and t <= t_last <= t + H
    kept = _outputs(inst)
    with pytest.raises(FMICallException):
        inst.fmu.doStep(t, H)
    assert _outputs(inst) == kept
