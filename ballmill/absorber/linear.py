"""Linear theory of the ball absorber: closed-form response, equivalent TMD, tuning.

This module owns the small-amplitude model of one horizontal axis of
structure + ball, what follows from it in closed form, and the tuning rules.

Derivation (one axis, modes q_j with shapes phi_j at the absorber, ball
centre displaced u = d n_x from the cavity's axis, all relative to the ground,
iota = I / (m r^2) = 2/5 for a solid ball). Rolling without slip gives the
ball's spin u'/r, so to second order

    T = sum 1/2 M_j q_j'^2 + 1/2 m (x_O' + u')^2 + 1/2 iota m u'^2,  x_O = sum phi_j q_j
    V = sum 1/2 K_j q_j^2 + 1/2 (m g / d) u^2

and the drag F_d = -c v_C,rel adds the generalised force -c u' on u. Mass,
damping and stiffness matrices in (q_1 .. q_n, u):

    M = [[diag(M_j) + m phi phi^T, m phi], [m phi^T, (1 + iota) m]]
    C = diag(C_j, c),   K = diag(K_j, m g / d)

Loads: a force F at the point with shapes psi: (psi F, 0); a ground
acceleration a_g: (-(L_j + m phi_j) a_g, -m a_g). The ball's own frequency is
omega_b^2 = g / ((1 + iota) d) = 5 g / (7 (R - r)).

The equivalent classic tuned-mass damper (one mode, phi = 1): with
u = v / (1 + iota) the kinetic energy becomes 1/2 M' x'^2 + 1/2 m_a (x' + v')^2 with

    m_a = m / (1 + iota)         (5/7 m: the absorbing mass)
    M'  = M + iota m / (1 + iota)   (the structure carries 2/7 m rigidly)
    k_a = m g / ((1 + iota)^2 d),  c_a = c / (1 + iota)^2,
    mass ratio mu = m_a / M'  (not m / M: 0.0142 for m / M = 0.02).

So Den Hartog's optimum for an undamped main system applies with this mu and
the main frequency sqrt(K / M'): f_a = f_main / (1 + mu),
zeta_a = sqrt(3 mu / (8 (1 + mu))), peak |x| K / F = sqrt(1 + 2 / mu). (zeta_a is the
absorber's own ratio c_a / (2 m_a omega_a); Den Hartog's c_a / (2 m_a omega_main) =
sqrt(3 mu / (8 (1 + mu)^3)) is the same damper referred to the main frequency.)
The rolling resistance delta is not linear (a Coulomb-type moment delta N):
over a cycle of ball amplitude U at Omega it dissipates what a drag
c_eq = 4 delta m g / (pi r Omega U) would, so it damps small motions much
more than large ones (`drag_equivalent_of_rolling_resistance`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ballmill.physics.params import Ball
from ballmill.absorber.structure import StructureAxis, Structure


def cavity_radius(frequency: float, r: float, g: float = 9.81, inertia_factor: float = 0.4) -> float:
    """R [m] that gives a ball of radius r the small-oscillation frequency [Hz]:
    R = r + g / ((1 + iota) (2 pi f)^2)  (= r + 5 g / (7 omega^2) for a solid ball)."""
    if not (frequency > 0 and math.isfinite(frequency)):
        raise ValueError(f"frequency must be positive and finite, got {frequency!r} Hz")
    return r + g / ((1.0 + inertia_factor) * (2.0 * math.pi * frequency) ** 2)


def ball_frequency(ball: Ball) -> float:
    """Small-oscillation frequency of the ball in its cavity [Hz]."""
    return ball.omega_small / (2.0 * math.pi)


def drag_for_damping_ratio(zeta: float, ball: Ball) -> float:
    """Drag c [N s/m] that gives the ball's linear oscillation the damping ratio zeta
    (c = 2 (1 + iota) m omega_b zeta)."""
    return 2.0 * (1.0 + ball.inertia_factor) * ball.m * ball.omega_small * zeta


def damping_ratio_of_drag(ball: Ball) -> float:
    """The ball's linear damping ratio from its drag alone."""
    return ball.drag / (2.0 * (1.0 + ball.inertia_factor) * ball.m * ball.omega_small)


def drag_equivalent_of_rolling_resistance(ball: Ball, frequency: float, amplitude: float) -> float:
    """Viscous drag [N s/m] that dissipates per cycle what the rolling resistance delta
    does for a ball centre amplitude ``amplitude`` [m] at ``frequency`` [Hz] (N = m g):
    c_eq = 4 delta m g / (pi r Omega U)."""
    W = 2.0 * math.pi * frequency
    return 4.0 * ball.rolling_resistance * ball.m * ball.g / (math.pi * ball.r * W * amplitude)


