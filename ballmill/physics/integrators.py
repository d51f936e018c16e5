"""Explicit Runge-Kutta integrators that advance a state over one interval.

`Integrator.advance(f, t, y, t_end, h)` integrates dy/dt = f(t, y) from t to
t_end exactly (the last internal step is clipped to land on t_end) and
returns the new state with the internal step size to try next, so that an
FMU can carry the adaptive step across communication points.

Methods:
  * ``DOP853``: Dormand-Prince 8(5,3), adaptive (scipy's tableau, embedded below);
  * ``RK45``: Dormand-Prince 5(4), adaptive (scipy's tableau, embedded below);
  * ``RK4``: the classic fourth-order method with a fixed step, as in the
    paper's MathCAD program.

`Integrator.steps` yields the same accepted steps one at a time (`Step`, with its
cubic Hermite dense output), and `Integrator.single_step` makes one step of any size
from a step's start (the method's own continuous extension): the event-driven driver
(events.py) detects switches on the first and locates them on the second.

After every accepted step the formulation's ``project`` (renormalise n) and
``check`` (refuse a singular coordinate region) hooks run. A step whose
values are not finite is retried smaller and finally raises `StepFailure`;
the input state is never modified.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .errors import StepFailure

# Butcher tableaus, copied from scipy.integrate._ivp (dop853_coefficients.py and rk.py,
# BSD-3-Clause) as exact float64 literals: importing scipy.integrate costs about half a second
# of start-up, and these numbers are all the integrators need from it.
_DOP853_A = [  # rows 1..11 of A, entries 0..s-1 (row 0 is empty)
    [0.05260015195876773],
    [0.0197250569845379, 0.0591751709536137],
    [0.02958758547680685, 0.0, 0.08876275643042054],
    [0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792],
    [0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242],
    [0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125],
    [0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402,
     0.008273789163814023],
    [0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671,
     20.154067550477894, -43.48988418106996],
    [0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193,
     15.279233632882423, -33.28821096898486, -0.020331201708508627],
    [-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927,
     -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196],
    [2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188,
     27.94888452941996, -2.8589982771350235, -8.87285693353063, 12.360567175794303,
     0.6433927460157636],
]
_DOP853_B = [0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
             -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034,
             0.04471061572777259]
_DOP853_C = [0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
             0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6,
             0.8571428571428571, 1.0]
_DOP853_E5 = [0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502,
              1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571,
              -0.022355307863886294, 0.0]
_DOP853_E3 = [-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003,
              -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034,
              0.02265179219836082, 0.0]
_RK45_A = [  # rows 1..5 of A, entries 0..s-1
    [0.2],
    [0.075, 0.225],
    [0.9777777777777777, -3.7333333333333334, 3.5555555555555554],
    [2.9525986892242035, -11.595793324188385, 9.822892851699436, -0.2908093278463649],
    [2.8462752525252526, -10.757575757575758, 8.906422717743473, 0.2784090909090909,
     -0.2735313036020583],
]
_RK45_B = [0.09114583333333333, 0.0, 0.44923629829290207, 0.6510416666666666, -0.322376179245283,
           0.13095238095238096]
_RK45_C = [0.0, 0.2, 0.3, 0.8, 0.8888888888888888, 1.0]
_RK45_E = [-0.0012326388888888888, 0.0, 0.0042527702905061394, -0.03697916666666667, 0.05086379716981132,
           -0.0419047619047619, 0.025]


def _square(rows, n):
    """The n x n strictly lower-triangular A from its rows 1..n-1."""
    A = np.zeros((n, n))
    for s, row in enumerate(rows, start=1):
        A[s, :s] = row
    return A


@dataclass(frozen=True)
class Tableau:
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    E: np.ndarray | None  # error weights (on the n_stages + 1 stages incl. FSAL)
    E3: np.ndarray | None  # DOP853's second error estimate
    order: int  # order used by the step-size controller (error estimator order + 1)
    n_stages: int


TABLEAUS = {
    "DOP853": Tableau(A=_square(_DOP853_A, 12), B=np.array(_DOP853_B), C=np.array(_DOP853_C),
                      E=np.array(_DOP853_E5), E3=np.array(_DOP853_E3), order=8, n_stages=12),
    "RK45": Tableau(A=_square(_RK45_A, 6), B=np.array(_RK45_B), C=np.array(_RK45_C),
                    E=np.array(_RK45_E), E3=None, order=5, n_stages=6),
    "RK4": Tableau(A=np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1.0, 0]]),
                   B=np.array([1 / 6, 1 / 3, 1 / 3, 1 / 6]), C=np.array([0, 0.5, 0.5, 1.0]),
                   E=None, E3=None, order=4, n_stages=4),
}
METHODS = tuple(TABLEAUS)


@dataclass
class StepStats:
    """Work done by one `advance` call."""

    steps: int = 0
    rejected: int = 0
    nfev: int = 0


class Step(NamedTuple):
    """One accepted step of `Integrator.steps`: from (t0, y0) with slope f0 to (t1, y1)
    (projected), f1 the slope at the end (None for RK4, which does not compute it),
    h_next the step the controller proposes next."""

    t0: float
    y0: np.ndarray
    f0: tuple
    t1: float
    y1: np.ndarray
    f1: tuple | None
    h_next: float

    def hermite(self, t: float, f1=None) -> np.ndarray:
        """The cubic Hermite interpolant through (y0, f0) and (y1, f1) at time t: the
        dense output between the ends, third order (an event is detected on it, and then
        located on the method's own step, `Integrator.single_step`). ``f1`` replaces a
        missing end slope."""
        f1 = self.f1 if f1 is None else f1
        h = self.t1 - self.t0
        s = (t - self.t0) / h
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        return (h00 * self.y0 + h01 * self.y1
                + (h * h10) * np.asarray(self.f0, dtype=float) + (h * h11) * np.asarray(f1, dtype=float))


def _identity(y):
    return y


def _nothing(y):
    return None


# ----------------------------------------------------------------------
# Scalar kernels for small systems.
#
# For the five or six states of the ball, numpy's per-call overhead (about
# a microsecond per array operation, some forty operations per DOP853 step)
# costs more than the arithmetic. A step of a small system is therefore
# done by a function generated once per (method, dimension): the tableau's
# coefficients written out as float literals (zeros left out), the state
# as Python floats. The arithmetic is the same as the numpy path's, up to
# the order in which each dot product is summed (round-off).
SMALL_SYSTEM = 16  # largest dimension that uses a generated kernel
_KERNELS: dict = {}


def _dot(coefs, names):
    """Source of sum(c * name) over the non-zero coefficients (left to right)."""
    terms = [f"{float(c)!r} * {nm}" for c, nm in zip(coefs, names) if c != 0.0]
    return "(" + " + ".join(terms) + ")" if terms else "0.0"


def _as_seq(n):
    def seq(r):
        """A right-hand side's value as n floats, broadcast as numpy would assign it."""
        return np.broadcast_to(np.asarray(r, dtype=float), (n,)).tolist()
    return seq


def _kernel(method: str, n: int, scaled: bool, n_err: int | None = None):
    """step(f, t, y, h, k0, tol, scale, tols, arr) for `method` on n states, the error
    norm over the first ``n_err`` of them (None: all).

    Adaptive methods return (y_new, f_new, err, finite); RK4 returns
    (y_new, finite). ``y`` is a list of floats, ``k0`` f(t, y) as a sequence,
    ``arr`` builds the array handed to f; ``scale``/``tols`` are the scale and
    tol * scale tuples (unused when not ``scaled``).
    """
    ne = n if n_err is None else n_err
    key = (method, n, scaled) if ne == n else (method, n, scaled, ne)
    fn = _KERNELS.get(key)
    if fn is not None:
        return fn
    tab = TABLEAUS[method]
    ns = tab.n_stages
    comps = range(n)
    K = [[f"k{s}_{i}" for i in comps] for s in range(ns + 1)]
    ys = [f"y_{i}" for i in comps]
    yn = [f"yn_{i}" for i in comps]
    one = "," if n == 1 else ""
    src = ["def step(f, t, y, h, k0, tol, scale, tols, arr):",
           f"    {', '.join(ys)}{one} = y",
           "    if type(k0) is not tuple:",
           "        k0 = seq(k0)",
           f"    {', '.join(K[0])}{one} = k0"]
    for s in range(1, ns):
        args = ", ".join(f"{ys[i]} + {_dot(tab.A[s, :s], [K[j][i] for j in range(s)])} * h" for i in comps)
        src += [f"    k = f(t + {float(tab.C[s])!r} * h, arr([{args}]))",
                "    if type(k) is not tuple:",
                "        k = seq(k)",
                f"    {', '.join(K[s])}{one} = k"]
    for i in comps:
        src.append(f"    {yn[i]} = {ys[i]} + h * {_dot(tab.B, [K[j][i] for j in range(ns)])}")
    src.append(f"    y_new = [{', '.join(yn)}]")
    src.append("    finite = " + " and ".join(f"isfinite({v})" for v in yn))
    if tab.E is None:
        src.append("    return y_new, finite")
    else:
        src += ["    k = f(t + h, arr(y_new))",
                "    if type(k) is not tuple:",
                "        k = seq(k)",
                f"    {', '.join(K[ns])}{one} = k"]
        if scaled:
            src.append(f"    {', '.join(f's_{i}' for i in comps)}{one} = scale")
            src.append(f"    {', '.join(f'ts_{i}' for i in comps)}{one} = tols")
        for i in comps:
            base = f"max(abs({ys[i]}), abs({yn[i]})" + (f", s_{i})" if scaled else ")")
            src.append(f"    sc_{i} = tol * {base} + " + (f"ts_{i}" if scaled else "1e-12"))
        col = [[K[j][i] for j in range(ns + 1)] for i in comps]
        controlled = range(ne)  # the components in the error norm (the rest: quadratures it ignores)
        if tab.E3 is None:
            for i in controlled:
                src.append(f"    e_{i} = {_dot(tab.E, col[i])} * h / sc_{i}")
            src.append(f"    err = sqrt(({' + '.join(f'e_{i} * e_{i}' for i in controlled)}) / {ne})")
        else:
            for i in controlled:
                src.append(f"    e_{i} = {_dot(tab.E, col[i])} / sc_{i}")
                src.append(f"    g_{i} = {_dot(tab.E3, col[i])} / sc_{i}")
            src.append(f"    e5n = {' + '.join(f'e_{i} * e_{i}' for i in controlled)}")
            src.append(f"    e3n = {' + '.join(f'g_{i} * g_{i}' for i in controlled)}")
            src += ["    if e5n == 0.0 and e3n == 0.0:",
                    "        err = 0.0",
                    "    else:",
                    f"        err = abs(h) * e5n / sqrt((e5n + 0.01 * e3n) * {ne})"]
        src.append("    return y_new, k, err, finite and isfinite(err)")
    namespace = {"seq": _as_seq(n), "isfinite": math.isfinite, "sqrt": math.sqrt}
    exec(compile("\n".join(src) + "\n", f"<ballmill {method} kernel, n={n}, n_err={ne}>", "exec"), namespace)
    fn = _KERNELS[key] = namespace["step"]
    return fn


class Integrator:
    """Advance dy/dt = f(t, y) over an interval with a chosen method.

    tol: relative tolerance of the adaptive methods; the absolute tolerance
         is tol * scale (scale: a typical magnitude of each state component).
    h_fixed: the step of RK4 (the last step of an interval is shortened to
         land on its end; an interval shorter than h_fixed takes one step).
    h_max: largest internal step of the adaptive methods (None: unbounded).
    n_err: the number of leading state components the error norm and the initial step
         weigh (None: all); the components after them are quadratures that ride along on
         the same stages without steering the step (the states' steps and floats are
         those of an integration without them).
    """

    def __init__(self, method: str = "DOP853", tol: float = 1e-9, scale=None,
                 h_fixed: float = 1e-3, h_max: float | None = None, max_steps: int = 1_000_000,
                 project=_identity, check=_nothing, n_err: int | None = None):
        if method not in TABLEAUS:
            raise ValueError(f"integrator method must be one of {METHODS}, got {method!r}")
        if not (math.isfinite(tol) and 1e-15 <= tol <= 1e-1):
            raise ValueError(f"tolerance must be within [1e-15, 0.1], got {tol!r}")
        if not (math.isfinite(h_fixed) and h_fixed > 0):
            raise ValueError(f"fixed step h_fixed must be positive and finite, got {h_fixed!r} s")
        self.method = method
        self.tab = TABLEAUS[method]
        self.adaptive = self.tab.E is not None
        self.tol = tol
        self.scale = None if scale is None else np.asarray(scale, dtype=float)
        self.h_fixed = h_fixed
        self.h_max = math.inf if h_max is None else h_max
        self.max_steps = max_steps
        self.project = project
        self.check = check
        self.n_err = None if n_err is None else int(n_err)
        self._bT = self.tab.B  # weights
        self._a_rows = [self.tab.A[s, :s] for s in range(self.tab.n_stages)]

    # ------------------------------------------------------------------
    def _scale(self, y, y_new):
        base = np.maximum(np.abs(y), np.abs(y_new))
        if self.scale is not None:
            base = np.maximum(base, self.scale)
        return self.tol * base + (self.tol * self.scale if self.scale is not None else 1e-12)

    def initial_step(self, f, t, y, f0, span):
        """Hairer-Wanner starting step for the adaptive methods."""
        ne = self.n_err
        sc = self._scale(y, y)
        if ne is None:
            yc, fc, scc = y, f0, sc
        else:  # the controlled components only (quadratures after them do not steer the step)
            yc, fc, scc = y[:ne], np.broadcast_to(f0, y.shape)[:ne], sc[:ne]
        d0 = math.sqrt(np.mean((yc / scc) ** 2))
        d1 = math.sqrt(np.mean((fc / scc) ** 2))
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, span)
        f1 = np.asarray(f(t + h0, y + h0 * f0))
        if ne is not None:
            f1 = np.broadcast_to(f1, y.shape)[:ne]
        d2 = math.sqrt(np.mean(((f1 - fc) / scc) ** 2)) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / self.tab.order)
        return min(100 * h0, h1, self.h_max)

    def _stages(self, f, t, y, h, f0):
        tab = self.tab
        K = np.empty((tab.n_stages + 1, y.size))
        K[0] = f0
        for s in range(1, tab.n_stages):
            dy = (self._a_rows[s] @ K[:s]) * h
            K[s] = f(t + tab.C[s] * h, y + dy)
        y_new = y + h * (self._bT @ K[:tab.n_stages])
        return K, y_new

    def _error_norm(self, K, h, y, y_new):
        tab = self.tab
        ne = self.n_err
        if ne is not None:
            K, y, y_new = K[:, :ne], y[:ne], y_new[:ne]
        sc = self._scale(y, y_new)
        if tab.E3 is None:
            err = (tab.E @ K) * h / sc
            return math.sqrt(np.mean(err * err))
        e5 = (tab.E @ K) / sc
        e3 = (tab.E3 @ K) / sc
        e5n = float(e5 @ e5)
        e3n = float(e3 @ e3)
        if e5n == 0.0 and e3n == 0.0:
            return 0.0
        return abs(h) * e5n / math.sqrt((e5n + 0.01 * e3n) * y.size)

    # ------------------------------------------------------------------
    def advance(self, f, t: float, y, t_end: float, h: float | None = None):
        """Integrate from t to t_end. Returns (y_end, h_next, StepStats).

        ``y`` is not modified. ``h`` is the internal step to try first
        (None: choose one). Raises StepFailure when a step cannot be made.
        """
        y = np.array(y, dtype=float)
        stats = StepStats()
        span = t_end - t
        if span <= 0.0:
            return y, h, stats
        if y.ndim != 1:
            raise ValueError(f"the state must be a 1-D sequence of floats, got shape {y.shape}")
        return self._advance(f, t, y, t_end, h, stats)

    def _numpy_step(self):
        """The step function for systems larger than SMALL_SYSTEM, with the same
        contract as the generated kernels (see `_kernel`), built on numpy."""
        adaptive = self.adaptive

        def step(f, t, yl, h, k0, tol, scale, tols, arr):
            y = np.asarray(yl, dtype=float)
            K, y_new = self._stages(f, t, y, h, np.asarray(k0, dtype=float))
            finite = bool(np.all(np.isfinite(y_new)))
            if not adaptive:
                return y_new.tolist(), finite
            # a scalar right-hand side is broadcast to every state, as `_as_seq` does
            k = np.broadcast_to(np.asarray(f(t + h, y_new), dtype=float), y.shape)
            K[-1] = k
            err = self._error_norm(K, h, y, y_new)
            return y_new.tolist(), tuple(k.tolist()), err, finite and math.isfinite(err)
        return step

    def _step_function(self, n):
        """(step, tol, scale, tols) for n states: the generated scalar kernel for small
        systems (numpy's per-call overhead outweighs the arithmetic there), numpy above
        SMALL_SYSTEM; cached, rebuilt if tol or scale change."""
        c = getattr(self, "_small", None)
        if c is None or c[0] != n or c[1] != self.tol or c[2] is not self.scale:
            scaled = self.scale is not None
            generated = n <= SMALL_SYSTEM and (not scaled or self.scale.shape == (n,))
            scaled = scaled and generated
            c = self._small = (n, self.tol, self.scale,
                               _kernel(self.method, n, scaled, self.n_err) if generated else self._numpy_step(),
                               tuple(self.scale.tolist()) if scaled else None,
                               tuple((self.tol * self.scale).tolist()) if scaled else None)
        return c[3], c[1], c[4], c[5]

    def _advance(self, f, t, y, t_end, h, stats):
        """The step-size driver of `advance`: the last of `steps`."""
        for step in self._steps(f, t, y, t_end, h, stats):
            pass
        return step.y1, step.h_next, stats

    def steps(self, f, t: float, y, t_end: float, h: float | None = None, stats=None):
        """The accepted steps from t to t_end, one `Step` at a time (a generator), the
        same steps and the same floats as `advance` makes (which is the last of them):
        an event-driven driver inspects each step's dense output and may stop anywhere.
        ``stats`` (a StepStats) is updated as it goes. Nothing is yielded for an empty
        interval."""
        y = np.array(y, dtype=float)
        if t_end - t <= 0.0:
            return
        if y.ndim != 1:
            raise ValueError(f"the state must be a 1-D sequence of floats, got shape {y.shape}")
        yield from self._steps(f, t, y, t_end, h, StepStats() if stats is None else stats)

    def single_step(self, f, t: float, y, h: float, f0):
        """One step of the method from (t, y) of size h, f0 = f(t, y), without error
        control, projected: the method's own continuous extension, y(t + h) for any
        0 < h <= the accepted step (an event is located on it). Returns an array."""
        y = np.asarray(y, dtype=float)
        step, tol, scale, tols = self._step_function(y.size)
        out = step(f, t, y.tolist(), h, tuple(f0), tol, scale, tols, np.array)
        return self.project(np.array(out[0]))

    def _steps(self, f, t, y, t_end, h, stats):
        n = y.size
        step, tol, scale, tols = self._step_function(n)
        arr = np.array
        span = t_end - t
        yl = y.tolist()
        f0 = f(t, y)
        stats.nfev += 1
        if type(f0) is not tuple:  # an array, a list or a scalar to broadcast: n floats
            f0 = _as_seq(n)(f0)
        if not all(map(math.isfinite, f0)):
            # no step size can help: the state or the input is already unusable
            raise StepFailure(f"{self.method}: non-finite derivative at t = {t:.9g} s "
                              f"(state or input not finite)")
        if not self.adaptive:
            count = max(1, math.ceil(span / self.h_fixed - 1e-9))
            if count > self.max_steps:
                raise StepFailure(f"RK4: {span:.6g} s at h_fixed = {self.h_fixed:g} s needs {count:.6g} "
                                  f"steps, more than {self.max_steps}")
            hh = span / count
            for i in range(count):
                ti = t + i * hh
                if i:
                    f0 = f(ti, y)
                    stats.nfev += 1
                y_new, finite = step(f, ti, yl, hh, f0, tol, scale, tols, arr)
                stats.nfev += self.tab.n_stages - 1
                if not finite:
                    raise StepFailure(f"RK4 step at t = {ti:.9g} s produced non-finite values "
                                      f"(step {hh:.3g} s); reduce the step")
                y0 = y
                y = self.project(arr(y_new))
                self.check(y)
                yl = y.tolist()
                stats.steps += 1
                yield Step(ti, y0, f0, t_end if i == count - 1 else ti + hh, y, None, self.h_fixed)
            return

        if h is None or not (h > 0.0 and math.isfinite(h)):
            h = self.initial_step(f, t, y, np.asarray(f0, dtype=float), span)
            stats.nfev += 1
        order = self.tab.order
        n_eval = self.tab.n_stages
        h_max = self.h_max
        h_min_abs = 1e-14 * max(1.0, abs(t_end))
        t_last = t_end - 1e-12 * max(1.0, abs(t_end))
        while t < t_end:
            if stats.steps + stats.rejected >= self.max_steps:
                raise StepFailure(f"{self.method}: more than {self.max_steps} internal steps "
                                  f"between t = {t:.9g} s and {t_end:.9g} s")
            h = min(h, h_max)
            last = t + h >= t_last
            hh = t_end - t if last else h
            y_new, f_new, err, finite = step(f, t, yl, hh, f0, tol, scale, tols, arr)
            stats.nfev += n_eval
            if not finite:
                stats.rejected += 1
                h = 0.2 * hh
                if not h >= h_min_abs:  # also catches a NaN step
                    raise StepFailure(f"{self.method}: non-finite values at t = {t:.9g} s "
                                      f"even with step {hh:.3g} s")
                continue
            if err <= 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / order))
                t0, y0, fa = t, y, f0
                t = t_end if last else t + hh
                y = self.project(arr(y_new))
                self.check(y)
                yl = y.tolist()
                f0 = f_new
                stats.steps += 1
                # keep the controller's step, not the clipped one, for the next interval
                h = max(h, hh * factor) if last else hh * factor
                yield Step(t0, y0, fa, t, y, f_new, h)
            else:
                stats.rejected += 1
                h = hh * max(0.2, 0.9 * err ** (-1.0 / order))
                if not h >= h_min_abs:
                    raise StepFailure(f"{self.method}: step size underflow at t = {t:.9g} s "
                                      f"(tolerance {self.tol:g} not met with step {hh:.3g} s)")
