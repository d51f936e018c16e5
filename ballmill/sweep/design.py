"""Design studies that choose their own points: what `ballmill optimize` and `ballmill
sensitivity` share.

A design study file is a sweep study file (scenario, stop, set, model, indicators: see
`spec`) with, instead of a grid or a sample, the design variables and their bounds, and the
command's own table:

    description = "..."
    scenario = "fast_start"
    stop = 20.0

    [variables]                             # "instance.parameter" = [low, high]
    "drive.t0" = [0.5, 10.0]                # [s]
    "drive.n0" = [30.0, 90.0]               # [1/min]

    [optimize]                              # ballmill optimize (see optimize.py)
    ...
    [sensitivity]                           # ballmill sensitivity (see sensitivity.py)
    ...

The scenario and every corner of the bounds are checked as `ballmill sweep` checks its
points, before any point runs.

`Session` evaluates the points an algorithm asks for, batch by batch, through the sweep's
own machinery: the evaluator chosen and prepared once (`engine.setup`), the batches on the
same executor (`engine.Executor`: Dask's processes scheduler by default, a LocalCluster, a
running scheduler, or in-process), each point by `engine.run_batch`. Every evaluation is
written to DIR/parts/ as its task ends and to DIR/results.parquet at the end; a point
already there (same id: the same parameter values) is read, not computed. The algorithms
are deterministic for a seed, so an interrupted study run again asks for the same points
in the same order: it finds the evaluations it has and computes only the rest, and ends
where the uninterrupted study would have ended (the evaluations of the tasks that were
running when it stopped are the only ones computed twice).
"""
from __future__ import annotations

import json
import math
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

from . import engine as _eng
from .spec import Study, StudyError, _check_key, _toml_value, build, point_id, resolve_study

COMMON_KEYS = {"description", "scenario", "stop", "set", "model", "indicators", "variables"}
OWN_KEYS = {"optimize", "objectives", "constraints", "sensitivity"}  # the commands' own tables


@dataclass
class DesignStudy:
    """A checked design study: the sweep Study it evaluates points of (its grid: the bounds'
    ends, the points `check_scenario` checks), the variables' bounds and the command's table."""

    study: Study
    bounds: dict  # "inst.param" -> (low, high)
    table: dict  # the command's own table ([optimize] or [sensitivity]), as read
    where: str  # the study file, for the problems
    section: str  # "optimize" or "sensitivity"

    @property
    def names(self) -> list[str]:
        return list(self.bounds)


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def load(path_or_name: str, section: str) -> DesignStudy:
    """A design study file with its [``section``] table (its keys checked by the command);
    StudyError names every problem with the file and key."""
    path = resolve_study(path_or_name)
    if path is None:
        from ..scenario import spec as _scen

        try:
            _scen.resolve(path_or_name)
            what = "a scenario, not a study file"
        except _scen.ScenarioError:
            what = "no such study file" if not Path(path_or_name).exists() else "not a study file (no scenario)"
        raise StudyError([f"{path_or_name}: {what} (expected a .toml path or a name in scenarios/studies/: "
                          f"a file naming its scenario, with [variables] and [{section}])"])
    where = path.as_posix()
    doc = tomllib.loads(path.read_text())
    problems = []
    unknown = set(doc) - COMMON_KEYS - OWN_KEYS
    if unknown:
        problems.append(f"{where}: unknown key(s) {sorted(unknown)}; expected {', '.join(sorted(COMMON_KEYS))}, "
                        f"{', '.join(sorted(OWN_KEYS))}")
    for k in ("grid", "sample", "case"):
        if k in doc:  # (also caught above: say why)
            problems.append(f"{where}: {k}: a design study chooses its own points from [variables]")
    if section not in doc:
        problems.append(f"{where}: no [{section}] table (ballmill {section} reads its settings there)")
    table = doc.get(section, {})
    if not isinstance(table, dict):
        problems.append(f"{where}: {section}: expected a table, got {table!r}")
        table = {}
    variables = doc.get("variables")
    bounds = {}
    if not isinstance(variables, dict) or not variables:
        problems.append(f"{where}: variables: expected a table of \"instance.parameter\" = [low, high], "
                        f"e.g. \"drive.t0\" = [0.5, 10.0], got {variables!r}")
        variables = {}
    for key, rng in variables.items():
        if not _check_key(key, f"{where}: variables", problems):
            continue
        if not (isinstance(rng, list) and len(rng) == 2 and all(_number(v) for v in rng) and rng[0] < rng[1]):
            problems.append(f"{where}: variables.{key}: expected [low, high], two finite numbers with low < high, "
                            f"got {rng!r}")
            continue
        bounds[key] = (float(rng[0]), float(rng[1]))
    if "set" in doc and not isinstance(doc["set"], dict):
        problems.append(f"{where}: set: expected a table of \"instance.parameter\" = value, got {doc['set']!r}")
    fixed = doc.get("set") if isinstance(doc.get("set"), dict) else {}
    for key in fixed:
        if key in bounds:
            problems.append(f"{where}: set.{key}: {key} is also a variable")
    if problems:
        raise StudyError(problems)
    scen = doc["scenario"]
    cand = path.parent / scen
    if cand.is_file() or cand.with_suffix(".toml").is_file():
        scen = str(cand if cand.is_file() else cand.with_suffix(".toml"))
    origins = {**{k: f"{where}: set.{k}" for k in fixed}, **{k: f"{where}: variables.{k}" for k in bounds}}
    # the grid of the bounds' ends: its corners are the points the scenario's check sees (every
    # parameter's declared range and the FMUs' rules at each end)
    study = build(scen, name=path.stem, description=str(doc.get("description", "")),
                  set_=[f"{k}={_toml_value(v)}" for k, v in fixed.items()],
                  grid={k: list(b) for k, b in bounds.items()}, model=doc.get("model"),
                  indicators=doc.get("indicators", []), source=path, where=where, stop=doc.get("stop"),
                  origins=origins)
    return DesignStudy(study, bounds, table, where, section)


