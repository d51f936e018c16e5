"""Build the native (C) flavour of the FMUs: no Python inside, only libc and libm.

Each native FMU is the FMI plumbing written once (fmu_src/native/fmu_instance.c under the
version's fmi2.c or fmi3.c, its
contract fmu_src/native/fmu_model.h, the FMU state's layout and check fmu_state.c/.h),
one C file for the model (next to its pythonfmu adapter: fmu_src/ballinshell.c,
drive_models/*.c) and, for the ball, the compiled
kernel (ballmill/physics/_kernel.c, #included). What a build step can make is made
here from the one declaration (ballmill/fmi/interface.py), never checked in: the
model description and the header of value references and variable table
(``<Model>_interface.h``).

The FMU carries its sources (``sources/``, listed as SourceFiles in the model
description, the FMI 2.0 headers included) so that a user on another platform can
compile it (e.g. fmpy.build.build_platform_binary); ``binaries/linux64`` holds the
build of this machine's C compiler (``cc``, or $CC): -O2 -Wall -Wextra with no
warnings, and -ffp-contract=off like setup.py so that the arithmetic rounds like
the Python path's.
"""
from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement, indent, tostring

from .interface import INTERFACES, UNITS, Interface

PACKAGE_DIR = Path(__file__).resolve().parent.parent
ROOT = PACKAGE_DIR.parent
PLUMBING = ROOT / "fmu_src" / "native"
KERNEL = PACKAGE_DIR / "physics" / "_kernel.c"
CRANK_LAW = PACKAGE_DIR / "physics" / "crank_law.h"  # #included by the kernel and the drive models

