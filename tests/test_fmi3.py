"""The FMI 3.0 archives (build/fmi3/<Model>.fmu: co-simulation with event mode, and Model
Exchange) through fmpy, checked against the FMI 2.0 archives and the library.

- Co-simulation without event mode is FMI 2.0's, bit for bit (the same plumbing, model and
  arithmetic: fmu_instance.c under fmi3.c instead of fmi2.c).
- With event mode, the step where a Boolean output changes (BallInShell's valid latching) returns
  eventHandlingNeeded, and only that step; the numbers stay the same.
- Model Exchange locates the ball's slip where the library does: fmpy's CVode at relative
  tolerance 1e-10 against the library's run at 1e-12 sampled every 0.1 ms, whose crossing
  (interpolated linearly) converges to 0.188323678 s (1e-8 s off at 0.1 ms, measured).
"""

import functools

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy import simulate_fmu as _simulate_fmu
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from ballmill.fmi.interface import INTERFACES
from ballmill.physics.drives.crank import CrankStartup, Fixed
from ballmill.physics.model import BallModel, simulate
from ballmill.physics.params import Ball

MODELS = sorted(INTERFACES)


def _quiet(*args):
    """fmpy's FMI 2.0 logger for simulate_fmu (its native proxy otherwise calls the last logger
    registered in the process, which another test's instance may have left behind freed)"""


def simulate_fmu(*args, **kwargs):
    return _simulate_fmu(*args, logger=_quiet, **kwargs)


@pytest.fixture(scope="module")
def fmi3(fmu_build_dir):
    return {name: fmu_build_dir / "fmi3" / f"{name}.fmu" for name in MODELS}


@pytest.fixture(scope="module")
def fmi2(fmus_of):
    return fmus_of("native")


@pytest.mark.parametrize("model", MODELS)
def test_fmi3_archive_validates_with_both_interfaces(fmi3, model):
    assert validate_fmu(str(fmi3[model])) == []
    md = read_model_description(str(fmi3[model]))
    assert md.fmiVersion == "3.0"
    assert md.coSimulation.hasEventMode and md.coSimulation.mightReturnEarlyFromDoStep
    assert md.modelExchange is not None


SHORT = {"BallInShell": dict(xC0=0.05), "MotorStartup": {}, "InductionMotor": {}, "Fig1Drive": {},
         "Structure": dict(F0_x=10.0)}


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("event_mode", [False, True])
def test_fmi3_co_simulation_is_fmi2_bit_for_bit(fmi2, fmi3, model, event_mode):
    """with and without event mode; early return allowed with event mode: these runs meet no
    event, and a step without one is the step without early return"""
    outputs = [v.name for v in INTERFACES[model].variables if v.causality == "output" and v.type == "Real"]
    kw = dict(fmi_type="CoSimulation", stop_time=0.4, output_interval=2e-3, start_values=SHORT[model],
              output=outputs)
    a = simulate_fmu(str(fmi2[model]), **kw)
    b = simulate_fmu(str(fmi3[model]), use_event_mode=event_mode, early_return_allowed=event_mode, **kw)
    if event_mode:  # events add rows at their times: compare the regular grid
        _, idx = np.unique(b["time"], return_index=True)
        b = b[idx]
    assert np.array_equal(a["time"], b["time"])
    for name in outputs:
        assert np.array_equal(a[name], b[name]), name


def _slave(path, name, event_mode, early=False):
    md = read_model_description(str(path))
    log = []

    def on_message(env, status, category, message):
        log.append((status, message.decode()))
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
    slave.instantiate(loggingOn=True, eventModeUsed=event_mode, earlyReturnAllowed=early,
                      logMessage=on_message)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return slave, vr, log


def test_event_mode_reports_the_step_where_validity_is_lost(fmi3):
    slave, vr, log = _slave(fmi3["BallInShell"], "events", True)
    try:
        slave.setFloat64([vr["wy0"], vr["mu"]], [-20.0, 0.1])
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        slave.updateDiscreteStates()  # FMI 3.0 with event mode: initialisation ends in event mode
        slave.enterStepMode()
        t, h, events = 0.0, 2e-3, []
        while t < 0.3 - 1e-12:
            needed, terminate, early, last = slave.doStep(t, h)
            assert not terminate and not early and last == pytest.approx(t + h, abs=1e-15)
            t = last
            if needed:
                events.append((t, bool(slave.getBoolean([vr["valid"]])[0])))
                slave.enterEventMode()
                slave.updateDiscreteStates()
                slave.enterStepMode()
        t_invalid = slave.getFloat64([vr["t_invalid"]])[0]
        assert events and events[0] == (pytest.approx(t_invalid, abs=1e-12), False)
        # the slip the library finds at 0.18832 s, at the communication point that ends its step
        assert 0.1883 < t_invalid <= 0.1883 + h
    finally:
        slave.terminate()
        slave.freeInstance()


