"""The ball rolling without slip in a chamber with any rigid motion (docs/design.md section 10):
the general model's equations, outputs, energy and first integrals, its model
class and its monolithic driver. What it owns; the chamber motions are in motions.py.

Derivation (state y = (n, omega), n = (C - A)/d, omega the ball's absolute
angular velocity, all in fixed axes; d = R - r, lambda = r/d). The chamber is a
rigid body with centre A(t), angular velocity Omega(t). No slip at the contact
P = A + R n: the ball's material point there, v_C + omega x (r n), moves with
the chamber's, v_A + Omega x (R n). With C = A + d n, v_C = v_A + d n', so

    n' = (R/d) Omega x n + lambda n x omega.

Newton for the centre and Euler about it, F the contact force on the ball at
P = C + r n, g_vec = (0, 0, -g):

    m (a_A + d n'') = F + m g_vec,        I omega' = r n x F.

Differentiating n' (with d lambda = r):
d n'' = R (Omega' x n + Omega x n') + r (n' x omega + n x omega'). Eliminating F,

    I omega' = m r n x (a_A - g_vec + R (Omega' x n + Omega x n') + r n' x omega)
               + m r^2 n x (n x omega').

Dotting with n: I n . omega' = 0, so n x (n x omega') = -omega' and

    omega' = k n x b,   b = a_A - g_vec + R (Omega' x n + Omega x n') + r n' x omega,

k = m r / (I + m r^2): closed form, no linear solve. The spin omega . n is no
longer constant: d(omega . n)/dt = omega . n' = (R/d) omega . (Omega x n).
With Omega = 0 and a horizontal a_A these are the translation-only equations
(equations.py) term for term, and `derivative` below is written so that it
gives the same floats (the Omega terms add exact zeros): a `Translation` runs
the same trajectory bit for bit on either model (tests check it).

First integrals. The ball's energy E = 1/2 m |v_C|^2 + 1/2 I |omega|^2 + m g zC
changes by the power of the contact force, dE/dt = F . (v_A + Omega x R n)
(the ball's material point at P moves with the chamber's). For a chamber that
turns at a constant Omega about a fixed axis through a fixed centre A:

* `moving_energy`: J = E - (R/r) I Omega . omega is conserved, for ANY axis
  direction. Proof: I omega' = r n x F gives (R/r) d/dt (I Omega . omega)
  = R Omega . (n x F) = F . (Omega x R n) = dE/dt. (This is the "moving energy"
  of affine nonholonomic constraints: the chamber's motion enters the
  constraint as the field "ball spinning in place at (R/r) Omega", which leaves
  the Lagrangian invariant.)
* `jacobi`: with the axis vertical (Omega parallel to g), the Lagrangian in the
  chamber's rotating frame does not depend on time and the constraint there is
  homogeneous, so the Jacobi integral of the rotating frame,
      h = 1/2 m |v_rel|^2 + 1/2 I |omega_rel|^2 - 1/2 m |Omega x (C - A)|^2
          - 1/2 I |Omega|^2 + m g zC = E - Omega . L_A,
  v_rel = v_C - Omega x (C - A), omega_rel = omega - Omega, L_A = m (C - A) x v_C
  + I omega, is conserved too (equivalently E - Omega . L_A). Both together give
  a third, momentum-like integral (R/r) I Omega . omega - Omega . L_A. With a
  horizontal axis (the tumbling drum) gravity turns in the rotating frame and h
  is not conserved, but J is.

Outputs (`ChamberOutputs`): the contact point in fixed axes P = A + R n and in
the chamber's axes P_ch = Q^T (P - A) + (0, 0, R) (the lowest point at rest is
the origin, as in section 1); N = -F . n, the friction force F + N n and the
friction ratio; the ball's force on the chamber F_s = -F in fixed and in
chamber axes; the reaction moments of the chamber's two drives M_i = w_i . (P x
F_s) + v_i . F_s (motions.py defines the drives' twists), and the power the
chamber delivers to the ball, P_ball = F . (v_A + Omega x R n), which equals
-(M1 q1' + M2 q2') and dE/dt. The model is lossless (no rolling resistance or
drag here; Ball's loss parameters are refused).

`simulate_chamber` runs a scene: a `motions.Translation` on the translation-only
model (ballmill.physics.model.simulate, unchanged, with its compiled kernel), anything else on
`ChamberModel` (compiled kernel functions bmg_* when built: kernel.py).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError
from ..integrators import Integrator
from ..model import KERNELS, BallModel, BallState, StepInfo, Trajectory, grid_run, record_interval, simulate
from ..params import Ball
from .motions import ChamberMotion, Translation


def constants(ball: Ball):
    """Constants of the general right-hand side: (R/d, lambda, R, r, g, k)."""
    return (ball.R / ball.d, ball.lam, ball.R, ball.r, ball.g, ball.k)


def derivative(c, y, kin):
    """dy/dt = (n', omega') for y = (n, omega), constants c = `constants(ball)` and the
    chamber's kin = (a_A, Omega, Omega') (9 floats, ChamberMotion.accel)."""
    nx, ny, nz, wx, wy, wz = y
    Rd, lam, R, r, g, k = c
    ax, ay, az, ox, oy, oz, px, py, pz = kin
    ndx = Rd * (oy * nz - oz * ny) + lam * (ny * wz - nz * wy)
    ndy = Rd * (oz * nx - ox * nz) + lam * (nz * wx - nx * wz)
    ndz = Rd * (ox * ny - oy * nx) + lam * (nx * wy - ny * wx)
    bx = ax + R * ((py * nz - pz * ny) + (oy * ndz - oz * ndy)) + r * (ndy * wz - ndz * wy)
    by = ay + R * ((pz * nx - px * nz) + (oz * ndx - ox * ndz)) + r * (ndz * wx - ndx * wz)
    bz = (az + g) + R * ((px * ny - py * nx) + (ox * ndy - oy * ndx)) + r * (ndx * wy - ndy * wx)
    return (ndx, ndy, ndz,
            k * (ny * bz - nz * by), k * (nz * bx - nx * bz), k * (nx * by - ny * bx))


class ChamberOutputs(NamedTuple):
    """What the general model reports at one instant; fixed axes unless named _ch; SI units."""

    Px: float  # contact point, fixed frame [m]
    Py: float
    Pz: float
    Pch_x: float  # contact point in the chamber's axes, Q^T (P - A) + (0, 0, R) [m]
    Pch_y: float
    Pch_z: float
    Cx: float  # ball centre, fixed frame [m]
    Cy: float
    Cz: float
    wx: float  # absolute angular velocity [rad/s]
    wy: float
    wz: float
    spin: float  # omega . n [rad/s]
    N: float  # normal force, > 0 pushes the ball towards the chamber centre [N]
    Ft: float  # magnitude of the friction force [N]
    friction_ratio: float  # |F_t| / N (inf when N <= 0) [1]
    Fx: float  # force of the ball on the chamber F_s = -F, fixed axes [N]
    Fy: float
    Fz: float
    Fch_x: float  # the same force in the chamber's axes, Q^T F_s [N]
    Fch_y: float
    Fch_z: float
    M1: float  # reaction moment on drive 1 (Fig1Machine: the frame shaft, about x1) [N m]
    M2: float  # reaction moment on drive 2 (Fig1Machine: the cranks) [N m]
    P_ball: float  # power the chamber delivers to the ball, F . v_P = -(M1 q1' + M2 q2') [W]
    E: float  # the ball's energy, 1/2 m v_C^2 + 1/2 I omega^2 + m g zC [J]
    contact: bool  # N > 0
    rolling: bool  # contact and |F_t| <= mu N


def out_constants(ball: Ball):
    """Constants of `evaluate`: (R/d, lambda, R, r, g, k, d, m, I, mu)."""
    return constants(ball) + (ball.d, ball.m, ball.I, ball.mu)


def evaluate(ball: Ball, y, cs) -> ChamberOutputs:
    """Outputs for the state y = (n, omega) and the chamber state cs (motions.ChamberState)."""
    return evaluate_c(out_constants(ball), y, cs)


def evaluate_c(c, y, cs) -> ChamberOutputs:
    """`evaluate` with the constants c = out_constants(ball) (the kernel's bmg_outputs
    mirrors this operation for operation)."""
    nx, ny, nz, wx, wy, wz = y
    Rd, lam, R, r, g, k, d, m, I, mu = c
    (Ax, Ay, Az, vAx, vAy, vAz, ax, ay, az, ox, oy, oz, px, py, pz,
     q00, q01, q02, q10, q11, q12, q20, q21, q22,
     q1d, w1x, w1y, w1z, v1x, v1y, v1z, q2d, w2x, w2y, w2z, v2x, v2y, v2z) = cs
    ndx, ndy, ndz, wdx, wdy, wdz = derivative(c[:6], y, (ax, ay, az, ox, oy, oz, px, py, pz))
    # n'' = (R/d) (Omega' x n + Omega x n') + lambda (n' x omega + n x omega')
    nddx = Rd * ((py * nz - pz * ny) + (oy * ndz - oz * ndy)) + lam * (ndy * wz - ndz * wy + ny * wdz - nz * wdy)
    nddy = Rd * ((pz * nx - px * nz) + (oz * ndx - ox * ndz)) + lam * (ndz * wx - ndx * wz + nz * wdx - nx * wdz)
    nddz = Rd * ((px * ny - py * nx) + (ox * ndy - oy * ndx)) + lam * (ndx * wy - ndy * wx + nx * wdy - ny * wdx)
    # contact force on the ball F = m (a_A + d n'' - g_vec)
    Fx = m * (ax + d * nddx)
    Fy = m * (ay + d * nddy)
    Fz = m * ((az + d * nddz) + g)
    N = -(Fx * nx + Fy * ny + Fz * nz)
    ftx, fty, ftz = Fx + N * nx, Fy + N * ny, Fz + N * nz
    Ft = math.sqrt(ftx * ftx + fty * fty + ftz * ftz)
    contact = N > 0.0
    ratio = Ft / N if contact else math.inf
    sx, sy, sz = -Fx, -Fy, -Fz
    Px, Py, Pz = Ax + R * nx, Ay + R * ny, Az + R * nz
    # drives: M_i = w_i . (P x F_s) + v_i . F_s
    mx, my, mz = Py * sz - Pz * sy, Pz * sx - Px * sz, Px * sy - Py * sx
    M1 = (w1x * mx + w1y * my + w1z * mz) + (v1x * sx + v1y * sy + v1z * sz)
    M2 = (w2x * mx + w2y * my + w2z * mz) + (v2x * sx + v2y * sy + v2z * sz)
    # the chamber's material point at P: v_A + Omega x R n
    vpx = vAx + R * (oy * nz - oz * ny)
    vpy = vAy + R * (oz * nx - ox * nz)
    vpz = vAz + R * (ox * ny - oy * nx)
    vcx, vcy, vcz = vAx + d * ndx, vAy + d * ndy, vAz + d * ndz
    E = (0.5 * m * (vcx * vcx + vcy * vcy + vcz * vcz) + 0.5 * I * (wx * wx + wy * wy + wz * wz)
         + m * g * (Az + d * nz))
    return ChamberOutputs(
        Px=Px, Py=Py, Pz=Pz,
        Pch_x=R * (q00 * nx + q10 * ny + q20 * nz),
        Pch_y=R * (q01 * nx + q11 * ny + q21 * nz),
        Pch_z=R * (q02 * nx + q12 * ny + q22 * nz) + R,
        Cx=Ax + d * nx, Cy=Ay + d * ny, Cz=Az + d * nz,
        wx=wx, wy=wy, wz=wz, spin=nx * wx + ny * wy + nz * wz,
        N=N, Ft=Ft, friction_ratio=ratio,
        Fx=sx, Fy=sy, Fz=sz,
        Fch_x=q00 * sx + q10 * sy + q20 * sz,
        Fch_y=q01 * sx + q11 * sy + q21 * sz,
        Fch_z=q02 * sx + q12 * sy + q22 * sz,
        M1=M1, M2=M2, P_ball=Fx * vpx + Fy * vpy + Fz * vpz, E=E,
        contact=contact, rolling=contact and Ft <= mu * N,
    )


# --------------------------------------------------------------------------- integrals
def energy(ball: Ball, y, cs) -> float:
    """The ball's energy in the fixed frame [J] (also ChamberOutputs.E)."""
    return evaluate(ball, y, cs).E


