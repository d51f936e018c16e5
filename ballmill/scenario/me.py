"""Model Exchange driver of the scenario master: every FMU's continuous states in one ODE.

`runner.run(..., interface="me")` loads the FMUs through their FMI 2.0 ModelExchange
interface and shares everything else with the co-simulation loop (instances, the bus of
values, the initialisation, the algebraic-loop iteration, the record, the shutdown). This
module is what replaces the communication steps: one integrator over the concatenated
states x = (x_FMU1, x_FMU2, ...), and at every derivative evaluation f(t, x)

1. fmi2SetTime(t) and fmi2SetContinuousStates(x_i) on every FMU;
2. the connections resolved in dependency order (`schedule`): each connected output is
   read after the inputs it depends on (the FMUs' ModelStructure) were set, so an input
   always sees its source's value at (t, x), with no communication step and so no coupling
   error; an algebraic loop (a cycle through direct feedthrough) is iterated exactly as in
   co-simulation (``[master] algebraic_loops``);
3. fmi2GetDerivatives of every FMU.

The integrator is one of scipy's (``[master] solver``, default DOP853, an explicit
Runge-Kutta method of order 8 with a 7th-order dense output) at ``[master] rtol`` and
``atol`` (an absolute tolerance per state: atol times the state's nominal value from
fmi2GetNominalsOfContinuousStates). Events, as FMI 2.0 section 3.2.3 describes the
master's part:

* time events: each FMU's nextEventTime from fmi2NewDiscreteStates ends an integration
  interval there;
* state events: after every accepted step the event indicators (fmi2GetEventIndicators,
  all FMUs) are compared with those at the step's start; a change of domain (z > 0 against
  z <= 0) is located by bisection on the step's dense output to ``EVENT_TOL`` in time,
  and the event handled at the right end of the bracket, where the indicator has changed;
* step events: fmi2CompletedIntegratorStep's enterEventMode;
* at an event every FMU enters event mode and fmi2NewDiscreteStates is called on every
  one until none needs another (event iteration), the connections resolved before each
  round, so that an FMU's discrete change reaches the inputs of the others; then
  fmi2EnterContinuousTimeMode, the states read again where valuesOfContinuousStatesChanged,
  and the integrator restarted from there.

The outputs are recorded on the co-simulation's grid (start + k step), from the dense
output of the step that covers each point (states set, connections resolved, every
recorded variable read), so that results, plots and summary are those of a co-simulation
run. A call refused with fmi2Discard or worse ends the run cleanly, everything recorded up
to then kept, as a refused step does in co-simulation; so does a work bound (MeError), which
names the time, the instance and what repeated instead of letting the run hang: rounds of
fmi2NewDiscreteStates at one instant, events at one time (a chattering model) or between two
output points (Zeno behaviour), and integrator steps between two output points (an input read
before its source was set, a stiff or wrong model: the message names the fastest state).
"""
from __future__ import annotations

import ctypes
import math

import numpy as np

EVENT_TOL = 1e-12  # [s] width of the bracket to which a state event's time is located (relative to max(1, |t|))
MAX_EVENT_ITERATIONS = 100  # rounds of fmi2NewDiscreteStates at one event instant
MAX_EVENTS_AT_ONE_TIME = 1000  # successive events without time advancing: a chattering model
# work bounds between two points of the output grid (the co-simulation's step apart): a run that
# exceeds one stops with MeError naming the time, the instance and what repeated, instead of
# hanging (an input read before its source was set, an event loop, a stiff or wrong model)
MAX_STEPS_PER_INTERVAL = 100_000  # integrator steps (the fast start takes about 10 per interval)
MAX_EVENTS_PER_INTERVAL = 10_000  # events (times advancing by a little each time: Zeno behaviour)


class MeError(RuntimeError):
    """The Model Exchange run cannot go on (the message says where and why)."""


