"""The co-simulation master's edges (ballmill/scenario/runner.py), for mutants that
tests/mutation/test_runner_master.py and test_runner_loops.py let through, with native FMUs
(tests/mutation/native_fmus.py): refusals (an initialisation, an instance that does not
instantiate, an input fmi2SetReal refuses, a step refused with fmi2Error; the run's message
gives the FMU's reason; what the FMUs log before the first communication point is stamped
with the start time), warnings that do not stop a run, the FMI logger's printf proxy and
echo limit, the progress bar's edges and the defaults, a Boolean parameter set true, tables
read at the start time and 1e-12 s outside their samples, ignored loops named whole, a loop
that does not converge with no tolerance, an instance without inputs before one with."""
from __future__ import annotations

import io

import numpy as np
import pytest

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


class _Clock:
    def __init__(self, now=0.0):
        self.now = now

    def perf_counter(self):
        return self.now


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_edges(monkeypatch):
    """A run shorter than a second (the fraction is done/total there too), a redraw exactly
    0.1 s after the last, the fraction capped at 1, and each tenth on a pipe printed once
    (9.5 % is still the first tenth)."""
    clock = _Clock(0.0)
    monkeypatch.setattr(runner, "time", clock)
    err = _Tty()
    monkeypatch.setattr(runner.sys, "stderr", err)
    bar = runner._Progress(0.5, True)
    bar.update(0.25, 0.25)
    first = "\r  [###############               ]  50.0%  t = 0.250 s  (0.0 s wall)"
    assert err.getvalue() == first
    clock.now = 0.1  # exactly 0.1 s after the last redraw: redrawn
    bar.update(0.3, 0.3)
    second = "\r  [##################            ]  60.0%  t = 0.300 s  (0.1 s wall)"
    assert err.getvalue() == first + second
    clock.now = 0.5
    bar.update(0.55, 0.55)  # past the end (rounding): shown as the end
    assert err.getvalue() == first + second + "\r  [##############################] 100.0%  t = 0.550 s  (0.5 s wall)\n"
    pipe = io.StringIO()
    monkeypatch.setattr(runner.sys, "stderr", pipe)
    bar = runner._Progress(4.0, True)
    for done in (0.2, 0.38, 0.4, 4.4):
        bar.update(done, done)
    assert pipe.getvalue() == ("    5.0%  t = 0.200 s  (0.0 s wall)\n   10.0%  t = 0.400 s  (0.0 s wall)\n"
                               "  100.0%  t = 4.400 s  (0.0 s wall)\n")


def test_an_ignored_loop_of_two_connections_is_named_whole(native_models, native_fmus):
    """Two structures, each one's acceleration the other's ball force: one loop of two
    connections, named in the file's order, joined by ', '; a drive's self-loop the second
    loop, after '; '."""
    st = {n: spec.Instance(n, fmu="Structure", parameters={"input_order": 0}) for n in ("s1", "s2")}
    st["d"] = spec.Instance("d", fmu="MotorStartup")
    sc = direct(st, [("s1", "ax1O", "s2", "Fx_ball"), ("s2", "ax1O", "s1", "Fx_ball"), ("d", "T_drive", "d", "M_reaction")],
                [("s1", "ax1O")], stop=0.01, master={"algebraic_loops": "ignore"})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success and res.loops == [["s1.ax1O -> s2.Fx_ball", "s2.ax1O -> s1.Fx_ball"], ["d.T_drive -> d.M_reaction"]]
    assert res.messages[0]["message"] == ("algebraic loop(s) not iterated (master.algebraic_loops = 'ignore'): "
                                          "s1.ax1O -> s2.Fx_ball, s2.ax1O -> s1.Fx_ball; d.T_drive -> d.M_reaction")


def test_a_table_is_read_up_to_1e_12_s_outside_its_samples(native_models, native_fmus):
    """Time arithmetic may miss a table's first or last sample by rounding: 1e-12 s either side
    is read (the spline extended), as the error message's range says."""
    from runner_cases import table

    src = table("src", ["a"], [0.0, 0.05, 0.1], [lambda t: 2.0 + t])
    for start, stop in ((-1e-12, 0.1), (0.0, 0.1 + 1e-12)):
        sc = direct({"src": src, "s": spec.Instance("s", fmu="Structure", parameters={"input_order": 0})},
                    [("src", "a", "s", "ag_x")], [("s", "agx_total")], start=start, stop=stop, step=stop - start)
        res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
        assert res.success and res.steps == 1, res.message
        assert abs(res.column("s.agx_total")[0] - (2.0 + start)) < 1e-14


