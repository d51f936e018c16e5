"""What a study is: its scenario, fixed overrides, swept parameters, points, model and indicators.

A study is a TOML file (usually in scenarios/studies/) or a scenario plus
command-line options; both become a `Study`:

    description = "t0 and n0 of the fast start"
    scenario = "fast_start"                 # a scenario name in scenarios/ or a path
    stop = 40.0                             # optional: the scenario's experiment stop, replaced [s]
    set = { "ball.mu" = 0.3 }               # fixed overrides, as `ballmill run --set`

    [grid]                                  # a full grid over every key
    "drive.t0" = [1.0, 2.0, 2.5, 3.0, 4.0]  # a list, or
    "drive.n0" = "40:80:5"                  # start:stop:count (count values, ends included)

    [sample]                                # or: a random or Latin-hypercube sample
    method = "lhs"                          # "lhs" or "random"
    points = 200
    seed = 1
    ranges = { "drive.t0" = [0.5, 30.0], "drive.n0" = [30.0, 90.0] }

    [model]                                 # how each point is computed
    kind = "auto"                           # or a registered evaluator ("crank-kernel", "cosim")
    method = "RK4"                          # the monolithic kernel's integrator
    h = 0.01                                # RK4 first step [s] (tolerance = 1e-8 for DOP853/RK45)
    target_P = 1e-5                         # RK4: h is halved until the contact point's estimated
                                            # error is below this [m]
    error = "one-pass"                      # RK4's estimate: from the run itself, in the same pass,
                                            # to where the model stops holding; or "richardson"
                                            # (step doubling: a second full run at 2h)
    dt = 0.01                               # sampling of the outputs the indicators read [s]

    [contact]                               # optional: run the ball as the hybrid model (rolling,
    mu_k = 0.3                              # sliding, flight, impacts: physics.params.Contact), on
    e_n = 0.5                               # the evaluator "hybrid-kernel" (DOP853 at the tolerance
    v_rest = 0.01                           # by default); its indicators add hybrid ones (mode
                                            # fractions, impacts, friction and impact energy)

    [[indicators]]                          # extra indicators on any recorded variable
    name = "xP_rms_late"
    variable = "ball.xP"
    stat = "rms"                            # max, min, range, amplitude, rms, mean, abs_max, integral
    window = ["after", "after+10"]          # numbers [s], "start", "after", "stop" or "inst.param",
                                            # each with an optional offset in seconds

`check_scenario` loads the study's scenario and checks it, the fixed
overrides and every point's values against the FMUs' model descriptions with
the check `ballmill run` makes (ballmill.scenario.spec), before any point
runs; each problem names where its value came from (the study file's key,
--set, --grid or --range).

`points()` lists the points in a fixed order (grid: the first key varies
slowest; samples: from the seed), so a study gives the same points, indices
and ids wherever it runs. A point's id hashes its parameter values; the
study's ``context`` (scenario file, overrides, model, indicators) is stored
with the results so that a resume never mixes two different studies.
"""
from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..scenario import spec as _scen

STUDY_DIR = _scen.SCENARIO_DIR / "studies"
STATS = ("max", "min", "range", "amplitude", "rms", "mean", "abs_max", "integral")
SAMPLERS = ("lhs", "random")


