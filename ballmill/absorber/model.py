"""Monolithic model of a ball absorber: the structure and the ball in one ODE.

This module owns docs/design.md section 11 in one initial-value problem: the
linear modal structure of `ballmill.absorber.structure` carries the spherical
cavity, the ball rolls in it by the vector equations of
`ballmill.physics.equations` (with its rolling resistance delta and drag
c_drag), and each pushes the other. Integrated by the library's own
Runge-Kutta integrators (`ballmill.physics.integrators`). No FMI, no I/O.

State z = (structure: q_x, q_x', q_y, q_y';  ball: n, omega;
           quadratures: W_exc, W_damp, W_ball)
with W_exc the work of the excitation (external force and the ground's
inertial load, in the ground's frame), W_damp the energy dissipated in the
structure's modal dampers, W_ball the energy dissipated by the ball's
rolling resistance and drag.

The accelerations, solved at each instant (no lag)
---------------------------------------------------
The ball's load on the cavity is F_b = -m (a_C - g_vec), a_C = a_O + d n''
(with drag, the load through the material is included: -F - F_d = -m (a_C - g_vec),
as in `outputs._evaluate_lossy`). The cavity's absolute acceleration is

    a_O = a_free + G F_b,h,    G = diag(sum_j phi_j^2 / M_j) per axis,

a_free what the excitation, springs and dampers alone give. From
omega' = k n x (a_O - g_vec + r n' x omega - F_d / m) + M_rr / (I + m r^2),
M_rr = -delta N w_t / s (s = sqrt(|w_t|^2 + eps^2)), N = N_0 - m a_O . n,
and d n'' = r (n' x omega + n x omega'), with r k = 1 / (1 + I/(m r^2)):

    F_b = F_b0 + B a_O,
    B = -m [ (1 - r k) 1 + r k n n^T + (d delta m / (J s)) n' n^T ]   (J = I + m r^2)

(horizontal 2x2 block; the last term only while the ball presses on the wall,
N > 0, and delta > 0; n x w_t = n x omega = n' / lambda). F_b0 is the load at
a_O = 0 on the same branch. So (1 - G B) a_O = a_free + G F_b0: a 2x2 linear
system, solved in closed form. At rest at the bottom B = -(2/7) m 1: the
rolling ball's instantaneous effective mass is 2/7 of its mass (a solid ball),
the rest of it is carried through the rolling.

The ball's derivative is then the library's `VectorFormulation.derivative` at
that a_O, and the load that goes into the structure is recomputed from the
omega' it returns; `StructureBall.accelerations` returns both, and the tests
check that the structure's acceleration equals the a_O the ball saw (to
round-off), and the whole against a Newton-Euler linear solve.

Energy: with E = structure (modal kinetic + strain) + ball (kinetic relative
to the ground + potential), dE/dt = P_exc - P_damp - P_ball, where
P_exc = sum q_j' (psi_j F - L_j a_g) - m a_g . v_C (v_C relative to the
ground). `AbsorberResult.energy_residual` is W_exc - (E - E_0) - W_damp - W_ball.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ballmill.physics import outputs as _out
from ballmill.physics.equations import ROLLING_EPS, VectorFormulation, omega_dot, omega_dot_lossy
from ballmill.physics.errors import ParameterError
from ballmill.physics.events import Plain, integrate
from ballmill.physics.integrators import Integrator
from ballmill.physics.model import judge
from ballmill.physics.params import Ball

from .structure import NoExcitation, Structure, StructureModel


@dataclass
class AbsorberState:
    """Time, state vector z (see module docstring) and the integrator's next step."""

    t: float
    z: np.ndarray
    h: float | None = None

    def copy(self) -> "AbsorberState":
        return AbsorberState(self.t, self.z.copy(), self.h)


