"""Reconstructing the platform's motion between communication points.

A co-simulation FMU receives its inputs only at communication points t_k,
but the ball needs the platform acceleration a_O(t) for t in [t_k, t_k + H].
`InputReconstruction` keeps the last few samples and fits one polynomial per
axis through them, which it then extrapolates over the coming step:

* mode "derivatives": each sample brings x, v and a. Two samples give a
  quintic (Hermite) through (x, v, a) at t_{k-1} and t_k; a(t) is then a
  cubic and its extrapolation error is O(H^4).
* mode "positions": each sample brings x only (a measured motion, a tool
  without derivative outputs). Six samples give a quintic in x, a(t) again
  a cubic, O(H^4) on smooth motion; a jump in acceleration (the start of the
  paper's crank law at t = 0) is smeared over the window and costs O(H) there.
* mode "hold": a(t) = a_k over the step (zero-order hold): first order, the
  baseline that DESIGN.md warns about; kept for measurements.

Until enough samples exist the fit uses what it has (lower degree).

The fit is reproducible in C (the native BallInShell FMU, fmu_src/ballinshell.c, does
the same): the inverse of the constraint matrix is the exact inverse of the float
matrix built from the sample times rounded to 12 decimals, correctly rounded to floats,
and the coefficients are its rows' dot products with the samples, summed left to right.
"""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from .errors import InputError

MODES = ("derivatives", "positions", "hold")

DEFAULT_POINTS = {"derivatives": 2, "positions": 6, "hold": 1}


