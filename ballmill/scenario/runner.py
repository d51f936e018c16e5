"""Co-simulation master on fmpy: instantiate, initialise and step a scenario.

Fixed-step Jacobi scheme: at each communication point t_k every connected
output is read and written to its inputs, then every instance steps to
t_k + H. Instances are initialised in dependency order (sources first), so
the outputs recorded at the start time already see their inputs; feedback
loops are iterated to a fixed point in initialisation mode. Table
sources (CSV) are interpolated with a cubic spline at each point.

A step an FMU refuses (fmi2Discard, e.g. a non-finite input or the paper
formulation at the equator) ends the run cleanly: everything recorded up to
the last good point is kept, and the reason is in the result's messages.
"""
from __future__ import annotations

import ctypes
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import spec as _spec

INIT_PASSES = 5  # at most, for the fixed-point iteration over connections in initialisation mode
STATUS = {0: "ok", 1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}


@dataclass
class RunResult:
    scenario: _spec.Scenario
    columns: list[str]
    data: np.ndarray  # rows: time, recorded variables
    success: bool
    message: str
    messages: list[dict] = field(default_factory=list)
    wall_time: float = 0.0
    init_time: float = 0.0
    steps: int = 0

    def column(self, name: str) -> np.ndarray:
        return self.data[:, self.columns.index(name)]


class _Logger:
    """FMI logger callbacks that collect messages (and echo the first warnings and errors)."""

    ECHO_LIMIT = 5

    def __init__(self, echo: bool):
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        from fmpy.fmi2 import calloc, free
        self.messages: list[dict] = []
        self.echo = echo
        self.now = 0.0
        self._shown: dict[str, int] = {}
        self.callbacks = fmi2CallbackFunctions()
        self._log = fmi2CallbackLoggerTYPE(self._on_message)
        self.callbacks.logger = self._log
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        try:
            from fmpy.logging import addLoggerProxy
            addLoggerProxy(ctypes.byref(self.callbacks))
        except Exception:  # pragma: no cover - the proxy only formats varargs
            pass

    def _on_message(self, env, instance, status, category, message):
        text = message.decode("utf-8", "replace") if message else ""
        entry = {"time": self.now, "instance": instance.decode() if instance else "",
                 "status": STATUS.get(status, str(status)),
                 "category": category.decode() if category else "", "message": text}
        self.messages.append(entry)
        if self.echo and status >= 1:
            shown = self._shown.get(entry["instance"], 0)
            self._shown[entry["instance"]] = shown + 1
            if shown < self.ECHO_LIMIT:
                sys.stderr.write(f"\n[{entry['status']}] {text}\n")
            elif shown == self.ECHO_LIMIT:
                sys.stderr.write(f"\n[{entry['status']}] {entry['instance']}: further messages are "
                                 f"in summary.json\n")


class _Progress:
    """A one-line progress bar on stderr (coarser when stderr is not a terminal)."""

    def __init__(self, total: float, enabled: bool):
        self.total, self.enabled = total, enabled
        self.tty = sys.stderr.isatty()
        self.last = -1.0
        self.t0 = time.perf_counter()

    def update(self, done: float, now: float):
        if not self.enabled:
            return
        frac = min(1.0, done / self.total) if self.total > 0 else 1.0
        wall = time.perf_counter() - self.t0
        if self.tty:
            if wall - self.last < 0.1 and frac < 1.0:
                return
            bar = "#" * int(30 * frac)
            sys.stderr.write(f"\r  [{bar:<30}] {100 * frac:5.1f}%  t = {now:.3f} s  ({wall:.1f} s wall)")
            if frac >= 1.0:
                sys.stderr.write("\n")
        else:
            tenth = math.floor(frac * 10)
            if tenth > self.last:
                self.last = tenth
                sys.stderr.write(f"  {100 * frac:5.1f}%  t = {now:.3f} s  ({wall:.1f} s wall)\n")
        if self.tty:
            self.last = wall


def _order(sc: _spec.Scenario) -> list[str]:
    """Instances with sources first (topological where the graph allows)."""
    names = list(sc.instances)
    deps = {n: {si for si, _, di, _ in sc.connections if di == n and si != n} for n in names}
    ordered, placed = [], set()
    while len(ordered) < len(names):
        ready = [n for n in names if n not in placed and deps[n] <= placed]
        pick = ready[0] if ready else next(n for n in names if n not in placed)  # a loop: break it
        ordered.append(pick)
        placed.add(pick)
    return ordered


