"""The SSP export (ballmill/scenario/ssp.py: build_ssd, export_ssp, the libpython lookup, the
log level) pinned where mutmut sees it: every value is computed inside the test functions.

tests/test_ssp_units.py checks every unit, factor and offset of the shipped scenarios against
the model descriptions, but through a module-scoped fixture: under mutmut only the first
test that builds it is mapped to build_ssd, so its binding and unit-definition checks never
ran against build_ssd's mutants. Here:

* a small system (a made-up model description with every causality and type the export
  meets, and some it must skip) serialised exactly as the SSP 1.0 standard places each
  element and attribute, word for word;
* every shipped scenario that can be exported, against the native FMUs' model descriptions
  and against SI derived independently from each unit's name (tests/test_ssp_units.si):
  every connector, every parameter binding's type, value text and unit, every unit
  definition's exponents, factor and offset (SSP's defaults where absent);
* the package export_ssp writes: its entries in order, compressed, the SSD's bytes, where it
  writes first, its default arguments;
* where the CPython library is looked up, and what happens when it must be loaded.
"""
from __future__ import annotations

import ctypes
import os
import sys
import zipfile
from pathlib import Path
from types import SimpleNamespace
from xml.etree import ElementTree as ET

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from test_ssp_units import si  # noqa: E402  (SI from the unit's name, independent of UNITS)

from ballmill.scenario import runner, spec, ssp  # noqa: E402
from ballmill.scenario.spec import Instance, Scenario  # noqa: E402

KINDS = ("parameter", "input", "output", "calculatedParameter")
TYPES = ("Real", "Integer", "Boolean", "String")
BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


def _var(name, causality, type_, unit=None, description=None):
    return SimpleNamespace(name=name, causality=causality, type=type_, unit=unit, description=description)


def toy_model():
    """A model description with what build_ssd must write (each kind, each type, a Real
    without unit, a variable without description) and what it must leave out (the
    independent time, a local, an Enumeration)."""
    return SimpleNamespace(modelVariables=[
        _var("time", "independent", "Real", "s", "time"),
        _var("n0", "parameter", "Real", "1/min", "crank speed"),
        _var("law", "parameter", "Integer", None, "start-up law"),
        _var("on", "parameter", "Boolean"),
        _var("tag", "parameter", "String", None, "a label"),
        _var("gain", "parameter", "Real", None, "a gain"),
        _var("M", "input", "Real", "N.m", "load torque"),
        _var("a", "output", "Real", "m/s2", "acceleration"),
        _var("ok", "output", "Boolean", None, "valid"),
        _var("ratio", "output", "Real", None, "a pure number"),
        _var("mass", "calculatedParameter", "Real", "kg", "mass"),
        _var("x", "local", "Real", "m", "hidden"),
        _var("mode", "parameter", "Enumeration", None, "an enumeration"),
    ])


def toy_scenario(description="two toys"):
    return Scenario(path=Path("toy.toml"), name="toy", description=description, start=0.5, stop=2.0, step=0.25,
                    instances={"b": Instance("b", fmu="Toy", parameters={"n0": 90, "law": 3.0, "on": 1, "tag": 7,
                                                                          "gain": 2.5}),
                               "a": Instance("a", fmu="Toy")},
                    connections=[("b", "a", "a", "M"), ("a", "a", "b", "M")], record=[], plots=[], summary={})


