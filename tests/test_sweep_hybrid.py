"""Studies of the hybrid ball (a study's [contact] table, evaluator "hybrid-kernel"): its
indicators against the closed form of a ball that keeps rolling, against simulate_hybrid's own
event list on a start that strikes the shell, on a record built by hand (the mode fractions, a
run stopped early), and the study checks of [contact]."""
import json
import math

import numpy as np
import pytest

from ballmill.physics import KERNEL_AVAILABLE, Ball, BallModel, CrankStartup
from ballmill.physics.hybrid import Contact, simulate_hybrid
from ballmill.sweep import StudyError, build, run_study
from ballmill.sweep import indicators as ind

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason="compiled kernel not built")
M_PAPER = 0.5105088062083415


def _rows(tmp_path, grid, stop=None, contact=None, set_=()):
    st = build("fast_start", grid=grid, set_=list(set_), contact={} if contact is None else contact, stop=stop)
    return run_study(st, tmp_path, scheduler="in-process", progress=False, plots=False).rows


@needs_kernel
def test_a_ball_that_keeps_rolling_gives_the_rolling_numbers_and_no_losses(tmp_path):
    """The paper's fast start (t0 = 2.5 s) never leaves rolling: the mode fractions are exactly
    1/0/0, no impact, no slip, no flight, no energy lost, valid; the rolling indicators are the
    rolling study's (docs/usage.md: N variation 8.48 N, ring 0.208..0.250 m) to DOP853's
    tolerance against RK4's estimated 1e-5 m."""
    rows = _rows(tmp_path / "h", {"drive.t0": [2.5]}, set_=[f"ball.m={M_PAPER}"])
    roll = run_study(build("fast_start", grid={"drive.t0": [2.5]}, set_=[f"ball.m={M_PAPER}"]), tmp_path / "r",
                     scheduler="in-process", progress=False, plots=False).rows
    h, r = rows[0], roll[0]
    assert h["status"] == "ok", h["message"]
    assert h["model"].startswith("hybrid-kernel") and "e_n = 0.5" in h["model"]
    assert (h["rolling_fraction"], h["sliding_fraction"], h["flight_fraction"]) == (1.0, 0.0, 0.0)
    assert h["n_impacts"] == 0 and h["v_impact_max"] == 0.0
    assert h["E_friction_rev"] == 0.0 and h["E_impact_rev"] == 0.0
    assert h["t_first_slip"] is None and h["t_first_flight"] is None
    assert h["valid"] is True and h["t_invalid"] is None
    assert h["N_range_after"] == pytest.approx(8.48, abs=0.01)
    for k in ("N_max", "N_range_after", "friction_ratio_max"):
        assert h[k] == pytest.approx(r[k], rel=1e-4), k
    for k in ("ring_inner", "ring_outer", "zP_max"):
        assert h[k] == pytest.approx(r[k], abs=2e-5), k
    assert r["valid"] is True  # the rolling model holds there too


@needs_kernel
def test_a_start_that_strikes_the_shell_counts_what_simulate_hybrid_lists(tmp_path):
    """t0 = 0.1 s, n0 = 100 1/min, 1.5 s: the ball slips at once, leaves the wall and strikes
    it. The indicators are those of simulate_hybrid's own run (its events), the flight time
    within one sample per flight of the events' times, and the point stays valid."""
    rows = _rows(tmp_path, {"drive.t0": [0.1], "drive.n0": [100.0]}, stop=1.5)
    row = rows[0]
    assert row["status"] == "ok", row["message"]
    ball, crank = Ball(m=M_PAPER), CrankStartup(t0=0.1, n0=100.0)
    state = BallModel(ball).initial(0.0, 0.0, (0.0, 0.0, 0.0))
    tr = simulate_hybrid(ball, crank, 1.5, 0.01, Contact(), initial=state, method="DOP853", tol=1e-8)
    impacts = tr.of_kind("impact")
    assert len(impacts) >= 2  # the scene does what it is here for
    assert row["n_impacts"] == len(impacts)
    assert row["v_impact_max"] == max(e.details["v_n"] for e in impacts)
    assert row["t_first_slip"] == tr.t_first_slip == 0.0 and tr["mode"][0] == 2  # slides from the start
    assert row["t_first_flight"] == tr.of_kind("leave")[0].t
    turns = crank.angles(np.array([1.5]))[0][0] / (2 * math.pi)
    assert row["E_friction_rev"] == pytest.approx(tr["E_friction"][-1] / turns, rel=1e-12)
    assert row["E_impact_rev"] == pytest.approx(tr["E_impact"][-1] / turns, rel=1e-12)
    # flight from the events: from each leave (or a rebound) to the next impact
    flight, up = 0.0, None
    for e in tr.events:
        if e.mode_after == 0 and up is None:
            up = e.t
        elif e.mode_after != 0 and up is not None:
            flight, up = flight + e.t - up, None
    n_flights = sum(e.mode_after == 0 for e in tr.events)
    assert row["flight_fraction"] * 1.5 == pytest.approx(flight, abs=n_flights * 0.01)
    assert row["flight_fraction"] > 0.0 and row["sliding_fraction"] > 0.0
    assert row["rolling_fraction"] + row["sliding_fraction"] + row["flight_fraction"] == pytest.approx(1.0, abs=1e-12)
    assert row["valid"] is True and row["t_invalid"] is None  # the rolling rule (slip at 0) does not latch
    info = json.loads((tmp_path / "study.json").read_text())["indicators"]
    assert info["valid"].startswith("the hybrid run reached the end") and "n_impacts" in info


