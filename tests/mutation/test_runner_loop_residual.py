"""The non-convergence message of an algebraic loop names the value furthest outside its
accepted change (ballmill/scenario/runner.py, run's solve_loops): with a tolerance, the
largest change over loop_tol |value| + loop_atol; with none (loop_tol = loop_atol = 0), the
first value that still changes, whatever its size. MotorStartup's self-loop (T_drive ->
M_reaction with direct feedthrough) changes by J psi''(t) at every sweep: a closed form."""
from __future__ import annotations

import re

from ballmill.scenario import runner, spec
from runner_cases import direct, quadratic_law


def _fragment(message):
    m = re.search(r"sweeps: (\S+) still changed by (\S+) \(accepted: loop_tol = (\S+) relative \+ loop_atol = (\S+)\)",
                  message)
    assert m, message
    return m.groups()


def test_without_tolerance_a_change_below_one_is_named(native_models, native_fmus):
    """A settled structure first on the bus, a drive whose torque changes by 0.1 psi'' < 1."""
    s = spec.Instance("s", fmu="Structure", parameters={"phi_x1": 0.0, "F0_x": 1.0, "f_exc": 3.0})
    d = spec.Instance("d", fmu="MotorStartup", parameters={"J_crank": 0.1})
    sc = direct({"s": s, "d": d}, [("s", "ax1O", "s", "Fx_ball"), ("d", "T_drive", "d", "M_reaction")], [("d", "psi")],
                start=0.1, master={"loop_tol": 0.0, "loop_atol": 0.0, "loop_max_iter": 2})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    change = 0.1 * quadratic_law(60.0, 2.5, 0.1)[2]
    assert 0.0 < change < 1.0
    assert not res.success
    assert _fragment(res.message) == ("d.T_drive", f"{change:.3g}", "0", "0")


def test_with_an_absolute_tolerance_the_largest_change_is_named(native_models, native_fmus):
    """Two drives' self-loops, the first changing by 0.1 psi'', the second by 0.5 psi'':
    with loop_atol = 1e-6 the second is the furthest outside."""
    a = spec.Instance("a", fmu="MotorStartup", parameters={"J_crank": 0.1})
    b = spec.Instance("b", fmu="MotorStartup", parameters={"J_crank": 0.5})
    sc = direct({"a": a, "b": b}, [("a", "T_drive", "a", "M_reaction"), ("b", "T_drive", "b", "M_reaction")],
                [("a", "psi")], start=0.1, master={"loop_tol": 0.0, "loop_atol": 1e-6, "loop_max_iter": 2})
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    change = 0.5 * quadratic_law(60.0, 2.5, 0.1)[2]
    assert not res.success
    assert _fragment(res.message) == ("b.T_drive", f"{change:.3g}", "0", "1e-06")