class StructureBall:
    """Structure (modal, per axis) + ball rolling in its cavity, one ODE.

    structure: `Structure`; ball: `Ball` (its rolling_resistance and drag are the
    absorber's damping); excitation: anything with ``loads(t) -> (F_x, F_y,
    a_gx, a_gy)`` (`ballmill.absorber.structure`).
    """

    def __init__(self, structure: Structure, ball: Ball, excitation=None):
        if not isinstance(ball, Ball):
            raise ParameterError(f"ball must be a Ball, got {ball!r}")
        if ball.bed_depth is not None:
            raise ParameterError(
                f"an absorber's cavity holds no ground material: bed_depth = {ball.bed_depth!r} m must be None "
                f"(its rolling resistance and drag, the absorber's damping, act wherever the ball touches)")
        self.ball = ball
        self.struct = StructureModel(structure, excitation)
        self.structure = structure
        self.form = VectorFormulation(ball)
        self.ns = self.struct.n_states
        self.ib = self.ns  # index of the ball's n_x
        self.iq = self.ns + 6  # index of the quadratures
        self.n_states = self.ns + 9
        b = ball
        self._c = (b.lam, b.r, b.g, b.k, b.m, b.d, b.r * b.k)
        self.delta = b.rolling_resistance
        self.J = b.I + b.m * b.r ** 2
        self.lossy = bool(b.rolling_resistance or b.drag)
        # the lossy omega' without the rolling resistance (it is added on a chosen branch)
        self._loss_nr = (b.k, b.r, b.g, b.m, b.d, b.drag * b.d / b.m, 0.0, self.J, ROLLING_EPS ** 2)

    @property
    def excitation(self):
        return self.struct.excitation

    @excitation.setter
    def excitation(self, exc):
        self.struct.excitation = exc if exc is not None else NoExcitation()

    # -- the instantaneous linear system ---------------------------------------------
    def _load_affine(self, n, w, nd, branch_rr):
        """(F0x, F0y, Bxx, Bxy, Byx, Byy): the ball's horizontal load F_b = F0 + B a_O
        (module docstring), with the rolling resistance on (branch_rr) or off."""
        lam, r, g, k, m, d, rk = self._c
        nx, ny, nz = n
        wx, wy, wz = w
        ndx, ndy, ndz = nd
        if self.lossy:
            wd = omega_dot_lossy(self._loss_nr, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, 0.0, 0.0)
        else:
            wd = omega_dot(k, r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, 0.0, 0.0)
        wdx, wdy, wdz = wd
        rho = 0.0
        if branch_rr:
            s = nx * wx + ny * wy + nz * wz
            tx, ty, tz = wx - s * nx, wy - s * ny, wz - s * nz
            sq = math.sqrt(tx * tx + ty * ty + tz * tz + ROLLING_EPS ** 2)
            N0 = m * (d * (ndx * ndx + ndy * ndy + ndz * ndz) - g * nz)
            f = -self.delta * N0 / (self.J * sq)
            wdx, wdy = wdx + f * tx, wdy + f * ty
            wdz = wdz + f * tz
            rho = d * self.delta * m / (self.J * sq)
        # d n''_0 = r (n' x omega + n x omega'_0), horizontal part
        F0x = -m * r * (ndy * wz - ndz * wy + ny * wdz - nz * wdy)
        F0y = -m * r * (ndz * wx - ndx * wz + nz * wdx - nx * wdz)
        c1 = 1.0 - rk
        Bxx = -m * (c1 + rk * nx * nx + rho * ndx * nx)
        Bxy = -m * (rk * nx * ny + rho * ndx * ny)
        Byx = -m * (rk * ny * nx + rho * ndy * nx)
        Byy = -m * (c1 + rk * ny * ny + rho * ndy * ny)
        return F0x, F0y, Bxx, Bxy, Byx, Byy

    def solve_acceleration(self, t, z, loads=None):
        """(a_Ox, a_Oy): the cavity's absolute acceleration at (t, z), solved with the
        ball's load (module docstring)."""
        if loads is None:
            loads = self.struct.excitation.loads(t)
        return self._solve(z, loads)[:2]

    def _solve(self, z, loads):
        ib = self.ib
        n = (z[ib], z[ib + 1], z[ib + 2])
        w = (z[ib + 3], z[ib + 4], z[ib + 5])
        lam = self._c[0]
        nd = (lam * (n[1] * w[2] - n[2] * w[1]), lam * (n[2] * w[0] - n[0] * w[2]),
              lam * (n[0] * w[1] - n[1] * w[0]))
        a0x, a0y, rx, ry = self.struct.free_acceleration(z, loads)
        Gx, Gy = self.struct.flexibility
        branches = (True, False) if self.delta else (False,)
        for branch in branches:
            F0x, F0y, Bxx, Bxy, Byx, Byy = self._load_affine(n, w, nd, branch)
            a11, a12 = 1.0 - Gx * Bxx, -Gx * Bxy
            a21, a22 = -Gy * Byx, 1.0 - Gy * Byy
            b1, b2 = a0x + Gx * F0x, a0y + Gy * F0y
            det = a11 * a22 - a12 * a21
            ax = (b1 * a22 - a12 * b2) / det
            ay = (a11 * b2 - a21 * b1) / det
            if len(branches) == 1:
                break
            m, d, g = self._c[4], self._c[5], self._c[2]
            N = m * (d * (nd[0] ** 2 + nd[1] ** 2 + nd[2] ** 2) - ax * n[0] - ay * n[1] - g * n[2])
            if (N > 0.0) == branch:
                break  # the branch assumed is the branch found
        return ax, ay, rx, ry, n, w, nd

    def accelerations(self, t, z, loads=None):
        """Everything the right-hand side computes at (t, z), as a dict: a_O (ax, ay),
        the ball's derivative (dball, 6), its horizontal load on the cavity (Fbx, Fby),
        the modal accelerations (qdd_x, qdd_y) and the cavity acceleration they imply
        (ax_struct, ay_struct: equal to ax, ay up to round-off), loads."""
        if loads is None:
            loads = self.struct.excitation.loads(t)
        ax, ay, rx, ry, n, w, nd = self._solve(z, loads)
        ib = self.ib
        db = self.form.derivative(list(z[ib:ib + 6]), ax, ay)
        lam, r, g, k, m, d, rk = self._c
        wdx, wdy, wdz = db[3], db[4], db[5]
        Fbx = -m * (ax + r * (nd[1] * w[2] - nd[2] * w[1] + n[1] * wdz - n[2] * wdy))
        Fby = -m * (ay + r * (nd[2] * w[0] - nd[0] * w[2] + n[2] * wdx - n[0] * wdz))
        qdd = []
        axs = []
        for (cs, off, nm), r_, Fb, g_ in zip(self.struct._axes, (rx, ry), (Fbx, Fby),
                                             (loads[2], loads[3])):
            q = [r_[j] + c[3] * Fb / c[0] for j, c in enumerate(cs)]
            qdd.append(q)
            axs.append(g_ + sum(c[3] * qq for c, qq in zip(cs, q)))
        return {"ax": ax, "ay": ay, "dball": db, "Fbx": Fbx, "Fby": Fby, "qdd_x": qdd[0],
                "qdd_y": qdd[1], "ax_struct": axs[0], "ay_struct": axs[1], "loads": loads,
                "n": n, "w": w, "nd": nd}

    # -- the ODE ---------------------------------------------------------------------
    def rhs(self, t, z):
        """dz/dt as a tuple (the integrators' fast path)."""
        if type(z) is not list:
            z = z.tolist()
        loads = self.struct.excitation.loads(t)
        acc = self.accelerations(t, z, loads)
        ns, ib = self.ns, self.ib
        dz = [0.0] * self.n_states
        for (cs, off, nm), q in zip(self.struct._axes, (acc["qdd_x"], acc["qdd_y"])):
            for j in range(nm):
                dz[off + j] = z[off + nm + j]
                dz[off + nm + j] = q[j]
        dz[ib:ib + 6] = acc["dball"]
        P_exc, P_damp = self.struct.powers(z, loads)
        # the ground's inertial load on the ball, -m a_g . v_C (relative to the ground)
        m, d = self._c[4], self._c[5]
        nd = acc["nd"]
        if loads[2] or loads[3]:
            xO, yO, vx, vy, _, _ = self.struct.cavity(t, z, 0.0, 0.0, loads)
            P_exc -= m * (loads[2] * (vx + d * nd[0]) + loads[3] * (vy + d * nd[1]))
        dz[ns + 6] = P_exc
        dz[ns + 7] = P_damp
        dz[ns + 8] = self._ball_dissipation(z, acc) if self.lossy else 0.0
        return tuple(dz)

    def _ball_dissipation(self, z, acc):
        b = self.ball
        nd, n, w = acc["nd"], acc["n"], acc["w"]
        m, d, g = b.m, b.d, b.g
        P = b.drag * d * d * (nd[0] ** 2 + nd[1] ** 2 + nd[2] ** 2)
        if self.delta:
            N = m * (d * (nd[0] ** 2 + nd[1] ** 2 + nd[2] ** 2) - acc["ax"] * n[0] - acc["ay"] * n[1]
                     - g * n[2])
            if N > 0.0:
                s = n[0] * w[0] + n[1] * w[1] + n[2] * w[2]
                t2 = sum((w[i] - s * n[i]) ** 2 for i in range(3))
                P += self.delta * N * t2 / math.sqrt(t2 + ROLLING_EPS ** 2)
        return P

    def project(self, z):
        """Put the ball's n back on the unit sphere (after an accepted step)."""
        ib = self.ib
        s = 1.0 / math.sqrt(z[ib] ** 2 + z[ib + 1] ** 2 + z[ib + 2] ** 2)
        z[ib] *= s
        z[ib + 1] *= s
        z[ib + 2] *= s
        return z

    # -- states ----------------------------------------------------------------------
    def initial(self, t0: float = 0.0, qx=None, qdx=None, qy=None, qdy=None, xC0: float = 0.0,
                yC0: float = 0.0, w0=(0.0, 0.0, 0.0)) -> AbsorberState:
        """Structure at rest (or modal q, q'), ball at (xC0, yC0) on the lower half of its
        sphere of centres with angular velocity w0, quadratures zero."""
        zs = self.struct.initial(qx, qdx, qy, qdy)
        d = self.ball.d
        for name, v in (("xC0", xC0), ("yC0", yC0)):
            if not math.isfinite(v):
                raise ParameterError(f"{name} must be finite, got {name} = {v!r} m")
        rho2 = xC0 * xC0 + yC0 * yC0
        if rho2 > d * d:
            raise ParameterError(f"initial ball position out of reach: sqrt(xC0^2 + yC0^2) must be "
                                 f"<= R - r = {d:.6g} m, got {math.sqrt(rho2):.6g} m")
        n = [xC0 / d, yC0 / d, -math.sqrt(max(0.0, 1.0 - rho2 / (d * d)))]
        return AbsorberState(float(t0), np.array(zs + n + [float(v) for v in w0] + [0.0] * 3), None)

    def scale(self, x_ref: float = 1e-3) -> list:
        """Typical magnitude of each state component for the absolute tolerance, for a
        structure displacement of about x_ref [m]."""
        sc = []
        for cs, off, nm in self.struct._axes:
            sc += [x_ref] * nm + [x_ref * math.sqrt(c[1] / c[0]) for c in cs]
        b = self.ball
        wb = b.omega_small
        u_ref = max(x_ref, 1e-9)
        sc += [u_ref / b.d, u_ref / b.d, 1.0] + [u_ref * wb / b.r] * 3
        E_ref = max(0.5 * sum(c[1] for cs, _, _ in self.struct._axes for c in cs) * x_ref ** 2, 1e-12)
        return sc + [E_ref] * 3

    # -- what a run reports ----------------------------------------------------------
    def energy(self, t, z) -> float:
        """Structure (relative to the ground) + ball (kinetic relative to the ground,
        potential) [J]."""
        z = list(z)
        xO, yO, vx, vy, _, _ = self.struct.cavity(t, z, 0.0, 0.0, (0.0, 0.0, 0.0, 0.0))
        ib = self.ib
        return self.struct.energy(z) + _out.energy(self.ball, z[ib:ib + 3], z[ib + 3:ib + 6], vx, vy)

    def outputs(self, t, z) -> dict:
        """Structure motion, the ball's outputs (`outputs.evaluate` at the solved a_O),
        energy and work at one instant."""
        z = list(z)
        loads = self.struct.excitation.loads(t)
        acc = self.accelerations(t, z, loads)
        xO, yO, vx, vy, _, _ = self.struct.cavity(t, z, 0.0, 0.0, loads)
        ib, q = self.ib, self.iq
        o = _out.evaluate(self.ball, z[ib:ib + 3], z[ib + 3:ib + 6], acc["ax"], acc["ay"])
        d = {"xO": xO, "yO": yO, "vxO": vx, "vyO": vy, "axO": acc["ax"], "ayO": acc["ay"],
             "Fx_ext": loads[0], "Fy_ext": loads[1], "agx": loads[2], "agy": loads[3],
             "Fbx": acc["Fbx"], "Fby": acc["Fby"],
             "theta": math.acos(max(-1.0, min(1.0, -z[ib + 2]))),
             "E": self.energy(t, z), "W_exc": z[q], "W_damp": z[q + 1], "W_ball": z[q + 2]}
        d.update(o._asdict())
        return d