class StudyError(ValueError):
    """A study has problems; ``problems`` lists each with its file or option."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__(f"{len(problems)} problem(s) in the study:\n  - " + "\n  - ".join(problems))


@dataclass
class Indicator:
    """A custom indicator: ``stat`` of ``variable`` over ``window`` ([a, b], each a number in
    seconds, "start", "after", "stop" or "instance.parameter")."""

    name: str
    variable: str
    stat: str
    window: tuple = ("start", "stop")

    def to_dict(self):
        return {"name": self.name, "variable": self.variable, "stat": self.stat, "window": list(self.window)}


@dataclass
class Study:
    name: str
    scenario: str  # name or path, as given (resolved by the scenario reader)
    description: str = ""
    set: list[str] = field(default_factory=list)  # fixed overrides "inst.param=value"
    grid: dict = field(default_factory=dict)  # "inst.param" -> list of values
    sample: dict | None = None  # {"method", "points", "seed", "ranges": {"inst.param": (lo, hi)}}
    model: dict = field(default_factory=dict)  # kind, method, h, tolerance, dt
    indicators: list[Indicator] = field(default_factory=list)
    source: Path | None = None  # the study file, if any
    stop: float | None = None  # overrides the scenario's experiment stop [s]
    case: str | None = None  # a built-in model case instead of an FMU scenario (evaluators.CASES)
    mode: str | None = None  # the case's mode (absorber: steady, up, down, both)
    contact: dict | None = None  # the hybrid ball's Contact parameters (None: the rolling model)
    # "inst.param" -> where a fixed or swept value came from ("--grid drive.t0=1,2", "FILE: set.ball.mu"),
    # for the problems the checks report (not part of the context: it does not change the results)
    origins: dict = field(default_factory=dict)

    @property
    def swept(self) -> list[str]:
        return list(self.sample["ranges"]) if self.sample else list(self.grid)

    def points(self) -> list[dict]:
        """The study's points, in order: dicts "inst.param" -> value."""
        names = self.swept
        if self.sample:
            s = self.sample
            rng = np.random.default_rng(int(s.get("seed", 0)))
            n, k = int(s["points"]), len(names)
            if s["method"] == "lhs":  # one point in each of n equal strata per axis, strata shuffled
                u = (np.argsort(rng.random((k, n)), axis=1).T + rng.random((n, k))) / n
            else:
                u = rng.random((n, k))
            lo = np.array([float(s["ranges"][p][0]) for p in names])
            hi = np.array([float(s["ranges"][p][1]) for p in names])
            vals = lo + u * (hi - lo)
            return [{p: float(v) for p, v in zip(names, row)} for row in vals]
        if not names:
            return [{}]
        axes = [self.grid[p] for p in names]
        out = []
        for combo in np.ndindex(*[len(a) for a in axes]):
            out.append({p: axes[i][j] for i, (p, j) in enumerate(zip(names, combo))})
        return out

    def context(self, scenario_text: str, evaluator: str) -> dict:
        """What the results of this study depend on besides the points (stored with them)."""
        ctx = {"scenario": self.scenario, "scenario_sha256": hashlib.sha256(scenario_text.encode()).hexdigest(),
                "stop": self.stop, "set": sorted(self.set), "model": dict(sorted(self.model.items())), "evaluator": evaluator,
                "indicators": [i.to_dict() for i in self.indicators]}
        if self.case is not None:  # (absent for FMU scenarios: their contexts stay as they were)
            ctx.update(case=self.case, mode=self.mode)
        if self.contact is not None:  # (absent for the rolling model: its contexts stay as they were)
            ctx["contact"] = dict(sorted(self.contact.items()))
        return ctx


