"""The sweep engine: points in batches, on Dask or in this process, into DIR/results.parquet.

    run_study(study, out_dir, scheduler=None | "local" | "in-process" | ADDRESS, workers=None,
              batch=None, retry_failed=False, progress=True, build_dir=None) -> Outcome

* One row per point (`columns` gives the order): the swept parameters as
  "instance.parameter", the indicators (indicators.BUILTIN, the study's own,
  then valid and t_invalid), how the point was computed (model, error_P_m,
  error_N_N, error_method), status ("ok" or "failed") and message, and the
  point's index and id. A point that raises becomes a failed row with the
  exception's message; the study goes on.
* Resume: rows already in DIR/results.parquet (and in DIR/parts/, written
  while a study runs, so an interrupted study keeps what it finished) are not
  computed again (failed ones are, with ``retry_failed``). DIR/study.json
  records the study's context; a DIR holding another study's results is
  refused rather than mixed.
* Execution: a batch of points is one task (``batch`` points; default: about
  eight tasks per worker, at most 250 points each, so the task overhead of a
  few ms is spread over many points). ``scheduler``:
  - None: Dask's local "processes" scheduler (dask.compute with
    dask.multiprocessing.get), its worker processes (one per core, or
    ``workers``) forked from this one, so that they inherit the imported
    modules and start in milliseconds (a LocalCluster's spawned workers
    import everything again, seconds); each task's rows come back here as
    the task ends (a Dask callback). Where the platform cannot fork, a
    LocalCluster as for "local";
  - "local": a dask.distributed LocalCluster (one single-threaded worker
    process per core, or ``workers``);
  - an address ("tcp://host:8786"): an existing cluster whose workers have
    ballmill installed;
  - "in-process": the batches here, one after another.
  This process writes the parts and the results, whatever computed the points; the
  PNGs are drawn by the workers when they share this machine (the heat maps shared
  out among them, `plots.jobs`: on the forked workers, forked again after the points,
  while this process imports matplotlib during the points so that they inherit it;
  on a LocalCluster), else here. An evaluator whose Prepared says ``sequential = True`` (points
  that continue from the previous one's state) gets all its points, in
  order, in one task; one with ``chain_key(params) -> (chain, order)`` gets
  each chain whole, in order, in one task (chains run in parallel; a chain
  with a point missing is recomputed whole, since its states are not kept).
* Rounds: a Prepared with ``next_points(rows) -> [params, ...]`` is asked,
  after each round, which points to add given every row so far (the
  absorber's FRF refines its grid where the curve peaks); each round is one
  batch of tasks on the same executor (the default forks its workers afresh
  for each round), until it names none. The rounds are a
  function of the rows, so a resumed study finds the same ones. A Prepared
  with ``write_outputs(study, rows, out_dir, plots, log)`` writes its own
  files beside results.parquet (the absorber's frf.csv and frf.png).
* `setup` (the checks, the evaluator prepared once, DIR's rows so far) and `Executor` (the
  scheduler, started once and kept for every batch) are what run_study is made of, and
  what the design studies (`design.Session`: optimize, sensitivity) use for their batches.
* The rows do not depend on the executor (tests check it): every point is
  computed by the same function from the same inputs, and the rows are sorted
  by point index before they are written.
"""
from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import evaluators as _ev
from . import indicators as _ind
from .spec import Study, StudyError, check_scenario, context_hash, point_id

META = ("valid", "t_invalid", "model", "error_P_m", "error_N_N", "error_method", "status", "message",
        "point", "point_id")
UNITS_META = {"error_P_m": "m", "error_N_N": "N", "t_invalid": "s"}


def columns(study: Study, builtin: dict = _ind.BUILTIN) -> list[str]:
    """The results' columns: swept parameters, the evaluator's built-in indicators, the study's own,
    then META."""
    return study.swept + list(builtin) + [i.name for i in study.indicators] + list(META)