_CONNECTORS = """        <ssd:Connectors>
          <ssd:Connector name="n0" kind="parameter" description="crank speed">
            <ssc:Real unit="1/min" />
          </ssd:Connector>
          <ssd:Connector name="law" kind="parameter" description="start-up law">
            <ssc:Integer />
          </ssd:Connector>
          <ssd:Connector name="on" kind="parameter">
            <ssc:Boolean />
          </ssd:Connector>
          <ssd:Connector name="tag" kind="parameter" description="a label">
            <ssc:String />
          </ssd:Connector>
          <ssd:Connector name="gain" kind="parameter" description="a gain">
            <ssc:Real />
          </ssd:Connector>
          <ssd:Connector name="M" kind="input" description="load torque">
            <ssc:Real unit="N.m" />
          </ssd:Connector>
          <ssd:Connector name="a" kind="output" description="acceleration">
            <ssc:Real unit="m/s2" />
          </ssd:Connector>
          <ssd:Connector name="ok" kind="output" description="valid">
            <ssc:Boolean />
          </ssd:Connector>
          <ssd:Connector name="ratio" kind="output" description="a pure number">
            <ssc:Real />
          </ssd:Connector>
          <ssd:Connector name="mass" kind="calculatedParameter" description="mass">
            <ssc:Real unit="kg" />
          </ssd:Connector>
        </ssd:Connectors>
"""

# SSP 1.0: SystemStructureDescription > System (Elements, Connections, Annotations), Units,
# DefaultExperiment; Component > Connectors, ParameterBindings; the units used, sorted, each
# with its SI base-unit exponents and factor (1/min: s^-1, factor 1/60)
TOY_SSD = ("""<ssd:SystemStructureDescription xmlns:oms="https://raw.githubusercontent.com/OpenModelica/OMSimulator/\
master/schema/oms.xsd" xmlns:osp="http://opensimulationplatform.com/SSP/OSPAnnotations" \
xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" \
xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" \
xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="toy">
  <ssd:System name="toy" description="two toys">
    <ssd:Elements>
      <ssd:Component name="b" type="application/x-fmu-sharedlibrary" source="resources/Toy.fmu">
""" + _CONNECTORS + """        <ssd:ParameterBindings>
          <ssd:ParameterBinding>
            <ssd:ParameterValues>
              <ssv:ParameterSet version="1.0" name="scenario">
                <ssv:Parameters>
                  <ssv:Parameter name="n0">
                    <ssv:Real value="90.0" unit="1/min" />
                  </ssv:Parameter>
                  <ssv:Parameter name="law">
                    <ssv:Integer value="3" />
                  </ssv:Parameter>
                  <ssv:Parameter name="on">
                    <ssv:Boolean value="true" />
                  </ssv:Parameter>
                  <ssv:Parameter name="tag">
                    <ssv:String value="7" />
                  </ssv:Parameter>
                  <ssv:Parameter name="gain">
                    <ssv:Real value="2.5" />
                  </ssv:Parameter>
                </ssv:Parameters>
              </ssv:ParameterSet>
            </ssd:ParameterValues>
          </ssd:ParameterBinding>
        </ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="a" type="application/x-fmu-sharedlibrary" source="resources/Toy.fmu">
""" + _CONNECTORS + """      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="b" startConnector="a" endElement="a" endConnector="M" />
      <ssd:Connection startElement="a" startConnector="a" endElement="b" endConnector="M" />
    </ssd:Connections>
    <ssd:Annotations>
      <ssc:Annotation type="org.openmodelica">
        <oms:Annotations>
          <oms:SimulationInformation>
            <oms:FixedStepMaster description="oms-ma" stepSize="0.25" />
          </oms:SimulationInformation>
        </oms:Annotations>
      </ssc:Annotation>
    </ssd:Annotations>
  </ssd:System>
  <ssd:Units>
    <ssc:Unit name="1/min">
      <ssc:BaseUnit s="-1" factor="0.016666666666666666" />
    </ssc:Unit>
    <ssc:Unit name="N.m">
      <ssc:BaseUnit kg="1" m="2" s="-2" />
    </ssc:Unit>
    <ssc:Unit name="kg">
      <ssc:BaseUnit kg="1" />
    </ssc:Unit>
    <ssc:Unit name="m/s2">
      <ssc:BaseUnit m="1" s="-2" />
    </ssc:Unit>
  </ssd:Units>
  <ssd:DefaultExperiment startTime="0.5" stopTime="2.0">
    <ssd:Annotations>
      <ssc:Annotation type="com.opensimulationplatform">
        <osp:Algorithm>
          <osp:FixedStepAlgorithm baseStepSize="0.25" />
        </osp:Algorithm>
      </ssc:Annotation>
    </ssd:Annotations>
  </ssd:DefaultExperiment>
</ssd:SystemStructureDescription>""")