# model -> its C file; the FMI plumbing and the kernel come with every model
MODEL_SOURCES = {
    "BallInShell": ROOT / "fmu_src" / "ballinshell.c",
    "MotorStartup": ROOT / "drive_models" / "motorstartup.c",
    "InductionMotor": ROOT / "drive_models" / "inductionmotor.c",
    "Structure": ROOT / "drive_models" / "structure.c",
    "Fig1Drive": ROOT / "drive_models" / "fig1drive.c",
}
# model -> the headers its C file includes besides the plumbing's, the kernel and the generated ones
MODEL_HEADERS = {
    "MotorStartup": [ROOT / "drive_models" / "crank_kinematics.h"],
    "InductionMotor": [ROOT / "drive_models" / "crank_kinematics.h"],
}
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
# FMI 3.0 archives (build/fmi3/): fmi3.c over the same plumbing; the model API keeps FMI 2.0's
# status type, so its headers come along
FMI3_HEADERS = ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")
CFLAGS = ["-O2", "-Wall", "-Wextra", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-fvisibility=hidden"]


class NativeBuildError(RuntimeError):
    """A native FMU could not be built (compiler missing, warnings, errors)."""


def available() -> list[str]:
    """The models that have a native C file."""
    return [name for name, src in MODEL_SOURCES.items() if src.exists()]


def fmi_headers_dir() -> Path:
    import fmpy
    return Path(fmpy.__file__).parent / "c-code"


def source_files(name: str, model_source: Path | None = None, fmi: int = 2) -> list[Path]:
    """Every file a native FMU of FMI version `fmi` is built from (its sources/ folder, less the
    generated headers)."""
    hdr = fmi_headers_dir()
    return ([PLUMBING / f"fmi{fmi}.c", PLUMBING / "fmu_instance.c", PLUMBING / "fmu_state.c",
             PLUMBING / "fmu_model.h", PLUMBING / "fmu_instance.h", PLUMBING / "fmu_state.h",
             model_source or MODEL_SOURCES[name], KERNEL, CRANK_LAW]
            + MODEL_HEADERS.get(name, []) + [hdr / h for h in FMI_HEADERS]
            + ([hdr / h for h in FMI3_HEADERS] if fmi == 3 else []))


def compiled_units(name: str, model_source: Path | None = None, fmi: int = 2) -> list[str]:
    """The files a compiler compiles (SourceFiles); the kernel is #included by the models that use it."""
    return [f"fmi{fmi}.c", "fmu_instance.c", "fmu_state.c", (model_source or MODEL_SOURCES[name]).name]


def guid(interface: Interface, sources: list[Path]) -> str:
    """Deterministic GUID: the declaration and every source file (a change gives a new one)."""
    h = hashlib.sha256(repr(interface).encode())
    for src in sources:
        h.update(src.name.encode())
        h.update(src.read_bytes())
    return "{" + str(uuid.UUID(h.hexdigest()[:32])) + "}"


# ----------------------------------------------------------------------------- generated text
def _c_double(x) -> str:
    if x is None:
        return "0.0"
    x = float(x)
    if x == float("inf"):
        return "INFINITY"
    if x == float("-inf"):
        return "-INFINITY"
    return repr(x)


def c_name(name: str) -> str:
    """The C identifier of a variable's value reference: der(n_x) -> der_n_x."""
    return name.replace("der(", "der_").replace(")", "").replace(".", "_")


def interface_header(interface: Interface, guid_: str) -> str:
    """<Model>_interface.h: value references, the variable table, identifier and GUID, and
    Model Exchange's states (value references of the states and their derivatives, nominals)
    and number of event indicators."""
    types = {"Real": "FMU_REAL", "Integer": "FMU_INTEGER", "Boolean": "FMU_BOOLEAN"}
    causes = {"parameter": "FMU_PARAMETER", "input": "FMU_INPUT", "output": "FMU_OUTPUT", "local": "FMU_LOCAL"}
    variables = interface.native_variables
    me = interface.model_exchange
    lines = [f"/* {interface.name}_interface.h: generated by ballmill build from ballmill/fmi/interface.py;",
             " * do not edit (and not kept in git). */",
             f"#ifndef {interface.name.upper()}_INTERFACE_H", f"#define {interface.name.upper()}_INTERFACE_H",
             "#include <math.h>", "#include \"fmu_model.h\"", "",
             f"#define FMU_IDENTIFIER \"{interface.name}\"", f"#define FMU_GUID \"{guid_}\"",
             f"#define FMU_N_VARS {len(variables)}", "", "enum {"]
    for vr, v in enumerate(variables):
        lines.append(f"    VR_{c_name(v.name)} = {vr},")
    lines += ["};", "", "static const fmu_variable FMU_VARIABLES[FMU_N_VARS] = {"]
    for v in variables:
        start = 1.0 if v.start is True else 0.0 if v.start is False else float(v.start)
        lo = "-INFINITY" if v.min is None else _c_double(v.min)
        hi = "INFINITY" if v.max is None else _c_double(v.max)
        tunable = int(v.fmi_variability == "tunable")
        discrete = int(v.fmi_variability == "discrete")
        lines.append(f"    {{\"{v.name}\", {types[v.type]}, {causes[v.causality]}, {tunable}, {discrete}, "
                     f"{_c_double(start)}, {lo}, {hi}, \"{v.unit or ''}\"}},")
    lines += ["};", ""]
    if me is not None:
        names = [row[0] for row in me.states]
        lines += [f"#define FMU_N_STATES {len(names)}", f"#define FMU_N_INDICATORS {len(me.indicators)}"]
        if names:  # C has no empty arrays
            lines += ["static const int FMU_STATE_VRS[FMU_N_STATES] = {"
                      + ", ".join(f"VR_{c_name(n)}" for n in names) + "};",
                      "static const int FMU_DERIVATIVE_VRS[FMU_N_STATES] = {"
                      + ", ".join(f"VR_der_{c_name(n)}" for n in names) + "};",
                      "static const double FMU_STATE_NOMINALS[FMU_N_STATES] = {"
                      + ", ".join(_c_double(row[3]) for row in me.states) + "};"]
        else:
            lines += ["#define FMU_STATE_VRS NULL", "#define FMU_DERIVATIVE_VRS NULL", "#define FMU_STATE_NOMINALS NULL"]
        if me.indicators:
            lines.append("static const int FMU_INDICATOR_VRS[FMU_N_INDICATORS] = {"
                         + ", ".join(f"VR_{c_name(row[0])}" for row in me.indicators) + "};")
        else:
            lines.append("#define FMU_INDICATOR_VRS NULL")
        lines.append("")
    lines += ["#endif", ""]
    return "\n".join(lines)


def tableau_header() -> str:
    """bm_tableaus.h: the Butcher tableaus of ballmill/physics/integrators.py (the one
    copy of those numbers), in the layout of the kernel's bm_problem."""
    from ballmill.physics.integrators import TABLEAUS

    lines = ["/* bm_tableaus.h: generated by ballmill build from ballmill/physics/integrators.py;",
             " * do not edit (and not kept in git). */", "#ifndef BM_TABLEAUS_H", "#define BM_TABLEAUS_H", "",
             "typedef struct {", "    const char *name;", "    int ns, order, adaptive, has_e3;",
             "    double A[144], B[12], C[12], E[13], E3[13];", "} bm_tableau;", "",
             f"static const bm_tableau BM_TABLEAUS[{len(TABLEAUS)}] = {{"]

    def arr(values):
        return "{" + ", ".join(repr(float(x)) for x in values) + "}" if len(values) else "{0.0}"
    for name, tab in TABLEAUS.items():
        ns = tab.n_stages
        A = [float(tab.A[i, j]) for i in range(ns) for j in range(ns)]
        lines.append(f"    {{\"{name}\", {ns}, {tab.order}, {int(tab.E is not None)}, {int(tab.E3 is not None)},")
        lines.append(f"     {arr(A)},")
        lines.append(f"     {arr(tab.B)}, {arr(tab.C)},")
        lines.append(f"     {arr([] if tab.E is None else tab.E)}, {arr([] if tab.E3 is None else tab.E3)}}},")
    lines += ["};", "", "#endif", ""]
    return "\n".join(lines)


def _number(v, kind: str) -> str:
    if kind == "Integer":
        return str(int(v))
    if kind == "Boolean":
        return "true" if v else "false"
    return repr(float(v))


def _units_categories_experiment(root, interface: Interface, variables) -> None:
    """UnitDefinitions, LogCategories and DefaultExperiment: the same elements, in the same
    order, in the FMI 2.0 and the FMI 3.0 schema."""
    units = SubElement(root, "UnitDefinitions")
    for u in sorted({v.unit for v in variables if v.unit}):
        spec = dict(UNITS[u])
        factor = spec.pop("factor", None)
        attrs = {k: str(x) for k, x in spec.items()}
        if factor is not None:
            attrs["factor"] = repr(factor)
        SubElement(SubElement(units, "Unit", name=u), "BaseUnit", attrs)
    cats = SubElement(root, "LogCategories")
    for name, desc in interface.log_categories.items():
        SubElement(cats, "Category", name=name, description=desc)
    start, stop, step = interface.default_experiment
    SubElement(root, "DefaultExperiment", startTime=repr(float(start)), stopTime=repr(float(stop)),
               stepSize=repr(float(step)))


def model_description(interface: Interface, guid_: str, sources: list[str]) -> str:
    """modelDescription.xml of the native flavour (the same variables, units, bounds,
    structure and DefaultExperiment as the pythonfmu flavour's; with Model Exchange as well
    when the interface declares it: its states and their derivatives as local variables after
    the declared ones, the event indicators, ModelStructure/Derivatives)."""
    me = interface.model_exchange
    variables = interface.native_variables
    root = Element("fmiModelDescription", dict(
        fmiVersion="2.0", modelName=interface.name, guid=guid_, description=interface.description,
        author="ballmill", license="MIT", generationTool=GENERATION_TOOL,
        variableNamingConvention="structured",
        numberOfEventIndicators=str(len(me.indicators) if me else 0)))
    common = dict(modelIdentifier=interface.name, needsExecutionTool="false",
                  canBeInstantiatedOnlyOncePerProcess="false", canNotUseMemoryManagementFunctions="true",
                  canGetAndSetFMUstate="true", canSerializeFMUstate="true",
                  providesDirectionalDerivative="false")
    if me is not None:
        me_el = SubElement(root, "ModelExchange", dict(common, completedIntegratorStepNotNeeded="true"))
        files = SubElement(me_el, "SourceFiles")
        for name in sources:
            SubElement(files, "File", name=name)
    cs = SubElement(root, "CoSimulation", dict(
        common, canHandleVariableCommunicationStepSize="true", canInterpolateInputs="false",
        maxOutputDerivativeOrder="0", canRunAsynchronuously="false"))
    files = SubElement(cs, "SourceFiles")
    for name in sources:
        SubElement(files, "File", name=name)
    _units_categories_experiment(root, interface, variables)
    mv = SubElement(root, "ModelVariables")
    index = {}
    states = [row[0] for row in me.states] if me else []
    for vr, v in enumerate(variables):
        index[v.name] = vr + 1
        attrs = dict(name=v.name, valueReference=str(vr), description=v.description,
                     causality=v.causality, variability=v.fmi_variability)
        if v.causality == "local":  # Model Exchange's states and derivatives: computed
            attrs["initial"] = "calculated"
        sv = SubElement(mv, "ScalarVariable", attrs)
        typed = {}
        if v.causality not in ("output", "local"):  # parameters and inputs have start values (initial exact)
            typed["start"] = _number(v.start, v.type)
        if v.unit:
            typed["unit"] = v.unit
        for key in ("min", "max"):
            x = getattr(v, key)
            if x is not None:
                typed[key] = _number(x, v.type) if v.type == "Integer" else repr(float(x))
        if v.name.startswith("der(") and v.name[4:-1] in states:
            typed["derivative"] = str(index[v.name[4:-1]])
        if v.name in states:
            typed["nominal"] = repr(float(me.states[states.index(v.name)][3]))
        SubElement(sv, v.type, typed)
    structure = SubElement(root, "ModelStructure")
    outputs = [v for v in variables if v.causality == "output"]
    # with Model Exchange an output depends on the continuous states too (every one: declared
    # conservatively; the discrete valid and t_invalid change only at events)
    state_deps = [str(index[n]) for n in states]
    if outputs:
        out_el = SubElement(structure, "Outputs")
        for v in outputs:
            deps = [str(index[d]) for d in v.feedthrough] + (state_deps if v.fmi_variability == "continuous" else [])
            SubElement(out_el, "Unknown", index=str(index[v.name]), dependencies=" ".join(deps))
    if states:
        der_el = SubElement(structure, "Derivatives")
        for n in states:  # on every state (conservatively) and the inputs the declaration names
            deps = [int(d) for d in state_deps] + [index[i] for i in me.derivative_dependencies(n)]
            SubElement(der_el, "Unknown", index=str(index[f"der({n})"]),
                       dependencies=" ".join(str(d) for d in sorted(deps)))
    init = SubElement(structure, "InitialUnknowns")
    for v in outputs:
        SubElement(init, "Unknown", index=str(index[v.name]),
                   dependencies=" ".join(str(index[d]) for d in v.depends))
    for v in variables:  # the states and their derivatives (not the event indicators)
        if v.causality == "local" and (v.name in states or v.name.startswith("der(")):
            SubElement(init, "Unknown", index=str(index[v.name]))
    if not len(init):
        structure.remove(init)
    indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, encoding="unicode") + "\n"


FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}


def model_description_fmi3(interface: Interface, token: str) -> str:
    """modelDescription.xml of the FMI 3.0 archive: the same variables (value references, units,
    bounds, descriptions) and structure as the FMI 2.0 one, in FMI 3.0's schema; co-simulation
    with event mode, and Model Exchange when the interface declares it."""
    me = interface.model_exchange
    variables = interface.native_variables
    root = Element("fmiModelDescription", dict(
        fmiVersion="3.0", modelName=interface.name, instantiationToken=token, description=interface.description,
        author="ballmill", license="MIT", generationTool=GENERATION_TOOL, variableNamingConvention="structured"))
    common = dict(modelIdentifier=interface.name, needsExecutionTool="false",
                  canBeInstantiatedOnlyOncePerProcess="false", canGetAndSetFMUState="true",
                  canSerializeFMUState="true", providesDirectionalDerivatives="false",
                  providesAdjointDerivatives="false", providesPerElementDependencies="false")
    if me is not None:
        SubElement(root, "ModelExchange", dict(common, needsCompletedIntegratorStep="false"))
    SubElement(root, "CoSimulation", dict(
        common, canHandleVariableCommunicationStepSize="true", maxOutputDerivativeOrder="0",
        providesIntermediateUpdate="false", mightReturnEarlyFromDoStep="true",
        canReturnEarlyAfterIntermediateUpdate="false", hasEventMode="true",
        providesEvaluateDiscreteStates="false"))
    _units_categories_experiment(root, interface, variables)
    mv = SubElement(root, "ModelVariables")
    states = [row[0] for row in me.states] if me else []
    indicators = [row[0] for row in me.indicators] if me else []
    vr_of = {v.name: vr for vr, v in enumerate(variables)}
    for vr, v in enumerate(variables):
        attrs = dict(name=v.name, valueReference=str(vr), description=v.description,
                     causality=v.causality, variability=v.fmi_variability)
        if v.causality in ("output", "local"):
            attrs["initial"] = "calculated"
        else:
            attrs["start"] = _number(v.start, v.type)
        if v.unit and v.type == "Real":
            attrs["unit"] = v.unit
        for key in ("min", "max"):
            x = getattr(v, key)
            if x is not None:
                attrs[key] = _number(x, v.type) if v.type == "Integer" else repr(float(x))
        if v.name.startswith("der(") and v.name[4:-1] in states:
            attrs["derivative"] = str(vr_of[v.name[4:-1]])
        if v.name in states:
            attrs["nominal"] = repr(float(me.states[states.index(v.name)][3]))
        SubElement(mv, FMI3_TYPES[v.type], attrs)
    # FMI 3.0 declares the independent variable; its value reference follows every variable's
    # (the FMU has no value for it: time is the importer's)
    SubElement(mv, "Float64", dict(name="time", valueReference=str(len(variables)), causality="independent",
                                   variability="continuous", unit="s", description="Simulation time"))
    structure = SubElement(root, "ModelStructure")
    state_deps = [str(vr_of[n]) for n in states]
    outputs = [v for v in variables if v.causality == "output"]
    for v in outputs:  # as the FMI 2.0 archive's (co-simulation's direct dependencies, the states)
        deps = [str(vr_of[d]) for d in v.feedthrough] + (state_deps if v.fmi_variability == "continuous" else [])
        SubElement(structure, "Output", valueReference=str(vr_of[v.name]), dependencies=" ".join(deps))
    for n in states:  # as the FMI 2.0 archive's: every state and the declared inputs
        deps = sorted([int(d) for d in state_deps] + [vr_of[i] for i in me.derivative_dependencies(n)])
        SubElement(structure, "ContinuousStateDerivative", valueReference=str(vr_of[f"der({n})"]),
                   dependencies=" ".join(str(d) for d in deps))
    for v in outputs:
        SubElement(structure, "InitialUnknown", valueReference=str(vr_of[v.name]),
                   dependencies=" ".join(str(vr_of[d]) for d in v.depends))
    for v in variables:
        if v.causality == "local" and (v.name in states or v.name.startswith("der(")):
            SubElement(structure, "InitialUnknown", valueReference=str(vr_of[v.name]))
    for n in indicators:
        SubElement(structure, "EventIndicator", valueReference=str(vr_of[n]))
    indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, encoding="unicode") + "\n"


