"""The pythonfmu flavour's model descriptions (ballmill.fmi.slave.Slave.to_xml over
`declare`) against the native flavour's (ballmill.fmi.native.model_description) and the one
declaration both come from (ballmill.fmi.interface), read back with fmpy: every variable's
value reference, causality, variability, type, unit, bounds and start, the outputs and their
initial dependencies, the unit definitions and the default experiment. In-process, so that
mutmut sees the slave's declaration code (docs/mutation.md); tests/test_flavours.py compares
the built FMUs' behaviour."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest
from fmpy import read_model_description

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import SCRIPTS, slave_class, write_model_descriptions  # noqa: E402

from ballmill.fmi import native  # noqa: E402
from ballmill.fmi.interface import INTERFACES, UNITS  # noqa: E402


@pytest.fixture(scope="module")
def mds(tmp_path_factory):
    """model -> (pythonfmu md, native md, Interface)."""
    d = tmp_path_factory.mktemp("md")
    py = write_model_descriptions(d / "py")
    out = {}
    for model in SCRIPTS:
        path = d / "native" / model / "modelDescription.xml"
        path.parent.mkdir(parents=True)
        path.write_text(native.model_description(INTERFACES[model], "{guid}", ["a.c"]))
        out[model] = (read_model_description(str(py[model])), read_model_description(str(path)),
                      INTERFACES[model])
    return out


def _number(x):
    return None if x is None else float(x)


@pytest.mark.parametrize("model", sorted(SCRIPTS))
def test_every_variable_as_declared_in_both_flavours(mds, model):
    py, nat, iface = mds[model]
    assert [v.name for v in py.modelVariables] == [v.name for v in iface.variables]
    # the native flavour adds Model Exchange's states, derivatives and event indicators after them
    assert [v.name for v in nat.modelVariables] == [v.name for v in iface.native_variables]
    for vr, (p, n, d) in enumerate(zip(py.modelVariables, nat.modelVariables, iface.variables)):
        assert p.valueReference == n.valueReference == vr, d.name
        assert p.causality == n.causality == d.causality, d.name
        assert p.variability == n.variability == d.fmi_variability, d.name
        assert p.type == n.type == d.type, d.name
        assert p.unit == n.unit == d.unit, d.name
        if d.type == "Real":
            assert d.unit in UNITS, d.name
        assert _number(p.min) == _number(n.min) == _number(d.min), d.name
        assert _number(p.max) == _number(n.max) == _number(d.max), d.name
        if d.causality != "output":
            start = {"Real": float, "Integer": int, "Boolean": lambda s: s in (True, "true")}[d.type]
            assert start(p.start) == start(n.start) == d.start, d.name
            if d.type == "Integer" and d.min is not None:
                assert d.min <= d.start <= d.max, d.name
            if d.type == "Real" and d.min is not None:
                assert d.min <= d.start, d.name
            if d.type == "Real" and d.max is not None:
                assert d.start <= d.max, d.name


@pytest.mark.parametrize("model", sorted(SCRIPTS))
def test_outputs_and_their_initial_dependencies(mds, model):
    py, nat, iface = mds[model]
    outputs = [v.name for v in iface.variables if v.causality == "output"]
    me = iface.model_exchange
    states = [row[0] for row in me.states] if me else []
    for md in (py, nat):
        assert [u.variable.name for u in md.outputs] == outputs
        # direct feedthrough: exactly the declared one (BallInShell's force, Structure's accelerations);
        # with Model Exchange (native) the continuous outputs depend on the states too
        feed = {v.name: sorted(v.feedthrough) for v in iface.variables if v.causality == "output"}
        assert {u.variable.name: sorted(d.name for d in u.dependencies if d.causality != "local")
                for u in md.outputs} == feed
        extra = (states + [f"der({n})" for n in states]) if md is nat else []
        assert [u.variable.name for u in md.initialUnknowns] == outputs + extra
        depends = {v.name: sorted(v.depends) for v in iface.variables if v.causality == "output"}
        assert {u.variable.name: sorted(d.name for d in u.dependencies) for u in md.initialUnknowns
                if u.variable.name in depends} == depends
    if model == "BallInShell":  # its outputs at the start follow the position inputs
        assert any(v.depends for v in iface.variables)


@pytest.mark.parametrize("model", sorted(SCRIPTS))
def test_units_are_defined_once_each_as_the_table_says(mds, model):
    py, nat, iface = mds[model]
    for md in (py, nat):
        used = {v.unit for v in (iface.native_variables if md is nat else iface.variables) if v.unit}
        defs = {u.name: u for u in md.unitDefinitions}
        assert set(defs) == used
        for name, u in defs.items():
            spec = dict(UNITS[name])
            factor = spec.pop("factor", 1.0)
            bu = u.baseUnit
            for k in ("kg", "m", "s", "A", "K", "mol", "cd", "rad"):
                assert getattr(bu, k) == spec.get(k, 0), (name, k)
            assert bu.factor == factor and bu.offset == 0.0, name


@pytest.mark.parametrize("model", sorted(SCRIPTS))
def test_default_experiment_and_identity(mds, model):
    py, nat, iface = mds[model]
    start, stop, step = iface.default_experiment[:3]
    for md in (py, nat):
        de = md.defaultExperiment
        assert (float(de.startTime), float(de.stopTime), float(de.stepSize)) == (start, stop, step)
        assert md.modelName == model and md.description == iface.description
        assert md.author == "ballmill" and md.license == "MIT"


# -- the declaration's own checks ----------------------------------------------------------
def test_a_real_without_unit_or_with_an_unknown_unit_is_refused():
    slave = slave_class("MotorStartup")(instance_name="decl")
    with pytest.raises(ValueError) as info:
        slave.add("z", "parameter", 1.0, "a length")
    assert str(info.value) == "Real variable 'z' needs a unit"
    with pytest.raises(ValueError) as info:
        slave.add("z", "parameter", 1.0, "a length", "furlong")
    assert str(info.value) == "unit 'furlong' of 'z' is not in UNITS"
    slave.add("k", "parameter", 3, "a count")  # an Integer needs none
    assert slave.k == 3 and slave._meta["k"]["type"] is int


def test_variabilities_follow_causality_type_and_tunable():
    slave = slave_class("MotorStartup")(instance_name="decl")
    slave.add("p_fixed", "parameter", 1.0, "p", "m")
    slave.add("p_tunable", "parameter", 1.0, "p", "m", tunable=True)
    slave.add("p_tunable2", "parameter", 1.0, "p", "m", variability="tunable")
    slave.add("o_real", "output", 1.0, "o", "m")
    slave.add("o_int", "output", 1, "o")
    slave.add("o_bool", "output", True, "o")
    slave.add("l_const", "local", 1.0, "c", "m", variability="constant")
    by = {v.name: v for v in slave.vars.values()}
    assert by["p_fixed"].variability.name == "fixed" and not slave._meta["p_fixed"]["tunable"]
    assert by["p_tunable"].variability.name == "tunable" and slave._meta["p_tunable"]["tunable"]
    assert by["p_tunable2"].variability.name == "tunable" and slave._meta["p_tunable2"]["tunable"]
    assert by["o_real"].variability.name == "continuous"
    assert by["o_int"].variability.name == "discrete" and by["o_bool"].variability.name == "discrete"
    assert by["l_const"].variability.name == "constant"
    assert by["o_bool"].causality.name == "output" and by["l_const"].causality.name == "local"
    assert type(by["o_int"]).__name__ == "Integer" and type(by["o_bool"]).__name__ == "Boolean"


def test_choice_names_the_value_and_the_allowed_ones():
    slave = slave_class("BallInShell")(instance_name="c")
    slave.formulation = 3
    with pytest.raises(ValueError) as info:
        slave.choice("formulation", {1: "vector", 2: "paper"})
    assert str(info.value) == "formulation must be one of [1, 2] (1 = vector, 2 = paper), got 3"
    slave.formulation = 2
    assert slave.choice("formulation", {1: "vector", 2: "paper"}) == "paper"


@pytest.mark.parametrize("model, name, value, text", [
    ("BallInShell", "m", -1.0, "parameter m = -1.0 kg is outside its accepted range ["),
    ("BallInShell", "mu", math.nan, "parameter mu = nan is outside its accepted range ["),
    ("BallInShell", "r", math.inf, "parameter r = inf m is outside its accepted range ["),
])
def test_check_parameters_names_value_unit_and_range(model, name, value, text):
    slave = slave_class(model)(instance_name="p")
    slave.check_parameters()  # the start values are accepted
    setattr(slave, name, value)
    with pytest.raises(ValueError) as info:
        slave.check_parameters()
    msg = str(info.value)
    assert msg.startswith(text), msg
    meta = slave._meta[name]
    lo = "-inf" if meta["min"] is None else f"{meta['min']:g}"
    hi = "inf" if meta["max"] is None else f"{meta['max']:g}"
    unit = f" {meta['unit']}" if meta["unit"] not in (None, "1") else ""
    assert msg.endswith(f"[{lo}, {hi}]{unit}"), msg


def test_bounds_are_inclusive():
    slave = slave_class("BallInShell")(instance_name="p")
    for name, meta in slave._meta.items():
        if meta["causality"] != "parameter" or meta["type"] is bool:
            continue
        for key in ("min", "max"):
            if meta[key] is not None:
                old = getattr(slave, name)
                setattr(slave, name, meta["type"](meta[key]))
                try:
                    slave.check_parameters()
                except ValueError as e:  # another parameter's rule may not hold at this edge
                    assert f"parameter {name} " not in str(e), str(e)
                setattr(slave, name, old)


def test_rename_replaces_whole_physics_names_only():
    slave = slave_class("BallInShell")(instance_name="n")
    assert slave.rename("rolling_resistance = 1 and drag = 2; dragon, rolling_resistances") == \
        "delta = 1 and c_drag = 2; dragon, rolling_resistances"
    plain = slave_class("MotorStartup")(instance_name="n")
    assert plain.rename("drag (rolling_resistance)") == "drag (rolling_resistance)"


def test_finite_outputs():
    S = slave_class("BallInShell")
    assert S.finite("N", 2.5) == 2.5
    assert S.finite("friction_ratio", math.inf, allow_infinite=True) == 1e300
    assert S.finite("friction_ratio", -math.inf, allow_infinite=True) == -1e300
    for value, allow in ((math.inf, False), (math.nan, True), (math.nan, False)):
        with pytest.raises(ArithmeticError) as info:
            S.finite("N", value, allow_infinite=allow)
        assert str(info.value) == f"output N would be {value!r}"


def test_a_percent_reaches_the_logger_as_a_percent():
    slave = slave_class("MotorStartup")(instance_name="w")
    slave.warn("50% of 10%")
    slave.error("e")
    assert slave.discard("d") is False
    assert [(m.msg, m.status.name) for m in slave.log_queue] == [
        ("50%% of 10%%", "warning"), ("e", "error"), ("d", "discard")]


# -- the declaration's constructors (they run at import, before mutmut's workers fork: called
# here again so that their mutants are seen) -------------------------------------------------
def test_a_variable_is_refused_with_its_name_and_what_is_wrong():
    from ballmill.fmi.interface import Variable
    for kwargs, text in (
            (dict(name="a", causality="state", start=1.0, description="d", unit="m"),
             "a: causality 'state' not in ('parameter', 'input', 'output', 'local')"),
            (dict(name="a", causality="input", start="x", description="d"), "a: start 'x' is not a float, int or bool"),
            (dict(name="a", causality="input", start=1.0, description="d"), "Real variable 'a' needs a unit"),
            (dict(name="a", causality="input", start=1.0, description="d", unit="parsec"),
             "unit 'parsec' of 'a' is not in UNITS"),
            (dict(name="a", causality="input", start=1, description="d", unit="furlong"),
             "unit 'furlong' of 'a' is not in UNITS"),
            (dict(name="a", causality="input", start=1.0, description="  ", unit="m"), "a: no description")):
        with pytest.raises(ValueError) as info:
            Variable(**kwargs)
        assert str(info.value) == text
    # an Integer or a Boolean needs no unit, a Real with a known one is taken
    assert Variable("k", "parameter", 2, "count").type == "Integer"
    assert Variable("b", "output", True, "flag").type == "Boolean"
    assert Variable("x", "output", 1.0, "x", unit="m").fmi_variability == "continuous"
    assert Variable("k", "output", 1, "k").fmi_variability == "discrete"
    assert Variable("p", "parameter", 1.0, "p", unit="m").fmi_variability == "fixed"
    assert Variable("p", "parameter", 1.0, "p", unit="m", variability="tunable").fmi_variability == "tunable"


def test_an_interface_is_refused_with_what_is_wrong():
    from ballmill.fmi.interface import Interface, Variable, _interface
    x = Variable("x", "input", 0.0, "x", unit="m")
    y = Variable("y", "output", 0.0, "y", unit="m", depends=("x",))
    p = Variable("p", "parameter", 0.0, "p", unit="m")
    with pytest.raises(ValueError) as info:
        Interface("M", "d", (x, y, x, p, p))
    assert str(info.value) == "M: variables declared twice: ['p', 'x']"
    with pytest.raises(ValueError) as info:
        Interface("M", "d", (x, p, Variable("z", "output", 0.0, "z", unit="m", depends=("x", "p", "q"))))
    assert str(info.value) == "M.z depends on non-inputs ['p', 'q']"
    m = Interface("M", "d", (x, y, p))
    assert m["y"] is y and m.value_reference("p") == 2 and m.of("input") == [x]
    with pytest.raises(KeyError) as info:
        m["w"]
    assert info.value.args[0] == "M has no variable 'w'"
    built = _interface("N", "desc", [("x", "input", 0.0, "x", dict(unit="m")), ("k", "parameter", 1, "k")],
                       default_experiment=(0.0, 1.0, 0.1))
    assert built.name == "N" and built.description == "desc" and built.default_experiment == (0.0, 1.0, 0.1)
    assert built.variables == (x, Variable("k", "parameter", 1, "k"))
    assert built.log_categories == Interface("Q", "q", ()).log_categories and built.log_categories
