"""Monolithic reference: induction-motor drive, crank, platform and ball in one ODE.

The co-simulation InductionMotor <-> BallInShell exchanges the platform
motion and the ball's reaction torque only at communication points. Here the
same physics is one initial-value problem, solved to tight tolerances, so
that the coupling error of the co-simulation can be measured against it.

State z = (drive state, ball state, quadratures):
    drive: (psi, psi') for Kloss, plus the 4 fluxes for the dq model
           (ballmill.physics.drives.induction.CrankDrive);
    ball:  the formulation's coordinates (vector: n, omega);
    quadratures: W_motor = int T_motor w_motor dt (motor's mechanical work),
           W_diss = int P_diss dt (rolling resistance and drag), and for dq
           W_el = int P_el dt, W_cu (copper losses).

The algebraic loop. The crank equation J_total psi'' = i T_motor + M_reaction
needs the ball's reaction torque, which depends on the platform acceleration
a_O, which depends on psi'':
    a_O = l (-psi'' sin psi - psi'^2 cos psi,  psi'' cos psi - psi'^2 sin psi).
a_O is affine in psi'', and every ball output is affine in a_O (omega' is
linear in a_O, the forces are linear in omega' and a_O; the rolling
resistance enters through N, also affine in a_O). So M_reaction = A + B psi''
exactly, and each right-hand-side evaluation finds A and B by evaluating the
ball's outputs (ballmill.physics.outputs.evaluate) at psi'' = 0 and 1, then
solves psi'' = (i T_motor + A) / (J_total - B). B is about -m l^2 (the ball
adds its mass to the platform's) minus what its rolling takes. The one
exception to affinity is the switch N > 0 of the rolling resistance: when
the ball is about to leave the wall the two evaluations can straddle it;
the model is invalid there anyway (see `contact` in the outputs).

Energy: with F_s the ball's load on the chamber, M_reaction psi' = F_s . v_O,
so d/dt (1/2 J_total psi'^2 + E_ball) = T_motor w_motor - P_diss:
    W_motor(t) = [E_drive + E_ball](t) - [E_drive + E_ball](0) + W_diss(t),
which `CoupledResult.energy_residual` reports (E_ball absolute, potential
energy of the ball included; the platform moves horizontally).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .. import outputs as _out
from ..errors import ParameterError
from ..model import BallModel, BallState
from ..params import Ball
from .induction import RPM, CrankDrive, platform_state


@dataclass
class CoupledResult:
    """A coupled run. ``t`` the output grid; ``data`` arrays over it:

    drive: psi, psi_dot, psi_ddot, w_motor, n_motor [1/min], T_motor, M_reaction,
        x1O, y1O, vx1O, vy1O, ax1O, ay1O, E_drive, W_motor, I_motor, P_el (dq only; 0
        for Kloss), W_el, W_cu, W_mag (dq only: electrical input, copper losses,
        magnetic energy [J]);
    ball: every field of `ballmill.physics.outputs.Outputs` (N, friction_ratio,
        xP, yP, zP, Fx, ..., P_diss), E_ball, W_diss, n_norm_error (|n| - 1).
    ``sol`` is solve_ivp's dense output of the state; ``y`` the state on the grid.
    """

    t: np.ndarray
    y: np.ndarray
    data: dict
    system: "CoupledSystem"
    sol: object
    success: bool
    message: str
    nfev: int = 0

    def __getitem__(self, key):
        return self.data[key]

    @property
    def energy_residual(self) -> np.ndarray:
        """W_motor - (change of drive and ball energy) - W_diss [J]: zero up to the
        integration error."""
        d = self.data
        E = d["E_drive"] + d["E_ball"]
        return d["W_motor"] - (E - E[0]) - d["W_diss"]


class CoupledSystem:
    """Drive (`CrankDrive`) and ball (`BallModel`, any formulation) as one ODE."""

    def __init__(self, drive: CrankDrive, ball: Ball | BallModel | None = None):
        if not isinstance(drive, CrankDrive):
            raise ParameterError(f"drive must be a CrankDrive, got drive = {drive!r}")
        self.drive = drive
        self.model = ball if isinstance(ball, BallModel) else BallModel(ball or Ball())
        self.ball = self.model.ball
        self.form = self.model.form
        self.nd = drive.n_states
        self.nb = self.form.ndim
        self.dq = drive.model == "dq"
        self.nq = 4 if self.dq else 2  # W_motor, W_diss (+ W_el, W_cu)
        self.lossy = bool(self.ball.rolling_resistance or self.ball.drag)

    # -- the algebraic loop ---------------------------------------------------
    def motor_torque(self, t, yd) -> float:
        return self.drive.motor_torque(yd, t)

    def solve_loop(self, t, yd, n, w, T=None):
        """(psi'', M_reaction, platform (x, y, vx, vy, ax, ay), A, B) at time t for
        the drive state yd and the ball's (n, omega): M_reaction = A + B psi''."""
        drive, ball = self.drive, self.ball
        if T is None:
            T = drive.motor_torque(yd, t)
        psi, pd = yd[0], yd[1]
        p0 = platform_state(drive.l, psi, pd, 0.0)
        p1 = platform_state(drive.l, psi, pd, 1.0)
        A = _out.evaluate(ball, n, w, p0[4], p0[5], p0[0], p0[1]).M_reaction
        B = _out.evaluate(ball, n, w, p1[4], p1[5], p1[0], p1[1]).M_reaction - A
        psi_ddot = (drive.i * T + A) / (drive.J_total - B)
        return psi_ddot, A + B * psi_ddot, platform_state(drive.l, psi, pd, psi_ddot), A, B

    def rhs(self, t, z):
        nd, nb = self.nd, self.nb
        drive = self.drive
        yd = z[:nd]
        yb = z[nd:nd + nb]
        n, w = self.form.to_nw(yb)
        w_m = drive.i * yd[1]
        T = drive.motor_torque(yd, t)
        psi_ddot, M, plat, _, _ = self.solve_loop(t, yd, n, w, T)
        dz = np.empty(nd + nb + self.nq)
        dz[0] = yd[1]
        dz[1] = psi_ddot
        if self.dq:
            dz[2:6] = drive.motor.dq_rhs(t, yd[2:6], w_m)
        dz[nd:nd + nb] = self.form.derivative(yb.tolist() if isinstance(yb, np.ndarray) else list(yb),
                                              plat[4], plat[5])
        q = nd + nb
        dz[q] = T * w_m
        dz[q + 1] = (_out.evaluate(self.ball, n, w, plat[4], plat[5], plat[0], plat[1]).P_diss
                     if self.lossy else 0.0)
        if self.dq:
            dz[q + 2] = drive.motor.dq_outputs(t, yd[2:6])[2]
            dz[q + 3] = drive.motor.dq_losses_and_energy(yd[2:6])[0]
        return dz

    # -- states ---------------------------------------------------------------
    def initial(self, drive_state=None, ball_state: BallState | None = None) -> np.ndarray:
        """z0: drive at rest (or drive_state), ball at rest at the bottom (or
        ball_state), quadratures zero."""
        yd = self.drive.initial_state() if drive_state is None else np.asarray(drive_state, dtype=float)
        if yd.shape != (self.nd,):
            raise ParameterError(f"drive_state must have {self.nd} entries for model "
                                 f"{self.drive.model!r}, got shape {yd.shape}")
        yb = (ball_state or self.model.initial()).y
        return np.concatenate([yd, yb, np.zeros(self.nq)])

    def scale(self) -> np.ndarray:
        """Typical magnitude of each state component (absolute tolerance = rtol * scale)."""
        motor = self.drive.motor
        w_crank = motor.synchronous_speed / self.drive.i
        flux = motor.phase_voltage_peak / (2.0 * math.pi * motor.rated_frequency)
        b = self.ball
        w_ref = b.d * b.omega_small / b.r
        ball = ([1.0, 1.0, 1.0] if self.form.name == "vector" else [b.d, b.d]) + [w_ref] * 3
        E = 0.5 * self.drive.J_total * w_crank ** 2
        return np.array([1.0, w_crank] + ([flux] * 4 if self.dq else []) + ball + [E] * self.nq)

    # -- outputs --------------------------------------------------------------
    def outputs(self, t, z) -> dict:
        """Everything on `CoupledResult.data` at one instant."""
        nd, nb, drive = self.nd, self.nb, self.drive
        yd, yb = z[:nd], z[nd:nd + nb]
        n, w = self.form.to_nw(yb)
        w_m = drive.i * yd[1]
        if self.dq:
            T, I, P = drive.motor.dq_outputs(t, yd[2:6])
        else:
            T, I, P = drive.motor.torque(w_m, t), 0.0, 0.0
        psi_ddot, M, plat, _, _ = self.solve_loop(t, yd, n, w, T)
        o = _out.evaluate(self.ball, n, w, plat[4], plat[5], plat[0], plat[1])
        q = nd + nb
        d = {"psi": yd[0], "psi_dot": yd[1], "psi_ddot": psi_ddot, "w_motor": w_m, "n_motor": w_m / RPM,
             "T_motor": T, "I_motor": I, "P_el": P,
             "x1O": plat[0], "y1O": plat[1], "vx1O": plat[2], "vy1O": plat[3], "ax1O": plat[4],
             "ay1O": plat[5], "E_drive": drive.kinetic_energy(yd), "W_motor": z[q], "W_diss": z[q + 1],
             "E_ball": _out.energy(self.ball, n, w, plat[2], plat[3]),
             "n_norm_error": math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2) - 1.0}
        if self.dq:
            d["W_el"], d["W_cu"] = z[q + 2], z[q + 3]
            d["W_mag"] = drive.motor.dq_losses_and_energy(yd[2:6])[1]
        d.update(o._asdict())
        d["M_reaction"] = M  # = o.M_reaction (same psi''), kept from the loop solution
        return d