def test_an_fmu_that_does_not_instantiate_gives_its_library_back(native_models, native_fmus, monkeypatch):
    """A model description whose GUID is not the binary's: fmi2Instantiate refuses (and says
    why); the loaded library goes back to fmucache for the next instance."""
    import copy

    from ballmill.scenario import fmucache

    md = copy.copy(native_models["MotorStartup"])
    md.guid = "{00000000-0000-0000-0000-000000000000}"
    monkeypatch.setattr(fmucache, "_idle", {})  # no library of an earlier run: a new one, with this GUID
    sc = direct({"drive": spec.Instance("drive", fmu="MotorStartup")}, [], [("drive", "psi")])
    res = runner.run(sc, {"MotorStartup": md}, native_fmus, progress=False, echo=False)
    why = (f"MotorStartup 'drive': fmi2Instantiate: GUID {md.guid} does not match this binary's "
           f"{native_models['MotorStartup'].guid}")
    assert (res.success, res.steps, res.data.shape) == (False, 0, (0, 2))
    assert res.message == f"Exception: Failed to instantiate model {why}"
    assert res.messages == [{"time": 0.0, "instance": "drive", "status": "error", "category": "logStatusError",
                             "message": why}]
    assert len(fmucache._idle[(fmucache.digest(native_fmus["MotorStartup"]), "cs")]) == 1


def test_an_input_the_fmu_refuses_to_take_stops_the_run(native_models, native_fmus):
    """A connection into a fixed parameter (the checker refuses it; built directly here):
    accepted in initialisation mode, refused by fmi2SetReal at the first communication point."""
    drives = {n: spec.Instance(n, fmu="MotorStartup") for n in ("a", "b")}
    sc = direct(drives, [("a", "x1O", "b", "l")], [("b", "l")])
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    why = ("MotorStartup 'b': fmi2SetReal: l cannot be set in state stepComplete: parameter l is fixed: it can be "
           "set only before fmi2ExitInitializationMode (fmi2Reset, then set it); l = 0.5 m refused, l keeps 0.5 m")
    assert (res.success, res.steps) == (False, 0)
    assert res.message == f"FMICallException: fmi2SetReal failed with status 3 (error). {why}"
    assert list(res.column("b.l")) == [0.5]  # the first point was recorded


def test_a_boolean_parameter_set_true(native_models, native_fmus):
    ball = spec.Instance("ball", fmu="BallInShell", parameters={"corrector": True, "formulation": 2})
    sc = direct({"ball": ball}, [], [("ball", "corrector"), ("ball", "formulation"), ("ball", "zP")], stop=0.02)
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success, res.message
    assert list(res.column("ball.corrector")) == [1.0] * 3 and list(res.column("ball.formulation")) == [2.0] * 3
    assert list(res.column("ball.zP")) == [0.0] * 3  # at rest at the bottom of a fixed chamber


def test_by_default_a_run_shows_its_progress_and_echoes_what_the_fmus_refuse(native_models, native_fmus, capsys):
    import re

    from runner_cases import table

    sc = direct({"drive": spec.Instance("drive", fmu="MotorStartup")}, [], [("drive", "psi")], start=0.5, stop=0.55)
    assert runner.run(sc, native_models, native_fmus).success
    assert re.fullmatch(r"  100\.0%  t = 0\.550 s  \(\d+\.\d s wall\)\n", capsys.readouterr().err)
    force = table("src", ["F"], [0.0, 0.1], [lambda t: 1e300])
    sc = direct({"src": force, "s": spec.Instance("s", fmu="Structure", parameters={"M_x1": 1.0})},
                [("src", "F", "s", "Fx_ball")], [("s", "x_rel")])
    res = runner.run(sc, native_models, native_fmus)
    assert not res.success
    assert capsys.readouterr().err == ("\n[discard] Structure 's': step from t = 0 s refused, last good state kept: "
                                       "the outputs at t = 0.01 s would not be finite\n")


def test_an_instance_without_inputs_does_not_end_the_list_of_inputs_to_set(native_models, native_fmus):
    """Drive a feeds its torque to drive b; a, first in the order, has no input connected."""
    a = spec.Instance("a", fmu="MotorStartup", parameters={"J_crank": 0.3, "n0": 60.0, "t0": 1.0})
    b = spec.Instance("b", fmu="MotorStartup", parameters={"J_crank": 0.1, "n0": 30.0, "t0": 1.0})
    sc = direct({"a": a, "b": b}, [("a", "T_drive", "b", "M_reaction")], [("a", "T_drive"), ("b", "T_drive")],
                stop=0.03)
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success
    t = res.column("time")
    from runner_cases import quadratic_law
    Ta = [0.3 * quadratic_law(60.0, 1.0, x)[2] for x in t]
    Tb = [0.1 * quadratic_law(30.0, 1.0, x)[2] - Ta[max(k - 1, 0)] for k, x in enumerate(t)]
    assert np.allclose(res.column("a.T_drive"), Ta, rtol=1e-13) and np.allclose(res.column("b.T_drive"), Tb, rtol=1e-12)


