"""The co-simulation master (ballmill/scenario/runner.py) driving native FMUs, where mutmut
sees it: the FMUs come from tests/mutation/native_fmus.py (built once, outside mutants/),
the master runs in this process. Each run is a few communication steps of the MotorStartup
drive (whose outputs are closed forms of time), the Structure (whose accelerations obey its
equation of motion at every instant) and table sources of cubic polynomials (which the
master's cubic spline reproduces exactly), against values computed here:

* the communication grid, the recorded times and the number of steps;
* parameters of each type applied before initialisation (read back, and in the physics);
* connections: each value reaches its input unchanged, from the right column, one
  communication step late (the Jacobi exchange), and at the start time after the sources
  are initialised (dependency order);
* records: the columns' names and order, Integers and Booleans among the Reals;
* tables out of their time range, steps an FMU refuses: the run ends, everything recorded
  before is kept, the message says why, word for word;
* the progress bar, the logger's echo and the result's fields.
"""
from __future__ import annotations

import io
import math
import re

import numpy as np
import pytest

from ballmill.scenario import runner, spec
from runner_cases import direct, linear_law, load, table, write_csv

DRIVE = """
[instances.drive]
fmu = "MotorStartup"
parameters = {{ l = 0.3, n0 = 90.0, t0 = 0.5, law = 3, J_crank = 0.02, m_platform = 1.5 }}
"""


def run(sc, models, paths, **kw):
    return runner.run(sc, models, paths, progress=kw.pop("progress", False), echo=kw.pop("echo", False))


def test_grid_parameters_and_drive_outputs_against_the_closed_form(tmp_path, native_models, native_fmus):
    """start 0.25 s, H = 10 ms, 10 steps: the recorded times are start + k H, every output of
    the linear law at those times, T_drive = J_total psi'' with M_reaction at its start value
    0 (J_total = J_crank + m_platform l^2), P_drive = T_drive psi'; the parameters of each type
    read back as set (the Integer law 3, the Real l)."""
    sc = load(tmp_path, """
[experiment]
start = 0.25
stop = 0.35
step = 0.01
""" + DRIVE.format() + """
[record]
variables = ["drive.psi", "drive.psi_dot", "drive.psi_ddot", "drive.x1O", "drive.y1O", "drive.vx1O",
             "drive.vy1O", "drive.ax1O", "drive.ay1O", "drive.T_drive", "drive.P_drive", "drive.law",
             "drive.l", "drive.n0"]
""", native_models)
    res = run(sc, native_models, native_fmus)
    assert (res.success, res.message, res.steps) == (True, "completed", 10)
    assert res.columns == ["time", "drive.psi", "drive.psi_dot", "drive.psi_ddot", "drive.x1O", "drive.y1O",
                           "drive.vx1O", "drive.vy1O", "drive.ax1O", "drive.ay1O", "drive.T_drive",
                           "drive.P_drive", "drive.law", "drive.l", "drive.n0"]
    assert res.data.shape == (11, 15)
    assert res.loops == [] and res.loop_sweeps == 0
    assert res.scenario is sc
    assert 0.0 <= res.init_time <= res.wall_time
    t = res.column("time")
    assert list(t) == [0.25 + k * 0.01 for k in range(11)]
    J = 0.02 + 1.5 * 0.3 ** 2
    for k, tk in enumerate(t):
        psi, pd, pdd = linear_law(90.0, 0.5, tk)
        c, s = math.cos(psi), math.sin(psi)
        expected = {"drive.psi": psi, "drive.psi_dot": pd, "drive.psi_ddot": pdd, "drive.x1O": 0.3 * c,
                    "drive.y1O": 0.3 * s, "drive.vx1O": -0.3 * s * pd, "drive.vy1O": 0.3 * c * pd,
                    "drive.ax1O": -0.3 * (s * pdd + c * pd * pd), "drive.ay1O": 0.3 * (c * pdd - s * pd * pd),
                    "drive.T_drive": J * pdd, "drive.P_drive": J * pdd * pd, "drive.law": 3.0, "drive.l": 0.3,
                    "drive.n0": 90.0}
        for name, value in expected.items():
            assert res.column(name)[k] == pytest.approx(value, rel=1e-12, abs=1e-14), (name, tk)