def _forget_prefixes():
    """Drop the prefixes an earlier export registered: build_ssd must register its own."""
    for uri in ssp.NS.values():
        ET._namespace_map.pop(uri, None)


def test_a_small_system_is_written_exactly_as_ssp_places_it():
    _forget_prefixes()
    root = ssp.build_ssd(toy_scenario(), {"Toy": toy_model()}).getroot()
    assert ET.tostring(root, encoding="unicode") == TOY_SSD
    assert 1 / 60 == float("0.016666666666666666")


# -- the shipped scenarios against the native model descriptions and SI --------------------

def _exported(models):
    """(scenario, ssd root) of every shipped scenario with FMU instances only, built here."""
    out = []
    for path in sorted(spec.SCENARIO_DIR.glob("*.toml")):
        sc = spec.load(str(path), [], models)
        if any(inst.fmu is None for inst in sc.instances.values()):
            continue
        out.append((sc, ssp.build_ssd(sc, models).getroot()))
    return out


def _base_unit_attributes(unit: str) -> dict:
    """The ssc:BaseUnit attributes of a unit as SI defines it: non-zero exponents, and the
    factor when it is not SSP's default 1 (the offset is 0, SSP's default, for all of them)."""
    exps, factor, offset = si(unit)
    assert offset == 0.0
    attrs = {k: str(exps[k]) for k in BASE if k in exps}
    if factor != 1.0:
        attrs["factor"] = repr(factor)
    return attrs


def _md_base_unit(unit) -> dict:
    bu = unit.baseUnit
    attrs = {k: str(getattr(bu, k)) for k in BASE if getattr(bu, k)}
    if float(bu.factor) != 1.0:
        attrs["factor"] = repr(float(bu.factor))
    assert float(bu.offset) == 0.0, unit.name
    return attrs


def test_every_shipped_scenario_exports_each_connector_as_its_model_declares_it(native_models):
    exported = _exported(native_models)
    assert {sc.name for sc, _ in exported} == {"absorber_frf", "absorber_hybrid", "fast_start", "fast_start_positions",
                                               "fig1_machine", "fig1_machine_hybrid",
                                               "grinding", "grinding_design", "grinding_design_motor", "induction_soft_start",
                                               "induction_start", "induction_start_hybrid", "slow_start",
                                               "spinning_bowl", "tower_absorber", "tumbling_drum", "violent_start"}
    for sc, root in exported:
        comps = root.findall("ssd:System/ssd:Elements/ssd:Component", ssp.NS)
        assert [c.get("name") for c in comps] == list(sc.instances), sc.name
        for comp in comps:
            md = native_models[sc.instances[comp.get("name")].fmu]
            want = [v for v in md.modelVariables if v.causality in KINDS and v.type in TYPES]
            conns = comp.findall("ssd:Connectors/ssd:Connector", ssp.NS)
            assert [c.get("name") for c in conns] == [v.name for v in want], (sc.name, comp.get("name"))
            for c, v in zip(conns, want):
                assert c.attrib == {"name": v.name, "kind": v.causality, "description": v.description}
                (typed,) = list(c)
                assert typed.tag == ssp._q("ssc", v.type), (sc.name, v.name)
                assert typed.attrib == ({"unit": v.unit} if v.type == "Real" else {}), (sc.name, v.name)
                assert v.type != "Real" or v.unit, (sc.name, v.name)  # every Real of the project has a unit