def check_keys(ds: DesignStudy, known: dict, problems: list):
    """Unknown keys of the command's table (known: key -> what it is)."""
    for k in ds.table:
        if k not in known:
            problems.append(f"{ds.where}: {ds.section}.{k}: unknown key (known: {', '.join(known)})")


def integer(ds: DesignStudy, key: str, default, problems: list, low: int = 1) -> int:
    v = ds.table.get(key, default)
    if not isinstance(v, int) or isinstance(v, bool) or v < low:
        problems.append(f"{ds.where}: {ds.section}.{key}: expected an integer >= {low}, got {v!r}")
        return default
    return v


def tables(doc: dict, name: str, where: str, known: tuple, what: str, expected: str, problems: list,
           required: bool = False):
    """The study's [[name]] tables, each as (its key for messages, the table): a value that is not a
    list (or, when required, an empty one) is named with `expected`; an entry that is not a table
    (described by `what`) is named and skipped; unknown keys are named and the table kept."""
    items = doc.get(name) if required else doc.get(name, [])
    if not isinstance(items, list) or (required and not items):
        problems.append(f"{where}: {name}: {expected}, got {items!r}")
        return
    for i, t in enumerate(items):
        key = f"{where}: {name}[{i}]"
        if not isinstance(t, dict):
            problems.append(f"{key}: expected a table with {what}, got {t!r}")
            continue
        unknown = set(t) - set(known)
        if unknown:
            problems.append(f"{key}: unknown key(s) {sorted(unknown)} (known: {', '.join(known)})")
        yield key, t


def check_indicator(ds: DesignStudy, key: str, name, known: dict, problems: list) -> bool:
    if name not in known:
        problems.append(f"{ds.where}: {key}: {name!r} is not an indicator of this study's points "
                        f"(known: {', '.join(known)})")
        return False
    return True


