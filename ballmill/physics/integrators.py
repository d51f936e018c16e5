"""Explicit Runge-Kutta integrators that advance a state over one interval.

`Integrator.advance(f, t, y, t_end, h)` integrates dy/dt = f(t, y) from t to
t_end exactly (the last internal step is clipped to land on t_end) and
returns the new state with the internal step size to try next, so that an
FMU can carry the adaptive step across communication points.

Methods:
  * ``DOP853``: Dormand-Prince 8(5,3), adaptive (scipy's tableau);
  * ``RK45``: Dormand-Prince 5(4), adaptive (scipy's tableau);
  * ``RK4``: the classic fourth-order method with a fixed step, as in the
    paper's MathCAD program.

After every accepted step the formulation's ``project`` (renormalise n) and
``check`` (refuse a singular coordinate region) hooks run. A step whose
values are not finite is retried smaller and finally raises `StepFailure`;
the input state is never modified.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop
from scipy.integrate._ivp.rk import RK45 as _RK45

from .errors import StepFailure


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
    "DOP853": Tableau(A=_dop.A[:_dop.N_STAGES, :_dop.N_STAGES], B=_dop.B, C=_dop.C[:_dop.N_STAGES],
                      E=_dop.E5, E3=_dop.E3, order=8, n_stages=_dop.N_STAGES),
    "RK45": Tableau(A=_RK45.A, B=_RK45.B, C=_RK45.C, E=_RK45.E, E3=None, order=5,
                    n_stages=_RK45.n_stages),
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


def _identity(y):
    return y


def _nothing(y):
    return None


class Integrator:
    """Advance dy/dt = f(t, y) over an interval with a chosen method.

    tol: relative tolerance of the adaptive methods; the absolute tolerance
         is tol * scale (scale: a typical magnitude of each state component).
    h_fixed: the step of RK4 (the last step of an interval is shortened to
         land on its end; an interval shorter than h_fixed takes one step).
    h_max: largest internal step of the adaptive methods (None: unbounded).
    """

    def __init__(self, method: str = "DOP853", tol: float = 1e-9, scale=None,
                 h_fixed: float = 1e-3, h_max: float | None = None, max_steps: int = 1_000_000,
                 project=_identity, check=_nothing):
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
        sc = self._scale(y, y)
        d0 = math.sqrt(np.mean((y / sc) ** 2))
        d1 = math.sqrt(np.mean((f0 / sc) ** 2))
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, span)
        f1 = np.asarray(f(t + h0, y + h0 * f0))
        d2 = math.sqrt(np.mean(((f1 - f0) / sc) ** 2)) / h0
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
        f0 = np.asarray(f(t, y), dtype=float)
        stats.nfev += 1
        if not np.all(np.isfinite(f0)):
            # no step size can help: the state or the input is already unusable
            raise StepFailure(f"{self.method}: non-finite derivative at t = {t:.9g} s "
                              f"(state or input not finite)")
        if not self.adaptive:
            n = max(1, math.ceil(span / self.h_fixed - 1e-9))
            hh = span / n
            for i in range(n):
                ti = t + i * hh
                if i:
                    f0 = np.asarray(f(ti, y), dtype=float)
                    stats.nfev += 1
                K, y_new = self._stages(f, ti, y, hh, f0)
                stats.nfev += self.tab.n_stages - 1
                if not np.all(np.isfinite(y_new)):
                    raise StepFailure(f"RK4 step at t = {ti:.9g} s produced non-finite values "
                                      f"(step {hh:.3g} s); reduce the step")
                y = self.project(y_new)
                self.check(y)
                stats.steps += 1
            return y, self.h_fixed, stats

        if h is None or not (h > 0.0 and math.isfinite(h)):
            h = self.initial_step(f, t, y, f0, span)
            stats.nfev += 1
        order = self.tab.order
        h_min_abs = 1e-14 * max(1.0, abs(t_end))
        while t < t_end:
            if stats.steps + stats.rejected >= self.max_steps:
                raise StepFailure(f"{self.method}: more than {self.max_steps} internal steps "
                                  f"between t = {t:.9g} s and {t_end:.9g} s")
            h = min(h, self.h_max)
            last = t + h >= t_end - 1e-12 * max(1.0, abs(t_end))
            hh = t_end - t if last else h
            K, y_new = self._stages(f, t, y, hh, f0)
            f_new = np.asarray(f(t + hh, y_new), dtype=float)
            stats.nfev += self.tab.n_stages
            K[-1] = f_new
            err = self._error_norm(K, hh, y, y_new)
            if not math.isfinite(err) or not np.all(np.isfinite(y_new)):
                stats.rejected += 1
                h = 0.2 * hh
                if not h >= h_min_abs:  # also catches a NaN step
                    raise StepFailure(f"{self.method}: non-finite values at t = {t:.9g} s "
                                      f"even with step {hh:.3g} s")
                continue
            if err <= 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / order))
                t = t_end if last else t + hh
                y = self.project(y_new)
                self.check(y)
                f0 = f_new
                stats.steps += 1
                # keep the controller's step, not the clipped one, for the next interval
                h = max(h, hh * factor) if last else hh * factor
            else:
                stats.rejected += 1
                h = hh * max(0.2, 0.9 * err ** (-1.0 / order))
                if not h >= h_min_abs:
                    raise StepFailure(f"{self.method}: step size underflow at t = {t:.9g} s "
                                      f"(tolerance {self.tol:g} not met with step {hh:.3g} s)")
        return y, h, stats
