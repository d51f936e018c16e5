"""An in-test co-simulation master for BallInShell with motion = 2: it feeds the FMU the exact
inputs of a library chamber motion (ballmill.physics.turning.motions) at every communication
point and collects the outputs (tests/test_fmu_chamber.py; the benchmark feeds the same inputs,
ballmill.physics.turning.reconstruction.inputs_of)."""
from __future__ import annotations

from fmpy.fmi1 import FMICallException

from ballmill.physics.turning.reconstruction import NAMES
from ballmill.physics.turning.reconstruction import inputs_of as reconstruction_inputs


def inputs_of(cs, R):
    """The FMU's inputs for a motions.ChamberState (reconstruction.inputs_of), by name."""
    return dict(zip(NAMES, reconstruction_inputs(cs, R)))


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
