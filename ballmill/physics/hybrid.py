"""The ball that rolls, slides, flies and strikes the shell (docs/design.md section 14), on
the event-driven driver (`events.integrate`), in a translating or a turning chamber.

Modes: FLIGHT (0), ROLLING (1), SLIDING (2). Fixed axes, z up, g_vec = (0, 0, -g). The
chamber: a platform motion (``motion.state(t) -> (x, y, vx, vy, ax, ay)``: CrankStartup,
Fixed, Harmonic, Circle) translates it, A(t) = O(t) + (0, 0, R), Omega = 0; a
`turning.motions.ChamberMotion` (Spin, Fig1Machine, Translation) moves and turns it (A, v_A,
a_A, Omega, Omega', Q from its state). d = R - r, n = (C - A)/|C - A|, P = A + R n, the wall's
material point at P moves at v_W = v_A + Omega x R n, k_t = 1 + m r^2 / I (7/2 for a solid
ball: the tangential impulse J changes the slip by k_t J / m).

* ROLLING: today's rolling models (state n, omega): `equations.VectorFormulation` for a
  translation, `turning.model` for a ChamberMotion; N and F_t from their outputs
  (`outputs.evaluate`, `turning.model.evaluate_c`). Leaves for SLIDING when |F_t| > mu N (guard mu N - |F_t|),
  for FLIGHT when N reaches 0 (guard N; with F_t != 0 slip comes first, then the sliding
  ball's N reaches 0).
* SLIDING: state (C, v_C, omega) in fixed axes; u = v_C + omega x r n - v_W the slip (its
  tangential part), F = -N n - mu_k N e, e = u/|u| (from zero slip: the direction of the
  friction-free relative tangential acceleration of P, kept until |u| > 1e-3 slip_eps),
  N = m (n.(g_vec - a_A) + |v_C - v_A|^2 / |C - A|); m a_C = m g_vec + F,
  I omega' = r n x F. Ends when |u| falls to ``slip_eps`` (guard |u| - slip_eps): the rest
  of the slip is removed by a tangential impulse (its energy booked as friction), then the
  stick test (rolling's |F_t| <= mu N: ROLLING, else SLIDING again, seeded as above); while
  |u| <= slip_eps also where the rolling model's |F_t| falls back to mu N (the grip guard,
  `GRIP_SCALE`: a slide whose slip never reaches slip_eps ends there by the same stick map); or
  when N reaches 0: FLIGHT.
* FLIGHT: (C, v_C, omega), a_C = g_vec, omega' = 0; guard the gap d - |C - A|.
* Impact (gap reaches 0 with approaching normal speed v_n): normal impulse (1 + e_n) m v_n;
  the tangential impulse that stops the slip, -m u_-/k_t, if within mu times the normal one
  (sticks), else mu_k times the normal one against u_-. The kinetic energy lost in the frame
  of the chamber's material point at P (velocity v_W) is booked as impact loss. If e_n v_n < v_rest the
  remaining normal velocity is removed by a further normal impulse (its energy booked as
  impact loss) and the ball stays on the wall: ROLLING if the slip is gone and the stick test
  holds, else SLIDING (FLIGHT if the wall does not press, N <= 0).

Work and losses ride along as quadratures in every mode's state: W, the work of the chamber
on the ball (the contact force times v_W, plus J.v_W for every impulse), and E_friction;
E_impact is summed at the impacts. E + E_friction + E_impact - W is then constant, E the
ball's mechanical energy in fixed axes (`HybridTrajectory.energy_residual`).

The torque of the ball's force F on the chamber about the vertical axis z through the fixed
origin O1 (the BallInShell FMU's M_reaction) is integrated exactly, impulses included, by an
angular-momentum balance (`reaction_momentum`): with K the ball's angular momentum that the
torque drains and q the rest of its rate, the torque's integral from t_a to t_b is
-(K(t_b) - K(t_a)) + Lq(t_b) - Lq(t_a), Lq = integral of q, a quadrature in every mode's state
(last component) outside the error norm (`Integrator` n_err: the other states' steps and floats
are those of a run without it). Translating chamber (M = (A x F)_z, the crank's torque): K = m (A
x v_C)_z, q = m (v_A x v_C)_z; turning chamber (M = (P x F)_z, the moment about O1 of the force at
the contact point P): K = m (C x v_C)_z + I omega_z, the ball's angular momentum about the z axis
(gravity has no moment about a vertical axis), q = 0. An impulse changes v_C and omega, so K
carries its torque impulse; Lq is continuous.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import outputs as _out
from .errors import ParameterError
from .events import BURST, MAX_RATE, EventRun, integrate
from .integrators import Integrator, StepStats
from .model import BallModel, BallState
from .params import Ball, Contact  # Contact: re-exported here, where it was first defined
from .turning import model as _turning
from .turning.motions import ChamberMotion

FLIGHT, ROLLING, SLIDING = 0, 1, 2
# A rebound whose hop would rise less than this many ulps of the chamber's size above the wall
# counts as rest: the gap d - |C - A| cannot resolve it (the driver would not see it open).
HOP_MIN_ULPS = 1e4
MODE_NAMES = {FLIGHT: "flight", ROLLING: "rolling", SLIDING: "sliding"}


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


# The creeping slide (docs/design.md section 14): below Contact.creep_eps the friction's
# direction blends from u_t/|u_t| towards a0/|a0| (a0 the friction-free relative tangential
# acceleration of P) where the slip lies within acos(CREEP_COS[0]) of a0, fully on a0 where
# |u_t| <= creep_eps / 2 and the angle is below acos(CREEP_COS[1]).
CREEP_COS = (0.9, 0.99)

# The grip guard (HybridBall._g_sliding; docs/design.md section 14, the grazing slide): a slide
# that starts from zero slip and whose slip never exceeds slip_eps ends where the rolling
# model's friction demand |F_t| falls back to mu N, by the stick map. Its value at and below
# slip_eps is max(|F_t| - mu N, GRIP_SCALE (|u| - slip_eps)) [N], GRIP_SCALE [N s/m] a power of
# two: where a slip falls through slip_eps with the demand below mu N (an ordinary stick) the
# second term is the larger, the guard is the stick guard scaled exactly, and the root finder
# takes the same iterates on both: the event is the stick guard's, to the bit. Small, so the
# demand term wins wherever |F_t| - mu N > -GRIP_SCALE slip_eps (1e-15 N at the default).
GRIP_SCALE = 2.0 ** -30


def _smooth(x):
    """0 for x <= 0, 1 for x >= 1, 3 x^2 - 2 x^3 between (continuous slope)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


