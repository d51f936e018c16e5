"""The one declaration (ballmill/fmi/interface.py) and the two flavours' model descriptions.

Both flavours of each FMU must present the same interface: every variable with the
same value reference, causality, variability, type, unit, description, bounds and start
value, the same outputs and InitialUnknowns with the same dependencies, the same unit
definitions and DefaultExperiment - and all of it as declared.
"""
import math

import pytest
from fmpy import read_model_description

from ballmill.fmi.interface import INTERFACES

MODELS = sorted(INTERFACES)


def _variables(md):
    out = {}
    for v in md.modelVariables:
        out[v.name] = dict(vr=v.valueReference, causality=v.causality, variability=v.variability,
                           type=v.type, unit=v.unit, description=v.description,
                           min=None if v.min is None else float(v.min),
                           max=None if v.max is None else float(v.max),
                           start=None if v.start is None else float(v.start) if v.type != "Boolean"
                           else v.start in (True, "true", "1", 1))
    return out


def _structure(md):
    """Outputs and InitialUnknowns with their dependencies, leaving out Model Exchange's
    states and derivatives (native flavour only: ``native_variables``)."""
    local = {v.name for v in md.modelVariables if v.causality == "local"}
    outs = [(u.variable.name, sorted(d.name for d in (u.dependencies or []) if d.name not in local))
            for u in md.outputs]
    init = [(u.variable.name, sorted(d.name for d in (u.dependencies or [])))
            for u in md.initialUnknowns if u.variable.name not in local]
    return outs, init


def _declared(md):
    """The variables both flavours have (the native one adds Model Exchange's after them)."""
    return {k: v for k, v in _variables(md).items() if v["causality"] != "local"}


@pytest.mark.parametrize("model", MODELS)
def test_both_flavours_describe_the_same_interface(fmus_of, model):
    native = read_model_description(str(fmus_of("native")[model]))
    python = read_model_description(str(fmus_of("pythonfmu")[model]))
    a, b = _declared(native), _variables(python)
    assert list(a) == list(b), "variables or their order differ"
    for name in a:
        assert a[name] == b[name], (name, a[name], b[name])
    assert _structure(native) == _structure(python)
    me_units = {v.unit for v in native.modelVariables if v.causality == "local"} - \
        {v.unit for v in python.modelVariables}
    units = {u.name: [(bu.kg, bu.m, bu.s, bu.A, bu.rad, bu.factor) for bu in [u.baseUnit]]
             for u in native.unitDefinitions if u.name not in me_units}
    assert units == {u.name: [(bu.kg, bu.m, bu.s, bu.A, bu.rad, bu.factor) for bu in [u.baseUnit]]
                     for u in python.unitDefinitions}
    de_a, de_b = native.defaultExperiment, python.defaultExperiment
    assert (float(de_a.startTime), float(de_a.stopTime), float(de_a.stepSize)) == \
           (float(de_b.startTime), float(de_b.stopTime), float(de_b.stepSize))
    assert native.description == python.description
    assert native.coSimulation.canGetAndSetFMUstate and python.coSimulation.canGetAndSetFMUstate
    assert native.coSimulation.canSerializeFMUstate and python.coSimulation.canSerializeFMUstate


@pytest.mark.parametrize("model", MODELS)
def test_model_descriptions_are_the_declaration(fmus_of, fmu_flavour, model):
    md = read_model_description(str(fmus_of(fmu_flavour)[model]))
    decl = INTERFACES[model]
    got = _variables(md)
    expected = decl.native_variables if fmu_flavour == "native" else decl.variables
    assert list(got) == [v.name for v in expected]
    for vr, v in enumerate(decl.variables):
        g = got[v.name]
        assert (g["vr"], g["causality"], g["variability"], g["type"], g["unit"], g["description"]) == \
               (vr, v.causality, v.fmi_variability, v.type, v.unit, v.description), v.name
        assert g["min"] == (None if v.min is None else float(v.min)), v.name
        assert g["max"] == (None if v.max is None else float(v.max)), v.name
        if v.causality != "output":
            expected = v.start if v.type == "Boolean" else float(v.start)
            assert g["start"] == expected or (isinstance(expected, float) and math.isclose(
                g["start"], expected, rel_tol=0, abs_tol=0)), v.name
    _, init = _structure(md)
    assert init == [(v.name, sorted(v.depends)) for v in decl.variables if v.causality == "output"]
    de = md.defaultExperiment
    assert (float(de.startTime), float(de.stopTime), float(de.stepSize)) == decl.default_experiment


def test_native_fmus_carry_their_sources(fmus_of):
    for model in MODELS:
        md = read_model_description(str(fmus_of("native")[model]))
        if md.generationTool and "PythonFMU" in md.generationTool:
            pytest.skip(f"{model} has no native model yet")
        files = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
        assert "fmi2.c" in files
