"""Prescribed rigid motions of the chamber (docs/design.md section 10): what it owns.

A chamber motion says, at any time t, where the chamber's centre A is, how it
moves and how the chamber turns, in the fixed frame O1 x1 y1 z1 (z1 up):

* ``state(t)`` -> `ChamberState`: A, v_A, a_A [m, m/s, m/s2], the angular
  velocity Omega and its derivative Omega' [rad/s, rad/s2], the orientation Q
  (chamber axes to fixed axes, row-major, Q' = [Omega]x Q), and the chamber's
  drives (below);
* ``accel(t)`` -> (a_A, Omega, Omega') as 9 floats: all the equations of motion
  need, for the integrator's inner loop.

Drives. A machine that moves the chamber has generalized coordinates q_i
driven by motors (the frame's shaft, the cranks). Each is described at time t
by its rate q_i' and the twist (w_i, v_i) that gives the velocity of any point
X fixed to the chamber per unit rate, dv_X/dq_i' = w_i x X + v_i (X in the
fixed frame, origin O1). A load F_s acting on the chamber at X then gives the
drive the generalized force (the reaction moment it feels)

    M_i = F_s . (w_i x X + v_i) = w_i . (X x F_s) + v_i . F_s,

and the power that the drives deliver through the chamber to whatever exerts
F_s is -sum_i M_i q_i'. A `ChamberState` carries two drives (a motion with one
leaves the second at zero).

Implementations:

* `Translation`: today's platform motions (drives/crank.py: ``state(t) -> (x, y, vx,
  vy, ax, ay)``), the chamber's centre at height ``zA`` above O1, no rotation.
  Its drive is the crank (rate psi', twist about the vertical crank axis
  through O1) when the platform law has one (``angle(t)``, CrankStartup), else
  the x and y motions themselves (the "moments" are then forces, in N).
  Scenes with a `Translation` run on the translation-only model
  (ballmill/physics/model.py), unchanged; the general model (turning/model.py)
  reproduces it bit for bit.
* `Spin`: A fixed, constant angular velocity Omega about an axis through A
  (the spinning bowl, the tumbling drum). One drive: the spin, rate |Omega|.
* `Fig1Machine`: the mill of the paper's Fig. 1. The bearing frame turns about
  the fixed x1 axis by phi(t) (drive 8, the frame shaft; ``shaft="z"``: about the
  vertical z1 axis instead, a turntable); on it the crank
  parallelogram (drive 5) carries the platform on a circle of radius l,
  relative to the frame, with the crank angle psi(t). The chamber's centre is
  A = Rx(phi) a(psi) and its orientation Rx(phi) (a circular translation
  relative to the frame). Crank axes perpendicular to the shaft (default):
  a(psi) = c + (l cos psi, l sin psi, 0); parallel to it:
  a(psi) = c + (0, l cos psi, l sin psi); c (``centre``) is the crank circle's
  centre in the frame's axes (default the origin, on the shaft). Drives: 1 the
  frame (rate phi', twist (e_x, 0): a rotation about the x1 axis through O1), 2
  the cranks (rate psi', twist (0, Rx(phi) da/dpsi): a translation).
  With the vertical shaft, Rz(phi) replaces Rx(phi), the frame's twist is (e_z, 0),
  and the crank circle lies in the frame's yz plane when the crank axes are
  perpendicular to the shaft (a(psi) = c + (0, l cos psi, l sin psi)), in its xy
  plane when parallel (a(psi) = c + (l cos psi, l sin psi, 0)).

Angle laws (``angle(t) -> (angle, rate, acceleration)`` [rad, rad/s, rad/s2]):
drives.crank.CrankStartup (the paper's start-up), `ConstantSpeed` and `SpeedRise`
(CrankStartup's rise shapes to any rate, for the frame).

The arithmetic is written as scalar expressions in a fixed order: the compiled
kernel (_kernel.c, functions bmg_*) mirrors it operation for operation.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, field

from ..drives.crank import LAWS, CrankStartup, rise_angle
from ..errors import ParameterError

_V = ("x", "y", "z")
STATE_FIELDS = (tuple(f"A{c}" for c in _V) + tuple(f"vA{c}" for c in _V) + tuple(f"aA{c}" for c in _V)
                + tuple(f"Om{c}" for c in _V) + tuple(f"Omd{c}" for c in _V)
                + tuple(f"Q{i}{j}" for i in range(3) for j in range(3))
                + ("q1d",) + tuple(f"w1{c}" for c in _V) + tuple(f"v1{c}" for c in _V)
                + ("q2d",) + tuple(f"w2{c}" for c in _V) + tuple(f"v2{c}" for c in _V))
NSTATE = len(STATE_FIELDS)  # 38

ChamberState = namedtuple("ChamberState", STATE_FIELDS)
ChamberState.__doc__ = (
    "The chamber's motion at one instant, fixed frame, SI units: A, v_A, a_A; Omega, Omega'; "
    "Q (chamber axes to fixed axes, row-major); drive 1 (rate q1d, twist w1, v1) and drive 2 "
    "(q2d, w2, v2). See the module docstring.")

_I3 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def _is_number(v) -> bool:
    """A finite int or float, and not a bool (True is an int to Python, not a speed)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_number(name, v, unit):
    """Refuse anything but a finite number, naming it with its unit (shared with drive.py)."""
    if not _is_number(v):
        raise ParameterError(f"{name} must be a finite number, got {name} = {v!r} {unit}")


