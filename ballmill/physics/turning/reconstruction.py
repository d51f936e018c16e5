"""Reconstructing a chamber's rigid motion between communication points (the BallInShell
FMU with motion = 2): what it owns.

A co-simulation FMU sees the chamber's motion only at communication points t_k: the
platform point O (position, velocity, acceleration, fixed axes), the angular velocity
Omega and its derivative Omega', and the orientation Q (chamber axes to fixed axes,
row-major). The general model (model.py) needs, between t_k and t_k + h, the chamber
centre's acceleration a_A(t), Omega(t) and Omega'(t); the outputs need A, v_A and Q at
the output time. `ChamberReconstruction` keeps the last samples and fits:

* the chamber centre A = O + Q (0, 0, R), with v_A = v_O + Omega x (A - O) and
  a_A = a_O + Omega' x (A - O) + Omega x (Omega x (A - O)) taken exactly from each
  sample. Mode "derivatives", two nodes: per axis the quintic through (A, v_A, a_A) at
  both (Hermite), so a_A(t) is a cubic, extrapolation error O(h^4) as in
  platform.InputReconstruction; positions relative to the newest node (offset
  invariance). One node, or mode "hold": the newest sample's Taylor polynomial
  (a_A held over the step).
* Omega, as the velocity of a rotation whose acceleration is Omega': mode "derivatives",
  two nodes, the cubic Hermite through (Omega, Omega') at both (Omega' a quadratic);
  one node or mode "hold": Omega(t) = Omega_k + Omega'_k (t - t_k), Omega' held.
* Q over a step (outputs only): the rotation by theta(t) = integral of the fitted Omega
  from t_k (Rodrigues' formula) applied to Q_k. The integral of Omega is the first
  Magnus term, exact for a fixed axis; each step restarts from the input Q_k, so the
  error (third order in h with Omega turning) does not accumulate.

Node choice, history length and the window of the predictor-corrector are
platform.InputReconstruction's (newest sample, then each older one at least h/2 before
the node chosen last, up to ``points``; history ``points + 6``). Modes "positions" and
"accelerations" are not offered for a turning chamber (the FMU refuses them): there is
no orientation-only counterpart of the position fit yet.

Every sample is checked: finite values (named by the FMU's input names) and Q a
rotation (|Q Q^T - I| <= Q_TOL entrywise, det Q > 0). In mode "derivatives" each new
sample's chamber centre (A, v_A, a_A) is checked against the previous one's per axis with
platform.InputReconstruction's Euler-Maclaurin residual and thresholds (|a|: the larger 3-D
magnitude of a_A); an inconsistency is reported (the FMU flags it: valid = false), and a
jump (6 |r| / H^2 > a_tol + |a|) restarts the history at the new sample. The arithmetic is written as
scalar expressions in a fixed order that fmu_src/ballinshell.c repeats operation for
operation, so both FMU flavours agree bit for bit. The fit's coefficients are in
physical time s = t - t_k; ``kin.poly`` carries them for the compiled kernel.
"""
from __future__ import annotations

import math

from ..errors import InputError
from ..platform import A_REL, SampleHistory, worst_residual
from .motions import ChamberMotion

MODES = ("derivatives", "hold")
POINTS = {"derivatives": 2, "hold": 1}
HISTORY_EXTRA = 6
Q_TOL = 1e-6  # orthonormality of the orientation input, entrywise on Q Q^T - I
# the inputs of one sample, in the FMU's value-reference order (after t)
NAMES = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O", "z1O", "vz1O", "az1O",
         "Omega_x", "Omega_y", "Omega_z", "Omega_dot_x", "Omega_dot_y", "Omega_dot_z",
         "Q11", "Q12", "Q13", "Q21", "Q22", "Q23", "Q31", "Q32", "Q33")
NSAMPLE = 1 + len(NAMES)  # 25
NPOLY = 34  # t0, a_A cubic (3 x 4), Omega cubic (3 x 4), Omega' quadratic (3 x 3)