def point_id(point: dict) -> str:
    """A stable id of a point's parameter values (16 hex digits); 2 and 2.0 are the same value."""
    norm = {k: float(v) if isinstance(v, int) and not isinstance(v, bool) else v for k, v in point.items()}
    text = json.dumps({k: norm[k] for k in sorted(norm)}, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def context_hash(context: dict) -> str:
    return hashlib.sha256(json.dumps(context, sort_keys=True).encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------
# values
def _scalar(text: str):
    """One value as TOML reads it (1 -> int, 2.5 -> float, true, "abc"); bare words stay strings."""
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_values(key: str, spec, where: str, origin: str | None = None) -> list:
    """A grid axis: a list, or "start:stop:count", or "a,b,c"; raises StudyError, each problem
    led by ``origin`` (e.g. "--grid drive.t0=4:1:3"), default "WHERE: KEY"."""
    at = origin or f"{where}: {key}"
    if isinstance(spec, list):
        values = spec
    elif isinstance(spec, dict) and set(spec) == {"start", "stop", "count"}:
        values = _linspace(key, spec["start"], spec["stop"], spec["count"], where, origin)
    elif isinstance(spec, str) and ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3:
            raise StudyError([f"{at}: expected start:stop:count, got {spec!r}"])
        values = _linspace(key, _scalar(parts[0]), _scalar(parts[1]), _scalar(parts[2]), where, origin)
    elif isinstance(spec, str):
        values = [_scalar(v) for v in spec.split(",") if v.strip()]
    else:
        values = [spec]
    if not values:
        raise StudyError([f"{at}: no values"])
    for v in values:
        if isinstance(v, float) and not math.isfinite(v):
            raise StudyError([f"{at}: values must be finite, got {v!r}"])
    if len(set(map(repr, values))) != len(values):
        raise StudyError([f"{at}: repeated values in {values}"])
    return values


def _linspace(key, start, stop, count, where, origin=None):
    at = origin or f"{where}: {key}"
    ok = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (start, stop)) and \
        isinstance(count, int) and not isinstance(count, bool) and count >= 1
    if not ok or not (math.isfinite(start) and math.isfinite(stop)):
        raise StudyError([f"{at}: start:stop:count needs two finite numbers and a count >= 1, "
                          f"got {start!r}:{stop!r}:{count!r}"])
    if count == 1:
        return [float(start)]
    if not start < stop:  # a reversed range is most often a typo; an empty one gives one value count times
        raise StudyError([f"{at}: start:stop:count needs start < stop ({'a reversed' if start > stop else 'an empty'} "
                          f"range; list the values to sweep downwards), got {start!r}:{stop!r}:{count!r}"])
    return [float(v) for v in np.linspace(float(start), float(stop), count)]


def _check_key(key: str, where: str, problems: list):
    if not isinstance(key, str) or key.count(".") < 1 or not all(key.split(".", 1)):
        problems.append(f"{where}: {key!r}: expected instance.parameter, e.g. drive.t0")
        return False
    return True


def _window_ok(w) -> bool:
    return isinstance(w, (list, tuple)) and len(w) == 2 and all(
        (isinstance(x, (int, float)) and not isinstance(x, bool)) or isinstance(x, str) for x in w)


def build(scenario: str, *, name: str | None = None, description: str = "", set_=(), grid=None,
          sample=None, model=None, indicators=(), source: Path | None = None, where: str = "study",
          stop: float | None = None, case: str | None = None, mode: str | None = None,
          origins: dict | None = None, contact: dict | None = None) -> Study:
    """A checked Study (StudyError lists every problem). ``case``: a built-in model case
    (`evaluators.CASES`, e.g. "absorber") instead of the FMU scenario ``scenario``; its
    ``mode``, model settings and pseudo-parameters come from the case. ``origins``:
    "inst.param" -> where a fixed or swept value came from (the problems name it). ``contact``:
    the hybrid ball's `physics.params.Contact` parameters (mu_k, e_n, v_rest, slip_eps, creep_eps; {} for
    its defaults): the points run on the evaluator "hybrid-kernel", by default with DOP853."""
    origins = dict(origins or {})
    problems: list[str] = []
    spec_case = None
    if case is not None:
        from .evaluators import CASES
        if case not in CASES:
            raise StudyError([f"{where}: case {case!r}: no such case (known: {', '.join(sorted(CASES))})"])
        spec_case = CASES[case]
        if stop is not None:
            problems.append(f"{where}: stop: does not apply to case {case!r} (its points run until they settle)")
        if sample:
            problems.append(f"{where}: sample: case {case!r} takes a [grid]")
        if indicators:
            problems.append(f"{where}: indicators: case {case!r} has its own indicators only")
        mode = spec_case.MODES[0] if mode is None else mode
        if mode not in spec_case.MODES:
            problems.append(f"{where}: mode: expected one of {', '.join(spec_case.MODES)}, got {mode!r}")
    elif mode is not None:
        problems.append(f"{where}: mode: only a study of a built-in case (case = ...) has a mode")
    if stop is not None and not (isinstance(stop, (int, float)) and not isinstance(stop, bool)
                                 and math.isfinite(stop) and stop > 0):
        problems.append(f"{where}: stop: expected a positive number of seconds, got {stop!r}")
    g = {}
    for key, spec in (grid or {}).items():
        if not _check_key(key, where, problems):
            continue
        try:
            g[key] = parse_values(key, spec, where, origins.get(key))
        except StudyError as e:
            problems += e.problems
    smp = None
    if sample:
        smp = dict(sample)
        method = smp.get("method", "lhs")
        if method not in SAMPLERS:
            problems.append(f"{where}: sample.method: expected one of {SAMPLERS}, got {method!r}")
        smp["method"] = method
        n = smp.get("points")
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            problems.append(f"{where}: sample.points: expected a positive integer, got {n!r}")
        seed = smp.get("seed", 0)
        if not isinstance(seed, int) or isinstance(seed, bool):
            problems.append(f"{where}: sample.seed: expected an integer, got {seed!r}")
        ranges = {}
        for key, rng in (smp.get("ranges") or {}).items():
            if not _check_key(key, where, problems):
                continue
            if isinstance(rng, str):
                rng = [_scalar(v) for v in rng.split(":")]
            if not (isinstance(rng, (list, tuple)) and len(rng) == 2 and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in rng)
                    and rng[1] > rng[0]):
                problems.append(f"{where}: sample.ranges.{key}: expected [low, high] with low < high, got {rng!r}")
                continue
            ranges[key] = (float(rng[0]), float(rng[1]))
        if not ranges:
            problems.append(f"{where}: sample.ranges: a sample needs at least one range, e.g. drive.t0 = [0.5, 30]")
        smp["ranges"] = ranges
        if g:
            problems.append(f"{where}: a study has either a grid or a sample, not both "
                            f"(grid keys {sorted(g)}, sample ranges {sorted(ranges)})")
    for text in set_:
        try:
            inst, param, _ = _scen.parse_override(text)
        except _scen.ScenarioError as e:
            problems += e.problems
            continue
        if f"{inst}.{param}" in g or (smp and f"{inst}.{param}" in smp["ranges"]):
            problems.append(f"{where}: --set {text}: {inst}.{param} is also swept")
    m = {"kind": "auto", "method": "RK4", "h": 0.01, "tolerance": 1e-8, "dt": 0.01, "target_P": 1e-5,
         "error": "one-pass"}
    if spec_case is not None:
        m = dict(spec_case.MODEL)
    if contact is None and (model or {}).get("kind") == HYBRID:
        contact = {}  # the hybrid evaluator asked for by name: Contact's defaults
    if contact is not None:
        m.update(kind=HYBRID, method="DOP853")
        problems += _check_contact(contact, case, (model or {}).get("kind", "auto"), where)
    for key, v in (model or {}).items():
        if key not in m:
            problems.append(f"{where}: model.{key}: unknown key (known: {', '.join(m)})")
            continue
        m[key] = v
    for key in (("h", "tolerance", "dt", "target_P") if spec_case is None else spec_case.POSITIVE):
        v = m[key]
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
            problems.append(f"{where}: model.{key}: expected a positive number, got {v!r}")
    if spec_case is not None:
        problems += spec_case.check_study(g, m, mode, where)
        g = spec_case.study_grid(g, mode)
    elif m["method"] not in ("RK4", "RK45", "DOP853"):
        problems.append(f"{where}: model.method: expected RK4, RK45 or DOP853, got {m['method']!r}")
    elif contact is not None and m["method"] == "RK4":
        problems.append(f"{where}: model.method: the hybrid ball ([contact]) needs an adaptive method, DOP853 "
                        f"or RK45, got 'RK4' (a fixed step cannot follow the stiff Coulomb direction of "
                        f"sliding near zero slip: at h = 0.01 s the fast start's energy diverges)")
    if spec_case is None and m["error"] not in ("one-pass", "richardson"):
        problems.append(f"{where}: model.error: expected one-pass or richardson, got {m['error']!r}")
    inds = []
    seen = set()
    for i, spec in enumerate(indicators):
        key = f"{where}: indicators[{i}]"
        if isinstance(spec, Indicator):
            spec = spec.to_dict()
        if not isinstance(spec, dict):
            problems.append(f"{key}: expected a table with name, variable, stat, window")
            continue
        unknown = set(spec) - {"name", "variable", "stat", "window"}
        if unknown:
            problems.append(f"{key}: unknown key(s) {sorted(unknown)}")
        nm, var, stat = spec.get("name"), spec.get("variable"), spec.get("stat")
        window = spec.get("window", ["start", "stop"])
        if not isinstance(nm, str) or not nm.isidentifier():
            problems.append(f"{key}.name: expected an identifier, got {nm!r}")
        elif nm in seen:
            problems.append(f"{key}.name: {nm!r} is defined twice")
        seen.add(nm)
        if not isinstance(var, str) or "." not in var:
            problems.append(f"{key}.variable: expected instance.variable, got {var!r}")
        if stat not in STATS:
            problems.append(f"{key}.stat: expected one of {', '.join(STATS)}, got {stat!r}")
        if not _window_ok(window):
            problems.append(f"{key}.window: expected [from, to], each seconds, 'start', 'after', 'stop' or "
                            f"'instance.parameter', got {window!r}")
            continue
        inds.append(Indicator(str(nm), str(var), str(stat), tuple(window)))
    if problems:
        raise StudyError(problems)
    return Study(name=name or Path(str(scenario)).stem, scenario=str(scenario), description=description,
                 set=list(set_), grid=g, sample=smp, model=m, indicators=inds, source=source,
                 stop=None if stop is None else float(stop), case=case, mode=mode, origins=origins,
                 contact=None if contact is None else dict(contact))