def moving_energy(ball: Ball, y, Omega) -> float:
    """J = E - (R/r) I Omega . omega [J], conserved for a constant Omega about a fixed
    centre A (any axis; module docstring). E is taken with A at height 0."""
    nx, ny, nz, wx, wy, wz = y
    ox, oy, oz = Omega
    kin = (0.0, 0.0, 0.0, ox, oy, oz, 0.0, 0.0, 0.0)
    nd = derivative(constants(ball), y, kin)[:3]
    d, m = ball.d, ball.m
    E = (0.5 * m * d * d * (nd[0] ** 2 + nd[1] ** 2 + nd[2] ** 2)
         + 0.5 * ball.I * (wx * wx + wy * wy + wz * wz) + m * ball.g * d * nz)
    return E - ball.R / ball.r * ball.I * (ox * wx + oy * wy + oz * wz)


def jacobi(ball: Ball, y, Omega) -> float:
    """The rotating frame's Jacobi integral h = E - Omega . L_A [J] (L_A the ball's angular
    momentum about A), conserved for a constant Omega parallel to gravity about a fixed A."""
    nx, ny, nz, wx, wy, wz = y
    ox, oy, oz = Omega
    kin = (0.0, 0.0, 0.0, ox, oy, oz, 0.0, 0.0, 0.0)
    nd = derivative(constants(ball), y, kin)[:3]
    d, m, I = ball.d, ball.m, ball.I
    vc = (d * nd[0], d * nd[1], d * nd[2])
    rho = (d * nx, d * ny, d * nz)
    L = (m * (rho[1] * vc[2] - rho[2] * vc[1]) + I * wx,
         m * (rho[2] * vc[0] - rho[0] * vc[2]) + I * wy,
         m * (rho[0] * vc[1] - rho[1] * vc[0]) + I * wz)
    E = 0.5 * m * (vc[0] ** 2 + vc[1] ** 2 + vc[2] ** 2) + 0.5 * I * (wx * wx + wy * wy + wz * wz) + m * ball.g * rho[2]
    return E - (ox * L[0] + oy * L[1] + oz * L[2])


