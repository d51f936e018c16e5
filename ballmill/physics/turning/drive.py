"""The drives of the Fig. 1 machine (motions.Fig1Machine) and the loads they carry: what
the Fig1Drive FMU computes (drive_models/fig1drive_fmu.py over this module; the native
drive_models/fig1drive.c mirrors it operation for operation).

Kinematics. The platform point O (the chamber's lowest point when the chamber's
orientation Q is the identity; the chamber's centre is A = O + Q (0, 0, R)) is carried
by the cranks on a circle of radius l about the crank centre c, in the frame's axes,
and the frame turns about its shaft (the fixed x1 or z1 axis through O1) by phi:
O(t) is the point that `Fig1Machine` with ``centre = c`` calls A. Its velocity and
acceleration, the chamber's angular velocity Omega = phi' e and Omega' = phi'' e (e
the shaft's unit vector) and Q = R_e(phi) come from `Fig1Machine.state` in closed form.

Loads. The ball's force on the chamber F (fixed axes) and its moment about the fixed
origin O1, M_O1 = P x F (P the contact point), are the ball's wrench on the chamber.
A drive i with twist (w_i, v_i) (motions.py: dv_X/dq_i' = w_i x X + v_i) feels the
reaction moment M_i = w_i . M_O1 + v_i . F:

    M_frame = e . M_O1                       (w = e, v = 0: rotation about the shaft)
    M_crank = (R_e(phi) da/dpsi) . F         (w = 0: the platform translates relative to the frame)

and M_frame phi' + M_crank psi' = F . v_P(chamber) = minus the power the chamber
delivers to the ball.

Torques the drives must supply (generalized forces of Lagrange's equations with phi and
psi prescribed; the crank motor sits on the frame, so its torque works on psi' alone):

    T_frame = J_frame phi'' + J_crank k_e (psi'' + k_e phi'') + m_p (a_O + g e_z) . (e x O) - M_frame
    T_crank = J_crank (psi'' + k_e phi'') + m_p (a_O + g e_z) . (R_e da/dpsi) - M_crank

with k_e = e . k the cosine between the shaft and the crank axes k (0 perpendicular,
1 parallel), and P_frame = T_frame phi', P_crank = T_crank psi'. The simplifications:
the platform with the chamber is a point mass m_p at O (its own moment of inertia
about the shaft, the frame's and the cranks' inertia transverse to their axes belong in
J_frame); the frame is balanced (its weight has no moment about the shaft); the
cranks are balanced and axisymmetric about their axes (their gyroscopic couple,
perpendicular to the shaft with perpendicular crank axes, loads the bearings, not the
motors); the platform's weight m_p g is included (it works when the frame tilts the
crank circle, as the horizontal shaft does). With J_frame = J_crank = m_p = 0 the
torques are the reactions alone: T = -M.

Plain Python floats, SI units, no FMI.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from ..errors import ParameterError
from .motions import ARRANGEMENTS, SHAFTS, ConstantSpeed, Fig1Machine, SpeedRise, check_number

# Fig1Drive's integer codes (ballmill/fmi/interface.py FIG1_DRIVE); frame_law 0 is ConstantSpeed
LAW_CODES = {1: "quadratic", 2: "scurve", 3: "linear", 4: "quintic"}  # MotorStartup's `law`
SHAFT_CODES = {1: "x", 2: "z"}
ARRANGEMENT_CODES = {1: "perpendicular", 2: "parallel"}


class DriveOutputs(NamedTuple):
    """Fig1Drive's outputs at one instant (fixed axes; SI units)."""

    phi: float  # frame angle [rad]
    phi_dot: float
    phi_ddot: float
    psi: float  # crank angle relative to the frame [rad]
    psi_dot: float
    psi_ddot: float
    x1O: float  # platform point O [m]
    y1O: float
    z1O: float
    vx1O: float
    vy1O: float
    vz1O: float
    ax1O: float
    ay1O: float
    az1O: float
    Omega_x: float  # the chamber's angular velocity [rad/s]
    Omega_y: float
    Omega_z: float
    Omega_dot_x: float  # its derivative [rad/s2]
    Omega_dot_y: float
    Omega_dot_z: float
    Q11: float  # orientation, chamber axes to fixed axes, row-major
    Q12: float
    Q13: float
    Q21: float
    Q22: float
    Q23: float
    Q31: float
    Q32: float
    Q33: float
    M_frame: float  # reaction moment on the frame shaft [N m]
    M_crank: float  # reaction moment on the cranks [N m]
    T_frame: float  # torque the frame drive must supply [N m]
    T_crank: float  # torque the crank drive must supply [N m]
    P_frame: float  # their powers [W]
    P_crank: float