def _creep_weight(a, ut, s, eps):
    """The weight [0, 1] of the direction of a0 = ``a`` in the sliding friction's direction, at
    the slip ut of speed s < eps: 1 at zero slip (a0 != 0), else the product of a radial factor
    (1 up to eps / 2, 0 from eps) and an alignment factor (1 where the angle between u_t and a0
    has cosine >= CREEP_COS[1], 0 where <= CREEP_COS[0]); 0 when a0 = 0."""
    sa2 = _dot(a, a)
    if sa2 == 0.0:
        return 0.0
    if s == 0.0:
        return 1.0
    c = _dot(a, ut) / (math.sqrt(sa2) * s)
    c0, c1 = CREEP_COS
    return _smooth((eps - s) / (0.5 * eps)) * _smooth((c - c0) / (c1 - c0))


class HybridBall:
    """The system `events.integrate` runs (its interface in events.py): the ball in a
    translating or turning chamber with its three modes. Holds the run's bookkeeping (impacts, impact
    loss, first slip and flight), so one instance serves one run."""

    def __init__(self, ball: Ball, motion, contact: Contact = Contact(), method: str = "DOP853",
                 tol: float = 1e-9, h_max: float | None = None, energy: bool = True,
                 h_fixed: float = 1e-3, max_steps: int = 1_000_000, t_ref: float = 0.0):
        if ball.rolling_resistance or ball.drag:
            raise ParameterError(
                f"the hybrid model has no rolling resistance or drag in sliding and flight; got "
                f"rolling_resistance = {ball.rolling_resistance!r} m, drag = {ball.drag!r} N s/m "
                f"(expected 0)")
        self.ball, self.motion, self.contact = ball, motion, contact
        self.mu, self.mu_k = ball.mu, contact.kinetic(ball)
        self.e_n, self.v_rest, self.slip_eps = contact.e_n, contact.v_rest, contact.slip_eps
        self.creep_eps = contact.creep_eps
        self.kt = 1.0 + 1.0 / ball.inertia_factor
        self.energy = energy
        # rolling: today's models, their integrators and right-hand sides: a platform motion
        # (drives.crank) on the translation-only model, a ChamberMotion (turning.motions,
        # the chamber turning) on the general one
        self.turning = isinstance(motion, ChamberMotion)
        if self.turning:
            self.rolling = _turning.ChamberModel(ball, method, tol=tol, h_fixed=h_fixed, h_max=h_max,
                                                 max_steps=max_steps)
            self._f_roll = self.rolling.rhs(motion)
            self._c_roll, self._oc_roll = _turning.constants(ball), _turning.out_constants(ball)
            project, check = _turning._project, (lambda y: None)
        else:
            self.rolling = BallModel(ball, "vector", method, tol=tol, h_fixed=h_fixed, h_max=h_max,
                                     max_steps=max_steps)
            self._f_roll = self.rolling.rhs(motion.accel)
            project, check = self.rolling.form.project, self.rolling.form.check
        v_ref = math.sqrt(ball.g * ball.r)
        e_ref = ball.m * ball.g * ball.r
        q = [e_ref, e_ref]  # W, E_friction
        lq = [e_ref * math.sqrt(ball.r / ball.g)]  # Lq [N m s] (outside the error norm: its scale only sizes it)
        roll = self.rolling.integrator
        roll_scale = list(roll.scale) + q
        self._int_roll_q = Integrator(method, tol=tol, scale=roll_scale + lq, h_fixed=h_fixed, h_max=h_max,
                                      max_steps=max_steps, project=project, check=check, n_err=len(roll_scale))
        # rolling without W, E_friction: the rolling model's own integrator with Lq after its states
        self._int_roll_l = Integrator(method, tol=roll.tol, scale=list(roll.scale) + lq, h_fixed=roll.h_fixed,
                                      h_max=h_max, max_steps=roll.max_steps, project=project, check=check,
                                      n_err=roll.scale.size)
        free = [ball.r] * 3 + [v_ref] * 3 + [v_ref / ball.r] * 3 + q
        self._int_free = Integrator(method, tol=tol, scale=free + lq, h_fixed=h_fixed, h_max=h_max,
                                    max_steps=max_steps, n_err=len(free))
        self.book = dict(E_impact=0.0, n_impacts=0, v_impact_max=0.0, t_first_slip=math.nan,
                         t_first_flight=math.nan, Q=(0.0, 0.0), W_lost=False, t_held=math.nan,
                         held_window=math.nan)
        self._seed = (0.0, 0.0, 0.0)
        self._rebound = False  # the last map was a rebound (the flight's gap is opening)
        self._set_gap_res(t_ref)

    def _set_gap_res(self, t):
        """The gap's resolution [m]: HOP_MIN_ULPS ulps of the coordinates it is computed from,
        HOP_MIN_ULPS 2.2e-16 (R + |A(t)|), A at the run's reference time t."""
        A0 = self.chamber(t)[0]
        self._gap_res = HOP_MIN_ULPS * 2.2e-16 * (self.ball.R + math.sqrt(_dot(A0, A0)))

    def set_motion(self, motion, t_ref: float) -> None:
        """Move the chamber along ``motion`` from now on (of the kind the system was built for:
        a platform motion or a ChamberMotion), the gap's resolution taken at t_ref: the
        co-simulation step's chamber, a new input fit at every step (`resume`)."""
        if isinstance(motion, ChamberMotion) != self.turning:
            raise ParameterError(f"set_motion: a {'turning' if self.turning else 'translating'} chamber's "
                                 f"system cannot take the motion {type(motion).__name__}")
        self.motion = motion
        self._f_roll = self.rolling.rhs(motion if self.turning else motion.accel)
        self._set_gap_res(t_ref)

    # -- resuming a run (the co-simulation step) ----------------------------
    BOOK = ("E_impact", "n_impacts", "v_impact_max", "t_first_slip", "t_first_flight", "Q0", "Q1",
            "seed_x", "seed_y", "seed_z", "rebound", "W_lost", "t_held", "held_window")

    def bookkeeping(self) -> tuple:
        """The run's bookkeeping as BOOK's 14 floats (the compiled kernel's bmh book: fast.hybrid_run):
        impact loss, count, largest impact speed, first slip and flight times (NaN: not yet), the
        rolling mode's quadratures (W, E_friction) while they are not in its state (energy =
        False), the sliding direction's seed, the rebound flag, whether W was lost, and the hold
        (`hold`: the time of the Zeno stop from which the ball is held on the wall, rolling only,
        and the span of the burst of events that made it; NaN: not held)."""
        bk = self.book
        return (float(bk["E_impact"]), float(bk["n_impacts"]), float(bk["v_impact_max"]),
                float(bk["t_first_slip"]), float(bk["t_first_flight"]), float(bk["Q"][0]), float(bk["Q"][1]),
                *(float(v) for v in self._seed), float(self._rebound), float(bk["W_lost"]),
                float(bk["t_held"]), float(bk["held_window"]))

    @property
    def held(self) -> bool:
        """The ball is held on the wall, rolling only (`hold`), until the run is reset."""
        return not math.isnan(self.book["t_held"])

    def set_bookkeeping(self, book) -> None:
        """Take back `bookkeeping`'s 14 floats (ValueError naming what does not fit)."""
        book = tuple(float(v) for v in book)
        if len(book) != len(self.BOOK):
            raise ValueError(f"the hybrid bookkeeping holds {len(self.BOOK)} numbers {self.BOOK}, got {len(book)}")
        for name, v in zip(self.BOOK, book):
            if name in ("t_first_slip", "t_first_flight", "t_held", "held_window"):
                if not (math.isnan(v) or math.isfinite(v)):
                    raise ValueError(f"bookkeeping {name} = {v!r}: expected a finite time or NaN (not yet)")
            elif not math.isfinite(v):
                raise ValueError(f"bookkeeping {name} = {v!r} is not finite")
        if book[1] < 0 or book[1] != int(book[1]) or book[0] < 0.0 or book[2] < 0.0:
            raise ValueError(f"bookkeeping E_impact = {book[0]!r} J, n_impacts = {book[1]!r}, v_impact_max = "
                             f"{book[2]!r} m/s: expected non-negative values and a whole count")
        if book[10] not in (0.0, 1.0) or book[11] not in (0.0, 1.0):
            raise ValueError(f"bookkeeping rebound = {book[10]!r}, W_lost = {book[11]!r}: expected 0 or 1")
        if math.isnan(book[12]) != math.isnan(book[13]):
            raise ValueError(f"bookkeeping t_held = {book[12]!r} s, held_window = {book[13]!r} s: expected both "
                             f"NaN (not held) or both finite")
        self._set_book(book)

    def _set_book(self, book) -> None:
        """Take back `bookkeeping`'s 14 floats as they are (the compiled kernel's run's)."""
        book = tuple(float(v) for v in book)
        self.book.update(E_impact=book[0], n_impacts=int(book[1]), v_impact_max=book[2], t_first_slip=book[3],
                         t_first_flight=book[4], Q=(book[5], book[6]), W_lost=bool(book[11]), t_held=book[12],
                         held_window=book[13])
        self._seed = book[7:10]
        self._rebound = bool(book[10])

    def begin(self, t0, initial=None):
        """(mode, y) of the run's start at t0 (`simulate_hybrid`'s ``initial``: None, (C, v_C,
        omega) or a rolling model's `BallState`, whose own time replaces t0), with the first
        flight booked if it starts in flight. Returns (t0, mode, y)."""
        b = self.ball
        if initial is None:  # at rest relative to the chamber (co-rotating) at its lowest point
            A, vA, _, Om, _ = self.chamber(t0)
            Q = self.motion.state(t0)[15:24] if self.turning else (1, 0, 0, 0, 1, 0, 0, 0, 1)
            rho = (-b.d * Q[2], -b.d * Q[5], -b.d * Q[8])
            spin = _cross(Om, rho)
            initial = (tuple(A[i] + rho[i] for i in range(3)), tuple(vA[i] + spin[i] for i in range(3)), Om)
        if isinstance(initial, BallState):  # the rolling model's state, taken as it is
            t0 = initial.t
            mode, y = self.start_rolling(t0, initial.y)
        else:
            mode, y = self.start(t0, *initial)
        if mode == FLIGHT and math.isnan(self.book["t_first_flight"]):
            self.book["t_first_flight"] = t0
        return t0, mode, y

    def resume(self, mode: int, t: float, y, h, book, t_end: float, motion=None, *, burst: int = BURST,
               max_rate: float = MAX_RATE, on_zeno: str = "stop") -> EventRun:
        """Go on with a run from its state at t, (mode, y, the integrator's next step h, the
        bookkeeping `book` as `bookkeeping` gave it), to t_end, the only grid point: events
        inside are located and applied as in any run (`events.integrate`, the one driver).
        ``motion``: the chamber's motion from now on (`set_motion`, its gap resolution at t),
        None: keep the system's. The bookkeeping is taken back first, so a step redone from
        the same saved state (the predictor-corrector) gives the same numbers. Returns the
        `EventRun`: on success its ``mode``, ``y``, ``h`` and `bookkeeping`() are the state at
        t_end and ``rows[-1]`` the sample there; on failure (``success`` False: a failed step or
        the Zeno guard, ``message`` says which and when) the system's bookkeeping is whatever
        the run reached: take it back from the saved state before going on. ``on_zeno``: the
        driver's Zeno policy (`events.integrate`; "hold": the ball held on the wall from the
        Zeno stop on, `hold`)."""
        if motion is not None:
            self.set_motion(motion, t)
        self.set_bookkeeping(book)
        return integrate(self, mode, t, y, (t_end,), h=h, burst=burst, max_rate=max_rate, on_zeno=on_zeno)

    # -- chamber ----------------------------------------------------------
    def chamber(self, t):
        """(A, v_A, a_A, Omega, Omega') at time t, fixed axes."""
        s = self.motion.state(t)
        if self.turning:
            return s[0:3], s[3:6], s[6:9], s[9:12], s[12:15]
        x, y, vx, vy, ax, ay = s
        return (x, y, self.ball.R), (vx, vy, 0.0), (ax, ay, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)

    def wall_velocity(self, t, n):
        """Velocity of the chamber's material point at P = A + R n, v_A + Omega x R n."""
        _, vA, _, Om, _ = self.chamber(t)
        c = _cross(Om, n)
        R = self.ball.R
        return (vA[0] + R * c[0], vA[1] + R * c[1], vA[2] + R * c[2])

    # -- modes: state layout ----------------------------------------------
    # ROLLING: (n, omega) [+ (W, E_friction) when energy] + Lq; FLIGHT, SLIDING:
    # (C, v_C, omega, W, E_friction, Lq). Lq (the torque's quadrature, last) is outside the error norm.
    def integrator(self, mode):
        if mode == ROLLING:
            return self._int_roll_q if self.energy else self._int_roll_l
        return self._int_free

    def rhs(self, mode):
        if mode == ROLLING:
            return self._rhs_roll_q if self.energy else self._rhs_roll_l
        return self._rhs_slide if mode == SLIDING else self._rhs_flight

    def _quad(self, mode, y):
        if mode == ROLLING and not self.energy:
            return self.book["Q"]
        return float(y[-3]), float(y[-2])

    # -- the torque about the vertical axis through O1 (module docstring) ----
    def _q_spin(self, vA, vC):
        """q = m (v_A x v_C)_z of a translating chamber, Lq's rate (0 in a turning one)."""
        if self.turning:
            return 0.0
        return self.ball.m * (vA[0] * vC[1] - vA[1] * vC[0])

    def _q_rolling(self, vA, n, w):
        """q of a rolling ball, whose centre moves at v_C = v_A + r n x omega (translating)."""
        r = self.ball.r
        nw = _cross(n, w)
        return self._q_spin(vA, (vA[0] + r * nw[0], vA[1] + r * nw[1]))

    def reaction_momentum(self, t, z):
        """K of a free state z at t: the angular momentum whose loss, with Lq's gain, is the
        integral of the torque of the ball's force on the chamber about the vertical axis
        through O1 (module docstring): m (A x v_C)_z translating, m (C x v_C)_z + I omega_z
        turning [N m s]."""
        b = self.ball
        if self.turning:
            return b.m * (z[0] * z[4] - z[1] * z[3]) + b.I * z[8]
        A = self.chamber(t)[0]
        return b.m * (A[0] * z[4] - A[1] * z[3])

    # -- right-hand sides -------------------------------------------------
    def _rhs_roll_l(self, t, y):
        """The rolling model's right-hand side (the same floats) and Lq's rate, q = m (v_A x v_C)_z
        with v_C = v_A + r n x omega (translating; 0 turning)."""
        d = tuple(self._f_roll(t, y[:6]))
        if self.turning:
            return d + (0.0,)
        (_, _, vx, vy, _, _) = self.motion.state(t)
        y = y.tolist()
        return d + (self._q_rolling((vx, vy), (y[0], y[1], y[2]), (y[3], y[4], y[5])),)

    def _rhs_roll_q(self, t, y):
        b = self.ball
        y = y.tolist()
        if self.turning:
            y6 = y[:6]
            o = _turning.evaluate_c(self._oc_roll, y6, self.motion.state(t))
            return _turning.derivative(self._c_roll, y6, self.motion.accel(t)) + (o.P_ball, 0.0, 0.0)
        (x, yy, vx, vy, ax, ay) = self.motion.state(t)
        d = self.rolling.form.derivative((y[0], y[1], y[2], y[3], y[4], y[5]), ax, ay)
        # contact force on the ball m (a_O + d n'' - g_vec), n'' = lambda (n' x w + n x w')
        lam = b.lam
        nd, wd = d[:3], d[3:]
        n, w = (y[0], y[1], y[2]), (y[3], y[4], y[5])
        c1, c2 = _cross(nd, w), _cross(n, wd)
        Fx = b.m * (ax + b.d * lam * (c1[0] + c2[0]))
        Fy = b.m * (ay + b.d * lam * (c1[1] + c2[1]))
        return d + (Fx * vx + Fy * vy, 0.0, self._q_rolling((vx, vy), n, w))

    def _rhs_flight(self, t, y):
        y = y.tolist()
        q = 0.0 if self.turning else self._q_spin(self.chamber(t)[1], (y[3], y[4]))
        return (y[3], y[4], y[5], 0.0, 0.0, -self.ball.g, 0.0, 0.0, 0.0, 0.0, 0.0, q)

    def _slide_forces(self, t, y, seed=None, chamber=None):
        """(N, friction force on the ball F_t, slip speed |u_t|, n, the wall's velocity at P, the
        friction's power -F_t.u_t [W] (mu_k N |u_t| where the friction opposes the slip)) of a
        sliding state; ``chamber``: (A, v_A, a_A, Omega, Omega') to use instead of the motion's
        at t (an FMU's outputs with the inputs just set). The friction's direction e: u_t/|u_t| (Coulomb),
        blended below ``creep_eps`` towards the direction of the friction-free relative
        tangential acceleration a0 of P (`_creep_weight`; the slow manifold of a slide whose
        slip is small, where u_t/|u_t| is stiff); from zero slip the seed when a0 = 0."""
        b = self.ball
        if type(y) is not list:
            y = y.tolist()  # Python floats: faster than numpy scalars here
        ch = self.chamber(t) if chamber is None else chamber
        A, vA, aA, Om, _ = ch
        rho = (y[0] - A[0], y[1] - A[1], y[2] - A[2])
        dist = math.sqrt(_dot(rho, rho))
        n = (rho[0] / dist, rho[1] / dist, rho[2] / dist)
        vrel = (y[3] - vA[0], y[4] - vA[1], y[5] - vA[2])
        N = b.m * (-b.g * n[2] - _dot(n, aA) + _dot(vrel, vrel) / dist)
        wr = _cross((y[6], y[7], y[8]), n)
        on = _cross(Om, n)
        R = b.R
        u = (vrel[0] + b.r * wr[0] - R * on[0], vrel[1] + b.r * wr[1] - R * on[1],
             vrel[2] + b.r * wr[2] - R * on[2])
        un = _dot(u, n)
        ut = (u[0] - un * n[0], u[1] - un * n[1], u[2] - un * n[2])
        s = math.sqrt(_dot(ut, ut))
        f = -self.mu_k * N
        w, a = 0.0, None
        if s < self.creep_eps:
            a = self._friction_free_slip_accel(ch, y, n)
            w = _creep_weight(a, ut, s, self.creep_eps)
        if w == 0.0:
            if s > 1e-3 * self.slip_eps:
                e = (ut[0] / s, ut[1] / s, ut[2] / s)
            else:
                e = self._seed if seed is None else seed
            p = self.mu_k * N * s
        else:
            sa = math.sqrt(_dot(a, a))
            if w == 1.0:
                e = (a[0] / sa, a[1] / sa, a[2] / sa)
            else:
                c, d = (1.0 - w) / s, w / sa
                v = (c * ut[0] + d * a[0], c * ut[1] + d * a[1], c * ut[2] + d * a[2])
                sv = math.sqrt(_dot(v, v))
                e = (v[0] / sv, v[1] / sv, v[2] / sv)
            p = -f * _dot(e, ut)
        vW = (vA[0] + R * on[0], vA[1] + R * on[1], vA[2] + R * on[2])
        return N, (f * e[0], f * e[1], f * e[2]), s, n, vW, p

    def _rhs_slide(self, t, y):
        b = self.ball
        y = y.tolist()
        N, Ft, s, n, vW, p = self._slide_forces(t, y)
        F = (Ft[0] - N * n[0], Ft[1] - N * n[1], Ft[2] - N * n[2])
        tq = _cross(n, Ft)
        c = b.r / b.I
        return (y[3], y[4], y[5], F[0] / b.m, F[1] / b.m, F[2] / b.m - b.g,
                c * tq[0], c * tq[1], c * tq[2], _dot(F, vW), p,
                self._q_spin(vW, (y[3], y[4])))  # translating: v_W = v_A

    # -- guards ---------------------------------------------------------
    def guards(self, mode):
        if mode == ROLLING:
            if self.held:  # held on the wall: the rolling model only, no event
                return (), None, ()
            return ("slip", "leave"), self._g_rolling, (0.0, 0.0)
        if mode == SLIDING:
            return ("stick", "leave", "stick"), self._g_sliding, (0.0, 0.0, 0.0)
        return ("impact",), self._g_flight, (self._gap_res,)

    def _roll_out(self, t, y):
        """The rolling model's outputs (N, Ft, ...) of the rolling state y = (n, omega, ...)."""
        if self.turning:
            return _turning.evaluate_c(self._oc_roll, [y[0], y[1], y[2], y[3], y[4], y[5]],
                                       self.motion.state(t))
        _, _, _, _, ax, ay = self.motion.state(t)
        return _out.evaluate(self.ball, (y[0], y[1], y[2]), (y[3], y[4], y[5]), ax, ay)

    def _g_rolling(self, t, y):
        """(mu N - |F_t|, N) of the rolling model."""
        o = self._roll_out(t, y)
        return self.mu * o.N - o.Ft, o.N

    def _g_sliding(self, t, y):
        """(|u| - slip_eps, N, the grip guard) of the sliding ball. The grip guard ends a slide
        whose slip stays below slip_eps (the stick guard is never armed there): at and below
        slip_eps it is max(|F_t| - mu N, GRIP_SCALE (|u| - slip_eps)), |F_t| and N the rolling
        model's where the stick map would put the ball (`_on_sphere`, `_unslip`: on_wall's stick
        test, the same floats), so it reaches 0 where the demand falls back to mu N; above
        slip_eps it is GRIP_SCALE (|u| - slip_eps) > 0 (module constant GRIP_SCALE)."""
        N, _, s, _, _, _ = self._slide_forces(t, y)
        g = s - self.slip_eps
        if g > 0.0:
            return g, N, GRIP_SCALE * g
        z, n, ut, _ = self._on_sphere(t, y)
        o = self._unslip(t, z, n, ut)
        return g, N, max(o.Ft - self.mu * o.N, GRIP_SCALE * g)

    def _g_flight(self, t, y):
        return (self._gap(t, y),)

    def _normal_motion(self, t, y):
        """(v_n, a_n) of a free state: the normal velocity relative to the wall (> 0 towards
        it) and the free flight's normal acceleration relative to the wall."""
        A, vA, aA, _, _ = self.chamber(t)
        rho = (y[0] - A[0], y[1] - A[1], y[2] - A[2])
        dist = math.sqrt(_dot(rho, rho))
        n = (rho[0] / dist, rho[1] / dist, rho[2] / dist)
        vn = (y[3] - vA[0]) * n[0] + (y[4] - vA[1]) * n[1] + (y[5] - vA[2]) * n[2]
        return vn, -self.ball.g * n[2] - _dot(aA, n)

    def armed(self, mode, t, y):
        """The flight's gap guard is armed at once after a rebound (the gap is 0 there and
        opening); a flight that starts by leaving the wall (N = 0, no normal speed) arms it
        when the gap is first seen positive."""
        if mode == FLIGHT:
            return (self._rebound,)
        return (False, False, False) if mode == SLIDING else (False, False)

    def first_step(self, mode, t, y):
        """After a rebound, a quarter of the hop's duration in free flight (so the opening gap
        is seen positive before it closes again)."""
        if mode != FLIGHT or not self._rebound:
            return None
        vn, an = self._normal_motion(t, y)
        if vn < 0.0 and an > 0.0:
            return max(0.5 * -vn / an, 1e-12)
        return None

    def _gap(self, t, y):
        A = self.chamber(t)[0]
        return self.ball.d - math.sqrt((y[0] - A[0]) ** 2 + (y[1] - A[1]) ** 2 + (y[2] - A[2]) ** 2)

    # -- conversions ----------------------------------------------------
    def free_state(self, mode, t, y):
        """(C, v_C, omega, W, E_friction, Lq) of any mode's state, fixed axes."""
        if mode != ROLLING:
            return np.array(y, dtype=float)
        b = self.ball
        A = self.chamber(t)[0]
        n, w = (y[0], y[1], y[2]), (y[3], y[4], y[5])
        nw = _cross(n, w)
        vW = self.wall_velocity(t, n)  # v_C = v_A + R Omega x n + r n x omega: no slip
        W, Ef = self._quad(mode, y)
        return np.array([A[0] + b.d * n[0], A[1] + b.d * n[1], A[2] + b.d * n[2],
                         vW[0] + b.r * nw[0], vW[1] + b.r * nw[1], vW[2] + b.r * nw[2],
                         w[0], w[1], w[2], W, Ef, float(y[-1])])

    def _rolling_state(self, n, w, Q, Lq):
        core = [n[0], n[1], n[2], w[0], w[1], w[2]]
        if self.energy:
            return np.array(core + list(Q) + [Lq])
        # W is not followed while rolling: the sliding or flying state that follows carries it
        # from 0 (a NaN there would stop the integrator) and the outputs show NaN from here on
        self.book["Q"] = (0.0, Q[1])
        self.book["W_lost"] = True
        return np.array(core + [Lq])

    def _onto_wall(self, t, z):
        """z with C put on the sphere |C - A| = d and the normal velocity relative to the wall
        removed: a sliding state's drift off the constraint (integration error, ~tol) taken out
        where the ball leaves the wall, so the flight starts exactly tangent (otherwise a drift
        towards the wall reads as an impact an instant later)."""
        b = self.ball
        A, vA, _, _, _ = self.chamber(t)
        z = np.array(z, dtype=float)
        rho = z[:3] - np.array(A)
        n = rho / math.sqrt(rho @ rho)
        z[:3] = np.array(A) + b.d * n
        vn = float((z[3:6] - np.array(vA)) @ n)
        z[3:6] -= vn * n
        return z

    def _impulse(self, t, z, J, n):
        """Apply the impulse J (on the ball, at P = C + r n) to the free state z in place;
        returns the kinetic energy lost in the frame moving with the wall's material point at P,
        v_W = v_A + Omega x R n, and adds J.v_W to W."""
        b = self.ball
        vA = self.wall_velocity(t, n)

        def ke(z):
            v = (z[3] - vA[0], z[4] - vA[1], z[5] - vA[2])
            return 0.5 * b.m * _dot(v, v) + 0.5 * b.I * (z[6] ** 2 + z[7] ** 2 + z[8] ** 2)
        before = ke(z)
        tq = _cross(n, J)
        for i in range(3):
            z[3 + i] += J[i] / b.m
            z[6 + i] += b.r * tq[i] / b.I
        z[9] += _dot(J, vA)
        return before - ke(z)

    def _slip(self, t, z, n):
        """Tangential slip u_t of a free state at the wall point C + r n."""
        b = self.ball
        vA = self.wall_velocity(t, n)
        wr = _cross((z[6], z[7], z[8]), n)
        u = (z[3] - vA[0] + b.r * wr[0], z[4] - vA[1] + b.r * wr[1], z[5] - vA[2] + b.r * wr[2])
        un = _dot(u, n)
        return (u[0] - un * n[0], u[1] - un * n[1], u[2] - un * n[2])

    def _friction_free_slip_accel(self, chamber, z, n):
        """Tangential acceleration of P relative to the wall without friction (the direction
        friction opposes when sliding starts from zero slip), in the chamber's (A, v_A, a_A,
        Omega, Omega')."""
        b = self.ball
        A, vA, aA, Om, Omd = chamber
        vrel = (z[3] - vA[0], z[4] - vA[1], z[5] - vA[2])
        N = b.m * (-b.g * n[2] - _dot(n, aA) + _dot(vrel, vrel) / b.d)
        aC = (-N * n[0] / b.m, -N * n[1] / b.m, -b.g - N * n[2] / b.m)
        vn = _dot(vrel, n)
        nd = ((vrel[0] - vn * n[0]) / b.d, (vrel[1] - vn * n[1]) / b.d, (vrel[2] - vn * n[2]) / b.d)
        wnd = _cross((z[6], z[7], z[8]), nd)
        # the wall point's acceleration: a_A + R (Omega' x n + Omega x n')
        c1, c2 = _cross(Omd, n), _cross(Om, nd)
        aW = tuple(aA[i] + b.R * (c1[i] + c2[i]) for i in range(3))
        a = (aC[0] - aW[0] + b.r * wnd[0], aC[1] - aW[1] + b.r * wnd[1], aC[2] - aW[2] + b.r * wnd[2])
        an = _dot(a, n)
        return (a[0] - an * n[0], a[1] - an * n[1], a[2] - an * n[2])

    def _on_sphere(self, t, z):
        """(a copy of the free state z with C put on the sphere |C - A| = d, n there, the
        tangential slip u_t, its speed): where `on_wall` and the grip guard start."""
        b = self.ball
        A = self.chamber(t)[0]
        z = np.array(z, dtype=float)
        rho = z[:3] - np.array(A)
        n = tuple(rho / math.sqrt(rho @ rho))
        z[:3] = np.array(A) + b.d * np.array(n)
        ut = self._slip(t, z, n)
        return z, n, ut, math.sqrt(_dot(ut, ut))

    def _unslip(self, t, z, n, ut):
        """The stick map: the slip u_t of z removed (in place) by the tangential impulse
        -m u_t / k_t, its energy booked as friction; returns the rolling model's outputs there
        (the stick test's N and |F_t|)."""
        self._remove_slip(t, z, n, ut)
        return self._roll_out(t, n + (z[6], z[7], z[8]))

    def on_wall(self, t, z, stuck=False):
        """Mode and state of a ball on the wall with no normal relative velocity (free
        state z): its slip removed if below slip_eps (booked as friction), then the stick
        test. ``stuck``: the slip is removed whatever its speed here: the stick guard found
        it at slip_eps (or the grip guard below it), and putting C back on the sphere may move
        the speed recomputed here above slip_eps by rounding (going on sliding from there, a
        slide the guard cannot see start above slip_eps, would chatter at zero slip). Returns
        (mode, y, details)."""
        z, n, ut, s = self._on_sphere(t, z)
        details = {}
        if s <= self.slip_eps or stuck:
            o = self._unslip(t, z, n, ut)
            details["slip_removed"] = s
            w = (z[6], z[7], z[8])
            if o.N <= 0.0:
                return FLIGHT, z, details
            if o.Ft <= self.mu * o.N:
                return ROLLING, self._rolling_state(n, w, (z[9], z[10]), z[11]), details
            return self._start_sliding(t, z, n, details)
        N = self._slide_forces(t, z, seed=(0.0, 0.0, 0.0))[0]
        if N <= 0.0:
            return FLIGHT, z, details
        if math.isnan(self.book["t_first_slip"]):
            self.book["t_first_slip"] = t
        return SLIDING, z, details

    def _remove_slip(self, t, z, n, ut):
        """Remove the slip ut of the free state z on the wall (in place) by the tangential impulse
        -m ut / k_t at P, its energy booked as friction loss."""
        b = self.ball
        J = (-b.m * ut[0] / self.kt, -b.m * ut[1] / self.kt, -b.m * ut[2] / self.kt)
        z[10] += self._impulse(t, z, J, n)

    def _remove_normal(self, t, z, n, vA):
        """Remove the normal velocity of the free state z relative to the wall (in place: the
        chamber's centre moves at vA; Omega x R n is tangent) by a normal impulse at P; returns the
        energy it takes (impact loss)."""
        b = self.ball
        vn = (z[3] - vA[0]) * n[0] + (z[4] - vA[1]) * n[1] + (z[5] - vA[2]) * n[2]
        return self._impulse(t, z, (-b.m * vn * n[0], -b.m * vn * n[1], -b.m * vn * n[2]), n)

    def hold(self, mode, t, y, window):
        """The map at a Zeno stop (`events.integrate` with on_zeno = "hold"; window: the span of the
        burst of events [s]): the ball put on the wall and held there, rolling only from now on
        (as the rolling model after contact_model = 1's latch): C onto the sphere, its normal
        velocity relative to the wall removed (booked as impact loss, as rest's), then its slip
        (booked as friction loss, as at a stick); the hold's time and window booked (`held`:
        rolling has no guard from here on). Returns (ROLLING, y)."""
        z, n, _, _ = self._on_sphere(t, self.free_state(mode, t, y))
        self.book["E_impact"] += self._remove_normal(t, z, n, self.chamber(t)[1])
        self._remove_slip(t, z, n, self._slip(t, z, n))
        self.book["t_held"], self.book["held_window"] = float(t), float(window)
        self._rebound = False
        return ROLLING, self._rolling_state(n, (z[6], z[7], z[8]), (z[9], z[10]), z[11])

    def _start_sliding(self, t, z, n, details):
        a = self._friction_free_slip_accel(self.chamber(t), z, n)
        s = math.sqrt(_dot(a, a))
        self._seed = (a[0] / s, a[1] / s, a[2] / s) if s > 0.0 else (0.0, 0.0, 0.0)
        if math.isnan(self.book["t_first_slip"]):
            self.book["t_first_slip"] = t
        details["seed"] = self._seed
        return SLIDING, z, details

    def start_rolling(self, t, y):
        """(mode, y) from the rolling model's state (n, omega): rolling if it holds there (the
        state kept as it is), else what the wall decides (`on_wall`)."""
        y = np.array(y, dtype=float)
        if y.shape != (6,):
            raise ParameterError(f"a rolling state holds the 6 numbers (n, omega) of the vector "
                                 f"formulation, got shape {y.shape}")
        o = self._roll_out(t, y)
        if o.N > 0.0 and o.Ft <= self.mu * o.N:
            return ROLLING, self._rolling_state(tuple(y[:3]), tuple(y[3:]), (0.0, 0.0), 0.0)
        mode, z, _ = self.on_wall(t, self.free_state(ROLLING, t, self._rolling_state(
            tuple(y[:3]), tuple(y[3:]), (0.0, 0.0), 0.0)))
        return mode, z

    def start(self, t, C, v, w):
        """(mode, y) of a ball with centre C, velocity v, angular velocity w (fixed axes) at
        time t: in flight if it clears the wall, on the wall (stick test) if it touches it
        with no normal relative velocity, struck at once if it moves into it."""
        b = self.ball
        A, vA, _, _, _ = self.chamber(t)
        z = np.array(list(C) + list(v) + list(w) + [0.0, 0.0, 0.0], dtype=float)
        for name, val in zip(("C", "v", "w"), (C, v, w)):
            if len(val) != 3 or not all(math.isfinite(x) for x in val):
                raise ParameterError(f"{name} must be three finite numbers, got {name} = {val!r}")
        rho = z[:3] - np.array(A)
        dist = math.sqrt(rho @ rho)
        if dist > b.d * (1.0 + 1e-9):
            raise ParameterError(f"the ball centre C = {tuple(C)!r} m lies outside the chamber: "
                                 f"|C - A| = {dist:.12g} m, expected <= R - r = {b.d:.12g} m")
        if b.d - dist > 1e-9 * b.r:
            self.book["t_first_flight"] = t
            return FLIGHT, z
        n = rho / dist
        vn = float((z[3:6] - np.array(vA)) @ n)
        if vn > 1e-12:
            mode, y, _ = self._impact(t, z)
            return mode, y
        if vn < -1e-12:
            return FLIGHT, z
        mode, y, details = self.on_wall(t, z)
        if mode == FLIGHT and math.isnan(self.book["t_first_flight"]):
            self.book["t_first_flight"] = t
        return mode, y

    # -- the map at an event ----------------------------------------------
    def jump(self, mode, kind, t, y):
        self._rebound = False
        z = self.free_state(mode, t, y)
        if kind == "impact":
            new, y2, details = self._impact(t, z)
        elif kind == "leave":
            new, y2, details = FLIGHT, self._onto_wall(t, z), {}
        elif kind == "slip" and self._slide_forces(t, z, seed=(0.0, 0.0, 0.0))[0] <= 0.0:
            # rolling's two guards met at N = 0 (mu N - |F_t| reaches 0 with N when F_t does not
            # hold the ball, as under a chamber pulled down faster than g): the wall no longer
            # presses, and a slide that never sees N > 0 could not arm its leave guard
            new, y2, details = FLIGHT, self._onto_wall(t, z), {}
        elif kind == "slip":
            A = self.chamber(t)[0]
            n = tuple((z[:3] - np.array(A)) / self.ball.d)
            new, y2, details = self._start_sliding(t, z, n, {})
        elif kind == "stick":
            new, y2, details = self.on_wall(t, z, stuck=True)
        else:  # pragma: no cover - the guards name only these
            raise ValueError(f"unknown event kind {kind!r}")
        if new == FLIGHT and math.isnan(self.book["t_first_flight"]):
            self.book["t_first_flight"] = t
        A = self.chamber(t)[0]
        rho = z[:3] - np.array(A)
        details["n"] = tuple((rho / math.sqrt(rho @ rho)).tolist())  # where it happened
        return new, y2, details

    def _impact(self, t, z):
        b = self.ball
        A, vA, _, _, _ = self.chamber(t)
        z = np.array(z, dtype=float)
        rho = z[:3] - np.array(A)
        n = tuple(rho / math.sqrt(rho @ rho))
        z[:3] = np.array(A) + b.d * np.array(n)
        vn = (z[3] - vA[0]) * n[0] + (z[4] - vA[1]) * n[1] + (z[5] - vA[2]) * n[2]
        if vn <= 0.0:
            # touching without approaching (a gap closing at round-off level): no impulse
            return FLIGHT, z, {"v_n": vn, "grazing": True}
        Jn = (1.0 + self.e_n) * b.m * vn
        ut = self._slip(t, z, n)
        s = math.sqrt(_dot(ut, ut))
        stick = s / self.kt <= self.mu * (1.0 + self.e_n) * vn
        if stick:
            Jt = (-b.m * ut[0] / self.kt, -b.m * ut[1] / self.kt, -b.m * ut[2] / self.kt)
        else:
            c = -self.mu_k * Jn / s
            Jt = (c * ut[0], c * ut[1], c * ut[2])
        J = (Jt[0] - Jn * n[0], Jt[1] - Jn * n[1], Jt[2] - Jn * n[2])
        loss = self._impulse(t, z, J, n)
        bk = self.book
        bk["n_impacts"] += 1
        bk["v_impact_max"] = max(bk["v_impact_max"], vn)
        details = {"v_n": vn, "slip": s, "stick": stick, "E_loss": loss}
        _, an = self._normal_motion(t, z)
        hop = (self.e_n * vn) ** 2 / (2.0 * an) if an > 0.0 else math.inf
        if self.e_n * vn < self.v_rest or hop < self._gap_res:
            loss += self._remove_normal(t, z, n, vA)
            bk["E_impact"] += loss
            details["E_loss"] = loss
            details["rest"] = True
            mode, y, more = self.on_wall(t, z)
            details.update(more)
            return mode, y, details
        bk["E_impact"] += loss
        self._rebound = True
        return FLIGHT, z, details

    # -- outputs ----------------------------------------------------------
    COLUMNS = ("mode", "nx", "ny", "nz", "xC", "yC", "zC", "vCx", "vCy", "vCz", "wx", "wy", "wz", "N", "Ft",
               "slip_speed", "gap", "E", "W_chamber", "E_friction", "E_impact", "n_impacts",
               "v_impact_max", "t_first_slip", "t_first_flight", "M_impulse")

    def sample(self, mode, t, y):
        """One row of COLUMNS: n = (C - A)/|C - A| (fixed axes); C in the chamber's axes with
        the origin at its lowest point, Q^T (C - A) + (0, 0, R) (translating: C relative to the
        platform point O, as `outputs.evaluate`); v_C and omega in fixed axes; N and |F_t| of
        the contact [N]; the slip speed [m/s] and gap d - |C - A| [m]; the ball's mechanical
        energy E in fixed axes and the bookkeeping [J]; M_impulse = Lq - K [N m s], whose change
        between two samples is the integral of the torque of the ball's force on the chamber about
        the vertical axis through O1, impulses included (`reaction_momentum`; `simulate_hybrid`
        counts it from its first sample)."""
        b = self.ball
        z = self.free_state(mode, t, y)
        A = self.chamber(t)[0]
        rho = z[:3] - np.array(A)
        dist = math.sqrt(rho @ rho)
        n = tuple(rho / dist)
        if mode == ROLLING:
            n = (y[0], y[1], y[2])  # the state itself: the rolling model's numbers, unrounded
            o = self._roll_out(t, y)
            N, Ft, slip = o.N, o.Ft, 0.0
        elif mode == SLIDING:
            N, Ftv, slip, _, _, _ = self._slide_forces(t, z)
            Ft = math.sqrt(_dot(Ftv, Ftv))
        else:
            N, Ft = 0.0, 0.0
            ut = self._slip(t, z, n)
            slip = math.sqrt(_dot(ut, ut))
        E = (0.5 * b.m * float(z[3:6] @ z[3:6]) + 0.5 * b.I * float(z[6:9] @ z[6:9])
             + b.m * b.g * z[2])
        bk = self.book
        c = (z[0] - A[0], z[1] - A[1], z[2])  # O = A - (0, 0, R) at height 0
        if self.turning:  # into the chamber's axes: Q^T (C - A) + (0, 0, R)
            Q = self.motion.state(t)[15:24]
            r = (c[0], c[1], z[2] - A[2])
            c = tuple(Q[i] * r[0] + Q[3 + i] * r[1] + Q[6 + i] * r[2] for i in range(3))
            c = (c[0], c[1], c[2] + b.R)
        W = math.nan if bk["W_lost"] else z[9]
        return (mode, n[0], n[1], n[2], c[0], c[1], c[2], z[3], z[4], z[5], z[6], z[7], z[8], N, Ft,
                slip, b.d - dist, E, W, z[10], bk["E_impact"], bk["n_impacts"],
                bk["v_impact_max"], bk["t_first_slip"], bk["t_first_flight"],
                z[11] - self.reaction_momentum(t, z))


