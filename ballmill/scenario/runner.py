"""Co-simulation master on fmpy: instantiate, initialise and step a scenario.

Fixed-step Jacobi scheme: at each communication point t_k every connected
output is read and written to its inputs, then every instance steps to
t_k + H. Instances are initialised in dependency order (sources first), so
the outputs recorded at the start time already see their inputs; feedback
loops are iterated to a fixed point in initialisation mode. Table
sources (CSV) are interpolated with a cubic spline at each point.

Algebraic loops: an output with direct feedthrough (the FMU declares it in
ModelStructure/Outputs and recomputes it when the input is set, without a
step) that reaches its own input through the connections, e.g. the structure's
acceleration -> the ball's force -> the structure's acceleration. The master
finds such loops from the model descriptions (`algebraic_loops`, not by
name) and, with ``[master] algebraic_loops = "iterate"`` (the default),
iterates at every communication point: Gauss-Seidel sweeps over the loop's
instances (set the inputs from the freshest values, read the outputs again)
until the values exchanged through the loop change by at most loop_tol
relative + loop_atol absolute, or stops the run with an error naming the
loop's variables and the residual after loop_max_iter sweeps. "ignore"
leaves the loop to the plain Jacobi exchange (values one step old on one
side).

A step an FMU refuses (fmi2Discard, e.g. a non-finite input or the paper
formulation at the equator) ends the run cleanly: everything recorded up to
the last good point is kept, and the reason is in the result's messages.

The master follows each instance through the FMI 2.0 state machine (section
4.2.4 of the standard) and ends it with the calls its state allows:
fmi2Terminate only once it is initialised (stepComplete, or stepFailed after
a refused step), then fmi2FreeInstance; after fmi2Error (a refused
instantiation, initialisation or call) fmi2FreeInstance alone; after
fmi2Fatal nothing at all for any instance of that FMU (section 2.1.3), whose
library is then not reused.

The stepping loop is lean (fmpy loads the FMUs and owns the instances; the loop
calls their fmi2 functions from fmpy's library handles with ctypes arguments
built once, and checks every status as fmpy does): the values travel through
one array of doubles (the bus) that fmi2GetReal writes into and fmi2SetReal
reads from, a record row is a copy of it into a preallocated array, and the
progress bar is updated every PROGRESS_EVERY steps.
"""
from __future__ import annotations

import ctypes
import math
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from . import fmucache
from . import me as _me
from . import spec as _spec

PROGRESS_EVERY = 50  # steps between updates of the progress bar (which itself shows at most 10 per s)
INIT_PASSES = 5  # at most, for the fixed-point iteration over connections in initialisation mode
STATUS = {0: "ok", 1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}
# the FMI 2.0 states in which fmi2Terminate is allowed (co-simulation; Model Exchange)
INITIALISED = ("stepComplete", "stepFailed", "eventMode", "continuousTimeMode")


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
    loops: list = field(default_factory=list)  # each a list of "a.x -> b.y" connections
    loop_sweeps: int = 0  # Gauss-Seidel sweeps over the loops, all communication points together
    interface: str = "cs"  # "cs": communication steps (steps: their number); "me": one ODE (steps: the integrator's)
    events: int = 0  # Model Exchange: the events handled (time, state and step events)

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
        self.echoed: set[int] = set()  # indices in messages of those echoed on stderr
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
                self.echoed.add(len(self.messages) - 1)
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


