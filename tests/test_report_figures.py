"""The figures of `ballmill run` and `ballmill sweep` as a user meets them: drawn from the run's
actual parameters (a --set reaches the banner, every title and the t0 marker), the span after
the ball model's validity ended shaded and labelled on every time plot, the ring plot's
start-up and steady parts in two colours with the summary's radii drawn, labels and legends in
words with units from the FMUs' declaration, and a placeholder that names no parameter refused.

The scenario runs go through the command (`cli.main`, native FMUs of the session's build) on
short copies of the scenario files; the figures are read back as report.py made them
(plt.subplots recorded, the figures kept after they are saved and closed).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from ballmill import cli
from ballmill.scenario import spec

SCENARIOS = Path(spec.SCENARIO_DIR)
T0_LABEL = "t0 = {} s, start-up time to reach n0"  # MotorStartup's t0, from its declaration


def copy_scenario(tmp_path, name, stop, edit=()):
    """scenarios/NAME.toml with experiment.stop replaced (and (old, new) text edits)."""
    text = (SCENARIOS / f"{name}.toml").read_text()
    text, n = re.subn(r"(?m)^stop\s*=\s*[^#\n]+", f"stop = {stop!r} ", text)
    assert n == 1
    for old, new in edit:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def run(build_dir, scenario, out, *sets):
    """`ballmill run` in process, not quiet: the banner is read from its stderr."""
    args = ["run", str(scenario), "--out", str(out), "--build-dir", str(build_dir)]
    for s in sets:
        args += ["--set", s]
    return cli.main(args)


def legend(ax):
    leg = ax.get_legend()
    return [t.get_text() for t in leg.get_texts()] if leg is not None else []


def spans(ax):
    """(x from, x to, label) of the shaded spans (axvspan) of a plot."""
    return [(p.get_x(), p.get_x() + p.get_width(), p.get_label()) for p in ax.patches]


def same(a, b):
    """The same samples (results.csv keeps 12 significant digits)."""
    return len(a) == len(b) and np.allclose(a, b, rtol=1e-11, atol=1e-15)


def column(out, name):
    with open(out / "results.csv") as fh:
        header = fh.readline().strip().split(",")
    return np.loadtxt(out / "results.csv", delimiter=",", skiprows=1)[:, header.index(name)]


def assert_laid_out(fig):
    """A saved one-axes figure whose every text lies inside the figure's canvas and off the
    axes' data area, each where a reader looks for it: the title above the axes (and above the y
    axis' offset text), the y tick labels left of the axes and the y label left of them, the x
    tick labels below the axes, the x label below them and the legend below the x label; and
    everything drawn (fig.get_tightbbox) inside the figure."""
    (ax,) = fig.axes
    renderer = fig.canvas.get_renderer()
    W, H = fig.bbox.width, fig.bbox.height
    box = ax.bbox

    def ticklabels(axis, i):  # the labels of the ticks inside the view: the drawn ones
        lo, hi = sorted(axis.get_view_interval())
        return [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                if t.get_text() and lo <= t.get_position()[i] <= hi]

    xt, yt = ticklabels(ax.xaxis, 0), ticklabels(ax.yaxis, 1)
    assert xt and yt
    texts = {"title": ax.title, "x label": ax.xaxis.label, "y label": ax.yaxis.label,
             "x offset": ax.xaxis.offsetText, "y offset": ax.yaxis.offsetText}
    ext = {k: t.get_window_extent(renderer) for k, t in texts.items() if t.get_text()}
    if ax.get_legend() is not None:
        ext["legend"] = ax.get_legend().get_window_extent(renderer)
    for name, b in [*ext.items(), *(("x tick label", b) for b in xt), *(("y tick label", b) for b in yt)]:
        assert 0 <= b.x0 and b.x1 <= W and 0 <= b.y0 and b.y1 <= H, (name, b, W, H)
    if "title" in ext:
        assert ext["title"].y0 >= max(box.y1, ext["y offset"].y1 if "y offset" in ext else 0), ext
    assert max(b.x1 for b in yt) <= box.x0 and ext["y label"].x1 <= min(b.x0 for b in yt)
    assert max(b.y1 for b in xt) <= box.y0 and ext["x label"].y1 <= min(b.y0 for b in xt)
    if "legend" in ext:
        assert ext["legend"].y1 <= ext["x label"].y0
    drawn = fig.get_tightbbox()
    w, h = fig.get_size_inches()
    assert drawn.x0 >= 0 and drawn.y0 >= 0 and drawn.x1 <= w and drawn.y1 <= h, (drawn, w, h)


def test_a_set_reaches_the_banner_the_titles_and_the_t0_marker(tmp_path, fmu_build_dir, subplots_made, capsys):
    """slow_start (t0 = 30 s in its file) run with --set drive.t0=2 over 3 s: the banner, the
    summary's description and every title say t0 = 2 s, the dashed t0 marker stands at 2 s with
    its label; the torque legend and the axes in words with units; the ring plot's start-up
    (t < 2 s) and steady part (t >= 2 s) in two colours, with the summary's inner and outer
    radii as circles named in the legend."""
    out = tmp_path / "out"
    assert run(fmu_build_dir, copy_scenario(tmp_path, "slow_start", 3.0), out, "drive.t0=2") == 0
    err = capsys.readouterr().err
    banner = next(line for line in err.splitlines() if line.startswith("running "))
    assert "t0 = 2 s" in banner and "30" not in banner
    summary = json.loads((out / "summary.json").read_text())
    assert "t0 = 2 s" in summary["description"] and summary["after_s"] == 2.0
    zP, ring, N, torque = (fig.axes[0] for fig in subplots_made)
    for ax in (zP, ring, N, torque):
        assert "t0 = 2 s" in ax.get_title() and "30" not in ax.get_title()
    for ax in (zP, N, torque):
        marker, = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert tuple(marker.get_xdata()) == (2.0, 2.0) and marker.get_label() == T0_LABEL.format(2)
        assert ax.get_xlabel() == "time [s]" and spans(ax) == []  # the model stayed valid
    assert legend(torque) == ["Torque of the ball's force about the vertical axis z1 through O1, M_reaction [N m]",
                              "Torque the drive must supply, T_drive [N m]", T0_LABEL.format(2)]
    assert torque.get_ylabel() == "torque [N m]"
    assert N.get_ylabel() == "Normal force of the chamber on the ball, N [N]"
    assert zP.get_ylabel() == "Contact point P, height above the chamber's lowest point O,\nzP [m]"
    # the ring: two colours split at t0, the summary's radii as circles
    assert ring.get_xlabel() == "Contact point P, x in the chamber frame Oxyz, xP [m]"
    t, xP, yP = column(out, "time"), column(out, "ball.xP"), column(out, "ball.yP")
    start, steady, inner, outer = ring.get_lines()
    assert start.get_color() != steady.get_color()
    assert same(start.get_xdata(), xP[t < 2.0]) and same(steady.get_ydata(), yP[t >= 2.0])
    r_in, r_out = summary["ring"]["inner_radius_m"], summary["ring"]["outer_radius_m"]
    assert np.allclose(np.hypot(inner.get_xdata(), inner.get_ydata()), r_in, rtol=1e-12)
    assert np.allclose(np.hypot(outer.get_xdata(), outer.get_ydata()), r_out, rtol=1e-12)
    assert r_in == pytest.approx(np.hypot(xP, yP)[t >= 2.0].min(), rel=1e-12)
    assert legend(ring) == ["start-up, t < t0 = 2 s", "after the start-up, t \u2265 t0 = 2 s",
                            f"ring's inner radius {r_in:.4f} m (the summary's, t \u2265 t0 = 2 s)",
                            f"ring's outer radius {r_out:.4f} m (the summary's, t \u2265 t0 = 2 s)"]
    for fig in subplots_made:
        assert_laid_out(fig)


def test_the_invalid_span_is_shaded_and_labelled_on_every_time_plot(tmp_path, fmu_build_dir, subplots_made):
    """induction_start: the ball slips at 0.01 s (BallInShell's t_invalid) and the run goes on to
    0.3 s. Every plot against time shades [t_invalid, 0.3 s] with the legend entry "ball model not
    valid (slip at 0.01 s)"; the ring plot draws the rows from there on in grey."""
    out = tmp_path / "out"
    assert run(fmu_build_dir, copy_scenario(tmp_path, "induction_start", 0.3), out) == 3
    summary = json.loads((out / "summary.json").read_text())
    t_inv = summary["t_invalid_s"]
    assert t_inv == pytest.approx(0.01, abs=1e-12) and summary["invalid_reason"] == "slip"
    label = "ball model not valid (slip at 0.01 s)"
    axes = [fig.axes[0] for fig in subplots_made]
    assert [ax.get_title() for ax in axes][:2] == ["Crank speed: induction motor vs the kinematic law (t0 = 2.5 s)",
                                                   "Air-gap torque of the motor (at the motor shaft), start_mode = 1"]
    *timed, ring = axes
    assert len(timed) == 5
    for ax in timed:
        assert ax.get_xlabel() == "time [s]"
        (x0, x1, text), = spans(ax)
        assert (x0, x1, text) == (t_inv, pytest.approx(0.3, abs=1e-12), label)
        assert label in legend(ax)
    # the crank speeds of motor and law, told apart by instance, in words with units
    assert legend(timed[0])[:2] == ["Crank angular speed, psi_dot of motor [rad/s]",
                                    "Crank angular speed, psi_dot of law [rad/s]"]
    xP = column(out, "ball.xP")
    first_bad = int(np.flatnonzero(column(out, "ball.valid") < 0.5)[0])
    valid_part, grey = ring.get_lines()
    assert same(valid_part.get_xdata(), xP[:first_bad])
    assert same(grey.get_xdata(), xP[first_bad:]) and grey.get_color() == "0.7"
    assert grey.get_label() == label + ", not physical"
    for fig in subplots_made:  # the ring's limits follow its equal aspect: a tick label at its right end
        assert_laid_out(fig)


def test_long_texts_small_values_and_many_entries_stay_inside_the_figure(tmp_path, subplots_made):
    """Series of micrometres (tick labels with a "1e-6" offset text above the y axis), labels of
    two and three lines, a title of two lines, a legend of six entries under the x label, and an
    x-y plot of equal aspect whose limits follow its box: every text inside the PNG and where it
    belongs (assert_laid_out)."""
    from ballmill.scenario import report
    from ballmill.scenario.runner import RunResult
    from ballmill.scenario.spec import Instance, Scenario

    names = [f"ground.a{i}" for i in range(6)]
    plots = [{"y": names, "file": "many.png", "title": "A title over two lines,\nthe second one longer than the first",
              "ylabel": "a label of three lines:\nthe acceleration of the ground\nin micrometres [m/s2]",
              "xlabel": "time since the start of the run,\nin seconds [s]",
              "legend": [f"the ground's acceleration number {i}, an entry of the legend [m/s2]" for i in range(6)]},
             {"x": "ground.a0", "y": ["ground.a1"], "aspect": "equal", "file": "path.png",
              "title": "Two of the accelerations against each other, of equal aspect"}]
    sc = Scenario(path=Path("s.toml"), name="s", description="", start=0.0, stop=2.0, step=0.01,
                  instances={"ground": Instance("ground", table=Path("g.csv"))}, connections=[], record=[],
                  plots=plots, summary={})
    t = np.linspace(0.0, 2.0, 201)
    data = np.column_stack([t] + [1e-6 * (1.0 + np.sin(3.0 * t + i)) for i in range(6)])
    res = RunResult(scenario=sc, columns=["time", *names], data=data, success=True, message="")
    assert [p.name for p in report.plot(res, tmp_path)] == ["many.png", "path.png"]
    many, path = subplots_made
    assert many.axes[0].yaxis.offsetText.get_text() == "1e\u22126" and len(legend(many.axes[0])) == 6
    for fig in (many, path):
        assert_laid_out(fig)


def test_a_placeholder_or_vline_that_names_no_parameter_is_refused(tmp_path, fmu_build_dir, capsys):
    """A title placeholder, a description placeholder and a vline that name no parameter (or no
    time): exit status 2 before anything runs, each problem named with its key."""
    scenario = copy_scenario(tmp_path, "fast_start", 1.0, edit=[
        ('description = "Fast start-up', 'description = "{nosuch.t0} Fast start-up'),
        ('title = "Height of the contact point (paper Fig. 4), t0 = {drive.t0} s"',
         'title = "Height of the contact point, t0 = {drive.t00} s, n0 = {drive.n0:.1f} 1/min"'),
        ('vlines = ["drive.t0"]\nfile = "N.png"', 'vlines = ["drive.n0", 1.5]\nfile = "N.png"'),
        ('file = "torque.png"', 'file = "torque.png"\nlegend = ["only one {drive.l0}"]'),
    ])
    out = tmp_path / "out"
    assert run(fmu_build_dir, scenario, out) == 2
    err = capsys.readouterr().err
    where = scenario.as_posix()
    assert f"{where}: description: unknown placeholder {{nosuch.t0}}: no instance 'nosuch'" in err
    assert (f"{where}: plots[0].title: unknown placeholder {{drive.t00}}: MotorStartup 'drive' has no "
            f"parameter 't00' (parameters: l, n0, t0, ") in err
    assert "{drive.n0:.1f}" not in err  # a known placeholder with a format is fine
    assert f"{where}: plots[2].vlines[0]: drive.n0 is not a time (unit '1/min', expected 's')" in err
    assert "vlines[1]" not in err and not out.exists()
    assert f"{where}: plots[3].legend: expected one text per variable of y (2), got ['only one {{drive.l0}}']" in err


def test_a_placeholder_is_filled_with_its_format(tmp_path, fmu_build_dir):
    """{drive.n0:.1f} in a title: the run's value (a --set's) in that format, the model's start
    value for a parameter the scenario does not set (m_platform = 0); a legend's texts likewise."""
    from ballmill.scenario import runner
    scenario = copy_scenario(tmp_path, "fast_start", 1.0, edit=[
        ('title = "Height of the contact point (paper Fig. 4), t0 = {drive.t0} s"',
         'title = "n0 = {drive.n0:.1f} 1/min, m_platform = {drive.m_platform} kg"'),
        ('file = "torque.png"', 'file = "torque.png"\nlegend = ["ball, l = {drive.l} m", "drive"]')])
    sc, _, _ = runner.prepare(str(scenario), ["drive.n0=45"], fmu_build_dir, log=lambda m: None)
    assert sc.plots[0]["title"] == "n0 = 45.0 1/min, m_platform = 0 kg"
    assert sc.plots[3]["legend"] == ["ball, l = 0.5 m", "drive"]


def test_sweep_axes_and_colour_bars_in_words_with_units(tmp_path, subplots_made):
    """The heat map of a two-parameter grid: both axes the swept parameters' declarations
    (MotorStartup's t0 [s], n0 [1/min]), the colour bar the indicator's description and unit."""
    from ballmill.sweep import plots
    from ballmill.sweep.spec import build

    study = build("fast_start", grid={"drive.t0": [1.0, 2.0], "drive.n0": [60, 80]})
    rows = [{"drive.t0": t0, "drive.n0": n0, "status": "ok", "valid": True, "N_range_after": t0 * n0}
            for n0 in (60, 80) for t0 in (1.0, 2.0)]
    files = plots.write(study, rows, tmp_path)
    assert [f.name for f in files] == ["map_N_range_after.png"]
    ax, cbar = subplots_made[0].axes
    assert ax.get_xlabel() == "Start-up time to reach n0, drive.t0 [s]"
    assert ax.get_ylabel() == "Steady crank speed, drive.n0 [1/min]"
    assert cbar.get_ylabel() == "variation of N after the start-up,\nN_range_after [N]"


@pytest.mark.parametrize("flags, why", [
    ({"contact": [1, 1, 0, 0], "rolling": [1, 1, 0, 0]}, "loss of contact"),  # rolling fails with contact
    ({"contact": [1, 1, 1, 1], "rolling": [1, 1, 0, 0]}, "slip"),
    ({"contact": [1, 1, 1, 1], "rolling": [1, 1, 1, 1]}, "inconsistent inputs"),  # flagged inputs
    ({}, "loss of contact, slip or inconsistent inputs"),  # the flags not recorded: not known here
])
def test_why_the_validity_ended_is_in_the_summary_and_on_the_plot(tmp_path, subplots_made, flags, why):
    """valid turns false at the third row, BallInShell's t_invalid = 0.15 s (between rows): the
    summary's invalid_reason and statistics_over, and the span [0.15, 0.3] s labelled with both."""
    from ballmill.scenario import report
    from ballmill.scenario.runner import RunResult
    from ballmill.scenario.spec import Instance, Scenario

    sc = Scenario(path=Path("s.toml"), name="s", description="", start=0.0, stop=0.3, step=0.1,
                  instances={"ball": Instance("ball", fmu="BallInShell", parameters={"mu": 0.3})},
                  connections=[], record=[], plots=[{"y": ["ball.N"], "file": "N.png"}], summary={})
    cols = {"ball.N": [3.0, 2.0, 1.0, 0.5], "ball.valid": [1, 1, 0, 0], "ball.t_invalid": [1e300, 1e300, 0.15, 0.15],
            **{f"ball.{k}": v for k, v in flags.items()}}
    data = np.column_stack([[0.0, 0.1, 0.2, 0.3]] + [np.asarray(v, float) for v in cols.values()])
    res = RunResult(scenario=sc, columns=["time", *cols], data=data, success=True, message="completed")
    summary = report.write_all(res, {}, tmp_path)
    assert summary["invalid_reason"] == why and f"t_invalid = 0.15 s ({why}; see log)" in summary["statistics_over"]
    ax = subplots_made[0].axes[0]
    assert spans(ax) == [(0.15, 0.3, f"ball model not valid ({why} at 0.15 s)")]
    assert ax.get_ylabel() == "Normal force of the chamber on the ball, N [N]"


def test_the_structure_with_and_without_the_ball_shades_the_invalid_span(tmp_path, subplots_made):
    """The absorber's comparison plot is a time plot too: the ball's invalid span shaded there."""
    from ballmill.scenario import report
    from ballmill.scenario.runner import RunResult
    from ballmill.scenario.spec import Instance, Scenario

    sc = Scenario(path=Path("s.toml"), name="s", description="", start=0.0, stop=0.3, step=0.1,
                  instances={"ball": Instance("ball", fmu="BallInShell"), "tower": Instance("tower", fmu="Structure")},
                  connections=[], record=[], plots=[], summary={"structure": "tower"})
    t = [0.0, 0.1, 0.2, 0.3]
    res = RunResult(scenario=sc, columns=["time", "tower.x_rel", "ball.valid", "ball.contact"],
                    data=np.column_stack([t, [0.0, 1.0, 2.0, 1.0], [1, 0, 0, 0], [1, 0, 0, 0]]), success=True,
                    message="")
    bare = RunResult(scenario=sc, columns=["time", "tower.x_rel"], data=np.column_stack([t, [0.0, 2.0, 4.0, 2.0]]),
                     success=True, message="")
    report.plot_bare(res, bare, tmp_path)
    ax = subplots_made[0].axes[0]
    assert spans(ax) == [(0.1, 0.3, "ball model not valid (loss of contact at 0.1 s)")]


def test_a_plot_legend_given_for_a_table_replaces_the_column_names(tmp_path, subplots_made):
    """A table's columns have no declaration: the plot's legend = [...] names the curves."""
    from ballmill.scenario import report
    from ballmill.scenario.runner import RunResult
    from ballmill.scenario.spec import Instance, Scenario

    plots = [{"y": ["ground.ax", "ground.ay"], "file": "g.png", "legend": ["ground x [m/s2]", "ground y [m/s2]"]},
             {"y": ["ground.ax", "ground.ay"], "file": "h.png"}]
    sc = Scenario(path=Path("s.toml"), name="s", description="", start=0.0, stop=0.1, step=0.1,
                  instances={"ground": Instance("ground", table=Path("g.csv"))}, connections=[], record=[],
                  plots=plots, summary={})
    res = RunResult(scenario=sc, columns=["time", "ground.ax", "ground.ay"],
                    data=np.array([[0.0, 1.0, 2.0], [0.1, 3.0, 4.0]]), success=True, message="")
    report.plot(res, tmp_path)
    assert legend(subplots_made[0].axes[0]) == ["ground x [m/s2]", "ground y [m/s2]"]
    assert legend(subplots_made[1].axes[0]) == ["ground.ax", "ground.ay"]
    assert subplots_made[1].axes[0].get_ylabel() == "ground.ax, ground.ay"


def test_sweep_map_hatches_exactly_the_cells_where_the_model_did_not_hold(tmp_path, subplots_made):
    """On every map of a two-parameter grid the hatched area is the cells of the points that
    failed or left the model's validity, no more and no fewer (runs of them along t0 and lone
    cells alike), and each map's title and colour bar name its own indicator."""
    from ballmill.sweep import plots
    from ballmill.sweep.spec import build

    t0s, n0s = [1.0, 2.0, 3.0, 4.0], [60, 70, 80]
    bad = {(1.0, 70), (2.0, 70), (1.0, 80), (2.0, 80), (3.0, 80), (4.0, 60)}
    study = build("fast_start", grid={"drive.t0": t0s, "drive.n0": n0s})
    rows = [{"drive.t0": t0, "drive.n0": n0, "status": "failed" if (t0, n0) == (4.0, 60) else "ok",
             "valid": (t0, n0) not in bad, "N_range_after": t0 * n0, "zP_max": t0 + n0}
            for n0 in n0s for t0 in t0s]
    files = plots.write(study, rows, tmp_path)
    assert [f.name for f in files] == ["map_N_range_after.png", "map_zP_max.png"]
    ax, cbar = subplots_made[-1].axes
    paths = [a.get_path().transformed(a.get_patch_transform()) if hasattr(a, "get_patch_transform") else p
             for a in [*ax.patches, *ax.collections] if a.get_hatch()
             for p in (a.get_paths() if not hasattr(a, "get_patch_transform") else [None])]
    assert paths
    inside = {(t0, n0) for t0 in t0s for n0 in n0s if any(p.contains_point((t0, n0)) for p in paths)}
    assert inside == bad
    assert ax.get_title() == "zP_max (hatched: model not valid)" and "zP_max" in cbar.get_ylabel()
