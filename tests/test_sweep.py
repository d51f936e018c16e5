"""Design studies (ballmill.sweep): indicators against hand-computed values, validity,
resume, failed points, Dask against in-process, the study files and the command line."""
import json
import math

import numpy as np
import pytest

from ballmill.physics import KERNEL_AVAILABLE
from ballmill.sweep import StudyError, build, load, run_study
from ballmill.sweep import indicators as ind
from ballmill.sweep.engine import read_rows
from ballmill.sweep.spec import Indicator

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason="compiled kernel not built")
M_PAPER = 0.5105088062083415


# ----------------------------------------------------------------------------
# indicators on records built by hand
def _record(t, N, fr=None, refs=None, **more):
    zeros = np.zeros_like(t)
    s = {"ball.N": N, "ball.friction_ratio": fr if fr is not None else zeros + 0.1,
         "ball.xP": more.get("xP", zeros), "ball.yP": more.get("yP", zeros), "ball.zP": more.get("zP", zeros),
         "ball.xC": more.get("xC", zeros), "ball.yC": more.get("yC", zeros), "ball.zC": more.get("zC", zeros + 0.1)}
    for k in ("T_drive", "P_drive"):
        if k in more:
            s["drive." + k] = more[k]
    r = {"start": 0.0, "stop": float(t[-1]), "after": 2.5}
    r.update(refs or {})
    return ind.Record(t, s, "ball", "drive" if "T_drive" in more else None, 0.3, r)


def test_indicators_against_hand_computed_values():
    t = np.linspace(0.0, 10.0, 1001)
    w = 2 * math.pi * 0.37  # peaks fall between samples
    N = 5.0 + 2.0 * np.sin(w * t)
    ang = 2 * math.pi * 0.5 * t
    xP, yP = 0.2 * np.cos(ang), 0.1 * np.sin(ang)  # an ellipse: ring radii 0.1 .. 0.2
    T = 3.0 * np.sin(2 * math.pi * t)  # whole periods in [0, 10]
    P = np.where(t <= 2.5, 4.0, 0.0)  # the drive delivers 4 W during the start-up
    rec = _record(t, N, xP=xP, yP=yP, zP=0.05 + 0.01 * np.cos(w * t), T_drive=T, P_drive=P)
    out = ind.evaluate(rec)
    # a sampled extremum is refined by the parabola through its neighbours: error O(dt^3)
    assert out["N_max"] == pytest.approx(7.0, abs=1e-5)
    assert out["N_range_after"] == pytest.approx(4.0, abs=2e-5)
    assert out["ring_inner"] == pytest.approx(0.1, abs=1e-7)
    assert out["ring_outer"] == pytest.approx(0.2, abs=1e-7)
    assert out["ring_width"] == pytest.approx(0.1, abs=2e-7)
    assert out["zP_max"] == pytest.approx(0.06, abs=1e-7)
    assert out["T_drive_peak"] == pytest.approx(3.0, abs=1e-6)
    assert out["T_drive_rms"] == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-3)
    assert out["E_startup"] == pytest.approx(4.0 * 2.5, abs=1e-12)
    assert out["friction_ratio_max"] == pytest.approx(0.1)
    assert out["valid"] is True and out["t_invalid"] is None


def test_theta_from_contact_point_and_centre():
    # ball centre at polar angle 30 deg from the bottom of a chamber R = 0.25, r = 0.025
    R, r, th = 0.25, 0.025, math.radians(30.0)
    d = R - r
    t = np.linspace(0, 10, 11)
    one = np.ones_like(t)
    rec = _record(t, 5 * one, xP=R * math.sin(th) * one, zP=R * (1 - math.cos(th)) * one,
                  xC=d * math.sin(th) * one, zC=(R - d * math.cos(th)) * one)
    out = ind.evaluate(rec)
    assert out["theta_min_deg"] == pytest.approx(30.0, abs=1e-12)
    assert out["theta_max_deg"] == pytest.approx(30.0, abs=1e-12)


