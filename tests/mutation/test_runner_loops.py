"""The co-simulation master's algebraic loops (ballmill/scenario/runner.py) with native FMUs
where mutmut sees them (tests/mutation/native_fmus.py): which loops `algebraic_loops` finds
from the model descriptions' direct feedthrough, the initialisation order, the Gauss-Seidel
iteration (its fixed point, checked against the structure's equation of motion; the number
of sweeps), "ignore" (the plain Jacobi exchange and its warning) and a loop that does not
converge (the run stops with a message naming the loops, the variable and its residual,
word for word). Loops through a variable and its own instance are built without the
scenario checker, which refuses their mixed units."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ballmill.scenario import runner, spec
from runner_cases import direct, quadratic_law, table

FAST_START = [("drive", v, "ball", v) for v in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")] + \
    [("ball", "M_reaction", "drive", "M_reaction")]


def _md(inputs, outputs):
    """A stand-in for fmpy's ModelDescription: outputs name -> list of inputs it depends on
    (None: the attribute is absent, i.e. every input)."""
    variables = [SimpleNamespace(name=n, causality="input") for n in inputs] + \
        [SimpleNamespace(name=n, causality="output") for n in outputs] + \
        [SimpleNamespace(name="p", causality="parameter")]
    unknowns = [SimpleNamespace(variable=SimpleNamespace(name=n),
                                dependencies=None if d is None else [SimpleNamespace(name=x) for x in d])
                for n, d in outputs.items()]
    return SimpleNamespace(modelVariables=variables, outputs=unknowns)


def _scenario(instances, connections):
    return direct({n: spec.Instance(n, fmu=m) if m else spec.Instance(n) for n, m in instances.items()}, connections)


def test_loops_are_the_cycles_through_connections_and_declared_feedthrough():
    models = {"F": _md(["u", "w"], {"y": ["u"], "z": []}),  # y follows u, z follows nothing
              "A": _md(["u", "w"], {"y": None}),  # y follows every input
              "Z": _md(["u", "w"], {"y": None, "z": ["w"]})}
    loops = runner.algebraic_loops
    # F.y -> G.u -> G.y -> F.u: a loop; the z's carry no feedthrough
    sc = _scenario({"f": "F", "g": "F"}, [("f", "y", "g", "u"), ("g", "z", "f", "w"), ("g", "y", "f", "u")])
    assert loops(sc, models) == [[("f", "y", "g", "u"), ("g", "y", "f", "u")]]
    # through z only: no feedthrough, no loop
    sc = _scenario({"f": "F", "g": "F"}, [("f", "z", "g", "u"), ("g", "z", "f", "u")])
    assert loops(sc, models) == []
    # an output without dependencies depends on every input: A.y on w
    sc = _scenario({"a": "A", "f": "F"}, [("a", "y", "f", "u"), ("f", "y", "a", "w")])
    assert loops(sc, models) == [[("a", "y", "f", "u"), ("f", "y", "a", "w")]]
    # a self-loop, and two separate loops listed in the order of their first connection
    sc = _scenario({"f": "F", "a": "Z", "b": "Z", "t": None},
                   [("a", "z", "b", "w"), ("f", "y", "f", "u"), ("t", "x", "f", "w"), ("b", "z", "a", "w")])
    assert loops(sc, models) == [[("a", "z", "b", "w"), ("b", "z", "a", "w")], [("f", "y", "f", "u")]]
    # a chain of three through feedthrough, closed: one loop with its connections in the file's order
    sc = _scenario({"x": "F", "y": "F", "z": "F"},
                   [("z", "y", "x", "u"), ("x", "y", "y", "u"), ("y", "y", "z", "u"), ("x", "z", "z", "w")])
    assert loops(sc, models) == [[("z", "y", "x", "u"), ("x", "y", "y", "u"), ("y", "y", "z", "u")]]
    # an instance whose model is unknown, and a table, add no edges, and the instances after
    # them still do
    assert loops(_scenario({"f": "F", "q": "Q"}, [("f", "y", "q", "u"), ("q", "y", "f", "u")]), models) == []
    assert loops(_scenario({"t": None, "q": "Q", "f": "F"}, [("f", "y", "f", "u")]), models) == [[("f", "y", "f", "u")]]
    # two paths from one output, the second reaching the first's end again: no cycle
    sc = _scenario({"r": "F", "x": "F", "y": "F"}, [("r", "z", "x", "u"), ("r", "z", "y", "u"), ("y", "y", "x", "u")])
    assert loops(sc, models) == []


def test_loops_of_the_project_fmus_from_their_model_descriptions(native_models):
    """Direct feedthrough while stepping (ModelStructure/Outputs): BallInShell's reaction
    torque and forces follow the chamber's position and acceleration, the Structure's
    accelerations follow the ball's force; MotorStartup's and InductionMotor's motion outputs
    do not follow their torque input (InductionMotor's only in initialisation mode)."""
    sc = _scenario({"drive": "MotorStartup", "ball": "BallInShell"}, FAST_START)
    assert runner.algebraic_loops(sc, native_models) == []
    sc = _scenario({"drive": "InductionMotor", "ball": "BallInShell"}, FAST_START)
    assert runner.algebraic_loops(sc, native_models) == []
    # the drive's torque output follows its input: fed to the ball's position input, a loop
    sc = _scenario({"drive": "MotorStartup", "ball": "BallInShell"}, FAST_START + [("drive", "T_drive", "ball", "x1O")])
    assert runner.algebraic_loops(sc, native_models) == [
        [("ball", "M_reaction", "drive", "M_reaction"), ("drive", "T_drive", "ball", "x1O")]]
    absorber = [("structure", v, "ball", v) for v in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")] + \
        [("ball", "Fx", "structure", "Fx_ball"), ("ball", "Fy", "structure", "Fy_ball")]
    sc = _scenario({"structure": "Structure", "ball": "BallInShell"}, absorber)
    assert runner.algebraic_loops(sc, native_models) == [
        [("structure", "ax1O", "ball", "ax1O"), ("structure", "ay1O", "ball", "ay1O"), ("ball", "Fx", "structure", "Fx_ball"),
         ("ball", "Fy", "structure", "Fy_ball")]]


def test_initialisation_order_puts_sources_first():
    order = runner._order
    inst = lambda *names: {n: spec.Instance(n) for n in names}  # noqa: E731
    assert order(direct(inst("c", "b", "a"), [("a", "x", "b", "y"), ("b", "x", "c", "y")])) == ["a", "b", "c"]
    assert order(direct(inst("c", "b", "a"), [("b", "x", "c", "y"), ("a", "x", "c", "z")])) == ["b", "a", "c"]
    # a loop is broken at the first instance of the file; self-connections are no dependency
    assert order(direct(inst("p", "q", "r"), [("p", "x", "q", "y"), ("q", "x", "p", "y"), ("q", "x", "r", "y"),
                                              ("r", "x", "r", "y")])) == ["p", "q", "r"]
    assert order(direct(inst("r", "q", "p"), [("p", "x", "q", "y"), ("q", "x", "p", "y"), ("q", "x", "r", "y")])) \
        == ["r", "q", "p"]
    assert order(direct(inst("s"), [])) == ["s"]


def _self_loop(mode, M=10.0, master=None, stop=0.1):
    """The structure's acceleration fed back as its own ball force, under a harmonic force:
    M a = F_exc - C v - K x + a at every instant, so a = (F_exc - C v - K x) / (M - 1)."""
    st = spec.Instance("structure", fmu="Structure",
                       parameters={"M_x1": M, "L_x1": M, "f_x1": 2.0, "zeta_x1": 0.1, "F0_x": 3.0, "f_exc": 5.0,
                                   "input_order": 0, "h_max": 0.002})
    rec = [("structure", v) for v in ("ax1O", "x_rel", "vx1O", "Fx_exc")]
    return direct({"structure": st}, [("structure", "ax1O", "structure", "Fx_ball")], rec, stop=stop,
                  master={"algebraic_loops": mode, **(master or {})})


def _residual_terms(res, M):
    c = res.column
    K, C = M * (2 * math.pi * 2.0) ** 2, 2 * 0.1 * M * 2 * math.pi * 2.0
    return c("structure.ax1O"), c("structure.Fx_exc") - C * c("structure.vx1O") - K * c("structure.x_rel")


def test_an_iterated_loop_meets_both_ends_at_every_point(native_models, native_fmus):
    sc = _self_loop("iterate")
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert (res.success, res.message, res.steps) == (True, "completed", 10)
    assert res.loops == [["structure.ax1O -> structure.Fx_ball"]]
    a, R = _residual_terms(res, 10.0)
    assert np.max(np.abs(R)) > 0.5  # the force acts
    assert np.allclose(a * (10.0 - 1.0), R, rtol=1e-9, atol=1e-12)
    # gain 1/M = 0.1 a sweep from the value of the step before: 9 to 12 sweeps to 1e-10
    assert 11 * 9 <= res.loop_sweeps <= 11 * 12
    assert not [m for m in res.messages if m["category"] == "master"]
    # an absolute tolerance above every change: one sweep a point
    loose = runner.run(_self_loop("iterate", master={"loop_atol": 1e3}), native_models, native_fmus,
                       progress=False, echo=False)
    assert loose.success and loose.loop_sweeps == 11
    # a relative tolerance of 1e-3: fewer sweeps, the equation met to about that
    rel = runner.run(_self_loop("iterate", master={"loop_tol": 1e-3}), native_models, native_fmus,
                     progress=False, echo=False)
    a, R = _residual_terms(rel, 10.0)
    assert 11 * 2 <= rel.loop_sweeps < res.loop_sweeps
    assert np.allclose(a * 9.0, R, rtol=2e-3, atol=1e-12)
    assert not np.allclose(a * 9.0, R, rtol=1e-9, atol=1e-12)


def test_an_ignored_loop_exchanges_values_one_step_late_and_says_so(native_models, native_fmus):
    sc = _self_loop("ignore")
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert (res.success, res.steps, res.loop_sweeps) == (True, 10, 0)
    assert res.loops == [["structure.ax1O -> structure.Fx_ball"]]
    assert res.messages[0] == {"time": 0.0, "instance": "", "status": "warning", "category": "master",
                               "message": "algebraic loop(s) not iterated (master.algebraic_loops = 'ignore'): "
                                          "structure.ax1O -> structure.Fx_ball"}
    a, R = _residual_terms(res, 10.0)
    # after t_0 the ball force held over a step is the acceleration read at the point before
    assert np.allclose(10.0 * a[1:], R[1:] + a[:-1], rtol=1e-12, atol=1e-12)
    assert not np.allclose(9.0 * a[1:], R[1:], rtol=1e-6, atol=1e-12)


def test_a_loop_that_does_not_settle_stops_the_run_naming_it(native_models, native_fmus, capsys):
    """The drive's torque fed back as its own input: T = J psi'' - T has the fixed point
    J psi''/2, but each sweep maps T to J psi'' - T, so the values alternate between T and
    J psi'' - T for ever. A converging loop beside it (the structure's) is named in the
    message too; the residual is the drive's, J psi''(t) here (the initialisation's five
    passes leave T = J psi'', J = 0.5 kg.m2). Nothing is recorded: the first point fails."""
    drive = spec.Instance("drive", fmu="MotorStartup", parameters={"J_crank": 0.5, "n0": 60.0, "t0": 1.0, "l": 0.2})
    st = _self_loop("iterate").instances["structure"]
    sc = direct({"structure": st, "drive": drive},
                [("structure", "ax1O", "structure", "Fx_ball"), ("drive", "T_drive", "drive", "M_reaction")],
                [("drive", "T_drive"), ("structure", "ax1O")], start=0.123456789012, stop=0.2, step=0.01,
                master={"loop_max_iter": 3, "loop_tol": 1e-6, "loop_atol": 1e-9})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=True)
    pdd = quadratic_law(60.0, 1.0, 0.123456789012)[2]
    residual = 0.5 * pdd  # J psi''
    message = ("AlgebraicLoopError: algebraic loop structure.ax1O -> structure.Fx_ball; drive.T_drive -> "
               "drive.M_reaction did not converge at t = 0.123456789 s after loop_max_iter = 3 sweeps: "
               f"drive.T_drive still changed by {residual:.3g} (accepted: loop_tol = 1e-06 relative + "
               "loop_atol = 1e-09); the loop's gain is too large for a fixed-point iteration, or an FMU does "
               "not recompute its outputs when its inputs are set")
    assert f"{residual:.3g}" == "5.51"
    assert (res.success, res.message, res.steps, res.loop_sweeps) == (False, message, 0, 0)
    assert res.data.shape == (0, 3)
    assert res.loops == [["structure.ax1O -> structure.Fx_ball"], ["drive.T_drive -> drive.M_reaction"]]
    assert capsys.readouterr().err == f"\nrun failed: {message}\n"


def test_initialisation_passes_values_around_five_times(native_models, native_fmus):
    """The drive's self-loop ignored: in initialisation mode the master passes the values
    around five times, T_drive alternating J psi'' (pass 1: the input at its start value 0),
    0, J psi'', 0, J psi''; the first point reads that value, the second J psi''(t_1) - J psi''(t_0)."""
    drive = spec.Instance("drive", fmu="MotorStartup", parameters={"J_crank": 0.5, "n0": 60.0, "t0": 1.0})
    sc = direct({"drive": drive}, [("drive", "T_drive", "drive", "M_reaction")], [("drive", "T_drive")],
                start=0.1, stop=0.12, step=0.01, master={"algebraic_loops": "ignore"})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success
    T = res.column("drive.T_drive")
    J0, J1 = (0.5 * quadratic_law(60.0, 1.0, t)[2] for t in (0.1, 0.11))
    assert T[0] == pytest.approx(J0, rel=1e-14)
    assert T[1] == pytest.approx(J1 - J0, rel=1e-12)


def test_a_source_feeding_a_loop_is_read_at_the_same_point(native_models, native_fmus):
    """A table's ground acceleration into a structure whose acceleration is fed back as its
    ball force: a = a_g + (-L a_g - C v - K x + a)/M at every point. The sweeps set every
    input of the loop's instance from the freshest values: the structure's a_g is the table's
    value at the same point (not the point before, as the Jacobi exchange alone would give)."""
    st = spec.Instance("structure", fmu="Structure",
                       parameters={"M_x1": 5.0, "L_x1": 2.0, "f_x1": 1.0, "zeta_x1": 0.2, "input_order": 0})
    src = table("ground", ["ag"], [0.0, 0.04, 0.07, 0.1], [lambda t: 0.5 + 30.0 * t - 100.0 * t ** 3])
    sc = direct({"structure": st, "ground": src},
                [("ground", "ag", "structure", "ag_x"), ("structure", "ax1O", "structure", "Fx_ball")],
                [("structure", v) for v in ("ax1O", "x_rel", "vx1O", "vxg", "agx_total")],
                master={"loop_tol": 1e-12})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success and res.loops == [["structure.ax1O -> structure.Fx_ball"]]
    c = res.column
    t = c("time")
    ag = 0.5 + 30.0 * t - 100.0 * t ** 3
    assert np.allclose(c("structure.agx_total"), ag, rtol=1e-13)
    M, L, w = 5.0, 2.0, 2 * math.pi
    a, x, v = c("structure.ax1O"), c("structure.x_rel"), c("structure.vx1O") - c("structure.vxg")
    assert np.allclose(a, ag + (-L * ag - 2 * 0.2 * M * w * v - M * w * w * x + a) / M, rtol=1e-10, atol=1e-12)


def test_loop_values_not_first_on_their_instance(native_models, native_fmus):
    """The loops' sources are not the first values their instances deliver (other connections
    come before them): the iteration still watches and names the right bus slots."""
    st = _self_loop("iterate").instances["structure"]
    drive = spec.Instance("drive", fmu="MotorStartup", parameters={"J_crank": 0.5, "n0": 60.0, "t0": 2.5})
    other = spec.Instance("other", fmu="MotorStartup")
    conns = [("structure", "vx1O", "other", "M_reaction"), ("structure", "ax1O", "structure", "Fx_ball")]
    rec = [("structure", v) for v in ("ax1O", "x_rel", "vx1O", "Fx_exc")]
    res = runner.run(direct({"structure": st, "drive": drive, "other": other}, conns, rec),
                     native_models, native_fmus, progress=False, echo=False)
    assert res.success, res.message
    a, R = _residual_terms(res, 10.0)
    assert np.allclose(a * 9.0, R, rtol=1e-9, atol=1e-12)
    conns = [("drive", "x1O", "other", "M_reaction"), ("structure", "vx1O", "structure", "ag_y"),
             ("structure", "ax1O", "structure", "Fx_ball"), ("drive", "T_drive", "drive", "M_reaction")]
    sc = direct({"structure": st, "drive": drive, "other": other}, conns, rec, master={"loop_max_iter": 3})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    residual = 0.5 * quadratic_law(60.0, 2.5, 0.0)[2]
    assert res.message.startswith(
        "AlgebraicLoopError: algebraic loop structure.ax1O -> structure.Fx_ball; drive.T_drive -> drive.M_reaction "
        f"did not converge at t = 0 s after loop_max_iter = 3 sweeps: drive.T_drive still changed by {residual:.3g} ")


def test_loop_max_iter_is_the_number_of_sweeps_allowed(native_models, native_fmus):
    """With no tolerance (loop_tol = loop_atol = 0: settled when a sweep changes nothing) the
    structure's loop takes one sweep at the first point (initialisation already settled it)
    and N at the second (a table ending before the third point ends the run there);
    loop_max_iter = N converges, N - 1 stops with the error; one sweep a point suffices when
    the tolerance accepts any change, also for loop_max_iter = 1."""
    src = table("src", ["ag"], [0.0, 0.015], [lambda t: 1.0])

    def run(**master):
        sc = _self_loop("iterate", master=master)
        sc.instances["src"] = src
        sc.connections.append(("src", "ag", "structure", "ag_x"))
        return runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    first = run(loop_tol=0.0, loop_atol=0.0)
    N = first.loop_sweeps - 1
    assert first.message == "ValueError: the table covers t = 0 .. 0.015 s, asked for t = 0.02 s"
    assert first.data.shape[0] == 2 and 3 <= N <= 49
    assert run(loop_tol=0.0, loop_atol=0.0, loop_max_iter=N).loop_sweeps == N + 1
    short = run(loop_tol=0.0, loop_atol=0.0, loop_max_iter=N - 1)
    assert short.message.startswith("AlgebraicLoopError: algebraic loop structure.ax1O -> structure.Fx_ball "
                                    f"did not converge at t = 0.01 s after loop_max_iter = {N - 1} sweeps: "
                                    "structure.ax1O still changed by ")
    one = run(loop_atol=1e3, loop_max_iter=1)
    assert one.loop_sweeps == 2 and one.message.startswith("ValueError: the table covers")


def test_an_input_refused_in_a_loop_sweep_stops_the_run_before_the_point_is_recorded(native_models, native_fmus):
    """The loop's instance also takes a fixed parameter from a connection (built without the
    checker, which refuses it): accepted in initialisation mode, refused by the first sweep's
    fmi2SetReal; nothing is recorded."""
    src = table("src", ["m"], [0.0, 0.1], [lambda t: 10.0])
    sc = _self_loop("iterate")
    sc.instances["src"] = src
    sc.connections.append(("src", "m", "structure", "M_x1"))
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    why = ("Structure 'structure': fmi2SetReal: M_x1 cannot be set in state stepComplete: parameter M_x1 is fixed: "
           "it can be set only before fmi2ExitInitializationMode (fmi2Reset, then set it); M_x1 = 10.0 kg refused, "
           "M_x1 keeps 10.0 kg")
    assert (res.success, res.steps, res.loop_sweeps, res.data.shape) == (False, 0, 0, (0, 5))
    assert res.message == f"FMICallException: fmi2SetReal failed with status 3 (error). {why}"


def test_initialisation_passes_until_the_values_settle_at_most_five_times(native_models, native_fmus):
    """Two drives, each one's torque the other's input (a loop left to the Jacobi exchange):
    T_a = A - T_b, T_b = B - T_a with A, B = J psi''(t_0) of each. The initialisation passes
    go a then b five times (the values never settle): T_a = A, T_b = B - A, then 2A - B,
    2B - 2A, ..., 5A - 4B and 5B - 5A at the first point."""
    a = spec.Instance("a", fmu="MotorStartup", parameters={"J_crank": 0.3, "n0": 60.0, "t0": 1.0})
    b = spec.Instance("b", fmu="MotorStartup", parameters={"J_crank": 0.1, "n0": 30.0, "t0": 1.0})
    sc = direct({"a": a, "b": b}, [("a", "T_drive", "b", "M_reaction"), ("b", "T_drive", "a", "M_reaction")],
                [("a", "T_drive"), ("b", "T_drive")], start=0.2, stop=0.21, step=0.01,
                master={"algebraic_loops": "ignore"})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert res.success
    A, B = 0.3 * quadratic_law(60.0, 1.0, 0.2)[2], 0.1 * quadratic_law(30.0, 1.0, 0.2)[2]
    assert res.column("a.T_drive")[0] == pytest.approx(5 * A - 4 * B, rel=1e-12)
    assert res.column("b.T_drive")[0] == pytest.approx(5 * B - 5 * A, rel=1e-12)
