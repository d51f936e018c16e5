"""The crank-kernel evaluator's one-pass RK4 run (model.error = "one-pass", the default): the
run estimates its own error, without a second run (bm_lerr in ballmill/physics/_kernel.c),
and ends where the model stops holding.

* every indicator, valid and t_invalid are those of step doubling's separate full runs
  (model.error = "richardson") at the same h, bit for bit, on points that stay valid and
  on points that slip; a point whose h the two estimates set differently meets the target
  with its own;
* a point that slips is integrated only up to its first invalid sample;
* the work is the one run's: 4 derivatives a step, one more to end;
* the estimate against the actual error: on a grid of points a user would sweep (t0 from
  1 s, up to 80 1/min, RK4 at h = 0.01 s and 0.005 s), the largest distance of the contact
  point, and of N, from a run at h/16 (RK4's error falls by 16^4: the reference is exact to
  ~1e-5 of the error measured), over the samples the indicators read. The stated factors:
  the contact point's estimate within [0.3, 3] of its actual error at every point (the
  median within [0.7, 2]); N's estimate never below its actual error and at most 30 times it
  (N's local errors, summed without sign, do not cancel as N's oscillating errors do).
  Richardson's estimate on the same points lies within [0.58, 1.0]: it is the error's
  leading term, for a second run. The free estimate's lowest ratio, 0.31, is at t0 = 1 s on
  a step boundary: the step from t0 takes the start-up's acceleration at its first stage (an
  O(h^2) error of that one step), which the run's own derivatives cannot show.
"""
import numpy as np
import pytest

from ballmill.physics import KERNEL_AVAILABLE, Ball, BallModel, CrankStartup, simulate
from ballmill.sweep.engine import read_rows, run_study
from ballmill.sweep.spec import build

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason="compiled kernel not built")

GRID = {"drive.t0": [0.5, 1.0, 1.2, 2.5], "drive.n0": [60.0, 75.0, 80.0]}
INDICATORS = [{"name": "xP_amp_early", "variable": "ball.xP", "stat": "amplitude", "window": [0.1, 0.3]}]


def _prepared(study):
    from ballmill.scenario import spec as scen
    from ballmill.sweep import evaluators

    sc = scen.load(study.scenario, study.set)
    return evaluators.choose(sc, "auto").prepare(sc, study)


@needs_kernel
def test_one_pass_gives_the_full_runs_indicators(tmp_path):
    one = run_study(build("fast_start", grid=GRID, indicators=INDICATORS), tmp_path / "one",
                    scheduler="in-process", progress=False, plots=False).rows
    old = run_study(build("fast_start", grid=GRID, indicators=INDICATORS, model={"error": "richardson"}),
                    tmp_path / "old", scheduler="in-process", progress=False, plots=False).rows
    assert [r["point_id"] for r in one] == [r["point_id"] for r in old]
    late = [r for r in one if r["valid"] is False and r["t_invalid"] > 0.3]  # after xP_amp_early's window
    assert len(late) >= 1 and sum(r["valid"] is False for r in one) >= 4  # some slip at once, some later
    estimate = ("error_P_m", "error_N_N", "error_method")
    same = 0
    for a, b in zip(one, old):
        assert a["status"] == "ok" and a["error_method"].startswith("the run's own")
        assert b["error_method"] == "Richardson: RK4 at h and 2h, |difference| / 15 (order 4)"
        if a["model"] == b["model"]:  # the same step: the same samples up to t_invalid
            same += 1
            assert {k: v for k, v in a.items() if k not in estimate} == \
                {k: v for k, v in b.items() if k not in estimate}
        else:  # the estimates set h differently: each meets the target with its own
            assert a["error_P_m"] <= 0.8 * 1e-5 or "h = 0.000625 s" in a["model"]
    assert same > 0  # at a fixed h every point is the same: test_the_free_estimate_costs_no_second_run...
    assert read_rows(tmp_path / "one" / "results.parquet") == one


@needs_kernel
def test_a_point_that_slips_stops_at_its_first_invalid_sample():
    study = build("fast_start", grid={"drive.t0": [1.0], "drive.n0": [80.0]})
    prep = _prepared(study)
    ball, crank, init, *_ = prep.objects(study.points()[0])
    traj, meta = prep._rk4_one_pass(ball, crank, init)
    rolling = (traj["N"] > 0) & (traj["friction_ratio"] <= ball.mu)
    assert rolling[:-1].all() and not rolling[-1]  # the first invalid sample is the last one
    assert 0.3 < traj.t[-1] < 0.4 and prep.sc.stop == 10.0  # it slips at 0.34 s; the scenario runs to 10 s
    full = prep._simulate(ball, crank, init, 0.01, prep.dt)  # the same samples as the full run
    assert np.array_equal(full["zP"][:len(traj.t)], traj["zP"])