def problems(sc, models, paths) -> list[str]:
    """Why this scenario cannot run through Model Exchange: each FMU instance whose FMU has
    no ModelExchange interface, named with its file and what to do (empty: it can)."""
    out = []
    for name, inst in sc.instances.items():
        if inst.fmu is None:
            continue
        md = models[inst.fmu]
        if md.modelExchange is not None:
            continue
        path = paths.get(inst.fmu)
        pythonfmu = "pythonfmu" in str(path) or md.generationTool and "pythonfmu" in md.generationTool.lower()
        why = ("a pythonfmu FMU: pythonfmu exports FMI 2.0 co-simulation only; use the native flavour "
               "(--flavour native)" if pythonfmu else
               "its modelDescription.xml declares CoSimulation only; rebuild it with a ModelExchange interface "
               "(ballmill build) or run the scenario with --interface cs")
        out.append(f"instances.{name}: --interface me needs FMI 2.0 ModelExchange, but {path} "
                   f"(model {inst.fmu}) has no ModelExchange interface: {why}")
    return out


# --------------------------------------------------------------------------- the evaluation order
def schedule(sc, models, order) -> list[tuple]:
    """The order in which one evaluation at (t, x) reads the connected outputs and sets the
    connected inputs: a list of ("get", instance, [outputs]), ("set", instance, [inputs]) and
    ("loops",) (every algebraic loop, iterated by the master's loop solver), each output read
    only after every input it depends on (ModelStructure/Outputs; none declared: all inputs)
    was set from its source. Consecutive operations on one instance are merged."""
    graph: dict = {}

    def edge(a, b):
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())

    for si, sv, di, dv in sc.connections:
        edge(("get", si, sv), ("set", di, dv))
    for name, inst in sc.instances.items():
        if inst.fmu is None:
            continue
        md = models[inst.fmu]
        inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        declared = {u.variable.name: u.dependencies for u in md.outputs}
        for node in [n for n in graph if n[0] == "get" and n[1] == name]:
            deps = declared.get(node[2])
            for d in (inputs if deps is None else [d.name for d in deps]):
                if ("set", name, d) in graph:
                    edge(("set", name, d), node)
    from .runner import components
    comp = components(graph)
    members: dict = {}
    for node, root in comp.items():
        members.setdefault(root, []).append(node)
    succ = {root: set() for root in members}
    for a, bs in graph.items():
        for b in bs:
            if comp[a] != comp[b]:
                succ[comp[a]].add(comp[b])
    indeg = {root: 0 for root in members}
    for root in members:
        for b in succ[root]:
            indeg[b] += 1
    rank = {n: i for i, n in enumerate(order)}

    def key(root):
        kind, inst, var = root if len(members[root]) == 1 else ("loops", "", "")
        return (rank.get(inst, -1), kind != "get", var)

    ops: list[tuple] = []
    ready = sorted((r for r in members if indeg[r] == 0), key=key)
    while ready:
        last = ops[-1] if ops else None
        # prefer what merges with the last operation, then the instance order
        pick = next((r for r in ready if last and len(members[r]) == 1 and last[:2] == r[:2]), ready[0])
        ready.remove(pick)
        if len(members[pick]) > 1:
            if not (last and last[0] == "loops"):
                ops.append(("loops",))
        elif last and last[:2] == pick[:2]:
            last[2].append(pick[2])
        else:
            ops.append((pick[0], pick[1], [pick[2]]))
        for b in succ[pick]:
            indeg[b] -= 1
            if indeg[b] == 0:
                ready.append(b)
        ready.sort(key=key)
    return ops


