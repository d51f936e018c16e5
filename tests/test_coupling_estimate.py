"""BallInShell's a-posteriori estimate of its coupling error (output coupling_error):
the distance between the contact point it predicted for a communication point and the
one its corrector computes there once the true inputs are known. The corrected state
is accurate to the interpolation error, far below the prediction's, so the estimate
should match the published contact point's actual error against the monolithic
solution; a step too long for the drive's time scale is reported in the log."""
import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, CrankStartup, simulate
from ballmill.scenario import runner


def _run(fmu_build_dir, step, stop, sets=(), flavour="native"):
    sc, models, paths = runner.prepare("fast_start", list(sets), fmu_build_dir, log=lambda m: None,
                                       flavour=flavour)
    sc.step, sc.stop = step, stop
    res = runner.run(sc, models, paths, progress=False, echo=False)
    assert res.success, res.message
    return res


@pytest.mark.parametrize("step", [0.005, 0.02])
def test_estimate_matches_the_actual_contact_point_error(fmu_build_dir, fmu_flavour, step):
    res = _run(fmu_build_dir, step, 5.0, flavour=fmu_flavour)
    ref = simulate(BallModel(Ball(), tol=1e-13), CrankStartup(0.5, 60.0, 2.5), 5.0, step)
    actual = np.sqrt(sum((res.column(f"ball.{c}") - ref[c]) ** 2 for c in ("xP", "yP", "zP")))
    estimate = res.column("ball.coupling_error")
    # the estimate at t_k describes the output published at t_k one step earlier
    # (the prediction); compare the worst cases over the run: within 10 %
    assert estimate.max() == pytest.approx(actual.max(), rel=0.1)
    assert estimate.max() > 1e-10  # not trivially zero


def test_too_long_a_step_for_the_drive_is_reported(fmu_build_dir, fmu_flavour):
    # a near-impulsive start (t0 = 10 ms) at a 10 ms step: accepted by max_step (ball time
    # scale) but far too coarse for the drive; the estimate flags it at the first correction
    res = _run(fmu_build_dir, 0.01, 0.5, ["drive.t0=0.01"], fmu_flavour)
    warnings = [m for m in res.messages if "coupling_warn" in m["message"]]
    assert len(warnings) == 1 and warnings[0]["status"] == "warning"
    assert res.column("ball.coupling_error").max() > 1e-3
    fine = _run(fmu_build_dir, 0.001, 0.5, ["drive.t0=0.01"], fmu_flavour)
    assert not [m for m in fine.messages if "coupling_warn" in m["message"]]