class _TableSource:
    def __init__(self, inst: _spec.Instance):
        from scipy.interpolate import CubicSpline
        self.columns = inst.columns
        data = inst.data
        self.t_first, self.t_last = data[0, 0], data[-1, 0]
        self.spline = CubicSpline(data[:, 0], data[:, 1:], axis=0)

    def values(self, names, t):
        if t < self.t_first - 1e-12 or t > self.t_last + 1e-12:
            raise ValueError(f"the table covers t = {self.t_first:g} .. {self.t_last:g} s, "
                             f"asked for t = {t:g} s")
        row = self.spline(t)
        return [float(row[self.columns.index(n)]) for n in names]


class _FmuInstance:
    def __init__(self, inst: _spec.Instance, path: Path, md, logger: _Logger):
        from fmpy import extract
        from fmpy.fmi2 import FMU2Slave
        self.name = inst.name
        self.md = md
        self.vars = {v.name: v for v in md.modelVariables}
        self.unzipdir = extract(str(path))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self.unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=inst.name)
        self.fmu.instantiate(callbacks=logger.callbacks, loggingOn=True)
        self.parameters = inst.parameters

    def set_parameters(self):
        for name, value in self.parameters.items():
            v = self.vars[name]
            if v.type == "Real":
                self.fmu.setReal([v.valueReference], [float(value)])
            elif v.type == "Integer":
                self.fmu.setInteger([v.valueReference], [int(value)])
            elif v.type == "Boolean":
                self.fmu.setBoolean([v.valueReference], [bool(value)])
            else:
                self.fmu.setString([v.valueReference], [str(value)])

    def getter(self, names):
        """A function returning the values of these variables (Reals and Booleans).

        The value-reference and value arrays are built once and the FMI functions called
        with them directly (fmpy's getReal builds both anew at every call)."""
        from fmpy.fmi2 import fmi2Boolean, fmi2Integer, fmi2Real, fmi2ValueReference
        fmu = self.fmu
        reals = [(i, self.vars[n].valueReference) for i, n in enumerate(names) if self.vars[n].type == "Real"]
        others = [(i, self.vars[n].valueReference, self.vars[n].type) for i, n in enumerate(names)
                  if self.vars[n].type != "Real"]
        n_total, n_real = len(names), len(reals)
        rvr = (fmi2ValueReference * n_real)(*[vr for _, vr in reals])
        rval = (fmi2Real * n_real)()
        get_real = fmu.fmi2GetReal
        plain = not others and [i for i, _ in reals] == list(range(n_total))
        if plain:
            def get():
                get_real(fmu.component, rvr, n_real, rval)
                return rval[:]
            return get
        bvr = [(i, fmi2ValueReference(vr), kind) for i, vr, kind in others]
        bval, ival = fmi2Boolean(), fmi2Integer()

        def get():
            out = [0.0] * n_total
            if n_real:
                get_real(fmu.component, rvr, n_real, rval)
                for (i, _), v in zip(reals, rval):
                    out[i] = v
            for i, vr, kind in bvr:
                if kind == "Boolean":
                    fmu.fmi2GetBoolean(fmu.component, ctypes.byref(vr), 1, ctypes.byref(bval))
                    out[i] = float(bval.value)
                else:
                    fmu.fmi2GetInteger(fmu.component, ctypes.byref(vr), 1, ctypes.byref(ival))
                    out[i] = float(ival.value)
            return out
        return get

    def setter(self, vrs):
        """A function setting these Real variables to a list of values (arrays built once)."""
        from fmpy.fmi2 import fmi2Real, fmi2ValueReference
        fmu = self.fmu
        n = len(vrs)
        varr = (fmi2ValueReference * n)(*vrs)
        kind = fmi2Real * n
        set_real = fmu.fmi2SetReal

        def put(values):
            set_real(fmu.component, varr, n, kind(*values))
        return put

    def close(self):
        import shutil
        try:
            self.fmu.terminate()
        except Exception:
            pass
        try:
            self.fmu.freeInstance()
        except Exception:
            pass
        shutil.rmtree(self.unzipdir, ignore_errors=True)


