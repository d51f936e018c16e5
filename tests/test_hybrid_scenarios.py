"""A scenario with the hybrid ball (BallInShell contact_model = 2: it slides, flies and strikes the
shell) as a user meets it: its time plots shade the sliding and the flight spans and tick the
impacts, its shell drawing colours the path by mode and marks the impacts, its summary has the
hybrid indicators; a scenario with contact_model = 1 gets none of it.

The report's tests run on a result table built from the library's hybrid ball
(`simulate_hybrid`, the paper's chamber on a crank started in t0 = 0.1 s to 60 1/min: it
slides at once, leaves the wall at 0.67 s and strikes the shell 7 times), whose events say
independently when each mode began and ended and when each impact happened; the figures are
read back as report.py made them (the ``subplots_made`` fixture).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ballmill.physics.drives.crank import CrankStartup
from ballmill.physics.hybrid import FLIGHT, ROLLING, SLIDING, Contact, simulate_hybrid
from ballmill.physics.params import Ball
from ballmill.scenario import report
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import CONTACT, Instance, Scenario

DT, STOP = 0.002, 2.0
DT_MOTOR = 0.001  # induction_start's communication step [s]
BALL = Ball(r=0.025, R=0.25, m=0.5105088062083415, mu=0.3)
CRANK = CrankStartup(l=0.5, n0=60.0, t0=0.1)
SLIDES, FLIES = "ball slides on the wall (mode 2)", "ball in flight (mode 0)"
PLOTS = [{"y": ["ball.N"], "file": "N.png"}, {"kind": "slip_margin", "ball": "ball", "file": "slip.png"},
         {"x": "ball.xP", "y": ["ball.yP"], "file": "ring.png"}, {"kind": "shell", "ball": "ball", "file": "shell.png"}]


@pytest.fixture(scope="module")
def traj():
    tr = simulate_hybrid(BALL, CRANK, STOP, DT, Contact())
    assert tr.success and len(tr.of_kind("impact")) == 7 and tr.t_first_flight > 0.6
    return tr


@pytest.fixture(scope="module")
def drawn(traj, tmp_path_factory):
    """write_all of the hybrid table: (its summary, the figures it made, in PLOTS' order)."""
    from ballmill.plotting import figures

    kept, subplots = [], figures.subplots

    def recording(*a, **kw):
        fig, ax = subplots(*a, **kw)
        kept.append(fig)
        return fig, ax
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(figures, "subplots", recording)
        summary = report.write_all(table(traj), {}, tmp_path_factory.mktemp("hybrid"))
    return summary, kept


def table(tr, contact=2, never=None) -> RunResult:
    """The run as `ballmill run` records it: the ball's outputs (P = C + r n, in the chamber's
    axes too: the chamber translates), the drive's crank angle; ``never``: the FMUs' "not yet"
    (1e300) in place of the library's NaN in t_first_slip and t_first_flight."""
    o, t = tr.out, tr.t
    cols = {"drive.psi": CRANK.angles(t)[0]}
    for name in ("mode", "n_impacts", "v_impact_max", "E_friction", "E_impact", "t_first_slip", "t_first_flight",
                 "N", "Ft"):
        cols[f"ball.{name}"] = np.where(np.isnan(o[name]), never, o[name]) if never else o[name]
    for ax in "xyz":
        cols[f"ball.{ax}P"] = cols[f"ball.{ax}P_ch"] = o[ax + "C"] + BALL.r * o["n" + ax]
    N = o["N"]
    cols["ball.friction_ratio"] = np.where(N > 0, o["Ft"] / np.where(N > 0, N, 1.0), 1e300)
    cols["ball.valid"] = np.ones_like(t)
    params = {"r": BALL.r, "R": BALL.R, "m": BALL.m, "mu": BALL.mu, CONTACT: contact}
    sc = Scenario(path=Path("hybrid.toml"), name="hybrid", description="", start=0.0, stop=STOP, step=DT,
                  instances={"ball": Instance("ball", fmu="BallInShell", parameters=params),
                             "drive": Instance("drive", fmu="MotorStartup", parameters={"t0": CRANK.t0})},
                  connections=[("drive", "x1O", "ball", "x1O")], record=[], plots=PLOTS,
                  summary={"ball": "ball", "after": CRANK.t0})
    return RunResult(scenario=sc, columns=["time", *cols], data=np.column_stack([t, *cols.values()]),
                     success=True, message="completed")


def mode_intervals(tr, mode):
    """[from, to] of each stretch of ``mode`` by the library's events (exact switch times)."""
    out, start, current = [], tr.t[0], int(tr["mode"][0])
    for e in tr.events:
        if e.mode_after == current:
            continue
        if current == mode:
            out.append((start, e.t))
        start, current = e.t, e.mode_after
    if current == mode:
        out.append((start, tr.t[-1]))
    return out


def shaded(ax, label):
    """(from, to) of each rectangle of the shaded collection labelled ``label`` (x in seconds)."""
    col = [c for c in ax.collections if c.get_label() == label]
    if not col:
        return []
    (col,) = col
    return [(p.vertices[:, 0].min(), p.vertices[:, 0].max()) for p in col.get_paths()]


def ticks(ax):
    """The impact ticks: their times [s] and their label."""
    col = [c for c in ax.collections if c.get_label().startswith("impacts on the shell")]
    if not col:
        return np.array([]), None
    (col,) = col
    return np.array([seg[0][0] for seg in col.get_segments()]), col.get_label()


def legend(ax):
    leg = ax.get_legend()
    return [t.get_text() for t in leg.get_texts()] if leg is not None else []


def test_time_plots_shade_slides_and_flights_and_tick_the_impacts(traj, drawn):
    """On the plot of N and on the slip margin: every stretch of sliding and of flight the events
    give, longer than a communication step, is shaded in its own colour with its ends within half
    a step of the event times (each instant takes the mode of its nearest sample) and no shaded
    span is without such a stretch; the shaded lengths are the summary's fractions times the run;
    one impact tick at the first sample after each impact event (7 impacts, 6 steps: two fall in
    one step); all three in the legend. The slip margin draws no 'rolling first fails' line."""
    summary, figs = drawn
    n_ax, slip_ax = figs[0].axes[0], figs[1].axes[0]
    impacts = np.array([e.t for e in traj.of_kind("impact")])
    after = np.unique(traj.t[np.searchsorted(traj.t, impacts - 1e-12)])
    for ax in (n_ax, slip_ax):
        for label, mode, fraction in ((SLIDES, SLIDING, "sliding_fraction"), (FLIES, FLIGHT, "flight_fraction")):
            spans, truth = shaded(ax, label), mode_intervals(traj, mode)
            assert spans and sum(b - a for a, b in spans) == pytest.approx(summary["hybrid"][fraction]["value"] * STOP,
                                                                           abs=1e-12)
            for a, b in spans:  # each drawn span is an event stretch, to half a step
                assert any(abs(a - ta) <= DT / 2 + 1e-12 and abs(b - tb) <= DT / 2 + 1e-12 for ta, tb in truth)
            assert len(spans) >= sum(tb - ta > DT for ta, tb in truth)
        at, text = ticks(ax)
        assert np.array_equal(np.sort(at), after) and len(at) == 6
        assert text == "impacts on the shell: 7, ticked at the end of each step with any (6 steps)"
        assert {SLIDES, FLIES, text} <= set(legend(ax))
    assert not [line for line in slip_ax.get_lines() if "first fails" in line.get_label()]
    # the path plot (x = xP) has no time axis: no marks
    assert not shaded(figs[2].axes[0], SLIDES) and ticks(figs[2].axes[0])[1] is None


def test_the_shell_drawing_colours_the_path_by_mode_and_marks_the_impacts(traj, drawn):
    """The shell drawing: the samples of each mode drawn in the mode's colour (rolling, sliding,
    and in flight the nearest wall point, faint), together every sample once; one hollow red
    marker per step that ends with impacts, at the contact point of that step's end sample."""
    axes = drawn[1][3].axes[:2]
    mode = traj["mode"]
    points = {}
    for ax in axes:
        for col in ax.collections:
            colour = tuple(np.round(col.get_facecolor()[0][:3], 3))
            points[colour] = points.get(colour, 0) + len(col.get_offsets())
    from matplotlib.colors import to_rgb
    count = {m: int((mode == m).sum()) for m in (ROLLING, SLIDING, FLIGHT)}
    assert points == {tuple(np.round(to_rgb(c), 3)): count[m] for m, c in
                     ((ROLLING, "tab:blue"), (SLIDING, "tab:orange"), (FLIGHT, "tab:purple"))}
    markers = [line for ax in axes for line in ax.get_lines() if line.get_marker() == "o" and len(line.get_xdata())]
    assert sum(len(line.get_xdata()) for line in markers) == 6
    assert all(line.get_markeredgecolor() == "tab:red" and line.get_markerfacecolor() == "none" for line in markers)
    (fig_legend,) = drawn[1][3].legends  # one for both hemispheres
    assert [t.get_text() for t in fig_legend.get_texts()] == [
        "rolling", "sliding", "in flight: the wall point nearest the ball (no contact), faint",
        "7 impacts: the point at the end of each step with any (6 steps)"]


def test_the_summary_has_the_hybrid_indicators(traj, drawn):
    """summary.json's `hybrid`: the run's impacts, losses and first times as the library counted
    them, the losses per crank revolution of the drive's psi, the fractions adding up to 1; an
    FMU's "not yet" (1e300) for t_first_slip / t_first_flight reads as None, not as a time;
    the mill's indicators are taken over the whole run (the hybrid stays valid)."""
    h = drawn[0]["hybrid"]
    v = {k: x["value"] for k, x in h.items()}
    turns = CRANK.angles(np.array([STOP]))[0][0] / (2 * np.pi)
    assert v["n_impacts"] == 7 and v["v_impact_max"] == traj["v_impact_max"][-1] > 0.5
    assert v["E_friction"] == traj["E_friction"][-1] > 0 and v["E_impact"] == traj["E_impact"][-1] > 0
    assert v["E_friction_rev"] == pytest.approx(v["E_friction"] / turns, rel=1e-12)
    assert v["E_impact_rev"] == pytest.approx(v["E_impact"] / turns, rel=1e-12)
    assert (v["t_first_slip"], v["t_first_flight"]) == (0.0, traj.t_first_flight)
    assert v["rolling_fraction"] + v["sliding_fraction"] + v["flight_fraction"] == pytest.approx(1.0, abs=1e-12)
    assert h["E_impact"]["unit"] == "J" and h["v_impact_max"]["unit"] == "m/s"
    # a ball that never flies, through the FMU's convention
    rolling = simulate_hybrid(BALL, CrankStartup(l=0.5, n0=60.0, t0=0.5), 0.5, DT, Contact())
    assert rolling.t_first_flight is None
    s = report.summarise(table(rolling, never=1e300), {})
    assert s["hybrid"]["t_first_flight"]["value"] is None and s["hybrid"]["n_impacts"]["value"] == 0


def test_a_ball_with_contact_1_gets_no_marks_and_no_hybrid_summary(tmp_path, traj, subplots_made):
    """The same table with contact_model = 1 (the rolling model's ball): no shaded modes, no ticks, no
    mode colours on the shell, no `hybrid` in the summary."""
    summary = report.write_all(table(traj, contact=1), {}, tmp_path)
    assert "hybrid" not in summary and "note" not in summary["validity"]
    for fig in subplots_made[:2]:
        ax = fig.axes[0]
        assert not shaded(ax, SLIDES) and not shaded(ax, FLIES) and ticks(ax)[1] is None
    assert not subplots_made[3].legends and not any("flight" in text or "impacts" in text
                                                    for ax in subplots_made[3].axes for text in legend(ax))


# -- the shipped hybrid scenarios through `ballmill run` ---------------------------------------
# Flavour-neutral: each runs on the native FMU when its BallInShell has the hybrid ball, else on
# the pythonfmu one; skipped (saying why) when neither has the parameter contact_model.

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


@pytest.fixture(scope="module")
def hybrid_fmus(fmu_build_dir):
    """(build folder, flavour) of a BallInShell FMU with the parameter contact_model."""
    from ballmill.fmi.build import fmu_path
    from ballmill.scenario import fmucache

    for flavour in ("native", "pythonfmu"):
        md = fmucache.model_description(fmu_path("BallInShell", fmu_build_dir, flavour))
        if any(v.name == CONTACT for v in md.modelVariables):
            return fmu_build_dir, flavour
    pytest.skip(f"the BallInShell FMU (either flavour) has no parameter {CONTACT}: the hybrid ball is not in it")


def run_copy(hybrid_fmus, tmp_path, name, stop, *sets):
    """`ballmill run` of scenarios/NAME.toml cut at ``stop`` [s]: (exit status, out folder, summary)."""
    import json
    import re

    from ballmill import cli

    text, n = re.subn(r"(?m)^stop\s*=\s*[^#\n]+", f"stop = {stop!r} ", (SCENARIOS / f"{name}.toml").read_text())
    assert n == 1
    tmp_path.mkdir(parents=True, exist_ok=True)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    build, flavour = hybrid_fmus
    out = tmp_path / "out"
    args = ["run", str(path), "--out", str(out), "--build-dir", str(build), "--flavour", flavour, "--quiet"]
    for s in sets:
        args += ["--set", s]
    status = cli.main(args)
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").is_file() else None
    return status, out, summary


def hybrid_values(summary):
    return {k: v["value"] for k, v in summary["hybrid"].items()}


def test_a_hybrid_ball_must_record_what_its_marks_and_summary_need(tmp_path, fmu_build_dir, capsys):
    """induction_start records a list of the ball's outputs without mode and the bookkeeping: with
    --set ball.contact_model=2 the run is refused before it starts (exit 2), naming every missing
    column; with contact_model = 1 the same file runs."""
    from ballmill import cli
    from ballmill.fmi.build import fmu_path
    from ballmill.scenario import fmucache

    md = fmucache.model_description(fmu_path("BallInShell", fmu_build_dir, "native"))
    if not any(v.name == CONTACT for v in md.modelVariables):
        pytest.skip(f"the BallInShell FMU has no parameter {CONTACT}")
    args = ["run", "induction_start", "--out", str(tmp_path), "--build-dir", str(fmu_build_dir), "--quiet",
            "--set", "ball.contact_model=2"]
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert ("record.variables: ball has contact_model = 2 (the hybrid ball): its plots' marks and the summary need "
            "ball.mode, ball.n_impacts, ball.v_impact_max, ball.E_friction, ball.E_impact, ball.t_first_slip, "
            "ball.t_first_flight recorded") in err


def test_violent_start_slides_at_once_and_rolls_again_when_the_library_says(hybrid_fmus, tmp_path, subplots_made):
    """violent_start (t0 = 0.5 s) over 1 s: exit 0, valid throughout, sliding from t = 0; every
    sliding span shaded on its plots is one of the library's (`simulate_hybrid` on the same crank
    law), its ends within half a step of the library's switch times (each instant is drawn in the
    mode of its nearest sample; the FMU's switches are the library's to well within a step:
    drawn 0-0.073, 0.269-0.437, 0.801-1 s against 0-0.07305, 0.26869-0.43684, 0.80087-1 s);
    friction's energy as the library's within 1e-3 (measured 4.5e-4: the FMU's input
    reconstruction has one sample over its first step, while the ball already slides)."""
    status, out, summary = run_copy(hybrid_fmus, tmp_path, "violent_start", 1.0)
    assert status == 0 and summary["left_validity"] is False
    v = hybrid_values(summary)
    tr = simulate_hybrid(BALL, CrankStartup(l=0.5, n0=60.0, t0=0.5), 1.0, DT, Contact())
    truth = mode_intervals(tr, SLIDING)
    assert v["t_first_slip"] == 0.0 and v["t_first_flight"] is None and v["n_impacts"] == 0
    assert v["E_friction"] == pytest.approx(tr["E_friction"][-1], rel=1e-3)
    ax = subplots_made[1].axes[0]  # N.png
    spans = shaded(ax, SLIDES)
    assert len(spans) == len(truth) == 3 and spans[0][0] == 0.0
    for (a, b), (ta, tb) in zip(spans, truth):
        assert abs(a - ta) <= DT / 2 + 1e-9 and abs(b - tb) <= DT / 2 + 1e-9
    assert SLIDES in legend(ax) and not shaded(ax, FLIES)


def test_induction_start_hybrid_stays_valid_where_the_rolling_ball_fails(hybrid_fmus, tmp_path, subplots_made):
    """induction_start_hybrid over 0.03 s: the direct-on-line start makes the ball slide within the
    10th millisecond, where induction_start's rolling ball stops being valid (t_invalid = 0.01 s,
    exit 3 over 0.3 s: tests/test_report_figures.py); here the run exits 0, valid
    throughout, and every time plot shades the slide from half a step before the first
    communication point that samples it. Under the held mean torque (M_reaction_mean, M_input = 1)
    the first slip, at 0.00992 s, sticks again within its step and the ball slides for good
    within the next one: the shading starts at a half step (0.0105 s), after the first slip and
    less than a step and a half after it."""
    status, out, summary = run_copy(hybrid_fmus, tmp_path, "induction_start_hybrid", 0.03)
    assert status == 0 and summary["left_validity"] is False
    v = hybrid_values(summary)
    assert 0.009 < v["t_first_slip"] <= 0.01 and v["sliding_fraction"] > 0
    timed = [fig.axes[0] for fig in subplots_made if fig.axes[0].get_xlabel() == "time [s]"]
    assert len(timed) == 6
    for ax in timed:
        start = shaded(ax, SLIDES)[0][0]
        assert v["t_first_slip"] < start < v["t_first_slip"] + 1.5 * DT_MOTOR
        assert (start / DT_MOTOR - 0.5) == pytest.approx(round(start / DT_MOTOR - 0.5), abs=1e-6)
        assert SLIDES in legend(ax)


def test_fig1_machine_hybrid_runs_as_the_library(hybrid_fmus, tmp_path, subplots_made):
    """fig1_machine_hybrid over 3 s: exit 0 and valid where fig1_machine's rolling ball fails at
    2.508 s; its first slip, first flight, its two impacts and the losses as the library's hybrid
    ball on the same machine (simulate_hybrid with Fig1Machine; measured: slip equal to 1e-13 s,
    flight 2.3e-6 s apart, E_friction 1.8e-4 and E_impact 1.9e-3 relative, the two impacts being
    soft re-landings at 0.023 m/s whose loss goes with the square of that speed); the two impacts
    marked on the shell drawing and ticked on the time plots."""
    from ballmill.physics.turning.motions import ConstantSpeed, Fig1Machine

    status, out, summary = run_copy(hybrid_fmus, tmp_path, "fig1_machine_hybrid", 3.0)
    assert status == 0 and summary["left_validity"] is False
    v = hybrid_values(summary)
    machine = Fig1Machine(frame=ConstantSpeed(0.5), crank=CrankStartup(l=0.5, n0=60.0, t0=2.5))
    tr = simulate_hybrid(BALL, machine, 3.0, DT, Contact())
    assert v["t_first_slip"] == pytest.approx(tr.t_first_slip, abs=1e-6)
    assert v["t_first_flight"] == pytest.approx(tr.t_first_flight, abs=1e-5)
    assert v["n_impacts"] == len(tr.of_kind("impact")) == 2
    assert v["E_friction"] == pytest.approx(tr["E_friction"][-1], rel=1e-3)
    assert v["E_impact"] == pytest.approx(tr["E_impact"][-1], rel=1e-2)
    shell_fig = subplots_made[0]
    marks = [line for ax in shell_fig.axes[:2] for line in ax.get_lines() if line.get_marker() == "o"]
    assert sum(len(line.get_xdata()) for line in marks) == 2
    n_ax = subplots_made[1].axes[0]
    assert len(ticks(n_ax)[0]) == 2 and shaded(n_ax, FLIES)[0][0] == pytest.approx(tr.t_first_flight, abs=DT)


def test_absorber_hybrid_slides_where_the_rolling_ball_would_lose_contact(hybrid_fmus, tmp_path):
    """absorber_hybrid over 36 s (the absorber_frf case at 5 N, 0.74 Hz, from rest): the ball that
    slides starts to slide at 23.58 s, with the rolling ball's latch at that step's end
    (--set ball.contact_model=1: exit 3, slip at 23.585 s), and keeps the wall past 33.4 s, where
    the rolling ball (glued to the wall after its slip) loses contact: exit 0, valid, no flight."""
    status, out, summary = run_copy(hybrid_fmus, tmp_path / "hybrid", "absorber_hybrid", 36.0)
    assert status == 0 and summary["left_validity"] is False
    v = hybrid_values(summary)
    assert 23.58 < v["t_first_slip"] <= 23.585 and v["t_first_flight"] is None and v["n_impacts"] == 0
    assert 0.1 < v["sliding_fraction"] < 0.5 and v["E_friction"] > 1.0
    status, out, rolling = run_copy(hybrid_fmus, tmp_path / "rolling", "absorber_hybrid", 36.0, "ball.contact_model=1")
    assert status == 3 and rolling["t_invalid_s"] == pytest.approx(23.585, abs=1e-9)
    assert rolling["invalid_reason"] == "slip"
    assert rolling["validity"]["contact"]["first_failure_interpolated_s"] == pytest.approx(33.40, abs=0.01)
