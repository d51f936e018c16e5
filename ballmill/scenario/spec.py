"""Scenario files: reading, overriding and checking them before anything runs.

A scenario is a TOML file:

    description = "..."
    [experiment]            start, stop [s], step [s] (the communication step)
    [instances.NAME]        fmu = "BallInShell"  (a model built into build/)
                            or table = "file.csv" (columns: time, then signals)
    [instances.NAME.parameters]   parameter = value
    connections = ["drive.x1O -> ball.x1O", ...]
    [record]                variables = ["ball.zP", ...]  (default: all outputs; a BallInShell
                            with contact_model = 2 needs HYBRID_RECORD among them)
    [summary]               ball = "ball"; after = 2.5 or "drive.t0" (statistics after the start-up);
                            structure = "NAME" (a Structure instance: the absorber summary, and a
                            second run without the ball for the bare structure unless bare = false)
    [master]                algebraic_loops = "iterate" (default) or "ignore": what the master does
                            with a loop of direct feedthrough through the connections (found from
                            the FMUs' ModelStructure); loop_tol (relative, default 1e-10),
                            loop_atol (absolute, default 1e-14), loop_max_iter (default 50);
                            for --interface me (Model Exchange, ballmill.scenario.me): solver
                            (scipy's DOP853 (default), RK45, Radau, BDF or LSODA), rtol (default
                            1e-10) and atol (default 1e-10, times each state's nominal value)
    [[plots]]               title, x = "time" or a variable, y = [variables], file = "name.png",
                            aspect = "equal" (optional), ylabel, xlabel (optional; default: the
                            variable's description and unit from its FMU's declaration),
                            vlines = [times: a number [s] or "instance.parameter", a time
                            parameter, drawn labelled with its value], legend = [one text per
                            y] (optional; default: the description and unit, as the labels);
                            or kind = "shell" / "slip_margin", ball = "ball", title, file
                            (the contact point on the sphere; mu - friction_ratio)

The description and the plots' title, xlabel and ylabel may hold placeholders
{instance.parameter} (or {instance.parameter:format}, a Python format spec; numbers default
to "g"): `load` with the model descriptions fills them with the value the run uses (the
file's, a --set's, else the model's start value), so that no text can contradict the run;
a placeholder that names no parameter is a problem like any other.

`load` returns a `Scenario` or raises `ScenarioError` listing every problem
at once, each with where the value came from (the file and key, or the
`--set` option). Given the FMUs' model descriptions it checks every value
before anything runs, as the FMUs would at initialisation: the parameter
exists and can be set (causality, variability), its type, finiteness and the
declared [min, max], and the rules each FMU declares in
ballmill.fmi.interface (e.g. BallInShell's r < R); `ballmill run`, `ballmill
sweep` (every point's values too) and `ballmill export-ssp` share this check.
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SCENARIO_DIR = Path(__file__).resolve().parents[2] / "scenarios"
# [[plots]] kind -> the ball outputs it draws besides N and Ft (report.py); "series" is the default
PLOT_KINDS = {"series": (), "shell": ("xP_ch", "yP_ch", "zP_ch"), "slip_margin": ("friction_ratio",)}
# BallInShell's parameter choosing the contact model: 1 rolling only, 2 the hybrid ball (it slides,
# flies and strikes the shell)
CONTACT = "contact_model"
# what a BallInShell with contact_model = 2 (the hybrid ball) must record: the marks on its plots (mode,
# n_impacts) and the summary's hybrid indicators (ballmill.sweep.indicators.hybrid)
HYBRID_RECORD = ("mode", "n_impacts", "v_impact_max", "E_friction", "E_impact", "t_first_slip", "t_first_flight")


class ScenarioError(ValueError):
    """A scenario has problems; ``problems`` lists them, each with file and key."""

    def __init__(self, problems: list[str]):
        self.problems = problems
        super().__init__(f"{len(problems)} problem(s) in the scenario:\n  - " + "\n  - ".join(problems))


@dataclass
class Instance:
    name: str
    fmu: str | None = None  # model name, for FMU instances
    table: Path | None = None  # CSV file, for table sources
    parameters: dict = field(default_factory=dict)
    columns: list[str] = field(default_factory=list)  # table sources: signal names
    data: np.ndarray | None = None  # table sources: rows of (time, signals...)
    origins: dict = field(default_factory=dict)  # parameter -> where its value came from (file key, --set)


@dataclass
class Scenario:
    path: Path
    name: str
    description: str
    start: float
    stop: float
    step: float
    instances: dict[str, Instance]
    connections: list[tuple[str, str, str, str]]  # (src inst, src var, dst inst, dst var)
    record: list[tuple[str, str]]
    plots: list[dict]
    summary: dict
    master: dict = field(default_factory=lambda: dict(MASTER_DEFAULTS))


MASTER_DEFAULTS = {"algebraic_loops": "iterate", "loop_tol": 1e-10, "loop_atol": 1e-14, "loop_max_iter": 50,
                   "solver": "DOP853", "rtol": 1e-10, "atol": 1e-10}
ME_SOLVERS = ("DOP853", "RK45", "Radau", "BDF", "LSODA")  # scipy's, for ballmill run --interface me
LOOP_MODES = ("iterate", "ignore")


def resolve(name_or_path: str) -> Path:
    """A scenario by path, or by name in scenarios/ (with or without .toml)."""
    p = Path(name_or_path)
    for cand in (p, p.with_suffix(".toml"), SCENARIO_DIR / p, (SCENARIO_DIR / p).with_suffix(".toml")):
        if cand.is_file():
            return cand
    known = ", ".join(sorted(q.stem for q in SCENARIO_DIR.glob("*.toml")))
    raise ScenarioError([f"{name_or_path}: no such scenario file (scenarios here: {known})"])


def parse_override(text: str):
    """'instance.parameter=value' -> (instance, parameter, value)."""
    if "=" not in text or "." not in text.split("=", 1)[0]:
        raise ScenarioError([f"--set {text!r}: expected instance.parameter=value, e.g. drive.t0=30"])
    key, value = text.split("=", 1)
    inst, param = key.strip().split(".", 1)
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()
    return inst, param, parsed


def load(name_or_path: str, overrides: list[str] = (), models: dict | None = None, *,
         origins: dict | None = None, points=()) -> Scenario:
    """Read a scenario and check it. ``models`` maps model name -> fmpy
    ModelDescription (to check parameters, connections and records); the
    runner passes it once the FMUs are built. ``origins``: "instance.parameter"
    -> where an override or a point's value came from (default for an override:
    "--set TEXT"); ``points``: dicts "instance.parameter" -> value (a sweep's
    points), each checked on top of the overrides as if it were set too."""
    path = resolve(name_or_path)
    where = path.as_posix()
    try:
        doc = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError([f"{where}: not valid TOML: {e}"]) from None
    problems: list[str] = []

    def bad(key, msg):
        problems.append(f"{where}: {key}: {msg}")

    def section(key, kind, default):
        """doc[key] when it is a table (dict) or an array (list), else reported and ``default``."""
        v = doc.get(key, default)
        if not isinstance(v, kind):
            bad(key, f"expected {'a table' if kind is dict else 'an array'}, got {v!r}")
            return default
        return v

    exp = doc.get("experiment", {})
    if not isinstance(exp, dict):
        bad("experiment", f"expected a table, got {exp!r}")
        exp = None
    start, stop, step = (exp.get("start", 0.0), exp.get("stop"), exp.get("step")) if exp is not None else (0.0,) * 3
    for key, v in (("start", start), ("stop", stop), ("step", step)) if exp is not None else ():
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            bad(f"experiment.{key}", f"expected a finite number of seconds, got {v!r}")
    if not problems:
        if stop <= start:
            bad("experiment.stop", f"must be after experiment.start = {start}, got {stop}")
        if step <= 0 or step > stop - start:
            bad("experiment.step", f"must be in (0, stop - start = {stop - start:g}] s, got {step!r}")

    instances: dict[str, Instance] = {}
    n_problems = len(problems)
    for name, spec in section("instances", dict, {}).items():
        key = f"instances.{name}"
        if not isinstance(spec, dict):
            bad(key, "expected a table")
            continue
        if "." in name:
            bad(key, "an instance name cannot contain '.' (connections and records split at the first '.')")
        params = spec.get("parameters", {})
        if not isinstance(params, dict):
            bad(f"{key}.parameters", f"expected a table of parameter = value, got {params!r}")
            params = {}
        inst = Instance(name, parameters=dict(params),
                        origins={p: f"{where}: {key}.parameters.{p}" for p in params})
        if "fmu" in spec and "table" not in spec:
            inst.fmu = str(spec["fmu"])
        elif "table" in spec and "fmu" not in spec:
            inst.table = (path.parent / spec["table"]).resolve()
            _load_table(inst, key, bad)
        else:
            bad(key, "needs exactly one of fmu = \"Model\" or table = \"file.csv\"")
        unknown = set(spec) - {"fmu", "table", "parameters"}
        if unknown:
            bad(key, f"unknown key(s) {sorted(unknown)}; expected fmu, table, parameters")
        instances[name] = inst
    if not instances and len(problems) == n_problems:
        bad("instances", "a scenario needs at least one instance")

    for text in overrides:
        try:
            inst, param, value = parse_override(text)
        except ScenarioError as e:
            problems += e.problems
            continue
        origin = (origins or {}).get(f"{inst}.{param}", f"--set {text}")
        if inst not in instances:
            problems.append(f"{origin}: no instance {inst!r} (instances: {', '.join(instances)})")
        else:
            instances[inst].parameters[param] = value
            instances[inst].origins[param] = origin

    connections, connection_at = [], []  # connection_at: each readable connection's index in the file
    for i, text in enumerate(section("connections", list, [])):
        key = f"connections[{i}]"
        try:
            src, dst = (s.strip() for s in str(text).split("->"))
            si, sv = src.split(".", 1)
            di, dv = dst.split(".", 1)
        except ValueError:
            bad(key, f"expected 'instance.output -> instance.input', got {text!r}")
            continue
        connections.append((si, sv, di, dv))
        connection_at.append(i)

    record_spec = section("record", dict, {}).get("variables")
    if record_spec is not None and not isinstance(record_spec, list):
        bad("record.variables", f"expected an array of 'instance.variable', got {record_spec!r}")
        record_spec = []
    record, record_at = [], []
    for i, text in enumerate(record_spec or []):
        if "." not in str(text):
            bad(f"record.variables[{i}]", f"expected 'instance.variable', got {text!r}")
            continue
        record.append(tuple(str(text).split(".", 1)))
        record_at.append(i)

    master = dict(MASTER_DEFAULTS)
    for key, v in section("master", dict, {}).items():
        if key not in MASTER_DEFAULTS:
            bad(f"master.{key}", f"unknown key; expected one of {sorted(MASTER_DEFAULTS)}")
        elif key == "algebraic_loops" and v not in LOOP_MODES:
            bad("master.algebraic_loops", f"expected one of {list(LOOP_MODES)}, got {v!r}")
        elif key == "loop_max_iter" and not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
            bad("master.loop_max_iter", f"expected an integer >= 1, got {v!r}")
        elif key == "solver" and v not in ME_SOLVERS:
            bad("master.solver", f"expected one of {list(ME_SOLVERS)}, got {v!r}")
        elif key in ("rtol", "atol") and not (isinstance(v, (int, float)) and not isinstance(v, bool)
                                              and math.isfinite(v) and v > 0):
            bad(f"master.{key}", f"expected a finite number > 0, got {v!r}")
        elif key in ("loop_tol", "loop_atol") and not (isinstance(v, (int, float)) and not isinstance(v, bool)
                                                        and math.isfinite(v) and v >= 0):
            bad(f"master.{key}", f"expected a finite number >= 0, got {v!r}")
        else:
            master[key] = v
    plots = section("plots", list, [])
    for i, plot in enumerate(plots):
        if not isinstance(plot, dict):
            bad(f"plots[{i}]", f"expected a table, got {plot!r}")
            continue
        if not isinstance(plot.get("x", "time"), str):
            bad(f"plots[{i}].x", f"expected a variable name, got {plot['x']!r}")
        ys = plot.get("y", [])
        if not (isinstance(ys, list) and all(isinstance(y, str) for y in ys)):
            bad(f"plots[{i}].y", f"expected an array of variable names, got {ys!r}")
    scenario = Scenario(path=path, name=path.stem, description=str(doc.get("description", "")),
                        start=_seconds(start), stop=_seconds(stop), step=_seconds(step),
                        instances=instances, connections=connections, record=record,
                        plots=list(plots), summary=dict(section("summary", dict, {})),
                        master=master)
    if models is not None:  # check even when other sections have problems: report them all at once
        problems += check(scenario, models, record_spec is None, connection_at, record_at)
        # a sweep's points: each kind of problem once (the first point's), with how many other
        # values have it, so that a sample of hundreds of points does not list hundreds of lines
        like: dict = {}
        memo: dict = {}
        for point in points:
            for kind, text in _point_problems(scenario, models, point, origins or {}, memo):
                like.setdefault(kind, {})[text] = None
        problems += [next(iter(texts)) + (f" (and {len(texts) - 1} more like it)" if len(texts) > 1 else "")
                     for texts in like.values()]
    if problems:
        raise ScenarioError(list(dict.fromkeys(problems)))
    if models is not None:
        _fill_texts(scenario, models)
    return scenario


def _seconds(v) -> float:
    """An experiment time as a float; 0.0 for a value already reported as bad."""
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else 0.0


def _load_table(inst: Instance, key: str, bad):
    if not inst.table.is_file():
        bad(f"{key}.table", f"no such file {inst.table}")
        return
    try:
        with open(inst.table) as fh:
            header = [h.strip() for h in fh.readline().split(",")]
        data = np.loadtxt(inst.table, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as e:
        bad(f"{key}.table", f"{inst.table.name}: not a numeric CSV with one header line: {e}")
        return
    if header[0] != "time" or data.shape[1] != len(header) or len(header) < 2:
        bad(f"{key}.table", f"{inst.table.name}: expected a header 'time,signal,...' matching the "
                            f"columns, got {header}")
        return
    if not np.all(np.isfinite(data)):
        row = int(np.argwhere(~np.isfinite(data))[0][0]) + 2
        bad(f"{key}.table", f"{inst.table.name}: non-finite value on line {row}")
        return
    if np.any(np.diff(data[:, 0]) <= 0):
        bad(f"{key}.table", f"{inst.table.name}: the time column must increase strictly")
        return
    inst.columns, inst.data = header[1:], data


def _broken(sc: Scenario, models: dict) -> set:
    """Instances that cannot be checked further: no fmu/table, an unknown model, an unreadable table."""
    return {n for n, i in sc.instances.items() if (i.fmu is None and i.table is None)
            or (i.fmu is not None and i.fmu not in models) or (i.table is not None and i.data is None)}


def _start(v):
    """A model variable's start value in its Python type (None without one)."""
    if v.start is None:
        return None
    if v.type == "Real":
        return float(v.start)
    if v.type in ("Integer", "Enumeration"):
        return int(v.start)
    if v.type == "Boolean":
        return v.start in ("true", "1", True)
    return v.start