# --------------------------------------------------------------------------- the model
def _check_lossless(ball: Ball):
    if ball.rolling_resistance or ball.drag:
        raise ParameterError(
            f"the general (turning-chamber) model is lossless: rolling_resistance = "
            f"{ball.rolling_resistance!r} m and drag = {ball.drag!r} N s/m must be 0 "
            f"(losses exist only in the translation-only model, model.BallModel)")


class ChamberModel:
    """The ball in a chamber with any rigid motion: integrator + state, one interval at a time.

    State y = (n, omega) in fixed axes (6 floats, n renormalised after each accepted
    step), the integrator and its scale as BallModel's vector formulation. ``kernel``:
    "auto" (compiled bmg_* functions when built and the motion is one they know:
    Spin, Fig1Machine with CrankStartup/ConstantSpeed laws), "python", or "c" (insist).
    """

    def __init__(self, ball: Ball, method: str = "DOP853", tol: float = 1e-9, h_fixed: float = 1e-3,
                 h_max: float | None = None, kernel: str = "auto", max_steps: int = 1_000_000):
        _check_lossless(ball)
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
        self.ball = ball
        self.kernel = kernel
        self._c = constants(ball)
        self._oc = out_constants(ball)
        w_ref = ball.d * ball.omega_small / ball.r
        self.integrator = Integrator(method, tol=tol, scale=[1.0, 1.0, 1.0] + [w_ref] * 3,
                                     h_fixed=h_fixed, h_max=h_max, max_steps=max_steps,
                                     project=_project)
        self.info = StepInfo()

    def initial(self, motion: ChamberMotion, xC0: float = 0.0, yC0: float = 0.0, w_rel=(0.0, 0.0, 0.0),
                t0: float = 0.0) -> BallState:
        """State at t0 with the ball centre at (xC0, yC0) in the chamber's axes (lower half of
        its sphere of centres) and angular velocity Omega(t0) + Q(t0) w_rel: w_rel = 0 is a
        ball at rest relative to the chamber (co-rotating with it)."""
        d = self.ball.d
        for name, v in (("xC0", xC0), ("yC0", yC0), ("t0", t0)) + tuple(
                (f"w_rel[{i}]", w) for i, w in enumerate(w_rel)):
            if not math.isfinite(v):
                raise ParameterError(f"{name} must be finite, got {name} = {v!r}")
        rho2 = xC0 * xC0 + yC0 * yC0
        if rho2 > d * d:
            raise ParameterError(
                f"initial position out of reach: sqrt(xC0^2 + yC0^2) must be <= R - r = {d:.6g} m, "
                f"got xC0 = {xC0!r} m, yC0 = {yC0!r} m")
        nc = (xC0 / d, yC0 / d, -math.sqrt(max(0.0, 1.0 - rho2 / (d * d))))
        cs = motion.state(t0)
        Q = cs[15:24]
        n = tuple(Q[3 * i] * nc[0] + Q[3 * i + 1] * nc[1] + Q[3 * i + 2] * nc[2] for i in range(3))
        wr = tuple(Q[3 * i] * w_rel[0] + Q[3 * i + 1] * w_rel[1] + Q[3 * i + 2] * w_rel[2] for i in range(3))
        w = (cs[9] + wr[0], cs[10] + wr[1], cs[11] + wr[2])
        return BallState(float(t0), np.array(n + w, dtype=float), None)

    def rhs(self, motion: ChamberMotion):
        c = self._c
        accel = motion.accel

        def f(t, y):
            return derivative(c, y.tolist(), accel(t))
        return f

    def advance(self, state: BallState, t_end: float, motion: ChamberMotion) -> BallState:
        """Integrate from state.t to t_end; the old state is left intact on failure. A motion
        whose accel is reconstruction.ChamberReconstruction's closure (``accel.poly``; the
        BallInShell FMU with motion = 2) runs in the compiled kernel unless ``kernel`` is
        "python" (the same state bit for bit); anything else in Python."""
        if self.kernel != "python" and hasattr(motion.accel, "poly"):
            from . import kernel as fast_turning

            new = fast_turning.advance(self, state, t_end, motion.accel)
            if new is not None:
                return new
        y, h, st = self.integrator.advance(self.rhs(motion), state.t, state.y, t_end, state.h)
        self.info.steps += st.steps
        self.info.rejected += st.rejected
        self.info.nfev += st.nfev
        return BallState(float(t_end), y, h)

    def outputs(self, state: BallState, motion: ChamberMotion) -> ChamberOutputs:
        return evaluate_c(self._oc, state.y.tolist(), motion.state(state.t))


