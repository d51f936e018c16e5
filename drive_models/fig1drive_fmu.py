"""Fig1Drive FMU: the drives of the paper's Fig. 1 machine (frame shaft and cranks) as the
chamber's motion source for BallInShell (motion = 2).

A thin pythonfmu adapter over ballmill.physics.turning.drive.Fig1Drive (kinematics from
motions.Fig1Machine in closed form; reaction moments, torques and powers from the ball's
wrench Fx..Fz, MO1x..MO1z). The native flavour is drive_models/fig1drive.c, the same
arithmetic in the same order.
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

from ballmill.fmi.interface import FIG1_DRIVE
from ballmill.fmi.slave import Slave
from ballmill.physics.turning.drive import ARRANGEMENT_CODES, LAW_CODES, SHAFT_CODES, DriveOutputs
from ballmill.physics.turning.drive import Fig1Drive as Drive

WRENCH = ("Fx", "Fy", "Fz", "MO1x", "MO1y", "MO1z")
FRAME_LAWS = {0: "constant", **LAW_CODES}


class Fig1Drive(Slave):
    """Frame shaft + cranks of the Fig. 1 machine: kinematics out, the ball's wrench in."""

    description = FIG1_DRIVE.description

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.declare(FIG1_DRIVE)
        self._drive = None

    def build(self):
        frame_law = self.choice("frame_law", FRAME_LAWS)
        self._drive = Drive(shaft=self.choice("shaft", SHAFT_CODES), Omega_frame=self.Omega_frame,
                            frame_law=0 if frame_law == "constant" else frame_law, t0_frame=self.t0_frame,
                            l=self.l, n0=self.n0, t0=self.t0, law=self.choice("law", LAW_CODES),
                            arrangement=self.choice("arrangement", ARRANGEMENT_CODES),
                            centre=(self.xc, self.yc, self.zc), J_frame=self.J_frame, J_crank=self.J_crank,
                            m_platform=self.m_platform, g=self.g)

    def _wrench_problem(self):
        for name in WRENCH:
            v = getattr(self, name)
            if not math.isfinite(v):
                return f"input {name} must be finite, got {v!r} {'N' if name[0] == 'F' else 'N.m'}"
        return ""

    def start(self):
        why = self._wrench_problem()
        if why:
            raise ValueError(why)
        self._publish(self._time)

    def _publish(self, t):
        out = self._drive.outputs(t, (self.Fx, self.Fy, self.Fz), (self.MO1x, self.MO1y, self.MO1z))
        values = [self.finite(name, v) for name, v in zip(DriveOutputs._fields, out)]
        for name, v in zip(DriveOutputs._fields, values):
            setattr(self, name, v)

    def step(self, t, t_end):
        why = self._wrench_problem()
        if why:
            return self.discard(f"{self.who}: {why} at t = {t:.9g} s; step refused, last good state kept")
        try:
            self._publish(t_end)
        except ArithmeticError as e:
            return self.discard(f"{self.who}: step to t = {t_end:.9g} s refused, last good state kept: {e}")
        return True