def rotation_problem(q) -> str | None:
    """None when the 9 entries q (row-major) are a rotation within Q_TOL, else what is wrong
    (the worst entry of Q Q^T - I with its rows, or the determinant)."""
    worst, wi, wj, wv = -1.0, 0, 0, 0.0
    for i in range(3):
        for j in range(i, 3):
            v = (q[3 * i] * q[3 * j] + q[3 * i + 1] * q[3 * j + 1]) + q[3 * i + 2] * q[3 * j + 2]
            e = abs(v - (1.0 if i == j else 0.0))
            if e > worst:
                worst, wi, wj, wv = e, i, j, v
    if worst > Q_TOL:
        rows = ", ".join(f"Q{i + 1}{k + 1} = {q[3 * i + k]!r}" for i in sorted({wi, wj}) for k in range(3))
        return (f"input Q is not a rotation matrix: row {wi + 1} . row {wj + 1} = {wv!r}, expected "
                f"{1.0 if wi == wj else 0.0!r} within {Q_TOL:g} ({rows})")
    det = (q[0] * (q[4] * q[8] - q[5] * q[7]) - q[1] * (q[3] * q[8] - q[5] * q[6])) \
        + q[2] * (q[3] * q[7] - q[4] * q[6])
    if not det > 0.0:
        return f"input Q is not a rotation matrix: det Q = {det!r}, expected +1 (a reflection)"
    return None


def centre(smp, R):
    """(A, v_A, a_A) of the chamber centre from one sample (t, inputs...) [m, m/s, m/s2]."""
    (_, x, y, vx, vy, ax, ay, z, vz, az, ox, oy, oz, px, py, pz,
     q00, q01, q02, q10, q11, q12, q20, q21, q22) = smp
    ex, ey, ez = R * q02, R * q12, R * q22
    cx, cy, cz = oy * ez - oz * ey, oz * ex - ox * ez, ox * ey - oy * ex
    return ((x + ex, y + ey, z + ez),
            (vx + cx, vy + cy, vz + cz),
            (ax + ((py * ez - pz * ey) + (oy * cz - oz * cy)),
             ay + ((pz * ex - px * ez) + (oz * cx - ox * cz)),
             az + ((px * ey - py * ex) + (ox * cy - oy * cx))))


def rotate(theta, q):
    """The rotation by the vector theta [rad] (Rodrigues) times q (row-major), row-major."""
    tx, ty, tz = theta
    th = math.sqrt(tx * tx + ty * ty + tz * tz)
    if th == 0.0:
        return tuple(q)
    ex, ey, ez = tx / th, ty / th, tz / th
    c, s = math.cos(th), math.sin(th)
    u = 1.0 - c
    m = (c + u * ex * ex, u * ex * ey - s * ez, u * ex * ez + s * ey,
         u * ey * ex + s * ez, c + u * ey * ey, u * ey * ez - s * ex,
         u * ez * ex - s * ey, u * ez * ey + s * ex, c + u * ez * ez)
    return tuple((m[3 * i] * q[j] + m[3 * i + 1] * q[3 + j]) + m[3 * i + 2] * q[6 + j]
                 for i in range(3) for j in range(3))


def inputs_of(cs, R):
    """The inputs (NAMES order) that describe the chamber state cs (motions.ChamberState's
    fields) to the FMU: the chamber-fixed point O = A - Q (0, 0, R) with its velocity and
    acceleration (the inverse of `centre`), Omega, Omega', Q. For in-test masters and the
    benchmark, which feed a library motion to the FMU."""
    (Ax, Ay, Az, vAx, vAy, vAz, aAx, aAy, aAz, ox, oy, oz, px, py, pz, *q) = cs[:24]
    ex, ey, ez = R * q[2], R * q[5], R * q[8]
    cx, cy, cz = oy * ez - oz * ey, oz * ex - ox * ez, ox * ey - oy * ex
    a = ((py * ez - pz * ey) + (oy * cz - oz * cy), (pz * ex - px * ez) + (oz * cx - ox * cz),
         (px * ey - py * ex) + (ox * cy - oy * cx))
    return (Ax - ex, Ay - ey, vAx - cx, vAy - cy, aAx - a[0], aAy - a[1], Az - ez, vAz - cz, aAz - a[2],
            ox, oy, oz, px, py, pz, *q)