class InputReconstruction:
    """Polynomial reconstruction of (x, y) of the platform from its samples."""

    def __init__(self, mode: str = "derivatives", points: int | None = None):
        if mode not in MODES:
            raise ValueError(f"input mode must be one of {MODES}, got {mode!r}")
        self.mode = mode
        self.points = DEFAULT_POINTS[mode] if points is None else int(points)
        if self.points < 1 or self.points > 8:
            raise ValueError(f"points must be between 1 and 8, got {points!r}")
        self.samples: list[tuple] = []  # (t, x, y, vx, vy, ax, ay)
        self._t0 = 0.0
        self._hs = 1.0
        self._cx = self._cy = (0.0,)  # polynomial coefficients in tau = (t - t0)/hs
        self._dirty = True

    # -- samples ---------------------------------------------------------
    def push(self, t, x, y, vx=0.0, vy=0.0, ax=0.0, ay=0.0):
        """Record the inputs seen at communication point t. A second sample at
        the same t replaces the first. Raises InputError (state unchanged) on
        a non-finite value or a time earlier than the last sample."""
        sample = (float(t), float(x), float(y), float(vx), float(vy), float(ax), float(ay))
        names = ("t", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
        for name, v in zip(names, sample):
            if not math.isfinite(v):
                raise InputError(f"input {name} must be finite, got {v!r} at t = {t!r} s")
        if self.samples and sample[0] < self.samples[-1][0]:
            raise InputError(f"inputs must come in time order: got t = {t!r} s after "
                             f"t = {self.samples[-1][0]!r} s")
        if self.samples and sample[0] == self.samples[-1][0]:
            self.samples[-1] = sample
        else:
            self.samples.append(sample)
            if len(self.samples) > self.points:
                del self.samples[0]
        self._dirty = True

    def get_state(self):
        return {"mode": self.mode, "points": self.points, "samples": [list(s) for s in self.samples]}

    def set_state(self, state):
        self.mode = state["mode"]
        self.points = state["points"]
        self.samples = [tuple(s) for s in state["samples"]]
        self._dirty = True

    # -- fit -----------------------------------------------------------
    def _fit(self):
        s = self.samples
        if not s:
            raise InputError("no platform sample has been set yet")
        tk = s[-1][0]
        self._t0 = tk
        self._hs = (tk - s[-2][0]) if len(s) > 1 else 1.0
        if self.mode == "hold":
            _, x, y, vx, vy, ax, ay = s[-1]
            self._cx, self._cy = (x, vx, 0.5 * ax), (y, vy, 0.5 * ay)
            self._hs = 1.0
        else:
            hs = self._hs
            deriv = self.mode == "derivatives"
            taus = tuple([(smp[0] - tk) / hs for smp in s])
            inv = self._ROWS.get((deriv, taus))
            if inv is None:
                inv = self._inverse_rows(deriv, taus)
            if deriv:
                bx, by = [], []
                for (_, x, y, vx, vy, ax, ay) in s:
                    bx += (x, vx * hs, ax * hs * hs)
                    by += (y, vy * hs, ay * hs * hs)
            else:
                bx = [smp[1] for smp in s]
                by = [smp[2] for smp in s]
            self._cx = tuple([_dot(row, bx) for row in inv])
            self._cy = tuple([_dot(row, by) for row in inv])
        self._dirty = False
        # derivative coefficient tuples for fast evaluation
        self._dx = self._deriv(self._cx)
        self._dy = self._deriv(self._cy)
        self._ddx = self._deriv(self._dx)
        self._ddy = self._deriv(self._dy)
        self._accel_fn = self._compile_accel()

    def _compile_accel(self):
        """a(t) as a closure over the cubic's coefficients in physical time (the
        integrator calls it at every stage, so it avoids loops and attribute look-ups).

        The cubic closure carries its coefficients as ``accel.poly = (t0, (x0, x1, x2,
        x3), (y0, y1, y2, y3))`` (floats, the values it computes with): `BallModel.advance`
        then integrates in the compiled kernel, which evaluates a(t) in the same
        operation order. The Horner fallback (higher degrees) has no ``poly``."""
        hs, t0 = self._hs, self._t0
        ax = [c / hs ** (j + 2) for j, c in enumerate(self._ddx)]
        ay = [c / hs ** (j + 2) for j, c in enumerate(self._ddy)]
        if len(ax) > 4 or len(ay) > 4:
            horner = self._horner
            return lambda t: (horner(ax, t - t0), horner(ay, t - t0))
        x0, x1, x2, x3 = ax + [0.0] * (4 - len(ax))
        y0, y1, y2, y3 = ay + [0.0] * (4 - len(ay))

        def accel(t):
            s = t - t0
            return x0 + s * (x1 + s * (x2 + s * x3)), y0 + s * (y1 + s * (y2 + s * y3))
        accel.poly = (float(t0), (float(x0), float(x1), float(x2), float(x3)),
                      (float(y0), float(y1), float(y2), float(y3)))
        return accel

    _INVERSES: dict = {}  # constraint pattern -> inverse matrix; equal spacing repeats one pattern
    _ROWS: dict = {}  # (derivatives?, exact taus) -> the inverse, as _fit uses it

    @classmethod
    def _inverse_rows(cls, deriv, taus):
        rows = []
        for tau in taus:
            rows.append((0, tau))
            if deriv:
                rows += ((1, tau), (2, tau))
        inv = cls._inverse(tuple(rows))
        if len(cls._ROWS) < 1024:
            cls._ROWS[(deriv, taus)] = inv
        return inv

    @classmethod
    def _inverse(cls, rows):
        """Inverse of the confluent Vandermonde matrix of the constraints (derivative order,
        tau): row i asks d^der/dtau^der of sum c_j tau^j at tau_i, with tau rounded to 12
        decimals. Exact (in rationals) for the float matrix, then correctly rounded: rows of
        floats. Cached per pattern."""
        key = tuple((der, round(tau, 12)) for der, tau in rows)
        inv = cls._INVERSES.get(key)
        if inv is None:
            n = len(key)
            M = [[Fraction(math.perm(j, der) * tau ** (j - der)) if j >= der else Fraction(0)
                  for j in range(n)] for der, tau in key]
            inv = tuple(tuple(float(x) for x in row) for row in _exact_inverse(M))
            if len(cls._INVERSES) < 256:
                cls._INVERSES[key] = inv
        return inv

    @staticmethod
    def _deriv(c):
        return tuple([j * c[j] for j in range(1, len(c))]) or (0.0,)

    @staticmethod
    def _horner(c, tau):
        acc = 0.0
        for v in reversed(c):
            acc = acc * tau + v
        return acc

    def prepare(self):
        """Fit the polynomials for the coming step (idempotent)."""
        if self._dirty:
            self._fit()

    def accel(self, t):
        """(ax, ay) [m/s2] at time t (beyond the last sample: extrapolation)."""
        if self._dirty:
            self._fit()
        return self._accel_fn(t)

    def accel_function(self):
        """The current fit's a(t) as a plain function, for an integrator's inner loop."""
        self.prepare()
        return self._accel_fn

    def state(self, t):
        """(x, y, vx, vy, ax, ay) of the reconstructed motion at time t."""
        self.prepare()
        tau = (t - self._t0) / self._hs
        hs = self._hs
        hz = self._horner
        return (hz(self._cx, tau), hz(self._cy, tau), hz(self._dx, tau) / hs, hz(self._dy, tau) / hs,
                hz(self._ddx, tau) / hs**2, hz(self._ddy, tau) / hs**2)


def _dot(row, b):
    """sum(row[j] * b[j]), left to right (the C reconstruction sums in this order)."""
    acc = row[0] * b[0]
    for j in range(1, len(row)):
        acc += row[j] * b[j]
    return acc


def _exact_inverse(M):
    """Inverse of a square matrix of Fractions by Gauss-Jordan elimination (exact)."""
    n = len(M)
    A = [list(row) + [Fraction(int(i == j)) for j in range(n)] for i, row in enumerate(M)]
    for col in range(n):
        piv = next((i for i in range(col, n) if A[i][col] != 0), None)
        if piv is None:
            raise InputError("the input samples do not determine the reconstruction "
                             "(two samples at the same time?)")
        A[col], A[piv] = A[piv], A[col]
        p = A[col][col]
        A[col] = [x / p for x in A[col]]
        for i in range(n):
            f = A[i][col]
            if i != col and f != 0:
                A[i] = [x - f * y for x, y in zip(A[i], A[col])]
    return [row[n:] for row in A]
