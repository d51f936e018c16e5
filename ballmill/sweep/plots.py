"""Plots of a study's results, written next to results.parquet.

* one swept parameter: `curves.png`, each main indicator against it; points
  where the model did not hold over the run (or failed) are marked with a red
  cross at the bottom of their panel instead of a value;
* two swept parameters on a full grid: `map_INDICATOR.png`, a heat map per main
  indicator, cells where the model did not hold hatched (and left uncoloured:
  their indicators are not reported);
* a sample (random / Latin hypercube): `scatter.png`, each main indicator
  against each swept parameter.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plotting import labels
from .indicators import BUILTIN

MAIN = ("N_range_after", "ring_width", "zP_max", "N_max", "theta_max_deg", "T_drive_peak", "E_startup",
        "friction_ratio_max")


def _num(v):
    return np.nan if v is None else float(v)


def _label(name, width=None):
    """An indicator in words with its unit (indicators.BUILTIN); a custom one by its name."""
    unit, description = BUILTIN.get(name, (None, None))
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
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    swept = study.swept
    main = [m for m in MAIN if any(r.get(m) is not None for r in rows)] + \
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
                                 squeeze=False)
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
        fig.tight_layout()
        path = out_dir / "curves.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        return [path]
    if study.sample is None and len(swept) == 2:
        px, py = swept
        xs, ys = study.grid[px], study.grid[py]
        index = {(repr(r[px]), repr(r[py])): r for r in rows}
        for m in main:
            Z = np.full((len(ys), len(xs)), np.nan)
            bad = np.zeros_like(Z, dtype=bool)
            for i, yv in enumerate(ys):
                for j, xv in enumerate(xs):
                    r = index.get((repr(xv), repr(yv)))
                    if r is None:
                        continue
                    Z[i, j] = _num(r.get(m))
                    bad[i, j] = not (r.get("status") == "ok" and bool(r.get("valid")))
            fig, ax = plt.subplots(figsize=(6.4, 4.8))
            xe, ye = _edges(np.array(xs, float)), _edges(np.array(ys, float))
            mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(Z), shading="flat", cmap="viridis")
            fig.colorbar(mesh, ax=ax, label=_label(m, width=45))
            if bad.any():  # the invalid cells, hatched, as one collection of rectangles
                from matplotlib.collections import PolyCollection

                i, j = np.nonzero(bad)
                cells = np.stack([np.stack([xe[j], ye[i]], 1), np.stack([xe[j + 1], ye[i]], 1),
                                  np.stack([xe[j + 1], ye[i + 1]], 1), np.stack([xe[j], ye[i + 1]], 1)], 1)
                ax.add_collection(PolyCollection(cells, facecolors="none", edgecolors="red", hatch="xx",
                                                 linewidths=0.0))
            ax.set_xlabel(_parameter_label(fmus, px, width=60))
            ax.set_ylabel(_parameter_label(fmus, py, width=45))
            ax.set_title(f"{m}" + (" (hatched: model not valid)" if bad.any() else ""), fontsize=10)
            fig.suptitle(title, fontsize=9)
            fig.tight_layout()
            path = out_dir / f"map_{m}.png"
            fig.savefig(path, dpi=100)
            plt.close(fig)
            files.append(path)
        return files
    # a sample, or more than two parameters: scatter
    n, k = len(main), len(swept)
    fig, axes = plt.subplots(n, k, figsize=(3.6 * k, 2.4 * n), squeeze=False)
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
    fig.tight_layout()
    path = out_dir / "scatter.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return [path]


def _edges(v: np.ndarray) -> np.ndarray:
    """Cell edges around sorted or unsorted grid values (midpoints; ends mirrored)."""
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else np.array([v[0] * 0.95, v[0] * 1.05])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])
