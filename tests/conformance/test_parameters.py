"""Parameters (docs/conformance.md, "parameters"): fixed ones are refused after
initialisation with the value unchanged, tunable ones take effect; a refused
initialisation names the FMU variable, the value and the accepted range; nothing
non-finite is ever published."""
from __future__ import annotations

import pytest

from .conftest import MODELS, OK
from .inputs import feed, run_ball

FIXED = {"BallInShell": ("m", 2.0), "MotorStartup": ("l", 0.7), "InductionMotor": ("i", 30.0),
         "Structure": ("M_x1", 50.0),
         "Fig1Drive": ("Omega_frame", 0.8)}


def _initialised(open_fmu, model, **parameters):
    fmu = open_fmu(model, **parameters)
    if model == "BallInShell":
        feed(fmu, 0.0)
    assert fmu.init() == OK, fmu.messages()
    return fmu


@pytest.mark.parametrize("model", MODELS)
def test_fixed_parameter_set_after_initialisation_is_refused_value_unchanged(open_fmu, flavour, model):
    name, value = FIXED[model]
    fmu = _initialised(open_fmu, model)
    old = fmu.get(name)
    n = len(fmu.log)
    assert fmu.set(**{name: value}) == flavour.refusal
    msg = fmu.messages(n)
    assert f"parameter {name} is fixed" in msg and f"{name} = {value!r}" in msg
    assert f"{name} keeps {old!r}" in msg
    if flavour.usable_after_refusal:
        assert fmu.get(name) == old


@pytest.mark.parametrize("model", MODELS)
def test_every_parameter_is_fixed_unless_declared_tunable(fmus, model):
    from fmpy import read_model_description

    md = read_model_description(str(fmus[model]))
    tunable = {v.name for v in md.modelVariables if v.causality == "parameter" and v.variability == "tunable"}
    assert tunable == ({"coupling_warn"} if model == "BallInShell" else set())


def test_a_tunable_parameter_takes_effect_at_the_next_step(open_fmu, flavour):
    fmu, st = run_ball(open_fmu, [2e-3] * 5, coupling_warn=1.0)
    assert fmu.set(coupling_warn=0.0) == OK
    assert fmu.get("coupling_warn") == 0.0
    n = len(fmu.log)
    feed(fmu, fmu.time)
    assert fmu.step(2e-3) == OK
    assert "coupling_warn = 0 m" in fmu.messages(n)  # warns now with the new threshold
    n = len(fmu.log)
    feed(fmu, fmu.time)
    assert fmu.step(2e-3) == OK and fmu.get("coupling_error") > 0.0
    assert "coupling_warn" not in fmu.messages(n)  # warned once
    n = len(fmu.log)
    assert fmu.set(coupling_warn=-1.0) == flavour.refusal
    assert "tunable parameter coupling_warn = -1.0 m refused: accepted range [0, inf] m" in fmu.messages(n)
    if flavour.usable_after_refusal:
        assert fmu.get("coupling_warn") == 0.0