@dataclass(frozen=True)
class EquivalentTMD:
    """The ball on a single-mode structure as a classic tuned-mass damper."""

    M_main: float  # M + iota m / (1 + iota) [kg]
    m_a: float  # m / (1 + iota) [kg]
    k_main: float  # [N/m]
    k_a: float  # [N/m]
    c_main: float  # [N s/m]
    c_a: float  # [N s/m]

    @property
    def mu(self) -> float:
        return self.m_a / self.M_main

    @property
    def f_main(self) -> float:
        return math.sqrt(self.k_main / self.M_main) / (2 * math.pi)

    @property
    def f_a(self) -> float:
        return math.sqrt(self.k_a / self.m_a) / (2 * math.pi)

    @property
    def zeta_main(self) -> float:
        return self.c_main / (2 * math.sqrt(self.k_main * self.M_main))

    @property
    def zeta_a(self) -> float:
        return self.c_a / (2 * math.sqrt(self.k_a * self.m_a))


def equivalent_tmd(axis: StructureAxis, ball: Ball) -> EquivalentTMD:
    """The equivalent TMD of a ball on a one-mode axis (mode scaled to phi = 1)."""
    if axis.n != 1:
        raise ValueError(f"the equivalent TMD is defined for one mode, the axis has {axis.n}")
    md = axis.modes[0]
    s2 = md.shape ** 2  # M / phi^2: the mode's mass seen at the absorber
    iota, m = ball.inertia_factor, ball.m
    return EquivalentTMD(M_main=md.mass / s2 + iota * m / (1 + iota), m_a=m / (1 + iota),
                         k_main=md.stiffness / s2, k_a=m * ball.g / ((1 + iota) ** 2 * ball.d),
                         c_main=md.damping_coefficient / s2, c_a=ball.drag / (1 + iota) ** 2)


def den_hartog(mu: float):
    """Den Hartog's optimum TMD for an undamped main system and mass ratio mu:
    (frequency ratio f_a / f_main, the absorber's own damping ratio
    zeta_a = c_a / (2 m_a omega_a) = sqrt(3 mu / (8 (1 + mu))), peak |x| k / F).
    (Den Hartog's sqrt(3 mu / (8 (1 + mu)^3)) is c_a / (2 m_a omega_main), the same damper
    referred to the main system's frequency omega_main = (1 + mu) omega_a.)"""
    return (1.0 / (1.0 + mu), math.sqrt(3.0 * mu / (8.0 * (1.0 + mu))), math.sqrt(1.0 + 2.0 / mu))


def den_hartog_ball(axis: StructureAxis, r: float, m: float, g: float = 9.81,
                    inertia_factor: float = 0.4, **ball_kw) -> Ball:
    """The ball (R and drag) that realises Den Hartog's optimum on a one-mode axis."""
    probe = Ball(r=r, R=cavity_radius(axis.modes[0].frequency, r, g, inertia_factor), m=m, g=g,
                 inertia_factor=inertia_factor)
    tmd = equivalent_tmd(axis, probe)
    f_ratio, zeta, _ = den_hartog(tmd.mu)
    R = cavity_radius(tmd.f_main * f_ratio, r, g, inertia_factor)
    ball = Ball(r=r, R=R, m=m, g=g, inertia_factor=inertia_factor, **ball_kw)
    return ball.with_(drag=drag_for_damping_ratio(zeta, ball))