def _unit(v) -> str:
    """' m' for a variable in metres; '' for unit 1, Integers, Booleans (as the FMUs' messages)."""
    return f" {v.unit}" if v.type == "Real" and v.unit and v.unit != "1" else ""


def _bound(text, default: float) -> float:
    return default if text is None else float(text)


def parameter_problems(name: str, inst: Instance, models: dict, values: dict, only=None,
                       where: str = "", kinds: list | None = None, rules=None, bad=None) -> list[str]:
    """What is wrong with these parameter ``values`` of instance ``name`` (``inst`` gives its
    model and the origins of its values), checked as the FMU checks them at initialisation:
    a parameter of the model that can be set (causality parameter, variability fixed or
    tunable), of its type, finite, within the model description's [min, max], then the
    model's rules (ballmill.fmi.interface) in their order, each evaluated when it reads a
    value given here (a rule reading a value already reported is left out: its problem is
    the one shown). ``only``: check just these parameters and the rules reading them (the
    rest was checked before). Each problem starts with where its value came from (default:
    the key in the scenario file ``where``). ``kinds``: gets, for each problem, what it is
    about (the parameter or the rule, with the origin), whatever the values. ``rules``: the
    indices of the model's rules to evaluate (default: all; ``()``: the values alone);
    ``bad``: gets the parameters found bad (with ``rules = ()`` the caller can evaluate the
    rules later, the bad ones given back through ``bad``)."""
    from ..fmi.interface import INTERFACES

    def origin(param):
        return inst.origins.get(param) or (f"{where}: " if where else "") + f"instances.{name}.parameters.{param}"

    problems, kinds = [], [] if kinds is None else kinds
    bad = set() if bad is None else bad
    md = models[inst.fmu] if inst.fmu is not None else None
    variables = _variables_of(md)
    parameters = [n for n, v in variables.items() if v.causality == "parameter"]
    check = set(values) if only is None else set(only)
    for param, value in values.items():
        if param not in check or param in bad:
            continue
        at = origin(param)
        v = variables.get(param)
        if v is None or v.causality != "parameter":
            other = f"; {param} is an {v.causality}" if v is not None and v.causality in ("input", "output") else ""
            problems.append(f"{at}: {inst.fmu or 'a table'} has no parameter {param!r} "
                            f"(parameters: {', '.join(parameters)}){other}")
            bad.add(param)
            kinds.append((name, at, param))
            continue
        kind = v.type
        ok = (kind == "Real" and isinstance(value, (int, float)) and not isinstance(value, bool)) or \
             (kind == "Integer" and isinstance(value, int) and not isinstance(value, bool)) or \
             (kind == "Boolean" and isinstance(value, bool)) or (kind == "String" and isinstance(value, str))
        if v.variability not in ("fixed", "tunable"):
            problems.append(f"{at}: {inst.fmu}'s parameter {param} has variability {v.variability!r} and "
                            f"cannot be set")
        elif not ok:
            problems.append(f"{at}: expected a {kind} value, got {value!r}")
        elif kind == "Real" and not math.isfinite(value):
            problems.append(f"{at}: parameter {param} = {value!r}{_unit(v)} must be finite")
        elif kind in ("Real", "Integer") and not (_bound(v.min, -math.inf) <= value <= _bound(v.max, math.inf)):
            lo, hi = _bound(v.min, -math.inf), _bound(v.max, math.inf)
            problems.append(f"{at}: parameter {param} = {value!r}{_unit(v)} is outside its accepted range "
                            f"[{lo:g}, {hi:g}]{_unit(v)}")
        else:
            continue
        bad.add(param)
        kinds.append((name, at, param))
    interface = INTERFACES.get(inst.fmu)
    if interface is None or md is None or rules == ():
        return problems
    p = {n: _start(variables[n]) for n in parameters}
    p.update({k: float(x) if variables[k].type == "Real" else x for k, x in values.items()
              if k in variables and k not in bad and variables[k].causality == "parameter"})
    for k, rule in enumerate(interface.rules):
        if not set(rule.names) & check or set(rule.names) & bad or (rules is not None and k not in rules):
            continue
        if any(p.get(n) is None for n in rule.names):  # a model description unlike the declaration
            continue
        try:
            holds = rule.holds(p)
        except (ArithmeticError, ValueError):  # e.g. a square root of a negative: the rule fails
            holds = False
        if holds:
            continue
        # led by the values from outside the scenario file (--set, a sweep's), if any
        given = [n for n in rule.names if n in values]
        lead = [n for n in given if not (where and origin(n).startswith(f"{where}: "))] or given

        def source(n):
            return "" if n in lead else " (default)" if n not in values else f" ({Path(where).name})"
        got = ", ".join(f"{n} = {values.get(n, p[n])!r}{_unit(variables[n])}{source(n)}" for n in rule.names)
        at = "; ".join(dict.fromkeys(origin(n) for n in lead))
        problems.append(f"{at}: {inst.fmu} {name!r} needs {rule.expected}, got {got}")
        bad.update(rule.names)
        kinds.append((name, at, k))
    return problems