# ---------------------------------------------------------------------------
@dataclass
class AbsorberResult:
    """A run of `simulate_absorber`: t, the state on the grid (rows), outputs."""

    t: np.ndarray
    z: np.ndarray
    data: dict = field(default_factory=dict)
    state: AbsorberState | None = None  # the last state (continue from here)
    success: bool = True
    message: str = "completed"
    steps: int = 0
    nfev: int = 0
    # the ball's rolling model (`ballmill.physics.model.Trajectory`'s meaning; None: not
    # judged, record = "motion" keeps no N)
    valid: bool | None = None
    t_invalid: float | None = None
    t_first_slip: float | None = None
    t_first_flight: float | None = None

    def __getitem__(self, key):
        return self.data[key]

    @property
    def energy_residual(self) -> np.ndarray:
        """W_exc - (E - E_0) - W_damp - W_ball [J]: zero up to the integration error."""
        d = self.data
        return d["W_exc"] - (d["E"] - d["E"][0]) - d["W_damp"] - d["W_ball"]


RECORDS = ("full", "motion")


def _state_row(t, z):
    """The driver's grid row of the absorber's runs: the state itself."""
    return z


def simulate_absorber(system: StructureBall, t_end: float, dt: float, state: AbsorberState | None = None,
                      tol: float = 1e-9, method: str = "DOP853", x_ref: float = 1e-3,
                      record: str = "full", h_max: float | None = None,
                      integrator: Integrator | None = None, kernel: str = "auto") -> AbsorberResult:
    """Integrate from state (default: all at rest) to t_end, sampled every dt.

    kernel: "auto" runs the integration in the compiled kernel where it covers
    the run (`ballmill.absorber.kernel.applicable`: harmonic force or ground,
    at most 4 modes per axis), "c" insists (KernelUnavailable with the reason),
    "python" never uses it. Both give the same trajectory to round-off in the
    right-hand side (tests/test_absorber_kernel.py); the outputs are Python's.

    record: "full" (every output of `StructureBall.outputs`) or "motion" (the
    state only, and xO, yO: cheaper, for steady-state measurements).
    x_ref: typical structure displacement [m]; sets the absolute tolerances.
    Where the excitation has breakpoints (a ground record's samples) the
    integrator lands on each. Stops early with success False and the message
    when a step fails. With record "full" the result carries the ball's validity
    (valid, t_invalid, t_first_slip, t_first_flight, and the message, as
    `ballmill.physics.model.Trajectory`); success stays True when only that ended.
    """
    if record not in RECORDS:
        raise ValueError(f"record must be one of {RECORDS}, got {record!r}")
    if not (dt > 0 and math.isfinite(dt)):
        raise ParameterError(f"dt must be positive and finite, got dt = {dt!r} s")
    state = state or system.initial()
    if not (t_end > state.t and math.isfinite(t_end)):
        raise ParameterError(f"t_end must be finite and after the start {state.t:g} s, got {t_end!r} s")
    integ = integrator or Integrator(method, tol=tol, scale=system.scale(x_ref), h_max=h_max,
                                     project=system.project)
    n_steps = int(round((t_end - state.t) / dt))
    times = state.t + dt * np.arange(n_steps + 1)
    times[-1] = t_end if abs(times[-1] - t_end) < 1e-9 * dt else times[-1]
    bps = tuple(getattr(system.excitation, "breakpoints", lambda: ())())
    zs = np.empty((n_steps + 1, system.n_states))
    zs[0] = state.z
    f = system.rhs
    z, h, t = state.z, state.h, state.t
    steps = nfev = 0
    success, message, last = True, "completed", n_steps
    compiled = None
    if kernel not in ("auto", "c", "python"):
        raise ValueError(f"kernel must be 'auto', 'c' or 'python', got {kernel!r}")
    if kernel != "python":
        from . import kernel as _kernel
        why = _kernel.applicable(system, integ) or ("ground record breakpoints" if bps else "")
        if kernel == "c" and why:
            from ballmill.physics.fast import KernelUnavailable
            raise KernelUnavailable(why)
        compiled = None if why else _kernel.problem(system, integ)
    i = 1
    while i <= n_steps:
        if compiled is not None and h is not None:  # the adaptive methods' first step is Python's
            reached, h_c, st_steps, st_nfev = _kernel.simulate_grid(compiled, times, zs, i - 1, h)
            if reached >= i:
                steps, nfev, h = steps + st_steps, nfev + st_nfev, h_c
                z, t, i = zs[reached].copy(), float(times[reached]), reached + 1
                continue
        # in Python on the event-driven driver: the interval the kernel handed back (or,
        # before the kernel's first chunk, the first one), or all the rest without the kernel
        upto = i if compiled is not None else n_steps
        run = integrate(Plain(integ, f, _state_row), 0, t, z, times[i:upto + 1], h=h, stops=bps)
        steps, nfev = steps + run.stats.steps, nfev + run.stats.nfev
        done = len(run.rows)
        zs[i:i + done] = run.rows
        if not run.success:
            success, message, last = False, f"stopped at t = {run.t_last:.6g} s: {run.error}", i - 1 + done
            break
        z, h, t, i = run.y, run.h, run.t_last, i + done
    times, zs = times[:last + 1], zs[:last + 1]
    data = {}
    if record == "full":
        rows = [system.outputs(float(tt), zz) for tt, zz in zip(times, zs)]
        data = {key: np.array([r[key] for r in rows], dtype=float) for key in rows[0]}
    else:
        # StructureModel.cavity's positions, sum(phi_j q_j) left to right, on all rows at once
        pos = []
        for cs, off, nm in system.struct._axes:
            acc = np.zeros(len(zs))
            for j, c in enumerate(cs):
                acc = c[3] * zs[:, off + j] if j == 0 else acc + c[3] * zs[:, off + j]
            pos.append(acc)
        data = {"xO": pos[0], "yO": pos[1]}
    result = AbsorberResult(times, zs, data, AbsorberState(float(times[-1]), zs[-1].copy(), h),
                            success, message, steps, nfev)
    judge(result, system.ball.mu)
    return result