def test_every_shipped_parameter_binding_has_its_type_value_and_unit(native_models):
    bound_units = set()
    for sc, root in _exported(native_models):
        for comp in root.findall("ssd:System/ssd:Elements/ssd:Component", ssp.NS):
            inst = sc.instances[comp.get("name")]
            md = {v.name: v for v in native_models[inst.fmu].modelVariables}
            params = comp.findall("ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues/"
                                  "ssv:ParameterSet/ssv:Parameters/ssv:Parameter", ssp.NS)
            assert [p.get("name") for p in params] == list(inst.parameters), (sc.name, inst.name)
            for p in params:
                v = md[p.get("name")]
                value = inst.parameters[v.name]
                (typed,) = list(p)
                assert typed.tag == ssp._q("ssv", v.type), (sc.name, v.name)
                if v.type == "Real":
                    # the value's text reads back as the scenario's number, in the variable's unit
                    assert typed.attrib == {"value": repr(float(value)), "unit": v.unit}, (sc.name, v.name)
                    assert float(typed.get("value")) == value
                    bound_units.add(v.unit)
                elif v.type == "Integer":
                    assert typed.attrib == {"value": str(value)} and int(typed.get("value")) == value
                else:
                    assert typed.attrib == {"value": "true" if value else "false"}, (sc.name, v.name)
    # among them the crank speed in 1/min, the motor's volts and the absorber's N.s/m
    assert {"1/min", "V", "N.s/m", "kg", "m", "s"} <= bound_units, bound_units


def test_every_shipped_unit_definition_is_si_and_the_model_descriptions(native_models):
    for sc, root in _exported(native_models):
        used = {t.get("unit") for t in root.iter() if t.get("unit")}
        units = root.findall("ssd:Units/ssc:Unit", ssp.NS)
        names = [u.get("name") for u in units]
        assert names == sorted(used), (sc.name, names, sorted(used))
        md_units = {u.name: u for inst in sc.instances.values()
                    for u in native_models[inst.fmu].unitDefinitions}
        for u in units:
            assert u.attrib == {"name": u.get("name")}
            (base,) = list(u)
            assert base.tag == ssp._q("ssc", "BaseUnit")
            assert base.attrib == _base_unit_attributes(u.get("name")), (sc.name, u.get("name"), base.attrib)
            assert base.attrib == _md_base_unit(md_units[u.get("name")]), (sc.name, u.get("name"))
            # what a tool computes from it: value_SI = factor * value + offset
            assert float(base.get("factor", 1.0)) == si(u.get("name"))[1], (sc.name, u.get("name"))
            assert float(base.get("offset", 0.0)) == 0.0


# -- the package -------------------------------------------------------------------------

@pytest.fixture()
def toy_package(tmp_path, monkeypatch):
    """export_ssp of the toy system with two models (instances in reverse order of their
    models' names), runner.prepare replaced by a spy returning made-up FMU files."""
    md = toy_model()
    sc = toy_scenario()
    sc.instances = {"z": Instance("z", fmu="Zeta"), "b": sc.instances["b"], "a": sc.instances["a"]}
    sc.connections = []
    files = {"Toy": tmp_path / "Toy.fmu", "Zeta": tmp_path / "Zeta.fmu"}
    files["Toy"].write_bytes(b"toy bytes " * 100)
    files["Zeta"].write_bytes(b"zeta bytes " * 100)
    calls = []

    def prepare(*args, **kwargs):
        calls.append((args, kwargs))
        return sc, {"Toy": md, "Zeta": SimpleNamespace(modelVariables=[])}, files
    monkeypatch.setattr(runner, "prepare", prepare)
    return sc, files, calls