@pytest.mark.parametrize("model, name, value, expected", [
    ("BallInShell", "delta", -1.0, "parameter delta = -1.0 m is outside its accepted range [0, "),
    ("BallInShell", "c_drag", 1e300, "parameter c_drag = 1e+300 N.s/m is outside its accepted range [0, 28489.3] "
     "N.s/m (1e4 m omega0: a viscous time constant m/c_drag below 1e-4/omega0 makes the equations too stiff for "
     "the explicit integrators)"),
    ("BallInShell", "m", 1e300, "parameter m = 1e+300 kg is outside its accepted range [0, 1e+06] kg"),
    ("BallInShell", "wx0", 1e300, "parameter wx0 = 1e+300 rad/s is outside its accepted range [-10000, 10000]"),
    ("BallInShell", "r", 0.3, "R must be larger than r"),
    # inside the declared range [0, ...] but not positive: refused by the model's own checks
    ("BallInShell", "r", 0.0, "r must be positive and finite, got r = 0.0 m"),
    ("BallInShell", "m", 0.0, "m must be positive and finite, got m = 0.0 kg"),
    ("BallInShell", "g", 0.0, "g must be positive and finite, got g = 0.0 m/s2"),
    ("BallInShell", "R", float("nan"), "parameter R = nan m is outside its accepted range"),
    ("MotorStartup", "l", 1e300, "parameter l = 1e+300 m is outside its accepted range [0, 1000] m"),
    ("MotorStartup", "t0", 1e300, "parameter t0 = 1e+300 s is outside its accepted range [0.001, 1e+06] s"),
    ("Structure", "zeta_x1", -0.1, "parameter zeta_x1 = -0.1 is outside its accepted range [0, 100]"),
    ("Structure", "n_x", 0, "parameter n_x = 0 is outside its accepted range [1, 3]"),
    ("Structure", "M_y2", 0.0, "parameter M_y2 = 0.0 kg is outside its accepted range [1e-12, 1e+15] kg"),
    ("MotorStartup", "t0", 1e-300, "parameter t0 = 1e-300 s is outside its accepted range [0.001, 1e+06] s"),
    ("MotorStartup", "l", 0.0, "l must be positive and finite, got l = 0.0 m"),  # inside [0, 1000]
    ("InductionMotor", "i", 1e300, "parameter i = 1e+300 is outside its accepted range [0.001, 10000]"),
    ("InductionMotor", "i", 1e-300, "parameter i = 1e-300 is outside its accepted range [0.001, 10000]"),
    ("InductionMotor", "eta", 2.0, "parameter eta = 2.0 is outside its accepted range [0, 1]"),
    # inside the declared range, refused by the model: both flavours name the FMU's parameter
    ("InductionMotor", "Tb_ratio", 1.0, "Tb_ratio Tb/Tn must be larger than 1 (Kloss's formula has no rated point "
     "otherwise), got Tb_ratio = 1.0"),
    ("InductionMotor", "Rs_share", 1.0, "Rs_share must lie in [0, 1), got Rs_share = 1.0"),
    ("InductionMotor", "f_start", 1.0, "f_start must lie in [0, 1), got f_start = 1.0"),
    ("InductionMotor", "J_rotor", 0.0, "J_rotor must be positive, got J_rotor = 0.0 kg m2"),
    ("Fig1Drive", "t0_frame", 0.0, "parameter t0_frame = 0.0 s is outside its accepted range [0.001, 1e+06] s"),
    ("Fig1Drive", "Omega_frame", float("inf"), "parameter Omega_frame = inf rad/s is outside its accepted range"),
    ("Fig1Drive", "zc", -1e4, "parameter zc = -10000.0 m is outside its accepted range [-1000, 1000] m"),
    ("Fig1Drive", "shaft", 3, "parameter shaft = 3 is outside its accepted range [1, 2]"),
    ("Fig1Drive", "frame_law", -1, "parameter frame_law = -1 is outside its accepted range [0, 4]"),
    ("Fig1Drive", "m_platform", -1.0, "parameter m_platform = -1.0 kg is outside its accepted range [0, "),
    # the hybrid contact's parameters
    ("BallInShell", "mu_k", 0.5, "parameter mu_k = 0.5 is outside its accepted range: -1 (equal to mu) or [0, "
     "mu = 0.3] (kinetic friction does not exceed static friction)"),
    ("BallInShell", "mu_k", -0.5, "parameter mu_k = -0.5 is outside its accepted range: -1 (equal to mu) or [0, "),
    ("BallInShell", "e_n", 1.5, "parameter e_n = 1.5 is outside its accepted range [0, 1]"),
    ("BallInShell", "e_n", -0.1, "parameter e_n = -0.1 is outside its accepted range [0, 1]"),
    ("BallInShell", "v_rest", 0.0, "v_rest must be positive and finite, got v_rest = 0.0 m/s"),
    ("BallInShell", "v_rest", -1.0, "parameter v_rest = -1.0 m/s is outside its accepted range [0, 1000] m/s"),
    ("BallInShell", "creep_eps", -1e-3, "parameter creep_eps = -0.001 m/s is outside its accepted range [0, 1000] m/s"),
    ("BallInShell", "creep_eps", float("nan"), "parameter creep_eps = nan m/s is outside its accepted range [0, 1000] "
     "m/s"),
    ("BallInShell", "creep_eps", float("inf"), "parameter creep_eps = inf m/s is outside its accepted range [0, 1000] "
     "m/s"),
    ("BallInShell", "contact_model", 3, "parameter contact_model = 3 is outside its accepted range [1, 2]"),
])
def test_refused_initialisation_names_variable_value_and_range(open_fmu, flavour, model, name, value, expected):
    fmu = open_fmu(model, **{name: value})
    if model == "BallInShell":
        feed(fmu, 0.0)
    assert fmu.init() == flavour.refusal
    msg = fmu.messages()
    assert expected in msg, msg
    assert "rolling_resistance" not in msg and "drag =" not in msg.replace("c_drag =", "")


