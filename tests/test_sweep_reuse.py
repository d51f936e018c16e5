"""What a crank-kernel worker keeps between the points of a study (the ball built once for the points
that share its parameters, the sample times) and the indicators' windowed derivations: a point's
values are its own whatever came before it, and a variable derived over a window is the whole
run's derivation there, bit for bit."""
import numpy as np
import pytest

from ballmill.physics import KERNEL_AVAILABLE
from ballmill.sweep.spec import build

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason="compiled kernel not built")


def _prepared(study):
    from ballmill.scenario import spec as scen
    from ballmill.sweep import evaluators

    sc = scen.load(study.scenario, study.set)
    return evaluators.choose(sc, "auto").prepare(sc, study)


@needs_kernel
def test_a_point_gets_its_own_ball_whatever_point_came_before():
    study = build("fast_start", grid={"ball.mu": [0.2, 0.4], "drive.n0": [60.0]})
    P = _prepared(study)
    a, b = {"ball.mu": 0.2, "drive.n0": 60.0}, {"ball.mu": 0.4, "drive.n0": 60.0}
    first = P.evaluate(P.run(a)[0], ())
    rec_b = P.run(b)[0]
    assert rec_b.mu == 0.4 and P.objects(b)[0].mu == 0.4 and P.objects(a)[0].mu == 0.2
    other = P.evaluate(rec_b, ())
    assert other["friction_ratio_max"] is not None or other["valid"] is False
    again = P.evaluate(P.run(a)[0], ())
    assert again == first  # exactly: the same run, the same indicators (None where not reported)
    assert other != first  # mu changes the run's validity or its margins
    # a ball parameter the model does not know is still refused at every point, also after a good one
    from ballmill.physics.errors import ParameterError

    for _ in range(2):
        with pytest.raises(ParameterError, match=r"ball\.spin: no such parameter"):
            P.objects({"ball.spin": 1.0, "drive.n0": 60.0})


@needs_kernel
def test_a_derived_variable_over_a_window_is_the_whole_runs_there():
    P = _prepared(build("fast_start", grid={"drive.n0": [60.0]}))
    rec = P.run({"drive.n0": 60.0})[0]
    n = len(rec.t)
    for name in ("ball.rhoP", "ball.theta_deg", "ball.slip_margin"):
        for sl in (slice(n // 4, n), slice(0, n // 2), slice(n // 3, n // 3 + 7)):
            part = rec.over(name, sl)
            assert name not in rec.derived  # derived over the window only
            whole = rec.get(name)[sl]
            assert part.tobytes() == whole.tobytes()
            rec.derived.clear()