def _project(y):
    """Put n back on the unit sphere after an accepted step (VectorFormulation.project)."""
    s = 1.0 / math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    y[0] *= s
    y[1] *= s
    y[2] *= s
    return y


def simulate_general(model: ChamberModel, motion: ChamberMotion, t_end: float, dt: float,
                     state: BallState | None = None, outputs: bool = True, kernel: str | None = None) -> Trajectory:
    """Monolithic run of the general model, sampled every dt; stops early (success False,
    with the message) when a step fails. ``kernel`` (default: the model's) as ChamberModel.
    The result carries the rolling model's validity (`Trajectory`: valid, t_invalid,
    t_first_slip, t_first_flight, and the message); success stays True when only that ended."""
    from . import kernel as fast_turning

    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"dt must be positive and finite, got {dt!r} s")
    kernel = model.kernel if kernel is None else kernel
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    state = state or model.initial(motion)
    return grid_run(model, motion, fast_turning, t_end, dt, state, outputs, kernel, "simulate_general",
                    model.rhs(motion), _sampler(model, motion), ChamberOutputs._fields)


def _sampler(model, motion):
    """outputs(t, y): the `ChamberOutputs` of state y at time t."""
    oc = model._oc

    def outputs(t, y):
        return tuple(evaluate_c(oc, y.tolist(), motion.state(t)))
    return outputs


