"""The ball model: formulation + integrator + state, one interval at a time.

`BallModel` is what both the monolithic run (`simulate`) and the
BallInShell FMU use. Its `advance` is a pure step: it takes a `BallState`,
returns a new one, and leaves the old one intact when it raises, so a
failing step never loses the last good state. `simulate` runs over its grid
in the compiled kernel or, in Python, on the library's one integration driver
(`events.integrate`, through `grid_run`), as the turning chamber's
`simulate_general` does.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import events as _events
from . import fast
from . import outputs as _out
from .equations import make_formulation
from .errors import ParameterError
from .integrators import Integrator
from .params import Ball


@dataclass
class BallState:
    """Everything that determines the ball's future: time, coordinates, and the
    adaptive integrator's next step size."""

    t: float
    y: np.ndarray
    h: float | None = None

    def copy(self) -> "BallState":
        return BallState(self.t, self.y.copy(), self.h)

    def to_dict(self):
        return {"t": self.t, "y": [float(v) for v in self.y], "h": self.h}

    @classmethod
    def from_dict(cls, d):
        return cls(float(d["t"]), np.array(d["y"], dtype=float), d["h"])


KERNELS = ("auto", "c", "python")


@dataclass
class StepInfo:
    steps: int = 0
    rejected: int = 0
    nfev: int = 0