HYBRID = "hybrid-kernel"  # the evaluator of a study with a [contact] table
CONTACT_KEYS = {"mu_k": "1", "e_n": "1", "v_rest": "m/s", "slip_eps": "m/s", "creep_eps": "m/s"}


def _check_contact(contact, case, kind, where) -> list[str]:
    """The problems of a [contact] table: its keys and values (as physics.params.Contact checks
    them), and a model or case it does not go with."""
    from ..physics.errors import ParameterError
    from ..physics.params import Contact

    if not isinstance(contact, dict):
        return [f"{where}: contact: expected a table of {', '.join(CONTACT_KEYS)}, got {contact!r}"]
    problems = []
    if case is not None:
        problems.append(f"{where}: contact: does not apply to case {case!r} (the hybrid ball runs a crank scenario)")
    if kind not in ("auto", HYBRID):
        problems.append(f"{where}: model.kind: a study with a [contact] table runs on {HYBRID!r}, got {kind!r}")
    unknown = sorted(set(contact) - set(CONTACT_KEYS))
    if unknown:
        problems.append(f"{where}: contact: unknown key(s) {unknown} (known: "
                        f"{', '.join(f'{k} [{u}]' for k, u in CONTACT_KEYS.items())})")
    for k, v in contact.items():
        if k in CONTACT_KEYS and not (isinstance(v, (int, float)) and not isinstance(v, bool)):
            problems.append(f"{where}: contact.{k}: expected a number [{CONTACT_KEYS[k]}], got {v!r}")
    if not problems:
        try:
            Contact(**contact)
        except ParameterError as e:
            problems.append(f"{where}: contact: {e}")
    return problems


