"""The built FMUs, as an FMI importer (fmpy) sees them.

Model descriptions (fmpy validation, units, InitialUnknowns), BallInShell's
behaviour through fmpy.simulate_fmu and through fmpy's FMU2Slave (refused
steps, loss of contact, FMU state save/restore, several instances), and the
paper formulation's refusal at the equator in a coupled run with MotorStartup.

The FMUs are built once per session into a temporary folder (conftest.py).
"""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu
from scipy.special import ellipk

from ballmill.physics import Ball, BallModel, Fixed, simulate
from fmu_instance import Instance, Opened

MODELS = ("BallInShell", "MotorStartup")
BALL_OUTPUTS = ("xP", "yP", "zP", "N", "Fx", "Fy", "Fz", "M_reaction", "MAx", "MAy", "MAz",
                "xC", "yC", "zC", "wx", "wy", "wz", "Ft", "friction_ratio")
PLATFORM = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
DISCARD, WARNING, ERROR = 2, 1, 3


@pytest.fixture
def instances():
    """Open instances, closed after the test whatever happens."""
    opened = Opened()
    yield opened.open
    opened.close_all()


def platform_path(t):
    """A smooth platform motion, positions only (for input_mode = 2)."""
    return 0.02 * math.sin(3.0 * t) + 0.01 * t * t, 0.015 * math.cos(2.0 * t) - 0.015


def _ball_mass(built_fmus):
    md = read_model_description(str(built_fmus["BallInShell"]))
    start = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"
             and v.type == "Real"}
    return start["m"], start["g"]


# -- model descriptions ---------------------------------------------------------------
def test_both_models_are_built(built_fmus):
    assert set(MODELS) <= set(built_fmus)


@pytest.mark.parametrize("model", MODELS)
def test_fmpy_validation_is_clean(built_fmus, model):
    path = built_fmus[model]
    assert validate_fmu(str(path)) == []
    # and the command-line tool says the same
    cli = subprocess.run([sys.executable, "-m", "fmpy", "validate", str(path)], capture_output=True,
                         text=True, timeout=120)
    assert cli.returncode == 0, cli.stdout + cli.stderr
    assert "No problems found" in cli.stdout


@pytest.mark.parametrize("model", MODELS)
def test_every_real_has_unit_and_description(built_fmus, model):
    md = read_model_description(str(built_fmus[model]))
    defined = {u.name for u in md.unitDefinitions}
    reals = [v for v in md.modelVariables if v.type == "Real"]
    assert reals
    for v in reals:
        assert v.unit, f"{model}.{v.name} has no unit"
        assert v.unit in defined, f"{model}.{v.name}: unit {v.unit!r} not in UnitDefinitions"
        assert v.description and v.description.strip(), f"{model}.{v.name} has no description"
    for v in md.modelVariables:  # Integers and Booleans need a description too
        assert v.description, f"{model}.{v.name} has no description"


@pytest.mark.parametrize("model", MODELS)
def test_initial_unknowns_cover_every_output(built_fmus, model):
    md = read_model_description(str(built_fmus[model]))
    outputs = {o.variable.name for o in md.outputs}
    assert outputs
    from ballmill.fmi.interface import INTERFACES

    # the native flavour's Model Exchange adds its continuous states and their derivatives (FMI
    # 2.0 lists them among the InitialUnknowns); the outputs then depend on the states too
    me = INTERFACES[model].model_exchange if md.modelExchange is not None else None
    states = {row[0] for row in me.states} if me else set()
    assert {u.variable.name for u in md.initialUnknowns} == outputs | states | {f"der({n})" for n in states}
    for o in md.outputs:  # direct feedthrough exactly where the interface declares it
        declared = sorted(INTERFACES[model][o.variable.name].feedthrough)
        inputs = sorted(d.name for d in o.dependencies if d.causality != "local")
        assert inputs == declared, f"{model}.{o.variable.name}: {o.dependencies}"
    if model == "BallInShell":  # the force follows the chamber's acceleration (docs/conformance.md)
        assert {o.variable.name for o in md.outputs if o.dependencies} >= {"Fx", "Fy", "N", "M_reaction"}
    deps = {u.variable.name: sorted(d.name for d in (u.dependencies or [])) for u in md.initialUnknowns}
    if model == "MotorStartup":
        assert deps["T_drive"] == ["M_reaction"] and deps["P_drive"] == ["M_reaction"]
        assert deps["psi"] == []
    else:
        # the outputs depend on every input at initialisation: the platform's and, with motion = 2,
        # the chamber's vertical motion and rotation (motion = 2)
        from ballmill.fmi.interface import BALL_MOTION_INPUTS
        assert deps["N"] == sorted(PLATFORM + BALL_MOTION_INPUTS)