def _finite3(name, v):
    try:
        out = tuple(float(x) for x in v)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be 3 numbers, got {v!r}") from None
    if len(out) != 3 or not all(map(math.isfinite, out)):
        raise ParameterError(f"{name} must be 3 finite numbers, got {name} = {v!r}")
    return out


@dataclass(frozen=True)
class ConstantSpeed:
    """An angle law with constant rate: angle = angle0 + w t [rad, rad/s]."""

    w: float = 0.5
    angle0: float = 0.0

    def __post_init__(self):
        for name, unit in (("w", "rad/s"), ("angle0", "rad")):
            check_number(name, getattr(self, name), unit)

    def angle(self, t: float):
        return self.angle0 + self.w * t, self.w, 0.0


@dataclass(frozen=True)
class SpeedRise:
    """An angle law whose rate rises from rest at t = 0 to w [rad/s] (either sign) in t0 [s]
    along one of CrankStartup's shapes ``law`` (drives.crank.LAWS), then stays at w; at
    rest before t = 0. CrankStartup's angle with w0 = w (drives.crank.rise_angle)."""

    w: float = 0.5
    t0: float = 2.5
    law: str = "quadratic"

    def __post_init__(self):
        for name, unit in (("w", "rad/s"), ("t0", "s")):
            check_number(name, getattr(self, name), unit)
        if not self.t0 > 0.0:
            raise ParameterError(f"t0 must be positive, got t0 = {self.t0!r} s")
        if self.law not in LAWS:
            raise ParameterError(f"law must be one of {', '.join(LAWS)}, got law = {self.law!r}")

    def angle(self, t: float):
        return rise_angle(self.law, self.w, self.t0, t)


class ChamberMotion:
    """Base of the chamber motions: ``state(t)``, ``accel(t)``; ``rotates`` is False
    only for motions that the translation-only model covers exactly."""

    rotates = True

    def state(self, t: float) -> ChamberState:  # pragma: no cover - interface
        raise NotImplementedError

    def accel(self, t: float):
        s = self.state(t)
        return s[6:15]