def components(graph: dict) -> dict:
    """Strongly connected components of a directed graph {node: set of successors}
    (Tarjan, iterative): node -> the root node naming its component."""
    index, low, on, stack, comp, counter = {}, {}, set(), [], {}, [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            node, it = work[-1]
            for nxt in it:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter[0]
                    counter[0] += 1
                    stack.append(nxt)
                    on.add(nxt)
                    work.append((nxt, iter(sorted(graph[nxt]))))
                    break
                if nxt in on:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp[w] = node
                        if w == node:
                            break
    return comp


def algebraic_loops(sc: _spec.Scenario, models: dict) -> list[list[tuple]]:
    """The scenario's algebraic loops: cycles through connections and direct feedthrough
    (ModelStructure/Outputs dependencies of the FMUs' model descriptions; an output without
    the attribute depends on every input, as FMI 2.0 says). Each loop is the list of its
    connections (src inst, src var, dst inst, dst var), in the scenario's order."""
    graph: dict[tuple, set] = {}

    def edge(a, b):
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())

    for si, sv, di, dv in sc.connections:
        edge((si, sv), (di, dv))
    for name, inst in sc.instances.items():
        md = models.get(inst.fmu) if inst.fmu else None
        if md is None:
            continue
        inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        for unknown in md.outputs:
            deps = unknown.dependencies
            names = inputs if deps is None else [d.name for d in deps]
            for d in names:
                edge((name, d), (name, unknown.variable.name))
    comp = components(graph)
    loops: dict = {}
    for c in sc.connections:
        si, sv, di, dv = c
        a, b = comp.get((si, sv)), comp.get((di, dv))
        if a is not None and a == b:
            loops.setdefault(a, []).append(c)
    return list(loops.values())


def _loop_text(loop) -> str:
    return ", ".join(f"{si}.{sv} -> {di}.{dv}" for si, sv, di, dv in loop)


class AlgebraicLoopError(RuntimeError):
    """The fixed-point iteration of an algebraic loop did not converge."""


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

    def reader(self, names, bus, offset: int):
        """A function writing the values of these columns at the time in ``bus[0]`` into
        ``bus[offset:offset + len(names)]`` (status 0: a table out of range raises)."""
        end = offset + len(names)

        def read():
            bus[offset:end] = self.values(names, bus[0])
            return 0
        return read


def _bare(fmu, name: str):
    """fmpy's loaded fmi2 function ``name`` of this FMU as a plain C function returning the
    status, without fmpy's wrapper or argument conversion: the master passes ready ctypes
    objects of the exact C types (fmi2Component, arrays, size_t, fmi2Real, fmi2Boolean) and
    checks the status itself. About half the cost of a call through fmpy's wrapper."""
    address = ctypes.cast(getattr(fmu.dll, name), ctypes.c_void_p).value
    return ctypes.CFUNCTYPE(ctypes.c_int)(address)


def _slot(bus, i: int):
    """A double* to element i of a ctypes array of doubles (what fmi2GetReal/SetReal take)."""
    return ctypes.cast(ctypes.addressof(bus) + i * ctypes.sizeof(ctypes.c_double),
                       ctypes.POINTER(ctypes.c_double))