# -- BallInShell through simulate_fmu --------------------------------------------------
def test_default_run_rests_exactly_at_the_bottom(built_fmus):
    res = simulate_fmu(str(built_fmus["BallInShell"]), stop_time=2.0, output_interval=1e-3)
    m, g = _ball_mass(built_fmus)
    assert len(res) == 2001 and res["time"][-1] == pytest.approx(2.0)
    for name in ("xP", "yP", "zP", "xC", "yC", "Fx", "Fy", "M_reaction", "wx", "wy", "wz"):
        assert np.all(res[name] == 0.0), name
    assert np.all(res["zC"] == pytest.approx(0.025, rel=1e-12))
    assert np.all(res["N"] == pytest.approx(m * g, rel=1e-14))
    assert np.all(res["Fz"] == pytest.approx(-m * g, rel=1e-14))
    assert np.all(res["contact"]) and np.all(res["rolling"])


def test_oscillation_matches_monolithic_run_and_pendulum_period(built_fmus):
    stop, dt, x0 = 3.0, 1e-3, 0.05
    res = simulate_fmu(str(built_fmus["BallInShell"]), stop_time=stop, output_interval=dt,
                       start_values={"xC0": x0})
    model = BallModel(Ball())
    ref = simulate(model, Fixed(), t_end=stop, dt=dt, state=model.initial(x0))
    assert ref.success and len(ref.t) == len(res)
    np.testing.assert_allclose(res["time"], ref.t, rtol=0, atol=1e-12)
    for name in ("xP", "yP", "zP"):
        assert np.max(np.abs(res[name] - ref[name])) <= 1e-7, name
    assert np.max(np.abs(res["N"] - ref["N"])) <= 1e-6

    # period from the zero crossings of xP (linear interpolation) vs the exact pendulum
    # period with the reduced gravity 5 g / 7 and length R - r, amplitude theta0
    t, x = res["time"], res["xP"]
    k = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    crossings = t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])
    assert len(crossings) >= 4
    period = 2.0 * np.mean(np.diff(crossings))
    ball = Ball()
    w0 = math.sqrt(5.0 * ball.g / (7.0 * (ball.R - ball.r)))
    theta0 = math.asin(x0 / (ball.R - ball.r))
    exact = 4.0 * ellipk(math.sin(theta0 / 2.0) ** 2) / w0
    assert period == pytest.approx(exact, rel=1e-7)  # measured: 7e-11
    # the amplitude correction is visible: the small-oscillation period is 0.3 % shorter
    assert period > 1.002 * 2.0 * math.pi / w0


BAD_PARAMETERS = [
    ({"r": 0.3}, ["r = 0.3 m", "R = 0.25 m", "R must be larger than r"]),
    ({"r": 0.25}, ["r = 0.25 m", "R = 0.25 m", "R must be larger than r"]),
    ({"m": -1.0}, ["m = -1.0 kg", "accepted range [0, 1e+06] kg"]),
    ({"m": 0.0}, ["m = 0.0 kg", "positive"]),
    ({"m": float("nan")}, ["m = nan", "accepted range"]),
    ({"xC0": 0.3}, ["xC0 = 0.3 m", "<= 0.225 m"]),
    ({"formulation": 3}, ["formulation = 3", "accepted range [1, 2]"]),
]


@pytest.mark.parametrize("start_values,expected", BAD_PARAMETERS,
                         ids=["r>R", "r=R", "m<0", "m=0", "m=nan", "xC0-out-of-reach", "formulation=3"])
def test_bad_parameters_fail_initialisation_with_a_message(built_fmus, start_values, expected):
    messages = []

    def logger(env, instance, status, category, message):
        messages.append((status, message.decode() if message else ""))
    with pytest.raises(FMICallException) as info:
        simulate_fmu(str(built_fmus["BallInShell"]), stop_time=0.01, output_interval=1e-3,
                     start_values=start_values, debug_logging=True, logger=logger)
    assert info.value.function == "fmi2ExitInitializationMode"
    errors = [m for s, m in messages if s == ERROR and "initialisation failed" in m]
    assert len(errors) == 1, messages
    for fragment in expected:
        assert fragment in errors[0], (fragment, errors[0])


