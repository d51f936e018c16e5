"""Response curves of the nonlinear absorber model: one point, a refined FRF, sweeps.

This module owns how a steady-state amplitude is measured on the monolithic
structure + ball model (`ballmill.physics.absorber`), and the frequency
response built from such points:

* `steady_state(case, frequency, state=None)`: one point. Starts from the
  linear steady state (or continues from a given state), integrates window
  after window of whole excitation periods, fits each window's cavity
  motion x_O(t) with a mean and the first three harmonics by least squares,
  and stops when the fundamental amplitude of the last three windows agrees
  to ``rtol``. The error estimate is the spread of those three amplitudes
  together with the Aitken extrapolation of their trend; a point that does
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

from ballmill.physics.absorber import AbsorberState, StructureBall, simulate_absorber
from ballmill.physics.params import Ball
from ballmill.physics.structure import HarmonicForce, Structure

from .linear import LinearAbsorber


@dataclass(frozen=True)
class AbsorberCase:
    """Structure, ball and a harmonic force F_x = force sin(2 pi f t) on the structure
    (at the modes' force_shape). ``seed_y`` [m]: the ball starts this far off the
    x-z plane (0: planar motion stays planar; a tiny seed lets an out-of-plane
    instability of the ball show)."""

    structure: Structure
    ball: Ball
    force: float = 0.05  # N
    seed_y: float = 0.0  # m
    tol: float = 1e-9

    def system(self, frequency: float, phase: float = 0.0, t0: float = 0.0) -> StructureBall:
        return StructureBall(self.structure, self.ball, HarmonicForce(self.force, frequency,
                                                                       phase=phase, t0=t0))

    def linear(self, axis: str = "x", ball: bool = True) -> LinearAbsorber:
        ax = self.structure.x if axis == "x" else self.structure.y
        return LinearAbsorber(ax, self.ball if ball else None)


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


def linear_start(case: AbsorberCase, frequency: float, theta: float = 0.0, t0: float = 0.0):
    """The state of the linear steady response at the instant the force's phase is theta."""
    lin = case.linear("x")
    q, qd, u, ud = lin.steady_state(case.force, frequency, theta)
    sysb = case.system(frequency)
    d, r = case.ball.d, case.ball.r
    u = max(-0.9 * d, min(0.9 * d, u))  # the linear answer may be beyond reach at resonance
    return sysb.initial(t0, qx=q, qdx=qd, xC0=u, yC0=case.seed_y, w0=(0.0, ud / r, 0.0))


def bare_amplitude(case: AbsorberCase, frequency) -> np.ndarray:
    """Steady-state amplitude of the bare structure (no ball) [m]: the closed form."""
    return np.abs(case.linear("x", ball=False).frf(frequency)) * case.force


def steady_state(case: AbsorberCase, frequency: float, state: AbsorberState | None = None,
                 theta: float = 0.0, periods_per_window: int = 4, samples: int = 16,
                 rtol: float = 1e-3, min_windows: int = 3, max_periods: int = 400) -> Point:
    """The steady-state response at one frequency (module docstring).

    state: continue from this state with the force's phase ``theta`` at state.t
    (a sweep); None: start from the linear steady state at t = 0.
    """
    if not (frequency > 0 and math.isfinite(frequency)):
        raise ValueError(f"frequency must be positive and finite, got {frequency!r} Hz")
    if state is None:
        state = linear_start(case, frequency, theta)
    t_start = state.t
    sysb = case.system(frequency, phase=theta, t0=t_start)
    T = 1.0 / frequency
    x_ref = max(float(abs(case.linear("x").frf(frequency)[0])) * case.force, 1e-6)
    amps, res, periods = [], None, 0
    ib = sysb.ib
    converged = False
    while periods < max_periods:
        t_end = t_start + (periods + periods_per_window) * T
        res = simulate_absorber(sysb, t_end, T / samples, state=state, tol=case.tol, x_ref=x_ref,
                                record="motion")
        if not res.success:
            break
        periods += periods_per_window
        state = res.state
        tw, xw = res.t[:-1], res["xO"][:-1]
        amps.append(_window_amplitude(tw, xw, frequency))
        if len(amps) >= min_windows:
            last = [a[0] for a in amps[-3:]]
            if max(last) - min(last) <= rtol * max(last):
                converged = True
                break
    last = [a[0] for a in amps[-3:]] if amps else [math.nan]
    A = last[-1]
    err = max(last) - min(last) if len(last) > 1 else math.inf
    if len(last) == 3:
        d1, d2 = last[1] - last[0], last[2] - last[1]
        if d1 != d2 and abs(d2) < abs(d1) and d1 * d2 > 0:  # a geometric trend: extrapolate it
            err = max(err, abs(d2 * d2 / (d1 - d2)))
    # the last window in full: ball outputs and the y motion
    ball_u, angle, ratio, Nmin, amp_y = math.nan, math.nan, math.nan, math.nan, math.nan
    if res is not None and res.success:
        zs = res.z[-samples * periods_per_window - 1:]
        rows = [sysb.outputs(float(tt), zz) for tt, zz in zip(res.t[-len(zs):], zs)]
        tw = res.t[-len(zs):-1]
        xc = np.array([r["xC"] for r in rows[:-1]])
        yO = np.array([r["yO"] for r in rows[:-1]])
        ball_u = _window_amplitude(tw, xc, frequency)[0]
        amp_y = _window_amplitude(tw, yO, frequency)[0]
        angle = max(r["theta"] for r in rows)
        ratio = max(r["friction_ratio"] for r in rows)
        Nmin = min(r["N"] for r in rows)
    pk, ph = (amps[-1][1], amps[-1][2]) if amps else (math.nan, math.nan)
    theta_end = sysb.excitation.theta(state.t)
    return Point(frequency_Hz=float(frequency), amplitude_m=float(A), amplitude_err_m=float(err),
                 peak_m=float(pk), amplitude_y_m=float(amp_y), phase_rad=float(ph),
                 ball_angle_max_rad=float(angle), ball_amplitude_m=float(ball_u),
                 friction_ratio_max=float(ratio), N_min=float(Nmin),
                 rolling=bool(ratio <= case.ball.mu), contact=bool(Nmin > 0.0),
                 converged=converged and res.success, periods=periods, t_end=float(state.t),
                 state=state, theta_end=float(math.fmod(theta_end, 2 * math.pi)))


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
        state, theta = p.state, p.theta_end
        p.state = None
        out.append(p)
        if progress:
            progress(p)
    return out
