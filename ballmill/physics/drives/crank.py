"""Prescribed platform motions: the paper's crank start-up law and simple tests.

A platform motion is any object with ``state(t) -> (x, y, vx, vy, ax, ay)``,
the position of the platform reference point O relative to the crank axis
and its exact first and second derivatives (SI units).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ParameterError


LAWS = ("quadratic", "linear", "scurve", "quintic")  # CrankStartup.law; the kernel's codes 0..3


def _check(name, value, unit, allow_zero=False):
    v = float(value)
    if not math.isfinite(v) or v < 0.0 or (v == 0.0 and not allow_zero):
        expected = "non-negative" if allow_zero else "positive"
        raise ParameterError(f"{name} must be {expected} and finite, got {name} = {value!r} {unit}")
    return v


def rise_angle(law: str, w0: float, t0: float, t: float):
    """(angle, rate, acceleration) at time t of a speed rise from rest at t = 0 to the rate
    w0 [rad/s] in t0 [s] along ``law`` (one of LAWS, formulas in `CrankStartup`), w0
    kept after t0, at rest before t = 0. CrankStartup's crank law; also the frame law of
    the Fig. 1 machine (turning/motions.py, SpeedRise). The native drive models mirror
    it operation for operation (ballmill/physics/crank_law.h)."""
    if t < 0.0:
        return 0.0, 0.0, 0.0
    if law == "quadratic":
        if t <= t0:
            # the paper's -w0 (t - t0)^3 / (3 t0^2) + w0 t - w0 t0 / 3 multiplied out: its three
            # terms of size w0 t0 / 3 cancel near t = 0 (psi(0) = -8.9e-16 rad, and relative
            # errors of 1e-8 at t = 1e-4 s); this form is exactly 0 at t = 0 and rounds only
            # to an ulp or two of psi everywhere
            s = t / t0
            u = 1.0 - s
            return (w0 * t0 * s * s * (1.0 - s / 3.0), w0 * (1.0 - u * u), 2.0 * w0 * u / t0)
        return 2.0 / 3.0 * w0 * t0 + w0 * (t - t0), w0, 0.0
    if t > t0:
        return 0.5 * w0 * t0 + w0 * (t - t0), w0, 0.0
    s = t / t0
    if law == "linear":
        return 0.5 * w0 * t0 * s * s, w0 * s, w0 / t0
    if law == "scurve":
        return (w0 * t0 * s * s * s * (1.0 - 0.5 * s), w0 * s * s * (3.0 - 2.0 * s),
                6.0 * w0 * s * (1.0 - s) / t0)
    # quintic
    u = 1.0 - s
    return (w0 * t0 * s ** 4 * (2.5 - 3.0 * s + s * s), w0 * s ** 3 * (10.0 - 15.0 * s + 6.0 * s * s),
            30.0 * w0 * s * s * u * u / t0)


@dataclass(frozen=True)
class CrankStartup:
    """The paper's start-up law: the crank's angular speed rises quadratically
    from 0 to w0 = 2 pi n0 / 60 in t0 seconds, then stays at w0.

        psi   = -w0 (t - t0)^3 / (3 t0^2) + w0 t - w0 t0 / 3,   t <= t0
              = w0 t0 s^2 (1 - s/3), s = t/t0  (computed so: exactly 0 at t = 0)
        psi   = 2/3 w0 t0 + w0 (t - t0),                        t >  t0
        psi'  = w0 (1 - (1 - t/t0)^2),   psi'' = 2 w0 (1 - t/t0) / t0   (t <= t0)

    The platform point O moves on a circle of radius l: x = l cos psi, y = l sin psi.
    Before t = 0 the crank is at rest; at t = 0 the law's right-hand limits apply
    (psi''(0) = 2 w0 / t0).

    ``law`` chooses the shape of the rise (tau = t / t0; all reach w0 at t0 and
    keep w0 after it, psi = c w0 t0 + w0 (t - t0)):
        "quadratic"  the paper's: psi' = w0 (1 - (1 - tau)^2)           c = 2/3
        "linear"     constant acceleration: psi' = w0 tau                 c = 1/2
        "scurve"     zero acceleration at both ends: psi' = w0 tau^2 (3 - 2 tau),
                     psi'' = 6 w0 tau (1 - tau) / t0                      c = 1/2
        "quintic"    also zero jerk at both ends:
                     psi' = w0 tau^3 (10 - 15 tau + 6 tau^2),
                     psi'' = 30 w0 tau^2 (1 - tau)^2 / t0                 c = 1/2
    """

    l: float = 0.5  # crank length [m]
    n0: float = 60.0  # steady crank speed [1/min]
    t0: float = 2.5  # start-up time [s]
    law: str = "quadratic"  # shape of the speed rise, one of LAWS

    def __post_init__(self):
        _check("l", self.l, "m")
        _check("n0", self.n0, "1/min", allow_zero=True)
        _check("t0", self.t0, "s")
        if self.law not in LAWS:
            raise ParameterError(f"law must be one of {', '.join(LAWS)}, got law = {self.law!r}")

    @property
    def w0(self) -> float:
        """Steady angular speed [rad/s]."""
        return 2.0 * math.pi * self.n0 / 60.0

    def angle(self, t: float):
        """(psi, psi', psi'') at time t [rad, rad/s, rad/s2]."""
        return rise_angle(self.law, self.w0, self.t0, t)

    def angles(self, t):
        """`angle` over an array of times: (psi, psi', psi'') as arrays (numpy; for studies,
        which need the drive's kinematics at every output sample)."""
        import numpy as np

        t = np.asarray(t, dtype=float)
        w0, t0 = self.w0, self.t0
        s = t / t0
        np.minimum(np.maximum(s, 0.0, out=s), 1.0, out=s)  # np.clip's values, without its wrapper's cost
        u = 1.0 - s
        if self.law == "quadratic":
            c, rise = 2.0 / 3.0, (w0 * t0 * s * s * (1.0 - s / 3.0), w0 * (1.0 - u * u), 2.0 * w0 * u / t0)
        else:
            c = 0.5
            rise = {"linear": lambda: (0.5 * w0 * t0 * s * s, w0 * s, np.full_like(s, w0 / t0)),
                    "scurve": lambda: (w0 * t0 * s ** 3 * (1.0 - 0.5 * s), w0 * s * s * (3.0 - 2.0 * s),
                                       6.0 * w0 * s * u / t0),
                    "quintic": lambda: (w0 * t0 * s ** 4 * (2.5 - 3.0 * s + s * s),
                                        w0 * s ** 3 * (10.0 - 15.0 * s + 6.0 * s * s),
                                        30.0 * w0 * s * s * u * u / t0)}[self.law]()
        before = t <= t0
        psi = np.where(before, rise[0], c * w0 * t0 + w0 * (t - t0))
        wd = np.where(before, rise[1], w0)
        wdd = np.where(before, rise[2], 0.0)
        neg = t < 0.0
        if not neg.any():  # a run's samples: t >= 0
            return psi, wd, wdd
        return np.where(neg, 0.0, psi), np.where(neg, 0.0, wd), np.where(neg, 0.0, wdd)

    def state(self, t: float):
        """(x, y, vx, vy, ax, ay) of the platform point O at time t."""
        psi, wd, wdd = self.angle(t)
        c, s, l = math.cos(psi), math.sin(psi), self.l
        return (l * c, l * s, -l * s * wd, l * c * wd,
                -l * (s * wdd + c * wd * wd), l * (c * wdd - s * wd * wd))

    def accel(self, t: float):
        """(ax, ay) at time t, for the integrator's inner loop."""
        return self.state(t)[4:]


@dataclass(frozen=True)
class Fixed:
    """A chamber that does not move (for energy and pendulum checks)."""

    def state(self, t: float):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0

    def accel(self, t: float):
        return 0.0, 0.0


@dataclass(frozen=True)
class Harmonic:
    """O moves as x = ax_amp sin(wx t + phx), y = ay_amp sin(wy t + phy) [m, rad/s]."""

    x_amp: float = 0.0
    x_omega: float = 0.0
    y_amp: float = 0.0
    y_omega: float = 0.0
    x_phase: float = 0.0
    y_phase: float = 0.0

    def state(self, t: float):
        sx, cx = math.sin(self.x_omega * t + self.x_phase), math.cos(self.x_omega * t + self.x_phase)
        sy, cy = math.sin(self.y_omega * t + self.y_phase), math.cos(self.y_omega * t + self.y_phase)
        return (self.x_amp * sx, self.y_amp * sy,
                self.x_amp * self.x_omega * cx, self.y_amp * self.y_omega * cy,
                -self.x_amp * self.x_omega**2 * sx, -self.y_amp * self.y_omega**2 * sy)

    def accel(self, t: float):
        return self.state(t)[4:]


@dataclass(frozen=True)
class Circle:
    """O moves on a circle of radius l at constant angular speed w [rad/s] (no start-up)."""

    l: float = 0.5
    w: float = 2.0 * math.pi

    def state(self, t: float):
        c, s = math.cos(self.w * t), math.sin(self.w * t)
        l, w = self.l, self.w
        return l * c, l * s, -l * w * s, l * w * c, -l * w * w * c, -l * w * w * s

    def accel(self, t: float):
        return self.state(t)[4:]
