"""What the model reports: contact point, forces, torques, validity, energy; and, over a
sampled run, where its validity ended (`validity`).

All from the state (n, omega) and the platform's motion at the same instant
(docs/design.md section 3). Pure functions; no integration here.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .equations import bed_constants, bed_share, loss_constants, omega_dot, omega_dot_lossy
from .params import Ball


class Outputs(NamedTuple):
    """Everything the BallInShell FMU reports, in the frame Oxyz, SI units."""

    xP: float  # contact point [m]
    yP: float
    zP: float
    xC: float  # ball centre [m]
    yC: float
    zC: float
    wx: float  # absolute angular velocity [rad/s]
    wy: float
    wz: float
    N: float  # normal force, > 0 pushes the ball towards the chamber centre [N]
    Fx: float  # force of the ball on the chamber, F_s = -F [N]
    Fy: float
    Fz: float
    M_reaction: float  # torque on the crank shaft about the vertical axis through O1 [N m]
    MAx: float  # moment of F_s about the chamber centre A [N m]
    MAy: float
    MAz: float
    Ft: float  # magnitude of the friction (tangential) force [N]
    friction_ratio: float  # |F_t| / N (inf when N <= 0) [1]
    contact: bool  # N > 0
    rolling: bool  # contact and |F_t| <= mu N
    P_diss: float = 0.0  # power dissipated by rolling resistance and drag (0 without losses) [W]
    # grinding power: the power the ball delivers to the ground material, the work rate of the
    # material's resistance relative to the material (carried by the chamber) [W]; the rolling
    # model loses energy to nothing else, so it equals P_diss here
    P_grind: float = 0.0
    # share of the material's resistance acting at the contact point: 1 in the bed (deeper than
    # Ball.bed_band below its surface, or everywhere without a bed surface), 0 above it [1]
    s_bed: float = 1.0


def evaluate(ball: Ball, n, w, ax: float, ay: float, xO: float = 0.0, yO: float = 0.0) -> Outputs:
    """Outputs for unit vector n, angular velocity w, platform acceleration (ax, ay)
    and platform position (xO, yO) relative to the crank axis."""
    if ball.rolling_resistance or ball.drag:
        return _evaluate_lossy(ball, n, w, ax, ay, xO, yO)
    nx, ny, nz = n
    wx, wy, wz = w
    lam, r, d, R, m, g = ball.lam, ball.r, ball.d, ball.R, ball.m, ball.g
    ndx = lam * (ny * wz - nz * wy)
    ndy = lam * (nz * wx - nx * wz)
    ndz = lam * (nx * wy - ny * wx)
    wdx, wdy, wdz = omega_dot(ball.k, r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay)
    # n'' = lambda (n' x omega + n x omega')
    nddx = lam * (ndy * wz - ndz * wy + ny * wdz - nz * wdy)
    nddy = lam * (ndz * wx - ndx * wz + nz * wdx - nx * wdz)
    nddz = lam * (ndx * wy - ndy * wx + nx * wdy - ny * wdx)
    # contact force on the ball F = m (a_C - g_vec)
    Fx = m * (ax + d * nddx)
    Fy = m * (ay + d * nddy)
    Fz = m * (d * nddz + g)
    N = -(Fx * nx + Fy * ny + Fz * nz)
    ftx, fty, ftz = Fx + N * nx, Fy + N * ny, Fz + N * nz
    Ft = math.sqrt(ftx * ftx + fty * fty + ftz * ftz)
    contact = N > 0.0
    ratio = Ft / N if contact else math.inf
    # the ball's force on the chamber
    sx, sy, sz = -Fx, -Fy, -Fz
    return Outputs(
        xP=R * nx, yP=R * ny, zP=R * (1.0 + nz),
        xC=d * nx, yC=d * ny, zC=R + d * nz,
        wx=wx, wy=wy, wz=wz,
        N=N, Fx=sx, Fy=sy, Fz=sz,
        M_reaction=xO * sy - yO * sx,
        MAx=R * (ny * sz - nz * sy), MAy=R * (nz * sx - nx * sz), MAz=R * (nx * sy - ny * sx),
        Ft=Ft, friction_ratio=ratio, contact=contact,
        rolling=contact and Ft <= ball.mu * N,
        s_bed=1.0 if ball.bed_depth is None else bed_share(bed_constants(ball), nz),
    )


def _evaluate_lossy(ball: Ball, n, w, ax, ay, xO, yO) -> Outputs:
    """`evaluate` with the ground material's losses (Ball.rolling_resistance, Ball.drag;
    equations.py has the derivation).

    - N, the friction force F_t and friction_ratio are those of the contact force
      F = m (a_C - g_vec) - F_d alone (the drag F_d = -c d n' acts on the centre);
    - Fx, Fy, Fz and M_reaction are the ball's whole load on the chamber and the
      material it carries, -m (a_C - g_vec) = -F - F_d: what the platform and
      the drive feel (then -M_reaction psi' is the power the drive gives the ball);
    - MA is the moment about A of that load: -F at P, -F_d at C, and the
      rolling-resistance couple -M_rr (a couple on a translating chamber does
      no work and adds nothing to M_reaction);
    - P_diss = delta N |w_t|^2 / sqrt(|w_t|^2 + eps^2) + c |v_C,rel|^2 >= 0, and P_grind,
      the grinding power, the same: the power of the ball's forces on the material relative
      to it, -(F_d . v_C,rel + M_rr . omega) (the material moves with the translating chamber);
    - with a material bed, delta and c scaled by its share s_bed at n (equations.bed_share).

    Energy: d/dt (kinetic + potential energy of the ball) = -M_reaction psi' - P_grind,
    i.e. (F + F_d) . v_O (the drive's power on the ball through chamber and material) minus
    the grinding power (tests/test_bed.py checks it to the integrator's tolerance).
    """
    nx, ny, nz = n
    wx, wy, wz = w
    lam, d, R, m, g = ball.lam, ball.d, ball.R, ball.m, ball.g
    consts = loss_constants(ball)
    bed = bed_constants(ball)
    share = bed_share(bed, nz)
    ndx = lam * (ny * wz - nz * wy)
    ndy = lam * (nz * wx - nx * wz)
    ndz = lam * (nx * wy - ny * wx)
    wdx, wdy, wdz = omega_dot_lossy(consts, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, bed)
    nddx = lam * (ndy * wz - ndz * wy + ny * wdz - nz * wdy)
    nddy = lam * (ndz * wx - ndx * wz + nz * wdx - nx * wdz)
    nddz = lam * (ndx * wy - ndy * wx + nx * wdy - ny * wdx)
    # everything chamber and material exert on the ball (but gravity): m (a_C - g_vec)
    Tx = m * (ax + d * nddx)
    Ty = m * (ay + d * nddy)
    Tz = m * (d * nddz + g)
    cd = ball.drag * d
    delta = ball.rolling_resistance
    if bed is not None:
        cd, delta = cd * share, delta * share
    Fdx, Fdy, Fdz = -cd * ndx, -cd * ndy, -cd * ndz  # drag on the centre, -c v_C,rel
    Fx, Fy, Fz = Tx - Fdx, Ty - Fdy, Tz - Fdz  # contact force
    N = -(Fx * nx + Fy * ny + Fz * nz)
    ftx, fty, ftz = Fx + N * nx, Fy + N * ny, Fz + N * nz
    Ft = math.sqrt(ftx * ftx + fty * fty + ftz * ftz)
    contact = N > 0.0
    ratio = Ft / N if contact else math.inf
    Mx = My = Mz = 0.0  # rolling-resistance couple on the ball
    P_diss = cd * d * (ndx * ndx + ndy * ndy + ndz * ndz)
    if delta and contact:
        s = nx * wx + ny * wy + nz * wz
        tx, ty, tz = wx - s * nx, wy - s * ny, wz - s * nz
        t2 = tx * tx + ty * ty + tz * tz
        f = -delta * N / math.sqrt(t2 + consts[-1])
        Mx, My, Mz = f * tx, f * ty, f * tz
        P_diss -= f * t2
    sx, sy, sz = -Tx, -Ty, -Tz  # the ball's load on chamber + material
    cx, cy, cz = -Fx, -Fy, -Fz  # through the contact, at P
    ex, ey, ez = -Fdx, -Fdy, -Fdz  # through the material, at C
    return Outputs(
        xP=R * nx, yP=R * ny, zP=R * (1.0 + nz),
        xC=d * nx, yC=d * ny, zC=R + d * nz,
        wx=wx, wy=wy, wz=wz,
        N=N, Fx=sx, Fy=sy, Fz=sz,
        M_reaction=xO * sy - yO * sx,
        MAx=R * (ny * cz - nz * cy) + d * (ny * ez - nz * ey) - Mx,
        MAy=R * (nz * cx - nx * cz) + d * (nz * ex - nx * ez) - My,
        MAz=R * (nx * cy - ny * cx) + d * (nx * ey - ny * ex) - Mz,
        Ft=Ft, friction_ratio=ratio, contact=contact,
        rolling=contact and Ft <= ball.mu * N, P_diss=P_diss, P_grind=P_diss, s_bed=share,
    )


def energy(ball: Ball, n, w, vx: float = 0.0, vy: float = 0.0) -> float:
    """Mechanical energy of the ball in the fixed frame [J]:
    1/2 m |v_O + d n'|^2 + 1/2 I |omega|^2 + m g zC, with (vx, vy) the platform velocity."""
    nx, ny, nz = n
    wx, wy, wz = w
    lam, d = ball.lam, ball.d
    vcx = vx + d * lam * (ny * wz - nz * wy)
    vcy = vy + d * lam * (nz * wx - nx * wz)
    vcz = d * lam * (nx * wy - ny * wx)
    return (0.5 * ball.m * (vcx * vcx + vcy * vcy + vcz * vcz)
            + 0.5 * ball.I * (wx * wx + wy * wy + wz * wz)
            + ball.m * ball.g * (ball.R + d * nz))


def spin(n, w) -> float:
    """Spin about the normal, omega . n [rad/s]: constant for any platform motion."""
    return n[0] * w[0] + n[1] * w[1] + n[2] * w[2]


# ----------------------------------------------------------------------------- validity
def first_failure(t, margin):
    """Time where a validity margin (N, or mu N - |F_t|) first drops to <= 0, by linear
    interpolation between the samples; None if it never does (the first sample's time if it
    starts there)."""
    k = np.flatnonzero(np.asarray(margin) <= 0.0)
    if not k.size:
        return None
    i = int(k[0])
    if i == 0:
        return float(t[0])
    a, b = margin[i - 1], margin[i]
    return float(t[i - 1] + (t[i] - t[i - 1]) * a / (a - b))


class Validity(NamedTuple):
    """Where a run's rolling model stopped holding, from its sampled outputs (the BallInShell
    FMU's validity signals, judged the same way: contact = N > 0, rolling = contact and
    |F_t| <= mu N), the times interpolated linearly between the samples where the margin
    (N, resp. mu N - |F_t|) changes sign (as the scenario report's first failures)."""

    t_first_slip: float | None  # rolling ended by slip, the ball still in contact [s]; None: it did not
    t_first_flight: float | None  # contact lost, N reached 0 [s]; None: never

    @property
    def valid(self) -> bool:
        return self.t_first_slip is None and self.t_first_flight is None

    @property
    def t_invalid(self) -> float | None:
        """The end of the model's validity: the earlier of the two [s]; None while valid."""
        times = [x for x in (self.t_first_slip, self.t_first_flight) if x is not None]
        return min(times) if times else None

    def describe(self) -> str:
        """'rolling ended (slip) at t = 2.50811 s; contact lost at 2.58462 s', or '' while valid."""
        parts = []
        if self.t_first_slip is not None:
            parts.append(f"rolling ended (slip) at t = {self.t_first_slip:.6g} s")
        if self.t_first_flight is not None:
            parts.append(f"contact lost at {'t = ' if not parts else ''}{self.t_first_flight:.6g} s")
        return "; ".join(parts)


def validity(t, N, Ft, mu: float) -> Validity:
    """`Validity` of outputs sampled at times t: N [N], |F_t| [N], friction coefficient mu.
    Slip counts only where the ball is still in contact at the sample where rolling fails
    (a ball that leaves the wall stops rolling by losing contact, said by t_first_flight)."""
    t = np.asarray(t, dtype=float)
    N = np.asarray(N, dtype=float)
    rolling_margin = np.where(N > 0.0, mu * N - np.asarray(Ft, dtype=float), N)
    t_slip = None
    k = np.flatnonzero(rolling_margin <= 0.0)
    if k.size and N[k[0]] > 0.0:
        i = int(k[0])
        t_slip = first_failure(t[max(i - 1, 0):i + 1], rolling_margin[max(i - 1, 0):i + 1])
    return Validity(t_slip, first_failure(t, N))