def test_with_no_tolerance_the_error_names_the_loop_still_changing(native_models, native_fmus):
    """loop_tol = loop_atol = 0 (allowed: settled when a sweep changes nothing). A structure
    whose ball force does not reach its acceleration (phi = 0) settles at once; the drive's
    self-loop never does: the error names the drive's torque and its change J psi''(t), not
    the settled value (before: 0/0 = nan, which argmax takes first, named 's.ax1O still
    changed by 0')."""
    import warnings

    from runner_cases import quadratic_law

    s = spec.Instance("s", fmu="Structure", parameters={"phi_x1": 0.0, "F0_x": 1.0, "f_exc": 3.0})
    d = spec.Instance("d", fmu="MotorStartup", parameters={"J_crank": 0.5})
    sc = direct({"s": s, "d": d}, [("s", "ax1O", "s", "Fx_ball"), ("d", "T_drive", "d", "M_reaction")], [("d", "psi")],
                start=0.1, master={"loop_tol": 0.0, "loop_atol": 0.0, "loop_max_iter": 2})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no division by zero on the way
        res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    change = 0.5 * quadratic_law(60.0, 2.5, 0.1)[2]
    assert res.message == (
        "AlgebraicLoopError: algebraic loop s.ax1O -> s.Fx_ball; d.T_drive -> d.M_reaction did not converge at "
        f"t = 0.1 s after loop_max_iter = 2 sweeps: d.T_drive still changed by {change:.3g} (accepted: loop_tol = 0 "
        "relative + loop_atol = 0); the loop's gain is too large for a fixed-point iteration, or an FMU does not "
        "recompute its outputs when its inputs are set")


def test_tables_are_read_at_the_start_time_in_initialisation(native_models, native_fmus):
    from runner_cases import table

    src = table("src", ["a"], [0.0, 0.05, 0.1, 0.2], [lambda t: 1.0 + 20.0 * t ** 3])
    sc = direct({"s": spec.Instance("s", fmu="Structure", parameters={"input_order": 0}), "src": src},
                [("src", "a", "s", "ag_x")], [("s", "agx_total")], start=0.07, stop=0.09)
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success
    assert res.column("s.agx_total")[0] == pytest.approx(1.0 + 20.0 * 0.07 ** 3, rel=1e-14)


def test_a_step_refused_with_fmi2error_ends_the_run_with_its_reason(native_models, native_fmus):
    """At t = 1e17 s a 1 s step does not move the time (1e17 + 1 rounds to 1e17): the FMU
    refuses the step with fmi2Error; with 16 s steps (the spacing of doubles there) it runs."""
    drive = {"drive": spec.Instance("drive", fmu="MotorStartup")}
    ok = runner.run(direct(drive, [], [("drive", "psi")], start=1e17, stop=1e17 + 64, step=16.0), native_models,
                    native_fmus, progress=False, echo=False)
    assert (ok.success, ok.steps) == (True, 4)
    res = runner.run(direct(drive, [], [("drive", "psi")], start=1e17, stop=1e17 + 32, step=1.0), native_models,
                     native_fmus, progress=False, echo=False)
    assert (res.success, res.steps) == (False, 0)
    assert res.message == ("drive refused the step at t = 1e+17 s (error): MotorStartup 'drive': fmi2DoStep: the step "
                           "ends at 1e+17 s, not after the FMU's time t = 1e+17 s; state unchanged")


def test_warnings_do_not_stop_a_run(native_models, native_fmus):
    """A ball that slips at once (mu = 0.01): BallInShell warns and latches valid = false; the
    run goes on to the end."""
    conns = [("drive", v, "ball", v) for v in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")]
    sc = direct({"drive": spec.Instance("drive", fmu="MotorStartup", parameters={"t0": 0.05, "n0": 120.0}),
                 "ball": spec.Instance("ball", fmu="BallInShell", parameters={"mu": 0.01})}, conns, [("ball", "valid")])
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert (res.success, res.message, res.steps) == (True, "completed", 10)
    assert list(res.column("ball.valid")) == [0.0] * 11
    assert res.messages[0]["status"] == "warning" and res.messages[0]["message"].startswith(
        "BallInShell 'ball': slip at t = 0 s: |F_t|/N = ")