@pytest.mark.parametrize("parameters, expected", [
    (dict(formulation=2), "contact_model = 2 needs formulation = 1 (the paper's coordinates end at the chamber's "
     "equator; a sliding or flying ball is followed in fixed axes), got formulation = 2"),
    (dict(c_drag=0.5), "contact_model = 2 models no ground-material losses off rolling: delta = 0.0 m and c_drag = "
     "0.5 N.s/m must be 0"),
    (dict(delta=1e-3), "contact_model = 2 models no ground-material losses off rolling: delta = 0.001 m and c_drag "
     "= 0.0 N.s/m must be 0"),
    (dict(bed=1, h_bed=0.05), "contact_model = 2 has no material bed: bed = 1 must be 0 (the hybrid ball models no "
     "ground-material losses)")])
def test_the_hybrid_contact_refuses_what_it_does_not_model(open_fmu, flavour, parameters, expected):
    """contact_model = 2 models no ground-material losses and follows the ball in fixed axes:
    each configuration it cannot run is refused at initialisation, named with its value."""
    fmu = open_fmu("BallInShell", contact_model=2, **parameters)
    feed(fmu, 0.0)
    assert fmu.init() == flavour.refusal
    assert expected in fmu.messages(), fmu.messages()


@pytest.mark.parametrize("model", MODELS)
def test_reset_after_a_refused_initialisation_works(open_fmu, flavour, model):
    if not flavour.usable_after_refusal:
        pytest.skip(f"{flavour}: an instance is gone after a refused initialisation (fmi2Fatal)")
    bad = {"BallInShell": {"m": -1.0}, "MotorStartup": {"t0": 0.0}, "InductionMotor": {"i": 0.0},
           "Structure": {"f_x1": 0.0}, "Fig1Drive": {"t0_frame": 0.0}}[model]
    fmu = open_fmu(model, **bad)
    if model == "BallInShell":
        feed(fmu, 0.0)
    assert fmu.init() != OK
    assert fmu.reset() == OK
    if model == "BallInShell":
        feed(fmu, 0.0)
    assert fmu.init() == OK
    assert fmu.step(1e-3) == OK


def test_outputs_keep_their_sign_and_never_carry_nan(open_fmu):
    """The one output allowed to be infinite (friction_ratio when N <= 0) is +1e300; every
    other output is finite or the step is refused."""
    fmu, st = run_ball(open_fmu, [2e-3] * 300, t0=0.5)
    for name, v in fmu.outputs().items():
        if isinstance(v, float):
            assert v == v and abs(v) < 1e300 or name in ("friction_ratio", "t_invalid", "t_first_slip", "t_first_flight"), (name, v)


def test_a_bed_deeper_than_the_chamber_is_refused_naming_the_limit(open_fmu, flavour):
    """h_bed's declared range cannot know R: with bed = 1 the model refuses a bed whose surface
    lies above the chamber's highest point, naming the limit 2 R it computed."""
    fmu = open_fmu("BallInShell", bed=1, h_bed=0.6)
    feed(fmu, 0.0)
    assert fmu.init() == flavour.refusal
    assert "h_bed = 0.6 m is outside its accepted range [0, 2 R = 0.5] m with bed = 1" in fmu.messages()
