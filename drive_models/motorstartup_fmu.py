"""MotorStartup FMU: the paper's kinematic crank start-up law as a platform source.

A thin pythonfmu adapter over ballmill.physics.drives.crank.CrankStartup (docs/design.md
sections 4 and 5). It outputs the crank angle and speed and the platform
point's position, velocity and acceleration, all exact (no numerical
derivatives). With the ball's reaction torque as an input it also reports the
torque and power the drive must supply to follow the law:
    T_drive = J_total psi'' - M_reaction,  J_total = J_crank + m_platform l^2,
    P_drive = T_drive psi'.
"""
from __future__ import annotations

import math
import os
import sys

# An earlier FMU in this process may have imported ballmill from its own, since deleted,
# resources folder (fmpy removes them after a run): forget it, so that the import below
# finds this FMU's copy (or an installed ballmill) again.
if not os.path.exists(getattr(sys.modules.get("ballmill"), "__file__", None) or os.curdir):
    for _name in [n for n in sys.modules if n.split(".")[0] == "ballmill"]:
        del sys.modules[_name]

from ballmill.fmi.interface import CRANK_KINEMATICS, MOTOR_STARTUP
from ballmill.fmi.slave import Slave
from ballmill.physics import CrankStartup

KINEMATICS = CRANK_KINEMATICS
LAWS = {1: "quadratic", 2: "scurve", 3: "linear", 4: "quintic"}  # CrankStartup.law
PUBLISHED = tuple(name for name, _, _ in KINEMATICS) + ("T_drive", "P_drive")  # what a step writes


class MotorStartup(Slave):
    """Crank start-up law: the crank speed rises to n0 in t0 (the paper's quadratic rise, or the
    S-curve, linear or quintic law chosen by ``law``)."""

    description = MOTOR_STARTUP.description

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.declare(MOTOR_STARTUP)
        self._law = None

    def build(self):
        self._law = CrankStartup(l=self.l, n0=self.n0, t0=self.t0, law=self.choice("law", LAWS))

    def start(self):
        self._publish(self._time)

    def _publish(self, t):
        """The crank's kinematics at t (ArithmeticError naming psi, psi_dot or psi_ddot when one
        is not finite, checked before cos(psi): an angle that overflowed has no position; the
        platform's position, velocity and acceleration are then finite, as l, w0 and t0 are
        bounded), then the torque."""
        angles = tuple(self.finite(name, v) for (name, _, _), v in zip(KINEMATICS, self._law.angle(t)))
        for (name, _, _), v in zip(KINEMATICS, angles + self._law.state(t)):
            setattr(self, name, v)
        self._update_torque()

    def _update_torque(self):
        """T_drive and P_drive from M_reaction (left as they are while it is not finite: the next
        step refuses it; ArithmeticError naming an output that would not be finite)."""
        m_r = self.M_reaction
        if not math.isfinite(m_r):
            return
        j_total = self.J_crank + self.m_platform * self.l ** 2
        t_drive = self.finite("T_drive", j_total * self.psi_ddot - m_r)
        p_drive = self.finite("P_drive", t_drive * self.psi_dot)
        self.T_drive, self.P_drive = t_drive, p_drive

    def inputs_set(self):
        """Direct feedthrough: T_drive and P_drive follow M_reaction set between steps; left
        as they are when they would not be finite (the next step refuses that)."""
        try:
            self._update_torque()
        except ArithmeticError:
            pass

    def step(self, t, t_end):
        m_r = self.M_reaction
        if not math.isfinite(m_r):
            return self.discard(f"{self.who}: input M_reaction must be finite, "
                                f"got {self.M_reaction!r} N.m at t = {t:.9g} s; step refused, last good state kept")
        backup = {name: getattr(self, name) for name in PUBLISHED}
        try:
            self._publish(t_end)
        except (ArithmeticError, ValueError) as e:  # ValueError: math.cos of an infinite angle
            for name, v in backup.items():
                setattr(self, name, v)
            return self.discard(f"{self.who}: step to t = {t_end:.9g} s refused, last good state kept: {e}")
        return True