class _FmuInstance:
    def __init__(self, inst: _spec.Instance, path: Path, md, logger: _Logger, interface: str = "cs"):
        self.name = inst.name
        self.path = path
        self.md = md
        self.vars = {v.name: v for v in md.modelVariables}
        # the FMU's files and its loaded library are kept between runs (fmucache): a
        # run still instantiates, initialises and frees its own instance
        self.fmu = fmucache.take(path, md, inst.name, interface)
        try:
            self.fmu.instantiate(callbacks=logger.callbacks, loggingOn=True)
        except Exception:
            fmucache.give_back(path, self.fmu, interface)  # nothing instantiated: the library is still good
            raise
        self.state = "instantiated"  # the instance's FMI 2.0 state, as far as the master knows it
        self.parameters = inst.parameters
        self.interface = interface

    def returned(self, function: str, status: int):
        """Follow a call's status above fmi2Warning: fmi2Discard of fmi2DoStep -> stepFailed,
        fmi2Error (or fmi2Pending, which these synchronous FMUs never mean) -> error,
        fmi2Fatal -> fatal; a discarded get or set leaves the state as it was."""
        if status == 4:
            self.state = "fatal"
        elif status in (3, 5) or status > 5:
            self.state = "error"
        elif status == 2 and function == "fmi2DoStep":
            self.state = "stepFailed"

    def call(self, function: str, method, *args, **kwargs):
        """One of fmpy's wrapped calls, its refusal followed (``returned``)."""
        from fmpy.fmi1 import FMICallException
        try:
            return method(*args, **kwargs)
        except FMICallException as e:
            self.returned(function, e.status)
            raise

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

    def readers(self, names, bus, offset: int):
        """FMI calls that write the values of these variables into ``bus[offset:offset + len(names)]``
        (a ctypes array of doubles), as (function, arguments, name, this instance): the master
        calls ``function(*arguments)`` and refuses a status above fmi2Warning exactly as fmpy does.

        ``names`` must list the Reals first (the master orders them so): one fmi2GetReal
        writes them straight into the bus; the Booleans and Integers (recorded, never
        connected) follow with one call each and are converted to float."""
        from fmpy.fmi2 import fmi2Boolean, fmi2Integer, fmi2Real, fmi2ValueReference
        comp = ctypes.c_void_p(self.fmu.component)
        kinds = [self.vars[n].type for n in names]
        n_real = sum(k == "Real" for k in kinds)
        if kinds[:n_real] != ["Real"] * n_real:
            raise ValueError(f"{self.name}: the Reals must come first in {names}")
        ops = []
        if n_real:
            vr = (fmi2ValueReference * n_real)(*[self.vars[n].valueReference for n in names[:n_real]])
            ops.append((_bare(self.fmu, "fmi2GetReal"),
                        (comp, vr, ctypes.c_size_t(n_real), _slot(bus, offset)), "fmi2GetReal", self))
        for kind, ctype in (("Boolean", fmi2Boolean), ("Integer", fmi2Integer)):
            where = [i for i, k in enumerate(kinds) if k == kind]
            if not where:
                continue
            vr = (fmi2ValueReference * len(where))(*[self.vars[names[i]].valueReference for i in where])
            val = (ctype * len(where))()
            fun = _bare(self.fmu, f"fmi2Get{kind}")
            slots = [offset + i for i in where]

            def get(fun=fun, vr=vr, n=ctypes.c_size_t(len(where)), val=val, slots=slots):
                status = fun(comp, vr, n, val)
                if status <= 1:
                    for slot, v in zip(slots, val):
                        bus[slot] = float(v)
                return status
            ops.append((get, (), f"fmi2Get{kind}", self))
        return ops

    def writer(self, vrs, values_ptr):
        """The fmi2SetReal call (function, arguments, name, this instance) that sets these Real
        inputs from the doubles at ``values_ptr``."""
        from fmpy.fmi2 import fmi2ValueReference
        varr = (fmi2ValueReference * len(vrs))(*vrs)
        return (_bare(self.fmu, "fmi2SetReal"),
                (ctypes.c_void_p(self.fmu.component), varr, ctypes.c_size_t(len(vrs)), values_ptr), "fmi2SetReal",
                self)

    def close(self, fatal: bool = False):
        """End the instance with the calls its state allows; ``fatal``: an instance of this FMU
        returned fmi2Fatal, so nothing may be called (the library is dropped, not reused)."""
        if fatal or self.state == "fatal":
            return
        if self.state in INITIALISED:
            try:
                self.fmu.terminate()
            except Exception:
                pass
        try:
            self.fmu.fmi2FreeInstance(self.fmu.component)  # the library stays loaded for the next run
        except Exception:
            return  # a library that failed to free an instance is not reused
        fmucache.give_back(self.path, self.fmu, self.interface)


def _refused(owner, function: str, status: int):
    """The exception for a call refused with ``status`` (> fmi2Warning), the calling instance's
    state followed (``owner``: its _FmuInstance; None for a table)."""
    from fmpy.fmi1 import FMICallException
    if owner is not None:
        owner.returned(function, status)
    return FMICallException(function=function, status=status)


def _stopped(logger: _Logger, e, f, what: str, t: float) -> str:
    """The message of a run that an FMU's refusal ``e`` (of ``what``, at t) ended, with the
    FMU's own last reason."""
    why = [m["message"] for m in logger.messages if m["instance"] == f.name
           and m["status"] in ("discard", "error", "fatal")]
    return (f"{f.name} refused {what} at t = {t:.6g} s ({STATUS.get(getattr(e, 'status', -1), 'error')}): "
            f"{why[-1] if why else e}")


