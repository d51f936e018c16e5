"""The SystemStructure.ssd of a scenario (ballmill.scenario.ssp.build_ssd), element by
element where the SSP 1.0 standard puts them (SystemStructureDescription > System >
Elements > Component > Connectors / ParameterBindings > ParameterBinding > ParameterValues >
ssv:ParameterSet > ssv:Parameters > ssv:Parameter; Connections; Units; DefaultExperiment)
and where libcosim and OMSimulator read the communication step, in its serialised form.
tests/test_ssp_units.py checks every unit and value; this file pins the structure, for the
mutants that test let through (docs/mutation.md). In-process model descriptions."""
from __future__ import annotations

import sys
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest
from fmpy import read_model_description

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import write_model_descriptions  # noqa: E402

from ballmill.scenario import spec, ssp  # noqa: E402
from ballmill.scenario.spec import Instance, Scenario, ScenarioError  # noqa: E402

SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
SSC = "{http://ssp-standard.org/SSP1/SystemStructureCommon}"
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
OSP = "{http://opensimulationplatform.com/SSP/OSPAnnotations}"
OMS = "{https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd}"


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    paths = write_model_descriptions(tmp_path_factory.mktemp("md"))
    return {name: read_model_description(str(p)) for name, p in paths.items()}


@pytest.fixture(scope="module")
def fast(models):
    sc = spec.load("fast_start", [], models)
    # forget the prefixes any earlier export registered: this export must register its own
    for uri in ssp.NS.values():
        ET._namespace_map.pop(uri, None)
    root = ssp.build_ssd(sc, models).getroot()
    return sc, root, ET.tostring(root, encoding="unicode")


def test_the_document_and_its_system(fast):
    sc, root, _ = fast
    assert root.tag == SSD + "SystemStructureDescription"
    assert root.attrib == {"version": "1.0", "name": "fast_start"}
    assert [c.tag for c in root] == [SSD + "System", SSD + "Units", SSD + "DefaultExperiment"]
    system = root[0]
    assert system.attrib == {"name": "fast_start", "description": sc.description}
    assert [c.tag for c in system] == [SSD + "Elements", SSD + "Connections", SSD + "Annotations"]


def test_components_connectors_and_bindings(fast, models):
    sc, root, _ = fast
    comps = root.findall(f"{SSD}System/{SSD}Elements/{SSD}Component")
    assert [c.get("name") for c in comps] == list(sc.instances)
    for comp in comps:
        inst = sc.instances[comp.get("name")]
        assert comp.attrib == {"name": inst.name, "type": "application/x-fmu-sharedlibrary",
                               "source": f"resources/{inst.fmu}.fmu"}
        assert [c.tag for c in comp] == [SSD + "Connectors", SSD + "ParameterBindings"]
        md = {v.name: v for v in models[inst.fmu].modelVariables}
        for conn in comp.find(SSD + "Connectors"):
            v = md[conn.get("name")]
            assert conn.tag == SSD + "Connector"
            assert conn.attrib == {"name": v.name, "kind": v.causality, "description": v.description}
        (binding,) = comp.find(SSD + "ParameterBindings")
        assert binding.tag == SSD + "ParameterBinding" and binding.attrib == {}
        (values,) = binding
        assert values.tag == SSD + "ParameterValues"
        (pset,) = values
        assert pset.tag == SSV + "ParameterSet" and pset.attrib == {"version": "1.0", "name": "scenario"}
        (params,) = pset
        assert params.tag == SSV + "Parameters"
        assert [p.get("name") for p in params] == list(inst.parameters)
        assert all(p.tag == SSV + "Parameter" for p in params)


def test_connections(fast):
    sc, root, _ = fast
    conns = root.findall(f"{SSD}System/{SSD}Connections/{SSD}Connection")
    assert [c.attrib for c in conns] == [
        {"startElement": a, "startConnector": b, "endElement": c, "endConnector": d}
        for a, b, c, d in sc.connections]


def test_the_step_where_omsimulator_and_libcosim_read_it(fast):
    sc, root, _ = fast
    (ann,) = root.find(f"{SSD}System/{SSD}Annotations")
    assert ann.tag == SSC + "Annotation" and ann.attrib == {"type": "org.openmodelica"}
    master = ann.find(f"{OMS}Annotations/{OMS}SimulationInformation/{OMS}FixedStepMaster")
    assert master.attrib == {"description": "oms-ma", "stepSize": "0.002"}
    exp = root.find(SSD + "DefaultExperiment")
    assert exp.attrib == {"startTime": "0.0", "stopTime": "10.0"}
    (ann,) = exp.find(SSD + "Annotations")
    assert ann.tag == SSC + "Annotation" and ann.attrib == {"type": "com.opensimulationplatform"}
    algo = ann.find(f"{OSP}Algorithm/{OSP}FixedStepAlgorithm")
    assert algo.attrib == {"baseStepSize": "0.002"}


def test_units_element(fast):
    sc, root, _ = fast
    units = root.find(SSD + "Units")
    names = [u.get("name") for u in units]
    assert names == sorted(names) and all(u.tag == SSC + "Unit" for u in units)
    assert all([c.tag for c in u] == [SSC + "BaseUnit"] for u in units)
    n_min = units.find(f"{SSC}Unit[@name='1/min']/{SSC}BaseUnit")
    assert n_min.attrib == {"s": "-1", "factor": repr(1 / 60)}


def test_the_prefixes_of_the_serialised_file(fast):
    _, _, text = fast
    assert text.startswith("<ssd:SystemStructureDescription xmlns:")
    for prefix, uri in ssp.NS.items():
        assert f'xmlns:{prefix}="{uri}"' in text
    assert "<ssv:ParameterSet " in text and "<osp:FixedStepAlgorithm " in text and "<oms:FixedStepMaster " in text


def test_a_scenario_without_connections_parameters_or_description(models):
    sc = Scenario(path=Path("bare.toml"), name="bare", description="", start=1.0, stop=2.0, step=0.5,
                  instances={"d": Instance("d", fmu="MotorStartup")}, connections=[], record=[], plots=[],
                  summary={})
    root = ssp.build_ssd(sc, models).getroot()
    system = root[0]
    assert system.attrib == {"name": "bare"}
    assert [c.tag for c in system] == [SSD + "Elements", SSD + "Annotations"]
    (comp,) = system.find(SSD + "Elements")
    assert [c.tag for c in comp] == [SSD + "Connectors"]
    assert root.find(SSD + "DefaultExperiment").attrib == {"startTime": "1.0", "stopTime": "2.0"}


def test_a_table_source_cannot_be_exported(models):
    sc = Scenario(path=Path("t.toml"), name="t", description="", start=0.0, stop=1.0, step=0.5,
                  instances={"g": Instance("g", table=Path("g.csv")), "h": Instance("h", table=Path("h.csv")),
                             "d": Instance("d", fmu="MotorStartup")},
                  connections=[], record=[], plots=[], summary={})
    with pytest.raises(ScenarioError) as info:
        ssp.build_ssd(sc, models)
    assert info.value.problems == [
        f"t.toml: instances.{n}: a table source (CSV) has no FMU and cannot be exported to SSP; "
        f"replace it by an FMU" for n in ("g", "h")]


@pytest.mark.parametrize("kind, value, text", [
    ("Real", 2, "2.0"), ("Real", 0.1, "0.1"), ("Integer", 3.0, "3"), ("Integer", True, "1"),
    ("Boolean", True, "true"), ("Boolean", 0, "false"), ("String", 5, "5"),
])
def test_values_as_ssp_writes_them(kind, value, text):
    assert ssp._fmt(kind, value) == text