def _connected(tmp_path, native_models, order_text):
    """table (a, b, c: cubics in t, sampled at uneven times) -> structure.ag_x, drive.M_reaction,
    structure.Fx_ball; the structure holds its inputs over a step (input_order 0)."""
    a = lambda t: 1.0 + 2.0 * t - 3.0 * t * t + 40.0 * t ** 3  # noqa: E731
    b = lambda t: -0.5 + 10.0 * t ** 3  # noqa: E731
    c = lambda t: 2.0 - t + 5.0 * t * t  # noqa: E731
    write_csv(tmp_path / "inputs.csv", ["a", "b", "c"], [0.0, 0.013, 0.031, 0.05, 0.072, 0.1, 0.12], [a, b, c])
    blocks = {"structure": """
[instances.structure]
fmu = "Structure"
parameters = { M_x1 = 4.0, f_x1 = 1.5, zeta_x1 = 0.05, L_x1 = 3.0, input_order = 0, h_max = 0.001 }
""", "drive": DRIVE.format(), "table": """
[instances.table]
table = "inputs.csv"
"""}
    sc = load(tmp_path, """
connections = ["table.a -> structure.ag_x", "table.b -> drive.M_reaction", "table.c -> structure.Fx_ball"]
[experiment]
start = 0.0
stop = 0.1
step = 0.01
""" + "".join(blocks[n] for n in order_text) + """
[record]
variables = ["structure.agx_total", "structure.ax1O", "structure.x_rel", "structure.vx1O", "structure.vxg",
             "drive.T_drive", "drive.psi_ddot"]
""", native_models)
    return sc, a, b, c


@pytest.mark.parametrize("order", [("structure", "drive", "table"), ("table", "drive", "structure")])
def test_connections_pass_each_value_one_step_late_from_its_column(tmp_path, native_models, native_fmus, order):
    """At t_k the inputs hold the sources' values of t_(k-1) (Jacobi), at t_0 those of t_0 (the
    table is initialised first wherever the file lists it). The structure's acceleration obeys
    M q'' + C q' + K q = -L a_g + F_ball with a_g and F_ball the values passed; the drive's
    torque is J_total psi'' - M_reaction. The structure's two inputs are not neighbours on the
    bus (the drive's input sits between them): they travel through the master's gather."""
    sc, a, b, c = _connected(tmp_path, native_models, order)
    res = run(sc, native_models, native_fmus)
    assert (res.success, res.message, res.steps) == (True, "completed", 10)
    t = res.column("time")
    assert len(t) == 11
    held = np.concatenate([[t[0]], t[:-1]])  # the time whose source values the inputs hold
    ag = np.array([a(x) for x in held])
    M_in = np.array([b(x) for x in held])
    F = np.array([c(x) for x in held])
    assert np.allclose(res.column("structure.agx_total"), ag, rtol=1e-13, atol=1e-13)
    J = 0.02 + 1.5 * 0.3 ** 2
    assert np.allclose(res.column("drive.T_drive"), J * res.column("drive.psi_ddot") - M_in, rtol=1e-13, atol=1e-13)
    M, w, zeta, L = 4.0, 2 * math.pi * 1.5, 0.05, 3.0
    x, v = res.column("structure.x_rel"), res.column("structure.vx1O") - res.column("structure.vxg")
    expected = ag + (-L * ag - 2 * zeta * M * w * v - M * w * w * x + F) / M
    assert np.allclose(res.column("structure.ax1O"), expected, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(x)) > 1e-5  # the structure moved: the stiffness and damping terms count