INTERFACES = ("cs", "me")


def run(sc: _spec.Scenario, models: dict, paths: dict, progress: bool = True, echo: bool = True,
        interface: str = "cs") -> RunResult:
    """Run a checked scenario. ``models``/``paths``: model name -> ModelDescription / FMU path.
    ``interface``: "cs" steps the FMUs' co-simulation interface on the communication grid;
    "me" integrates every FMU's continuous states together through Model Exchange
    (`ballmill.scenario.me`), recorded on the same grid."""
    if interface not in INTERFACES:
        raise ValueError(f"interface must be one of {INTERFACES}, got {interface!r}")
    if interface == "me":
        import scipy.integrate  # noqa: F401  (its integrators; an import of seconds, not the run's time)
    wall0 = time.perf_counter()
    master = {**_spec.MASTER_DEFAULTS, **(getattr(sc, "master", None) or {})}
    loops = algebraic_loops(sc, models)
    iterate = bool(loops) and master["algebraic_loops"] == "iterate"
    loop_sweeps = 0
    logger = _Logger(echo)
    logger.now = sc.start  # the time stamped on what the FMUs log before the first communication point
    fmus: dict[str, _FmuInstance] = {}
    tables: dict[str, _TableSource] = {}
    order = _order(sc)
    columns = ["time"] + [f"{a}.{b}" for a, b in sc.record]
    rows, record, columns_at = 0, None, None
    success, message, steps, events = True, "completed", 0, 0
    try:
        for name in order:
            inst = sc.instances[name]
            if inst.fmu is not None:
                fmus[name] = _FmuInstance(inst, paths[inst.fmu], models[inst.fmu], logger, interface)
            else:
                tables[name] = _TableSource(inst)
        # what each instance must deliver at a communication point: connection sources + records,
        # the Reals first (one fmi2GetReal for them)
        wanted = {n: [] for n in sc.instances}
        for si, sv, _, _ in sc.connections:
            if sv not in wanted[si]:
                wanted[si].append(sv)
        for inst, var in sc.record:
            if var not in wanted[inst]:
                wanted[inst].append(var)
        for n in fmus:
            wanted[n].sort(key=lambda v, n=n: fmus[n].vars[v].type != "Real")  # stable
        # the bus: slot 0 the time, then each instance's wanted values; the getters write
        # into it, the setters read from it, a row of the record is a copy of it
        offset, width = {}, 1
        for n in sc.instances:
            offset[n], width = width, width + len(wanted[n])
        bus = (ctypes.c_double * width)()
        bus_np = np.ctypeslib.as_array(bus)
        reads = {n: (fmus[n].readers(wanted[n], bus, offset[n]) if n in fmus else
                     [(tables[n].reader(wanted[n], bus, offset[n]), (), "table", None)]) for n in sc.instances}
        # inputs per destination FMU: value references and the bus slots they take
        setters = {n: ([], []) for n in fmus}
        for si, sv, di, dv in sc.connections:
            setters[di][0].append(fmus[di].vars[dv].valueReference)
            setters[di][1].append(offset[si] + wanted[si].index(sv))
        gathers, writes, gather_of = [], {}, {}
        for n, (vrs, slots) in setters.items():
            if not vrs:
                continue
            if slots == list(range(slots[0], slots[0] + len(slots))):  # contiguous: straight from the bus
                ptr = _slot(bus, slots[0])
            else:
                staged = (ctypes.c_double * len(slots))()
                gathers.append((np.array(slots, dtype=np.intp), np.ctypeslib.as_array(staged)))
                gather_of[n] = gathers[-1]
                ptr = staged
            writes[n] = fmus[n].writer(vrs, ptr)
        # the algebraic loops: Gauss-Seidel sweeps over their destination instances (in the
        # initialisation order), the residual on the values that travel through them
        in_loop = [c for loop in loops for c in loop]
        loop_insts = [n for n in order if any(di == n for _, _, di, _ in in_loop)]
        loop_slots = np.array(sorted({offset[si] + wanted[si].index(sv) for si, sv, _, _ in in_loop}), dtype=np.intp)
        slot_names = {offset[si] + wanted[si].index(sv): f"{si}.{sv}" for si, sv, _, _ in in_loop}
        if loops and not iterate:
            logger.messages.append({"time": sc.start, "instance": "", "status": "warning", "category": "master",
                                    "message": f"algebraic loop(s) not iterated (master.algebraic_loops = "
                                               f"'ignore'): " + "; ".join(_loop_text(lp) for lp in loops)})
        tol, atol, max_iter = float(master["loop_tol"]), float(master["loop_atol"]), int(master["loop_max_iter"])

        def solve_loops(t):
            """Sweep until the loop values settle (sweeps done), or AlgebraicLoopError."""
            previous = bus_np[loop_slots].copy()
            for sweep in range(1, max_iter + 1):
                for n in loop_insts:
                    g = gather_of.get(n)
                    if g is not None:
                        np.take(bus_np, g[0], out=g[1])
                    fun, args, fname, owner = writes[n]
                    status = fun(*args)
                    if status > 1:
                        raise _refused(owner, fname, status)
                    for fun, args, fname, owner in reads[n]:
                        status = fun(*args)
                        if status > 1:
                            raise _refused(owner, fname, status)
                current = bus_np[loop_slots]
                residual = np.abs(current - previous)
                if np.all(residual <= tol * np.abs(current) + atol):
                    return sweep
                previous = current.copy()
            # the slot furthest outside its accepted change (with loop_tol = loop_atol = 0 any
            # change is infinitely far, a settled slot not at all)
            accepted = tol * np.abs(current) + atol
            excess = np.divide(residual, accepted, out=np.where(residual > 0.0, np.inf, 0.0), where=accepted > 0.0)
            worst = int(np.argmax(excess))
            raise AlgebraicLoopError(
                f"algebraic loop {'; '.join(_loop_text(lp) for lp in loops)} did not converge at t = {t:.9g} s "
                f"after loop_max_iter = {max_iter} sweeps: {slot_names[int(loop_slots[worst])]} still changed by "
                f"{residual[worst]:.3g} (accepted: loop_tol = {tol:g} relative + loop_atol = {atol:g}); "
                f"the loop's gain is too large for a fixed-point iteration, or an FMU does not recompute its "
                f"outputs when its inputs are set")
        step_ops = [op for n in sc.instances for op in reads[n]]
        set_ops = list(writes.values())
        columns_at = [0] + [offset[a] + wanted[a].index(b) for a, b in sc.record]

        def check(fun, args, fname, owner):
            status = fun(*args)
            if status > 1:
                raise _refused(owner, fname, status)

        t = sc.start
        for name in order:
            if name not in fmus:
                continue
            f = fmus[name]
            f.call("fmi2SetReal", f.set_parameters)
            f.call("fmi2SetupExperiment", f.fmu.setupExperiment, startTime=sc.start, stopTime=sc.stop)
            f.call("fmi2EnterInitializationMode", f.fmu.enterInitializationMode)
            f.state = "initializationMode"
        # initialisation mode: outputs follow the inputs (see ballmill.fmi.slave), so pass
        # values around until they settle; a loop through the connections converges in a few
        # passes because the fed-back quantities (reaction torque) barely move the sources
        bus[0] = t
        values = {}
        for _ in range(INIT_PASSES):
            previous = {n: list(v) for n, v in values.items()}
            for name in order:
                if name in fmus:
                    vrs, slots = setters[name]
                    src = [si for si, _, di, _ in sc.connections if di == name]
                    ready = [(vr, bus[slot]) for vr, slot, si in zip(vrs, slots, src) if si in values]
                    if ready:  # inputs fed back from a later instance keep their start values on pass 1
                        fmus[name].call("fmi2SetReal", fmus[name].fmu.setReal, [vr for vr, _ in ready],
                                        [v for _, v in ready])
                for op in reads[name]:
                    check(*op)
                values[name] = bus[offset[name]:offset[name] + len(wanted[name])]
            if values == previous:
                break
        for name in order:
            if name in fmus:
                fmus[name].call("fmi2ExitInitializationMode", fmus[name].fmu.exitInitializationMode)
                fmus[name].state = "stepComplete" if interface == "cs" else "eventMode"
        init_time = time.perf_counter() - wall0
        bar = _Progress(sc.stop - sc.start, progress)
        n_steps = int(round((sc.stop - sc.start) / sc.step))
        record = np.empty((n_steps + 1, width))
        row_bytes = record.strides[0]
        record_at, bus_at = record.ctypes.data, ctypes.addressof(bus)
        memmove = ctypes.memmove
        if interface == "me":
            def solve_loops_once():
                for n in loop_insts:
                    g = gather_of.get(n)
                    if g is not None:
                        np.take(bus_np, g[0], out=g[1])
                    check(*writes[n])
                    for op in reads[n]:
                        check(*op)
            sweeps = [0]
            driver = _me.Driver(SimpleNamespace(
                sc=sc, models=models, master=master, fmus=fmus, order=order, bus=bus, bus_np=bus_np,
                offset=offset, wanted=wanted, reads=reads, step_ops=step_ops, iterate=iterate,
                solve_loops=solve_loops, solve_loops_once=solve_loops_once, sweeps=sweeps, logger=logger,
                refused=_refused, stopped=_stopped, record_at=record_at, row_bytes=row_bytes))
            rows, success, message = driver.run(bar, PROGRESS_EVERY)
            steps, events, loop_sweeps = driver.steps, driver.events, loop_sweeps + sweeps[0]
        else:
            now, size = ctypes.c_double(), ctypes.c_double()  # the doStep arguments, set at each step
            no_set_prior = ctypes.c_int(1)  # noSetFMUStatePriorToCurrentPoint = fmi2True, as fmpy's doStep
            steppers = [(f, _bare(f.fmu, "fmi2DoStep"), (ctypes.c_void_p(f.fmu.component), now, size, no_set_prior))
                        for f in fmus.values()]
            every = PROGRESS_EVERY
            reached = sc.start  # where the last step took the FMUs
            for k in range(n_steps + 1):
                # the grid start + k H; the last point is where the last step ended (stop, when
                # stop - start is not a whole number of steps and that step was shortened)
                t = sc.start + k * sc.step if k < n_steps else reached
                logger.now = t
                bus[0] = t
                for fun, args, fname, owner in step_ops:
                    status = fun(*args)
                    if status > 1:
                        raise _refused(owner, fname, status)
                if iterate:
                    loop_sweeps += solve_loops(t)
                memmove(record_at + k * row_bytes, bus_at, row_bytes)
                rows = k + 1
                if k == n_steps:
                    break
                for slots, staged in gathers:
                    np.take(bus_np, slots, out=staged)
                for fun, args, fname, owner in set_ops:
                    status = fun(*args)
                    if status > 1:
                        raise _refused(owner, fname, status)
                h = min(sc.step, sc.stop - t) if k == n_steps - 1 else sc.step
                now.value, size.value = t, h
                for f, do_step, args in steppers:
                    status = do_step(*args)
                    if status > 1:
                        success = False
                        message = _stopped(logger, _refused(f, "fmi2DoStep", status), f, "the step", t)
                        break
                if not success:
                    break
                steps += 1
                reached = t + h
                if steps % every == 0 or k == n_steps - 1:
                    bar.update(t + h - sc.start, t + h)
    except Exception as e:
        success, message = False, f"{type(e).__name__}: {e}"
        shown = message
        # the FMU's own reason (an initialisation or an instance refused, an input not settable): the
        # first error of the run, which ended it (pythonfmu adds a generic fmi2Fatal line after it)
        why = next((i for i, m in enumerate(logger.messages) if m["status"] in ("error", "fatal")), None)
        if why is not None:
            message += f" {logger.messages[why]['message']}"
            # on stderr once: where the logger echoed it, the failure points there
            shown = f"{shown.rstrip('.')}; the FMU's reason is above" if why in logger.echoed else message
        init_time = locals().get("init_time", time.perf_counter() - wall0)
        if echo:
            sys.stderr.write(f"\nrun failed: {shown}\n")
    finally:
        fatal = {f.path for f in fmus.values() if f.state == "fatal"}
        for f in fmus.values():
            f.close(fatal=f.path in fatal)
    data = record[:rows, columns_at] if rows else np.empty((0, len(columns)))
    return RunResult(sc, columns, data, success, message, logger.messages,
                     time.perf_counter() - wall0, init_time, steps,
                     [[f"{si}.{sv} -> {di}.{dv}" for si, sv, di, dv in lp] for lp in loops], loop_sweeps,
                     interface, events)