def test_the_package_holds_the_ssd_then_each_model_once_compressed(toy_package, tmp_path, monkeypatch):
    sc, files, calls = toy_package
    replaced = []
    real_replace = os.replace

    def spy(src, dst):
        replaced.append((Path(src), Path(dst)))
        assert Path(src).is_file()
        real_replace(src, dst)
    monkeypatch.setattr(os, "replace", spy)
    target = tmp_path / "deep" / "er" / "toy.ssp"  # two folders that do not exist yet
    logs = []
    out = ssp.export_ssp("toy", str(target), ("b.n0=90",), tmp_path / "build", log=logs.append)
    assert out == target and isinstance(out, Path)
    assert calls == [(("toy", ["b.n0=90"], tmp_path / "build"), {"log": logs.append})]
    # written to toy.ssp.part beside it first, then renamed into place
    assert replaced == [(target.with_name("toy.ssp.part"), target)]
    assert not target.with_name("toy.ssp.part").exists()
    with zipfile.ZipFile(target) as z:
        infos = z.infolist()
        assert [i.filename for i in infos] == ["SystemStructure.ssd", "resources/Toy.fmu", "resources/Zeta.fmu"]
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos)
        assert z.read("resources/Toy.fmu") == files["Toy"].read_bytes()
        assert z.read("resources/Zeta.fmu") == files["Zeta"].read_bytes()
        ssd = z.read("SystemStructure.ssd")
    assert ssd.startswith(b"<?xml version='1.0' encoding='UTF-8'?>\n<ssd:SystemStructureDescription ")
    _forget_prefixes()
    expected = ET.tostring(ssp.build_ssd(sc, {"Toy": toy_model(), "Zeta": SimpleNamespace(modelVariables=[])})
                           .getroot(), encoding="unicode")
    assert ssd.decode("utf-8") == "<?xml version='1.0' encoding='UTF-8'?>\n" + expected
    # a second export into the folder that now exists replaces the package
    files["Zeta"].write_bytes(b"new")
    again = ssp.export_ssp("toy", target, log=logs.append)
    assert again == target
    with zipfile.ZipFile(target) as z:
        assert z.read("resources/Zeta.fmu") == b"new"


def test_export_defaults_no_overrides_the_default_build_and_print(toy_package, tmp_path):
    sc, files, calls = toy_package
    ssp.export_ssp("toy", tmp_path / "toy.ssp")
    assert calls == [(("toy", [], None), {"log": print})]


def test_read_ssd_of_a_package_and_of_a_file(toy_package, tmp_path):
    out = ssp.export_ssp("toy", tmp_path / "p" / "toy.ssp", log=lambda m: None)
    root = ssp.read_ssd(out)
    assert root.tag == ssp._q("ssd", "SystemStructureDescription") and root.get("name") == "toy"
    assert ssp._experiment(root) == (0.5, 2.0, 0.25)
    # a bare .ssd file is parsed as it is; a file of another suffix is read as a zip
    with zipfile.ZipFile(out) as z:
        (tmp_path / "x.ssd").write_bytes(z.read("SystemStructure.ssd"))
        (tmp_path / "x.zip").write_bytes(out.read_bytes())
    assert ssp.read_ssd(str(tmp_path / "x.ssd")).get("name") == "toy"
    assert ssp.read_ssd(tmp_path / "x.zip").get("name") == "toy"


# -- libpython and libcosim's log level ------------------------------------------------

def test_libpython_is_looked_up_in_libdir_under_its_soname_then_its_link_name(monkeypatch, tmp_path):
    import sysconfig

    present = {str(tmp_path / "libpython3.x.so.1.0"), str(tmp_path / "libpython3.x.so"),
               str(tmp_path / "libpython3.x.dylib")}
    monkeypatch.setattr(os.path, "exists", lambda p: p in present)
    cases = [
        ({"LIBDIR": str(tmp_path), "INSTSONAME": "libpython3.x.so.1.0", "LDLIBRARY": "libpython3.x.so"},
         str(tmp_path / "libpython3.x.so.1.0")),
        ({"LIBDIR": str(tmp_path), "INSTSONAME": None, "LDLIBRARY": "libpython3.x.so"},
         str(tmp_path / "libpython3.x.so")),
        ({"LIBDIR": str(tmp_path), "INSTSONAME": "libpython3.x.a", "LDLIBRARY": "libpython3.x.so"},
         str(tmp_path / "libpython3.x.so")),  # a static library is not loadable
        ({"LIBDIR": str(tmp_path), "INSTSONAME": "libpython3.x.so.2", "LDLIBRARY": "libpython3.x.so"},
         str(tmp_path / "libpython3.x.so")),  # named, but not there
        ({"LIBDIR": str(tmp_path), "INSTSONAME": "libpython3.x.dylib", "LDLIBRARY": None},
         str(tmp_path / "libpython3.x.dylib")),
        ({"LIBDIR": str(tmp_path), "INSTSONAME": "libpython3.x.a", "LDLIBRARY": "libpython3.x.a"}, None),
        ({"LIBDIR": None, "INSTSONAME": "libpython3.x.so", "LDLIBRARY": None}, None),  # no LIBDIR: ''
        ({"LIBDIR": None, "INSTSONAME": None, "LDLIBRARY": None}, None),
    ]
    for config, expected in cases:
        monkeypatch.setattr(sysconfig, "get_config_var", config.get)
        assert ssp.libpython_path() == expected, config
    # without LIBDIR the name alone is tried (relative to the working directory)
    present.add("libpython3.x.so")
    monkeypatch.setattr(sysconfig, "get_config_var", {"LIBDIR": None, "INSTSONAME": "libpython3.x.so"}.get)
    assert ssp.libpython_path() == "libpython3.x.so"


