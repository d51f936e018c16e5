"""An in-test co-simulation master for BallInShell with motion = 2: it feeds the FMU the exact
inputs of a library chamber motion (ballmill.physics.turning.motions) at every communication
point and collects the outputs. Shared by tests/test_fmu_chamber.py and the benchmark."""
from __future__ import annotations

from fmpy.fmi1 import FMICallException

from ballmill.fmi.interface import BALL_ALL_INPUTS


def inputs_of(cs, R):
    """The FMU's inputs (BALL_ALL_INPUTS order) for a motions.ChamberState: the chamber-fixed
    point O = A - Q (0, 0, R) and its velocity and acceleration, Omega, Omega', Q."""
    (Ax, Ay, Az, vAx, vAy, vAz, aAx, aAy, aAz, ox, oy, oz, px, py, pz, *q) = cs[:24]
    ex, ey, ez = R * q[2], R * q[5], R * q[8]
    cx, cy, cz = oy * ez - oz * ey, oz * ex - ox * ez, ox * ey - oy * ex
    a = ((py * ez - pz * ey) + (oy * cz - oz * cy), (pz * ex - px * ez) + (oz * cx - ox * cz),
         (px * ey - py * ex) + (ox * cy - oy * cx))
    values = {"x1O": Ax - ex, "y1O": Ay - ey, "z1O": Az - ez,
              "vx1O": vAx - cx, "vy1O": vAy - cy, "vz1O": vAz - cz,
              "ax1O": aAx - a[0], "ay1O": aAy - a[1], "az1O": aAz - a[2],
              "Omega_x": ox, "Omega_y": oy, "Omega_z": oz, "Omega_dot_x": px, "Omega_dot_y": py,
              "Omega_dot_z": pz}
    values.update({f"Q{i + 1}{j + 1}": q[3 * i + j] for i in range(3) for j in range(3)})
    return {name: values[name] for name in BALL_ALL_INPUTS}


def drive(inst, motion, R, h, t_end, outputs, t_start=0.0):
    """Run an initialised-but-not-yet-started Instance (parameters set) over [t_start, t_end]
    at communication step h with the exact inputs of `motion`; returns (times, rows), one row
    of `outputs` per communication point, and the first non-OK doStep status (0 if none)."""
    inst.set(**inputs_of(motion.state(t_start), R))
    inst.initialize(t_start)
    n = int(round((t_end - t_start) / h))
    times, rows = [t_start], [inst.reals(outputs)]
    for k in range(n):
        t = t_start + k * h
        try:
            inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        except FMICallException as e:
            return times, rows, e.status
        t1 = t_start + (k + 1) * h
        inst.set(**inputs_of(motion.state(t1), R))
        times.append(t1)
        rows.append(inst.reals(outputs))
    return times, rows, 0
