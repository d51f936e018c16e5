"""The plots of a scenario run that a person looks at (ballmill.scenario.report): the contact
point on the chamber's shell (_plot_shell, _shell_unit_vectors), the slip margin
(_plot_slip_margin), the dispatch of [[plots]] by kind and the PNG files (plot), and the
structure with and without the ball (plot_bare); on small synthetic results whose points,
failure times and margins are worked out by hand below. The figures are inspected: which curves
are drawn from which data, axis labels with units, titles, legends, limits, the colour scale,
the files and their size in pixels. The scenario tests reach this code only with built FMUs
(docs/mutation.md); tests/mutation/test_report_files.py pins the series plots' basics.
"""
from __future__ import annotations

import math
import struct
from pathlib import Path
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest

from ballmill.plotting import shell
from ballmill.scenario import report
from ballmill.scenario.runner import RunResult
from ballmill.scenario.spec import Instance, Scenario

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.layout_engine import ConstrainedLayoutEngine  # noqa: E402

S4, S8 = math.sqrt(0.4), math.sqrt(0.8)
T6 = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
# The contact point in the chamber's axes on a shell of R = 0.5 m (lowest point the origin):
# unit vectors u = (P - (0, 0, R)) / R by hand (3-4-5 triangles), and their hemisphere.
P_CH = [(0.0, 0.0, 0.0), (0.3, 0.0, 0.1), (0.0, 0.4, 0.8), (0.5, 0.0, 0.5), (0.0, -0.3, 0.1), (0.0, 0.0, 1.0)]
U = [(0.0, 0.0, -1.0), (0.6, 0.0, -0.8), (0.0, 0.8, 0.6), (1.0, 0.0, 0.0), (0.0, -0.6, -0.8), (0.0, 0.0, 1.0)]
LOWER, UPPER = [0, 1, 4], [2, 3, 5]
# Lambert's equal-area coordinates (radius sqrt(2 (1 -+ u_z)) along (u_x, u_y)); the upper
# hemisphere is seen from below (y flipped).
XY = {0: (0.0, 0.0), 1: (S4, 0.0), 4: (0.0, -S4), 2: (0.0, -S8), 3: (math.sqrt(2.0), 0.0), 5: (0.0, 0.0)}
# Validity: mu = 0.5, N = 2 N until it drops to -1 N at t = 0.4 and F_t rises past mu N between
# t = 0.2 and 0.3: rolling's margin mu N - F_t = 0.4 -> -0.5 N fails at 0.2 + 0.1 * 0.4 / 0.9 s;
# contact's margin N = 2 -> -1 N at 0.3 + 0.1 * 2 / 3 s.
T_ROLL, T_CONTACT = 0.2 + 0.1 * 0.4 / 0.9, 0.3 + 0.1 * 2.0 / 3.0
FAILING = {"N": [2.0, 2.0, 2.0, 2.0, -1.0, -1.0], "Ft": [0.2, 0.4, 0.6, 1.5, 1.5, 1.5],
           "contact": [1, 1, 1, 1, 0, 0], "rolling": [1, 1, 1, 0, 0, 0]}
HOLDING = {"N": [2.0] * 6, "Ft": [0.1] * 6, "contact": [1] * 6, "rolling": [1] * 6}
# friction_ratio = F_t / N as the FMU records it (>= 1e299: no contact): margin mu - ratio
RATIO = [0.1, 1e300, 0.3, 0.6, 1e299, 0.2]
MARGIN = [0.4, math.nan, 0.2, -0.1, math.nan, 0.3]


def scenario(plots=(), ball_parameters=None, summary=None):
    """Two balls: 'first' (found by the scenario's model) and 'second' (named by a plot's spec)."""
    inst = {"drive": Instance("drive", fmu="MotorStartup", parameters={}),
            "first": Instance("first", fmu="BallInShell", parameters={"mu": 0.1, "R": 0.25}),
            "second": Instance("second", fmu="BallInShell", parameters=dict(ball_parameters or {}))}
    return Scenario(path=Path("shell.toml"), name="shell", description="synthetic shell", start=0.0, stop=0.5,
                    step=0.1, instances=inst, connections=[], record=[], plots=list(plots),
                    summary={} if summary is None else summary)


