"""Parameters of the ball-in-chamber system: validated, frozen, SI units.

`Ball` holds what the equations need (radii, mass, gravity, friction
coefficient) and the derived constants (d = R - r, lambda = r/d, I, and the
gain k = m r / (I + m r^2) of the closed-form angular acceleration); `Contact`
the hybrid ball's contact beyond the static friction (`hybrid.HybridBall`).
Building one with an impossible value raises `ParameterError` naming the value.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import ParameterError

STEEL_DENSITY = 7800.0  # kg/m^3; the paper gives no mass, docs/design.md section 1 fixes a steel ball
PAPER_R_BALL = 0.025  # m
PAPER_R_CHAMBER = 0.25  # m


def steel_ball_mass(r: float) -> float:
    """Mass of a solid steel ball of radius r [m], in kg (7800 kg/m^3)."""
    return STEEL_DENSITY * 4.0 / 3.0 * math.pi * r**3


def _positive_finite(name: str, value: float, unit: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number in {unit}, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ParameterError(f"{name} must be positive and finite, got {name} = {value!r} {unit}")
    return v


def _non_negative_finite(name: str, value: float, unit: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number in {unit}, got {value!r}") from None
    if not math.isfinite(v) or v < 0.0:
        raise ParameterError(f"{name} must be non-negative and finite, got {name} = {value!r} {unit}")
    return v


@dataclass(frozen=True)
class Ball:
    """A solid ball of radius r and mass m rolling inside a sphere of radius R.

    All values SI. `mu` is the friction coefficient, used only for the rolling
    (no-slip) validity check |F_t| <= mu N.

    Losses to the ground material, both off by default (0): a rolling
    resistance of length ``rolling_resistance`` = delta, a resisting moment
    M_rr = -delta N w_t/|w_t| on the ball (w_t: part of omega perpendicular
    to n), and a viscous drag ``drag`` = c on the ball's centre,
    F_d = -c v_C,rel (equations.py has the derivation).

    Where the material lies (docs/design.md section 2, "The material bed"):
    ``bed_depth`` = None (default) means the material fills the chamber and
    both resistances act wherever the ball touches the wall, as they always
    have; a number h [m] puts the material in a bed at the chamber's bottom
    whose free surface is the horizontal plane z_P = h (z_P the contact
    point's height above the chamber's lowest point), so the resistances act
    only while the contact point is below it: their share is
    `equations.bed_share`, 1 deeper than ``bed_band`` = w [m] below the
    surface, 0 above it, a C-infinity blend across the band. h = 0 is no bed
    (no resistance at all); 0 <= h <= 2 R, w > 0.
    """

    r: float = PAPER_R_BALL
    R: float = PAPER_R_CHAMBER
    m: float = field(default_factory=lambda: steel_ball_mass(PAPER_R_BALL))
    g: float = 9.81
    mu: float = 0.3
    inertia_factor: float = 0.4  # I = inertia_factor * m r^2 (0.4: solid sphere)
    rolling_resistance: float = 0.0  # delta, rolling-resistance length [m]
    drag: float = 0.0  # c, viscous drag of the ground material on the centre [N s/m]
    bed_depth: float | None = None  # h, the material bed's surface above the lowest point [m]; None: everywhere
    bed_band: float = 0.01  # w, width of the blend below the bed's surface [m]

    def __post_init__(self):
        for name, unit in (("r", "m"), ("R", "m"), ("m", "kg"), ("g", "m/s2"),
                           ("mu", "1"), ("inertia_factor", "1")):
            object.__setattr__(self, name, _positive_finite(name, getattr(self, name), unit))
        for name, unit in (("rolling_resistance", "m"), ("drag", "N s/m")):
            object.__setattr__(self, name, _non_negative_finite(name, getattr(self, name), unit))
        object.__setattr__(self, "bed_band", _positive_finite("bed_band", self.bed_band, "m"))
        if self.bed_depth is not None:
            h = _non_negative_finite("bed_depth", self.bed_depth, "m")
            if not h <= 2.0 * self.R:
                raise ParameterError(
                    f"bed_depth must be within [0, 2 R] = [0, {2.0 * self.R:g}] m (the bed's surface lies "
                    f"between the chamber's lowest and highest points), got bed_depth = {self.bed_depth!r} m")
            object.__setattr__(self, "bed_depth", h)
        if not self.r < self.R:
            raise ParameterError(
                f"R must be larger than r (the ball must fit in the chamber), "
                f"got r = {self.r:g} m, R = {self.R:g} m")
        if (self.R - self.r) / self.R < 1e-9:
            raise ParameterError(
                f"R - r must be at least 1e-9 R, got r = {self.r!r} m, R = {self.R!r} m")

    # derived constants -----------------------------------------------------
    @property
    def d(self) -> float:
        """Distance from the chamber centre A to the ball centre C, R - r [m]."""
        return self.R - self.r

    @property
    def lam(self) -> float:
        """lambda = r / (R - r) [1]."""
        return self.r / (self.R - self.r)

    @property
    def I(self) -> float:  # noqa: E743 - the physics symbol
        """Moment of inertia about the centre [kg m2]."""
        return self.inertia_factor * self.m * self.r**2

    @property
    def k(self) -> float:
        """Gain m r / (I + m r^2) of the closed-form omega' [1/m]."""
        return 1.0 / (self.r * (1.0 + self.inertia_factor))

    @property
    def omega_small(self) -> float:
        """Angular frequency of small oscillations at the bottom, sqrt(g_red/d) [rad/s]
        with the reduced gravity g_red = g / (1 + I/(m r^2)) (5g/7 for a solid ball)."""
        return math.sqrt(self.g / (1.0 + self.inertia_factor) / self.d)

    def with_(self, **changes) -> "Ball":
        """A copy with some values changed (validated again)."""
        values = {k: getattr(self, k) for k in ("r", "R", "m", "g", "mu", "inertia_factor",
                                                "rolling_resistance", "drag", "bed_depth", "bed_band")}
        values.update(changes)
        return Ball(**values)


