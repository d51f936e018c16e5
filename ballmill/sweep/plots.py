"""Plots of a study's results, written next to results.parquet.

* one swept parameter: `curves.png`, each main indicator against it; points
  where the model did not hold over the run (or failed) are marked with a red
  cross at the bottom of their panel instead of a value;
* two swept parameters on a full grid: `map_INDICATOR.png`, a heat map per main
  indicator, cells where the model did not hold hatched (and left uncoloured:
  their indicators are not reported);
  A study of the hybrid ball (rows with n_impacts) maps its own indicators too, and draws
  on every map the boundary of the shockless region: the cell edges between the points with
  impacts (n_impacts > 0) and those without;
* a sample (random / Latin hypercube): `scatter.png`, each main indicator
  against each swept parameter.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting import labels
from .indicators import BUILTIN, HYBRID

MAIN = ("N_range_after", "ring_width", "zP_max", "N_max", "theta_max_deg", "T_drive_peak", "E_startup",
        "friction_ratio_max")
# the hybrid ball's (a rolling study's rows do not have them, so its plots do not change)
MAIN_HYBRID = ("n_impacts", "v_impact_max", "sliding_fraction", "flight_fraction", "E_friction_rev",
               "E_impact_rev", "t_first_slip")
SHOCKLESS = "white"  # the colour of the shockless region's boundary on a map


def _num(v):
    return np.nan if v is None else float(v)


def _label(name, width=None):
    """An indicator in words with its unit (indicators.BUILTIN); a custom one by its name."""
    unit, description = {**BUILTIN, **HYBRID}.get(name, (None, None))
    return labels.label(None, name, unit=unit, description=description, width=width)


def _fmus(study) -> dict:
    """instance -> FMU name of the study's scenario (for the swept parameters' declarations);
    empty when the scenario cannot be read here (the engine reports that itself)."""
    from ballmill.scenario import spec as _scen
    try:
        return {n: i.fmu for n, i in _scen.load(study.scenario).instances.items()}
    except (_scen.ScenarioError, OSError):
        return {}


def _parameter_label(fmus: dict, name: str, width=None) -> str:
    """A swept "instance.parameter" in words with its unit, from its FMU's declaration."""
    inst, _, param = name.partition(".")
    return labels.label(fmus.get(inst), param, name, width=width)


def write(study, rows: list[dict], out_dir: Path) -> list[Path]:
    """The study's PNGs, drawn here one job after another (`jobs` with one job for the maps)."""
    return [f for job in jobs(study, rows, out_dir) for f in job()]


def warm() -> None:
    """Import what the jobs draw with (matplotlib, PIL's PNG encoder), so that processes forked
    after this draw at once (about 0.5 s of CPU)."""
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.collections  # noqa: F401
    import matplotlib.figure  # noqa: F401
    import matplotlib.patches  # noqa: F401
    import matplotlib.path  # noqa: F401
    from PIL import Image, PngImagePlugin  # noqa: F401