def build_description_fmi3(name: str, units: list[str]) -> str:
    """sources/buildDescription.xml: how to compile the FMI 3.0 archive's sources."""
    root = Element("fmiBuildDescription", fmiVersion="3.0")
    files = SubElement(SubElement(root, "BuildConfiguration", modelIdentifier=name), "SourceFileSet")
    for unit in units:
        SubElement(files, "SourceFile", name=unit)
    indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, encoding="unicode") + "\n"


# ----------------------------------------------------------------------------- compile, package
def has_compiler() -> bool:
    try:
        compiler()
    except NativeBuildError:
        return False
    return True


def compiler() -> str:
    env = os.environ.get("CC")
    cc = shutil.which(env) if env else (shutil.which("cc") or shutil.which("gcc") or shutil.which("clang"))
    if not cc:
        raise NativeBuildError("no C compiler found (cc, gcc, clang or $CC): the native FMUs need one; "
                               "the pythonfmu flavour (build/pythonfmu/) does not")
    return cc


def platform_dir() -> str:
    machine = platform.machine().lower()
    bits = "64" if sys.maxsize > 2 ** 32 else "32"
    if sys.platform.startswith("linux"):
        return "linux" + bits
    if sys.platform == "darwin":
        return "darwin" + bits
    if sys.platform == "win32":
        return "win" + bits
    raise NativeBuildError(f"unsupported platform {sys.platform} {machine}")


