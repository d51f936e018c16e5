"""Peer "paper-literal": a literal port of the paper's MathCAD program.

State (xC, yC, wx, wy, wz) as in the paper's system (13); omega' from the
3x3 linear system of eq. (12), solved by Cramer's rule at every call
(`ballmill.physics.equations.omega_dot_cramer`, derived anew because the
printed determinants have typos); the platform law (14) written out inline.
scipy's solve_ivp(method="RK45") with t_eval on the output grid stands in
for MathCAD's Rkadapt (adaptive steps, results on a uniform grid).

Outputs per grid point, as the paper: P = R/(R-r) (xC, yC, zC - r), and N by
eq. (18) with the centre's acceleration taken from the equations of motion
(the paper differentiated cubic splines of xC, yC, zC instead; that route is
measured separately by `spline_normal_force`).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from ballmill.physics.equations import omega_dot_cramer

from .problem import Problem, RunResult, Sample, errors


def make_rhs(problem: Problem):
    """(f(t, y), platform_accel(t)) of the paper's system (13) for the fast start-up."""
    ball, drive = problem.ball, problem.drive
    r, R = ball.r, ball.R
    lam = r / (R - r)
    d2 = (R - r) ** 2
    l, t0 = drive.l, drive.t0
    w0 = 2.0 * math.pi * drive.n0 / 60.0

    def platform_accel(t):
        # law (14): x1O = l cos psi, y1O = l sin psi, psi from the start-up law
        if t <= t0:
            psi = -w0 * (t - t0) ** 3 / (3.0 * t0 ** 2) + w0 * t - w0 * t0 / 3.0
            dpsi = w0 * (1.0 - (1.0 - t / t0) ** 2)
            ddpsi = 2.0 * w0 * (1.0 - t / t0) / t0
        else:
            psi = 2.0 / 3.0 * w0 * t0 + w0 * (t - t0)
            dpsi, ddpsi = w0, 0.0
        c, s = math.cos(psi), math.sin(psi)
        return -l * (s * ddpsi + c * dpsi * dpsi), l * (c * ddpsi - s * dpsi * dpsi)

    def f(t, y):
        # y arrives as a numpy array: unpack it as Python floats (tolist), as the library's
        # rhs does; unpacking the array itself gives numpy scalars, whose arithmetic makes
        # this function about 6x slower (measured in the micro section)
        xC, yC, wx, wy, wz = y.tolist()
        R_zC = math.sqrt(d2 - xC * xC - yC * yC)  # R - zC
        ax, ay = platform_accel(t)
        dwx, dwy, dwz = omega_dot_cramer(ball, xC, yC, wx, wy, wz, ax, ay)
        return [lam * (wy * R_zC + wz * yC), -lam * (wx * R_zC + wz * xC), dwx, dwy, dwz]

    return f, platform_accel


def outputs(problem: Problem, ts, ys, platform_accel) -> Sample:
    """P and N (eq. 18) at the grid points, one point at a time as the paper's program."""
    ball = problem.ball
    r, R, m, g = ball.r, ball.R, ball.m, ball.g
    d = R - r
    lam = r / d
    P = np.empty((len(ts), 3))
    N = np.empty(len(ts))
    for i, (t, (xC, yC, wx, wy, wz)) in enumerate(zip(ts.tolist(), ys.T.tolist())):
        s = math.sqrt(d * d - xC * xC - yC * yC)
        zC = R - s
        P[i] = (R / d * xC, R / d * yC, R / d * (zC - r))
        ax, ay = platform_accel(t)
        ex, ey, ez = omega_dot_cramer(ball, xC, yC, wx, wy, wz, ax, ay)
        px, py, pz = xC, yC, zC - R  # rho = C - A
        vx = lam * (py * wz - pz * wy)  # v_C = lambda rho x omega
        vy = lam * (pz * wx - px * wz)
        vz = lam * (px * wy - py * wx)
        # a_C = a_O + lambda (v_C x omega + rho x omega')
        acx = ax + lam * (vy * wz - vz * wy + py * ez - pz * ey)
        acy = ay + lam * (vz * wx - vx * wz + pz * ex - px * ez)
        acz = lam * (vx * wy - vy * wx + px * ey - py * ex)
        N[i] = -m * (acx * xC / d + acy * yC / d + (acz + g) * (zC - R) / d)
    return Sample(P, N)


def run(problem: Problem, rtol: float):
    f, platform_accel = make_rhs(problem)
    scale = np.array([problem.ball.d] * 2 + [problem.w_ref] * 3)
    sol = solve_ivp(f, (0.0, problem.t_end), [0.0, 0.0, 0.0, 0.0, 0.0], method="RK45",
                    t_eval=problem.grid, rtol=rtol, atol=rtol * scale)
    return sol, outputs(problem, sol.t, sol.y, platform_accel)


def prepare(problem: Problem, ref: Sample, rtol: float) -> RunResult:
    """One untimed run (errors, nfev) and the closure that repeats it."""
    res = RunResult("paper-literal", "solve_ivp RK45", f"rtol {rtol:g}", rtol)
    try:
        sol, sample = run(problem, rtol)
    except (ValueError, ArithmeticError) as e:  # sqrt of a negative number: past the equator
        res.ok, res.message = False, f"{type(e).__name__}: {e} (the paper's coordinates left " \
                                     f"the lower hemisphere)"
        return res
    res.ok, res.message = bool(sol.success), sol.message
    res.err_P, res.err_N = errors(sample, ref)
    res.nfev = int(sol.nfev)
    res.extra["sample"] = sample
    res.extra["rerun"] = lambda: run(problem, rtol)
    return res


def spline_normal_force(problem: Problem, rtol: float = 1e-12):
    """The paper's own route to N: cubic splines through xC, yC, zC on the grid,
    differentiated twice. Returns the sample (with this N) for error checks."""
    from scipy.interpolate import CubicSpline

    sol, _ = run(problem, rtol)
    ball = problem.ball
    d = ball.d
    t = sol.t
    xC, yC = sol.y[0], sol.y[1]
    zC = ball.R - np.sqrt(d * d - xC ** 2 - yC ** 2)
    acc = [CubicSpline(t, q)(t, 2) for q in (xC, yC, zC)]
    _, platform_accel = make_rhs(problem)
    aO = np.array([platform_accel(float(tt)) for tt in t])
    acx, acy, acz = aO[:, 0] + acc[0], aO[:, 1] + acc[1], acc[2]
    N = -ball.m * (acx * xC / d + acy * yC / d + (acz + ball.g) * (zC - ball.R) / d)
    P = np.column_stack([ball.R / d * xC, ball.R / d * yC, ball.R / d * (zC - ball.r)])
    return Sample(P, N)


def spline_error(problem: Problem, ref: Sample):
    return errors(spline_normal_force(problem), ref)