def test_mode_fractions_and_a_run_stopped_early_on_a_record_built_by_hand():
    """Rolling over [0, 1], sliding over (1, 2], flight over (2, 4] sampled every 0.5 s: the
    trapezoidal rule gives 1.25/4, 1/4, 1.75/4. A run that stopped early (a Zeno sequence) is
    invalid from its first missing sample and reports nothing whose window reaches it."""
    t = np.arange(9) * 0.5
    mode = np.array([1, 1, 1, 2, 2, 0, 0, 0, 0], float)
    z = np.zeros_like(t)
    s = {"ball." + k: z for k in ("N", "friction_ratio", "xP", "yP", "zP", "xC", "yC")}
    s.update({"ball.zC": z + 0.1, "ball.mode": mode, "ball.n_impacts": np.array([0, 0, 0, 0, 0, 0, 1, 1, 2.]),
              "ball.v_impact_max": np.array([0, 0, 0, 0, 0, 0, .5, .5, .7]), "ball.E_friction": t * 0.1,
              "ball.E_impact": z, "ball.t_first_slip": np.where(t >= 1.5, 1.2, np.nan),
              "ball.t_first_flight": np.where(t >= 2.5, 2.1, np.nan), "drive.psi": t * math.pi})
    rec = ind.Record(t, s, "ball", "drive", 0.3, {"start": 0.0, "stop": 4.0, "after": 1.0})
    out = ind.evaluate_hybrid(rec)
    assert out["rolling_fraction"] == pytest.approx(1.25 / 4, abs=1e-15)
    assert out["sliding_fraction"] == pytest.approx(1.0 / 4, abs=1e-15)
    assert out["flight_fraction"] == pytest.approx(1.75 / 4, abs=1e-15)
    assert (out["n_impacts"], out["v_impact_max"], out["t_first_slip"], out["t_first_flight"]) == (2, .7, 1.2, 2.1)
    assert out["E_friction_rev"] == pytest.approx(0.4 / 2.0)  # 0.4 J over 2 revolutions
    assert out["valid"] is True and out["t_invalid"] is None
    stopped = ind.evaluate_hybrid(rec, [ind_spec("early", "ball.zC", "max", (0.0, 1.0))], stopped_at=6)
    assert stopped["valid"] is False and stopped["t_invalid"] == 3.0
    assert all(stopped[k] is None for k in ind.HYBRID) and stopped["N_max"] is None
    assert stopped["early"] == pytest.approx(0.1)  # a window before the stop is still reported


def ind_spec(name, var, stat, window):
    from ballmill.sweep.spec import Indicator

    return Indicator(name, var, stat, window)


def test_contact_table_is_checked_and_kept_in_the_context():
    st = build("fast_start", grid={"drive.t0": [1.0]}, contact={"e_n": 0.8})
    assert st.model["kind"] == "hybrid-kernel" and st.model["method"] == "DOP853"
    assert st.context("", "hybrid-kernel")["contact"] == {"e_n": 0.8}
    assert "contact" not in build("fast_start", grid={"drive.t0": [1.0]}).context("", "crank-kernel")
    with pytest.raises(StudyError) as e:
        build("fast_start", grid={"drive.t0": [1.0]}, contact={"e_n": 1.5, "mu": 0.2},
              model={"method": "RK4", "kind": "crank-kernel"}, where="W")
    p = e.value.problems
    assert "W: model.kind: a study with a [contact] table runs on 'hybrid-kernel', got 'crank-kernel'" in p
    assert any(x.startswith("W: contact: unknown key(s) ['mu']") for x in p)
    assert any(x.startswith("W: model.method: the hybrid ball ([contact]) needs an adaptive method") for x in p)
    with pytest.raises(StudyError) as e:
        build("fast_start", grid={"drive.t0": [1.0]}, contact={"e_n": 1.5}, where="W")
    assert e.value.problems == ["W: contact: e_n must lie in [0, 1], got e_n = 1.5 1"]