def models(**starts):
    """BallInShell's start values behind a decoy variable (a wrong lookup shows)."""
    ball = [SimpleNamespace(name="decoy", start=123.0)] + [SimpleNamespace(name=k, start=v) for k, v in starts.items()]
    return {"BallInShell": SimpleNamespace(modelVariables=ball), "MotorStartup": SimpleNamespace(modelVariables=[])}


MODELS = models(mu=0.5, R=0.5)  # 'second' takes both from here


def ball_columns(validity, P=P_CH, ratio=RATIO):
    x, y, z = zip(*P)
    return {"xP_ch": x, "yP_ch": y, "zP_ch": z, "friction_ratio": ratio, **validity}


def result(sc, cols_by_ball, t=T6):
    cols = {f"{b}.{k}": v for b, c in cols_by_ball.items() for k, v in c.items()}
    data = np.column_stack([np.asarray(t, float)] + [np.asarray(v, float) for v in cols.values()])
    return RunResult(scenario=sc, columns=["time", *cols], data=data, success=True, message="completed")


def two_balls(sc, second_validity, first_validity=None):
    """'first' sits still at the bottom and holds; 'second' moves along P_CH."""
    first = ball_columns(first_validity or HOLDING, P=[(0.0, 0.0, 0.0)] * 6, ratio=[0.05] * 6)
    return result(sc, {"first": first, "second": ball_columns(second_validity)})


@pytest.fixture
def figures():
    """Closes the figures a test made directly."""
    made = []
    yield made
    for fig in made:
        plt.close(fig)


def png_size(path: Path):
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


def offsets(collection):
    return [tuple(p) for p in np.asarray(collection.get_offsets())]


def legend_texts(ax):
    leg = ax.get_legend()
    return [t.get_text() for t in leg.get_texts()] if leg is not None else []


def test_shell_unit_vectors_from_the_contact_point_and_R():
    """R from the scenario or else from the model (a wrong R gives vectors that are not these)."""
    sc = scenario(ball_parameters={"R": 0.5})
    res = two_balls(sc, HOLDING)
    for m in (models(R=7.0), MODELS):
        assert np.allclose(report._shell_unit_vectors(res, m, "second"), U, rtol=0, atol=1e-15)
    res = two_balls(scenario(), HOLDING)
    assert np.allclose(report._shell_unit_vectors(res, MODELS, "second"), U, rtol=0, atol=1e-15)
    # 'first' (R = 0.25 in the scenario) at its bottom
    assert np.allclose(report._shell_unit_vectors(res, MODELS, "first"), [(0.0, 0.0, -1.0)] * 6, atol=0)
    assert report.SHELL_OUTPUTS == ("xP_ch", "yP_ch", "zP_ch")


def check_hemispheres(fig, t_fail, t_end):
    """The two hemispheres of _plot_shell's figure: valid samples coloured by time on [0, t_end],
    later ones grey, the failure marked on the hemisphere of the first sample at or after it."""
    lower, upper, cbar = fig.axes
    assert lower.get_title() == "lower hemisphere, seen from above"
    assert upper.get_title() == "upper hemisphere, seen from below"
    # side by side, one row
    assert lower.get_subplotspec().get_geometry() == (1, 2, 0, 0)
    assert upper.get_subplotspec().get_geometry() == (1, 2, 1, 1)
    t = np.asarray(T6)
    valid = [i for i in range(6) if t_fail is None or t[i] <= t_fail]
    k = None if t_fail is None else int(np.searchsorted(t, t_fail))
    for ax, side in ((lower, LOWER), (upper, UPPER)):
        *grey, coloured = ax.collections
        ok = [i for i in side if i in valid]
        assert np.allclose(offsets(coloured), [XY[i] for i in ok], rtol=0, atol=1e-15)
        assert np.array_equal(coloured.get_array(), t[ok])
        assert coloured.get_clim() == (0.0, t_end)
        if t_fail is None:
            assert grey == [] and legend_texts(ax) == [] and ax.get_lines() == []
            continue
        late = [i for i in side if i not in valid]
        assert len(grey) == 1 and np.allclose(offsets(grey[0]), [XY[i] for i in late], rtol=0, atol=1e-15)
        want = ["after rolling or contact fails (not physical)"]
        if k in side:
            want.append(f"rolling or contact fails, t = {t_fail:.3f} s")
            assert ax.get_lines()[-1].get_xydata().tolist() == [list(XY[k])]
        assert legend_texts(ax) == want
    # the colour scale: time [s] from 0 to the end of the valid span
    assert cbar.get_ylabel() == "time [s]" and cbar.get_ylim() == (0.0, t_end)


