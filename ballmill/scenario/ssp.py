"""Scenarios as SSP packages, for other FMI tools; running an SSP in libcosim.

`export_ssp` writes a scenario as an SSP 1.0 package (a zip: SystemStructure.ssd
plus the native FMUs under resources/): one ssd:Component per FMU instance, its
connectors with units, the scenario's parameter values as inline
ssv:ParameterSets, the connections, and the experiment's start and stop time.

Written so that tools apply it as written:
* every component's parameter set has the same name (`PARAMETER_SET`): an engine
  that applies one named set per run (libcosim keys its sets by name across the
  components: asked for one name it applies only the components' sets of that
  name, and by default each component's first set) applies all the scenario's
  values, not one component's;
* the communication step (SSP 1.0 has no place for it) goes where each
  co-simulation tool reads it: the Open Simulation Platform's fixed-step
  algorithm annotation in the DefaultExperiment (libcosim), and OMSimulator's
  fixed-step master in the system's org.openmodelica annotation
  (oms:SimulationInformation/oms:FixedStepMaster stepSize). Tools that read
  neither need the step given to them (see docs/OTHER_TOOLS.md).

`run_ssp_libcosim` runs such a package with libcosimpy (libcosim, the Open
Simulation Platform's C++ co-simulation engine) and returns the recorded
variables as arrays. libcosim is loaded into this Python process, so the
pythonfmu binaries find the CPython C API already loaded; `ensure_libpython`
makes sure of that (and loads libpython with RTLD_GLOBAL when it is not).

Table sources (CSV instances) have no FMU and cannot go into an SSP.
"""
from __future__ import annotations

import ctypes
import os
import sysconfig
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from ..fmi.slave import UNITS
from . import spec as _spec

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
}
PARAMETER_SET = "scenario"  # the one name of every component's parameter set
FMU_MIME = "application/x-fmu-sharedlibrary"
SSD_NAME = "SystemStructure.ssd"
_KINDS = {"parameter": "parameter", "input": "input", "output": "output",
          "calculatedParameter": "calculatedParameter"}
_TYPES = ("Real", "Integer", "Boolean", "String")


def _q(prefix: str, tag: str) -> str:
    return f"{{{NS[prefix]}}}{tag}"


def _fmt(kind: str, value) -> str:
    if kind == "Real":
        return repr(float(value))
    if kind == "Integer":
        return str(int(value))
    if kind == "Boolean":
        return "true" if value else "false"
    return str(value)