def _variables_of(md) -> dict:
    """{name: ModelVariable} of a model description ({} for none), made once per description."""
    if md is None:
        return {}
    got = getattr(md, "_ballmill_variables", None)
    if got is None:
        got = {v.name: v for v in md.modelVariables}
        try:
            md._ballmill_variables = got
        except AttributeError:
            pass
    return got


def _point_problems(sc: Scenario, models: dict, point: dict, origins: dict, memo: dict | None = None) -> list[tuple]:
    """A sweep point's values ("instance.parameter" -> value) checked on top of the scenario's:
    (kind, problem) pairs (``parameter_problems``' kinds). ``memo`` (one dict for all the points
    of a study) keeps what was found for each value and for each rule's values: a value's
    problems depend on it and its origin alone, a rule's on the values of the parameters it
    reads, so that a grid's check costs one look per axis value and one evaluation of a rule
    per distinct combination of the values it reads, not one of everything per point."""
    from ..fmi.interface import INTERFACES

    memo = {} if memo is None else memo
    problems, given = [], {}
    broken = memo.get("broken")
    if broken is None:
        broken = memo["broken"] = _broken(sc, models)
    where = sc.path.as_posix()
    for key, value in point.items():
        name, param = key.split(".", 1)
        at = origins.get(key, key)
        if name not in sc.instances:
            problems.append((at, f"{at}: no instance {name!r} (instances: {', '.join(sc.instances)})"))
        elif name not in broken:
            given.setdefault(name, {})[param] = (value, at)
    for name, vals in given.items():
        inst = sc.instances[name]
        values = {**inst.parameters, **{p: v for p, (v, _) in vals.items()}}
        found, bad = [], set()
        # each value alone, in the order parameter_problems checks them
        for param in values:
            if param not in vals:
                continue
            value, at = vals[param]
            key = ("value", name, param, type(value), value, at)
            hit = memo.get(key)
            if hit is None:
                one = Instance(name, fmu=inst.fmu, table=inst.table, columns=inst.columns, data=inst.data,
                               parameters={param: value}, origins={**inst.origins, param: at})
                kinds, got = [], set()
                texts = parameter_problems(name, one, models, {param: value}, where=where, kinds=kinds,
                                           rules=(), bad=got)
                hit = memo[key] = (list(zip(kinds, texts)), got)
            found += hit[0]
            bad |= hit[1]
        # the rules reading a value of the point, each on the values it reads
        interface = INTERFACES.get(inst.fmu)
        if interface is not None and inst.fmu is not None:
            moved = None
            for k, rule in enumerate(interface.rules):
                names = set(rule.names)
                if not names & set(vals) or names & bad:
                    continue
                key = ("rule", name, k, tuple((n, type(vals[n][0]), vals[n][0], vals[n][1]) for n in rule.names
                                              if n in vals))
                hit = memo.get(key)
                if hit is None:
                    if moved is None:
                        moved = Instance(name, fmu=inst.fmu, table=inst.table, columns=inst.columns,
                                         data=inst.data, parameters=values,
                                         origins={**inst.origins, **{p: at for p, (_, at) in vals.items()}})
                    kinds = []
                    texts = parameter_problems(name, moved, models, values, only=set(vals), where=where,
                                               kinds=kinds, rules=(k,), bad=set(bad))
                    hit = memo[key] = list(zip(kinds, texts))
                found += hit
                if hit:  # as in parameter_problems: a later rule reading these values is left out
                    bad |= names
        problems += found
    return problems