class BallModel:
    """A ball in a translating spherical chamber.

    formulation: 'vector' (default, whole sphere) or 'paper' (xC, yC; lower
        hemisphere, refuses near the equator).
    method: 'DOP853' (default), 'RK45' or 'RK4' (fixed step ``h_fixed``).
    tol: relative tolerance of the adaptive methods.
    cramer: paper formulation only: solve for omega' by Cramer's rule.
    kernel: how `advance` integrates an interval whose platform acceleration is
        InputReconstruction's cubic closure (``accel.poly``; the FMU's case):
        ``"auto"`` (default) in the compiled kernel (`ballmill.physics.fast`) when
        it is built and covers the model (vector formulation, the library's
        integrator), else in Python; ``"python"`` always in Python; ``"c"``
        insists (`fast.KernelUnavailable` with the reason when it cannot). The
        results are the same bit for bit. Other accelerations (a motion's
        ``accel``) always run in Python here; `simulate` has its own ``kernel``.
    """

    def __init__(self, ball: Ball, formulation: str = "vector", method: str = "DOP853",
                 tol: float = 1e-9, h_fixed: float = 1e-3, equator_margin: float = 0.02,
                 cramer: bool = False, h_max: float | None = None, kernel: str = "auto",
                 max_steps: int = 1_000_000):
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
        self.kernel = kernel
        self.ball = ball
        opts = {"equator_margin": equator_margin, "cramer": cramer} if formulation == "paper" else {}
        self.form = make_formulation(formulation, ball, **opts)
        w_ref = ball.d * ball.omega_small / ball.r  # spin of a ball rolling at the pendulum's speed
        scale = ([1.0, 1.0, 1.0] if formulation == "vector" else [ball.d, ball.d]) + [w_ref] * 3
        self.integrator = Integrator(method, tol=tol, scale=scale, h_fixed=h_fixed, h_max=h_max, max_steps=max_steps,
                                     project=self.form.project, check=self.form.check)
        self.info = StepInfo()

    @property
    def formulation(self) -> str:
        return self.form.name

    # -- states ---------------------------------------------------------
    def initial(self, xC0: float = 0.0, yC0: float = 0.0, w0=(0.0, 0.0, 0.0), t0: float = 0.0) -> BallState:
        """State with the ball centre at (xC0, yC0) on the lower half of its
        sphere of centres and angular velocity w0. Raises ParameterError when
        the position cannot be reached or a value is not finite.

        Only the part of w0 compatible with rolling matters: all three
        components are state (the spin about n is conserved)."""
        d = self.ball.d
        for name, v in (("xC0", xC0), ("yC0", yC0), ("wx0", w0[0]), ("wy0", w0[1]), ("wz0", w0[2])):
            if not math.isfinite(v):
                raise ParameterError(f"{name} must be finite, got {name} = {v!r}")
        rho2 = xC0 * xC0 + yC0 * yC0
        if rho2 > d * d:
            raise ParameterError(
                f"initial position out of reach: the ball centre lies on a sphere of radius "
                f"R - r = {d:.6g} m, so sqrt(xC0^2 + yC0^2) must be <= {d:.6g} m, got "
                f"xC0 = {xC0!r} m, yC0 = {yC0!r} m ({math.sqrt(rho2):.6g} m)")
        n = (xC0 / d, yC0 / d, -math.sqrt(max(0.0, 1.0 - rho2 / (d * d))))
        try:
            y = self.form.from_nw(n, w0)
        except ArithmeticError as e:
            raise ParameterError(str(e)) from None
        return BallState(float(t0), y, None)

    def nw(self, state: BallState):
        """(n, omega) of a state, as tuples."""
        return self.form.to_nw(state.y)

    # -- dynamics -------------------------------------------------------
    def rhs(self, accel: Callable[[float], tuple]):
        """f(t, y) for the integrator, with a_O(t) = accel(t)."""
        deriv = self.form.derivative

        def f(t, y):
            ax, ay = accel(t)
            return deriv(y.tolist(), ax, ay)
        return f

    def advance(self, state: BallState, t_end: float, accel: Callable[[float], tuple]) -> BallState:
        """Integrate from state.t to t_end with platform acceleration accel(t).
        Returns a new state; raises StepFailure or FormulationLimitError and
        then leaves ``state`` as it was. With InputReconstruction's cubic closure
        as accel, in the compiled kernel (see ``kernel`` in the class docstring)."""
        if self.kernel != "python" and hasattr(accel, "poly"):
            new = fast.advance(self, state, t_end, accel)
            if new is not None:
                return new
            if self.kernel == "c":
                why = fast.advance_reason(self, state, t_end, accel)
                if why:
                    raise fast.KernelUnavailable(f"BallModel(kernel='c').advance: {why}")
            # else: nothing to integrate, or a step fails: Python does it (and raises)
        elif self.kernel == "c":
            raise fast.KernelUnavailable(f"BallModel(kernel='c').advance: "
                                         f"{fast.advance_reason(self, state, t_end, accel)}")
        y, h, st = self.integrator.advance(self.rhs(accel), state.t, state.y, t_end, state.h)
        self.info.steps += st.steps
        self.info.rejected += st.rejected
        self.info.nfev += st.nfev
        return BallState(float(t_end), y, h)

    def __getstate__(self):
        # the compiled kernel's buffers (fast.advance) hold addresses: never copy them
        d = dict(self.__dict__)
        d.pop("_fast_advance", None)
        return d

    def outputs(self, state: BallState, ax: float, ay: float, xO: float = 0.0, yO: float = 0.0):
        """`outputs.evaluate` of a state; in the compiled kernel (the same values bit for
        bit) unless ``kernel == "python"`` or the kernel cannot do it."""
        if self.kernel != "python":
            out = fast.outputs(self, state, ax, ay, xO, yO)
            if out is not None:
                return out
        n, w = self.form.to_nw(state.y)
        return _out.evaluate(self.ball, n, w, ax, ay, xO, yO)

    def energy(self, state: BallState, vx: float = 0.0, vy: float = 0.0) -> float:
        n, w = self.form.to_nw(state.y)
        return _out.energy(self.ball, n, w, vx, vy)