def jobs(study, rows: list[dict], out_dir: Path, parts: int = 1) -> list:
    """The study's PNGs as jobs: picklable callables of no argument, each drawing some of the
    files and returning their paths, independent of one another (a Dask task each, or called
    here one after another: the same bytes). The rows are read here; a job holds only what it
    draws (the grids of values, the labels). ``parts``: how many jobs the heat maps of a
    two-parameter grid are cut into (each draws its share on a figure of its own); curves and
    scatter plots are one job. No jobs when there is nothing to plot."""
    import functools
    import textwrap

    swept = study.swept
    main = [m for m in MAIN + MAIN_HYBRID if any(r.get(m) is not None for r in rows)] + \
        [i.name for i in study.indicators if any(r.get(i.name) is not None for r in rows)]
    if not rows or not main or not swept:
        return []
    numeric = all(isinstance(r.get(p), (int, float)) and not isinstance(r.get(p), bool) for r in rows for p in swept)
    if not numeric:
        return []
    ok = np.array([r.get("status") == "ok" and bool(r.get("valid")) for r in rows])
    fmus = _fmus(study)
    title = textwrap.fill(f"{study.name}: {study.description}" if study.description else study.name, 90)
    if study.sample is None and len(swept) == 2:
        px, py = swept
        xs, ys = study.grid[px], study.grid[py]
        Z, bad = _grid_values(rows, main, px, py, xs, ys)
        impacts = None
        if any(r.get("n_impacts") is not None for r in rows):  # the hybrid ball: where impacts begin
            impacts = _grid_values(rows, ["n_impacts"], px, py, xs, ys)[0]["n_impacts"] > 0
        common = dict(first=(main[0], Z[main[0]], _label(main[0], width=45)), bad=bad, impacts=impacts,
                      xe=_edges(np.array(xs, float)), ye=_edges(np.array(ys, float)),
                      xlabel=_parameter_label(fmus, px, width=60), ylabel=_parameter_label(fmus, py, width=45),
                      title=title, out_dir=Path(out_dir))
        n = max(1, min(parts, len(main)))
        share = [main[k * len(main) // n:(k + 1) * len(main) // n] for k in range(n)]
        return [functools.partial(_maps, [(m, Z[m], _label(m, width=45)) for m in ms], **common) for ms in share]
    if study.sample is None and len(swept) == 1:
        p = swept[0]
        return [functools.partial(_curves, np.array([_num(r[p]) for r in rows]),
                                  [(np.array([_num(r.get(m)) for r in rows]), _label(m, width=40)) for m in main],
                                  ok, _parameter_label(fmus, p, width=50), title, Path(out_dir) / "curves.png")]
    # a sample, or more than two parameters: scatter
    return [functools.partial(_scatter, [np.array([_num(r[p]) for r in rows]) for p in swept],
                              [_parameter_label(fmus, p, width=40) for p in swept],
                              [(np.array([_num(r.get(m)) for r in rows]), _label(m, width=30)) for m in main],
                              ok, title, Path(out_dir) / "scatter.png")]


def _curves(x, ys, ok, xlabel, title, path) -> list[Path]:
    """curves.png: each indicator (values, label) against the one swept parameter's values x;
    the points where the model did not hold (~ok) as red crosses at the bottom of each panel."""
    from ..plotting import figures as plt  # Figure objects on Agg canvases, drawn once each

    order = np.argsort(x)
    n = len(ys)
    cols = 2 if n > 1 else 1
    fig, axes = plt.subplots((n + cols - 1) // cols, cols, figsize=(5.2 * cols, 2.8 * ((n + cols - 1) // cols)),
                             squeeze=False, dpi=100, layout="tight")
    for ax, (y, label) in zip(axes.flat, ys):
        ax.plot(x[order], y[order], "o-", ms=3, lw=1.2)
        bad = ~ok
        if bad.any():
            lo = np.nanmin(y) if np.isfinite(y).any() else 0.0
            ax.plot(x[bad], np.full(bad.sum(), lo), "x", color="red", label="model not valid")
            ax.legend(fontsize=7)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    fig.suptitle(title, fontsize=10)
    return [plt.save(fig, path)]


def _maps(maps, first, bad, impacts, xe, ye, xlabel, ylabel, title, out_dir) -> list[Path]:
    """map_INDICATOR.png for each (indicator, values on the grid, label) of ``maps``: one
    figure for them all (the axes, their ticks and labels and the title are the same, laid out
    and measured once; each map changes the colours, the colour bar and its label), laid out
    for ``first``, the study's first map, whichever maps this job draws. A map whose colour
    bar's label (which lies beyond its tick labels), its offset text or its title would leave
    that layout is laid out for itself, and the next map is back in the first's layout: each
    PNG depends on its own map and the first only, so that the maps can be cut into jobs.
    ``bad``: the cells hatched (model not valid); ``impacts``: the cells with impacts (the
    hybrid ball; their outline drawn), or None."""
    from ..plotting import figures as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100, layout="tight")
    mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(first[1]), shading="flat", cmap="viridis")
    bar = fig.colorbar(mesh, ax=ax)
    hatched = _runs(bad, xe, ye)
    if hatched is not None:  # the invalid cells, hatched, as one path
        from matplotlib.patches import PathPatch

        ax.add_patch(PathPatch(hatched, facecolor="none", edgecolor="red", hatch="xx", lw=0.0))
    border = None
    segs = _outline(impacts, xe, ye) if impacts is not None else []
    if segs:
        from matplotlib.collections import LineCollection

        border = ax.add_collection(LineCollection(segs, colors=SHOCKLESS, linewidths=2.0,
                                                  label="boundary of the shockless region"))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    fig.suptitle(title, fontsize=9)

    def show(m, values, label):
        mesh.set_array(np.ma.masked_invalid(values))
        mesh.autoscale()
        bar.set_label(label)
        ax.set_title(f"{m}" + (" (hatched: model not valid)" if hatched is not None else "")
                     + (f"\n{SHOCKLESS} line: where impacts begin (n_impacts > 0 on its inner side)"
                        if border is not None else ""), fontsize=10)

    files, layout = [], None  # layout: the first map's (the figure's subplot parameters)
    if maps[0][0] != first[0]:  # laid out for the first map, as the job drawing it lays it out
        show(*first)
        fig.get_layout_engine().execute(fig)
        layout = vars(fig.subplotpars).copy()
        fig.set_layout_engine("none")
    for m, values, label in maps:
        show(m, values, label)
        if layout is not None:
            fig.subplots_adjust(**layout)
        path = plt.save(fig, out_dir / f"map_{m}.png")
        if layout is None:  # the first map, laid out in its drawing
            layout = vars(fig.subplotpars).copy()
        elif not _within(fig, bar.ax.yaxis.label, bar.ax.yaxis.offsetText, ax.title):
            fig.set_layout_engine("tight")
            path = plt.save(fig, path)
        fig.set_layout_engine("none")
        files.append(path)
    return files


