"""Event-driven integration: the one driver every model of the library runs on.

A *system* integrated here has a finite set of modes (integers). In each mode it has a
right-hand side, an `Integrator`, and guard functions g(t, y); a guard *fires* when it
crosses from g > 0 to g <= 0 (a guard is armed once it has been seen positive, so a guard
that starts at or below zero, as the gap of a flight that has just left the wall, does
not fire at once). At the event the system's exact map (`jump`) gives the new mode and
state, and the integration restarts there. Without events this is a plain integration
over the user's grid: the integrator's steps land on every grid point (and on every
``stops`` time, breakpoints of the right-hand side that are not sampled), as
`Integrator.advance` from one grid point to the next does, so a scene that never switches
gives the same floats as a loop of `advance` calls.

Who runs on it: the hybrid ball (`hybrid.HybridBall`: rolling, sliding, flight, impacts);
and, as `Plain` systems (one mode, no guards: the loop is the integrator's steps over the
grid, nothing more), the rolling models' Python paths (`model.simulate`,
`turning.model.simulate_general`, and the intervals the compiled kernel hands back to
Python, `model.record_interval`) and the absorber's structure + ball and bare structure
(`absorber.model.simulate_absorber`, `simulate_structure`, with a ground record's samples
as stops). The compiled kernel's one grid loop (_kernel.c's bm_drive) mirrors it, bit for
bit, for the rolling models (as Plain systems) and for the hybrid ball of a translating or
turning chamber with this event location (bm_advance_seen with a bm_events set,
bmh_simulate).

The adaptive methods and RK4 with its fixed step are driven alike: an RK4 step is cut short
where a grid point, a stop or an event ends it (the next one starts there, with h_fixed).

Locating an event (docs/design.md section 14):

1. detection, on the dense output: after each accepted step the guards are evaluated at
   ``scan`` interior points of the step's cubic Hermite interpolant (`Step.hermite`) and
   at the step's end; the first sub-interval where an armed guard changes sign brackets
   the event (a guard that dips below zero and comes back within one step is seen if the
   dip spans a scan point);
2. location, on the method's own continuous extension: y(t) for t in the step is one step
   of the method from the step's start (`Integrator.single_step`), as accurate as the
   integrator's accepted steps (the Hermite cubic is only third order); the guard along it
   is solved by the Illinois variant of regula falsi until the bracket is shorter than
   ``xtol`` (1e-11 s by default). The event is put at the bracket's end where g <= 0, so
   the state handed to `jump` has crossed (a gap <= 0, N <= 0, ...).

Zeno guard: a run that makes more than ``burst`` events within ``burst / max_rate`` seconds
(an accumulation of events the system's own rules, e.g. a rest speed, did not resolve)
stops with ``success = False`` and a message naming the time, never a hang; or, with
``on_zeno="hold"``, the system's ``hold`` map is applied there (a state from which it makes no
more events: the hybrid ball held on the wall, rolling only) and the run goes on
(``EventRun.held`` names the stop).

The system's interface (duck-typed):

- ``integrator(mode) -> Integrator``
- ``rhs(mode) -> f(t, y)``
- ``guards(mode) -> (kinds, G, levels)``: the names of the mode's guards, G(t, y) their
  values as a tuple (one evaluation serves all guards: they usually share the work), and
  the level each must exceed to be armed (0, or a guard's noise floor: a gap that has just
  opened from 0 must rise above its round-off before its return to 0 means anything)
- ``jump(mode, kind, t, y) -> (mode, y, details)``: the exact map at an event (details: a
  dict for the event log)
- ``sample(mode, t, y) -> tuple``: one row of outputs on the grid
- optional ``armed(mode, t, y) -> sequence of bool``: guards to arm at a mode's start although
  they are not positive there (a gap of 0 that is opening: the flight after a rebound)
- optional ``first_step(mode, t, y) -> float | None``: the longest first step after an event
  (a short hop must not fit inside one step, where no guard value would see it)
- ``hold(mode, t, y, window) -> (mode, y)``, for ``on_zeno="hold"`` only: the map at a Zeno stop
  at t (window: the span of the burst of events [s]), to a state without further events
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from .errors import StepFailure
from .integrators import StepStats


# the Zeno guard's defaults (`integrate`): more than BURST events within BURST / MAX_RATE s
BURST, MAX_RATE = 100, 1e4


@dataclass
class Event:
    """One switch: time [s], what fired (the guard's kind), the modes before and after, and
    the system's details of the map (impact speed, energy lost, ...)."""

    t: float
    kind: str
    mode_before: int
    mode_after: int
    width: float = 0.0  # final bracket of the root finder [s]: the event time's uncertainty
    details: dict = field(default_factory=dict)


@dataclass
class EventRun:
    """What `integrate` returns: the grid times reached, one `sample` row per time, the
    events in order, and whether the run reached the end (``message`` says why not, and
    ``error`` is the exception that stopped it)."""

    t: np.ndarray
    rows: list
    events: list
    success: bool = True
    message: str = "completed"
    stats: StepStats = field(default_factory=StepStats)
    # the state at the last grid point reached (continue from here): mode, state vector, the
    # integrator's next step, and its time
    mode: int = 0
    y: np.ndarray | None = None
    h: float | None = None
    t_last: float = math.nan
    error: Exception | None = None  # what stopped the run (None: it completed)
    held: Exception | None = None  # on_zeno="hold": the Zeno guard's error where the system's hold map applied


def illinois(phi, a: float, fa: float, b: float, fb: float, xtol: float, max_iter: int = 200):
    """Root of phi on [a, b] with phi(a) > 0 >= phi(b): the Illinois variant of regula falsi
    (superlinear, never slower than bisection by more than a constant: every third
    iteration bisects). Returns (b, phi(b), width) once b - a <= xtol or phi(b) == 0: the
    end where phi <= 0, and the final bracket's width (0 on an exact root)."""
    side = 0
    for it in range(max_iter):
        if b - a <= xtol or fb == 0.0:
            break
        if it % 3 == 2 or fa == fb:
            c = 0.5 * (a + b)
        else:
            c = (a * fb - b * fa) / (fb - fa)
            if not (a < c < b):
                c = 0.5 * (a + b)
        fc = phi(c)
        if fc > 0.0:
            a, fa = c, fc
            if side == 1:
                fb *= 0.5
            side = 1
        else:
            b, fb = c, fc
            if side == -1:
                fa *= 0.5
            side = -1
    return b, fb, (0.0 if fb == 0.0 else b - a)


def _locate(integ, f, step, G, j, ta, tb, xtol):
    """(t_event, y_event, bracket width) of guard j of G in [ta, tb] within the step, on
    the method's continuous extension (module docstring); None if it does not change sign
    there on it (the Hermite scan saw a crossing the method's own solution does not have)."""
    t0, y0, f0 = step.t0, step.y0, step.f0
    cache = {}

    def state(t):
        if t == t0:
            return y0
        if t == step.t1:
            return step.y1
        y = cache.get(t)
        if y is None:
            y = cache[t] = integ.single_step(f, t0, y0, t - t0, f0)
        return y

    def phi(t):
        return G(t, state(t))[j]

    fa, fb = phi(ta), phi(tb)
    if not fa > 0.0:
        ta, fa = t0, phi(t0)
    if not fa > 0.0 and fb <= 0.0:
        # armed at t0 without a positive value (an opening gap): find where it is positive
        for k in range(1, 80):
            tm = t0 + (tb - t0) * 0.5 ** k
            if tm - t0 <= xtol:
                break
            fm = phi(tm)
            if fm > 0.0:
                ta, fa = tm, fm
                break
    if not fb <= 0.0:
        tb, fb = step.t1, phi(step.t1)
    if not (fa > 0.0 and fb <= 0.0):
        return None
    t, _, width = illinois(phi, ta, fa, tb, fb, xtol)
    return t, state(t), width


def _detect(step, f, G, levels, armed, scan):
    """Brackets [(j, ta, tb), ...] of the armed guards that change sign first within the
    step on its dense output (all those changing sign in the same sub-interval), updating
    ``armed``; [] when no guard fires."""
    h = step.t1 - step.t0
    f1 = step.f1
    if f1 is None:
        f1 = f(step.t1, step.y1)
    prev = [step.t0] * len(armed)
    for k in range(1, scan + 2):
        if k <= scan:
            tk = step.t0 + h * k / (scan + 1)
            yk = step.hermite(tk, f1)
        else:
            tk, yk = step.t1, step.y1
        hits = []
        for j, v in enumerate(G(tk, yk)):
            if v > 0.0:
                if v > levels[j]:
                    armed[j] = True
                prev[j] = tk
            elif armed[j]:
                hits.append((j, prev[j], tk))
        if hits:
            return hits
    return []


def integrate(system, mode: int, t: float, y, times, *, h: float | None = None, stops=(),
              scan: int = 3, xtol: float = 1e-11, burst: int = BURST,
              max_rate: float = MAX_RATE, on_zeno: str = "stop") -> EventRun:
    """Integrate ``system`` from (t, mode, y) over the grid ``times`` (times[0] == t is
    sampled as it is), handling every event on the way (module docstring). Returns an
    `EventRun`; a step failure or a Zeno sequence ends it early with success False.

    on_zeno: what the Zeno guard does: "stop" the run (success False), or "hold": apply the
        system's ``hold`` map at the stop and go on (success True, ``EventRun.held`` the
        guard's error).

    h: the integrator's step to try first (None: its own starting step), as
        `Integrator.advance` takes it; the run's last one comes back in ``EventRun.h``.
    stops: times (increasing) the integration lands on without sampling them, e.g. the
        breakpoints of a piecewise excitation: an interval of the grid is integrated in
        pieces up to each stop inside it (one less than 1e-12 s before the grid point is
        left out), as a loop of `Integrator.advance` calls from stop to stop does.

    The work of an interval is added to ``EventRun.stats`` when the interval is complete:
    a failing interval's is not counted (as `Integrator.advance`, which raises, reports
    none)."""
    hold = holds_on_zeno(on_zeno)
    times = np.asarray(times, dtype=float)
    y = np.array(y, dtype=float)
    t = float(t)
    held = None
    stats = StepStats()
    events: list[Event] = []
    rows = []
    success, message, error = True, "completed", None
    stops = tuple(float(s) for s in stops)
    start = 1 if len(times) and times[0] == t else 0
    if start:
        rows.append(system.sample(mode, t, y))
    last = (mode, t, y, h)  # the state at the last grid point reached
    for i in range(start, len(times)):
        t_next = float(times[i])
        seg = StepStats()
        try:
            j = bisect.bisect_right(stops, t)
            while t < t_next:
                while j < len(stops) and stops[j] <= t:
                    j += 1
                target = stops[j] if j < len(stops) and stops[j] < t_next - 1e-12 else t_next
                kinds, G, levels = system.guards(mode)
                f = system.rhs(mode)
                integ = system.integrator(mode)
                hit = None
                if not kinds:  # no events possible in this mode: a plain integration
                    for step in integ.steps(f, t, y, target, h, seg):
                        t, y, h = step.t1, step.y1, step.h_next
                    t = target
                    continue
                armed = [v > lv for v, lv in zip(G(t, y), levels)]
                if hasattr(system, "armed"):
                    armed = [a or b for a, b in zip(armed, system.armed(mode, t, y))]
                for step in integ.steps(f, t, y, target, h, seg):
                    for j_, ta, tb in _detect(step, f, G, levels, armed, scan):
                        loc = _locate(integ, f, step, G, j_, ta, tb, xtol)
                        if loc is not None and (hit is None or loc[0] < hit[1]):
                            hit = (kinds[j_], loc[0], loc[1], loc[2], step.t1 - step.t0)
                    if hit is not None:
                        break
                    t, y, h = step.t1, step.y1, step.h_next
                if hit is None:
                    t = target
                    continue
                kind, t_e, y_e, width, h_used = hit
                t_e = float(t_e)
                new_mode, y, details = system.jump(mode, kind, t_e, y_e)
                events.append(Event(t_e, kind, mode, new_mode, width, details))
                mode, t, h = new_mode, t_e, h_used
                y = np.array(y, dtype=float)
                bound = system.first_step(mode, t, y) if hasattr(system, "first_step") else None
                if bound is not None:
                    h = min(h, bound)
                if len(events) >= burst and t_e - events[-burst].t < burst / max_rate:
                    if not hold:
                        raise zeno(events, burst, max_rate)
                    held = zeno(events, burst, max_rate)
                    mode, y = system.hold(mode, t, y, t_e - events[-burst].t)
                    y = np.array(y, dtype=float)
        except (_Zeno, StepFailure, ArithmeticError) as e:
            success, error = False, e
            message = f"stopped at t = {t:.9g} s: {e}"
            break
        stats.steps += seg.steps
        stats.rejected += seg.rejected
        stats.nfev += seg.nfev
        rows.append(system.sample(mode, t, y))
        last = (mode, t, y, h)
    mode, t_last, y, h = last
    return EventRun(times[:len(rows)], rows, events, success, message, stats, mode, y, h,
                    t_last, error, held)


class Plain:
    """A system of one mode without events (mode 0): dy/dt = f(t, y) integrated by
    ``integrator``, each grid point recorded as ``sample(t, y)``. What the rolling models
    (`model.simulate`, `turning.model.simulate_general`) and the absorber
    (`absorber.model.simulate_absorber`) run on the driver: with no guard the driver's
    loop is a plain sequence of the integrator's steps over the grid."""

    def __init__(self, integrator, f, sample):
        self._integ, self._f, self._sample = integrator, f, sample

    def integrator(self, mode):
        return self._integ

    def rhs(self, mode):
        return self._f

    def guards(self, mode):
        return (), None, ()

    def sample(self, mode, t, y):
        return self._sample(t, y)


def holds_on_zeno(on_zeno: str) -> bool:
    """The Zeno policy ``on_zeno`` ("stop" or "hold") as "the system's hold map applies"
    (ValueError naming any other)."""
    if on_zeno not in ("stop", "hold"):
        raise ValueError(f"on_zeno must be 'stop' or 'hold', got on_zeno = {on_zeno!r}")
    return on_zeno == "hold"


def zeno_words(burst: int, window: float, t: float, max_rate: float, last_kind: str | None = None) -> str:
    """What the Zeno guard says: ``burst`` events within ``window`` s before t (the last of kind
    ``last_kind``, when known), more than ``max_rate``."""
    last = f" (the last: {last_kind!r})" if last_kind is not None else ""
    return (f"Zeno sequence: {burst} events within {window:.3g} s before t = {t:.9g} s{last}, more than the "
            f"allowed rate {max_rate:g} events/s")


class _Zeno(Exception):
    pass


def zeno(events, burst: int, max_rate: float) -> _Zeno:
    """The Zeno guard's error at the last of ``events``: ``burst`` events within less than
    burst / max_rate seconds (also what the compiled kernel's run reports, fast.hybrid_run)."""
    last = events[-1]
    return _Zeno(zeno_words(burst, last.t - events[-burst].t, last.t, max_rate, last.kind))