def build_ssd(sc: _spec.Scenario, models: dict) -> ET.ElementTree:
    """The SystemStructure.ssd of a checked scenario (FMU instances only)."""
    for prefix, uri in NS.items():
        ET.register_namespace(prefix, uri)
    tables = [n for n, inst in sc.instances.items() if inst.fmu is None]
    if tables:
        raise _spec.ScenarioError([f"{sc.path.as_posix()}: instances.{n}: a table source (CSV) has no FMU "
                                   f"and cannot be exported to SSP; replace it by an FMU"
                                   for n in tables])
    root = ET.Element(_q("ssd", "SystemStructureDescription"), {"version": "1.0", "name": sc.name})
    system = ET.SubElement(root, _q("ssd", "System"), {"name": sc.name})
    if sc.description:
        system.set("description", sc.description)
    elements = ET.SubElement(system, _q("ssd", "Elements"))
    units_used: set[str] = set()
    for name, inst in sc.instances.items():
        md = models[inst.fmu]
        comp = ET.SubElement(elements, _q("ssd", "Component"),
                             {"name": name, "type": FMU_MIME, "source": f"resources/{inst.fmu}.fmu"})
        connectors = ET.SubElement(comp, _q("ssd", "Connectors"))
        kinds = {}
        for v in md.modelVariables:
            if v.causality not in _KINDS or v.type not in _TYPES:
                continue
            kinds[v.name] = v.type
            attrs = {"name": v.name, "kind": _KINDS[v.causality]}
            if v.description:
                attrs["description"] = v.description
            conn = ET.SubElement(connectors, _q("ssd", "Connector"), attrs)
            typed = ET.SubElement(conn, _q("ssc", v.type))
            if v.type == "Real" and v.unit:
                typed.set("unit", v.unit)
                units_used.add(v.unit)
        if inst.parameters:
            bindings = ET.SubElement(comp, _q("ssd", "ParameterBindings"))
            binding = ET.SubElement(bindings, _q("ssd", "ParameterBinding"))
            values = ET.SubElement(binding, _q("ssd", "ParameterValues"))
            pset = ET.SubElement(values, _q("ssv", "ParameterSet"),
                                 {"version": "1.0", "name": PARAMETER_SET})
            params = ET.SubElement(pset, _q("ssv", "Parameters"))
            for pname, value in inst.parameters.items():
                kind = kinds[pname]
                p = ET.SubElement(params, _q("ssv", "Parameter"), {"name": pname})
                typed = ET.SubElement(p, _q("ssv", kind), {"value": _fmt(kind, value)})
                unit = next((v.unit for v in md.modelVariables if v.name == pname), None)
                if kind == "Real" and unit:
                    typed.set("unit", unit)
    if sc.connections:
        connections = ET.SubElement(system, _q("ssd", "Connections"))
        for si, sv, di, dv in sc.connections:
            ET.SubElement(connections, _q("ssd", "Connection"),
                          {"startElement": si, "startConnector": sv, "endElement": di, "endConnector": dv})
    # OMSimulator's fixed-step master (its SSD annotation, at the end of the system)
    sys_annotations = ET.SubElement(system, _q("ssd", "Annotations"))
    oms = ET.SubElement(ET.SubElement(sys_annotations, _q("ssc", "Annotation"), {"type": "org.openmodelica"}),
                        _q("oms", "Annotations"))
    ET.SubElement(ET.SubElement(oms, _q("oms", "SimulationInformation")), _q("oms", "FixedStepMaster"),
                  {"description": "oms-ma", "stepSize": repr(sc.step)})
    if units_used:
        units = ET.SubElement(root, _q("ssd", "Units"))
        for u in sorted(units_used):
            spec = dict(UNITS.get(u, {}))
            unit_el = ET.SubElement(units, _q("ssc", "Unit"), {"name": u})
            ET.SubElement(unit_el, _q("ssc", "BaseUnit"), {k: repr(v) if k == "factor" else str(v)
                                                           for k, v in spec.items()})
    exp = ET.SubElement(root, _q("ssd", "DefaultExperiment"),
                        {"startTime": repr(sc.start), "stopTime": repr(sc.stop)})
    annotations = ET.SubElement(exp, _q("ssd", "Annotations"))
    annotation = ET.SubElement(annotations, _q("ssc", "Annotation"), {"type": "com.opensimulationplatform"})
    algorithm = ET.SubElement(annotation, _q("osp", "Algorithm"))
    ET.SubElement(algorithm, _q("osp", "FixedStepAlgorithm"), {"baseStepSize": repr(sc.step)})
    ET.indent(root)
    return ET.ElementTree(root)


def export_ssp(scenario_name_or_path: str, out_path, overrides=(), build_dir: Path | None = None,
               log=print) -> Path:
    """Write a scenario (with ``--set``-style overrides) as an SSP package.

    Builds the FMUs if needed and checks the scenario first (runner.prepare).
    Returns the path written. Raises ScenarioError / BuildError like `ballmill run`.
    """
    from . import runner
    sc, models, paths = runner.prepare(scenario_name_or_path, list(overrides), build_dir, log=log)
    tree = build_ssd(sc, models)
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open(SSD_NAME, "w") as fh:
            tree.write(fh, encoding="UTF-8", xml_declaration=True)
        for model in sorted({inst.fmu for inst in sc.instances.values()}):
            z.write(paths[model], f"resources/{model}.fmu")
    os.replace(tmp, out)
    return out