def _unit_interval(name, value, unit="1"):
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise ParameterError(f"{name} must lie in [0, 1], got {name} = {value!r} {unit}")
    return v


@dataclass(frozen=True)
class Contact:
    """The contact's parameters beyond the ball's static friction coefficient ``Ball.mu``.

    mu_k: kinetic friction coefficient [1], 0 <= mu_k <= mu (None: mu).
    e_n: normal restitution [1], in [0, 1].
    v_rest [m/s]: a rebound slower than this ends the bounce sequence (the ball stays on
        the wall), > 0.
    slip_eps [m/s]: sliding ends when the slip speed falls to it, > 0; above the
        integrator's error in the slip (about tol times the velocity scale, 1e-9 m/s at the
        defaults), else sticking would chatter; small enough that the rolling onset it
        advances, slip_eps / |du/dt|, is negligible (1e-7 s for mu_k g = 3 m/s2).
    creep_eps [m/s]: below this slip speed the sliding friction's direction is taken on the
        slide's slow manifold, the direction of the friction-free relative tangential
        acceleration of P, where the slip is aligned with it (docs/design.md section 14: a
        slide whose slip stays small is otherwise stiff, u/|u| turning at the rate
        k_t mu_k N / (m |u|)), >= 0; 0: Coulomb's u/|u| at every slip (the unreduced model)."""

    mu_k: float | None = None
    e_n: float = 0.5
    v_rest: float = 0.01
    slip_eps: float = 1e-6
    creep_eps: float = 1e-3

    def __post_init__(self):
        if self.mu_k is not None:
            v = float(self.mu_k)
            if not (math.isfinite(v) and v >= 0.0):
                raise ParameterError(f"mu_k must be non-negative and finite, got mu_k = {self.mu_k!r}")
        _unit_interval("e_n", self.e_n)
        for name in ("v_rest", "slip_eps"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0.0):
                raise ParameterError(f"{name} must be positive and finite, got {name} = "
                                     f"{getattr(self, name)!r} m/s")
        v = float(self.creep_eps)
        if not (math.isfinite(v) and v >= 0.0):
            raise ParameterError(f"creep_eps must be non-negative and finite (0: no creeping slide), got "
                                 f"creep_eps = {self.creep_eps!r} m/s")

    def kinetic(self, ball: Ball) -> float:
        """mu_k for this ball, checked against its static mu."""
        mu_k = ball.mu if self.mu_k is None else float(self.mu_k)
        if mu_k > ball.mu:
            raise ParameterError(f"mu_k must not exceed the static friction coefficient mu = "
                                 f"{ball.mu!r}, got mu_k = {self.mu_k!r}")
        return mu_k