ESTIMATE_GRID = {"drive.t0": [1.0, 1.5, 2.5, 4.0], "drive.n0": [40.0, 60.0, 80.0]}
BALL = Ball(r=0.025, R=0.25, m=0.5105088062083415, mu=0.3)  # fast_start's ball


def actual_errors(t0, n0, h, last):
    """(contact point [m], N [N]): the largest differences of the run at h from the run at h/16
    over the samples 0..last (every 0.01 s)."""
    crank = CrankStartup(law="quadratic", l=0.5, n0=n0, t0=t0)
    runs = []
    for step in (h, h / 16):
        model = BallModel(BALL, method="RK4", h_fixed=step)
        state = model.initial(0.0, 0.0, (0.0, 0.0, 0.0), t0=0.0)
        runs.append(simulate(model, crank, t_end=10.0, dt=0.01, state=state, outputs=True, kernel="c"))
    a, b = runs
    k = last + 1
    dP = np.sqrt(sum((a[v][:k] - b[v][:k]) ** 2 for v in ("xP", "yP", "zP")))
    return float(dP.max()), float(np.abs(a["N"][:k] - b["N"][:k]).max())


def estimates(tmp_path, h, error):
    """The sweep's rows on GRID at a fixed h (target_P = 1 m: no halving)."""
    from ballmill.sweep.engine import run_study
    from ballmill.sweep.spec import build

    study = build("fast_start", grid=ESTIMATE_GRID, model={"h": h, "target_P": 1.0, "error": error})
    return run_study(study, tmp_path / f"{error}_{h}", scheduler="in-process", progress=False, plots=False).rows


@needs_kernel
@pytest.mark.parametrize("h", [0.01, 0.005])
def test_the_free_estimate_tracks_the_actual_error_within_its_stated_factor(tmp_path, h):
    rows = estimates(tmp_path, h, "one-pass")
    assert len(rows) == 12 and all(r["status"] == "ok" for r in rows)
    assert all(r["error_method"].startswith("the run's own") for r in rows)
    ratios_P, ratios_N = [], []
    for r in rows:
        t = 10.0 if r["valid"] else r["t_invalid"]
        last = min(1000, int(np.ceil(t / 0.01 - 1e-9)))  # the sample where the run stopped
        eP, eN = actual_errors(r["drive.t0"], r["drive.n0"], h, last)
        ratios_P.append(r["error_P_m"] / eP)
        ratios_N.append(r["error_N_N"] / eN)
    ratios_P, ratios_N = np.array(ratios_P), np.array(ratios_N)
    assert ratios_P.min() >= 0.3 and ratios_P.max() <= 3, ratios_P
    assert 0.7 <= np.median(ratios_P) <= 2, ratios_P
    assert ratios_N.min() >= 1 and ratios_N.max() <= 30, ratios_N


@needs_kernel
def test_the_free_estimate_costs_no_second_run_and_leaves_the_indicators_as_they_are(tmp_path):
    """At a fixed h, every point's indicators are those of step doubling's full runs (the
    samples up to t_invalid are the same); the work is the one run's: 4 derivatives a step
    plus one to end (step doubling: 1.5 times that); a run whose estimate passes a limit (it
    will be redone at h / 2) ends there."""
    from ballmill.physics import fast

    one, rich = estimates(tmp_path, 0.01, "one-pass"), estimates(tmp_path, 0.01, "richardson")
    skip = {"error_P_m", "error_N_N", "error_method"}
    for a, b in zip(one, rich):
        assert {k: v for k, v in a.items() if k not in skip} == {k: v for k, v in b.items() if k not in skip}
    model = BallModel(BALL, method="RK4", h_fixed=0.01)
    crank = CrankStartup(law="quadratic", l=0.5, n0=60.0, t0=2.5)
    times = 0.01 * np.arange(1001)
    r = fast.study_run(model, crank, times, model.initial(0.0, 0.0, (0.0, 0.0, 0.0), t0=0.0), True, None)
    assert r.last == 1000 and r.err_P is not None and model.info.nfev == 4 * 1000 + 1
    # a run to be redone at h / 2 ends where its estimate passes the limit, the samples so far the same
    half = fast.study_run(model, crank, times, model.initial(0.0, 0.0, (0.0, 0.0, 0.0), t0=0.0), True, None,
                          limit=r.err_P / 2)
    assert half.exceeded and not half.failed and 100 < half.last < 1000 and r.err_P / 2 < half.err_P < r.err_P
    assert np.array_equal(half.ys[:half.last + 1], r.ys[:half.last + 1])
