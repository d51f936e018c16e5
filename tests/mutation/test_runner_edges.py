"""The co-simulation master's edges (ballmill/scenario/runner.py), for mutants that
tests/mutation/test_runner_master.py and test_runner_loops.py let through, with native FMUs
(tests/mutation/native_fmus.py): an initialisation an FMU refuses (the run's message gives
the FMU's reason; what the FMUs log before the first communication point is stamped with the
start time), the FMI logger's printf proxy, the echo limit."""
from __future__ import annotations

import io

from ballmill.scenario import runner, spec
from runner_cases import direct


def test_a_refused_initialisation_stops_the_run_with_the_fmus_reason(native_models, native_fmus):
    sc = direct({"drive": spec.Instance("drive", fmu="MotorStartup", parameters={"l": -1.0})}, [],
                [("drive", "psi")], start=0.5, stop=0.6)
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    why = "MotorStartup 'drive': initialisation failed: parameter l = -1.0 m is outside its accepted range [0, 1000] m"
    assert (res.success, res.steps, res.data.shape) == (False, 0, (0, 2))
    assert res.message == f"FMICallException: fmi2GetReal failed with status 3 (error). {why}"
    assert res.messages[0] == {"time": 0.5, "instance": "drive", "status": "error", "category": "logStatusError",
                               "message": why}


def test_the_loggers_messages_are_formatted_as_printf_formats():
    """The FMU hands a message over as a printf format: fmpy's proxy formats it ('%%' is '%')."""
    log = runner._Logger(echo=False)
    log.callbacks.logger(None, b"inst", 1, b"cat", b"100%% done")
    assert log.messages == [{"time": 0.0, "instance": "inst", "status": "warning", "category": "cat",
                             "message": "100% done"}]


def test_the_echo_limit_line_comes_once(monkeypatch):
    err = io.StringIO()
    monkeypatch.setattr(runner.sys, "stderr", err)
    log = runner._Logger(echo=True)
    for i in range(9):
        log._on_message(None, b"a", 2, b"logStatusDiscard", f"d{i}".encode())
    assert err.getvalue() == ("".join(f"\n[discard] d{i}\n" for i in range(5))
                              + "\n[discard] a: further messages are in summary.json\n")
    assert [m["message"] for m in log.messages] == [f"d{i}" for i in range(9)]
