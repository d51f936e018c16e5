"""The communication grid of the co-simulation master when stop - start is not a whole number
of steps (native FMUs, tests/mutation/native_fmus.py): the number of steps is the nearest
whole number (as ballmill.physics.simulate does); when that reaches past stop, the last step
is shortened to end at stop, and the last row is recorded at the time the FMUs reached,
not on the grid point beyond it (before this test: psi(0.096 s) recorded as t = 0.1 s)."""
from __future__ import annotations

import pytest

from ballmill.scenario import runner
from runner_cases import linear_law, load

DRIVE = """
[instances.drive]
fmu = "MotorStartup"
parameters = { n0 = 60.0, t0 = 1.0, law = 3 }
[record]
variables = ["drive.psi", "drive.psi_dot"]
"""


@pytest.mark.parametrize("stop, steps, last", [(0.096, 10, 0.096), (0.094, 9, 0.09), (0.1, 10, 0.1)])
def test_the_last_row_is_where_the_fmus_stopped(tmp_path, native_models, native_fmus, stop, steps, last):
    sc = load(tmp_path, f"[experiment]\nstart = 0.0\nstop = {stop}\nstep = 0.01\n" + DRIVE, native_models)
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert (res.success, res.steps) == (True, steps)
    t = res.column("time")
    assert list(t[:-1]) == [k * 0.01 for k in range(steps)]
    assert t[-1] == pytest.approx(last, abs=1e-15)
    for k, tk in enumerate(t):
        psi, pd, _ = linear_law(60.0, 1.0, tk)
        assert res.column("drive.psi")[k] == pytest.approx(psi, rel=1e-12), tk
        assert res.column("drive.psi_dot")[k] == pytest.approx(pd, rel=1e-12), tk
