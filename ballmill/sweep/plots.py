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
    from ..plotting import figures as plt  # Figure objects on Agg canvases, drawn once each

    swept = study.swept
    main = [m for m in MAIN + MAIN_HYBRID if any(r.get(m) is not None for r in rows)] + \
        [i.name for i in study.indicators if any(r.get(i.name) is not None for r in rows)]
    if not rows or not main or not swept:
        return []
    ok = np.array([r.get("status") == "ok" and bool(r.get("valid")) for r in rows])
    fmus = _fmus(study)
    files = []
    import textwrap

    title = textwrap.fill(f"{study.name}: {study.description}" if study.description else study.name, 90)
    numeric = all(isinstance(r.get(p), (int, float)) and not isinstance(r.get(p), bool) for r in rows for p in swept)
    if not numeric:
        return []
    if study.sample is None and len(swept) == 1:
        p = swept[0]
        x = np.array([_num(r[p]) for r in rows])
        order = np.argsort(x)
        n = len(main)
        cols = 2 if n > 1 else 1
        fig, axes = plt.subplots((n + cols - 1) // cols, cols, figsize=(5.2 * cols, 2.8 * ((n + cols - 1) // cols)),
                                 squeeze=False, dpi=100, layout="tight")
        for ax, m in zip(axes.flat, main):
            y = np.array([_num(r.get(m)) for r in rows])
            ax.plot(x[order], y[order], "o-", ms=3, lw=1.2)
            bad = ~ok
            if bad.any():
                lo = np.nanmin(y) if np.isfinite(y).any() else 0.0
                ax.plot(x[bad], np.full(bad.sum(), lo), "x", color="red", label="model not valid")
                ax.legend(fontsize=7)
            ax.set_xlabel(_parameter_label(fmus, p, width=50))
            ax.set_ylabel(_label(m, width=40), fontsize=8)
            ax.grid(alpha=0.3)
        for ax in list(axes.flat)[n:]:
            ax.set_visible(False)
        fig.suptitle(title, fontsize=10)
        return [plt.save(fig, out_dir / "curves.png")]
    if study.sample is None and len(swept) == 2:
        px, py = swept
        xs, ys = study.grid[px], study.grid[py]
        Z, bad = _grid_values(rows, main, px, py, xs, ys)
        xe, ye = _edges(np.array(xs, float)), _edges(np.array(ys, float))
        hatched = _runs(bad, xe, ye)
        # one figure for every map: the axes, their ticks and labels and the title are the same,
        # laid out and measured once; each map changes the colours, the colour bar and its label
        fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100, layout="tight")
        mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(Z[main[0]]), shading="flat", cmap="viridis")
        bar = fig.colorbar(mesh, ax=ax)
        if hatched is not None:  # the invalid cells, hatched, as one path
            from matplotlib.patches import PathPatch

            ax.add_patch(PathPatch(hatched, facecolor="none", edgecolor="red", hatch="xx", lw=0.0))
        border = None
        if any(r.get("n_impacts") is not None for r in rows):  # the hybrid ball: where impacts begin
            impacts, _ = _grid_values(rows, ["n_impacts"], px, py, xs, ys)
            segs = _outline(impacts["n_impacts"] > 0, xe, ye)
            if segs:
                from matplotlib.collections import LineCollection

                border = ax.add_collection(LineCollection(segs, colors=SHOCKLESS, linewidths=2.0,
                                                          label="boundary of the shockless region"))
        ax.set_xlabel(_parameter_label(fmus, px, width=60))
        ax.set_ylabel(_parameter_label(fmus, py, width=45))
        fig.suptitle(title, fontsize=9)
        for k, m in enumerate(main):
            mesh.set_array(np.ma.masked_invalid(Z[m]))
            mesh.autoscale()
            bar.set_label(_label(m, width=45))
            ax.set_title(f"{m}" + (" (hatched: model not valid)" if hatched is not None else "")
                         + (f"\n{SHOCKLESS} line: where impacts begin (n_impacts > 0 on its inner side)"
                            if border is not None else ""), fontsize=10)
            path = plt.save(fig, out_dir / f"map_{m}.png")
            # the maps after the first keep its layout (laid out again, and drawn again, only when
            # their colour bar's label, which lies beyond its tick labels, its offset text or their
            # title would leave the figure)
            if k and not _within(fig, bar.ax.yaxis.label, bar.ax.yaxis.offsetText, ax.title):
                fig.set_layout_engine("tight")
                path = plt.save(fig, path)
            fig.set_layout_engine("none")
            files.append(path)
        return files

    # a sample, or more than two parameters: scatter
    n, k = len(main), len(swept)
    fig, axes = plt.subplots(n, k, figsize=(3.6 * k, 2.4 * n), squeeze=False, dpi=90, layout="tight")
    for a, m in enumerate(main):
        y = np.array([_num(r.get(m)) for r in rows])
        for b, p in enumerate(swept):
            x = np.array([_num(r[p]) for r in rows])
            ax = axes[a, b]
            ax.plot(x[ok], y[ok], ".", ms=3)
            if (~ok).any():
                lo = np.nanmin(y) if np.isfinite(y).any() else 0.0
                ax.plot(x[~ok], np.full((~ok).sum(), lo), "x", color="red", ms=3)
            if a == n - 1:
                ax.set_xlabel(_parameter_label(fmus, p, width=40), fontsize=8)
            if b == 0:
                ax.set_ylabel(_label(m, width=30), fontsize=7)
            ax.grid(alpha=0.3)
    fig.suptitle(title + "  (red x: model not valid)", fontsize=10)
    return [plt.save(fig, out_dir / "scatter.png")]


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