@dataclass(frozen=True)
class Translation(ChamberMotion):
    """A horizontal translation: a platform motion of drives/crank.py, chamber centre at height zA."""

    platform: object = field(default_factory=CrankStartup)
    zA: float = 0.25  # height of A above O1 [m] (R: O1 level with the chamber's lowest point)

    rotates = False

    def state(self, t: float) -> ChamberState:
        x, y, vx, vy, ax, ay = self.platform.state(t)
        if hasattr(self.platform, "angle"):  # a crank: rate psi', twist about the vertical axis
            d1 = (self.platform.angle(t)[1], 0.0, 0.0, 0.0, -y, x, 0.0)
            d2 = (0.0,) * 7
        else:  # the x and y motions
            d1 = (vx, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0)
            d2 = (vy, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        return ChamberState(x, y, self.zA, vx, vy, 0.0, ax, ay, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                            *_I3, *d1, *d2)

    def accel(self, t: float):
        ax, ay = self.platform.accel(t)
        return ax, ay, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


class Spin(ChamberMotion):
    """A fixed, constant angular velocity Omega [rad/s] about an axis through the fixed
    centre A [m]; Q(0) = 1, Q(t) the rotation by |Omega| t about Omega/|Omega|."""

    def __init__(self, Omega=(0.0, 0.0, 3.0), A=(0.0, 0.0, 0.25)):
        self.Omega = _finite3("Omega", Omega)
        self.A = _finite3("A", A)
        ox, oy, oz = self.Omega
        self.rate = math.sqrt(ox * ox + oy * oy + oz * oz)
        self.axis = (ox / self.rate, oy / self.rate, oz / self.rate) if self.rate > 0.0 else (0.0, 0.0, 1.0)
        ex, ey, ez = self.axis
        ax, ay, az = self.A
        self._const = (ax, ay, az, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ox, oy, oz, 0.0, 0.0, 0.0)
        # the drive's twist: v_X = |Omega| (e x X + A x e) = Omega x (X - A)
        self._drives = (self.rate, ex, ey, ez, ay * ez - az * ey, az * ex - ax * ez, ax * ey - ay * ex,
                        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        self._accel = (0.0, 0.0, 0.0, ox, oy, oz, 0.0, 0.0, 0.0)

    def __repr__(self):
        return f"Spin(Omega={self.Omega}, A={self.A})"

    def orientation(self, t: float):
        """Q(t) (Rodrigues' formula), row-major."""
        ex, ey, ez = self.axis
        th = self.rate * t
        c, s = math.cos(th), math.sin(th)
        u = 1.0 - c
        return (c + u * ex * ex, u * ex * ey - s * ez, u * ex * ez + s * ey,
                u * ey * ex + s * ez, c + u * ey * ey, u * ey * ez - s * ex,
                u * ez * ex - s * ey, u * ez * ey + s * ex, c + u * ez * ez)

    def state(self, t: float) -> ChamberState:
        return ChamberState(*self._const, *self.orientation(t), *self._drives)

    def accel(self, t: float):
        return self._accel


ARRANGEMENTS = ("perpendicular", "parallel")
SHAFTS = ("x", "z")  # the frame's shaft: the horizontal x1 axis (Fig. 1) or the vertical z1 axis


class Fig1Machine(ChamberMotion):
    """The machine of the paper's Fig. 1 (module docstring): the frame turns about the
    fixed x1 axis by ``frame.angle(t)``, the cranks (length ``crank.l``) turn relative to
    the frame by ``crank.angle(t)``; ``arrangement`` 'perpendicular' (crank axes
    perpendicular to the frame's shaft, default) or 'parallel'; ``centre``: the crank
    circle's centre in the frame's axes [m]; ``l``: the crank length [m] (default: the crank
    law's own ``l``, as CrankStartup has one); ``shaft``: "x" (the fixed horizontal x1
    axis, default) or "z" (the vertical z1 axis)."""

    def __init__(self, frame=None, crank=None, arrangement: str = "perpendicular", centre=(0.0, 0.0, 0.0),
                 l: float | None = None, shaft: str = "x"):
        self.frame = ConstantSpeed(0.5) if frame is None else frame
        self.crank = CrankStartup(l=0.5, n0=60.0, t0=2.5) if crank is None else crank
        if arrangement not in ARRANGEMENTS:
            raise ParameterError(f"arrangement must be one of {ARRANGEMENTS}, got {arrangement!r}")
        for name, law in (("frame", self.frame), ("crank", self.crank)):
            if not hasattr(law, "angle"):
                raise ParameterError(f"{name} must be an angle law with angle(t) -> (angle, rate, "
                                     f"acceleration), got {law!r}")
        if l is None:
            l = getattr(self.crank, "l", None)
        if not (_is_number(l) and l >= 0.0):
            raise ParameterError(f"crank.l must be a non-negative length in m, got {l!r}")
        self.l = float(l)
        if shaft not in SHAFTS:
            raise ParameterError(f"shaft must be one of {SHAFTS}, got {shaft!r}")
        self.arrangement = arrangement
        self.shaft = shaft
        self.vertical = shaft == "z"
        # the crank circle in the frame's yz plane (else xy)
        self.parallel = (arrangement == "parallel") != self.vertical
        self.centre = _finite3("centre", centre)

    def __repr__(self):
        return (f"Fig1Machine(frame={self.frame!r}, crank={self.crank!r}, "
                f"arrangement={self.arrangement!r}, centre={self.centre}"
                + (f", shaft={self.shaft!r})" if self.vertical else ")"))

    def _kin(self, t):
        """(cos phi, sin phi, phi', phi'', psi', psi'', A, T, U): A = Rx a, T = Rx a_psi,
        U = Rx a_psipsi (Rz with the vertical shaft)."""
        ph, phd, phdd = self.frame.angle(t)
        ps, psd, psdd = self.crank.angle(t)
        c, s = math.cos(ph), math.sin(ph)
        cp, sp = math.cos(ps), math.sin(ps)
        l = self.l
        ox, oy, oz = self.centre
        if self.parallel:
            a = (ox, oy + l * cp, oz + l * sp)
            ap = (0.0, -l * sp, l * cp)
            app = (0.0, -l * cp, -l * sp)
        else:
            a = (ox + l * cp, oy + l * sp, oz)
            ap = (-l * sp, l * cp, 0.0)
            app = (-l * cp, -l * sp, 0.0)
        if self.vertical:
            A = (c * a[0] - s * a[1], s * a[0] + c * a[1], a[2])
            T = (c * ap[0] - s * ap[1], s * ap[0] + c * ap[1], ap[2])
            U = (c * app[0] - s * app[1], s * app[0] + c * app[1], app[2])
        else:
            A = (a[0], c * a[1] - s * a[2], s * a[1] + c * a[2])
            T = (ap[0], c * ap[1] - s * ap[2], s * ap[1] + c * ap[2])
            U = (app[0], c * app[1] - s * app[2], s * app[1] + c * app[2])
        return c, s, phd, phdd, psd, psdd, A, T, U

    @staticmethod
    def _acc(phd, phdd, psd, psdd, A, T, U):
        # a_A = Omega' x A + Omega x (Omega x A) + 2 psi' Omega x T + psi'^2 U + psi'' T,
        # Omega = (phi', 0, 0)
        return (psd * psd * U[0] + psdd * T[0],
                -phdd * A[2] - phd * phd * A[1] - 2.0 * phd * psd * T[2] + psd * psd * U[1] + psdd * T[1],
                phdd * A[1] - phd * phd * A[2] + 2.0 * phd * psd * T[1] + psd * psd * U[2] + psdd * T[2])

    @staticmethod
    def _acc_z(phd, phdd, psd, psdd, A, T, U):
        # the same with Omega = (0, 0, phi')
        return (-phdd * A[1] - phd * phd * A[0] - 2.0 * phd * psd * T[1] + psd * psd * U[0] + psdd * T[0],
                phdd * A[0] - phd * phd * A[1] + 2.0 * phd * psd * T[0] + psd * psd * U[1] + psdd * T[1],
                psd * psd * U[2] + psdd * T[2])

    def accel(self, t: float):
        c, s, phd, phdd, psd, psdd, A, T, U = self._kin(t)
        if self.vertical:
            return self._acc_z(phd, phdd, psd, psdd, A, T, U) + (0.0, 0.0, phd, 0.0, 0.0, phdd)
        return self._acc(phd, phdd, psd, psdd, A, T, U) + (phd, 0.0, 0.0, phdd, 0.0, 0.0)

    def state(self, t: float) -> ChamberState:
        c, s, phd, phdd, psd, psdd, A, T, U = self._kin(t)
        if self.vertical:
            vA = (-phd * A[1] + psd * T[0], phd * A[0] + psd * T[1], psd * T[2])
            aA = self._acc_z(phd, phdd, psd, psdd, A, T, U)
            return ChamberState(*A, *vA, *aA, 0.0, 0.0, phd, 0.0, 0.0, phdd,
                                c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0,
                                phd, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
                                psd, 0.0, 0.0, 0.0, T[0], T[1], T[2])
        vA = (psd * T[0], -phd * A[2] + psd * T[1], phd * A[1] + psd * T[2])
        aA = self._acc(phd, phdd, psd, psdd, A, T, U)
        return ChamberState(*A, *vA, *aA, phd, 0.0, 0.0, phdd, 0.0, 0.0,
                            1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c,
                            phd, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                            psd, 0.0, 0.0, 0.0, T[0], T[1], T[2])
