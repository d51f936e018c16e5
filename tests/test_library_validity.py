"""The library's trajectories carry the rolling model's validity, as the BallInShell FMU
reports it (valid, t_invalid): `simulate` (the translating chamber), `simulate_chamber` /
`simulate_general` (a chamber that turns) and the absorber's `simulate_absorber` say when the
ball first slipped and first left the wall, interpolated between the samples, in their
attributes and their message; ``success`` keeps meaning that the integration reached t_end.
(The FMU's own t_invalid against the library's: tests/test_fmu_chamber.py.)"""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.absorber.model import StructureBall, simulate_absorber
from ballmill.absorber.structure import HarmonicForce, Structure
from ballmill.physics import Ball, BallModel, CrankStartup, fast, simulate
from ballmill.physics.turning import Fig1Machine, simulate_chamber

KERNELS = ["python"] + (["c"] if fast.KERNEL_AVAILABLE else [])


def _bracketed(t, margin, when):
    """when lies between the last sample with margin > 0 and the first with margin <= 0."""
    i = int(np.flatnonzero(np.asarray(margin) <= 0.0)[0])
    return t[i - 1] < when <= t[i]


@pytest.mark.parametrize("kernel", KERNELS)
def test_the_fig1_machine_run_says_where_rolling_ended(kernel):
    """The Fig. 1 machine's 10 s run completes (success), but N falls to -4.1 N: the ball
    slips at 2.508 s and leaves the wall at 2.585 s, which the result says."""
    tr = simulate_chamber(Ball(), Fig1Machine(), t_end=10.0, dt=0.01, kernel=kernel)
    assert tr.success and tr["N"].min() < -4.0
    assert tr.message == "completed; rolling ended (slip) at t = 2.50818 s; contact lost at 2.58535 s"
    assert tr.valid is False and tr.t_invalid == tr.t_first_slip
    mu = Ball().mu
    assert _bracketed(tr.t, mu * tr["N"] - tr["Ft"], tr.t_first_slip)
    assert _bracketed(tr.t, tr["N"], tr.t_first_flight)
    # interpolated, not the next sample: a ten times finer grid moves them by < dt / 10
    fine = simulate_chamber(Ball(), Fig1Machine(), t_end=3.0, dt=0.001, kernel=kernel)
    assert abs(fine.t_first_slip - tr.t_first_slip) < 1e-3
    assert abs(fine.t_first_flight - tr.t_first_flight) < 1e-3
    assert fine.t_first_slip != pytest.approx(2.51, abs=1e-4)


@pytest.mark.parametrize("kernel", KERNELS)
def test_the_crank_mill_is_valid_until_it_runs_too_fast(kernel):
    model = BallModel(Ball())
    ok = simulate(model, CrankStartup(l=0.5, n0=60.0, t0=2.5), 10.0, 0.01, kernel=kernel)
    assert (ok.success, ok.message, ok.valid, ok.t_invalid, ok.t_first_slip, ok.t_first_flight) == \
        (True, "completed", True, None, None, None)
    fast_mill = simulate(model, CrankStartup(l=0.5, n0=150.0, t0=2.5), 10.0, 0.01, kernel=kernel)
    assert fast_mill.success and not fast_mill.valid and fast_mill.t_first_flight is None
    assert fast_mill.message == f"completed; rolling ended (slip) at t = {fast_mill.t_first_slip:.6g} s"
    assert np.max(fast_mill["friction_ratio"]) > 0.3
    assert _bracketed(fast_mill.t, 0.3 * fast_mill["N"] - fast_mill["Ft"], fast_mill.t_first_slip)
    # no outputs recorded: nothing to judge
    bare = simulate(model, CrankStartup(l=0.5, n0=150.0, t0=2.5), 10.0, 0.01, outputs=False, kernel=kernel)
    assert (bare.message, bare.valid) == ("completed", None)


def test_the_absorber_run_says_where_rolling_ended():
    ball = Ball(r=0.025, R=0.30, m=2.0)
    tower = Structure.single(100.0, 0.8, 0.01)
    calm = simulate_absorber(StructureBall(tower, ball, HarmonicForce(8.0, 0.86)), 10.0, 1e-2)
    assert (calm.success, calm.message, calm.valid) == (True, "completed", True)
    storm = simulate_absorber(StructureBall(tower, ball, HarmonicForce(200.0, 0.86)), 10.0, 1e-2)
    assert storm.success and storm["N"].min() < 0.0
    assert storm.message == "completed; rolling ended (slip) at t = 0.99399 s; contact lost at 1.56939 s"
    assert (storm.valid, storm.t_invalid) == (False, storm.t_first_slip)
    assert _bracketed(storm.t, ball.mu * storm["N"] - storm["Ft"], storm.t_first_slip)
    assert _bracketed(storm.t, storm["N"], storm.t_first_flight)