@dataclass
class Trajectory:
    """Result of `simulate` (and of the turning model's `simulate_general`/`simulate_chamber`):
    outputs on the time grid, like scipy's OdeResult.

    ``success`` says whether the integration reached t_end (False: it stopped, ``message``
    says where and why). It stays True when the rolling model stopped holding on the way:
    the equations were integrated to the end, but past ``t_invalid`` they describe a ball
    that slips or has left the wall, which it does not model (the BallInShell FMU's
    ``valid``/``t_invalid``). That is said by ``valid`` (None when the run recorded no
    outputs to judge), ``t_first_slip`` (rolling ended by slip, the ball still in contact),
    ``t_first_flight`` (contact lost, N = 0) and ``t_invalid`` (the earlier of the two), in
    seconds interpolated between the samples (`outputs.validity`), and ``message`` carries
    it: "completed; rolling ended (slip) at t = 2.50811 s; contact lost at 2.58462 s"."""

    t: np.ndarray
    y: np.ndarray
    out: dict = field(default_factory=dict)
    success: bool = True
    message: str = "completed"
    info: StepInfo | None = None
    valid: bool | None = None
    t_invalid: float | None = None
    t_first_slip: float | None = None
    t_first_flight: float | None = None

    def __getitem__(self, name):
        return self.out[name]

    def judge(self, mu: float) -> "Trajectory":
        """Set the validity attributes from the N and Ft outputs (friction coefficient mu) and
        add what failed, and when, to the message; returns self. Without outputs: unjudged."""
        judge(self, mu)
        return self


def judge(result, mu: float) -> None:
    """The validity of a sampled run (`Trajectory`, the absorber's `AbsorberResult`): its
    ``t`` and the ``N`` and ``Ft`` columns of its outputs (``out``, or ``data``) give
    ``valid``, ``t_invalid``, ``t_first_slip``, ``t_first_flight`` (`outputs.validity`); what
    failed is appended to ``message``. Left unjudged (valid None) without those outputs."""
    cols = result.out if hasattr(result, "out") else result.data
    if "N" not in cols or "Ft" not in cols or not len(result.t):
        return
    v = _out.validity(result.t, cols["N"], cols["Ft"], mu)
    result.valid, result.t_invalid = v.valid, v.t_invalid
    result.t_first_slip, result.t_first_flight = v.t_first_slip, v.t_first_flight
    if not v.valid:
        result.message = f"{result.message}; {v.describe()}"


