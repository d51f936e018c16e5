"""The quasi-static calculator: the ball's relative equilibrium on the crank circle.

Once the crank turns at a constant w = 2 pi n0 / 60, the platform point O runs
on a circle of radius l and its acceleration a_O = -w^2 l (cos wt, sin wt) is
constant in a frame that turns with the crank about the vertical. In that
frame the equations of motion (docs/design.md section 2, `VectorFormulation`) are
autonomous:

    n_r'     = lambda n_r x omega_r - W x n_r
    omega_r' = k n_r x (a_r - g + r (lambda n_r x omega_r) x omega_r) - W x omega_r

with W = (0, 0, w) and a_r = (-w^2 l, 0, 0) (the crank along x). A relative
equilibrium is a fixed point: the ball goes round with the crank at a fixed
polar angle theta_e from the bottom and a fixed phase phi_e behind the crank.
For a ball started without spin, omega . n = 0 for ever (the spin about n is
conserved), and n_r' = 0 gives omega = -(1/lambda) W_perp (W_perp: the part of W
perpendicular to n); the omega' equation then leaves two equations for
(theta, phi), solved here by Newton's method (scipy's fsolve) from a start
that follows the branch from rest upward in speed.

What `equilibrium` reports, all from the library's own equations and outputs:
theta_e, phi_e, the contact point (its radius in Oxy, its height), N_e, the
friction ratio |F_t|/N and the reaction torque; the small oscillations about it
(the "ring" the contact point draws after a start-up that is not slow enough):
the eigenvalues of the linearised rotating-frame system (+-i w_1, +-i w_2 on the
constraint manifold |n| = 1, omega . n = 0); and the fill level of the ground
material at which the ball's path dips into it. `limits` finds the crank
speeds at which rolling (|F_t| = mu N) or contact (N = 0) would be lost on the
equilibrium branch.

Pure functions, SI units, no I/O; `ballmill steady` prints them.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .equations import VectorFormulation
from .errors import ParameterError
from .outputs import evaluate
from .params import Ball


@dataclass(frozen=True)
class Equilibrium:
    """The relative equilibrium of the ball on the crank circle (SI units, angles in degrees)."""

    n0: float  # crank speed [1/min]
    l: float  # crank length [m]
    theta_deg: float  # polar angle of the ball centre (and contact point) from the bottom
    phi_deg: float  # azimuth of the ball relative to the crank direction (0: outward along the crank)
    rho_P: float  # radius of the contact point in Oxy [m]
    zP: float  # height of the contact point [m]
    N: float  # normal force [N]
    friction_ratio: float  # |F_t| / N [1]
    mu: float
    rolling: bool  # friction_ratio <= mu and N > 0
    M_reaction: float  # torque of the ball on the crank shaft [N m]
    ring_frequencies: tuple  # angular frequencies of the small oscillations in the turning frame [rad/s]
    ball_lowest: float  # height of the ball's lowest point above the chamber's lowest point [m]
    n: tuple  # unit vector A -> C in the turning frame (crank along x)
    omega: tuple  # the ball's angular velocity in that frame [rad/s]

    def to_dict(self) -> dict:
        return asdict(self)


def _check(name, v, unit, positive=True):
    if not (isinstance(v, (int, float)) and math.isfinite(v) and (v > 0 if positive else v >= 0)):
        raise ParameterError(f"{name} must be {'positive' if positive else 'non-negative'} and finite, "
                             f"got {name} = {v!r} {unit}")
    return float(v)


class _Turning:
    """The equations in the frame turning with the crank."""

    def __init__(self, ball: Ball, l: float, w: float):
        self.form = VectorFormulation(ball.with_(rolling_resistance=0.0, drag=0.0))
        self.ball, self.l, self.w = ball, l, w
        self.a = (-w * w * l, 0.0)

    def f(self, y):
        d = np.array(self.form.derivative(list(map(float, y)), *self.a))
        n, om = y[:3], y[3:]
        W = np.array([0.0, 0.0, self.w])
        d[:3] -= np.cross(W, n)
        d[3:] -= np.cross(W, om)
        return d

    def state(self, theta, phi):
        st, ct = math.sin(theta), math.cos(theta)
        n = np.array([st * math.cos(phi), st * math.sin(phi), -ct])
        W = np.array([0.0, 0.0, self.w])
        om = -(W - n * (n @ W)) / self.ball.lam
        return np.concatenate([n, om])

    def residual(self, x):
        theta, phi = x
        y = self.state(theta, phi)
        r = self.f(y)[3:]
        # omega' lies in the plane perpendicular to n: two tangent components
        n = y[:3]
        e1 = np.array([math.cos(theta) * math.cos(phi), math.cos(theta) * math.sin(phi), math.sin(theta)])
        e2 = np.cross(n, e1)
        return [r @ e1, r @ e2]


def _solve(tf: _Turning, guess):
    from scipy.optimize import fsolve

    x, info, ier, msg = fsolve(tf.residual, guess, full_output=True, xtol=1e-13)
    if max(abs(v) for v in tf.residual(x)) > 1e-9 * (1.0 + tf.w ** 2 * tf.l / tf.ball.r):
        raise ArithmeticError(f"no relative equilibrium found near theta = {math.degrees(guess[0]):.4g} deg: {msg}")
    return x


def _continue(ball: Ball, l: float, w: float, x):
    """(theta, phi) at crank speed w [rad/s] from the solution x at a nearby lower speed
    (None: from rest)."""
    tf = _Turning(ball, l, w)
    if x is None or x[0] < 1e-2:  # small speeds: the linear answer tan theta ~ w^2 l / g, phi ~ 0
        x = np.array([math.atan(w * w * l / ball.g), 0.0])
    return _solve(tf, x)


def _result(ball: Ball, l: float, n0: float, x) -> Equilibrium:
    theta, phi = float(x[0]), float(x[1])
    tf = _Turning(ball, l, 2.0 * math.pi * n0 / 60.0)
    y = tf.state(theta, phi)
    n, om = y[:3], y[3:]
    # outputs at the instant the crank points along x (xO = l, yO = 0)
    out = evaluate(ball.with_(rolling_resistance=0.0, drag=0.0), tuple(n), tuple(om), tf.a[0], tf.a[1], l, 0.0)
    return Equilibrium(
        n0=n0, l=l, theta_deg=math.degrees(theta), phi_deg=math.degrees(phi),
        rho_P=ball.R * math.hypot(n[0], n[1]), zP=ball.R * (1.0 + n[2]), N=out.N,
        friction_ratio=out.friction_ratio, mu=ball.mu, rolling=bool(out.rolling), M_reaction=out.M_reaction,
        ring_frequencies=tuple(_frequencies(tf, y)), ball_lowest=ball.d * (1.0 + n[2]),
        n=tuple(float(v) for v in n), omega=tuple(float(v) for v in om))


def equilibrium(ball: Ball | None = None, l: float = 0.5, n0: float = 60.0) -> Equilibrium:
    """The relative equilibrium at crank speed n0 [1/min] on a crank of length l [m],
    followed by continuation in speed from rest (so that the branch is the one a
    slow start-up reaches). Raises ArithmeticError when the branch cannot be followed."""
    ball = ball or Ball()
    l = _check("l", l, "m")
    n0 = _check("n0", n0, "1/min")
    w_end = 2.0 * math.pi * n0 / 60.0
    k = max(8, int(math.ceil(n0 / 5.0)))
    x = None
    for w in np.linspace(w_end / k, w_end, k):
        x = _continue(ball, l, w, x)
    return _result(ball, l, n0, x)
def _frequencies(tf: _Turning, y) -> list[float]:
    """Angular frequencies of the small oscillations about the fixed point y, from the
    Jacobian restricted to the constraint manifold (|n| = 1, omega . n = 0): the tangent
    space is 4-dimensional, the eigenvalues there are +-i w_1, +-i w_2 (sorted, highest first)."""
    n, om = y[:3], y[3:]
    # a basis of the tangent space: dn perpendicular to n (2), and domega with
    # n . domega + dn . omega = 0 (3 - 1 = 2 free), 4 in all... plus the spin directions
    # excluded. Build it as the null space of the constraint gradients.
    G = np.zeros((2, 6))
    G[0, :3] = n  # d|n|^2 / 2
    G[1, :3], G[1, 3:] = om, n  # d(n . omega)
    _, _, vt = np.linalg.svd(G)
    T = vt[2:].T  # 6 x 4, orthonormal
    eps = 1e-7
    J = np.empty((6, 4))
    for j in range(4):
        J[:, j] = (tf.f(y + eps * T[:, j]) - tf.f(y - eps * T[:, j])) / (2 * eps)
    ev = np.linalg.eigvals(T.T @ J)
    freqs = sorted({round(abs(float(e.imag)), 9) for e in ev if abs(e.imag) > 1e-6}, reverse=True)
    return freqs


def limits(ball: Ball | None = None, l: float = 0.5, n_max: float = 300.0, dn: float = 1.0) -> dict:
    """Where the equilibrium branch stops being a rolling ball, scanning the crank speed
    from dn to n_max [1/min] in steps of dn (continuation) and refining by bisection:
    ``rolling_lost_n0`` (first speed with friction_ratio > mu), ``contact_lost_n0``
    (N <= 0), ``branch_end_n0`` (no equilibrium could be followed beyond), each None when
    it does not happen below n_max; and the branch's largest friction ratio
    (``friction_ratio_peak`` at ``friction_ratio_peak_n0``: the smallest mu that keeps the
    ball rolling at every steady speed up to n_max)."""
    ball = ball or Ball()
    l = _check("l", l, "m")
    found = {"rolling_lost_n0": None, "contact_lost_n0": None, "branch_end_n0": None,
             "friction_ratio_peak": 0.0, "friction_ratio_peak_n0": None, "n_max": n_max}
    tests = {"rolling_lost_n0": lambda e: not (e.friction_ratio <= e.mu),
             "contact_lost_n0": lambda e: not (e.N > 0)}
    x, prev, n = None, None, dn
    while n <= n_max * (1 + 1e-12):
        try:
            x_new = _continue(ball, l, 2.0 * math.pi * n / 60.0, x)
        except ArithmeticError:
            found["branch_end_n0"] = n
            break
        eq = _result(ball, l, n, x_new)
        if eq.friction_ratio > found["friction_ratio_peak"]:
            found["friction_ratio_peak"], found["friction_ratio_peak_n0"] = float(eq.friction_ratio), n
        for key, bad in tests.items():
            if found[key] is None and bad(eq) and prev is not None and not bad(prev):
                lo, hi, xl = n - dn, n, x
                for _ in range(30):
                    mid = 0.5 * (lo + hi)
                    xm = _continue(ball, l, 2.0 * math.pi * mid / 60.0, xl)
                    if bad(_result(ball, l, mid, xm)):
                        hi = mid
                    else:
                        lo, xl = mid, xm
                found[key] = 0.5 * (lo + hi)
        x, prev = x_new, eq
        n += dn
    return found