@pytest.mark.parametrize("named", [True, False])
def test_shell_plot_with_failures(figures, named):
    """The ball named by the plot ('second', failing), or the scenario's [summary] ball when the plot
    names none: colours up to the first failure (rolling, interpolated), grey after it."""
    if named:
        sc, spec = scenario(), {"kind": "shell", "ball": "second", "file": "s.png", "title": "My shell"}
    else:
        sc, spec = scenario(summary={"ball": "second"}), {"kind": "shell", "file": "s.png"}
    res = two_balls(sc, FAILING)
    fig = report._plot_shell(res, MODELS, spec, plt)
    figures.append(fig)
    check_hemispheres(fig, T_ROLL, T_ROLL)
    title = "My shell" if named else "Contact point on the shell"
    assert fig.get_suptitle() == f"{title}\n({shell.CAPTION})" and fig._suptitle.get_fontsize() == 10
    assert tuple(fig.get_size_inches()) == (9.0, 4.9)
    assert isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)


def test_shell_plot_of_a_ball_that_holds(figures):
    """No failure: every sample coloured, the scale up to the last sample's time; the ball found
    by its model ('first' holds at the bottom; 'second' is named by [summary] in the other test)."""
    sc = scenario(ball_parameters={"R": 0.5, "mu": 0.5}, summary={})
    res = two_balls(sc, HOLDING, first_validity=FAILING)
    fig = report._plot_shell(res, MODELS, {"kind": "shell", "ball": "second", "file": "s.png"}, plt)
    figures.append(fig)
    check_hemispheres(fig, None, 0.5)
    # unnamed: the scenario's first BallInShell, which sits at the bottom and fails: its rolling
    # flag drops at t = 0.3 where its margin mu N - F_t = 0.1 * 2 - 0.6 N is negative already
    # (no sign change to interpolate: that sample's time)
    fig = report._plot_shell(res, MODELS, {"kind": "shell", "file": "s.png"}, plt)
    figures.append(fig)
    lower = fig.axes[0]
    assert lower.collections[-1].get_clim() == (0.0, 0.3)
    assert offsets(lower.collections[-1]) == [(0.0, 0.0)] * 4 and offsets(lower.collections[0]) == [(0.0, 0.0)] * 2
    assert legend_texts(lower) == ["after rolling or contact fails (not physical)",
                                   "rolling or contact fails, t = 0.300 s"]


def check_slip(ax, mu, t, margin, fails, lw=1.2):
    line, zero, *marks = ax.get_lines()
    assert np.array_equal(line.get_xdata(), t)
    assert np.allclose(line.get_ydata(), margin, rtol=0, atol=1e-15, equal_nan=True)
    assert line.get_linewidth() == lw
    assert list(zero.get_ydata()) == [0.0, 0.0] and zero.get_color() == "k" and zero.get_linewidth() == 0.6
    assert [tuple(m.get_xdata()) for m in marks] == [pytest.approx((when, when), rel=1e-15) for _, when, _ in fails]
    assert [m.get_linestyle() for m in marks] == [style for _, _, style in fails]
    assert all(m.get_color() == "tab:red" and m.get_linewidth() == 1.0 for m in marks)
    assert legend_texts(ax) == [f"mu - friction_ratio (mu = {mu:g})"] + [
        f"{flag} first fails, t = {when:.4f} s" for flag, when, _ in fails]
    assert all(txt.get_fontsize() == 8 for txt in ax.get_legend().get_texts())
    assert ax.get_ylim() == (-mu, 1.05 * mu)
    assert ax.get_xlabel() == "time [s]"
    grid = ax.xaxis.get_gridlines() + ax.yaxis.get_gridlines()
    assert all(g.get_visible() and g.get_alpha() == 0.3 for g in grid)