@functools.lru_cache(maxsize=None)
def _slip_library_time():
    """the library's first slip of the ball spun at wy0 = -20 rad/s with mu = 0.1 in a fixed
    chamber (0.188323678 s: the module's docstring)"""
    m = BallModel(Ball(mu=0.1), tol=1e-12)
    return simulate(m, Fixed(), 0.3, 1e-4, m.initial(w0=(0.0, -20.0, 0.0))).t_first_slip


@pytest.mark.parametrize("event_mode", [False, True])
def test_early_return_ends_the_step_at_the_slip(fmi3, event_mode):
    """the step that meets the slip returns early at its time, located where the library has it
    (the co-simulation's integrator at 1e-8 against the library's 1e-12: measured 5e-12 s apart;
    1e-8 s is the library's own sampling error), with the outputs right at it: |F_t|/N = mu;
    with event mode the importer then enters event mode; the next step goes on from there"""
    slave, vr, log = _slave(fmi3["BallInShell"], "early", event_mode, early=True)
    try:
        slave.setFloat64([vr["wy0"], vr["mu"]], [-20.0, 0.1])
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        if event_mode:
            slave.updateDiscreteStates()
            slave.enterStepMode()
        t, h, returns = 0.0, 2e-3, []
        while t < 0.3 - 1e-12:
            step = min(h, 0.3 - t)
            needed, terminate, early, last = slave.doStep(t, step)
            assert not terminate
            if early:
                returns.append((t, last, needed, slave.getBoolean([vr["valid"], vr["rolling"]]),
                                slave.getFloat64([vr["t_invalid"], vr["N"], vr["Ft"]])))
            else:
                assert last == t + step and not needed
            if needed:
                slave.enterEventMode()
                slave.updateDiscreteStates()
                slave.enterStepMode()
            t = last
        assert len(returns) == 1, returns
        t0, last, needed, (valid, rolling), (t_invalid, n, ft) = returns[0]
        assert t0 < last < t0 + h and needed == event_mode
        assert last == pytest.approx(_slip_library_time(), abs=1e-8)
        assert not valid and not rolling and t_invalid == last
        assert ft / n == pytest.approx(0.1, rel=1e-9)  # slip sets in right there
        assert any(s == 1 and f"valid = false from t = {last:.9g} s" in m for s, m in log)
        assert t == 0.3
    finally:
        slave.terminate()
        slave.freeInstance()


def test_early_return_ends_the_step_at_a_time_event(fmi3):
    """MotorStartup's law reaches n0 at t0 = 10.5 ms (its jerk jumps): the step over it returns
    early at t0 exactly, psi_dot = n0 there; a master that does not allow it steps over t0"""
    for early in (True, False):
        slave, vr, log = _slave(fmi3["MotorStartup"], "time", False, early=early)
        try:
            slave.setFloat64([vr["t0"]], [0.0105])
            slave.enterInitializationMode(startTime=0.0)
            slave.exitInitializationMode()
            ends = []
            t = 0.0
            while t < 0.014 - 1e-12:
                needed, terminate, returned, last = slave.doStep(t, 2e-3)
                ends.append((last, returned))
                t = last
            if early:
                assert ends[5] == (0.0105, True) and ends[6][0] == pytest.approx(0.0125, abs=1e-15)
                assert slave.getFloat64([vr["psi_dot"]])[0] == pytest.approx(60.0 * 2 * np.pi / 60.0, rel=1e-15)
            else:
                assert not any(r for _, r in ends) and ends[5][0] == pytest.approx(0.012, abs=1e-15)
        finally:
            slave.terminate()
            slave.freeInstance()