class _FakeCDLL:
    """ctypes.CDLL as seen by ensure_libpython: the process's symbols (None) without the
    C API; any other library is recorded with its mode."""
    loaded: list = []

    def __init__(self, name, mode=None):
        if name is not None:
            _FakeCDLL.loaded.append((name, mode))
        self.name = name

    def __getattr__(self, symbol):
        raise AttributeError(symbol)


def test_libpython_is_loaded_globally_when_the_c_api_is_not_visible(monkeypatch):
    _FakeCDLL.loaded = []
    monkeypatch.setattr(ctypes, "CDLL", _FakeCDLL)
    monkeypatch.setattr(ssp, "libpython_path", lambda: "/some/libpython3.x.so")
    assert ssp.ensure_libpython() == "/some/libpython3.x.so"
    assert _FakeCDLL.loaded == [("/some/libpython3.x.so", ctypes.RTLD_GLOBAL)]
    monkeypatch.setattr(ssp, "libpython_path", lambda: None)
    with pytest.raises(OSError) as e:
        ssp.ensure_libpython()
    assert str(e.value) == ("the CPython C API is not globally visible and no shared libpython was found; "
                            "pythonfmu FMUs cannot load in libcosim from this Python")
    assert len(_FakeCDLL.loaded) == 1


def test_libcosims_log_level_by_name_warning_by_default(monkeypatch, tmp_path):
    pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (the 'test' extra)")
    from libcosimpy import CosimLogging

    levels = []
    monkeypatch.setattr(CosimLogging, "log_output_level", levels.append)
    ssp.set_libcosim_log_level()
    ssp.set_libcosim_log_level("Error")
    ssp.set_libcosim_log_level("trace")
    assert levels == [CosimLogging.CosimLogLevel.WARNING, CosimLogging.CosimLogLevel.ERROR,
                      CosimLogging.CosimLogLevel.TRACE]
    # run_ssp_libcosim sets it (warning unless told) before it reads the package; None leaves it
    bad = tmp_path / "bad.ssp"
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("SystemStructure.ssd", '<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/'
                                          'SSP1/SystemStructureDescription"/>')
    asked = []
    monkeypatch.setattr(ssp, "set_libcosim_log_level", asked.append)
    for kwargs in ({}, {"log_level": "info"}, {"log_level": None}):
        with pytest.raises(ValueError) as e:
            ssp.run_ssp_libcosim(bad, **kwargs)
        assert str(e.value) == "give step and stop: the package's DefaultExperiment does not define them"
    assert asked == ["warning", "info"]
    with pytest.raises(ValueError) as e:
        ssp.run_ssp_libcosim(bad, step=0.1)
    assert str(e.value) == "give step and stop: the package's DefaultExperiment does not define them"
    with pytest.raises(ValueError) as e:
        ssp.run_ssp_libcosim(bad, stop=1.0)
    assert str(e.value) == "give step and stop: the package's DefaultExperiment does not define them"