@pytest.mark.parametrize("named", [True, False])
def test_slip_margin_plot(figures, named):
    """mu - friction_ratio (mu from the model: 0.5), not drawn where the ratio stands for infinite
    (>= 1e299); both first failures marked (rolling dotted, contact dashed), limits -mu .. 1.05 mu."""
    if named:
        sc, spec = scenario(), {"kind": "slip_margin", "ball": "second", "file": "m.png"}
    else:
        sc = scenario(summary={"ball": "second"})
        spec = {"kind": "slip_margin", "file": "m.png", "title": "Margin", "ylabel": "margin [1]"}
    res = two_balls(sc, FAILING)
    fig = report._plot_slip_margin(res, MODELS, spec, plt)
    figures.append(fig)
    ax, = fig.axes
    check_slip(ax, 0.5, T6, MARGIN, [("rolling", T_ROLL, ":"), ("contact", T_CONTACT, "--")])
    assert T_ROLL == pytest.approx(0.24444444444444446, abs=1e-15)
    if named:
        assert ax.get_ylabel() == "slip margin mu - F_t / N [1] (cut at -mu)"
        assert ax.get_title() == "Slip margin: the ball rolls while positive"
    else:
        assert ax.get_ylabel() == "margin [1]" and ax.get_title() == "Margin"
    assert tuple(fig.get_size_inches()) == (7.5, 4.8)


def test_slip_margin_of_a_ball_that_holds_and_of_long_runs(figures):
    """No failure: no marks; the ball found by its model ('first', mu = 0.1 from the scenario);
    runs longer than 2000 samples drawn thinner."""
    res = two_balls(scenario(), HOLDING)
    fig = report._plot_slip_margin(res, MODELS, {"kind": "slip_margin", "file": "m.png"}, plt)
    figures.append(fig)
    check_slip(fig.axes[0], 0.1, T6, [0.1 - 0.05] * 6, [])
    for n, lw in ((2000, 1.2), (2001, 0.8)):
        t = np.linspace(0.0, 1.0, n)
        cols = {"N": np.full(n, 2.0), "Ft": np.full(n, 0.5), "contact": np.ones(n), "rolling": np.ones(n),
                "friction_ratio": np.full(n, 0.25)}
        res = result(scenario(), {"second": cols}, t=t)
        fig = report._plot_slip_margin(res, MODELS, {"kind": "slip_margin", "ball": "second", "file": "m.png"}, plt)
        figures.append(fig)
        check_slip(fig.axes[0], 0.5, t, np.full(n, 0.25), [], lw=lw)


def test_plot_dispatches_by_kind_and_writes_every_file(tmp_path, subplots_made):
    """A shell, a slip margin and a series plot, in the scenario's order, each its own PNG at
    110 dpi; every figure closed after saving."""
    plots = [{"kind": "shell", "ball": "second", "file": "shell.png"},
             {"kind": "slip_margin", "ball": "second", "file": "margin.png"},
             {"y": ["second.friction_ratio"], "file": "ratio.png"},
             {"kind": "series", "x": "second.xP_ch", "y": ["second.yP_ch"], "file": "path.png", "aspect": "equal"}]
    res = two_balls(scenario(plots), FAILING)
    open_before = set(plt.get_fignums())
    files = report.plot(res, tmp_path, MODELS)
    assert files == [tmp_path / "shell.png", tmp_path / "margin.png", tmp_path / "ratio.png", tmp_path / "path.png"]
    assert [png_size(f) for f in files] == [(990, 539), (825, 528), (825, 528), (704, 704)]
    assert len(subplots_made) == 4 and set(plt.get_fignums()) == open_before
    shell_fig, margin_fig, ratio_fig, path_fig = subplots_made
    assert [ax.get_title() for ax in shell_fig.axes[:2]] == ["lower hemisphere, seen from above",
                                                             "upper hemisphere, seen from below"]
    assert margin_fig.axes[0].get_title() == "Slip margin: the ball rolls while positive"
    # the series: 1e300 and exactly 1e299 stand for infinite and are not drawn
    ax = ratio_fig.axes[0]
    assert np.allclose(ax.get_lines()[0].get_ydata(), [0.1, math.nan, 0.3, 0.6, math.nan, 0.2], equal_nan=True,
                       rtol=0, atol=0)
    # the y axis in words with the unit, from BallInShell's declaration
    assert ax.get_title() == "" and ax.get_ylabel() == "|F_t| / N, friction_ratio [1]"
    assert all(g.get_alpha() == 0.3 for g in ax.xaxis.get_gridlines())
    # equal aspect by moving the data limits, not by shrinking the box
    ax = path_fig.axes[0]
    assert ax.get_aspect() == 1.0 and ax.get_adjustable() == "datalim"
    # a negative infinite stand-in too, and the line width switches above 2000 samples
    n = 2000
    sc = scenario([{"y": ["second.N"], "file": "n.png"}])
    res = result(sc, {"second": {"N": np.r_[-1e299, np.ones(n - 1)]}}, t=np.linspace(0.0, 1.0, n))
    report.plot(res, tmp_path, MODELS)
    line = subplots_made[-1].axes[0].get_lines()[0]
    assert math.isnan(line.get_ydata()[0]) and line.get_ydata()[1] == 1.0 and line.get_linewidth() == 1.2