def platform_dir_fmi3() -> str:
    """FMI 3.0's platform tuple (binaries/x86_64-linux)."""
    machine = {"amd64": "x86_64", "arm64": "aarch64"}.get(platform.machine().lower(), platform.machine().lower())
    system = {"linux": "linux", "darwin": "darwin", "win32": "windows"}.get(sys.platform, sys.platform)
    return f"{machine}-{system}"


def shared_suffix() -> str:
    return {"win32": ".dll", "darwin": ".dylib"}.get(sys.platform, ".so")


def compile_binary(sources_dir: Path, units: list[str], out: Path, extra_flags=()) -> None:
    """Compile the units in sources_dir into the shared library out; warnings are errors
    here (the sources must build clean at -Wall -Wextra)."""
    cmd = [compiler(), *CFLAGS, *extra_flags, "-shared", "-I", str(sources_dir),
           *[str(sources_dir / u) for u in units], "-o", str(out), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0 or proc.stderr.strip():
        raise NativeBuildError(f"compiling {out.name} failed or warned:\n  {' '.join(cmd)}\n{proc.stderr}")


def stage_sources(name: str, dest: Path, interface: Interface | None = None,
                  model_source: Path | None = None, fmi: int = 2) -> tuple[str, list[str]]:
    """Copy the sources of model `name` and its generated headers into dest; (guid, units)."""
    interface = interface or INTERFACES[name]
    files = source_files(name, model_source, fmi)
    g = guid(interface, files)
    dest.mkdir(parents=True, exist_ok=True)
    for f in files:
        shutil.copy2(f, dest / f.name)
    (dest / f"{name}_interface.h").write_text(interface_header(interface, g))
    (dest / "bm_tableaus.h").write_text(tableau_header())
    return g, compiled_units(name, model_source, fmi)


def build_native(name: str, out_dir: Path, interface: Interface | None = None,
                 model_source: Path | None = None, fmi: int = 2) -> Path:
    """Build build/<name>.fmu (native; ``fmi=3``: the FMI 3.0 archive, for build/fmi3/): sources,
    binary for this platform, model description. ``interface``/``model_source``: another model
    than the project's (the benchmark's do-nothing FMU)."""
    interface = interface or INTERFACES[name]
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ballmill_native_") as tmp:
        tmp = Path(tmp)
        src = tmp / "sources"
        g, units = stage_sources(name, src, interface, model_source, fmi)
        bindir = tmp / "binaries" / (platform_dir() if fmi == 2 else platform_dir_fmi3())
        bindir.mkdir(parents=True)
        compile_binary(src, units, bindir / f"{name}{shared_suffix()}")
        if fmi == 2:
            (tmp / "modelDescription.xml").write_text(model_description(interface, g, units))
        else:
            (tmp / "modelDescription.xml").write_text(model_description_fmi3(interface, g))
            (src / "buildDescription.xml").write_text(build_description_fmi3(interface.name, units))
        target = out_dir / f"{name}.fmu"
        partial = target.with_suffix(".fmu.part")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(tmp.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(tmp).as_posix())
        partial.replace(target)
    return target


GENERATION_TOOL = "ballmill native build"


def is_native(fmu: Path) -> bool:
    """Whether an FMU file was made by this native build (not a pythonfmu copy)."""
    try:
        with zipfile.ZipFile(fmu) as z:
            return f'generationTool="{GENERATION_TOOL}"' in z.read("modelDescription.xml").decode("utf-8")
    except (OSError, KeyError, zipfile.BadZipFile):
        return False


def build_inputs(name: str) -> list[Path]:
    """Every file the native FMUs of model `name` (FMI 2.0 and 3.0) are made from: their sources,
    and the Python that generates their model descriptions and headers."""
    return source_files(name, fmi=3) + [PLUMBING / "fmi2.c", Path(__file__), PACKAGE_DIR / "fmi" / "interface.py",
                                        PACKAGE_DIR / "physics" / "integrators.py"]


def newest_source_mtime(name: str) -> float:
    return max(f.stat().st_mtime for f in build_inputs(name))