def simulate_coupled(drive: CrankDrive, ball: Ball | BallModel | None = None, t_end: float = 10.0,
                     dt: float = 1e-3, drive_state=None, ball_state: BallState | None = None,
                     rtol: float = 1e-10, method: str = "DOP853", max_step: float = math.inf) -> CoupledResult:
    """Integrate drive + ball from t = 0 to t_end, outputs every dt.

    Defaults: drive at rest with zero fluxes, ball at rest at the bottom of its
    chamber, DOP853 with rtol 1e-10 and atol = rtol * (typical magnitude of each
    state). Use method="Radau" or "LSODA" for long dq runs.
    """
    if not (t_end > 0 and math.isfinite(t_end)):
        raise ParameterError(f"t_end must be positive and finite, got t_end = {t_end!r} s")
    if not (dt > 0 and math.isfinite(dt)):
        raise ParameterError(f"dt must be positive and finite, got dt = {dt!r} s")
    system = CoupledSystem(drive, ball)
    z0 = system.initial(drive_state, ball_state)
    n_out = int(round(t_end / dt))
    t_eval = np.linspace(0.0, n_out * dt, n_out + 1)
    res = solve_ivp(system.rhs, (0.0, t_eval[-1]), z0, method=method, t_eval=t_eval, rtol=rtol,
                    atol=rtol * system.scale(), dense_output=True, max_step=max_step)
    t, z = res.t, res.y
    rows = [system.outputs(tt, z[:, k]) for k, tt in enumerate(t)]
    data = {key: np.array([r[key] for r in rows], dtype=float) for key in rows[0]} if rows else {}
    return CoupledResult(t=t, y=z, data=data, system=system, sol=res.sol, success=bool(res.success),
                         message=str(res.message), nfev=int(res.nfev))