class ChamberReconstruction(SampleHistory):
    """The chamber's motion between communication points from its samples (module docstring).
    ``R``: the chamber's radius [m] (A = O + Q (0, 0, R))."""

    WHAT = "chamber"
    NSAMPLE = NSAMPLE

    def sample_problem(self, smp) -> str | None:
        return rotation_problem(smp[16:25])

    def __init__(self, mode: str = "derivatives", R: float = 0.25, a_tol: float = 1e-2):
        if mode not in MODES:
            raise ValueError(f"input mode must be one of {MODES} for a turning chamber, got {mode!r}")
        if not (a_tol > 0 and math.isfinite(a_tol)):
            raise ValueError(f"a_tol must be positive and finite, got {a_tol!r} m/s2")
        self.a_tol = float(a_tol)
        self.mode = mode
        self.points = POINTS[mode]
        self.R = float(R)
        self.samples: list[tuple] = []
        self.h_next = 0.0
        self.dropped = None  # the positions are never left out here (InputReconstruction's flag)
        self._dirty = True

    # -- samples ---------------------------------------------------------
    def push(self, t, *inputs):
        """Record the inputs (NAMES order) seen at t; a sample at the newest time replaces
        it. InputError (state unchanged) for a non-finite value, a time earlier than the
        newest sample or a Q that is not a rotation. Returns None, or (mode "derivatives") the
        description of an inconsistency of the new sample with the previous one (the history
        then restarts at this sample on a jump)."""
        smp = (float(t),) + tuple(float(v) for v in inputs)
        if len(smp) != NSAMPLE:
            raise InputError(f"a chamber sample has {NSAMPLE - 1} inputs, got {len(smp) - 1}")
        for name, v in zip(NAMES, smp[1:]):
            if not math.isfinite(v):
                raise InputError(f"input {name} must be finite, got {v!r} at t = {t!r} s")
        problem = rotation_problem(smp[16:25])
        if problem:
            raise InputError(f"{problem} at t = {t!r} s")
        if self.samples and smp[0] < self.samples[-1][0]:
            raise InputError(f"inputs must come in time order: got t = {t!r} s after "
                             f"t = {self.samples[-1][0]!r} s")
        self._dirty = True
        if self.samples and smp[0] == self.samples[-1][0]:
            self.samples[-1] = smp
            prev = self.samples[-2] if len(self.samples) > 1 else None
        else:
            prev = self.samples[-1] if self.samples else None
            self.samples.append(smp)
            if len(self.samples) > self.points + HISTORY_EXTRA:
                del self.samples[0]
        if self.mode == "derivatives" and prev is not None:
            problem, jump = self.inconsistency(prev, smp)
            if problem:
                if jump:
                    self.samples[:] = [smp]
                return problem
        return None

    def inconsistency(self, p, q):
        """(None, False) if the chamber centre's A, v_A, a_A of samples p and q agree, else
        (what disagrees, whether it is a jump); module docstring."""
        R = self.R
        Ap, vp, ap = centre(p, R)
        Aq, vq, aq = centre(q, R)
        H = q[0] - p[0]
        a_mag = max(math.sqrt(ap[0] * ap[0] + ap[1] * ap[1] + ap[2] * ap[2]),
                    math.sqrt(aq[0] * aq[0] + aq[1] * aq[1] + aq[2] * aq[2]))
        worst = worst_residual(self.a_tol, H, a_mag,
                               ((k, (Ap[k], Aq[k], vp[k], vq[k], ap[k], aq[k])) for k in range(3)))
        if worst is None:
            return None, False
        k, r, limit, jump = worst
        c = "xyz"[k]
        restart = "; the reconstruction restarts at the newer sample" if jump else ""
        return (f"the chamber centre A = O + Q (0, 0, R) of the inputs (x1O..az1O, Omega, Omega_dot, Q) "
                f"disagrees in {c} between t = {p[0]!r} s (A{c} = {Ap[k]!r} m, vA{c} = {vp[k]!r} m/s, "
                f"aA{c} = {ap[k]!r} m/s2) and t = {q[0]!r} s (A{c} = {Aq[k]!r} m, vA{c} = {vq[k]!r} m/s, "
                f"aA{c} = {aq[k]!r} m/s2): position residual {r:.3g} m, accepted |r| <= {limit:.3g} m "
                f"(input_tol = {self.a_tol:g} m/s2 + {A_REL:g} |a| of acceleration){restart}"), jump

    # -- fit -------------------------------------------------------------
    def _fit(self):
        nodes = self.nodes()
        new = nodes[-1]
        R = self.R
        A1, v1, a1 = centre(new, R)
        om1, od1 = new[10:13], new[13:16]
        pos = []  # per axis: coefficients of A(s), s = t - t0, degree 5
        om = []  # per axis: Omega(s), degree 3
        if self.mode == "hold" or len(nodes) == 1:
            for k in range(3):
                pos.append((A1[k], v1[k], 0.5 * a1[k], 0.0, 0.0, 0.0))
                om.append((om1[k], od1[k], 0.0, 0.0))
        else:
            old = nodes[0]
            A0, v0, a0 = centre(old, R)
            om0, od0 = old[10:13], old[13:16]
            H = new[0] - old[0]
            H2 = H * H
            H3 = H2 * H
            H4 = H3 * H
            H5 = H4 * H
            for k in range(3):
                # quintic in tau = s / H through (x, v, a) at tau = -1 and 0, x relative to A1
                c1 = H * v1[k]
                c2 = 0.5 * H2 * a1[k]
                P = ((A0[k] - A1[k]) + c1) - c2
                V = (H * v0[k] - c1) + 2.0 * c2
                Acc = H2 * a0[k] - 2.0 * c2
                c3 = (-10.0 * P - 4.0 * V) - 0.5 * Acc
                c4 = (-15.0 * P - 7.0 * V) - Acc
                c5 = (-6.0 * P - 3.0 * V) - 0.5 * Acc
                pos.append((A1[k], v1[k], 0.5 * a1[k], c3 / H3, c4 / H4, c5 / H5))
                # cubic in tau through (Omega, H Omega') at tau = -1 and 0
                e1 = H * od1[k]
                p = (om0[k] - om1[k]) + e1
                q = H * od0[k] - e1
                e2 = 3.0 * p + q
                e3 = 2.0 * p + q
                om.append((om1[k], od1[k], e2 / H2, e3 / H3))
        self._t0 = new[0]
        self._Q = new[16:25]
        self._pos = pos
        self._om = om
        self._kin = self._compile(new[0], pos, om)
        self._dirty = False

    @staticmethod
    def _compile(t0, pos, om):
        """kin(t) = (a_A, Omega, Omega') as 9 floats (the integrator's inner loop), with
        ``kin.poly`` = (t0, a_A cubics, Omega cubics, Omega' quadratics) for the kernel."""
        (ax0, ax1, ax2, ax3), (ay0, ay1, ay2, ay3), (az0, az1, az2, az3) = (
            (2.0 * p[2], 6.0 * p[3], 12.0 * p[4], 20.0 * p[5]) for p in pos)
        (ox0, ox1, ox2, ox3), (oy0, oy1, oy2, oy3), (oz0, oz1, oz2, oz3) = om
        dx0, dx1, dx2 = ox1, 2.0 * ox2, 3.0 * ox3
        dy0, dy1, dy2 = oy1, 2.0 * oy2, 3.0 * oy3
        dz0, dz1, dz2 = oz1, 2.0 * oz2, 3.0 * oz3

        def kin(t):
            s = t - t0
            return (ax0 + s * (ax1 + s * (ax2 + s * ax3)), ay0 + s * (ay1 + s * (ay2 + s * ay3)),
                    az0 + s * (az1 + s * (az2 + s * az3)),
                    ox0 + s * (ox1 + s * (ox2 + s * ox3)), oy0 + s * (oy1 + s * (oy2 + s * oy3)),
                    oz0 + s * (oz1 + s * (oz2 + s * oz3)),
                    dx0 + s * (dx1 + s * dx2), dy0 + s * (dy1 + s * dy2), dz0 + s * (dz1 + s * dz2))
        kin.poly = (float(t0), ax0, ax1, ax2, ax3, ay0, ay1, ay2, ay3, az0, az1, az2, az3,
                    ox0, ox1, ox2, ox3, oy0, oy1, oy2, oy3, oz0, oz1, oz2, oz3,
                    dx0, dx1, dx2, dy0, dy1, dy2, dz0, dz1, dz2)
        return kin

    def prepare(self):
        if self._dirty:
            self._fit()

    def accel_function(self):
        """The current fit's kin(t) -> (a_A, Omega, Omega'), for the integrator."""
        self.prepare()
        return self._kin

    def motion(self) -> "ReconstructedChamber":
        """The current fit as a `motions.ChamberMotion` for the hybrid ball
        (`ReconstructedChamber`), frozen: a later sample does not change it."""
        self.prepare()
        return ReconstructedChamber(self._t0, self._pos, self._om, self._Q, self._kin)

    def state(self, t):
        """The chamber's state at t as motions.ChamberState's 38 floats (A, v_A, a_A, Omega,
        Omega', Q; the drive fields 0)."""
        self.prepare()
        return chamber_state(self._t0, self._pos, self._om, self._Q, t)


