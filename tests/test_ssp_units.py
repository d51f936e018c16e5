"""SSP export down to every unit, factor and offset, against the FMUs' model descriptions.

For every shipped scenario that can be exported (FMU instances only), the SystemStructure.ssd
is compared with the model descriptions of its FMUs:

* every connector: one per variable of causality parameter/input/output/calculatedParameter,
  its kind, its type and (Real) its unit as the model description declares them;
* every parameter binding: the variable exists with that type, the value is the scenario's,
  and a Real value carries the variable's unit (a value without unit is read in the
  variable's unit by some tools and in SI by others);
* every unit definition: exactly the units used, each with the base-unit exponents
  (kg, m, s, A, K, mol, cd, rad), factor and offset of the model description's
  UnitDefinitions (SSP's defaults: exponent 0, factor 1, offset 0);

and both the model descriptions and the SSD against SI derived independently here from the
unit's name (a small parser: products '.', one '/', trailing exponents, and the SI derived
units), so that a wrong entry in the one shared table (ballmill.fmi.slave.UNITS) cannot
pass by agreeing with itself.
"""
from __future__ import annotations

import math
import re
from fractions import Fraction

import pytest

from ballmill.scenario import runner, spec, ssp

BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
# SI derived units as (exponents, factor), from their definitions
ATOMS = {
    "1": ({}, 1.0), "kg": ({"kg": 1}, 1.0), "m": ({"m": 1}, 1.0), "s": ({"s": 1}, 1.0),
    "A": ({"A": 1}, 1.0), "K": ({"K": 1}, 1.0), "mol": ({"mol": 1}, 1.0), "cd": ({"cd": 1}, 1.0),
    "rad": ({"rad": 1}, 1.0), "min": ({"s": 1}, 60.0), "Hz": ({"s": -1}, 1.0),
    "N": ({"kg": 1, "m": 1, "s": -2}, 1.0),  # kg m / s2
}
ATOMS["J"] = ({"kg": 1, "m": 2, "s": -2}, 1.0)  # N m
ATOMS["W"] = ({"kg": 1, "m": 2, "s": -3}, 1.0)  # J / s
ATOMS["V"] = ({"kg": 1, "m": 2, "s": -3, "A": -1}, 1.0)  # W / A
ATOMS["Ohm"] = ({"kg": 1, "m": 2, "s": -3, "A": -2}, 1.0)  # V / A
ATOMS["Wb"] = ({"kg": 1, "m": 2, "s": -2, "A": -1}, 1.0)  # V s
ATOMS["H"] = ({"kg": 1, "m": 2, "s": -2, "A": -2}, 1.0)  # Wb / A


def si(unit: str):
    """(exponents, factor, offset) of a unit name like 'N.m', 'm/s2', '1/min', 'kg.m2'."""
    num, _, den = unit.partition("/")
    exps: dict = {}
    factor = Fraction(1)

    def add(part, sign):
        nonlocal factor
        for term in part.split("."):
            m = re.fullmatch(r"([A-Za-z]+|1)(-?\d+)?", term)
            assert m, f"cannot read {term!r} in unit {unit!r}"
            atom, power = m[1], int(m[2] or 1) * sign
            e, f = ATOMS[atom]
            for k, v in e.items():
                exps[k] = exps.get(k, 0) + v * power
            factor *= Fraction(f) ** power
    add(num, 1)
    if den:
        add(den, -1)
    return {k: v for k, v in exps.items() if v}, float(factor), 0.0


def test_the_parser_knows_the_units():
    assert si("1/min") == ({"s": -1}, 1 / 60, 0.0)
    assert si("N.m") == si("J") == ({"kg": 1, "m": 2, "s": -2}, 1.0, 0.0)
    assert si("N.s/m") == ({"kg": 1, "s": -1}, 1.0, 0.0)
    assert si("kg.m2") == ({"kg": 1, "m": 2}, 1.0, 0.0)
    assert si("rad/s2") == ({"rad": 1, "s": -2}, 1.0, 0.0)
    assert si("1") == ({}, 1.0, 0.0)


def base_unit_of_md(unit):
    """(exponents, factor, offset) of a model description's Unit."""
    bu = unit.baseUnit
    assert bu is not None, f"unit {unit.name} has no BaseUnit"
    return ({k: getattr(bu, k) for k in BASE if getattr(bu, k)}, float(bu.factor), float(bu.offset))


def base_unit_of_ssd(el):
    """(exponents, factor, offset) of an ssc:Unit, SSP's defaults filled in."""
    bus = el.findall("ssc:BaseUnit", ssp.NS)
    assert len(bus) == 1, f"unit {el.get('name')}: {len(bus)} BaseUnit elements"
    a = bus[0].attrib
    unknown = set(a) - set(BASE) - {"factor", "offset"}
    assert not unknown, (el.get("name"), unknown)
    return ({k: int(a[k]) for k in BASE if int(a.get(k, 0))}, float(a.get("factor", 1.0)),
            float(a.get("offset", 0.0)))


def same(a, b):
    return a[0] == b[0] and math.isclose(a[1], b[1], rel_tol=1e-15) and a[2] == b[2]