def test_fmpy_simulate_with_early_return_samples_the_slip(fmi3):
    """fmpy's own FMI 3 master, with event mode and early return: a row at the slip's time"""
    r = simulate_fmu(str(fmi3["BallInShell"]), fmi_type="CoSimulation", stop_time=0.2, output_interval=2e-3,
                     start_values=dict(wy0=-20.0, mu=0.1), use_event_mode=True, early_return_allowed=True,
                     output=["valid", "t_invalid"])
    off_grid = [t for t in r["time"] if abs(t / 2e-3 - round(t / 2e-3)) > 1e-6]
    assert off_grid == [pytest.approx(_slip_library_time(), abs=1e-8)] * len(off_grid) and off_grid
    assert r["t_invalid"][-1] == off_grid[0] and not r["valid"][-1]


def test_fmi3_serialised_state_with_a_byte_changed_is_refused(fmi3):
    slave, vr, log = _slave(fmi3["BallInShell"], "state", False)
    try:
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        slave.doStep(0.0, 2e-3)
        blob = bytearray(slave.serializeFMUState(slave.getFMUState()))
        state = slave.deserializeFMUState(bytes(blob))
        slave.setFMUState(state)
        blob[300] ^= 0x01
        n = len(log)
        with pytest.raises(Exception):
            slave.deserializeFMUState(bytes(blob))
        assert any(s == 3 and "fmi3DeserializeFMUState: state refused: checksum mismatch" in m for s, m in log[n:])
    finally:
        slave.terminate()
        slave.freeInstance()


def test_fmi3_model_exchange_locates_the_slip_at_the_librarys_time(fmi3):
    r = simulate_fmu(str(fmi3["BallInShell"]), fmi_type="ModelExchange", stop_time=0.5, output_interval=0.01,
                     start_values=dict(wy0=-20.0, mu=0.1), relative_tolerance=1e-10, output=["valid", "t_invalid"])
    m = BallModel(Ball(mu=0.1), tol=1e-12)
    lib = simulate(m, Fixed(), 0.3, 1e-4, m.initial(w0=(0.0, -20.0, 0.0)))
    assert not r["valid"][-1]
    assert r["t_invalid"][-1] == pytest.approx(lib.t_first_slip, abs=1e-7)


def test_fmi3_model_exchange_motor_startup_has_its_time_events(fmi3):
    r = simulate_fmu(str(fmi3["MotorStartup"]), fmi_type="ModelExchange", stop_time=2.0, output_interval=0.05,
                     start_values=dict(t0=1.13), record_events=True, output=["ax1O"])
    assert 1.13 in r["time"]
    law = CrankStartup(t0=1.13)
    for t, ax in zip(r["time"], r["ax1O"]):
        assert ax == pytest.approx(law.state(float(t))[4], rel=1e-12, abs=1e-12)


def test_fmi3_getters_and_setters_take_any_number_of_references(fmi3):
    """150 references in one call (more than the plumbing's chunks of 64), the same one
    repeated: every value read back is the one a single reference gives, and 150 set leave
    the last value."""
    slave, vr, log = _slave(fmi3["BallInShell"], "many", False)
    try:
        slave.setFloat64([vr["xC0"]], [0.05])
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        slave.doStep(0.0, 2e-3)
        one = slave.getFloat64([vr["xC"]])[0]
        assert one != 0.0 and list(slave.getFloat64([vr["xC"]] * 150)) == [one] * 150
        valid = slave.getBoolean([vr["valid"]])[0]
        assert list(slave.getBoolean([vr["valid"]] * 150)) == [valid] * 150
        slave.setFloat64([vr["x1O"]] * 150, [1e-4 * i for i in range(150)])
        assert slave.getFloat64([vr["x1O"]])[0] == 1e-4 * 149
    finally:
        slave.terminate()
        slave.freeInstance()


def test_fmi3_binary_and_clock_calls_take_no_variable_and_refuse_any(fmi3):
    """These FMUs have no Binary variables and no clocks: a call with no value references does
    nothing (fmi3OK), one that names a variable is refused (fmi3Error) saying why."""
    import ctypes

    slave, vr, log = _slave(fmi3["MotorStartup"], "binary", False)
    try:
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        ref = (ctypes.c_uint32 * 1)(vr["psi"])
        sizes, values = (ctypes.c_size_t * 1)(0), (ctypes.POINTER(ctypes.c_uint8) * 1)()
        clocks = (ctypes.c_bool * 1)()
        dll = slave.dll
        for name, args, what in (("fmi3GetBinary", (sizes, values), "Binary variables"),
                                 ("fmi3SetBinary", (sizes, values), "Binary variables"),
                                 ("fmi3GetClock", (clocks,), "clocks"), ("fmi3SetClock", (clocks,), "clocks")):
            nvalues = (1,) if "Binary" in name else ()
            assert getattr(dll, name)(slave.component, ref, ctypes.c_size_t(0), *args,
                                      *(ctypes.c_size_t(0) for _ in nvalues)) == 0, name
            n = len(log)
            assert getattr(dll, name)(slave.component, ref, ctypes.c_size_t(1), *args,
                                      *(ctypes.c_size_t(1) for _ in nvalues)) == 3, name
            assert any(s == 3 and name in m and f"this FMU has no {what}" in m for s, m in log[n:]), (name, log[n:])
    finally:
        slave.terminate()
        slave.freeInstance()