def test_a_statistic_over_an_invalid_span_is_not_reported():
    t = np.linspace(0.0, 10.0, 1001)
    N = 3.0 - 0.5 * t  # contact lost at t = 6 (N = 0 there)
    fr = np.full_like(t, 0.1)
    rec = _record(t, N, fr)
    valid, t_inv, first = ind.validity(t, N, fr, 0.3)
    assert (valid, t_inv, first) == (False, 6.0, 600)
    out = ind.evaluate(rec, [Indicator("early", "ball.N", "max", (0.0, 5.0)),
                             Indicator("late", "ball.N", "max", (5.0, "stop"))])
    assert out["valid"] is False and out["t_invalid"] == 6.0
    assert out["N_max"] is None and out["N_range_after"] is None  # windows reach past t = 6
    assert out["early"] == pytest.approx(3.0) and out["late"] is None
    # slip: the friction ratio above mu at one sample
    fr2 = fr.copy()
    fr2[250] = 0.31
    assert ind.validity(t, np.full_like(t, 5.0), fr2, 0.3)[:2] == (False, 2.5)
    # NaN counts as invalid, never as valid
    fr2[100] = np.nan
    assert ind.validity(t, np.full_like(t, 5.0), fr2, 0.3)[:2] == (False, 1.0)


# ----------------------------------------------------------------------------
# study files and points
def test_grid_and_sample_points():
    st = build("fast_start", grid={"drive.t0": "1,2,2.5", "drive.n0": "40:80:5"})
    pts = st.points()
    assert len(pts) == 15 and pts[0] == {"drive.t0": 1, "drive.n0": 40.0}
    assert [p["drive.n0"] for p in pts[:5]] == [40.0, 50.0, 60.0, 70.0, 80.0]  # the last key varies fastest
    lhs = build("fast_start", sample={"method": "lhs", "points": 50, "seed": 3,
                                      "ranges": {"drive.t0": [1.0, 6.0], "drive.n0": [30.0, 90.0]}})
    pts = lhs.points()
    assert pts == lhs.points()  # the same seed, the same points
    for key, (lo, hi) in (("drive.t0", (1.0, 6.0)), ("drive.n0", (30.0, 90.0))):
        strata = sorted(int((p[key] - lo) / (hi - lo) * 50) for p in pts)
        assert strata == list(range(50))  # one point in each of the 50 strata of each axis


def test_study_problems_are_named():
    with pytest.raises(StudyError) as e:
        build("fast_start", grid={"drive.t0": "1:2", "nodot": [1], "drive.n0": [1, 1]},
              model={"method": "Euler", "h": -1})
    text = str(e.value)
    for part in ("start:stop:count", "'nodot'", "repeated values", "model.method", "model.h"):
        assert part in text
    with pytest.raises(StudyError, match="either a grid or a sample"):
        build("fast_start", grid={"drive.t0": [1]}, sample={"points": 3, "ranges": {"drive.n0": [1, 2]}})


def test_committed_study_files_load():
    for name in ("t0_n0", "start_laws", "lhs_mill"):
        st = load(name)
        assert st.swept and len(st.points()) >= 20


# ----------------------------------------------------------------------------
# whole studies (monolithic kernel)
@needs_kernel
def test_pendulum_indicators_against_energy_conservation(tmp_path):
    """A ball released at rest at polar angle theta0 in a chamber that does not move
    (n0 = 0): it swings back to theta0 (energy), passes the bottom with
    N = m g (1 + 10/7 (1 - cos theta0)) (rolling: 7/10 m v^2 = m g d (1 - cos theta0)),
    and its largest friction ratio, at the turning points, is (2/7) tan theta0."""
    st = build("fast_start", grid={"ball.xC0": [0.05, 0.1]}, set_=["drive.n0=0"], model={"dt": 0.002})
    res = run_study(st, tmp_path / "s", scheduler="in-process", progress=False, plots=False)
    R, r, g = 0.25, 0.025, 9.81
    d = R - r
    for row in res.rows:
        assert row["status"] == "ok", row["message"]
        th0 = math.asin(row["ball.xC0"] / d)
        assert row["theta_max_deg"] == pytest.approx(math.degrees(th0), abs=1e-4)
        assert row["zP_max"] == pytest.approx(R * (1 - math.cos(th0)), abs=1e-7)
        assert row["N_max"] == pytest.approx(M_PAPER * g * (1 + 10 / 7 * (1 - math.cos(th0))), rel=1e-5)
        assert row["friction_ratio_max"] == pytest.approx(2 / 7 * math.tan(th0), rel=1e-5)
        assert row["T_drive_peak"] == pytest.approx(0.0, abs=1e-12)  # swings in x, crank along x
        assert row["E_startup"] == pytest.approx(0.0, abs=1e-12)
        assert row["valid"] is True and row["error_P_m"] < 1e-5