def record_python(model, motion, times, state, i, ys, outs):
    """One interval of `simulate_general`'s loop in Python (the kernel hands failures here)."""
    return record_interval(model, model.rhs(motion), _sampler(model, motion), times, state, i, ys, outs)


def simulate_chamber(ball: Ball, motion: ChamberMotion, t_end: float, dt: float, xC0: float = 0.0,
                     yC0: float = 0.0, w_rel=(0.0, 0.0, 0.0), method: str = "DOP853", tol: float = 1e-9,
                     h_fixed: float = 1e-3, h_max: float | None = None, kernel: str = "auto") -> Trajectory:
    """Run a scene and report `ChamberOutputs` columns. A `motions.Translation` (no rotation,
    no vertical motion) runs on the translation-only model (model.simulate, exactly as
    before: it does not pay for the general model); any other motion on `ChamberModel`.
    The ball starts at (xC0, yC0) in the chamber's axes, at rest relative to the chamber
    plus w_rel (for a Translation: absolute angular velocity w_rel, as BallModel.initial).
    Both carry the rolling model's validity (`Trajectory`: valid, t_invalid, t_first_slip,
    t_first_flight; "completed; rolling ended (slip) at t = ... s; contact lost at ... s"):
    success says only that the integration reached t_end."""
    if not motion.rotates:
        bm = BallModel(ball, method=method, tol=tol, h_fixed=h_fixed, h_max=h_max, kernel=kernel)
        traj = simulate(bm, motion.platform, t_end, dt, bm.initial(xC0, yC0, tuple(w_rel)), kernel=kernel)
        traj.out = translation_columns(ball, motion, traj)
        return traj
    model = ChamberModel(ball, method=method, tol=tol, h_fixed=h_fixed, h_max=h_max, kernel=kernel)
    return simulate_general(model, motion, t_end, dt, model.initial(motion, xC0, yC0, w_rel))