# -- refused steps ----------------------------------------------------------------------
@pytest.mark.parametrize("bad_input,input_mode", [("x1O", 2), ("ay1O", 1)])
def test_non_finite_input_is_discarded_and_the_run_can_continue(built_fmus, instances, bad_input,
                                                                input_mode):
    path, H, n = built_fmus["BallInShell"], 0.01, 12

    def inputs(t):
        x, y = platform_path(t)
        return {"x1O": x, "y1O": y, "vx1O": 0.06 * math.cos(3 * t), "vy1O": 0.0,
                "ax1O": -0.18 * math.sin(3 * t), "ay1O": -0.06 * math.cos(2 * t)}

    ref = instances(path, "reference", xC0=0.04, yC0=-0.02, input_mode=input_mode)
    ball = instances(path, "ball", xC0=0.04, yC0=-0.02, input_mode=input_mode)
    ref.initialize()
    ball.initialize()
    expected = []
    for k in range(n):
        ref.set(**inputs(k * H))
        ref.fmu.doStep(k * H, H)
        expected.append(ref.reals(BALL_OUTPUTS))
    got = []
    for k in range(n):
        t = k * H
        ball.set(**inputs(t))
        if k == 5:
            before = ball.reals(BALL_OUTPUTS) + [ball.get("contact"), ball.get("rolling")]
            ball.set(**{bad_input: float("nan")})
            with pytest.raises(FMICallException) as info:
                ball.fmu.doStep(t, H)
            assert info.value.status == DISCARD
            discards = [m for s, m in ball.messages if s == DISCARD]
            assert len(discards) == 1
            assert f"input {bad_input} must be finite" in discards[0] and "nan" in discards[0]
            assert "last good state kept" in discards[0]
            # outputs bitwise as before the refused step
            assert ball.reals(BALL_OUTPUTS) + [ball.get("contact"), ball.get("rolling")] == before
            ball.set(**inputs(t))  # a finite value again: retry the same step
        ball.fmu.doStep(t, H)
        got.append(ball.reals(BALL_OUTPUTS))
    assert got == expected  # bitwise: the refused step left no trace
    assert all(s < DISCARD for s, _ in ref.messages)


def _coupled_run(built_fmus, instances, formulation, stop=1.0, H=0.002, n0=90.0, t0=1.0):
    """MotorStartup -> BallInShell (and the reaction torque back), Jacobi steps of H."""
    drive = instances(built_fmus["MotorStartup"], "drive", n0=n0, t0=t0)
    ball = instances(built_fmus["BallInShell"], f"ball_f{formulation}", formulation=formulation)
    drive.initialize()
    ball.set(**{s: drive.get(s) for s in PLATFORM})
    ball.initialize()
    rows, refused = [], None
    for k in range(int(round(stop / H))):
        t = k * H
        rows.append([t] + ball.reals(("xP", "yP", "zP", "N", "zC", "M_reaction")))
        platform = {s: drive.get(s) for s in PLATFORM}
        drive.set(M_reaction=ball.get("M_reaction"))
        ball.set(**platform)
        try:
            ball.fmu.doStep(t, H)
        except FMICallException as e:
            refused = (t, e)
            break
        drive.fmu.doStep(t, H)
    else:
        rows.append([stop] + ball.reals(("xP", "yP", "zP", "N", "zC", "M_reaction")))
    return np.array(rows), refused, ball


def test_paper_formulation_refuses_near_the_equator_instead_of_nan(built_fmus, instances):
    rows, refused, ball = _coupled_run(built_fmus, instances, formulation=2)
    assert refused is not None, "the paper formulation should stop before the equator"
    t_fail, e = refused
    assert e.status == DISCARD and 0.3 < t_fail < 1.0
    discards = [m for s, m in ball.messages if s == DISCARD]
    assert len(discards) == 1 and "equator" in discards[0] and "vector" in discards[0]
    assert np.all(np.isfinite(rows))
    R, d = 0.25, 0.225
    assert R - rows[-1, 5] < 0.03 * d  # the last good point is close to the equator (zC -> R)
    # the outputs still hold the last good state
    assert ball.reals(("zC",))[0] == rows[-1, 5]

    # the vector formulation runs the same case to the end, and agrees where both are valid
    rows1, refused1, ball1 = _coupled_run(built_fmus, instances, formulation=1)
    assert refused1 is None, refused1
    assert rows1[-1, 0] == pytest.approx(1.0) and np.all(np.isfinite(rows1))
    assert not [m for s, m in ball1.messages if s >= DISCARD]
    n = len(rows)
    assert np.max(np.abs(rows1[:n, 1:4] - rows[:, 1:4])) < 1e-6