@needs_kernel
def test_fast_start_point_reproduces_the_paper_numbers(tmp_path):
    st = build("fast_start", grid={"drive.t0": [2.5, 30.0]}, set_=["ball.m=0.5105088062083415"])
    rows = run_study(st, tmp_path / "s", scheduler="in-process", progress=False, plots=False).rows
    fast = rows[0]
    assert fast["N_range_after"] == pytest.approx(8.48, abs=0.01)  # docs/usage.md: 8.48 N
    assert fast["ring_inner"] == pytest.approx(0.208, abs=1e-3) and fast["ring_outer"] == pytest.approx(0.250, abs=1e-3)
    assert fast["zP_max"] == pytest.approx(0.240, abs=1e-3)
    assert fast["error_P_m"] <= 1e-5 and fast["model"].startswith("crank-kernel")
    # t0 = 30 s is past the scenario's stop (10 s): nothing 'after' it is reported
    slow = rows[1]
    assert slow["N_range_after"] is None and slow["ring_width"] is None and slow["N_max"] is not None


@needs_kernel
def test_resume_skips_finished_points_and_a_bad_point_is_a_failed_row(tmp_path):
    # n0 = 1e5 1/min passes the check before the run (within MotorStartup's range) but the
    # kernel's RK4 at h = 0.01 s diverges on it: a failed row with the integrator's reason. With
    # the Richardson estimate's two full runs: the default one-pass run stops at the point's first
    # invalid sample (it slips at once), before it diverges (tests/test_sweep_one_pass.py)
    out = tmp_path / "s"
    model = {"error": "richardson"}
    first = run_study(build("fast_start", grid={"drive.n0": [60.0, 1e5]}, model=model), out,
                      scheduler="in-process", progress=False, plots=False)
    assert (first.computed, first.failed) == (2, 1)
    bad = next(r for r in first.rows if r["drive.n0"] == 1e5)
    assert bad["status"] == "failed" and "non-finite" in bad["message"]
    assert bad["N_max"] is None
    good = next(r for r in first.rows if r["drive.n0"] == 60.0)
    assert good["status"] == "ok" and good["N_max"] > 0
    # a larger grid over the same study: only the new points run; the old rows stay as they were
    second = run_study(build("fast_start", grid={"drive.n0": [60.0, 1e5, 70.0]}, model=model), out,
                       scheduler="in-process", progress=False, plots=False)
    assert (second.computed, second.skipped) == (1, 2)
    rows = read_rows(out / "results.parquet")
    assert [r["point"] for r in rows] == [0, 1, 2]
    assert rows[0] == good and rows[1]["status"] == "failed"
    # failed points again, on request
    third = run_study(build("fast_start", grid={"drive.n0": [60.0, 1e5, 70.0]}, model=model), out,
                      scheduler="in-process", progress=False, plots=False, retry_failed=True)
    assert (third.computed, third.skipped, third.failed) == (1, 2, 1)
    # another study into the same folder is refused, not mixed
    with pytest.raises(StudyError, match="another study"):
        run_study(build("fast_start", grid={"drive.n0": [60.0]}, set_=["drive.t0=2"], model=model), out,
                  scheduler="in-process", progress=False, plots=False)


@needs_kernel
def test_dask_processes_localcluster_and_in_process_give_identical_results(tmp_path):
    st = build("fast_start", grid={"drive.t0": [1.0, 2.5, 4.0], "drive.n0": [50, 70]},
               indicators=[{"name": "xP_amp", "variable": "ball.xP", "stat": "amplitude", "window": ["after", 8]}])
    here = run_study(st, tmp_path / "a", scheduler="in-process", progress=False, plots=False)
    dask = run_study(st, tmp_path / "b", scheduler="local", workers=2, batch=2, progress=False, plots=False)
    assert "dask LocalCluster" in dask.executor and dask.computed == 6
    forked = run_study(st, tmp_path / "f", workers=2, batch=2, progress=False, plots=False)  # the default
    assert forked.executor == "dask processes scheduler, 2 worker process(es) forked from this one"
    assert forked.computed == 6 and forked.batch == 2
    assert read_rows(tmp_path / "a" / "results.parquet") == read_rows(tmp_path / "b" / "results.parquet")
    assert read_rows(tmp_path / "a" / "results.parquet") == read_rows(tmp_path / "f" / "results.parquet")
    assert here.rows == dask.rows == forked.rows