def _scatter(xs, xlabels, ys, ok, title, path) -> list[Path]:
    """scatter.png: each indicator (values, label) against each swept parameter's values (xs,
    xlabels); the points where the model did not hold (~ok) as red crosses at the bottom."""
    from ..plotting import figures as plt

    n, k = len(ys), len(xs)
    fig, axes = plt.subplots(n, k, figsize=(3.6 * k, 2.4 * n), squeeze=False, dpi=90, layout="tight")
    for a, (y, ylabel) in enumerate(ys):
        for b, (x, xlabel) in enumerate(zip(xs, xlabels)):
            ax = axes[a, b]
            ax.plot(x[ok], y[ok], ".", ms=3)
            if (~ok).any():
                lo = np.nanmin(y) if np.isfinite(y).any() else 0.0
                ax.plot(x[~ok], np.full((~ok).sum(), lo), "x", color="red", ms=3)
            if a == n - 1:
                ax.set_xlabel(xlabel, fontsize=8)
            if b == 0:
                ax.set_ylabel(ylabel, fontsize=7)
            ax.grid(alpha=0.3)
    fig.suptitle(title + "  (red x: model not valid)", fontsize=10)
    return [plt.save(fig, path)]


def _within(fig, *texts) -> bool:
    """Whether the texts, as last drawn, lie inside the figure (an empty one anywhere)."""
    w, h = fig.bbox.width, fig.bbox.height
    for text in texts:
        if text.get_visible() and text.get_text():
            b = text.get_window_extent()
            if not (b.x0 >= 0.0 and b.y0 >= 0.0 and b.x1 <= w and b.y1 <= h):
                return False
    return True


def _grid_values(rows, main, px, py, xs, ys):
    """({indicator: values on the grid, rows along ys, columns along xs; NaN where no row or
    no value}, the cells where the model did not hold or the point failed), in one pass over
    the rows (a grid value is matched by its repr, as the study lists it)."""
    col = {repr(v): j for j, v in enumerate(xs)}
    row = {repr(v): i for i, v in enumerate(ys)}
    Z = {m: np.full((len(ys), len(xs)), np.nan) for m in main}
    bad = np.zeros((len(ys), len(xs)), dtype=bool)
    for r in rows:
        j, i = col.get(repr(r.get(px))), row.get(repr(r.get(py)))
        if i is None or j is None:
            continue
        for m in main:
            Z[m][i, j] = _num(r.get(m))
        bad[i, j] = not (r.get("status") == "ok" and bool(r.get("valid")))
    return Z, bad


def _runs(bad: np.ndarray, xe: np.ndarray, ye: np.ndarray):
    """The cells marked in ``bad`` (rows along y, columns along x; edges xe, ye) as one
    matplotlib Path: a closed rectangle per run of adjacent marked cells in a row. Hatched as
    one path, it covers the cells' area with one pattern, drawn once (a collection of the
    cells draws the pattern once per cell). None when no cell is marked."""
    from matplotlib.path import Path as MPath

    if not bad.any():
        return None
    verts = []
    for i in np.flatnonzero(bad.any(axis=1)):
        d = np.diff(np.concatenate([[0], bad[i].astype(np.int8), [0]]))
        for j0, j1 in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            verts += [(xe[j0], ye[i]), (xe[j1], ye[i]), (xe[j1], ye[i + 1]), (xe[j0], ye[i + 1]), (xe[j0], ye[i])]
    codes = np.tile([MPath.MOVETO, MPath.LINETO, MPath.LINETO, MPath.LINETO, MPath.CLOSEPOLY], len(verts) // 5)
    return MPath(np.array(verts, float), codes)


def _outline(mark: np.ndarray, xe: np.ndarray, ye: np.ndarray) -> list:
    """The cell edges between a marked cell and an unmarked neighbour (rows along y, columns
    along x; edges xe, ye), as segments ((x0, y0), (x1, y1)): the boundary of the marked region
    inside the grid (the grid's own border is none)."""
    segs = []
    for i, j in zip(*np.nonzero(mark[:, 1:] != mark[:, :-1])):  # between columns j and j + 1
        segs.append(((xe[j + 1], ye[i]), (xe[j + 1], ye[i + 1])))
    for i, j in zip(*np.nonzero(mark[1:, :] != mark[:-1, :])):  # between rows i and i + 1
        segs.append(((xe[j], ye[i + 1]), (xe[j + 1], ye[i + 1])))
    return segs


def _edges(v: np.ndarray) -> np.ndarray:
    """Cell edges around sorted or unsorted grid values (midpoints; ends mirrored)."""
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else np.array([v[0] * 0.95, v[0] * 1.05])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])