def test_table_outside_its_time_range_ends_the_run_keeping_the_rows_before(tmp_path, native_models, native_fmus,
                                                                          capsys):
    cubic = [lambda t: 1.0 + t ** 3]
    tab = table("src", ["a"], [0.0, 0.03, 0.06, 0.1], cubic)
    structure = spec.Instance("structure", fmu="Structure", parameters={"input_order": 0})
    conn = [("src", "a", "structure", "ag_x")]
    rec = [("structure", "agx_total")]
    # exactly its range, from the first to the last sample: runs
    ok = run(direct({"src": tab, "structure": structure}, conn, rec, start=0.0, stop=0.1), native_models,
             native_fmus)
    assert ok.success and ok.steps == 10
    assert ok.column("structure.agx_total")[-1] == pytest.approx(1.0 + 0.09 ** 3, rel=1e-14)
    # past its end: the row at 0.11 s is not recorded
    sc = direct({"src": tab, "structure": spec.Instance("structure", fmu="Structure", parameters={"input_order": 0})},
                conn, rec, start=0.0, stop=0.2)
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=True)
    message = "ValueError: the table covers t = 0 .. 0.1 s, asked for t = 0.11 s"
    assert (res.success, res.message, res.steps) == (False, message, 11)
    assert res.data.shape == (11, 2)
    assert np.allclose(res.column("time"), np.arange(11) * 0.01, rtol=0, atol=1e-15)
    assert np.allclose(res.column("structure.agx_total")[1:], 1.0 + res.column("time")[:-1] ** 3, rtol=1e-13)
    assert capsys.readouterr().err == f"\nrun failed: {message}\n"
    # before its start: nothing recorded at all
    sc = direct({"src": tab, "structure": spec.Instance("structure", fmu="Structure")}, conn, rec,
                start=-0.01, stop=0.05)
    res = run(sc, native_models, native_fmus)
    assert (res.success, res.message, res.steps) == (
        False, "ValueError: the table covers t = 0 .. 0.1 s, asked for t = -0.01 s", 0)
    assert res.data.shape == (0, 2) and res.columns == ["time", "structure.agx_total"]
    assert 0.0 <= res.init_time <= res.wall_time


def test_a_step_the_fmu_refuses_ends_the_run_with_its_reason(tmp_path, native_models, native_fmus):
    """A ball force of 1e300 N from t = 0.03 s on: the structure's energy would overflow, it
    refuses the step from 0.03 s (fmi2Discard); the rows up to 0.03 s are kept."""
    times = [round(0.01 * k, 2) for k in range(11)]
    force = table("src", ["F"], times, [lambda t: 0.0 if t < 0.025 else 1e300])
    sc = direct({"structure": spec.Instance("structure", fmu="Structure", parameters={"input_order": 0, "M_x1": 1.0}),
                 "src": force}, [("src", "F", "structure", "Fx_ball")], [("structure", "x_rel")])
    res = run(sc, native_models, native_fmus)
    why = ("Structure 'structure': step from t = 0.03 s refused, last good state kept: the outputs at t = 0.04 s "
           "would not be finite")
    assert (res.success, res.steps) == (False, 3)
    assert res.message == f"structure refused the step at t = 0.03 s (discard): {why}"
    assert res.data.shape == (4, 2)
    assert list(res.column("time")) == [0.0, 0.01, 0.02, 0.03]
    assert res.column("structure.x_rel")[-1] == 0.0  # no force yet
    assert {"time": 0.03, "instance": "structure", "status": "discard", "category": "logStatusDiscard",
            "message": why} in res.messages