@needs_kernel
def test_default_batches_are_cut_for_the_forked_workers(tmp_path):
    """20 points on 2 workers: about 8 tasks per worker, so batches of 2 (not the 3 of one worker)."""
    st = build("fast_start", grid={"drive.t0": [1.0, 1.5, 2.0, 2.5, 3.0], "drive.n0": [50, 55, 60, 65]})
    res = run_study(st, tmp_path, workers=2, progress=False, plots=False)
    assert res.executor.startswith("dask processes scheduler, 2 ") and res.computed == 20
    assert res.batch == 2 and json.loads((tmp_path / "timing.json").read_text())["batch"] == 2


@needs_kernel
def test_plots_hatch_the_invalid_cells(tmp_path, subplots_made):
    st = build("fast_start", grid={"drive.t0": [0.5, 2.5], "drive.n0": [60, 80]})
    res = run_study(st, tmp_path / "s", scheduler="in-process", progress=False)
    assert any(r["valid"] is False for r in res.rows)  # t0 = 0.5 s at 80 1/min: the ball slips
    names = {p.name for p in res.plots}
    assert "map_N_range_after.png" in names and all(p.stat().st_size > 1000 for p in res.plots)
    one = run_study(build("fast_start", grid={"drive.t0": [1.0, 2.0, 3.0]}), tmp_path / "c",
                    scheduler="in-process", progress=False)
    assert [p.name for p in one.plots] == ["curves.png"]
    # the default executor (Dask's processes scheduler): the same files, byte for byte, drawn by
    # its workers (no figure made in this process)
    drawn_here = len(subplots_made)
    forked = run_study(st, tmp_path / "f", workers=2, progress=False)
    assert forked.executor.startswith("dask processes scheduler")
    assert len(subplots_made) == drawn_here
    assert sorted(p.name for p in forked.plots) == sorted(names) and len(forked.plots) == len(res.plots)
    assert all((tmp_path / "f" / p.name).read_bytes() == p.read_bytes() for p in res.plots)


@needs_kernel
def test_sweep_command_line(tmp_path):
    from ballmill.cli import main

    out = tmp_path / "cli"
    assert main(["sweep", "fast_start", "--grid", "drive.t0=2,3", "--set", "drive.n0=50", "--out", str(out),
                 "--in-process", "--quiet", "--no-plots"]) == 0
    rows = read_rows(out / "results.parquet")
    assert [r["drive.t0"] for r in rows] == [2, 3] and all(r["status"] == "ok" for r in rows)
    assert list(rows[0])[:2] == ["drive.t0", "N_max"]
    assert main(["sweep", "fast_start", "--grid", "nodot=1", "--out", str(out), "--in-process"]) == 2


# ----------------------------------------------------------------------------
# the co-simulation evaluator, against the monolithic kernel on the same points
@needs_kernel
def test_cosim_points_agree_with_the_kernel(tmp_path, fmu_build_dir):
    from ballmill.scenario import spec as scen
    from ballmill.sweep import evaluators

    assert evaluators.choose(scen.load("fast_start")).kind == "crank-kernel"
    assert evaluators.choose(scen.load("induction_start")).kind == "cosim"  # no closed form
    grid = {"drive.t0": [2.5], "drive.law": [1, 2]}
    kern = run_study(build("fast_start", grid=grid), tmp_path / "k", scheduler="in-process", progress=False,
                     plots=False).rows
    cos = run_study(build("fast_start", grid=grid, model={"kind": "cosim"}), tmp_path / "c",
                    scheduler="in-process", progress=False, plots=False, build_dir=fmu_build_dir).rows
    for k, c in zip(kern, cos):
        assert c["status"] == "ok", c["message"]
        assert c["model"].startswith("cosim") and "coupling_error" in c["error_method"]
        # docs/usage.md: the coupled fast start is within 1e-9 m of the monolithic contact point and
        # 3e-4 N in N at the 2 ms step; the indicators sample at 2 ms (cosim) and 10 ms (kernel).
        # E_startup: the drive FMU's T_drive at a communication point uses the M_reaction of the
        # previous one (Jacobi), a lag of one 2 ms step: -h * integral(M' psi') ~ 0.03 J
        for name, tol in (("N_range_after", 5e-3), ("N_max", 5e-3), ("ring_inner", 1e-5), ("ring_outer", 1e-5),
                          ("zP_max", 1e-5), ("theta_max_deg", 1e-3), ("T_drive_peak", 5e-3), ("E_startup", 0.05)):
            assert c[name] == pytest.approx(k[name], abs=tol), name


