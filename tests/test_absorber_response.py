"""Steady states, refined FRFs and sweeps of the absorber (ballmill.absorber.response)
and the absorber_frf study's FRF at 0.05 N against the linear closed form."""
import csv
import math

import numpy as np
import pytest

from ballmill.absorber.linear import den_hartog_ball
from ballmill.absorber.response import refine, steady_state, sweep
from ballmill.studies import absorber as study


def test_refine_resolves_a_narrow_peak():
    """A resonance 0.008 Hz wide at half power: on a uniform 0.005 Hz grid its height
    can be misread by 10 % or more; refining until `refine` adds nothing gets it within
    0.5 %."""
    f0, zeta = 0.8479, 0.005

    def amp(f):
        r = f / f0
        return 1.0 / math.sqrt((1 - r * r) ** 2 + (2 * zeta * r) ** 2)

    top = max(amp(f) for f in np.linspace(f0 - 1e-3, f0 + 1e-3, 20001))
    grid = list(np.arange(0.70, 0.90 + 1e-9, 0.005))
    coarse = max(amp(f) for f in grid)
    assert coarse < 0.9 * top  # the misreading the refinement is for
    for _ in range(30):
        new = refine(grid, [amp(f) for f in grid])
        if not new:
            break
        grid = sorted(set(grid) | set(new))
    else:
        pytest.fail("refine did not finish")
    assert max(amp(f) for f in grid) == pytest.approx(top, rel=0.005)
    assert len(grid) < 80  # refined where it peaks, not everywhere


def test_error_estimate_covers_the_distance_to_the_steady_state():
    """Started from rest (a full transient), the converged amplitude is within its
    error estimate of the exact steady state (the linear one, at 0.05 N)."""
    case = study.case()
    exact = abs(case.linear().frf(0.78)[0]) * case.force
    p = steady_state(case, 0.78, state=case.system(0.78).initial(), max_periods=600)
    assert p.converged
    assert abs(p.amplitude_m - exact) <= max(p.amplitude_err_m, 1e-3 * exact)
    assert p.periods > 40  # it did have to wait out the transient


def test_sweep_continues_state_and_phase():
    """A sweep point at the frequency it already settled at needs only the minimum of
    windows and finds the same amplitude: the state and the force's phase carry over."""
    ball = den_hartog_ball(study.structure().x, study.R_BALL, study.M_BALL)
    case = study.case(force=1.0, ball=ball)
    pts = sweep(case, [0.78, 0.78])
    assert pts[0].converged and pts[1].converged
    assert pts[1].periods == 12
    assert pts[1].amplitude_m == pytest.approx(pts[0].amplitude_m, rel=1e-3)
    assert not pts[1].restarted


def test_study_frf_matches_linear_closed_form(tmp_path):
    """The absorber_frf case at F0 = 0.05 N (quick grid, refined at the peaks): every
    point within 2 % of the linear two-degree-of-freedom solution, and both split
    peaks found within 2 % of their closed-form height."""
    rows = study.run_frf(quick=True)
    study.write_csv(tmp_path / "frf.csv", rows)
    with open(tmp_path / "frf.csv") as fh:
        read = list(csv.DictReader(fh))
    assert list(read[0])[:3] == ["frequency_Hz", "amplitude_m", "amplitude_bare_m"]
    f = np.array([float(r["frequency_Hz"]) for r in read])
    a = np.array([float(r["amplitude_m"]) for r in read])
    case = study.case()
    lin = np.abs(case.linear().frf(f)) * case.force
    peak = lin.max()
    # relative 2 % wherever the response is not within 1 % of the peak of zero (the
    # antiresonance at 0.8 Hz, where the linear amplitude vanishes)
    big = lin > 0.01 * peak
    assert np.all(np.abs(a[big] / lin[big] - 1) < 0.02)
    assert np.all(np.abs(a[~big] - lin[~big]) < 0.02 * 0.01 * peak)
    for fp, hp in case.linear().peaks(study.F_LO, study.F_HI):
        near = np.abs(f - fp) < 0.01
        assert a[near].max() == pytest.approx(hp * case.force, rel=0.02)
    bare = np.abs(case.linear(ball=False).frf(f)) * case.force
    assert np.allclose([float(r["amplitude_bare_m"]) for r in read], bare, rtol=1e-12)
    assert all(r["rolling"] == "1" and r["contact"] == "1" for r in read)