# ----------------------------------------------------------------------------
# evaluations on the sweep's executor, every one in DIR, resumed by point id
class Session:
    """Evaluations of a design study's points (see the module docstring).

    ``context``: the command's settings, stored with the results (a DIR holding another
    study or other settings is refused); ``check(indicators) -> problems``: the command's
    check of the indicators it names (name -> unit); ``extra``: (column, unit) of the
    command's own columns (or a function of the indicators giving them), filled by
    ``annotate(row)`` before a row is written; ``total``: the evaluations the progress bar
    expects."""

    def __init__(self, ds: DesignStudy, out_dir, *, context: dict, extra=(), annotate=None, check=None,
                 scheduler=None, workers=None, batch=None, build_dir=None, progress=True, total=0, log=None):
        self.t0 = time.perf_counter()
        self.ds, self.study = ds, ds.study
        self.out_dir = Path(out_dir)
        self.log = log or (lambda m: print(m, file=sys.stderr))
        if len(ds.bounds) > 10:  # (the check sees the 2^k corners)
            raise StudyError([f"{ds.where}: variables: {len(ds.bounds)} variables; at most 10 are supported"])
        self.setup = _eng.setup(self.study, self.out_dir, build_dir, self.log, context={ds.section: context})
        if check is not None:  # the command's names of indicators, against what the points report
            problems = check(self.indicators)
            if problems:
                raise StudyError(problems)
        self.extra = list(extra(self.indicators) if callable(extra) else extra)
        self.cols = self.setup.cols + [c for c, _ in self.extra]
        self.units = {**self.setup.units, **{c: u for c, u in self.extra if u}}
        self.annotate = annotate or (lambda row: None)
        self.batch = batch
        self.executor = _eng.Executor(scheduler, workers, self.setup.prepared, keep=True)
        self.cache = dict(self.setup.done_rows)  # point id -> row
        self.order: dict[str, int] = {}  # point id -> evaluation number, in the order first asked
        self.new_rows: list[dict] = []
        self.parts = self.out_dir / "parts"
        self.part_no = len(list(self.parts.glob("part-*.parquet"))) if self.parts.exists() else 0
        self.bar = _eng._Bar(total, progress)
        self.computed = self.reused = 0
        self.run_s = self.write_s = 0.0
        self.split: dict = {}
        info = {"name": self.study.name, "description": self.study.description, "command": ds.section,
                "context": self.setup.context, "context_hash": self.setup.chash, "evaluator": self.setup.ev.kind,
                "model": self.setup.prepared.model, "variables": {k: list(b) for k, b in ds.bounds.items()},
                "columns": self.cols, "units": self.units,
                "indicators": {k: d for k, (_, d) in {**self.setup.ev.indicators, **self.setup.ev.validity}.items()}}
        self.setup.info_path.write_text(json.dumps(info, indent=2))
        self.setup_s = time.perf_counter() - self.t0

    @property
    def sc(self):
        return self.setup.sc

    @property
    def indicators(self) -> dict:
        """The indicators a point of this study reports: name -> unit (the evaluator's built-in
        ones, whatever its registry holds, the study's own, valid and t_invalid)."""
        out = {k: u for k, (u, _) in self.setup.ev.indicators.items()}
        out.update({i.name: "" for i in self.study.indicators})
        out.update(valid="", t_invalid="s")
        return out

    def _take(self, rows, split):
        rows = [{**{c: r.get(c) for c in self.setup.cols}, **{c: r.get(c) for c, _ in self.extra}} for r in rows]
        for r in rows:
            self.annotate(r)
            self.cache[r["point_id"]] = r
        self.new_rows.extend(rows)
        for k, v in split.items():
            self.split[k] = self.split.get(k, 0.0) + v
        w0 = time.perf_counter()  # every task's rows on disk as it ends: a killed study loses only its tasks in flight
        self.parts.mkdir(exist_ok=True)
        _eng._write(_eng._table(rows, self.cols, self.units), self.parts / f"part-{self.part_no:05d}.parquet")
        self.part_no += 1
        self.write_s += time.perf_counter() - w0
        self.computed += len(rows)
        self.bar.add(len(rows))

    def evaluate(self, points: list[dict], **tags) -> list[dict]:
        """The rows of ``points`` (dicts "inst.param" -> value), in order: those DIR has are read,
        the others computed in one batch of tasks; ``tags`` (e.g. generation) go into the new rows
        (through ``annotate``, which sees them as row keys)."""
        ids = [point_id(p) for p in points]
        todo, seen = [], set()
        for pid, p in zip(ids, points):
            if pid not in self.order:
                self.order[pid] = len(self.order)
            if pid in self.cache or pid in seen:
                continue
            seen.add(pid)
            todo.append((self.order[pid], pid, {k: float(v) for k, v in p.items()}))
        reused = len({pid for pid in ids if pid in self.cache} - seen)
        self.reused += reused
        if reused:
            self.bar.add(reused)
        if todo:
            self.executor.start()
            # about two tasks per worker: a batch (a generation) is small, and every task's rows
            # are written as it ends
            nb = self.batch or max(1, min(250, math.ceil(len(todo) / (2 * self.executor.nworkers))))
            tasks = [todo[k:k + nb] for k in range(0, len(todo), nb)]
            self.run_s += self.executor.run(tasks, self.study.indicators,
                                            lambda rows, split: self._take([{**r, **tags} for r in rows], split))
        return [self.cache[pid] for pid in ids]

    def close(self) -> list[dict]:
        """Stop the executor, write DIR/results.parquet (every evaluation this study asked for,
        in the order first asked, then any others DIR held) and DIR/timing.json; the rows."""
        split = self.executor.close()
        w0 = time.perf_counter()
        rows = sorted(self.cache.values(), key=lambda r: (self.order.get(r["point_id"], math.inf), r.get("point", 0)))
        for r in rows:
            if r["point_id"] in self.order:
                r["point"] = self.order[r["point_id"]]
        _eng._write(_eng._table(rows, self.cols, self.units), self.out_dir / "results.parquet")
        if self.parts.exists():
            for p in self.parts.glob("part-*.parquet"):
                p.unlink()
            self.parts.rmdir()
        self.write_s += time.perf_counter() - w0
        timing = {"prepare": self.setup_s, **split, "run": self.run_s, "write": self.write_s,
                  "points_computed": self.computed, "points_reused": self.reused, "executor": self.executor.name,
                  "workers": self.split}
        (self.out_dir / "timing.json").write_text(json.dumps(timing, indent=2))
        self.rows = rows
        return rows


def value(row: dict, name: str):
    """An indicator of a row as a float (valid: 1.0 or 0.0), None when not reported."""
    v = row.get(name)
    if v is None or row.get("status") != "ok":
        return None
    if isinstance(v, bool):
        return 1.0 if v else 0.0
    v = float(v)
    return v if math.isfinite(v) else None