def test_records_mix_reals_integers_and_booleans_in_the_order_asked(tmp_path, native_models, native_fmus):
    """BallInShell on the drive (the fast_start coupling): Booleans (valid, contact, the
    parameter corrector set false) and an Integer (law) recorded between Reals, in the order
    of [record]; the ball at rest at the bottom of the shell at t = 0 touches it at the
    chamber frame's origin; its reaction torque is the drive's input."""
    sc = load(tmp_path, """
connections = ["drive.x1O -> ball.x1O", "drive.y1O -> ball.y1O", "drive.vx1O -> ball.vx1O", "drive.vy1O -> ball.vy1O",
               "drive.ax1O -> ball.ax1O", "drive.ay1O -> ball.ay1O", "ball.M_reaction -> drive.M_reaction"]
[experiment]
start = 0.0
stop = 0.03
step = 0.01
""" + DRIVE.format().replace("law = 3", "law = 2") + """
[instances.ball]
fmu = "BallInShell"
parameters = { corrector = false, mu = 0.5 }
""" + """
[record]
variables = ["ball.valid", "drive.law", "ball.xP", "drive.x1O", "ball.corrector", "ball.contact", "ball.mu",
             "ball.M_reaction", "drive.T_drive", "drive.psi_ddot"]
""", native_models)
    res = run(sc, native_models, native_fmus)
    assert (res.success, res.message, res.steps) == (True, "completed", 3)
    assert res.columns == ["time", "ball.valid", "drive.law", "ball.xP", "drive.x1O", "ball.corrector",
                           "ball.contact", "ball.mu", "ball.M_reaction", "drive.T_drive", "drive.psi_ddot"]
    c = res.column
    assert list(c("ball.valid")) == [1.0] * 4 and list(c("ball.contact")) == [1.0] * 4
    assert list(c("drive.law")) == [2.0] * 4 and list(c("ball.corrector")) == [0.0] * 4
    assert list(c("ball.mu")) == [0.5] * 4
    assert c("drive.x1O")[0] == 0.3 and c("ball.xP")[0] == 0.0
    # the ball's torque on the crank reaches the drive one step late (at t_0: after initialisation)
    M_ball = c("ball.M_reaction")
    held = np.concatenate([[M_ball[0]], M_ball[:-1]])
    J = 0.02 + 1.5 * 0.3 ** 2
    assert np.all(np.abs(M_ball[2:]) > 1e-2)
    assert np.allclose(c("drive.T_drive"), J * c("drive.psi_ddot") - held, rtol=1e-13, atol=1e-15)


def test_progress_bar_on_a_pipe_prints_each_new_tenth(tmp_path, native_models, native_fmus, capsys):
    """120 steps: the bar is updated every 50 steps and at the last: 41.7 %, 83.3 %, 100 %."""
    sc = load(tmp_path, "[experiment]\nstart = 0.0\nstop = 1.2\nstep = 0.01\n" + DRIVE.format()
              + '[record]\nvariables = ["drive.psi"]\n', native_models)
    res = run(sc, native_models, native_fmus, progress=True)
    assert res.success and res.steps == 120
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 3, lines
    for line, (pct, t) in zip(lines, (("41.7", "0.500"), ("83.3", "1.000"), ("100.0", "1.200"))):
        assert re.fullmatch(rf" +{re.escape(pct)}%  t = {t} s  \(\d+\.\d s wall\)", line), line
        assert line.startswith(f"  {pct:>5}%")


class _Clock:
    def __init__(self):
        self.now = 100.0

    def perf_counter(self):
        return self.now


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_on_a_terminal_redraws_at_most_ten_times_a_second(monkeypatch):
    clock, err = _Clock(), _Tty()
    monkeypatch.setattr(runner, "time", clock)
    monkeypatch.setattr(runner.sys, "stderr", err)
    bar = runner._Progress(2.0, True)
    clock.now = 100.5
    bar.update(0.5, 1.5)
    first = "\r  [#######                       ]  25.0%  t = 1.500 s  (0.5 s wall)"
    assert err.getvalue() == first
    clock.now = 100.55  # 0.05 s later: not redrawn
    bar.update(1.0, 2.0)
    assert err.getvalue() == first
    clock.now = 100.65
    bar.update(1.0, 2.0)
    second = "\r  [###############               ]  50.0%  t = 2.000 s  (0.7 s wall)"
    assert err.getvalue() == first + second
    clock.now = 100.66  # the end is always drawn, with a new line
    bar.update(2.0, 3.0)
    assert err.getvalue() == first + second + "\r  [##############################] 100.0%  t = 3.000 s  (0.7 s wall)\n"
    quiet = runner._Progress(2.0, False)
    quiet.update(2.0, 3.0)
    empty = runner._Progress(0.0, True)  # nothing to run: done
    empty.update(0.0, 0.0)
    assert err.getvalue().endswith("] 100.0%  t = 0.000 s  (0.0 s wall)\n")
    assert err.getvalue().count("\n") == 2