# ----------------------------------------------------------------------------
# a model of another kind plugs in without touching the engine
class _ToyPrepared:
    model = "toy: N = m g (1 + a sin t)"
    sequential = True  # its points continue from one another: one task, in order
    timing: dict = {}

    def run(self, params):
        t = np.linspace(0.0, 10.0, 1001)
        a = float(params["ball.m"])  # any parameter of the scenario, read as the toy pleases
        zeros = np.zeros_like(t)
        s = {"ball.N": 9.81 * (1 + 0.5 * a * np.sin(t)), "ball.friction_ratio": zeros}
        s.update({f"ball.{k}": zeros for k in ("xP", "yP", "zP", "xC", "yC", "zC")})
        rec = ind.Record(t, s, "ball", None, 0.3, {"start": 0.0, "stop": 10.0, "after": 0.0})
        return rec, {"model": self.model, "error_P_m": 0.0, "error_N_N": 0.0, "error_method": "exact"}

    def evaluate(self, rec, custom):
        valid, t_inv, n = ind.validity(rec.t, rec.get("ball.N"), rec.get("ball.friction_ratio"), rec.mu)
        return {"N_swing": ind.statistic(rec, rec.get("ball.N"), "range", ("start", "stop"), n),
                "valid": valid, "t_invalid": t_inv}


def test_an_evaluator_plugs_in(tmp_path):
    from ballmill.sweep import evaluators

    class Toy(evaluators.Evaluator):
        kind = "toy"
        indicators = {"N_swing": ("N", "max - min of N")}

        def check(self, sc):
            return ""

        def prepare(self, sc, study, build_dir=None):
            return _ToyPrepared()

    evaluators.register(Toy(), before="cosim")
    try:
        assert evaluators.ORDER.index("toy") == evaluators.ORDER.index("cosim") - 1
        res = run_study(build("fast_start", grid={"ball.m": [0.5, 1.0]}, model={"kind": "toy"}), tmp_path / "t",
                        scheduler="in-process", progress=False, plots=False)
        assert [r["N_swing"] for r in res.rows] == pytest.approx([9.81 * 0.5, 9.81 * 1.0], rel=1e-6)
        assert "N_max" not in res.rows[0] and res.rows[0]["model"].startswith("toy")
        assert res.batch == 2  # both points in one task
    finally:
        evaluators.REGISTRY.pop("toy")
        evaluators.ORDER.remove("toy")


@needs_kernel
def test_startup_energy_is_the_energy_given_to_ball_and_platform(tmp_path):
    """E_startup = integral of T_drive psi' over [0, t0] with T_drive = J_total psi'' - M_reaction:
    by the energy balance it equals 1/2 J_total w0^2 plus the ball's energy gain up to t0
    (kinetic, with the platform's velocity, and potential)."""
    from ballmill.physics import Ball, BallModel, CrankStartup, simulate

    st = build("fast_start", grid={"drive.t0": [1.5, 2.5, 4.0]},
               set_=["drive.m_platform=30.0", "drive.J_crank=0.2", f"ball.m={M_PAPER!r}"], model={"dt": 0.002})
    rows = run_study(st, tmp_path / "e", scheduler="in-process", progress=False, plots=False).rows
    ball = Ball(m=M_PAPER)
    for row in rows:
        t0 = row["drive.t0"]
        law = CrankStartup(0.5, 60.0, t0)
        model = BallModel(ball, tol=1e-12)
        tr = simulate(model, law, t0, t0 / 1000)
        from ballmill.physics.model import BallState
        end = BallState(float(tr.t[-1]), tr.y[-1])
        _, _, vx, vy, _, _ = law.state(float(tr.t[-1]))
        gain = model.energy(end, vx, vy) - model.energy(model.initial(), 0.0, 0.0)
        j_total = 0.2 + 30.0 * 0.5 ** 2
        # trapezoid rule over samples every 2 ms of a power that oscillates at ~10 rad/s: ~1e-4 J
        assert row["E_startup"] == pytest.approx(0.5 * j_total * law.w0 ** 2 + gain, abs=1e-3), t0