# the clock calls: the arrays each takes after nValueReferences (a clock's interval, shift, counter,
# resolution, qualifier)
CLOCK_CALLS = {"fmi3GetIntervalDecimal": 2, "fmi3GetIntervalFraction": 3, "fmi3GetShiftDecimal": 1,
               "fmi3GetShiftFraction": 2, "fmi3SetIntervalDecimal": 1, "fmi3SetIntervalFraction": 2,
               "fmi3SetShiftDecimal": 1, "fmi3SetShiftFraction": 2}


def test_fmi3_every_clock_call_takes_no_clock_and_refuses_any(fmi3):
    """The calls on a clock's interval and shift: with no value references they do nothing
    (fmi3OK), with one they are refused (fmi3Error) saying the FMU has no clocks, whatever
    the call."""
    import ctypes

    slave, vr, log = _slave(fmi3["MotorStartup"], "clocks", False)
    try:
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        ref = (ctypes.c_uint32 * 1)(vr["psi"])
        for name, arrays in CLOCK_CALLS.items():
            # a prototype of our own: every array as a pointer to 8 bytes, enough for one value
            call = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t,
                                    *[ctypes.c_void_p] * arrays)((name, slave.dll))
            buffers = [ctypes.cast((ctypes.c_uint64 * 1)(), ctypes.c_void_p) for _ in range(arrays)]
            assert call(slave.component, ctypes.cast(ref, ctypes.c_void_p), 0, *buffers) == 0, name
            n = len(log)
            assert call(slave.component, ctypes.cast(ref, ctypes.c_void_p), 1, *buffers) == 3, name
            assert any(s == 3 and name in m and "this FMU has no clocks" in m for s, m in log[n:]), (name, log[n:])
        # and the one call of scheduled execution
        activate = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_uint32, ctypes.c_double)(
            ("fmi3ActivateModelPartition", slave.dll))
        n = len(log)
        assert activate(slave.component, 0, 0.0) == 3
        assert [m for s, m in log[n:] if s == 3] == [
            "MotorStartup 'clocks': fmi3ActivateModelPartition: this FMU has no scheduled execution"], log[n:]
    finally:
        slave.terminate()
        slave.freeInstance()


def test_fmi3_a_wrong_token_is_named_and_an_empty_read_checks_the_state(fmi3):
    """fmi3InstantiateCoSimulation with another instantiationToken refuses naming both tokens;
    a getter with no value references still checks that the instance may be read (not in the
    Instantiated state) and says so."""
    import ctypes

    md = read_model_description(str(fmi3["MotorStartup"]))
    log = []

    def on_message(env, status, category, message):
        log.append((status, message.decode()))
    bad = FMU3Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=extract(str(fmi3["MotorStartup"])),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="token")
    with pytest.raises(Exception):
        bad.instantiate(loggingOn=True, logMessage=on_message)
    assert any("instantiationToken {00000000-0000-0000-0000-000000000000} does not match this binary's "
               f"{md.guid}" in m for _, m in log), log
    slave, vr, log = _slave(fmi3["MotorStartup"], "empty", False)
    try:
        get = slave.dll.fmi3GetFloat64
        assert get(slave.component, None, ctypes.c_size_t(0), None, ctypes.c_size_t(0)) == 3
        assert any("fmi3GetFloat64 is not allowed in state Instantiated" in m for _, m in log), log
        slave.enterInitializationMode(startTime=0.0)
        assert get(slave.component, None, ctypes.c_size_t(0), None, ctypes.c_size_t(0)) == 0
        slave.exitInitializationMode()
    finally:
        slave.terminate()
        slave.freeInstance()