# ----------------------------------------------------------------------------
# what a worker runs
def run_point(prepared, custom, index: int, pid: str, params: dict) -> dict:
    """One point's row (never raises: a failure is a row with its message)."""
    row = dict(params)
    row.update(point=index, point_id=pid)
    try:
        rec, meta = prepared.run(params)
        t0 = time.perf_counter()
        vals = prepared.evaluate(rec, custom)
        prepared.timing["indicators"] = prepared.timing.get("indicators", 0.0) + time.perf_counter() - t0
        for k, v in vals.items():
            row[k] = v if isinstance(v, bool) else _ind.clean(v)
        row.update(model=meta["model"], error_P_m=_ind.clean(meta.get("error_P_m")),
                   error_N_N=_ind.clean(meta.get("error_N_N")), error_method=meta.get("error_method"),
                   status="ok", message="")
    except Exception as e:  # noqa: BLE001 - any failure of a point is reported in its row
        row.update(model=getattr(prepared, "model", ""), status="failed",
                   message=f"{type(e).__name__}: {e}")
    return row


def run_batch(prepared, custom, batch):
    """Rows of a batch [(index, id, params), ...] and the time split of the worker [s]."""
    t0, c0 = time.perf_counter(), time.thread_time()
    prepared.timing.clear()
    prepared.timing.update(integration=0.0, indicators=0.0)
    begin = getattr(prepared, "begin_batch", None)
    if begin is not None:  # a chained evaluator starts each task's chain afresh
        begin()
    rows = [run_point(prepared, custom, i, pid, p) for i, pid, p in batch]
    split = dict(prepared.timing)
    split["task"] = time.perf_counter() - t0
    split["task_cpu"] = time.thread_time() - c0  # CPU time of this thread: what load does not inflate
    return rows, split


# ----------------------------------------------------------------------------
# results on disk
def _table(rows: list[dict], cols: list[str], units: dict):
    """The rows as an Arrow table: a column per name in cols, typed by its values (string,
    bool, int64, else float64; None is null), with its unit in the field's metadata."""
    import pyarrow as pa

    arrays, fields = [], []
    for c in cols:
        vals = [r.get(c) for r in rows]
        present = [v for v in vals if v is not None]
        if c in ("status", "message", "model", "error_method", "point_id") or any(isinstance(v, str) for v in present):
            typ = pa.string()
        elif c == "valid" or (present and all(isinstance(v, bool) for v in present)):
            typ = pa.bool_()
        elif c == "point" or (present and all(isinstance(v, int) and not isinstance(v, bool) for v in present)):
            typ = pa.int64()
        else:
            typ = pa.float64()
        meta = {b"unit": units[c].encode()} if units.get(c) else None
        fields.append(pa.field(c, typ, metadata=meta))
        arrays.append(_arrow_array(vals, typ))
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def _arrow_array(vals: list, typ):
    """What ``pyarrow.array(vals, type=typ)`` makes of the values (str() of each for a string
    column, float() for float64, None as null; NaN stays NaN), made from numpy buffers:
    pyarrow.array looks for pandas on its first call (pandas' import: about 0.45 s of CPU in a
    command that never uses it)."""
    import numpy as np
    import pyarrow as pa

    n = len(vals)
    null = np.array([v is None for v in vals], dtype=bool)
    nulls = int(null.sum())
    valid = pa.py_buffer(np.packbits(~null, bitorder="little")) if nulls else None
    if typ == pa.string():
        data = [b"" if v is None else str(v).encode("utf-8") for v in vals]
        offsets = np.zeros(n + 1, np.int64)
        np.cumsum(np.array([len(d) for d in data], dtype=np.int64), out=offsets[1:])
        if offsets[-1] >= 2 ** 31:  # beyond a string column's 32-bit offsets
            return pa.array(vals, type=typ)
        return pa.Array.from_buffers(typ, n, [valid, pa.py_buffer(offsets.astype(np.int32)),
                                              pa.py_buffer(b"".join(data))], null_count=nulls)
    if typ == pa.bool_():
        bits = np.packbits(np.array([bool(v) for v in vals], dtype=bool), bitorder="little")
        return pa.Array.from_buffers(typ, n, [valid, pa.py_buffer(bits)], null_count=nulls)
    if typ == pa.int64():
        data = np.array([0 if v is None else v for v in vals], dtype=np.int64)
    else:  # None becomes NaN here, in a slot the validity marks null
        data = np.array(vals, dtype=np.float64)
    return pa.Array.from_buffers(typ, n, [valid, pa.py_buffer(data)], null_count=nulls)