def simulate(model: BallModel, motion, t_end: float, dt: float, state: BallState | None = None,
             outputs: bool = True, kernel: str = "auto") -> Trajectory:
    """Monolithic run: the ball driven by a platform motion with exact
    derivatives (``motion.state(t) -> (x, y, vx, vy, ax, ay)``), sampled every
    dt up to t_end. Stops early (success False, with the message) when the
    formulation or the integrator gives up. The result carries the rolling model's
    validity (`Trajectory`: valid, t_invalid, t_first_slip, t_first_flight, and the
    message); success stays True when only that ended.

    kernel: ``"auto"`` (default) runs in the compiled kernel (`ballmill.physics.fast`)
    when it is built and covers the run (vector formulation; CrankStartup, Fixed,
    Harmonic or Circle; DOP853, RK45 or RK4; with or without losses), else in
    Python; ``"c"`` insists (`fast.KernelUnavailable` with the reason when it
    cannot); ``"python"`` never uses it. Both give the same Trajectory, bit for bit.
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"dt must be positive and finite, got {dt!r} s")
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    state = state or model.initial()
    size = len(model.integrator.scale)
    if np.shape(state.y) != (size,):
        raise ParameterError(
            f"state.y must hold the {size} coordinates of the {model.formulation!r} formulation "
            f"({'n, omega' if size == 6 else 'xC, yC, omega'}), got shape {np.shape(state.y)}")
    return grid_run(model, motion, fast, t_end, dt, state, outputs, kernel, "simulate",
                    model.rhs(motion.accel), _sampler(model, motion), _out.Outputs._fields)


def grid_run(model, motion, compiled, t_end: float, dt: float, state: BallState, outputs: bool,
             kernel: str, who: str, f, outputs_at, fields) -> Trajectory:
    """A rolling model's run sampled every dt from state.t to t_end (`simulate`,
    `turning.model.simulate_general`): in the compiled kernel (``compiled``: the module with
    its ``applicable(model, motion, state)`` and ``simulate(model, motion, times, state,
    outputs)``) when ``kernel`` allows it and it covers the run, else in Python
    (`run_python`: the event-driven driver; right-hand side f, outputs_at(t, y) the row of
    output columns ``fields``). Both give the same `Trajectory`, judged for validity."""
    n_steps = int(round((t_end - state.t) / dt))
    times = state.t + dt * np.arange(n_steps + 1)
    run = None
    if kernel != "python":
        why = compiled.applicable(model, motion, state)
        if not why and n_steps < 1:
            why = "no interval to integrate"
        if not why:
            run = compiled.simulate(model, motion, times, state, outputs)
        elif kernel == "c":
            raise fast.KernelUnavailable(f"{who}(kernel='c'): {why}")
    if run is None:
        run = run_python(model, f, outputs_at, times, state, outputs)
    ys, arr, success, message, last = run
    out = {name: arr[:, j] for j, name in enumerate(fields)} if outputs and last >= 0 else {}
    return Trajectory(times[:last + 1], ys, out, success, message, model.info).judge(model.ball.mu)


def _sampler(model: BallModel, motion):
    """outputs(t, y): the `Outputs` of state y at time t (the platform's state from motion)."""
    def outputs(t, y):
        x, yy, _, _, ax, ay = motion.state(t)
        return tuple(model.outputs(BallState(t, y), ax, ay, x, yy))
    return outputs


def python_grid(model, f, outputs_at, times, state: BallState, outputs: bool = True):
    """A rolling model's run in Python over the grid ``times`` (times[0] = state.t, or the
    first interval's end when state.t is its start), on the event-driven driver without
    events (`events.Plain`): `simulate`'s and `turning.model.simulate_general`'s Python path
    and the intervals the compiled kernel hands back (`record_interval`). f(t, y) is the
    right-hand side, outputs_at(t, y) a row of outputs; the work goes to ``model.info``.

    Returns (run, ys, outputs or None): the driver's `events.EventRun` (success, error, the
    last state and step) and the states and outputs on its grid, run.t."""
    def sample(t, y):
        return y, (outputs_at(t, y) if outputs else None)

    run = _events.integrate(_events.Plain(model.integrator, f, sample), 0, state.t, state.y, times,
                            h=state.h)
    info = model.info
    info.steps += run.stats.steps
    info.rejected += run.stats.rejected
    info.nfev += run.stats.nfev
    n = len(run.rows)
    ys = np.array([r[0] for r in run.rows], dtype=float).reshape(n, np.size(state.y))
    arr = np.array([r[1] for r in run.rows], dtype=float).reshape(n, -1) if outputs and n else None
    return run, ys, arr


def run_python(model, f, outputs_at, times, state: BallState, outputs: bool = True):
    """`python_grid` over the whole grid (times[0] = state.t), as `fast.run_grid` returns
    a kernel run: (ys, outputs or None, success, message, last), the message on failure
    "stopped at t = <the last grid time reached> s: <why>"."""
    run, ys, arr = python_grid(model, f, outputs_at, times, state, outputs)
    message = run.message if run.success else f"stopped at t = {run.t_last:.6g} s: {run.error}"
    return ys, arr, run.success, message, len(run.rows) - 1


def _stopped(times, i, e) -> str:
    return f"stopped at t = {times[i - 1]:.6g} s: {e}"


def record_python(model: BallModel, motion, times, state: BallState, i: int, ys, outs):
    """One interval of `simulate`'s loop in Python, times[i - 1] -> times[i], recorded
    in row i of ys and outs (None: no outputs). Returns (ok, message, state); the
    compiled kernel hands over the intervals it cannot do through this."""
    return record_interval(model, model.rhs(motion.accel), _sampler(model, motion), times, state, i,
                           ys, outs)


def record_interval(model, f, outputs_at, times, state: BallState, i: int, ys, outs):
    """`python_grid` over the one interval times[i - 1] -> times[i] from ``state``, recorded in
    row i of ys and outs (None: no outputs). Returns (ok, message, state): on failure the
    message and ``state`` itself, untouched."""
    run, y1, o1 = python_grid(model, f, outputs_at, times[i:i + 1], state, outs is not None)
    if not run.success:
        return False, _stopped(times, i, run.error), state
    ys[i] = y1[0]
    if outs is not None:
        outs[i] = o1[0]
    return True, "completed", BallState(float(times[i]), y1[0], run.h)