class ReconstructedChamber(ChamberMotion):
    """The chamber's motion along one fit of `ChamberReconstruction`, for the hybrid ball:
    ``state(t)`` is `ChamberReconstruction.state` (A(s) the fit's quintic, v_A and a_A its
    derivatives, Omega and Omega' the fit's, Q by Rodrigues from the newest sample's),
    ``accel(t)`` the fit's kin(t) (the floats the rolling model integrates). The quintic is
    the exact integral of a_A's cubic from (A, v_A) at the fit's reference time, written
    with the quintic's own coefficients (a_A(s) = 2 p2 + s (6 p3 + s (12 p4 + s 20 p5))), so
    the sliding and flying ball needs no further integration: fmu_src/ballinshell.c's
    general_state is the same arithmetic."""

    def __init__(self, t0, pos, om, Q, kin):
        self._args = (t0, pos, om, Q)
        self.accel = kin

    def state(self, t):
        return chamber_state(*self._args, t)


def chamber_state(t0, pos, om, Q, t):
    """`ChamberReconstruction.state` of the fit (t0, pos, om, Q) at t."""
    s = t - t0
    A, vA, aA, Om, Omd, th = [], [], [], [], [], []
    for p, o in zip(pos, om):
        p0, p1, p2, p3, p4, p5 = p
        o0, o1, o2, o3 = o
        A.append(p0 + s * (p1 + s * (p2 + s * (p3 + s * (p4 + s * p5)))))
        vA.append(p1 + s * (2.0 * p2 + s * (3.0 * p3 + s * (4.0 * p4 + s * (5.0 * p5)))))
        aA.append(2.0 * p2 + s * (6.0 * p3 + s * (12.0 * p4 + s * (20.0 * p5))))
        Om.append(o0 + s * (o1 + s * (o2 + s * o3)))
        Omd.append(o1 + s * (2.0 * o2 + s * (3.0 * o3)))
        th.append(s * (o0 + s * (0.5 * o1 + s * (o2 / 3.0 + s * (0.25 * o3)))))
    return tuple(A) + tuple(vA) + tuple(aA) + tuple(Om) + tuple(Omd) + rotate(th, Q) + (0.0,) * 14


__all__ = ["ChamberReconstruction", "ReconstructedChamber", "chamber_state", "MODES", "NAMES", "NPOLY", "Q_TOL",
           "centre", "inputs_of", "rotate", "rotation_problem"]