# --------------------------------------------------------------------------- the driver
class Driver:
    """The Model Exchange integration of one run; ``ctx`` carries what the master set up
    (see `runner.run`)."""

    def __init__(self, ctx):
        from fmpy.fmi2 import fmi2EventInfo, fmi2ValueReference

        self.ctx = c = ctx
        sc, bus = c.sc, c.bus
        master = c.master
        self.solver_name = str(master["solver"])
        self.rtol, self.atol = float(master["rtol"]), float(master["atol"])
        self.names = [n for n in c.order if n in c.fmus]
        self.fmus = [c.fmus[n] for n in self.names]
        self.nx = [len(f.md.derivatives) for f in self.fmus]
        self.nz = [int(f.md.numberOfEventIndicators or 0) for f in self.fmus]
        NX, NZ = sum(self.nx), sum(self.nz)
        self.x = (ctypes.c_double * max(NX, 1))()
        self.dx = (ctypes.c_double * max(NX, 1))()
        self.z = (ctypes.c_double * max(NZ, 1))()
        self.x_np = np.ctypeslib.as_array(self.x)[:NX]
        self.dx_np = np.ctypeslib.as_array(self.dx)[:NX]
        self.z_np = np.ctypeslib.as_array(self.z)[:NZ]
        self.NX, self.NZ = NX, NZ
        self.time = ctypes.c_double()
        self.event_info = fmi2EventInfo()
        dbl = ctypes.sizeof(ctypes.c_double)
        self.per_fmu = []  # (fmu, comp, nx, x pointer, dx pointer, nz, z pointer, bound functions)
        ox = oz = 0
        for f, nx, nz in zip(self.fmus, self.nx, self.nz):
            fn = {name: _bare(f.fmu, name) for name in (
                "fmi2SetTime", "fmi2SetContinuousStates", "fmi2GetDerivatives", "fmi2GetEventIndicators",
                "fmi2GetContinuousStates", "fmi2GetNominalsOfContinuousStates", "fmi2CompletedIntegratorStep",
                "fmi2EnterEventMode", "fmi2NewDiscreteStates", "fmi2EnterContinuousTimeMode")}
            px = ctypes.cast(ctypes.addressof(self.x) + ox * dbl, ctypes.POINTER(ctypes.c_double))
            pdx = ctypes.cast(ctypes.addressof(self.dx) + ox * dbl, ctypes.POINTER(ctypes.c_double))
            pz = ctypes.cast(ctypes.addressof(self.z) + oz * dbl, ctypes.POINTER(ctypes.c_double))
            self.per_fmu.append((f, ctypes.c_void_p(f.fmu.component), ctypes.c_size_t(nx), px, pdx,
                                 ctypes.c_size_t(nz), pz, fn))
            ox, oz = ox + nx, oz + nz
        self.ops = self._operations(fmi2ValueReference)
        # what every evaluation calls: the time and states on each FMU; then its derivatives
        self.point_calls, self.derivative_calls = [], []
        for f, comp, nx, px, pdx, _, _, fn in self.per_fmu:
            self.point_calls.append((fn["fmi2SetTime"], (comp, self.time), f, "fmi2SetTime"))
            if nx.value:
                self.point_calls.append((fn["fmi2SetContinuousStates"], (comp, px, nx), f, "fmi2SetContinuousStates"))
                self.derivative_calls.append((fn["fmi2GetDerivatives"], (comp, pdx, nx), f, "fmi2GetDerivatives"))
        self.evaluations = 0
        self.at = math.nan  # the time last set on the FMUs
        self.events = 0
        self.steps = 0
        self.t_next_event = math.inf
        self.next_event_owner = ""  # which FMU announced t_next_event

    # -- naming what happened, for the work bounds' messages ---------------------------
    def _who(self, i: int) -> str:
        return f"instance {self.names[i]} (model {self.fmus[i].md.modelName})"

    def _indicator(self, j: int) -> str:
        """the global event indicator j as "<instance> (model M)'s event indicator k of n" """
        for i, nz in enumerate(self.nz):
            if j < nz:
                return f"{self._who(i)}'s event indicator {j} of {nz}"
            j -= nz
        return f"event indicator {j}"

    def _fastest_state(self, t, y) -> str:
        """the state whose derivative at (t, y) is largest against its nominal value"""
        rate = np.abs(self.rhs(t, y)) / self.nominal
        j = k = int(np.argmax(rate))
        for i, nx in enumerate(self.nx):
            if j < nx:
                name = self.fmus[i].md.derivatives[j].variable.derivative.name
                return f"{self._who(i)}'s state {name}: |der({name})| / nominal = {rate[k]:.3g} 1/s"
            j -= nx
        return "no state"

    # -- the building blocks ------------------------------------------------
    def _call(self, f, fname, fun, *args):
        status = fun(*args)
        if status > 1:
            self._fail(f, fname, status)

    def _operations(self, fmi2ValueReference):
        """The evaluation order (`schedule`) as calls on the bus: (function, arguments, FMU,
        function name, before, after), ``before``/``after`` None or a copy between the bus and
        the call's own array where the bus slots are not contiguous; a status above
        fmi2Warning ends the run."""
        c = self.ctx
        ops = []
        src = {(di, dv): c.offset[si] + c.wanted[si].index(sv) for si, sv, di, dv in c.sc.connections}
        for op in schedule(c.sc, c.models, c.order):
            if op[0] == "loops":
                ops.append((self._loops, (), None, "", None, None))
                continue
            kind, inst, names = op
            if inst not in c.fmus:  # a table: its reader fills every value it delivers
                ops.append((c.reads[inst][0][0], (), None, "", None, None))
                continue
            f = c.fmus[inst]
            slots = ([c.offset[inst] + c.wanted[inst].index(v) for v in names] if kind == "get"
                     else [src[(inst, v)] for v in names])
            slots, names = map(list, zip(*sorted(zip(slots, names))))  # bus order: contiguous where it can be
            vrs = (fmi2ValueReference * len(names))(*[f.vars[v].valueReference for v in names])
            fname = "fmi2GetReal" if kind == "get" else "fmi2SetReal"
            head = (ctypes.c_void_p(f.fmu.component), vrs, ctypes.c_size_t(len(names)))
            if slots == list(range(slots[0], slots[0] + len(slots))):  # straight from/into the bus
                ops.append((_bare(f.fmu, fname), head + (_slot(c.bus, slots[0]),), f, fname, None, None))
                continue
            staged = (ctypes.c_double * len(names))()
            pairs = list(enumerate(slots))
            bus = c.bus
            if kind == "get":
                def scatter(staged=staged, pairs=pairs):
                    for j, i in pairs:
                        bus[i] = staged[j]
                ops.append((_bare(f.fmu, fname), head + (staged,), f, fname, None, scatter))
            else:
                def gather(staged=staged, pairs=pairs):
                    for j, i in pairs:
                        staged[j] = bus[i]
                ops.append((_bare(f.fmu, fname), head + (staged,), f, fname, gather, None))
        return ops

    def _loops(self):
        c = self.ctx
        if c.iterate:
            c.sweeps[0] += c.solve_loops(c.bus[0])
        else:  # "ignore": one pass over the loop's instances, values one evaluation old on one side
            c.solve_loops_once()
        return 0

    def _fail(self, f, fname, status):
        e = self.ctx.refused(f, fname, status)
        e.owner = f
        raise e

    def connect(self) -> None:
        """The connections resolved at the time and states last set."""
        for fun, args, f, fname, before, after in self.ops:
            if before is not None:
                before()
            status = fun(*args)
            if status > 1:
                self._fail(f, fname, status)
            if after is not None:
                after()

    def set_point(self, t: float, y) -> None:
        """Time and states on every FMU, then the connections resolved at (t, y)."""
        self.at = t
        self.time.value = t
        self.ctx.bus[0] = t
        if self.NX:
            self.x_np[:] = y
        for fun, args, f, fname in self.point_calls:
            status = fun(*args)
            if status > 1:
                self._fail(f, fname, status)
        self.connect()
        self.evaluations += 1

    def rhs(self, t, y):
        self.set_point(t, y)
        for fun, args, f, fname in self.derivative_calls:
            status = fun(*args)
            if status > 1:
                self._fail(f, fname, status)
        return self.dx_np.copy()

    def indicators(self) -> np.ndarray:
        for f, comp, _, _, _, nz, pz, fn in self.per_fmu:
            if nz.value:
                self._call(f, "fmi2GetEventIndicators", fn["fmi2GetEventIndicators"], comp, pz, nz)
        return self.z_np.copy()

    def indicators_at(self, t, y) -> np.ndarray:
        self.set_point(t, y)
        return self.indicators()

    def states(self) -> np.ndarray:
        for f, comp, nx, px, _, _, _, fn in self.per_fmu:
            if nx.value:
                self._call(f, "fmi2GetContinuousStates", fn["fmi2GetContinuousStates"], comp, px, nx)
        return self.x_np.copy()

    def nominals(self) -> np.ndarray:
        for f, comp, nx, px, _, _, _, fn in self.per_fmu:
            if nx.value:
                self._call(f, "fmi2GetNominalsOfContinuousStates", fn["fmi2GetNominalsOfContinuousStates"],
                           comp, px, nx)
        return self.x_np.copy()

    def record(self, k: int, t: float) -> None:
        """Every recorded value read into the bus (at the point last set, the grid time t) and
        row k of the record."""
        c = self.ctx
        c.bus[0] = t
        for fun, args, fname, owner in c.step_ops:
            status = fun(*args)
            if status > 1:
                raise c.refused(owner, fname, status)
        if c.iterate:
            c.sweeps[0] += c.solve_loops(c.bus[0])
        ctypes.memmove(c.record_at + k * c.row_bytes, ctypes.addressof(c.bus), c.row_bytes)

    def completed_step(self) -> tuple[bool, bool]:
        """fmi2CompletedIntegratorStep on every FMU: (enter event mode, terminate); the FMU that
        asked for the event is `step_event_owner`."""
        enter, term, any_enter, any_term = ctypes.c_int(0), ctypes.c_int(0), False, False
        no_prior = ctypes.c_int(1)
        for i, (f, comp, _, _, _, _, _, fn) in enumerate(self.per_fmu):
            self._call(f, "fmi2CompletedIntegratorStep", fn["fmi2CompletedIntegratorStep"], comp, no_prior,
                       ctypes.byref(enter), ctypes.byref(term))
            if enter.value and not any_enter:
                self.step_event_owner = f"{self._who(i)}'s step event (fmi2CompletedIntegratorStep)"
            any_enter |= bool(enter.value)
            any_term |= bool(term.value)
        return any_enter, any_term

    def event_iteration(self, first: bool) -> tuple[bool, bool]:
        """At the instant last set, every FMU in event mode (``first``: just out of initialisation,
        already there): fmi2NewDiscreteStates on all until none needs another, the connections
        resolved before each round; then continuous-time mode. Returns (states changed,
        terminate) and sets the next time event."""
        c = self.ctx
        if not first:
            for f, comp, _, _, _, _, _, fn in self.per_fmu:
                self._call(f, "fmi2EnterEventMode", fn["fmi2EnterEventMode"], comp)
                f.state = "eventMode"
        info = self.event_info
        changed, terminate = False, False
        for rounds in range(MAX_EVENT_ITERATIONS):
            self.connect()
            again = []  # the FMUs that need another round
            self.t_next_event, self.next_event_owner = math.inf, ""
            for i, (f, comp, _, _, _, _, _, fn) in enumerate(self.per_fmu):
                info.newDiscreteStatesNeeded = 1
                info.nextEventTimeDefined = 0
                self._call(f, "fmi2NewDiscreteStates", fn["fmi2NewDiscreteStates"], comp, ctypes.byref(info))
                if info.newDiscreteStatesNeeded:
                    again.append(self._who(i))
                terminate |= bool(info.terminateSimulation)
                changed |= bool(info.valuesOfContinuousStatesChanged)
                if info.nextEventTimeDefined and float(info.nextEventTime) < self.t_next_event:
                    self.t_next_event = float(info.nextEventTime)
                    self.next_event_owner = f"{self._who(i)}'s time event (nextEventTime = {self.t_next_event:.9g} s)"
            if terminate or not again:
                break
        else:
            raise MeError(f"the event iteration at t = {c.bus[0]:.9g} s did not settle after "
                          f"{MAX_EVENT_ITERATIONS} rounds of fmi2NewDiscreteStates: {', '.join(again)} still "
                          f"returned newDiscreteStatesNeeded = true in the last round")
        for f, comp, _, _, _, _, _, fn in self.per_fmu:
            self._call(f, "fmi2EnterContinuousTimeMode", fn["fmi2EnterContinuousTimeMode"], comp)
            f.state = "continuousTimeMode"
        self.events += not first
        return changed, terminate

    def _solver(self, t0, y0, t_bound):
        import scipy.integrate as si
        cls = getattr(si, self.solver_name)
        if not self.NX:
            return None
        return cls(self.rhs, t0, y0, t_bound, rtol=self.rtol, atol=self.atol_vec)

    def locate(self, t0, t1, z0, sol):
        """The state event in (t0, t1]: the bracket [a, b] (b - a <= EVENT_TOL (1 + |t|)) where
        an indicator first leaves the domain it had at t0; returns (b, y(b)). Bisection on the
        dense output ``sol``."""
        side = z0 > 0
        a, b = t0, t1
        while b - a > EVENT_TOL * max(1.0, abs(b)):
            m = 0.5 * (a + b)
            if m <= a or m >= b:
                break
            z = self.indicators_at(m, sol(m))
            if np.any((z > 0) != side):
                b = m
            else:
                a = m
        return b, sol(b)

    # -- the run -------------------------------------------------------------
    def run(self, bar, every: int) -> tuple[int, bool, str]:
        """From the end of initialisation to stop: (rows recorded, success, message). A call
        refused by an FMU ends the run there, with the FMU's reason in the message."""
        from fmpy.fmi1 import FMICallException
        self.k = 0
        try:
            return self._run(bar, every)
        except MeError as e:  # a work bound: what was recorded up to then is kept
            return self.k, False, f"the Model Exchange run stopped: {e}"
        except FMICallException as e:
            f = getattr(e, "owner", None)
            if f is None:
                raise
            return self.k, False, self.ctx.stopped(self.ctx.logger, e, f, e.function, self.ctx.bus[0])

    def _run(self, bar, every: int) -> tuple[int, bool, str]:
        c = self.ctx
        sc = c.sc
        t = sc.start
        n_points = int(round((sc.stop - sc.start) / sc.step))
        grid = [sc.start + k * sc.step for k in range(n_points)] + [sc.stop]  # the co-simulation's grid
        ended = "an FMU ended the simulation at t = {:.9g} s (terminateSimulation)"
        _, terminate = self.event_iteration(first=True)
        y = self.states()
        nominal = np.abs(self.nominals()) if self.NX else np.zeros(0)
        self.nominal = np.where(nominal > 0, nominal, 1.0)
        self.atol_vec = self.atol * self.nominal
        self.set_point(t, y)
        self.record(0, grid[0])
        self.k = 1  # the next grid point to record
        if terminate:
            return self.k, True, ended.format(t)
        z = self.indicators()
        same_time, last_event = 0, -math.inf
        # the work since the last output point (the work bounds) and what caused the events
        interval_k, interval_t, interval_steps, interval_events = self.k, t, 0, {}
        while self.k <= n_points:
            t_end = min(sc.stop, self.t_next_event)
            event = t_end <= t  # a time event now
            cause = self.next_event_owner if event else ""
            solver = self._solver(t, y, t_end) if not event else None
            while not event:
                sol = None
                if solver is None:  # no states: from grid point to grid point (and time events)
                    t_new, y_new = min(t_end, grid[self.k]), y
                    sol = (lambda s, y=y: y)
                else:
                    message = solver.step()
                    if solver.status == "failed":
                        return self.k, False, (f"the {self.solver_name} integrator failed at t = {solver.t:.9g} s: "
                                               f"{message}")
                    self.steps += 1
                    if self.k != interval_k:
                        interval_k, interval_t, interval_steps, interval_events = self.k, t, 0, {}
                    interval_steps += 1
                    if interval_steps > MAX_STEPS_PER_INTERVAL:
                        raise MeError(
                            f"the {self.solver_name} integrator took {MAX_STEPS_PER_INTERVAL} steps from t = "
                            f"{interval_t!r} s to {solver.t:.9g} s without reaching the next output point "
                            f"{grid[self.k]:.9g} s (MAX_STEPS_PER_INTERVAL; its step is now {solver.step_size:.3g} s); "
                            f"the fastest state is {self._fastest_state(solver.t, solver.y)}: check that model's "
                            f"inputs and connections (an input read before its source was set makes the "
                            f"derivatives inconsistent) and the tolerances rtol = {self.rtol:g}, atol = {self.atol:g}")
                    t_new, y_new = solver.t, solver.y
                z_new = self.indicators_at(t_new, y_new)
                if self.NZ and np.any((z_new > 0) != (z > 0)):
                    sol = sol or solver.dense_output()
                    t_new, y_new = self.locate(t, t_new, z, sol)
                    z_at = self.indicators_at(t_new, y_new)
                    crossed = np.flatnonzero((z_at > 0) != (z > 0))
                    cause = f"{self._indicator(int(crossed[0]) if len(crossed) else 0)}'s state event"
                    event = True
                # the grid points this step covers, from its dense output
                last = self.k
                while last <= n_points and grid[last] <= t_new + 1e-12 * max(1.0, abs(t_new)):
                    last += 1
                if last > self.k:
                    inner = [tk for tk in grid[self.k:last] if tk < t_new]
                    if inner:
                        sol = sol or solver.dense_output()
                        ys = np.asarray(sol(np.array(inner))).reshape(len(y_new), len(inner)).T
                    for j, tk in enumerate(grid[self.k:last]):
                        if tk < t_new:
                            self.set_point(tk, ys[j])
                        else:
                            self.set_point(t_new, y_new)
                        self.record(self.k, tk)
                        self.k += 1
                if self.at != t_new:
                    self.set_point(t_new, y_new)
                enter, terminate = self.completed_step()
                if self.steps % every == 0 or self.k > n_points:
                    bar.update(t_new - sc.start, t_new)
                t, y, z = t_new, y_new, z_new
                c.logger.now = t
                if terminate:
                    return self.k, True, ended.format(t)
                if not event and enter:
                    cause, event = self.step_event_owner, True
                if not event and t >= self.t_next_event:
                    cause, event = self.next_event_owner, True
                if t >= t_end or self.k > n_points:
                    break
            if self.k > n_points:
                break
            if event:
                same_time = same_time + 1 if t <= last_event else 0
                last_event = t
                if self.k != interval_k:
                    interval_k, interval_t, interval_steps, interval_events = self.k, t, 0, {}
                interval_events[cause] = interval_events.get(cause, 0) + 1
                if same_time > MAX_EVENTS_AT_ONE_TIME:
                    raise MeError(f"{same_time} events at t = {t:.9g} s without time advancing "
                                  f"(MAX_EVENTS_AT_ONE_TIME): the model chatters; the last was {cause}")
                if sum(interval_events.values()) > MAX_EVENTS_PER_INTERVAL:
                    top = max(interval_events, key=interval_events.get)
                    raise MeError(f"{MAX_EVENTS_PER_INTERVAL} events from t = {interval_t:.9g} s to {t:.9g} s "
                                  f"without reaching the next output point {grid[self.k]:.9g} s "
                                  f"(MAX_EVENTS_PER_INTERVAL): {top} repeated {interval_events[top]} times "
                                  f"(an event loop: a state event whose handling does not move its indicator away "
                                  f"from 0, or time events a little apart)")
                changed, terminate = self.event_iteration(first=False)
                if terminate:
                    return self.k, True, ended.format(t)
                if changed:
                    y = self.states()
                self.set_point(t, y)
                z = self.indicators()
        return self.k, True, "completed"


def _bare(fmu, name):
    from .runner import _bare as bare
    return bare(fmu, name)


def _slot(bus, i):
    from .runner import _slot as slot
    return slot(bus, i)
