"""Response curves of the nonlinear absorber model: one point, a refined FRF, sweeps.

This module owns how a steady-state amplitude is measured on the monolithic
structure + ball model (`ballmill.absorber.model`), and the frequency
response built from such points:

* `steady_state(case, frequency, state=None)`: one point. Starts from the
  linear steady state (or continues from a given state), integrates window
  after window of whole excitation periods, fits each window's cavity
  motion x_O(t) with a mean and the first three harmonics by least squares,
  and stops when the fundamental amplitude of the last K windows agrees to
  ``rtol``, K chosen so that the windows span a beat of the slowest
  transient against the forcing or its decay time (`settling_windows`). The
  error estimate is the spread of those K amplitudes, or the Aitken
  extrapolation of their trend when larger; a point that does
  not settle within ``max_periods`` is returned with ``converged`` False and
  the spread of its last windows as the error. Validity over the last
  window: the largest friction ratio |F_t|/N against mu (rolling), the
  smallest normal force (contact), the ball's largest angle from the bottom.
  This is the function a sweep layer calls per point (plain arguments, a
  plain result, the final state to continue from).
* `refine(frequencies, amplitudes)`: the frequencies to add so that every
  local maximum is resolved (a parabola through the three points around it
  predicts the same height as the sampled maximum within ``rtol``, or the
  spacing is below ``df_min``). A caller evaluates, refines, evaluates the
  new points, until nothing is added (`frf` does exactly that).
* `sweep(case, frequencies)`: a stepped sweep up or down: each point
  continues from the previous point's final state with the excitation's
  phase continued, so the response stays on its branch until the branch
  ends and it jumps.

The bare structure is linear: its amplitude is the closed form
(`ballmill.absorber.linear`), exact, and `bare_amplitude` returns it.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ballmill.absorber.model import AbsorberState, StructureBall, simulate_absorber
from ballmill.physics import outputs as _out
from ballmill.physics.params import Ball
from ballmill.absorber.structure import HarmonicForce, HarmonicGround, Structure

from .linear import LinearAbsorber


@dataclass(frozen=True)
class AbsorberCase:
    """Structure, ball and a harmonic load in x: with ``load = "force"`` a force
    F_x = force sin(2 pi f t) [N] on the structure (at the modes' force_shape), with
    ``load = "ground"`` a ground acceleration a_gx = force sin(2 pi f t) [m/s2].
    ``seed_y`` [m]: the ball starts this far off the x-z plane (0: planar motion
    stays planar; a tiny seed lets an out-of-plane instability of the ball show)."""

    structure: Structure
    ball: Ball
    force: float = 0.05  # N, or m/s2 for load = "ground"
    seed_y: float = 0.0  # m
    tol: float = 1e-9
    load: str = "force"

    def __post_init__(self):
        if self.load not in ("force", "ground"):
            raise ValueError(f"load must be 'force' or 'ground', got load = {self.load!r}")

    def system(self, frequency: float, phase: float = 0.0, t0: float = 0.0) -> StructureBall:
        kind = HarmonicForce if self.load == "force" else HarmonicGround
        return StructureBall(self.structure, self.ball, kind(self.force, frequency, phase=phase, t0=t0))

    def linear(self, axis: str = "x", ball: bool = True) -> LinearAbsorber:
        ax = self.structure.x if axis == "x" else self.structure.y
        return LinearAbsorber(ax, self.ball if ball else None)

    def linear_frf(self, frequency, ball: bool = True):
        """Complex cavity displacement of the linear model per unit of this case's load."""
        return self.linear("x", ball).frf(frequency, self.load)


@dataclass
class Point:
    """One steady state. Amplitudes of the cavity (structure at the absorber)
    relative to the ground [m]; the ball's values over the last window."""

    frequency_Hz: float
    amplitude_m: float  # fundamental (first-harmonic) amplitude of x_O
    amplitude_err_m: float  # error estimate of amplitude_m
    peak_m: float  # max |x_O - mean| over the last window (from the harmonic fit)
    amplitude_y_m: float  # fundamental amplitude of y_O (out of the forcing plane)
    phase_rad: float  # phase of x_O's fundamental against the force
    ball_angle_max_rad: float  # largest angle of the ball from the bottom
    ball_amplitude_m: float  # fundamental amplitude of the ball centre's x relative to the cavity
    friction_ratio_max: float  # max |F_t| / N
    N_min: float  # smallest normal force [N]
    rolling: bool  # friction_ratio_max <= mu throughout the last window
    contact: bool  # N_min > 0
    converged: bool
    periods: int  # excitation periods integrated for this point
    t_end: float  # simulated time at the end [s]
    state: AbsorberState | None = field(default=None, repr=False)
    theta_end: float = 0.0  # excitation phase at t_end [rad]
    restarted: bool = False  # a sweep point that did not continue from its predecessor

    def row(self) -> dict:
        d = asdict(self)
        d.pop("state")
        return d


def fit_harmonics(t, x, frequency: float, n_harm: int = 3):
    """Least-squares fit x ~ c0 + sum (a_k cos k W t + b_k sin k W t): (c0, a[], b[])."""
    W = 2.0 * math.pi * frequency
    cols = [np.ones_like(t)]
    for k in range(1, n_harm + 1):
        cols += [np.cos(k * W * t), np.sin(k * W * t)]
    c = np.linalg.lstsq(np.column_stack(cols), x, rcond=None)[0]
    return c[0], c[1::2], c[2::2]


def _window_amplitude(t, x, frequency):
    c0, a, b = fit_harmonics(t, x, frequency)
    W = 2.0 * math.pi * frequency
    tt = np.linspace(t[0], t[0] + 1.0 / frequency, 256, endpoint=False)
    fit = sum(a[k] * np.cos((k + 1) * W * tt) + b[k] * np.sin((k + 1) * W * tt) for k in range(len(a)))
    return math.hypot(a[0], b[0]), float(np.abs(fit).max()), math.atan2(a[0], b[0])


LINEAR_START_LIMIT = 0.25  # largest ball amplitude / (R - r) for which the linear start is used


def linear_start(case: AbsorberCase, frequency: float, theta: float = 0.0, t0: float = 0.0):
    """The state of the linear steady response at the instant the force's phase is theta;
    where that puts the ball beyond LINEAR_START_LIMIT (R - r) from the bottom (the linear
    answer near a resonance with a large force), everything at rest instead."""
    lin = case.linear("x")
    q, qd, u, ud = lin.steady_state(case.force, frequency, theta, case.load)
    sysb = case.system(frequency)
    d, r = case.ball.d, case.ball.r
    U = abs(complex(lin.ball_frf(frequency, case.load)[0])) * case.force
    if U > LINEAR_START_LIMIT * d:
        return sysb.initial(t0, yC0=case.seed_y)
    return sysb.initial(t0, qx=q, qdx=qd, xC0=u, yC0=case.seed_y, w0=(0.0, ud / r, 0.0))


def bare_amplitude(case: AbsorberCase, frequency) -> np.ndarray:
    """Steady-state amplitude of the bare structure (no ball) [m]: the closed form."""
    return np.abs(case.linear_frf(frequency, ball=False)) * case.force


def steady_state(case: AbsorberCase, frequency: float, state: AbsorberState | None = None,
                 theta: float = 0.0, periods_per_window: int = 4, samples: int = 16,
                 rtol: float = 1e-3, min_windows: int = 3, max_periods: int = 400,
                 stop_on_contact_loss: bool = True) -> Point:
    """The steady-state response at one frequency (module docstring).

    state: continue from this state with the force's phase ``theta`` at state.t
    (a sweep); None: start from the linear steady state at t = 0. The ball's
    validity is checked at every sample; when it leaves the wall (N <= 0) the
    rolling model no longer holds and, with ``stop_on_contact_loss``, the point
    ends there (contact False, converged False).
    """
    if not (frequency > 0 and math.isfinite(frequency)):
        raise ValueError(f"frequency must be positive and finite, got {frequency!r} Hz")
    if state is None:
        state = linear_start(case, frequency, theta)
    t_start = state.t
    sysb = case.system(frequency, phase=theta, t0=t_start)
    T = 1.0 / frequency
    x_ref = max(float(abs(case.linear_frf(frequency)[0])) * case.force, 1e-6)
    K = settling_windows(case, frequency, periods_per_window, min_windows)
    windows, periods = [], 0
    converged = ok = False
    lost = False
    while periods < max_periods:
        t_end = t_start + (periods + periods_per_window) * T
        res = simulate_absorber(sysb, t_end, T / samples, state=state, tol=case.tol, x_ref=x_ref,
                                record="motion")
        if not res.success:
            break
        ok = True
        periods += periods_per_window
        state = res.state
        windows.append(_window(sysb, res, frequency))
        if windows[-1]["N_min"] <= 0.0:
            lost = True
            if stop_on_contact_loss:
                break
        if len(windows) >= K:
            last = [w["A"] for w in windows[-K:]]
            if max(last) - min(last) <= rtol * max(last):
                converged = True
                break
    last = [w["A"] for w in windows[-K:]] if windows else [math.nan]
    A = last[-1]
    err = max(last) - min(last) if len(last) > 1 else math.inf
    if len(last) >= 3:
        d1, d2 = last[-2] - last[-3], last[-1] - last[-2]
        if d1 != d2 and abs(d2) < abs(d1) and d1 * d2 > 0:  # a geometric trend: extrapolate it
            err = max(err, abs(d2 * d2 / (d1 - d2)))
    w = windows[-1] if windows else {k: math.nan for k in ("A", "peak", "phase", "Ay", "U", "angle",
                                                          "ratio", "N_min")}
    theta_end = sysb.excitation.theta(state.t)
    return Point(frequency_Hz=float(frequency), amplitude_m=float(A), amplitude_err_m=float(err),
                 peak_m=float(w["peak"]), amplitude_y_m=float(w["Ay"]), phase_rad=float(w["phase"]),
                 ball_angle_max_rad=float(w["angle"]), ball_amplitude_m=float(w["U"]),
                 friction_ratio_max=float(w["ratio"]), N_min=float(w["N_min"]),
                 rolling=bool(w["ratio"] <= case.ball.mu), contact=bool(w["N_min"] > 0.0 and not lost),
                 converged=converged and ok and not lost, periods=periods, t_end=float(state.t),
                 state=state, theta_end=float(math.fmod(theta_end, 2 * math.pi)))


def settling_windows(case: AbsorberCase, frequency: float, periods_per_window: int = 4,
                     min_windows: int = 3, max_windows: int = 10) -> int:
    """How many consecutive windows must agree before a point counts as settled.

    A transient of a mode at f_j leaks into the fit at f and makes the window
    amplitudes oscillate with the beat period 1/|f - f_j| while it decays with
    1/(zeta_j omega_j). The windows compared must span the shorter of the two for
    the mode where that is longest (linear modes), so that their spread shows the
    leakage rather than a quiet stretch of it."""
    fj, zj = case.linear("x").modes()
    span = 0.0
    for f_, z_ in zip(fj, zj):
        decay = 1.0 / (z_ * 2 * math.pi * f_) if z_ > 0 else math.inf
        beat = 1.0 / abs(frequency - f_) if frequency != f_ else math.inf
        span = max(span, min(decay, beat))
    k = math.ceil(span * frequency / periods_per_window) + 1 if math.isfinite(span) else max_windows
    return int(min(max_windows, max(min_windows, k)))


def _window(sysb: StructureBall, res, frequency: float) -> dict:
    """Amplitudes and the ball's validity over one window of whole periods (the
    last sample, which starts the next window, left out of the fits)."""
    # the few outputs a window needs, as StructureBall.outputs computes them (the same
    # calls, so the same numbers), without the rest of that dict (energy, forces, ...)
    ib, ball = sysb.ib, sysb.ball
    xC, N, ratio, angle = [], [], [], []
    for tt, zz in zip(res.t, res.z):
        z = zz.tolist()
        ax, ay = sysb.solve_acceleration(float(tt), z)
        o = _out.evaluate(ball, z[ib:ib + 3], z[ib + 3:ib + 6], ax, ay)
        xC.append(o.xC)
        N.append(o.N)
        ratio.append(o.friction_ratio)
        angle.append(math.acos(max(-1.0, min(1.0, -z[ib + 2]))))
    tw = res.t[:-1]
    A, pk, ph = _window_amplitude(tw, res["xO"][:-1], frequency)
    return {"A": A, "peak": pk, "phase": ph,
            "Ay": _window_amplitude(tw, res["yO"][:-1], frequency)[0],
            "U": _window_amplitude(tw, np.array(xC[:-1]), frequency)[0],
            "angle": max(angle), "ratio": max(ratio), "N_min": min(N)}


def refine(frequencies, amplitudes, rtol: float = 0.003, df_min: float = 2e-4):
    """Frequencies to add around each interior local maximum of amplitudes(frequencies)
    that is not yet resolved (module docstring): the midpoints on both sides."""
    f = np.asarray(frequencies, dtype=float)
    a = np.asarray(amplitudes, dtype=float)
    o = np.argsort(f)
    f, a = f[o], a[o]
    new = []
    for i in range(1, len(f) - 1):
        if not (a[i] >= a[i - 1] and a[i] >= a[i + 1]):
            continue
        h1, h2 = f[i] - f[i - 1], f[i + 1] - f[i]
        if max(h1, h2) <= df_min:
            continue
        # parabola through the three points: its vertex height
        x = np.array([f[i - 1], f[i], f[i + 1]]) - f[i]
        c = np.polyfit(x, a[i - 1:i + 2], 2)
        top = c[2] - c[1] ** 2 / (4 * c[0]) if c[0] < 0 else a[i]
        if abs(top - a[i]) <= rtol * a[i] and max(h1, h2) <= 8 * df_min:
            continue
        for lo, hi in ((f[i - 1], f[i]), (f[i], f[i + 1])):
            if hi - lo > df_min:
                new.append(0.5 * (lo + hi))
    return sorted(set(round(v, 9) for v in new))


def frf(case: AbsorberCase, frequencies, refine_rounds: int = 8, progress=None, **kw):
    """Independent steady states over the grid, refined around every peak (`refine`).
    Returns the Points sorted by frequency. ``progress(point)`` is called after each."""
    points = {}
    todo = sorted(set(float(f) for f in frequencies))
    for _ in range(refine_rounds + 1):
        for f in todo:
            p = steady_state(case, f, **kw)
            p.state = None  # keep results small
            points[f] = p
            if progress:
                progress(p)
        fs = sorted(points)
        todo = [f for f in refine(fs, [points[f].amplitude_m for f in fs]) if f not in points]
        if not todo:
            break
    return [points[f] for f in sorted(points)]


def sweep(case: AbsorberCase, frequencies, start: AbsorberState | None = None, progress=None, **kw):
    """Stepped sweep in the order given (up or down): each point continues from the
    previous one's final state and phase. The first starts from ``start`` or the
    linear steady state. Returns the Points in sweep order."""
    out = []
    state, theta = start, 0.0
    for f in frequencies:
        p = steady_state(case, float(f), state=state, theta=theta, **kw)
        p.restarted = state is None and bool(out)
        state, theta = p.state, p.theta_end
        if not p.contact:  # the rolling model ended: the next point starts afresh
            state, theta = None, 0.0
        p.state = None
        out.append(p)
        if progress:
            progress(p)
    return out