def resolve_study(name_or_path: str) -> Path | None:
    """The study file for a name (scenarios/studies/NAME.toml) or path, or None when the
    name is a scenario instead."""
    p = Path(name_or_path)
    cands = [p] if p.suffix == ".toml" else []
    cands += [STUDY_DIR / p, (STUDY_DIR / p).with_suffix(".toml")]
    for c in cands:
        if c.is_file():
            try:
                doc = tomllib.loads(c.read_text())
            except tomllib.TOMLDecodeError as e:
                raise StudyError([f"{c}: not valid TOML: {e}"]) from None
            if "scenario" in doc or "case" in doc:
                return c
    return None


def load(name_or_path: str, *, set_=(), grid=None, sample=None, model=None, stop=None, mode=None) -> Study:
    """A study from a study file or a scenario name, with command-line additions: ``set_``
    (overrides, appended), ``grid`` (axes, replacing the file's), ``sample``, ``model``,
    ``mode`` (a case study's mode, replacing the file's)."""
    path = resolve_study(name_or_path)
    # where each value came from: the command line's options, else the study file's keys
    cli = {**{k: f"--range {k}={_text(v, ':')}" for k, v in ((sample or {}).get("ranges") or {}).items()},
           **{k: f"--grid {k}={_text(v, ',')}" for k, v in (grid or {}).items()}}
    for text in set_:
        if "=" in text and "." in text.split("=", 1)[0]:
            cli[text.split("=", 1)[0].strip()] = f"--set {text}"
    if path is None:
        if mode is not None:
            raise StudyError([f"--mode {mode}: only a study of a built-in case (case = ...) has a mode"])
        _scen.resolve(name_or_path)  # a clear error when it is no scenario either
        return build(name_or_path, set_=list(set_), grid=grid, sample=sample, model=model, where="command line",
                     stop=stop, origins=cli)
    where = path.as_posix()
    doc = tomllib.loads(path.read_text())
    unknown = set(doc) - {"description", "scenario", "case", "mode", "stop", "set", "grid", "sample", "model",
                          "indicators", "contact"}
    if unknown:
        design = " (a design study: run it with ballmill optimize or ballmill sensitivity)" \
            if "variables" in unknown else ""
        raise StudyError([f"{where}: unknown key(s) {sorted(unknown)}; expected description, scenario (or case "
                          f"and mode), stop, set, grid, sample, model, contact, indicators{design}"])
    if "case" in doc and "scenario" in doc:
        raise StudyError([f"{where}: a study has a scenario or a case, not both"])
    scen = doc.get("scenario", doc.get("case"))
    cand = path.parent / scen
    if cand.is_file() or cand.with_suffix(".toml").is_file():
        scen = str(cand if cand.is_file() else cand.with_suffix(".toml"))
    fixed = [f"{k}={_toml_value(v)}" for k, v in (doc.get("set") or {}).items()] + list(set_)
    g = dict(doc.get("grid") or {})
    smp = doc.get("sample")
    if grid:
        g.update(grid)
        smp = None if sample is None else smp
    if sample:
        smp = {**(smp or {}), **sample, "ranges": {**((smp or {}).get("ranges") or {}), **sample.get("ranges", {})}}
        g = {} if not grid else g
    mdl = {**(doc.get("model") or {}), **(model or {})}
    origins = {**{k: f"{where}: set.{k}" for k in (doc.get("set") or {})},
               **{k: f"{where}: grid.{k}" for k in (doc.get("grid") or {})},
               **{k: f"{where}: sample.ranges.{k}" for k in ((doc.get("sample") or {}).get("ranges") or {})}, **cli}
    return build(scen, name=path.stem, description=str(doc.get("description", "")), set_=fixed, grid=g,
                 sample=smp, model=mdl, indicators=doc.get("indicators", []), source=path, where=where,
                 stop=stop if stop is not None else doc.get("stop"), case=doc.get("case"),
                 mode=mode if mode is not None else doc.get("mode"), origins=origins, contact=doc.get("contact"))