def without(sc: _spec.Scenario, instance: str, record: list | None = None) -> _spec.Scenario:
    """The scenario with one instance and every connection touching it removed (the bare
    structure of an absorber scenario: the ball's force cut); ``record``: what to record
    instead (default: the recorded variables of the instances that remain)."""
    import dataclasses

    if instance not in sc.instances:
        raise KeyError(f"{sc.name}: no instance {instance!r} to remove")
    keep = {n: i for n, i in sc.instances.items() if n != instance}
    conns = [c for c in sc.connections if instance not in (c[0], c[2])]
    rec = record if record is not None else [r for r in sc.record if r[0] != instance]
    return dataclasses.replace(sc, instances=keep, connections=conns, record=rec, plots=[])


class _Descriptions(Mapping):
    """model name -> its parsed model description, parsed on first use (a scenario reads
    only the FMUs it instantiates) and kept per process by fmucache."""

    def __init__(self, paths: dict):
        self._paths = dict(paths)

    def __getitem__(self, name):
        return fmucache.model_description(self._paths[name])

    def __iter__(self):
        return iter(self._paths)

    def __len__(self):
        return len(self._paths)


def _models_used(name_or_path: str) -> list[str]:
    """The models a scenario file instantiates (its instances' ``fmu``), the ones a run must
    have built; none when the file cannot be read (the scenario's check then says why)."""
    import tomllib

    try:
        doc = tomllib.loads(_spec.resolve(name_or_path).read_text())
        return sorted({str(i["fmu"]) for i in doc.get("instances", {}).values() if isinstance(i, dict) and "fmu" in i})
    except Exception:  # noqa: BLE001  (reported by spec.load, with where and why)
        return []


