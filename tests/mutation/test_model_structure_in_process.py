"""The ModelStructure and UnitDefinitions that ballmill.fmi.slave.Slave.to_xml writes into
every pythonfmu FMU's modelDescription.xml, read back from the XML text and checked against
an independent reading of the one declaration (ballmill.fmi.interface): every output in
ModelStructure/Outputs and InitialUnknowns by its 1-based index, ``dependencies`` exactly the
declared direct feedthrough (Outputs) and initial dependencies (InitialUnknowns), each a list of
input indices and present even when empty (an absent attribute means "depends on everything");
each used unit defined once, its BaseUnit's SI exponents, factor and offset those of the unit's
name (a table written out here by hand, not UNITS).

Every test calls `to_xml` inside the test function (no module- or session-scoped fixture):
mutmut maps a mutant of `to_xml` to the tests during which the function ran, so a fixture that
writes the description once would tie every mutant to the first test alone (which is how the
checks of tests/mutation/test_model_descriptions_in_process.py missed these mutants)."""
from __future__ import annotations

import sys
from pathlib import Path
from xml.etree.ElementTree import fromstring, tostring

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import SCRIPTS, slave_class  # noqa: E402

from ballmill.fmi.interface import INTERFACES  # noqa: E402

MODELS = sorted(SCRIPTS)

# unit name -> SI base-unit exponents (FMI 2.0 BaseUnit: kg, m, s, A, K, mol, cd, rad) and the
# factor to SI (value_SI = factor * value + offset), from the units' names
SI = {
    "1": {}, "m": {"m": 1}, "kg": {"kg": 1}, "s": {"s": 1}, "A": {"A": 1}, "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2}, "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2}, "Hz": {"s": -1}, "Hz/s": {"s": -2},
    "N": {"kg": 1, "m": 1, "s": -2}, "N.m": {"kg": 1, "m": 2, "s": -2}, "J": {"kg": 1, "m": 2, "s": -2},
    "W": {"kg": 1, "m": 2, "s": -3}, "kg.m2": {"kg": 1, "m": 2}, "N.s/m": {"kg": 1, "s": -1},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1}, "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2}, "Wb": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "1/min": {"s": -1},
}
FACTOR = {"1/min": 1.0 / 60.0}  # one per minute is a sixtieth of one per second


def _written(model):
    """The modelDescription's root as a tool reads it: `to_xml`'s tree written to text and parsed."""
    slave = slave_class(model)(instance_name="structure")
    return fromstring(tostring(slave.to_xml(), encoding="unicode"))


def _indices(text):
    assert text is not None, "the dependencies attribute is missing (it would mean: depends on every variable)"
    return [int(s) for s in text.split()]


@pytest.mark.parametrize("model", MODELS)
def test_outputs_and_initial_unknowns_list_the_declared_dependencies(model):
    iface = INTERFACES[model]
    root = _written(model)
    names = [sv.get("name") for sv in root.find("ModelVariables")]
    assert names == [v.name for v in iface.variables]  # value-reference order = declaration order
    index = {v.name: k + 1 for k, v in enumerate(iface.variables)}  # FMI indices are 1-based
    causality = {v.name: v.causality for v in iface.variables}
    outputs = [v for v in iface.variables if v.causality == "output"]
    assert outputs, model
    structure = root.find("ModelStructure")
    assert [c.tag for c in structure] == ["Outputs", "InitialUnknowns"]
    for section, key in (("Outputs", "feedthrough"), ("InitialUnknowns", "depends")):
        unknowns = list(structure.find(section))
        assert all(u.tag == "Unknown" for u in unknowns), section
        # every output once, ordered by index
        assert [int(u.get("index")) for u in unknowns] == [index[v.name] for v in outputs], section
        for u, v in zip(unknowns, outputs):
            assert names[int(u.get("index")) - 1] == v.name
            deps = _indices(u.get("dependencies"))
            assert sorted(deps) == sorted(index[d] for d in getattr(v, key)), (section, v.name, deps)
            assert len(set(deps)) == len(deps), (section, v.name, deps)
            assert all(causality[names[k - 1]] == "input" for k in deps), (section, v.name, deps)
    if model == "BallInShell":
        # the force and moments follow the chamber's position, velocity (a sliding ball's N and
        # slip), acceleration, angular velocity and acceleration and orientation between steps; the
        # contact point does not
        outs = {names[int(u.get("index")) - 1]: u for u in structure.find("Outputs")}
        assert sorted(_indices(outs["Fx"].get("dependencies"))) == sorted(
            index[n] for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O", "z1O", "vz1O", "az1O",
                               "Omega_x", "Omega_y", "Omega_z",
                               "Omega_dot_x", "Omega_dot_y", "Omega_dot_z",
                               "Q11", "Q12", "Q13", "Q21", "Q22", "Q23", "Q31", "Q32", "Q33"))
        assert outs["xP"].get("dependencies") == ""
        init = {names[int(u.get("index")) - 1]: u for u in structure.find("InitialUnknowns")}
        assert len(_indices(init["xP"].get("dependencies"))) == 6 + 18  # every input of both motions


@pytest.mark.parametrize("model", MODELS)
def test_unit_definitions_give_each_units_si_base_units(model):
    iface = INTERFACES[model]
    root = _written(model)
    tags = [c.tag for c in root]
    assert tags.index("UnitDefinitions") == tags.index("CoSimulation") + 1  # the schema's order
    units = root.find("UnitDefinitions")
    defined = [u.get("name") for u in units]
    assert all(u.tag == "Unit" for u in units)
    assert sorted(defined) == sorted({v.unit for v in iface.variables if v.unit}), model
    assert len(set(defined)) == len(defined)
    for unit in units:
        name = unit.get("name")
        assert [c.tag for c in unit] == ["BaseUnit"], name
        attrs = dict(unit[0].attrib)
        factor = attrs.pop("factor", None)
        assert "offset" not in attrs, name  # no unit here has an offset (0 by default)
        assert {k: int(v) for k, v in attrs.items()} == SI[name], name
        if name in FACTOR:
            assert factor is not None and float(factor) == FACTOR[name], (name, factor)
        else:
            assert factor is None, (name, factor)


@pytest.mark.parametrize("model", MODELS)
def test_every_variable_carries_its_declared_unit_and_bounds(model):
    iface = INTERFACES[model]
    root = _written(model)
    for sv, v in zip(root.find("ModelVariables"), iface.variables):
        typed = sv[0]
        assert typed.tag == v.type, v.name
        assert typed.get("unit") == v.unit, v.name
        for key in ("min", "max"):
            bound = getattr(v, key)
            text = typed.get(key)
            if bound is None:
                assert text is None, (v.name, key, text)
            elif v.type == "Integer":
                assert text == str(int(bound)), (v.name, key, text)
            else:
                assert float(text) == float(bound) and ("." in text or "e" in text), (v.name, key, text)