def read_rows(path: Path) -> list[dict]:
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist()


def _write(table, path: Path):
    import pyarrow.parquet as pq

    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


@dataclass
class Outcome:
    out_dir: Path
    results: Path
    rows: list[dict]
    computed: int
    skipped: int
    failed: int
    wall_s: float
    setup_s: float
    compute_s: float
    write_s: float
    split: dict = field(default_factory=dict)
    executor: str = ""
    evaluator: str = ""
    batch: int = 0
    plots: list = field(default_factory=list)
    run_s: float = 0.0  # from the first task to the last result


class _Bar:
    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled, self.done = total, enabled, 0
        self.t0 = time.perf_counter()
        self.tty = sys.stderr.isatty()
        self.last = -1.0

    def add(self, n: int):
        self.done += n
        if not self.enabled or self.total <= 0:
            return
        wall = time.perf_counter() - self.t0
        frac = self.done / self.total
        if self.tty and (wall - self.last >= 0.1 or self.done == self.total):
            bar = "#" * int(30 * frac)
            rate = self.done / wall if wall > 0 else 0.0
            sys.stderr.write(f"\r  [{bar:<30}] {self.done}/{self.total} points  {rate:.0f} points/s  "
                             f"({wall:.1f} s)")
            if self.done == self.total:
                sys.stderr.write("\n")
            self.last = wall
        elif not self.tty and math.floor(10 * frac) > self.last:
            self.last = math.floor(10 * frac)
            sys.stderr.write(f"  {self.done}/{self.total} points ({wall:.1f} s)\n")


MAX_ROUNDS = 50  # refinement rounds at most (an evaluator's own limit is usually lower)


def _chains(todo: list, key) -> list[list]:
    """The tasks of a chained evaluator: points with the same key(params) form one chain, run
    whole and in the order given by key's second element (so a chain is never split)."""
    groups: dict = {}
    for item in todo:
        k, order = key(item[2])
        groups.setdefault(k, []).append((order, item))
    return [[it for _, it in sorted(g, key=lambda x: x[0])] for g in groups.values()]


def _can_fork() -> bool:
    import multiprocessing

    return "fork" in multiprocessing.get_all_start_methods()


def _fork_pool(nworkers: int):
    """The worker processes of Dask's processes scheduler, forked from this one, as dask.multiprocessing
    makes them (its worker initialiser), to be kept for several batches (`Executor`)."""
    import functools
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    import dask.multiprocessing

    if os.environ.get("PYTHONHASHSEED") in (None, "0"):  # as dask.multiprocessing.get sets it for its pools
        os.environ["PYTHONHASHSEED"] = "6640"
    init = functools.partial(dask.multiprocessing.initialize_worker_process, user_initializer=None)
    return ProcessPoolExecutor(nworkers, mp_context=multiprocessing.get_context("fork"), initializer=init)


def _compute_forked(calls: list, nworkers: int, take, pool=None, warm=None) -> float:
    """dask.compute of the delayed calls on Dask's local processes scheduler
    (dask.multiprocessing.get), its nworkers processes forked from this one: they inherit the
    imported modules (numpy, the kernel, ballmill), so they start in milliseconds where spawned
    ones import everything again. One task at a time per worker (chunksize 1), so that a
    worker done early takes the next; take(call's index, result) is called here as each call
    ends (a Dask callback), so that results are used as they come. Returns the perf_counter
    time of the last result (then Dask stops the workers). The scheduler is passed as the
    function, not by its name "processes": dask.compute then does not look for a
    dask.distributed client, an import of about 0.3 s of CPU. ``pool``: worker processes kept
    from an earlier batch (`_fork_pool`; then Dask neither starts nor stops them). ``warm``: a
    function run in a thread of this process while the tasks run (started at the first result,
    when the workers are forked; joined before this returns, so that no thread outlives it
    into the next fork): what this process would otherwise do after the tasks, such as
    importing what processes forked later need."""
    import threading

    import dask
    import dask.multiprocessing
    from dask.callbacks import Callback

    last = time.perf_counter()
    index = {c.key: k for k, c in enumerate(calls)}
    warming = threading.Thread(target=warm, name="warm", daemon=True) if warm is not None else None

    def posttask(key, result, dsk, state, worker_id):
        nonlocal last
        if key in index:  # (not the nodes holding the tasks' inputs)
            if warming is not None and warming.ident is None:
                warming.start()
            take(index[key], result)
            last = time.perf_counter()

    try:
        with dask.config.set({"multiprocessing.context": "fork"}), Callback(posttask=posttask):
            dask.compute(*calls, scheduler=dask.multiprocessing.get, num_workers=nworkers, chunksize=1,
                         **({"pool": pool} if pool is not None else {}))
    finally:
        if warming is not None and warming.ident is not None:
            warming.join()
    return last