def prepare(name_or_path: str, overrides=(), build_dir: Path | None = None, log=print,
            flavour: str = "native", interface: str = "cs", **check):
    """Build the FMUs the scenario uses if needed (only the flavour asked), read their model
    descriptions, load and check the scenario.
    flavour: "native" (C, build/<Model>.fmu) or "pythonfmu" (build/pythonfmu/<Model>.fmu);
    interface: "cs" or "me" (`run`): for "me", an FMU without a ModelExchange interface is a
    problem of the scenario (ScenarioError, naming the instance, its file and why);
    ``check``: `spec.load`'s origins and points (a sweep's)."""
    from ..fmi import build as _build
    fmus = _build.build_all(build_dir, log=log, flavour=flavour, only=True, names=_models_used(name_or_path))
    paths = {p.stem: p for p in fmus}
    for name in _build.model_names():  # and the others, not built for this run: the check names them
        paths.setdefault(name, _build.fmu_path(name, build_dir, flavour))
    sc, models = load_built(name_or_path, overrides, paths, **check)
    if interface == "me":
        problems = _me.problems(sc, models, paths)
        if problems:
            raise _spec.ScenarioError(problems)
    elif interface not in INTERFACES:
        raise _spec.ScenarioError([f"--interface {interface!r}: expected one of {INTERFACES}"])
    return sc, models, paths


def load_built(name_or_path: str, overrides, paths: dict, **check):
    """(scenario, model descriptions) of a scenario whose FMUs `prepare` has built and checked
    (``paths``: its model name -> FMU): the scenario and its overrides loaded and checked, no
    build check (what a study's points repeat, prepare being once per study)."""
    models = _Descriptions(paths)
    return _spec.load(name_or_path, overrides, models, **check), models