def _text(v, sep: str) -> str:
    """A command-line value as the user types it (a list's items joined by ``sep``)."""
    return sep.join(map(str, v)) if isinstance(v, (list, tuple)) else str(v)


def check_scenario(study: Study, build_dir=None, log=None):
    """The study's scenario (an FMU scenario, not a case), loaded and checked as `ballmill run`
    checks it: the FMUs built if needed, the scenario, the fixed overrides and every point's
    values against the model descriptions and the FMUs' rules; StudyError lists every problem,
    each with where its value came from, before any point runs."""
    from ..scenario import runner

    log = log or (lambda m: None)
    try:
        sc, _, _ = runner.prepare(study.scenario, study.set, build_dir, log=lambda m: m.startswith("up to date")
                                  or log(m), origins=study.origins, points=study.points())
    except _scen.ScenarioError as e:
        raise StudyError(e.problems) from None
    return sc


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(v)


def parse_grid_option(text: str) -> tuple[str, object]:
    """--grid inst.param=VALUES -> (key, spec)."""
    if "=" not in text:
        raise StudyError([f"--grid {text!r}: expected instance.parameter=values, e.g. drive.t0=1,2,2.5 "
                          f"or drive.n0=40:80:5"])
    key, values = text.split("=", 1)
    return key.strip(), values.strip()


def parse_sample_option(text: str) -> dict:
    """--sample lhs:N[:SEED] or random:N[:SEED]."""
    parts = text.split(":")
    try:
        out = {"method": parts[0], "points": int(parts[1])}
        if len(parts) > 2:
            out["seed"] = int(parts[2])
        if len(parts) > 3:
            raise ValueError
    except (IndexError, ValueError):
        raise StudyError([f"--sample {text!r}: expected lhs:N[:SEED] or random:N[:SEED]"]) from None
    return out
