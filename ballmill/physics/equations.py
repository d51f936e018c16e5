"""Equations of motion of the ball, in two formulations (DESIGN.md section 2).

Both describe the same system: a ball rolling without slip on the inside of
a sphere that translates with a prescribed horizontal acceleration a_O.

* ``VectorFormulation`` (default): state y = (n, omega), n the unit vector
  from the chamber centre to the ball centre, omega the absolute angular
  velocity. Valid on the whole sphere.

      n'     = lambda n x omega
      omega' = k n x (a_O - g + r n' x omega),   k = m r / (I + m r^2)

* ``PaperFormulation``: the seed paper's coordinates y = (xC, yC, wx, wy, wz)
  with zC = R - sqrt(d^2 - xC^2 - yC^2), eq. (1) and (6). Only the lower
  hemisphere; it raises `FormulationLimitError` before the ball reaches the
  equator, where R - zC -> 0 makes (xC, yC) singular.

Also here, for cross-checks and the benchmark: the paper's own way of getting
omega', a 3x3 linear system solved by Cramer's rule at every evaluation
(`omega_dot_cramer`), derived anew from eq. (10)-(12) (the printed
determinants have typos).

The kernels are scalar Python on purpose: for six states, float arithmetic
beats numpy's per-call overhead.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import FormulationLimitError
from .params import Ball


def omega_dot(ball_k, r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay):
    """Closed-form omega' = k n x (a_O - g_vec + r n' x omega), g_vec = (0, 0, -g)."""
    bx = ax + r * (ndy * wz - ndz * wy)
    by = ay + r * (ndz * wx - ndx * wz)
    bz = g + r * (ndx * wy - ndy * wx)
    return (ball_k * (ny * bz - nz * by),
            ball_k * (nz * bx - nx * bz),
            ball_k * (nx * by - ny * bx))


def omega_dot_cramer(ball: Ball, xC, yC, wx, wy, wz, ax, ay):
    """omega' of the paper's formulation, from eq. (11)-(12) and Cramer's rule.

    Eq. (11) gives omega' = alpha rho x (a_O + g e_z + a_C,rel) with
    rho = (xC, yC, zC - R), alpha = lambda m / I. The relative acceleration
    a_C,rel = lambda (v_C x omega + rho x omega') depends on omega', so
    omega' solves A omega' = b with A = 1 - alpha lambda [rho]x[rho]x and
    b = alpha rho x (a_O + g e_z + lambda v_C x omega). Solved here the way
    the paper does it: determinants, every call.
    """
    lam = ball.lam
    s = math.sqrt(ball.d**2 - xC * xC - yC * yC)  # R - zC
    px, py, pz = xC, yC, -s
    alpha = lam * ball.m / ball.I
    # v_C = lambda rho x omega  (eq. 6)
    vx = lam * (py * wz - pz * wy)
    vy = lam * (pz * wx - px * wz)
    vz = lam * (px * wy - py * wx)
    cx = ax + lam * (vy * wz - vz * wy)
    cy = ay + lam * (vz * wx - vx * wz)
    cz = ball.g + lam * (vx * wy - vy * wx)
    b1 = alpha * (py * cz - pz * cy)
    b2 = alpha * (pz * cx - px * cz)
    b3 = alpha * (px * cy - py * cx)
    # [rho]x[rho]x = rho rho^T - |rho|^2 1
    q = alpha * lam
    p2 = px * px + py * py + pz * pz
    a11 = 1.0 - q * (px * px - p2)
    a22 = 1.0 - q * (py * py - p2)
    a33 = 1.0 - q * (pz * pz - p2)
    a12 = a21 = -q * px * py
    a13 = a31 = -q * px * pz
    a23 = a32 = -q * py * pz
    det = (a11 * a22 * a33 + a12 * a23 * a31 + a21 * a32 * a13
           - a31 * a22 * a13 - a21 * a12 * a33 - a32 * a23 * a11)
    d1 = (b1 * a22 * a33 + a12 * a23 * b3 + b2 * a32 * a13
          - b3 * a22 * a13 - b2 * a12 * a33 - a32 * a23 * b1)
    d2 = (a11 * b2 * a33 + b1 * a23 * a31 + a21 * b3 * a13
          - a31 * b2 * a13 - a21 * b1 * a33 - b3 * a23 * a11)
    d3 = (a11 * a22 * b3 + a12 * b2 * a31 + a21 * a32 * b1
          - a31 * a22 * b1 - a21 * a12 * b3 - a32 * b2 * a11)
    return d1 / det, d2 / det, d3 / det


class VectorFormulation:
    """State (nx, ny, nz, wx, wy, wz); valid everywhere on the sphere."""

    name = "vector"
    ndim = 6
    labels = ("nx", "ny", "nz", "wx", "wy", "wz")

    def __init__(self, ball: Ball):
        self.ball = ball

    def derivative(self, y, ax, ay):
        """dy/dt as a tuple, for platform acceleration (ax, ay) [m/s2]."""
        nx, ny, nz, wx, wy, wz = y
        lam = self.ball.lam
        ndx = lam * (ny * wz - nz * wy)
        ndy = lam * (nz * wx - nx * wz)
        ndz = lam * (nx * wy - ny * wx)
        b = self.ball
        return (ndx, ndy, ndz) + omega_dot(b.k, b.r, b.g, nx, ny, nz, wx, wy, wz,
                                           ndx, ndy, ndz, ax, ay)

    def to_nw(self, y):
        """(n, omega) as two tuples."""
        return (y[0], y[1], y[2]), (y[3], y[4], y[5])

    def from_nw(self, n, w):
        return np.array([n[0], n[1], n[2], w[0], w[1], w[2]], dtype=float)

    def project(self, y):
        """Put n back on the unit sphere (after an accepted step)."""
        s = 1.0 / math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
        y[0] *= s
        y[1] *= s
        y[2] *= s
        return y

    def check(self, y):
        """Vector coordinates have no singularity: nothing to refuse."""


class PaperFormulation:
    """The paper's state (xC, yC, wx, wy, wz), lower hemisphere only.

    ``equator_margin`` is the smallest allowed (R - zC)/(R - r) = -n_z; below
    it `check` (called after every accepted step) raises
    `FormulationLimitError`. ``cramer=True`` solves for omega' as the paper
    did (a 3x3 system by Cramer's rule) instead of the closed form.
    """

    name = "paper"
    ndim = 5
    labels = ("xC", "yC", "wx", "wy", "wz")

    def __init__(self, ball: Ball, equator_margin: float = 0.02, cramer: bool = False):
        self.ball = ball
        self.equator_margin = equator_margin
        self.cramer = cramer

    def _depth(self, xC, yC):
        """R - zC = sqrt(d^2 - xC^2 - yC^2), or FormulationLimitError past the equator."""
        d = self.ball.d
        s2 = d * d - xC * xC - yC * yC
        if s2 <= 0.0:
            raise FormulationLimitError(
                f"paper formulation: the ball centre (xC, yC) = ({xC:.6g}, {yC:.6g}) m lies at "
                f"or beyond the chamber's equator (sqrt(xC^2 + yC^2) >= R - r = {d:.6g} m), where "
                f"the paper's coordinates do not exist; use formulation 'vector'")
        return math.sqrt(s2)

    def derivative(self, y, ax, ay):
        xC, yC, wx, wy, wz = y
        b = self.ball
        lam = b.lam
        s = self._depth(xC, yC)
        xd = lam * (wy * s + wz * yC)
        yd = -lam * (wx * s + wz * xC)
        if self.cramer:
            return (xd, yd) + omega_dot_cramer(b, xC, yC, wx, wy, wz, ax, ay)
        d = b.d
        zd = (xC * xd + yC * yd) / s
        nx, ny, nz = xC / d, yC / d, -s / d
        return (xd, yd) + omega_dot(b.k, b.r, b.g, nx, ny, nz, wx, wy, wz,
                                    xd / d, yd / d, zd / d, ax, ay)

    def to_nw(self, y):
        d = self.ball.d
        s = self._depth(y[0], y[1])
        return (y[0] / d, y[1] / d, -s / d), (y[2], y[3], y[4])

    def from_nw(self, n, w):
        if n[2] > -self.equator_margin:
            raise FormulationLimitError(
                f"paper formulation: the ball starts at n_z = {n[2]:.6g}, within the margin "
                f"{self.equator_margin:g} of the chamber's equator (its coordinates need "
                f"n_z < -{self.equator_margin:g}); use formulation 'vector'")
        d = self.ball.d
        return np.array([n[0] * d, n[1] * d, w[0], w[1], w[2]], dtype=float)

    def project(self, y):
        return y

    def check(self, y):
        d = self.ball.d
        s = self._depth(y[0], y[1])
        if s < self.equator_margin * d:
            angle = math.degrees(math.asin(min(1.0, s / d)))
            raise FormulationLimitError(
                f"paper formulation stopped: the ball centre is {angle:.2f} deg below the "
                f"chamber's equator (R - zC = {s:.4g} m < {self.equator_margin:g} (R - r)); "
                f"its coordinates (xC, yC) become singular there. Use formulation 'vector', "
                f"which is valid on the whole sphere")


FORMULATIONS = {"vector": VectorFormulation, "paper": PaperFormulation}


def make_formulation(name: str, ball: Ball, **options):
    """Formulation object by name ('vector' or 'paper')."""
    try:
        cls = FORMULATIONS[name]
    except KeyError:
        raise ValueError(f"formulation must be one of {sorted(FORMULATIONS)}, got {name!r}") from None
    return cls(ball, **options)