class Fig1Drive:
    """The Fig. 1 machine's drives with their inertias (module docstring).

    ``shaft`` "x" or "z"; ``frame_law`` 0 (constant speed Omega_frame from t = 0) or one of
    drives.crank.LAWS (a rise to Omega_frame in t0_frame); the cranks: length ``l`` >= 0,
    speed ``n0`` [1/min] reached in ``t0`` along ``law``; ``arrangement`` of the crank axes
    relative to the shaft; ``centre`` c of the crank circle in the frame's axes [m];
    ``J_frame``, ``J_crank`` [kg m2], ``m_platform`` [kg], ``g`` [m/s2]."""

    def __init__(self, shaft="x", Omega_frame=0.5, frame_law=0, t0_frame=2.5, l=0.5, n0=60.0, t0=2.5,
                 law="quadratic", arrangement="perpendicular", centre=(0.0, 0.0, 0.0), J_frame=0.0,
                 J_crank=0.0, m_platform=0.0, g=9.81):
        for name, v, unit in (("Omega_frame", Omega_frame, "rad/s"), ("t0_frame", t0_frame, "s"),
                              ("l", l, "m"), ("n0", n0, "1/min"), ("t0", t0, "s"), ("J_frame", J_frame, "kg.m2"),
                              ("J_crank", J_crank, "kg.m2"), ("m_platform", m_platform, "kg"), ("g", g, "m/s2")):
            check_number(name, v, unit)
            if name != "Omega_frame" and v < 0.0:
                raise ParameterError(f"{name} must be non-negative, got {name} = {v!r} {unit}")
        for name, v in (("t0_frame", t0_frame), ("t0", t0)):
            if not v > 0.0:
                raise ParameterError(f"{name} must be positive, got {name} = {v!r} s")
        if shaft not in SHAFTS:
            raise ParameterError(f"shaft must be one of {SHAFTS}, got {shaft!r}")
        if arrangement not in ARRANGEMENTS:
            raise ParameterError(f"arrangement must be one of {ARRANGEMENTS}, got {arrangement!r}")
        frame = ConstantSpeed(float(Omega_frame)) if frame_law == 0 else SpeedRise(
            float(Omega_frame), float(t0_frame), frame_law)
        w0 = 2.0 * math.pi * n0 / 60.0  # CrankStartup.w0
        self.machine = Fig1Machine(frame=frame, crank=SpeedRise(w0, float(t0), law), arrangement=arrangement,
                                   centre=centre, l=float(l), shaft=shaft)
        self.k_e = 1.0 if arrangement == "parallel" else 0.0  # cosine between shaft and crank axes
        self.J_frame, self.J_crank, self.m_p, self.g = float(J_frame), float(J_crank), float(m_platform), float(g)

    def chamber(self, R: float) -> Fig1Machine:
        """The chamber's motion (centre A = O + Q (0, 0, R)) for simulate_chamber."""
        m = self.machine
        c = m.centre
        return Fig1Machine(frame=m.frame, crank=m.crank, arrangement=m.arrangement,
                           centre=(c[0], c[1], c[2] + R), l=m.l, shaft=m.shaft)

    def outputs(self, t: float, F=(0.0, 0.0, 0.0), MO1=(0.0, 0.0, 0.0)) -> DriveOutputs:
        """Everything at time t, with the ball's force F [N] on the chamber and its moment
        MO1 [N m] about O1 (fixed axes)."""
        m = self.machine
        ph, phd, phdd = m.frame.angle(t)
        ps, psd, psdd = m.crank.angle(t)
        cs = m.state(t)
        Ox, Oy, Oz, vx, vy, vz, ax, ay, az = cs[0:9]
        Tx, Ty, Tz = cs[35], cs[36], cs[37]  # the cranks' twist: R_e da/dpsi
        Fx, Fy, Fz = F
        if m.vertical:  # e = e_z: e . M_O1, and e . (O x b) = Ox by - Oy bx
            M_frame = MO1[2]
        else:
            M_frame = MO1[0]
        M_crank = Tx * Fx + Ty * Fy + Tz * Fz
        # the platform's inertial and weight load: m_p (a_O + g e_z)
        bx, by, bz = self.m_p * ax, self.m_p * ay, self.m_p * (az + self.g)
        if m.vertical:
            plat_frame = Ox * by - Oy * bx
        else:
            plat_frame = Oy * bz - Oz * by
        crank_acc = psdd + self.k_e * phdd
        T_crank = (self.J_crank * crank_acc + (bx * Tx + by * Ty + bz * Tz)) - M_crank
        T_frame = ((self.J_frame * phdd + self.J_crank * self.k_e * crank_acc) + plat_frame) - M_frame
        return DriveOutputs(ph, phd, phdd, ps, psd, psdd, Ox, Oy, Oz, vx, vy, vz, ax, ay, az,
                            *cs[9:24], M_frame, M_crank, T_frame, T_crank, T_frame * phd, T_crank * psd)


__all__ = ["ARRANGEMENT_CODES", "DriveOutputs", "Fig1Drive", "LAW_CODES", "SHAFT_CODES"]