@needs_kernel
def test_the_creeping_slides_threshold_is_a_contact_key(tmp_path):
    """[contact] creep_eps: checked as Contact checks it, and the points run with it: creep_eps = 0
    (the unreduced Coulomb model) on the fast start (t0 = 0.5 s, 1 s) gives the friction loss of
    simulate_hybrid's unreduced run, which the default creeping slide misses by 2.3e-6 J."""
    with pytest.raises(StudyError) as e:
        build("fast_start", grid={"drive.t0": [0.5]}, contact={"creep_eps": -1.0}, where="W")
    assert e.value.problems == ["W: contact: creep_eps must be non-negative and finite (0: no creeping slide), "
                                "got creep_eps = -1.0 m/s"]
    (row,) = _rows(tmp_path, {"drive.t0": [0.5]}, stop=1.0, contact={"creep_eps": 0.0})
    assert row["status"] == "ok" and "creep_eps = 0 m/s" in row["model"]
    ball, crank = Ball(m=M_PAPER), CrankStartup(t0=0.5)
    state = BallModel(ball).initial(0.0, 0.0, (0.0, 0.0, 0.0))
    turns = crank.angles(np.array([1.0]))[0][0] / (2 * math.pi)
    E = {ce: simulate_hybrid(ball, crank, 1.0, 0.01, Contact(creep_eps=ce), initial=state, method="DOP853",
                             tol=1e-8)["E_friction"][-1] for ce in (0.0, 1e-3)}
    assert row["E_friction_rev"] == pytest.approx(E[0.0] / turns, rel=1e-12)
    assert abs(E[0.0] - E[1e-3]) > 1e-6


def test_maps_draw_the_boundary_of_the_shockless_region(tmp_path, subplots_made):
    """On a 3 x 3 grid with impacts at the two points (t0 = 1, n0 = 60) and (t0 = 1, n0 = 80),
    every map carries the outline of those two cells inside the grid: the edges x = 1.5 (their
    right), y = 50 (below them), and no others (the grid's own border is not a boundary)."""
    from ballmill.sweep import plots

    study = build("fast_start", grid={"drive.t0": [1.0, 2.0, 3.0], "drive.n0": [40, 60, 80]}, contact={})
    hit = {(1.0, 60), (1.0, 80)}
    rows = [{"drive.t0": t0, "drive.n0": n0, "status": "ok", "valid": True, "N_max": t0 + n0,
             "n_impacts": 3.0 if (t0, n0) in hit else 0.0, "v_impact_max": 1.0 if (t0, n0) in hit else 0.0}
            for n0 in (40, 60, 80) for t0 in (1.0, 2.0, 3.0)]
    files = plots.write(study, rows, tmp_path)
    assert [f.name for f in files] == ["map_N_max.png", "map_n_impacts.png", "map_v_impact_max.png"]
    ax = subplots_made[0].axes[0]
    (lines,) = [c for c in ax.collections if c.get_label() == "boundary of the shockless region"]
    segs = sorted(tuple(map(tuple, np.round(s, 9))) for s in lines.get_segments())
    assert segs == [((0.5, 50.0), (1.5, 50.0)), ((1.5, 50.0), (1.5, 70.0)), ((1.5, 70.0), (1.5, 90.0))]
    assert "where impacts begin" in ax.get_title()
    assert subplots_made[0].axes[1].get_ylabel().endswith("v_impact_max [m/s]")


@needs_kernel
def test_the_first_slip_is_at_once_exactly_where_the_start_asks_for_more_than_mu(tmp_path):
    """From rest at the bottom, the quadratic law's psi''(0) = 2 w0 / t0 asks for the friction
    ratio (2/7) l psi''(0) / g: above mu = 0.3 the ball slips at t = 0 (t0 = 0.55 s, n0 = 60:
    0.326), below it later or never (t0 = 0.7 s: 0.256). The shockless map's 400 points obey
    this without exception (329 slip at once)."""
    rows = _rows(tmp_path, {"drive.t0": [0.55, 0.7]}, stop=1.0)
    w0 = 2 * math.pi * 60 / 60
    for row in rows:
        asked = 2 / 7 * 0.5 * 2 * w0 / row["drive.t0"] / 9.81
        assert (row["t_first_slip"] == 0.0) == (asked > 0.3), (row["drive.t0"], asked, row["t_first_slip"])
    assert rows[1]["t_first_slip"] is None or rows[1]["t_first_slip"] > 0.0


def test_the_shockless_map_study_file():
    from ballmill.sweep import load

    st = load("t0_n0_hybrid")
    assert len(st.points()) == 400 and st.contact == {"e_n": 0.5, "v_rest": 0.01}
    assert st.model["kind"] == "hybrid-kernel" and st.model["method"] == "DOP853"
