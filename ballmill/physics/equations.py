"""Equations of motion of the ball, in two formulations (docs/design.md section 2).

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

Losses to the ground material (``Ball.rolling_resistance`` = delta [m],
``Ball.drag`` = c [N s/m]; both 0 by default, and then the lossless code
above runs unchanged). With a moment M on the ball about its centre and a
force F_d on its centre, Newton and Euler (F the contact force at
P = C + r n) read

    m a_C = F + m g_vec + F_d,      I omega' = r n x F + M.

With a_C = a_O + d n'' and d n'' = r (n' x omega + n x omega'), F drops out:

    (I + m r^2) omega' - m r^2 n (n . omega')
        = m r n x (a_O - g_vec + r n' x omega) - r n x F_d + M.

Dotting with n gives I n . omega' = n . M = 0 for the moment below (it is
perpendicular to n), so the spin omega . n stays constant and

    omega' = k n x (a_O - g_vec + r n' x omega - F_d / m) + M / (I + m r^2).

* drag: F_d = -c v_C,rel = -c d n', i.e. (c d / m) n' joins the bracket;
* rolling resistance: M = -delta N w_t / sqrt(|w_t|^2 + eps^2), with
  w_t = omega - (omega . n) n the rolling part of omega (the chamber does not
  rotate, so omega is also the angular velocity relative to the wall) and
  N = -F . n = m (d |n'|^2 - a_O . n - g n_z). N involves neither omega'
  (n'' . n = -|n'|^2) nor F_d (n' . n = 0): the moment is explicit. Only a
  pressing wall resists (N > 0; without contact the model is invalid anyway).

Regularisation: eps = ROLLING_EPS = 1e-3 rad/s. The moment is odd and smooth
in w_t and zero at w_t = 0, so a ball at rest at the bottom stays at rest
exactly; above |w_t| = 10 eps (a centre speed of 0.25 mm/s for r = 25 mm)
its size is within 0.5 % of delta N. Near rest it acts as a viscous moment
delta N / eps: relaxation time (I + m r^2) eps / (delta N), 0.9 ms for the
paper's ball with delta = 0.1 mm, which the explicit integrators follow with
ordinary steps (a sign function would chatter, a much smaller eps would make
the equations stiff at rest). The price: a ball that exact Coulomb-type
rolling resistance would hold at rest at an angle theta from the bottom of
a fixed chamber creeps instead, at |w_t| = eps r tan(theta) / delta (the
centre moves at r |w_t|), e.g. 0.03 mm/s for theta = 0.01 rad, delta = 0.1 mm.

The material bed (``Ball.bed_depth`` = h, ``Ball.bed_band`` = w; docs/design.md
section 2). By default (h None) the material fills the chamber and both
resistances act wherever the ball touches the wall. With a bed, the material's
free surface is the horizontal plane z_P = h, z_P = R (1 + n_z) the contact
point's height above the chamber's lowest point (the chamber translates: its
axes stay the fixed ones, so the surface stays horizontal), and both
resistances are multiplied by the share s = `bed_share`, a function of n_z
alone:

    x = (h - z_P) / w,   s = 0 (x <= 0),   s = 1 (x >= 1),
    s = 1 / (1 + exp(1/x - 1/(1 - x)))   between,

the standard C-infinity step: every derivative is continuous everywhere (and
0 at both edges of the band), so the right-hand side stays as smooth as the
integrators' order needs, and the resistance is exactly 0 above the surface
and exactly its full value deeper than w below it. |ds/dz_P| <= 2/w (at the
band's middle): the band adds no stiffness, only a length scale the steps
must resolve (w/|z_P'|, about 30 ms for w = 10 mm at the paper's speeds).
The drag and the rolling resistance are both scaled: c -> s c, delta -> s delta
(N and the spin argument above hold unchanged, s depending on n only).
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


ROLLING_EPS = 1e-3  # rad/s: regularisation of w_t / |w_t| in the rolling resistance


def loss_constants(ball: Ball):
    """Constants of the lossy right-hand side: (k, r, g, m, d, c d / m, delta,
    I + m r^2, eps^2)."""
    return (ball.k, ball.r, ball.g, ball.m, ball.d, ball.drag * ball.d / ball.m,
            ball.rolling_resistance, ball.I + ball.m * ball.r ** 2, ROLLING_EPS ** 2)


def bed_constants(ball: Ball):
    """(R, h, w) of the ball's material bed, or None when the material fills the chamber
    (``Ball.bed_depth`` None: the resistances act wherever the ball touches the wall)."""
    return None if ball.bed_depth is None else (ball.R, ball.bed_depth, ball.bed_band)


def bed_share(bed, nz) -> float:
    """The share s of the material's resistance acting at the contact point of unit vector
    n (n_z alone matters), for bed = bed_constants(ball) = (R, h, w): 1 deeper than w below
    the bed's surface z_P = h, 0 above it, the C-infinity step 1 / (1 + exp(1/x - 1/(1 - x)))
    of x = (h - z_P) / w between (module docstring). 1 when bed is None."""
    if bed is None:
        return 1.0
    R, h, w = bed
    x = (h - R * (1.0 + nz)) / w
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    e = 1.0 / x - 1.0 / (1.0 - x)
    if e > 0.0:  # exp(-e) <= 1: no overflow on either side of the band
        q = math.exp(-e)
        return q / (1.0 + q)
    q = math.exp(e)
    return 1.0 / (1.0 + q)


def omega_dot_lossy(c, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, bed=None):
    """omega' with drag and rolling resistance (module docstring), for the
    constants c = loss_constants(ball); with a material bed (bed = bed_constants(ball)
    not None) both scaled by its share `bed_share` at n."""
    k, r, g, m, d, cd, delta, J, eps2 = c
    if bed is not None:
        s = bed_share(bed, nz)
        cd, delta = cd * s, delta * s
    bx = ax + r * (ndy * wz - ndz * wy) + cd * ndx
    by = ay + r * (ndz * wx - ndx * wz) + cd * ndy
    bz = g + r * (ndx * wy - ndy * wx) + cd * ndz
    wdx, wdy, wdz = k * (ny * bz - nz * by), k * (nz * bx - nx * bz), k * (nx * by - ny * bx)
    if delta:
        N = m * (d * (ndx * ndx + ndy * ndy + ndz * ndz) - ax * nx - ay * ny - g * nz)
        if N > 0.0:
            s = nx * wx + ny * wy + nz * wz
            tx, ty, tz = wx - s * nx, wy - s * ny, wz - s * nz
            f = -delta * N / (J * math.sqrt(tx * tx + ty * ty + tz * tz + eps2))
            wdx, wdy, wdz = wdx + f * tx, wdy + f * ty, wdz + f * tz
    return wdx, wdy, wdz


def _lossy(ball: Ball) -> bool:
    return bool(getattr(ball, "rolling_resistance", 0.0) or getattr(ball, "drag", 0.0))


class VectorFormulation:
    """State (nx, ny, nz, wx, wy, wz); valid everywhere on the sphere."""

    name = "vector"
    ndim = 6
    labels = ("nx", "ny", "nz", "wx", "wy", "wz")

    def __init__(self, ball: Ball):
        self.ball = ball

    @property
    def ball(self) -> Ball:
        return self._ball

    @ball.setter
    def ball(self, ball: Ball):
        # Ball is frozen: its derived constants are read once, not at every call
        self._ball = ball
        self._consts = (ball.lam, ball.r, ball.g, ball.k)
        # losses: a separate right-hand side, so that the lossless one stays as it is
        self.__dict__.pop("derivative", None)
        if _lossy(ball):
            self._loss = loss_constants(ball)
            self._bed = bed_constants(ball)
            self.derivative = self._derivative_lossy

    def _derivative_lossy(self, y, ax, ay):
        """dy/dt with the ground material's losses (Ball.rolling_resistance, Ball.drag, where
        its bed lies: Ball.bed_depth)."""
        nx, ny, nz, wx, wy, wz = y
        lam = self._consts[0]
        ndx = lam * (ny * wz - nz * wy)
        ndy = lam * (nz * wx - nx * wz)
        ndz = lam * (nx * wy - ny * wx)
        return (ndx, ndy, ndz) + omega_dot_lossy(self._loss, nx, ny, nz, wx, wy, wz,
                                                 ndx, ndy, ndz, ax, ay, self._bed)

    def derivative(self, y, ax, ay):
        """dy/dt as a tuple, for platform acceleration (ax, ay) [m/s2]."""
        nx, ny, nz, wx, wy, wz = y
        lam, r, g, k = self._consts
        ndx = lam * (ny * wz - nz * wy)
        ndy = lam * (nz * wx - nx * wz)
        ndz = lam * (nx * wy - ny * wx)
        # omega_dot(k, r, g, ...) written out: the same expressions, without the call
        bx = ax + r * (ndy * wz - ndz * wy)
        by = ay + r * (ndz * wx - ndx * wz)
        bz = g + r * (ndx * wy - ndy * wx)
        return (ndx, ndy, ndz,
                k * (ny * bz - nz * by), k * (nz * bx - nx * bz), k * (nx * by - ny * bx))

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
        if cramer and _lossy(ball):
            raise ValueError("cramer=True solves the paper's lossless 3x3 system only; with "
                             "rolling_resistance or drag use cramer=False (closed form)")

    @property
    def ball(self) -> Ball:
        return self._ball

    @ball.setter
    def ball(self, ball: Ball):
        # Ball is frozen: its derived constants are read once, not at every call
        self._ball = ball
        self._consts = (ball.lam, ball.d, ball.r, ball.g, ball.k)
        # losses: a separate right-hand side, so that the lossless one stays as it is
        self.__dict__.pop("derivative", None)
        if _lossy(ball):
            self._loss = loss_constants(ball)
            self._bed = bed_constants(ball)
            self.derivative = self._derivative_lossy

    def _derivative_lossy(self, y, ax, ay):
        """dy/dt with the ground material's losses (closed form; see the module docstring)."""
        xC, yC, wx, wy, wz = y
        lam, d = self._consts[0], self._consts[1]
        s = self._depth(xC, yC)
        xd = lam * (wy * s + wz * yC)
        yd = -lam * (wx * s + wz * xC)
        zd = (xC * xd + yC * yd) / s
        return (xd, yd) + omega_dot_lossy(self._loss, xC / d, yC / d, -s / d, wx, wy, wz,
                                          xd / d, yd / d, zd / d, ax, ay, self._bed)

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
        lam, d, r, g, k = self._consts
        s2 = d * d - xC * xC - yC * yC
        s = math.sqrt(s2) if s2 > 0.0 else self._depth(xC, yC)  # _depth raises the clear error
        xd = lam * (wy * s + wz * yC)
        yd = -lam * (wx * s + wz * xC)
        if self.cramer:
            return (xd, yd) + omega_dot_cramer(self._ball, xC, yC, wx, wy, wz, ax, ay)
        zd = (xC * xd + yC * yd) / s
        nx, ny, nz = xC / d, yC / d, -s / d
        ndx, ndy, ndz = xd / d, yd / d, zd / d
        # omega_dot(k, r, g, ...) written out: the same expressions, without the call
        bx = ax + r * (ndy * wz - ndz * wy)
        by = ay + r * (ndz * wx - ndx * wz)
        bz = g + r * (ndx * wy - ndy * wx)
        return (xd, yd, k * (ny * bz - nz * by), k * (nz * bx - nx * bz), k * (nx * by - ny * bx))

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