def run(sc: _spec.Scenario, models: dict, paths: dict, progress: bool = True, echo: bool = True) -> RunResult:
    """Run a checked scenario. ``models``/``paths``: model name -> ModelDescription / FMU path."""
    from fmpy.fmi1 import FMICallException

    wall0 = time.perf_counter()
    logger = _Logger(echo)
    fmus: dict[str, _FmuInstance] = {}
    tables: dict[str, _TableSource] = {}
    order = _order(sc)
    columns = ["time"] + [f"{a}.{b}" for a, b in sc.record]
    rows: list[list[float]] = []
    success, message, steps = True, "completed", 0
    try:
        for name in order:
            inst = sc.instances[name]
            if inst.fmu is not None:
                fmus[name] = _FmuInstance(inst, paths[inst.fmu], models[inst.fmu], logger)
            else:
                tables[name] = _TableSource(inst)
        # what each instance must deliver at a communication point: connection sources + records
        wanted = {n: [] for n in sc.instances}
        for si, sv, _, _ in sc.connections:
            if sv not in wanted[si]:
                wanted[si].append(sv)
        for inst, var in sc.record:
            if var not in wanted[inst]:
                wanted[inst].append(var)
        getters = {n: fmus[n].getter(wanted[n]) for n in fmus}
        # inputs per destination FMU: (positions in the source's wanted list)
        setters = {n: ([], []) for n in fmus}
        for si, sv, di, dv in sc.connections:
            setters[di][0].append(fmus[di].vars[dv].valueReference)
            setters[di][1].append((si, wanted[si].index(sv)))
        record_index = [(a, wanted[a].index(b)) for a, b in sc.record]

        puts = [(fmus[n].setter(vrs), srcs) for n, (vrs, srcs) in setters.items() if vrs]
        sources = [(n, getters[n], None) if n in fmus else (n, None, tables[n]) for n in sc.instances]

        def collect(t):
            return {n: (get() if get is not None else table.values(wanted[n], t)) for n, get, table in sources}

        def push(values):
            for put, srcs in puts:
                put([values[s][k] for s, k in srcs])

        t = sc.start
        for name in order:
            if name not in fmus:
                continue
            f = fmus[name]
            f.set_parameters()
            f.fmu.setupExperiment(startTime=sc.start, stopTime=sc.stop)
            f.fmu.enterInitializationMode()
        # initialisation mode: outputs follow the inputs (see ballmill.fmi.slave), so pass
        # values around until they settle; a loop through the connections converges in a few
        # passes because the fed-back quantities (reaction torque) barely move the sources
        values = {}
        for _ in range(INIT_PASSES):
            previous = {n: list(v) for n, v in values.items()}
            for name in order:
                if name in tables:
                    values[name] = tables[name].values(wanted[name], t)
                    continue
                vrs, srcs = setters[name]
                ready = [(vr, values[s][k]) for vr, (s, k) in zip(vrs, srcs) if s in values]
                if ready:  # inputs fed back from a later instance keep their start values on pass 1
                    fmus[name].fmu.setReal([vr for vr, _ in ready], [v for _, v in ready])
                values[name] = getters[name]()
            if values == previous:
                break
        for name in order:
            if name in fmus:
                fmus[name].fmu.exitInitializationMode()
        init_time = time.perf_counter() - wall0
        bar = _Progress(sc.stop - sc.start, progress)
        n_steps = int(round((sc.stop - sc.start) / sc.step))
        for k in range(n_steps + 1):
            t = sc.start + k * sc.step
            logger.now = t
            values = collect(t)
            rows.append([t] + [values[a][i] for a, i in record_index])
            if k == n_steps:
                break
            push(values)
            h = min(sc.step, sc.stop - t) if k == n_steps - 1 else sc.step
            for name, f in fmus.items():
                try:
                    f.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                except FMICallException as e:
                    why = [m["message"] for m in logger.messages if m["instance"] == name
                           and m["status"] in ("discard", "error", "fatal")]
                    success = False
                    message = (f"{name} refused the step at t = {t:.6g} s "
                               f"({STATUS.get(getattr(e, 'status', -1), 'error')}): "
                               f"{why[-1] if why else e}")
                    break
            if not success:
                break
            steps += 1
            bar.update(t + h - sc.start, t + h)
    except Exception as e:
        success, message = False, f"{type(e).__name__}: {e}"
        init_time = locals().get("init_time", time.perf_counter() - wall0)
        if echo:
            sys.stderr.write(f"\nrun failed: {message}\n")
    finally:
        for f in fmus.values():
            f.close()
    data = np.array(rows, dtype=float) if rows else np.empty((0, len(columns)))
    return RunResult(sc, columns, data, success, message, logger.messages,
                     time.perf_counter() - wall0, init_time, steps)


def prepare(name_or_path: str, overrides=(), build_dir: Path | None = None, log=print,
            flavour: str = "native"):
    """Build the FMUs if needed, read their model descriptions, load and check the scenario.
    flavour: "native" (C, build/<Model>.fmu) or "pythonfmu" (build/pythonfmu/<Model>.fmu)."""
    from fmpy import read_model_description

    from ..fmi import build as _build
    fmus = _build.build_all(build_dir, log=log, flavour=flavour)
    paths = {p.stem: p for p in fmus}
    models = {name: read_model_description(str(p)) for name, p in paths.items()}
    sc = _spec.load(name_or_path, overrides, models)
    return sc, models, paths