def test_progress_bar_on_a_pipe(monkeypatch):
    clock, err = _Clock(), io.StringIO()
    monkeypatch.setattr(runner, "time", clock)
    monkeypatch.setattr(runner.sys, "stderr", err)
    bar = runner._Progress(4.0, True)
    for done, now, wall in ((0.3, 0.3, 100.1), (0.35, 0.35, 100.2), (0.4, 0.4, 100.3), (1.0, 1.0, 101.0),
                            (4.0, 4.0, 102.0)):
        clock.now = wall
        bar.update(done, now)
    assert err.getvalue() == ("    7.5%  t = 0.300 s  (0.1 s wall)\n   10.0%  t = 0.400 s  (0.3 s wall)\n"
                              "   25.0%  t = 1.000 s  (1.0 s wall)\n  100.0%  t = 4.000 s  (2.0 s wall)\n")


def test_logger_collects_every_message_and_echoes_the_first_five_per_instance(monkeypatch):
    err = io.StringIO()
    monkeypatch.setattr(runner.sys, "stderr", err)
    log = runner._Logger(echo=True)
    log.now = 1.25
    for i in range(7):
        log._on_message(None, b"a", 1, b"logStatusWarning", f"w{i}".encode())
    log._on_message(None, b"a", 0, b"logAll", b"fine")
    log._on_message(None, b"b", 3, b"logStatusError", b"bad \xff")
    log._on_message(None, None, 7, None, None)
    assert err.getvalue() == ("".join(f"\n[warning] w{i}\n" for i in range(5))
                              + "\n[warning] a: further messages are in summary.json\n"
                              + "\n[error] bad \ufffd\n" + "\n[7] \n")
    assert log.messages[0] == {"time": 1.25, "instance": "a", "status": "warning", "category": "logStatusWarning",
                               "message": "w0"}
    assert log.messages[7] == {"time": 1.25, "instance": "a", "status": "ok", "category": "logAll", "message": "fine"}
    assert log.messages[8]["status"] == "error" and log.messages[8]["message"] == "bad \ufffd"
    assert log.messages[9] == {"time": 1.25, "instance": "", "status": "7", "category": "", "message": ""}
    assert len(log.messages) == 10
    quiet = runner._Logger(echo=False)
    quiet._on_message(None, b"a", 4, b"logStatusFatal", b"gone")
    assert quiet.messages[0]["status"] == "fatal"
    assert err.getvalue().count("gone") == 0
    assert runner.STATUS == {0: "ok", 1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}


def test_without_removes_an_instance_its_connections_and_records(tmp_path):
    inst = {n: spec.Instance(n, fmu="MotorStartup") for n in ("a", "b", "c")}
    conns = [("a", "x", "b", "y"), ("b", "x", "c", "y"), ("c", "x", "a", "y"), ("a", "z", "c", "w")]
    rec = [("a", "p"), ("b", "p"), ("c", "q")]
    sc = direct(inst, conns, rec, name="three")
    sc.plots = [{"y": ["b.p"]}]
    cut = runner.without(sc, "b")
    assert list(cut.instances) == ["a", "c"]
    assert cut.connections == [("c", "x", "a", "y"), ("a", "z", "c", "w")]
    assert cut.record == [("a", "p"), ("c", "q")] and cut.plots == []
    assert runner.without(sc, "b", record=[("c", "q")]).record == [("c", "q")]
    assert list(sc.instances) == ["a", "b", "c"] and len(sc.connections) == 4  # the original is unchanged
    with pytest.raises(KeyError) as e:
        runner.without(sc, "d")
    assert e.value.args[0] == "three: no instance 'd' to remove"


def test_descriptions_are_a_mapping_of_the_models_parsed_on_use(native_fmus):
    d = runner._Descriptions(native_fmus)
    assert len(d) == len(native_fmus) == 5
    assert list(d) == list(native_fmus)
    assert d["Structure"].modelName == "Structure"
    assert d["MotorStartup"] is d["MotorStartup"]