def _variables(inst: Instance, models: dict):
    """{name: (causality, type, unit)} of an instance."""
    if inst.table is not None:
        return {c: ("output", "Real", None) for c in inst.columns}
    md = models[inst.fmu]
    return {v.name: (v.causality, v.type, v.unit) for v in md.modelVariables}


def check(sc: Scenario, models: dict, record_all: bool, connection_at=None, record_at=None) -> list[str]:
    """Check instances, parameters, connections and records against the model descriptions.
    ``connection_at``, ``record_at``: the index in the file of each connection and recorded
    variable (default: their positions), so that a problem names the file's entry when an
    unreadable entry before it was left out."""
    where = sc.path.as_posix()
    problems = []
    for name, inst in sc.instances.items():
        if inst.fmu is not None and inst.fmu not in models:
            problems.append(f"{where}: instances.{name}.fmu: unknown model {inst.fmu!r} "
                            f"(built models: {', '.join(sorted(models))})")
    # instances already reported as unusable (no fmu/table or an unknown one, unreadable table)
    # are left out here; the others are still checked, so that every problem shows at once
    broken = _broken(sc, models)
    variables = {name: _variables(inst, models) for name, inst in sc.instances.items() if name not in broken}
    for name, inst in sc.instances.items():
        if name not in broken:
            problems += parameter_problems(name, inst, models, inst.parameters, where=where)
    seen_inputs = set()
    for i, (si, sv, di, dv) in enumerate(sc.connections):
        key = f"{where}: connections[{i if connection_at is None else connection_at[i]}] ({si}.{sv} -> {di}.{dv})"
        for inst, var, role in ((si, sv, "output"), (di, dv, "input")):
            if inst in broken:
                continue  # already reported
            if inst not in variables:
                problems.append(f"{key}: no instance {inst!r}")
            elif variables[inst].get(var, (None,))[0] != role:
                names = [v for v, c in variables[inst].items() if c[0] == role]
                problems.append(f"{key}: {inst!r} has no {role} {var!r} ({role}s: {', '.join(names)})")
        if si in variables and di in variables and sv in variables[si] and dv in variables[di]:
            su, du = variables[si][sv][2], variables[di][dv][2]
            if su and du and su != du:
                problems.append(f"{key}: unit mismatch, {su} -> {du}")
        if (di, dv) in seen_inputs:
            problems.append(f"{key}: input {di}.{dv} is connected twice")
        seen_inputs.add((di, dv))
    if record_all:
        sc.record = [(n, v) for n in variables for v, c in variables[n].items()
                     if c[0] == "output" and c[1] in ("Real", "Boolean", "Integer")]
    for i, (inst, var) in enumerate(sc.record):
        if inst not in broken and (inst not in variables or var not in variables[inst]):
            at = i if record_all or record_at is None else record_at[i]
            problems.append(f"{where}: record.variables[{at}]: no variable {inst}.{var}")
    recorded = {f"{a}.{b}" for a, b in sc.record} | {"time"}
    for ball in hybrid_balls(sc, models):
        missing = [f"{ball}.{v}" for v in HYBRID_RECORD if f"{ball}.{v}" not in recorded]
        if missing and ball not in broken:
            problems.append(f"{where}: record.variables: {ball} has {CONTACT} = 2 (the hybrid ball): its plots' marks "
                            f"and the summary need {', '.join(missing)} recorded")
    for i, plot in enumerate(sc.plots):
        if not isinstance(plot, dict):
            continue  # reported by load
        kind = plot.get("kind", "series")
        if kind not in PLOT_KINDS:
            problems.append(f"{where}: plots[{i}].kind: expected one of {', '.join(PLOT_KINDS)}, got {kind!r}")
            continue
        if kind != "series":  # the ball's own outputs (report.py)
            ball = plot.get("ball") or next((n for n, inst in sc.instances.items() if inst.fmu == "BallInShell"), None)
            if ball not in sc.instances or sc.instances[ball].fmu is None:
                problems.append(f"{where}: plots[{i}].ball: a {kind} plot needs a BallInShell instance, "
                                f"got {ball!r}")
                continue
            needed = PLOT_KINDS[kind] + ("N", "Ft")
            missing = [f"{ball}.{v}" for v in needed if f"{ball}.{v}" not in recorded]
            if missing:
                problems.append(f"{where}: plots[{i}]: a {kind} plot needs {', '.join(missing)} recorded "
                                f"(BallInShell with motion = 2 has them)")
            if not plot.get("file"):
                problems.append(f"{where}: plots[{i}].file: expected a PNG file name")
            continue
        ys = plot.get("y", [])
        for var in [plot.get("x", "time")] + (list(ys) if isinstance(ys, list) else []):
            if not isinstance(var, str):
                continue  # reported by load
            if var not in recorded and var.split(".", 1)[0] not in broken:
                problems.append(f"{where}: plots[{i}]: {var!r} is not recorded")
        if not plot.get("file"):
            problems.append(f"{where}: plots[{i}].file: expected a PNG file name")
    problems += _check_texts(sc, models, variables, broken)
    return problems