def simulate_structure(structure: Structure, excitation, t_end: float, dt: float, tol: float = 1e-9,
                       x_ref: float = 1e-3, method: str = "DOP853") -> AbsorberResult:
    """The bare structure (no ball) under the same excitation, with the same
    integrator: the reference an absorber is measured against. ``data`` holds
    xO, yO, vxO, vyO (relative to the ground), axO, ayO (absolute), E, W_exc, W_damp."""
    sm = StructureModel(structure, excitation)
    ns = sm.n_states

    def f(t, z):
        zl = z.tolist()
        loads = excitation.loads(t)
        dz = sm.derivative(t, zl, 0.0, 0.0, loads)
        P_exc, P_damp = sm.powers(zl, loads)
        return tuple(dz) + (P_exc, P_damp)

    sc = []
    for cs, off, nm in sm._axes:
        sc += [x_ref] * nm + [x_ref * math.sqrt(c[1] / c[0]) for c in cs]
    E_ref = max(0.5 * sum(c[1] for cs, _, _ in sm._axes for c in cs) * x_ref ** 2, 1e-12)
    integ = Integrator(method, tol=tol, scale=sc + [E_ref, E_ref])
    n_steps = int(round(t_end / dt))
    times = dt * np.arange(n_steps + 1)
    bps = tuple(getattr(excitation, "breakpoints", lambda: ())())
    run = integrate(Plain(integ, f, _state_row), 0, 0.0, np.zeros(ns + 2), times, stops=bps)
    if not run.success:
        raise run.error
    zs = np.array(run.rows)
    rows = []
    for tt, zz in zip(times, zs):
        zl = zz.tolist()
        loads = excitation.loads(float(tt))
        rows.append(sm.cavity(float(tt), zl, 0.0, 0.0, loads) + (sm.energy(zl), zl[ns], zl[ns + 1]))
    arr = np.array(rows)
    keys = ("xO", "yO", "vxO", "vyO", "axO", "ayO", "E", "W_exc", "W_damp")
    return AbsorberResult(times, zs, {k: arr[:, i] for i, k in enumerate(keys)})