def _run_forked(prepared, custom, tasks: list, nworkers: int, take, pool=None, warm=None) -> float:
    """run_batch of each task by `_compute_forked` (take(rows, split) as each task ends); the
    time of the last result."""
    import dask

    # the Prepared as one value of the graph, not traversed (a dataclass's fields would be, for every
    # task: about 20 ms a task for the kernel's)
    prep = dask.delayed(prepared, traverse=False)
    # each task's points likewise (a list of 250 tuples of dicts: about 1 ms a task to traverse)
    calls = [dask.delayed(run_batch, pure=False)(prep, custom, dask.delayed(task, traverse=False)) for task in tasks]
    return _compute_forked(calls, nworkers, lambda k, result: take(*result), pool, warm)


def _default_batch(n: int, workers: int) -> int:
    return max(1, min(250, math.ceil(n / (8 * max(1, workers)))))


class Executor:
    """Where the tasks of a study run (see the module docstring: ``scheduler`` None, "local",
    an address or "in-process"), kept for as many batches as the study asks: a LocalCluster
    or a scheduler's client is started once (`start`), its workers get the Prepared once
    (scattered), and `close` stops it. The forked workers of the default are forked afresh
    for each batch, or, with ``keep``, once at the first batch and kept until `close` (a
    study of many small batches, an optimiser's generations: the fork and the stop of the
    workers, about 0.1 s, once instead of once a batch). `run(tasks, custom, take)` runs run_batch on each task
    and calls take(rows, split) here as each task ends; it returns the time from the first task
    to the last result [s]."""

    def __init__(self, scheduler: str | None, workers: int | None, prepared, keep: bool = False):
        self.scheduler, self.workers, self.prepared = scheduler, workers, prepared
        self.keep, self.pool = keep, None  # keep: the forked workers live from the first batch to close
        self.forked = scheduler is None and _can_fork()  # Dask's processes scheduler, workers forked from here
        self.nworkers = max(1, workers or os.cpu_count() or 1) if self.forked else 1
        self.client = self.cluster = self._prep = None
        self.name = "in-process" if scheduler == "in-process" else (
            f"dask processes scheduler, {self.nworkers} worker process(es) forked from this one" if self.forked else "")
        self.split = {"cluster_start": 0.0, "cluster_close": 0.0}

    def start(self):
        if self.scheduler == "in-process" or self.forked or self.client is not None:
            return
        from dask.distributed import Client, LocalCluster

        k0 = time.perf_counter()
        if self.scheduler in (None, "local"):
            n = self.workers or os.cpu_count() or 1
            self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                        dashboard_address=None, silence_logs=40)
            self.client = Client(self.cluster)
            self.name = f"dask LocalCluster, {n} worker process(es)"
        else:
            self.client = Client(self.scheduler)
            self.name = f"dask scheduler {self.scheduler}"
        self.split["cluster_start"] += time.perf_counter() - k0
        self.nworkers = max(1, len(self.client.scheduler_info(n_workers=-1)["workers"]))
        self.name += f" ({self.nworkers} worker(s) seen)"
        self._prep = self.client.scatter(self.prepared, broadcast=True)

    def run(self, tasks: list, custom, take, warm=None) -> float:
        """``warm``: with the forked workers, a function this process runs in a thread while
        they compute (`_compute_forked`); elsewhere not called."""
        self.start()
        r0 = time.perf_counter()
        if self.scheduler == "in-process":
            for task in tasks:
                take(*run_batch(self.prepared, custom, task))
            return time.perf_counter() - r0
        if self.forked:
            if self.keep and self.pool is None:  # forked once, kept for every batch
                self.pool = _fork_pool(self.nworkers)
            last = _run_forked(self.prepared, custom, tasks, self.nworkers, take, self.pool, warm)
            self.split["cluster_close"] += time.perf_counter() - last
            return last - r0
        from dask.distributed import as_completed

        futs = [self.client.submit(run_batch, self._prep, custom, task, pure=False) for task in tasks]
        for fut in as_completed(futs):
            take(*fut.result())
            fut.release()
        return time.perf_counter() - r0

    def call(self, jobs: list) -> list:
        """The results of callables of no argument (a study's PNGs, `plots.jobs`), each one task on
        this executor's workers where they share this machine's files (the forked workers, forked
        afresh unless kept, or a LocalCluster started here), else called here one after
        another; in the order given."""
        if not jobs:
            return []
        if self.forked:
            import dask

            out = [None] * len(jobs)

            def take(k, result):
                out[k] = result
            _compute_forked([dask.delayed(job, pure=False)() for job in jobs], self.nworkers, take, self.pool)
            return out
        if self.cluster is not None:
            return self.client.gather([self.client.submit(job, pure=False) for job in jobs])
        return [job() for job in jobs]

    def close(self) -> dict:
        """Stop the cluster or the kept workers (if any); the time its start and stop took [s]."""
        if self.pool is not None:
            k1 = time.perf_counter()
            self.pool.shutdown(wait=True, cancel_futures=True)  # (after an interrupt: only the tasks running)
            self.pool = None
            self.split["cluster_close"] += time.perf_counter() - k1
        if self.client is not None:
            k1 = time.perf_counter()
            self.client.close()
            if self.cluster is not None:
                self.cluster.close()
            self.client = self.cluster = None
            self.split["cluster_close"] += time.perf_counter() - k1
        return dict(self.split)