class LinearAbsorber:
    """The linear model of one axis: structure modes + (optionally) the ball.

    ball None: the bare structure. Coordinates (q_1 .. q_n[, u]).
    """

    def __init__(self, axis: StructureAxis, ball: Ball | None = None):
        self.axis = axis
        self.ball = ball
        n = axis.n
        nb = n + (1 if ball is not None else 0)
        Mm = np.zeros((nb, nb))
        Cm = np.zeros((nb, nb))
        Km = np.zeros((nb, nb))
        phi = np.array([md.shape for md in axis.modes])
        self.phi = np.concatenate([phi, [0.0]]) if ball is not None else phi
        self.psi = np.array([md.force_shape for md in axis.modes] + ([0.0] if ball is not None else []))
        L = np.array([md.participation for md in axis.modes])
        for j, md in enumerate(axis.modes):
            Mm[j, j] = md.mass
            Km[j, j] = md.stiffness
            Cm[j, j] = md.damping_coefficient
        if ball is not None:
            m = ball.m
            Mm[:n, :n] += m * np.outer(phi, phi)
            Mm[:n, n] = Mm[n, :n] = m * phi
            Mm[n, n] = (1.0 + ball.inertia_factor) * m
            Km[n, n] = m * ball.g / ball.d
            Cm[n, n] = ball.drag
            self.ground = -np.concatenate([L + m * phi, [m]])
        else:
            self.ground = -L
        self.M, self.C, self.K = Mm, Cm, Km

    def response(self, frequency, load: str = "force"):
        """Complex amplitudes of all coordinates per unit load (force [N] at psi, or
        ground acceleration [m/s2]), shape (len(frequency), n_coords)."""
        if load not in ("force", "ground"):
            raise ValueError(f"load must be 'force' or 'ground', got load = {load!r}")
        f = np.atleast_1d(np.asarray(frequency, dtype=float))
        Q = self.psi if load == "force" else self.ground
        out = np.empty((f.size, self.M.shape[0]), dtype=complex)
        for i, fi in enumerate(f):
            W = 2.0 * math.pi * fi
            out[i] = np.linalg.solve(self.K - W * W * self.M + 1j * W * self.C, Q)
        return out

    def frf(self, frequency, load: str = "force"):
        """Complex displacement of the cavity (relative to the ground) per unit load."""
        return self.response(frequency, load) @ self.phi

    def ball_frf(self, frequency, load: str = "force"):
        """Complex displacement u of the ball centre relative to the cavity per unit load."""
        if self.ball is None:
            raise ValueError("the bare structure has no ball")
        return self.response(frequency, load)[:, -1]

    def modes(self):
        """(frequencies [Hz], damping ratios) of the damped modes, ascending."""
        nb = self.M.shape[0]
        Minv = np.linalg.inv(self.M)
        A = np.block([[np.zeros((nb, nb)), np.eye(nb)], [-Minv @ self.K, -Minv @ self.C]])
        ev = np.linalg.eigvals(A)
        ev = ev[ev.imag > 0]
        wn = np.abs(ev)
        order = np.argsort(wn)
        return wn[order] / (2 * math.pi), (-ev.real / wn)[order]

    def peaks(self, f_lo: float, f_hi: float, load: str = "force", n: int = 4001):
        """Local maxima of |frf| in [f_lo, f_hi]: list of (frequency, |frf|), refined by a
        golden-section search to 1e-9 Hz."""
        f = np.linspace(f_lo, f_hi, n)
        a = np.abs(self.frf(f, load))
        out = []
        for i in range(1, n - 1):
            if a[i] >= a[i - 1] and a[i] > a[i + 1]:
                lo, hi = f[i - 1], f[i + 1]
                g = (math.sqrt(5) - 1) / 2
                while hi - lo > 1e-9:
                    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
                    if abs(self.frf(x1, load)[0]) > abs(self.frf(x2, load)[0]):
                        hi = x2
                    else:
                        lo = x1
                fm = 0.5 * (lo + hi)
                out.append((fm, float(abs(self.frf(fm, load)[0]))))
        return out

    def steady_state(self, amplitude: float, frequency: float, theta: float = 0.0,
                     load: str = "force"):
        """(q, q', u, u') of the steady response to the load amplitude sin(theta(t)) at the
        instant where the excitation's phase theta(t) is ``theta`` [rad] (q, q' arrays
        over the modes; u, u' are 0.0 for the bare structure)."""
        X = self.response(frequency, load)[0] * amplitude
        W = 2.0 * math.pi * frequency
        e = np.exp(1j * theta)
        disp = (X * e).imag
        vel = (1j * W * X * e).imag
        n = self.axis.n
        if self.ball is None:
            return disp[:n], vel[:n], 0.0, 0.0
        return disp[:n], vel[:n], float(disp[n]), float(vel[n])

    def slowest_decay_time(self) -> float:
        """1 / (zeta omega) of the least damped mode [s]: how long transients last."""
        f, z = self.modes()
        return float(max(1.0 / (zz * 2 * math.pi * ff) if zz > 0 else math.inf for ff, zz in zip(f, z)))


def linear_models(structure: Structure, ball: Ball | None):
    """LinearAbsorber per axis (None for an axis that does not move)."""
    return tuple(LinearAbsorber(ax, ball) if ax is not None else None for ax in structure.axes)


def peak_of(axis: StructureAxis, ball: Ball, f_lo: float, f_hi: float) -> float:
    """Highest |x_O / F| [m/N] in [f_lo, f_hi] of the linear model."""
    pk = LinearAbsorber(axis, ball).peaks(f_lo, f_hi, n=1201)
    return max(a for _, a in pk) if pk else float(np.abs(LinearAbsorber(axis, ball).frf([f_lo, f_hi])).max())


def optimum(axis: StructureAxis, r: float, m: float, f_lo: float, f_hi: float, g: float = 9.81,
            inertia_factor: float = 0.4, start=None):
    """The ball tuning (frequency f_b [Hz] and linear damping ratio zeta_b) that
    minimises the highest peak of |x_O / F| over [f_lo, f_hi] in the linear model,
    with the structure's own damping. Returns (f_b, zeta_b, peak [m/N], Ball)."""
    from scipy.optimize import minimize

    def make(fb, zb):
        b = Ball(r=r, R=cavity_radius(fb, r, g, inertia_factor), m=m, g=g, inertia_factor=inertia_factor)
        return b.with_(drag=drag_for_damping_ratio(max(zb, 0.0), b))

    def cost(p):
        fb, zb = p
        if fb <= 0 or zb < 0:
            return 1e9
        return peak_of(axis, make(fb, zb), f_lo, f_hi)

    if start is None:
        probe = make(axis.modes[0].frequency, 0.0)
        tmd = equivalent_tmd(axis, probe)
        fr, zt, _ = den_hartog(tmd.mu)
        start = (tmd.f_main * fr, zt)
    res = minimize(cost, start, method="Nelder-Mead",
                   options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 400})
    fb, zb = res.x
    return float(fb), float(zb), float(res.fun), make(fb, zb)