def translation_columns(ball: Ball, motion: Translation, traj: Trajectory) -> dict:
    """ChamberOutputs columns of a translation-only run: its own outputs where they exist
    (the contact point in the chamber's axes is its (xP, yP, zP), the crank's moment its
    M_reaction), the rest from the platform's state (numpy over the grid)."""
    o = traj.out
    if not o:
        return {}
    platform = motion.platform
    ps = np.array([platform.state(float(t)) for t in traj.t], dtype=float).reshape(-1, 6)
    x, yy, vx, vy = ps[:, 0], ps[:, 1], ps[:, 2], ps[:, 3]
    nv, w = traj.y[:, :3], traj.y[:, 3:]
    d, m, g, R, zA = ball.d, ball.m, ball.g, ball.R, motion.zA
    vc = d * ball.lam * np.cross(nv, w)
    vc[:, 0] += vx
    vc[:, 1] += vy
    E = 0.5 * m * np.sum(vc * vc, axis=1) + 0.5 * ball.I * np.sum(w * w, axis=1) + m * g * (zA + d * nv[:, 2])
    if hasattr(platform, "angle"):  # the crank (motions.Translation's drive 1)
        M1, M2 = o["M_reaction"], np.zeros_like(x)
    else:  # the x and y motions: forces [N]
        M1, M2 = o["Fx"], o["Fy"]
    cols = {"Px": x + R * nv[:, 0], "Py": yy + R * nv[:, 1], "Pz": zA + R * nv[:, 2],
            "Pch_x": o["xP"], "Pch_y": o["yP"], "Pch_z": o["zP"],
            "Cx": x + o["xC"], "Cy": yy + o["yC"], "Cz": zA - R + o["zC"],
            "wx": o["wx"], "wy": o["wy"], "wz": o["wz"], "spin": np.sum(nv * w, axis=1),
            "N": o["N"], "Ft": o["Ft"], "friction_ratio": o["friction_ratio"],
            "Fx": o["Fx"], "Fy": o["Fy"], "Fz": o["Fz"], "Fch_x": o["Fx"], "Fch_y": o["Fy"], "Fch_z": o["Fz"],
            "M1": M1, "M2": M2, "P_ball": -(o["Fx"] * vx + o["Fy"] * vy), "E": E,
            "contact": o["contact"], "rolling": o["rolling"]}
    return {k: np.asarray(cols[k], dtype=float) for k in ChamberOutputs._fields}


__all__ = ["ChamberModel", "ChamberOutputs", "constants", "derivative", "evaluate", "energy", "jacobi",
           "moving_energy", "simulate_chamber", "simulate_general"]