@pytest.fixture(scope="module")
def exported(fmu_build_dir):
    """name -> (scenario, models, ssd root) of every scenario with FMU instances only."""
    out = {}
    for path in sorted(spec.SCENARIO_DIR.glob("*.toml")):
        sc, models, _ = runner.prepare(str(path), [], fmu_build_dir, log=lambda m: None)
        if any(inst.fmu is None for inst in sc.instances.values()):
            continue  # a table source cannot go into an SSP (tested in test_libcosim)
        out[sc.name] = (sc, models, ssp.build_ssd(sc, models).getroot())
    assert {"fast_start", "slow_start", "induction_start", "induction_soft_start"} <= set(out)
    return out


def test_model_descriptions_define_their_units_as_si_does(fmu_build_dir):
    from pathlib import Path

    from fmpy import read_model_description
    seen = set()
    for fmu in sorted(Path(fmu_build_dir).glob("*.fmu")):
        md = read_model_description(str(fmu))
        defined = {u.name: u for u in md.unitDefinitions}
        used = {v.unit for v in md.modelVariables if v.type == "Real" and v.unit}
        assert used == set(defined), (fmu.name, used ^ set(defined))
        for name, unit in defined.items():
            assert same(base_unit_of_md(unit), si(name)), (fmu.name, name, base_unit_of_md(unit), si(name))
        seen |= used
    assert {"1/min", "N.m", "rad/s2", "kg.m2", "V", "A", "W", "J", "N.s/m"} <= seen


def test_every_connector_has_the_model_descriptions_kind_type_and_unit(exported):
    kinds = ("parameter", "input", "output", "calculatedParameter")
    for name, (sc, models, root) in exported.items():
        for comp in root.iterfind("ssd:System/ssd:Elements/ssd:Component", ssp.NS):
            md = models[sc.instances[comp.get("name")].fmu]
            want = {v.name: v for v in md.modelVariables if v.causality in kinds}
            conns = comp.findall("ssd:Connectors/ssd:Connector", ssp.NS)
            assert sorted(c.get("name") for c in conns) == sorted(want), (name, comp.get("name"))
            for c in conns:
                v = want[c.get("name")]
                assert c.get("kind") == v.causality, (name, v.name)
                typed = list(c)
                assert len(typed) == 1 and typed[0].tag == ssp._q("ssc", v.type), (name, v.name)
                if v.type == "Real":
                    assert typed[0].get("unit") == v.unit, (name, v.name, typed[0].get("unit"), v.unit)
                else:
                    assert "unit" not in typed[0].attrib


def test_every_parameter_binding_has_its_value_type_and_unit(exported):
    for name, (sc, models, root) in exported.items():
        for comp in root.iterfind("ssd:System/ssd:Elements/ssd:Component", ssp.NS):
            inst = sc.instances[comp.get("name")]
            md = {v.name: v for v in models[inst.fmu].modelVariables}
            params = comp.findall(".//ssv:Parameter", ssp.NS)
            assert {p.get("name") for p in params} == set(inst.parameters), (name, inst.name)
            for p in params:
                v = md[p.get("name")]
                (typed,) = list(p)
                assert typed.tag == ssp._q("ssv", v.type), (name, v.name)
                value = inst.parameters[v.name]
                if v.type == "Real":
                    assert float(typed.get("value")) == float(value)
                    # the unit of the value: the variable's, so that no tool converts it
                    assert typed.get("unit") == v.unit and v.unit, (name, v.name, typed.get("unit"))
                elif v.type == "Integer":
                    assert int(typed.get("value")) == int(value)
                elif v.type == "Boolean":
                    assert typed.get("value") == ("true" if value else "false")
    # the scenarios bind Real parameters with units, among them one in 1/min
    bound = {(sc.instances[c.get("name")].fmu, p.get("name"))
             for sc, _, root in exported.values()
             for c in root.iterfind("ssd:System/ssd:Elements/ssd:Component", ssp.NS)
             for p in c.iterfind(".//ssv:Parameter", ssp.NS)}
    assert ("MotorStartup", "n0") in bound or ("MotorStartup", "t0") in bound, bound


def test_every_unit_definition_matches_the_model_descriptions_and_si(exported):
    for name, (sc, models, root) in exported.items():
        used = {t.get("unit") for t in root.iter() if t.get("unit")}
        defs = {u.get("name"): u for u in root.iterfind("ssd:Units/ssc:Unit", ssp.NS)}
        assert set(defs) == used, (name, set(defs) ^ used)
        md_units = {}
        for inst in sc.instances.values():
            for u in models[inst.fmu].unitDefinitions:
                md_units[u.name] = base_unit_of_md(u)
        for unit, el in defs.items():
            got = base_unit_of_ssd(el)
            assert same(got, md_units[unit]), (name, unit, got, md_units[unit])
            assert same(got, si(unit)), (name, unit, got, si(unit))
    # the induction scenarios carry the electrical units, the crank's speed is in 1/min
    all_units = {u.get("name") for _, _, root in exported.values()
                 for u in root.iterfind("ssd:Units/ssc:Unit", ssp.NS)}
    assert {"1/min", "V", "A", "W", "N.m"} <= all_units, all_units