def test_loss_of_contact_is_reported(built_fmus, instances):
    # ball high on the wall (xC0 = 0.2 m of R - r = 0.225 m), then the chamber is suddenly
    # accelerated towards +x (input_mode 3 holds ax1O): the wall moves away from the ball
    ball = instances(built_fmus["BallInShell"], "ball", xC0=0.2, input_mode=3)
    ball.initialize()
    H = 1e-3
    for k in range(10):
        ball.fmu.doStep(k * H, H)
    assert ball.get("contact") and ball.get("N") > 0
    assert not [m for s, m in ball.messages if "contact lost" in m]
    ball.set(ax1O=20.0)
    ball.fmu.doStep(10 * H, H)  # completes: a warning, not a refusal
    assert ball.get("contact") is False and ball.get("rolling") is False
    assert ball.get("N") < 0
    assert ball.get("friction_ratio") == 1e300
    lost = [(s, m) for s, m in ball.messages if "contact lost" in m]
    assert len(lost) == 1 and lost[0][0] == WARNING
    # judged at the communication point where the acceleration arrived, with the true inputs
    assert "0.01 s (N = -" in lost[0][1]


# -- state save/restore -------------------------------------------------------------------
def test_fmu_state_save_restore_is_bitwise_including_input_history(built_fmus, instances):
    path, H = built_fmus["BallInShell"], 0.01
    ball = instances(path, "ball", xC0=0.03, input_mode=2)  # positions: a 6-sample history
    ball.initialize()

    def step(k, path_fn=platform_path):
        x, y = path_fn(k * H)
        ball.set(x1O=x, y1O=y)
        ball.fmu.doStep(k * H, H)
        return ball.reals(BALL_OUTPUTS) + [ball.get("contact")]

    for k in range(8):
        step(k)
    saved = ball.fmu.getFMUstate()
    first = [step(k) for k in range(8, 20)]

    # pollute state and input history with a different platform motion, then restore
    def other(t):  # the same motion up to the saved point, then it bends away
        x, y = platform_path(t)
        return x + 0.5 * (t - 8 * H) ** 2, y
    ball.fmu.setFMUstate(saved)
    polluted = [step(k, other) for k in range(8, 20)]
    assert polluted != first
    ball.fmu.setFMUstate(saved)
    again = [step(k) for k in range(8, 20)]
    assert again == first

    # serialised and read back, into the same instance and into a fresh one
    blob = ball.fmu.serializeFMUstate(saved)
    assert isinstance(blob, bytes) and len(blob) > 0
    restored = ball.fmu.deSerializeFMUstate(blob)
    ball.fmu.setFMUstate(restored)
    assert [step(k) for k in range(8, 20)] == first
    ball.fmu.freeFMUstate(restored)
    ball.fmu.freeFMUstate(saved)

    fresh = instances(path, "fresh", xC0=0.03, input_mode=2)
    fresh.initialize()
    state = fresh.fmu.deSerializeFMUstate(blob)
    fresh.fmu.setFMUstate(state)
    fresh.fmu.freeFMUstate(state)
    ball = fresh
    assert [step(k) for k in range(8, 20)] == first


def test_two_instances_with_different_parameters_are_independent(built_fmus, instances):
    path, H, n = built_fmus["BallInShell"], 0.005, 60
    params = {"a": dict(xC0=0.05, input_mode=2),
              "b": dict(R=0.3, r=0.03, m=0.9, xC0=-0.02, yC0=0.04, wz0=3.0, input_mode=2)}

    def run(names):
        insts = {nm: instances(path, f"{nm}_{'_'.join(names)}", **params[nm]) for nm in names}
        for inst in insts.values():
            inst.initialize()
        out = {nm: [] for nm in names}
        for k in range(n):
            x, y = platform_path(k * H)
            for nm, inst in insts.items():
                inst.set(x1O=x, y1O=y)
                inst.fmu.doStep(k * H, H)
                out[nm].append(inst.reals(BALL_OUTPUTS))
        return out

    together = run(["a", "b"])
    alone_a, alone_b = run(["a"])["a"], run(["b"])["b"]
    assert together["a"] == alone_a
    assert together["b"] == alone_b
    assert together["a"] != together["b"]
    # the instances use their own parameters: b's ball is heavier, its pressure larger
    assert together["b"][0][BALL_OUTPUTS.index("N")] > 1.5 * together["a"][0][BALL_OUTPUTS.index("N")]