@dataclass
class Setup:
    """A study made ready to compute points (`setup`): its scenario, evaluator and Prepared,
    its context, the results' columns and units, and the rows DIR already holds."""

    sc: object
    ev: object
    prepared: object
    context: dict
    chash: str
    cols: list
    units: dict
    info_path: Path
    done_rows: dict


def setup(study: Study, out_dir: Path, build_dir=None, log=None, context: dict | None = None) -> Setup:
    """The scenario checked (every point of the study, before any runs), the evaluator chosen
    and prepared once, and DIR's rows so far by point id (results.parquet and parts/); a DIR
    holding another study's results (another context: ``context`` adds to the study's own) is
    refused."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    parts, results = out_dir / "parts", out_dir / "results.parquet"
    if study.case is not None:  # a built-in model case: its pseudo-scenario (instances, parameters)
        sc = _ev.CASES[study.case].scenario(study.set)
    else:  # checked as `ballmill run` checks it, with every point's values, before any point runs
        sc = check_scenario(study, build_dir, log)
    if study.stop is not None:
        if study.stop <= sc.start:
            raise StudyError([f"stop = {study.stop} s must be after the scenario's start {sc.start} s"])
        sc.stop = study.stop
    for key in study.swept:
        inst = key.split(".", 1)[0]
        if inst not in sc.instances:
            raise StudyError([f"{key}: no instance {inst!r} in scenario {sc.name} "
                              f"(instances: {', '.join(sc.instances)})"])
    try:
        ev = _ev.choose(sc, study.model["kind"])
    except ValueError as e:
        raise StudyError([str(e)]) from None
    prepared = ev.prepare(sc, study, build_dir)
    ctx = study.context(getattr(sc, "text", None) or sc.path.read_text(), ev.kind)
    if context:
        ctx.update(context)
    chash = context_hash(ctx)
    cols = columns(study, ev.indicators)
    info_path = out_dir / "study.json"
    done_rows: dict[str, dict] = {}
    if info_path.exists():
        old = json.loads(info_path.read_text())
        if old.get("context_hash") != chash:
            raise StudyError([f"{out_dir} holds the results of another study ({old.get('name')}, context "
                              f"{old.get('context_hash')}; this one is {chash}: scenario, overrides, model, "
                              f"indicators or settings differ); use another --out or delete {out_dir}"])
    sources = ([results] if results.exists() else []) + (sorted(parts.glob("part-*.parquet")) if parts.exists() else [])
    for src in sources:
        for r in read_rows(src):
            if r.get("point_id"):
                done_rows[r["point_id"]] = r
    units = {**{k: u for k, (u, _) in ev.indicators.items()}, **UNITS_META}
    return Setup(sc, ev, prepared, ctx, chash, cols, units, info_path, done_rows)


def _warm(draw: bool) -> None:
    """What this process imports in a thread while the forked workers compute the points: what it
    needs after them (pyarrow's Parquet writer) and, with ``draw``, what the plots need (the
    processes forked afterwards to draw them inherit it)."""
    import pyarrow.parquet  # noqa: F401

    if draw:
        from . import plots

        plots.warm()


def run_study(study: Study, out_dir, scheduler: str | None = None, workers: int | None = None,
              batch: int | None = None, retry_failed: bool = False, progress: bool = True,
              build_dir=None, plots: bool = True, log=None) -> Outcome:
    log = log or (lambda m: print(m, file=sys.stderr))
    wall0 = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    parts = out_dir / "parts"
    results = out_dir / "results.parquet"

    st = setup(study, out_dir, build_dir, log)
    ev, prepared, context, chash, cols, units = st.ev, st.prepared, st.context, st.chash, st.cols, st.units
    info_path, done_rows = st.info_path, st.done_rows
    if retry_failed:
        done_rows = {k: r for k, r in done_rows.items() if r.get("status") == "ok"}

    points = study.points()
    todo = [(i, point_id(p), p) for i, p in enumerate(points) if point_id(p) not in done_rows]
    chain_key = getattr(prepared, "chain_key", None)
    if chain_key is not None and todo:
        # a chain continues from state to state: one missing point recomputes its whole chain
        missing = {chain_key(p)[0] for _, _, p in todo}
        todo = [(i, point_id(p), p) for i, p in enumerate(points) if chain_key(p)[0] in missing]
    skipped = len(points) - len(todo)
    info = {"name": study.name, "description": study.description, "context": context, "context_hash": chash,
            "evaluator": ev.kind, "model": prepared.model, "swept": study.swept, "points": len(points),
            "columns": cols, "units": units,
            "indicators": {k: d for k, (_, d) in {**ev.indicators, **ev.validity}.items()}}
    info_path.write_text(json.dumps(info, indent=2))

    # run
    setup_s = time.perf_counter() - wall0
    new_rows: list[dict] = []
    split_total: dict = {}
    nb = 0
    bar = _Bar(len(todo), progress)
    pending: list[dict] = []
    part_no = len(list(parts.glob("part-*.parquet"))) if parts.exists() else 0
    last_flush = time.perf_counter()
    write_s = 0.0

    def flush(force=False):
        nonlocal part_no, last_flush, pending, write_s
        if pending and (force or time.perf_counter() - last_flush > 5.0):
            w0 = time.perf_counter()
            parts.mkdir(exist_ok=True)
            _write(_table(pending, cols, units), parts / f"part-{part_no:05d}.parquet")
            part_no += 1
            pending = []
            last_flush = time.perf_counter()
            write_s += time.perf_counter() - w0

    def take(rows, split):
        rows = [{c: r.get(c) for c in cols} for r in rows]  # every column, in order
        new_rows.extend(rows)
        pending.extend(rows)
        for k, v in split.items():
            split_total[k] = split_total.get(k, 0.0) + v
        bar.add(len(rows))
        flush()

    c0 = time.perf_counter()
    run_s = 0.0
    # an evaluator whose points continue from one another (a slow sweep up or down a
    # frequency, say) gets each chain of points, whole and in order, in one task
    sequential = bool(getattr(prepared, "sequential", False))
    chain_key = getattr(prepared, "chain_key", None)
    next_points = getattr(prepared, "next_points", None)
    ex = Executor(scheduler, workers, prepared)

    def tasks_of(todo_round):
        if chain_key is not None:
            return _chains(todo_round, chain_key)
        nb_ = len(todo_round) if sequential else (
            batch or _default_batch(len(todo_round), ex.nworkers))
        return [todo_round[k:k + nb_] for k in range(0, len(todo_round), nb_)]

    draw = plots and getattr(prepared, "generic_plots", True)
    plot_files, plots_s = [], 0.0
    try:
        if draw:
            from . import plots as _plots

        def warm():  # (looked up when called: the benchmark clocks it)
            _warm(draw)
        rnd = 0
        while True:
            if todo:
                ex.start()  # (a LocalCluster or a scheduler: once; the batch size for the workers seen)
                tasks = tasks_of(todo)
                nb = max(nb, max(len(t) for t in tasks))
                run_s += ex.run(tasks, study.indicators, take, warm)
            # refinement: the evaluator looks at every row so far and names the points to add
            # (each round one batch of tasks on the same executor); deterministic, so a resumed
            # study finds the same rounds and skips what it has
            if next_points is None or rnd >= MAX_ROUNDS:
                break
            have = {r["point_id"]: r for r in done_rows.values()}
            have.update({r["point_id"]: r for r in new_rows})
            listed = [have[point_id(p)] for p in points if point_id(p) in have]
            extra = next_points(listed)
            extra = [p for p in extra if point_id(p) not in {point_id(q) for q in points}]
            if not extra:
                break
            rnd += 1
            base = len(points)
            points.extend(extra)
            todo = [(base + j, point_id(p), p) for j, p in enumerate(extra) if point_id(p) not in done_rows]
            bar.total += len(todo)
            skipped += len(extra) - len(todo)
        compute_s = time.perf_counter() - c0

        # the results file: old rows (minus those recomputed) and the new ones, by point index
        w0 = time.perf_counter()
        fresh = {r["point_id"] for r in new_rows}
        rows = [r for k, r in done_rows.items() if k not in fresh] + new_rows
        rows.sort(key=lambda r: (r.get("point", 0), r.get("point_id", "")))
        _write(_table(rows, cols, units), results)
        if parts.exists():
            for p in parts.glob("part-*.parquet"):
                p.unlink()
            parts.rmdir()
        write_s += time.perf_counter() - w0
        # the PNGs: on the study's workers (the maps shared out among them), which are still there
        p0 = time.perf_counter()
        if draw:
            try:
                plot_files = [f for files in ex.call(_plots.jobs(study, rows, out_dir, parts=ex.nworkers))
                              for f in files]
            except Exception as e:  # noqa: BLE001 - the results stand without their plots
                log(f"plots not written: {type(e).__name__}: {e}")
        plots_s = time.perf_counter() - p0
    finally:
        for k, v in ex.close().items():
            split_total[k] = split_total.get(k, 0.0) + v
    executor = ex.name or "none"
    write_outputs = getattr(prepared, "write_outputs", None)
    if write_outputs is not None:  # an evaluator's own result files (and plots) beside the parquet
        plot_files += write_outputs(study, rows, out_dir, plots=plots, log=log)
    failed = sum(1 for r in new_rows if r.get("status") != "ok")
    # how the time went (not part of the results, which do not depend on who computed them)
    timing = {"prepare": setup_s, "cluster_start": split_total.pop("cluster_start", 0.0), "run": run_s,
              "cluster_close": split_total.pop("cluster_close", 0.0), "write": write_s, "plots": plots_s,
              "points_computed": len(new_rows), "executor": executor, "batch": nb,
              "sustained_points_per_s": len(new_rows) / run_s if run_s > 0 else None, "workers": split_total}
    (out_dir / "timing.json").write_text(json.dumps(timing, indent=2))
    return Outcome(out_dir, results, rows, len(new_rows), skipped, failed, time.perf_counter() - wall0,
                   setup_s, compute_s, write_s, split_total, executor, ev.kind, nb, plot_files, run_s)