def read_ssd(ssp_path) -> ET.Element:
    """The root element of the SystemStructure.ssd inside an .ssp (or of an .ssd file)."""
    p = Path(ssp_path)
    if p.suffix == ".ssd":
        return ET.parse(p).getroot()
    with zipfile.ZipFile(p) as z, z.open(SSD_NAME) as fh:
        return ET.parse(fh).getroot()


# -- libcosim ----------------------------------------------------------------

def libpython_path() -> str | None:
    """This Python's shared libpython (None for a statically linked Python)."""
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    for key in ("INSTSONAME", "LDLIBRARY"):
        name = sysconfig.get_config_var(key)
        if name and (name.endswith((".so", ".dylib")) or ".so." in name):
            path = os.path.join(libdir, name)
            if os.path.exists(path):
                return path
    return None


def ensure_libpython() -> str | None:
    """Make the CPython C API globally visible, as pythonfmu binaries need it.

    A pythonfmu FMU binary does not link libpython: it uses the Py* symbols it
    finds at load time. In a Python process they normally are already global
    (the interpreter executable links libpython or exports the API itself),
    and nothing is done. Otherwise libpython is loaded with RTLD_GLOBAL.
    Returns the library loaded, or None when nothing had to be done.
    """
    try:
        ctypes.CDLL(None).Py_IsInitialized  # noqa: B018 - the lookup is the test
        return None
    except AttributeError:
        pass
    path = libpython_path()
    if path is None:
        raise OSError("the CPython C API is not globally visible and no shared libpython was found; "
                      "pythonfmu FMUs cannot load in libcosim from this Python")
    ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
    return path


def _get_real_samples(observer, slave: int, ref: int, n: int):
    """All real samples of one variable: (step numbers, times [ns], values).

    Calls libcosimc directly: libcosimpy 0.0.6's time_series_real_samples trims
    its arrays by counting zero step numbers, which drops a sample whenever
    step 0 is among them.
    """
    from libcosimpy._internal import libcosimc
    from libcosimpy.CosimObserver import CosimObserver
    fn = libcosimc()["cosim_observer_slave_get_real_samples"]  # a private function object
    fn.restype = ctypes.c_int64
    fn.argtypes = [ctypes.POINTER(CosimObserver), ctypes.c_int, ctypes.c_uint32, ctypes.c_int64,
                   ctypes.c_size_t, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int64),
                   ctypes.POINTER(ctypes.c_int64)]
    values = (ctypes.c_double * n)()
    steps = (ctypes.c_int64 * n)()
    times = (ctypes.c_int64 * n)()
    got = fn(observer.ptr(), slave, ref, 0, n, values, steps, times)
    if got < 0:
        from libcosimpy._internal import get_last_error_message
        raise RuntimeError(f"libcosim: cannot read samples of slave {slave} variable {ref}: "
                           f"{get_last_error_message()}")
    return (np.frombuffer(steps, dtype=np.int64)[:got].copy(), np.frombuffer(times, dtype=np.int64)[:got].copy(),
            np.frombuffer(values, dtype=np.float64)[:got].copy())


def _experiment(root: ET.Element):
    exp = root.find("ssd:DefaultExperiment", NS)
    start = float(exp.get("startTime", 0.0)) if exp is not None else 0.0
    stop = float(exp.get("stopTime")) if exp is not None and exp.get("stopTime") else None
    fixed = root.find("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation/osp:Algorithm/"
                      "osp:FixedStepAlgorithm", NS)
    step = float(fixed.get("baseStepSize")) if fixed is not None else None
    return start, stop, step


def set_libcosim_log_level(level: str = "warning") -> None:
    """libcosim's console log level (trace, debug, info, warning, error, fatal).
    libcosim's default is debug: several lines per FMI call."""
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    log_output_level(CosimLogLevel[level.upper()])