# -- the texts drawn from the run's parameters (description, plot titles and labels, vlines) --
PLACEHOLDER = re.compile(r"\{([^{}]*)\}")
PLOT_TEXTS = ("title", "xlabel", "ylabel")  # [[plots]] keys that may hold placeholders (and legend's texts)


def _typed(start, kind):
    """A model description's start value (fmpy gives strings) as a Python value of its type."""
    if not isinstance(start, str):
        return start
    if kind == "Integer":
        return int(start)
    if kind == "Boolean":
        return start.strip().lower() in ("true", "1")
    if kind == "String":
        return start
    return float(start)


def parameter_value(sc: Scenario, models, inst: str, param: str):
    """A parameter's value in the run: the scenario's (its file or a --set), else the model's
    start value. KeyError when the instance or the model has no such variable."""
    i = sc.instances[inst]
    if param in i.parameters:
        return i.parameters[param]
    if i.fmu is None:
        raise KeyError(f"{inst} is a table and has no parameters")
    v = next((v for v in models[i.fmu].modelVariables if v.name == param), None)
    if v is None:
        raise KeyError(f"{i.fmu} has no parameter {param!r}")
    return _typed(v.start, getattr(v, "type", "Real"))


def hybrid_balls(sc: Scenario, models) -> list[str]:
    """The BallInShell instances whose contact_model (CONTACT) is 2 in the run (the ball that
    slides, flies and strikes the shell), by parameter_value; a model without it has none."""
    out = []
    for name, inst in sc.instances.items():
        if inst.fmu != "BallInShell":
            continue
        try:
            contact = parameter_value(sc, models or {}, name, CONTACT)
        except KeyError:
            continue
        if not isinstance(contact, bool) and contact == 2:
            out.append(name)
    return out