@dataclass
class HybridTrajectory:
    """Result of `simulate_hybrid`: outputs on the time grid (``out``, the columns of
    `HybridBall.COLUMNS`, also by ``traj["name"]``), the events in order (`events.Event`:
    time, kind 'slip' | 'leave' | 'stick' | 'impact', modes before and after, details),
    ``success`` (False: the run stopped early, ``message`` says where and why) and the
    integrator's work."""

    t: np.ndarray
    out: dict
    events: list
    success: bool = True
    message: str = "completed"
    info: StepStats | None = None
    t_first_slip: float | None = None
    t_first_flight: float | None = None

    def __getitem__(self, name):
        return self.out[name]

    @property
    def energy_residual(self) -> np.ndarray:
        """E + E_friction + E_impact - W_chamber - (its initial value) [J]: zero up to the
        integrator's error."""
        r = self.out["E"] + self.out["E_friction"] + self.out["E_impact"] - self.out["W_chamber"]
        return r - r[0]

    def of_kind(self, kind: str) -> list:
        return [e for e in self.events if e.kind == kind]


def simulate_hybrid(ball: Ball, motion, t_end: float, dt: float, contact: Contact = Contact(), *,
                    initial=None, t0: float = 0.0, method: str = "DOP853", tol: float = 1e-9,
                    h_max: float | None = None, energy: bool = True, burst: int = BURST,
                    max_rate: float = MAX_RATE, h_fixed: float = 1e-3,
                    kernel: str = "auto", on_zeno: str = "stop") -> HybridTrajectory:
    """The ball in a chamber moved by ``motion`` (a platform motion: translation; a
    `turning.motions.ChamberMotion`: any rigid motion) with rolling, sliding, flight and
    impacts, sampled every dt [s] from t0 to t_end.

    initial: None (the ball at rest relative to the chamber at its lowest point, as
        `simulate`), (C, v_C, omega) in fixed axes at t0 [m, m/s, rad/s], or a rolling model's
        `BallState` (n, omega; its own time replaces t0), e.g. ``BallModel.initial(...)`` or
        ``ChamberModel.initial(...)``: the same start as `simulate`/`simulate_general`.
    energy: carry the chamber's work W_chamber in the rolling mode too (the energy balance in
        every mode); False integrates rolling exactly as `simulate` does (the same floats
        while the ball rolls) and leaves W_chamber NaN after rolling.
    method, tol, h_fixed, h_max: the integrator (`integrators.Integrator`) of every mode:
        DOP853 or RK45 adaptive at tol, or RK4 with the fixed step h_fixed [s] (the last
        step before a grid point or an event shortened to land there); with either, events
        are located on the method's own step from the step's start (events.py).
    burst, max_rate: the Zeno guard of `events.integrate`.
    on_zeno: what the Zeno guard does: "stop" the run there (``success`` False, the message
        naming the stop), or "hold" the ball on the wall from there, rolling only
        (`HybridBall.hold`, as the BallInShell FMU does; ``message`` then names the stop).
    kernel: ``"auto"`` (default) runs the scene in the compiled kernel (`fast.hybrid_run`:
        the same numbers bit for bit) when it is built and covers the run
        (`fast.hybrid_reason`: the kernel's platform motions, or Spin and Fig1Machine), else
        in Python; ``"c"`` insists (`fast.KernelUnavailable`
        with the reason); ``"python"`` never uses it. A run whose step fails is redone in
        Python, which reports the failure.
    """
    from . import fast
    from .model import KERNELS

    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"dt must be positive and finite, got dt = {dt!r} s")
    if not (math.isfinite(t_end) and t_end >= t0):
        raise ValueError(f"t_end must be finite and >= t0 = {t0!r} s, got t_end = {t_end!r} s")
    system = HybridBall(ball, motion, contact, method, tol, h_max, energy, h_fixed)
    t0, mode, y = system.begin(t0, initial)
    n_steps = int(round((t_end - t0) / dt))
    times = t0 + dt * np.arange(n_steps + 1)
    run = None
    if kernel != "python":
        why = fast.hybrid_reason(system)
        if not why:
            run = fast.hybrid_run(system, mode, t0, y, times, burst=burst, max_rate=max_rate, on_zeno=on_zeno)
        elif kernel == "c":
            raise fast.KernelUnavailable(f"simulate_hybrid(kernel='c'): {why}")
    if run is None:
        run = integrate(system, mode, t0, y, times, burst=burst, max_rate=max_rate, on_zeno=on_zeno)
    arr = np.array(run.rows, dtype=float).reshape(len(run.rows), len(HybridBall.COLUMNS))
    out = {name: arr[:, j] for j, name in enumerate(HybridBall.COLUMNS)}
    out["M_impulse"] = out["M_impulse"] - out["M_impulse"][0]  # from the first sample
    bk = system.book
    nan_none = lambda v: None if math.isnan(v) else v  # noqa: E731
    message = run.message
    if run.held is not None:
        message = f"held on the wall, rolling only, from t = {bk['t_held']:.9g} s: {run.held}"
    return HybridTrajectory(run.t, out, run.events, run.success, message, run.stats,
                            nan_none(bk["t_first_slip"]), nan_none(bk["t_first_flight"]))