def run_ssp_libcosim(ssp_path, step: float | None = None, stop: float | None = None,
                     record=(), log_level: str | None = "warning") -> dict[str, np.ndarray]:
    """Run an SSP package in libcosim (fixed-step master) and return the records.

    ``step``/``stop`` default to the package's DefaultExperiment (with the OSP
    fixed-step annotation that `export_ssp` writes). ``record`` lists
    (instance, variable) pairs of Real variables (outputs, inputs or
    parameters). Returns {"time": t, "inst.var": values}, sampled at every
    communication point from the start time (the values after initialisation)
    to ``stop``. ``log_level`` sets libcosim's console log level (None: leave it).

    libcosim's fixed-step algorithm is a Jacobi scheme like `runner.run`: every
    instance steps from t_k with the outputs of t_k, then outputs are
    transferred. Parameters come from the package's ParameterBindings; note
    that libcosim only logs a warning for a binding it cannot apply.
    """
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy._internal import get_last_error_message

    ensure_libpython()
    if log_level is not None:
        set_libcosim_log_level(log_level)
    root = read_ssd(ssp_path)
    start, ssd_stop, ssd_step = _experiment(root)
    step = step if step is not None else ssd_step
    stop = stop if stop is not None else ssd_stop
    if step is None or stop is None:
        raise ValueError("give step and stop: the package's DefaultExperiment does not define them")
    if start != 0.0:
        raise ValueError(f"run_ssp_libcosim supports start time 0 only, the package starts at {start} s")
    step_ns = int(round(step * 1e9))
    n_steps = int(round(stop / step))
    if n_steps < 1 or abs(n_steps * step_ns - stop * 1e9) > 1.0:
        raise ValueError(f"stop = {stop} s is not a positive whole number of steps of {step} s")
    with tempfile.TemporaryDirectory(prefix="ballmill_ssp_") as tmp:
        with zipfile.ZipFile(ssp_path) as z:
            z.extractall(tmp)
        try:
            execution = CosimExecution.from_ssp_file(tmp, step_size=step_ns)
        except AssertionError:
            raise RuntimeError(f"libcosim cannot load {ssp_path}: {get_last_error_message()}") from None
        collect = observe_series(execution, record, n_steps)
        ok = execution.simulate_until(n_steps * step_ns)
        reached = execution.status().current_time
        if not ok or reached != n_steps * step_ns:
            raise RuntimeError(f"libcosim stopped at t = {reached * 1e-9:g} s: {get_last_error_message()}")
        return collect()


def observe_series(execution, record, n_steps: int):
    """Record Real variables of a libcosim execution at every step.

    ``record``: (instance, variable) pairs. Adds a time-series observer to the
    execution (before it runs) and returns a function that, after the run,
    gives {"time": t [s], "inst.var": values} (one sample per communication
    point, the first at the start time).
    """
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimObserver import CosimObserver

    buffer = n_steps + 16
    slaves = {info.name.decode(): info.index for info in execution.slave_infos()}
    observer = CosimObserver.create_time_series(buffer_size=buffer)
    execution.add_observer(observer)
    refs = []
    for inst, var in record:
        if inst not in slaves:
            raise KeyError(f"no instance {inst!r} in the execution (instances: {', '.join(sorted(slaves))})")
        idx = slaves[inst]
        desc = {v.name.decode(): v for v in execution.slave_variables(idx)}
        if var not in desc:
            raise KeyError(f"instance {inst!r} has no variable {var!r}")
        if CosimVariableType(desc[var].type) is not CosimVariableType.REAL:
            raise ValueError(f"{inst}.{var}: only Real variables can be recorded here")
        if not observer.start_time_series(idx, desc[var].reference, CosimVariableType.REAL):
            raise RuntimeError(f"libcosim cannot observe {inst}.{var}")
        refs.append((f"{inst}.{var}", idx, desc[var].reference))

    def collect() -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        grid = None
        for key, idx, ref in refs:
            steps, times, values = _get_real_samples(observer, idx, ref, buffer)
            if grid is None:
                grid = steps
                out["time"] = times * 1e-9
            elif not np.array_equal(grid, steps):
                raise RuntimeError(f"libcosim sampled {key} at other steps than {refs[0][0]}")
            out[key] = values
        return out

    collect.observer = observer  # keep the observer alive as long as the function
    return collect