def _format(value, fmt: str) -> str:
    if isinstance(value, bool):
        return format(str(value).lower(), fmt)
    return format(value, fmt or ("g" if isinstance(value, float) else ""))


def fill(text: str, sc: Scenario, models) -> str:
    """``text`` with each {instance.parameter} or {instance.parameter:format} replaced by the
    parameter's value in the run (parameter_value)."""
    def one(m):
        key, _, fmt = m.group(1).partition(":")
        inst, _, param = key.strip().partition(".")
        return _format(parameter_value(sc, models, inst, param), fmt)
    return PLACEHOLDER.sub(one, text)


def _fill_texts(sc: Scenario, models):
    """Fill the placeholders of the description and of each plot's title and labels (in place:
    the scenario now says what this run uses)."""
    sc.description = fill(sc.description, sc, models)
    sc.plots = [{k: (fill(v, sc, models) if k in PLOT_TEXTS and isinstance(v, str) else
                     [fill(x, sc, models) for x in v] if k == "legend" else v)
                 for k, v in p.items()} if isinstance(p, dict) else p for p in sc.plots]


def _check_texts(sc: Scenario, models, variables: dict, broken: set) -> list[str]:
    """Problems with the placeholders of the description and the plots' texts (each named with
    the parameters its instance has), and with vlines entries."""
    where = sc.path.as_posix()
    problems = []

    def parameter(ref: str):
        """None if 'instance.parameter' names a parameter, else why not."""
        inst, dot, param = ref.strip().partition(".")
        if not dot or inst not in sc.instances:
            return f"no instance {inst!r} (instances: {', '.join(sc.instances)}); expected instance.parameter"
        if inst in broken:
            return None  # already reported
        params = [v for v, c in variables[inst].items() if c[0] == "parameter"]
        if param not in params:
            return (f"{sc.instances[inst].fmu or 'a table'} {inst!r} has no parameter {param!r}"
                    f" (parameters: {', '.join(params) or 'none'})")
        return None

    texts = [("description", sc.description)] + [
        (f"plots[{i}].{k}", p[k]) for i, p in enumerate(sc.plots) if isinstance(p, dict)
        for k in PLOT_TEXTS if isinstance(p.get(k), str)]
    for i, p in enumerate(sc.plots):
        if not isinstance(p, dict) or "legend" not in p:
            continue
        texts_, ys = p["legend"], p.get("y", [])
        if not (isinstance(texts_, list) and all(isinstance(x, str) for x in texts_)
                and isinstance(ys, list) and len(texts_) == len(ys)):
            problems.append(f"{where}: plots[{i}].legend: expected one text per variable of y "
                            f"({len(ys) if isinstance(ys, list) else '?'}), got {texts_!r}")
            continue
        texts += [(f"plots[{i}].legend[{j}]", x) for j, x in enumerate(texts_)]
    for key, text in texts:
        for m in PLACEHOLDER.finditer(text):
            ref, _, fmt = m.group(1).partition(":")
            why = parameter(ref)
            if why is not None:
                problems.append(f"{where}: {key}: unknown placeholder {m.group(0)}: {why}")
                continue
            inst, _, param = ref.strip().partition(".")
            if inst in broken:
                continue
            try:
                _format(parameter_value(sc, models, inst, param), fmt)
            except (ValueError, TypeError) as e:
                problems.append(f"{where}: {key}: placeholder {m.group(0)}: bad format {fmt!r}: {e}")
    for i, p in enumerate(sc.plots):
        lines = p.get("vlines", []) if isinstance(p, dict) else []
        if not isinstance(lines, list):
            problems.append(f"{where}: plots[{i}].vlines: expected an array of times [s] or "
                            f"'instance.parameter', got {lines!r}")
            continue
        for j, v in enumerate(lines):
            if isinstance(v, str):
                why = parameter(v)
                inst, _, param = v.strip().partition(".")
                if why is None and inst not in broken and variables[inst][param][2] != "s":
                    why = f"{inst}.{param} is not a time (unit {variables[inst][param][2]!r}, expected 's')"
                if why is not None:
                    problems.append(f"{where}: plots[{i}].vlines[{j}]: {why}")
            elif not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
                problems.append(f"{where}: plots[{i}].vlines[{j}]: expected a time [s] or "
                                f"'instance.parameter', got {v!r}")
    return problems