def test_plot_bare(tmp_path, subplots_made):
    """The structure's displacement with (blue) and without (red) the ball, one plot per axis the
    bare run moves in; an axis the bare run does not record, or where it stays at zero, is left out."""
    sc = scenario(summary={"structure": "tower"})
    t = np.array([0.0, 0.1, 0.2])
    res = RunResult(scenario=sc, columns=["time", "tower.x_rel", "tower.y_rel"],
                    data=np.column_stack([t, [0.0, 0.01, -0.02], [0.0, 0.003, 0.004]]), success=True, message="")
    bare = RunResult(scenario=sc, columns=["time", "tower.x_rel", "tower.y_rel"],
                     data=np.column_stack([t + 1.0, [0.0, 0.1, -0.2], [0.0, 0.03, 0.04]]), success=True, message="")
    open_before = set(plt.get_fignums())
    files = report.plot_bare(res, bare, tmp_path)
    assert files == [tmp_path / "structure_x_with_without_ball.png", tmp_path / "structure_y_with_without_ball.png"]
    assert [png_size(f) for f in files] == [(825, 528)] * 2
    assert set(plt.get_fignums()) == open_before
    for fig, axis, col in zip(subplots_made, "xy", (1, 2)):
        ax, = fig.axes
        b, w = ax.get_lines()
        assert np.array_equal(b.get_xdata(), bare.data[:, 0]) and np.array_equal(b.get_ydata(), bare.data[:, col])
        assert np.array_equal(w.get_xdata(), res.data[:, 0]) and np.array_equal(w.get_ydata(), res.data[:, col])
        assert (b.get_color(), b.get_linewidth(), w.get_color(), w.get_linewidth()) == ("tab:red", 0.8, "tab:blue", 0.8)
        assert legend_texts(ax) == ["bare structure", "with the ball absorber"]
        assert ax.get_xlabel() == "time [s]"
        assert ax.get_ylabel() == f"displacement {axis} at the absorber [m]"
        assert ax.get_title() == f"Structure displacement {axis}, with and without the ball"
        assert all(g.get_visible() and g.get_alpha() == 0.3 for g in ax.xaxis.get_gridlines())
        assert tuple(fig.get_size_inches()) == (7.5, 4.8)
    # x still in the bare run: only y; y not recorded by the bare run: only x
    still = RunResult(scenario=sc, columns=["time", "tower.x_rel", "tower.y_rel"],
                      data=np.column_stack([t, np.zeros(3), [0.0, 0.03, 0.04]]), success=True, message="")
    assert report.plot_bare(res, still, tmp_path) == [tmp_path / "structure_y_with_without_ball.png"]
    assert subplots_made[-1].axes[0].get_ylabel() == "displacement y at the absorber [m]"
    x_only = RunResult(scenario=sc, columns=["time", "tower.x_rel"], data=bare.data[:, :2], success=True, message="")
    assert report.plot_bare(res, x_only, tmp_path) == [tmp_path / "structure_x_with_without_ball.png"]
