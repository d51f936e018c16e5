"""The contact point on the chamber's shell: equal-area cells and the visited fraction, and
the two-hemisphere equal-area picture of its path. Shared by the scenario reports
(ballmill/scenario/report.py: plot kind "shell", the summary's visited fraction) and the
Fig. 1 study (ballmill/studies/fig1.py).

Points on the shell are unit vectors u from the chamber's centre in the chamber's axes
(`unit_vectors` makes them from the contact point P_ch, whose lowest point at rest is the
origin: u = (P_ch - (0, 0, R)) / R).

The visited fraction: the shell is cut into N_CELLS cells of equal area (Archimedes:
N_BANDS bands of equal height in the chamber's z times N_SECTORS equal sectors of
longitude, each 4 pi R^2 / N_CELLS; on R = 0.25 m about 25 mm across, a ball's radius);
a cell is visited when a sample of the contact point falls in it (the samples must lie
closer than a cell's size apart: a few mm at the scenarios' steps).

The picture: each hemisphere in Lambert's azimuthal equal-area projection (equal areas on
the sphere are equal areas in the picture), the lower one seen from above (the bottom in
the centre), the upper one seen from below; the rim circle is the equator.
`draw_hemispheres` colours the path by time (grey after the rolling model's first failure);
`draw_modes` colours a hybrid ball's path by its mode (rolling, sliding; in flight, when the
ball has no contact point, faintly the wall point nearest it) and marks its impacts.
"""
from __future__ import annotations

import math

import numpy as np

from ballmill.physics.outputs import first_failure  # noqa: F401 (the validity margins' zero, written once)

N_BANDS, N_SECTORS = 40, 32  # 1280 cells of 0.61 dm^2 (side ~25 mm on R = 0.25 m)
N_CELLS = N_BANDS * N_SECTORS


def unit_vectors(x, y, z, R: float) -> np.ndarray:
    """Unit vectors from the chamber's centre to the contact points P_ch = (x, y, z) [m]
    (chamber axes, the lowest point at rest the origin), normalised (rows)."""
    u = np.column_stack([np.asarray(x, float), np.asarray(y, float), np.asarray(z, float) - R])
    return u / np.linalg.norm(u, axis=1)[:, None]


def cells(u) -> np.ndarray:
    """Equal-area cell index of each unit vector u (N_BANDS x N_SECTORS)."""
    u = np.asarray(u, float)
    band = np.clip(((u[:, 2] + 1.0) / 2.0 * N_BANDS).astype(int), 0, N_BANDS - 1)
    lon = np.mod(np.arctan2(u[:, 1], u[:, 0]), 2.0 * math.pi)
    sector = np.clip((lon / (2.0 * math.pi) * N_SECTORS).astype(int), 0, N_SECTORS - 1)
    return band * N_SECTORS + sector


def visited_fraction(u, upto=None) -> float:
    """Fraction of the N_CELLS equal-area cells visited by the samples u[:upto]."""
    c = cells(u[:upto] if upto is not None else u)
    return np.unique(c).size / N_CELLS


def visited_curve(u) -> np.ndarray:
    """Visited fraction as a function of sample index (cumulative)."""
    seen = np.zeros(N_CELLS, dtype=bool)
    out = np.empty(len(u))
    count = 0
    for i, c in enumerate(cells(u)):
        if not seen[c]:
            seen[c] = True
            count += 1
        out[i] = count / N_CELLS
    return out


def hemisphere_xy(u, upper: bool):
    """Lambert azimuthal equal-area coordinates of a hemisphere (radius sqrt(2) at the equator);
    the lower one seen from inside the chamber looking down, the upper one looking up."""
    rho = np.sqrt(np.maximum(0.0, 2.0 * (1.0 - u[:, 2] if upper else 1.0 + u[:, 2])))
    h = np.hypot(u[:, 0], u[:, 1])
    h = np.where(h > 0, h, 1.0)
    x, y = rho * u[:, 0] / h, rho * u[:, 1] / h
    return (x, -y) if upper else (x, y)


def draw_hemispheres(axes, u, t, t_fail=None, t_end=None, fail_label="rolling fails"):
    """Draw the path u(t) on a pair of matplotlib axes (lower, upper hemisphere), coloured by
    time from 0 to t_end (default t[-1]); samples after t_fail (the model's first failure)
    in grey, the failure point marked. Returns the colour scale (a ScalarMappable)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    t = np.asarray(t, float)
    t_end = float(t[-1]) if t_end is None else t_end
    valid = np.ones(len(t), dtype=bool) if t_fail is None else t <= t_fail
    norm = Normalize(0, t_end)
    for ax, upper in zip(axes, (False, True)):
        sel = (u[:, 2] >= 0) if upper else (u[:, 2] < 0)
        x, y = hemisphere_xy(u, upper)
        _frame(ax)
        if (~valid).any():
            ax.scatter(x[sel & ~valid], y[sel & ~valid], s=0.6, color="0.72", lw=0)
            ax.plot([], [], "o", color="0.72", ms=4, label=f"after {fail_label} (not physical)")
        ax.scatter(x[sel & valid], y[sel & valid], c=t[sel & valid], s=1.5, cmap="viridis", norm=norm, lw=0)
        if t_fail is not None:
            k = min(int(np.searchsorted(t, t_fail)), len(t) - 1)
            if sel[k]:
                ax.plot(x[k], y[k], "rx", ms=9, mew=2, label=f"{fail_label}, t = {t_fail:.3f} s")
        _finish(ax, upper)
    return ScalarMappable(cmap="viridis", norm=norm)


def _frame(ax):
    """A hemisphere's outline: the equator (rim) and the circles 30 and 60 degrees above it."""
    from matplotlib.patches import Circle

    ax.add_patch(Circle((0, 0), math.sqrt(2.0), fill=False, color="0.4", lw=1.0))
    for zc in (0.5, 0.866):  # 30 and 60 degrees from the equator
        ax.add_patch(Circle((0, 0), math.sqrt(2.0 * (1.0 - zc)), fill=False, color="0.85", lw=0.6, ls="--"))


def _finish(ax, upper: bool):
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-1.5, 1.5)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title("upper hemisphere, seen from below" if upper else "lower hemisphere, seen from above",
                 fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower left", fontsize=7, framealpha=0.9)


# the hybrid ball's path by mode (the colours of the time plots' spans: report.MODE_SPANS); in
# flight there is no contact point: the wall point nearest the ball is drawn, faintly
MODE_STYLES = ((1, "rolling", {"color": "tab:blue", "s": 1.5}),
               (2, "sliding", {"color": "tab:orange", "s": 1.5}),
               (0, "in flight: the wall point nearest the ball (no contact), faint", {"color": "tab:purple",
                                                                                       "s": 1.0, "alpha": 0.35}))
IMPACT_MARKER = {"marker": "o", "ms": 5, "mfc": "none", "mec": "tab:red", "mew": 1.0, "ls": "none"}


def draw_modes(axes, u, mode, impact_rows=(), n_valid=None, impacts=None):
    """The hybrid ball's path u on a pair of axes (lower, upper hemisphere) coloured by its mode
    (MODE_STYLES: rolling, sliding, and in flight faintly the wall point nearest the ball),
    the points at ``impact_rows`` (the rows ending a communication step with impacts) as
    hollow red circles, the rows from ``n_valid`` on (past the model's validity) in grey.
    ``impacts``: the number of impacts, for the legend: one legend for both hemispheres, under
    them, with what appears on either."""
    from matplotlib.lines import Line2D

    mode = np.asarray(mode)
    n = len(u) if n_valid is None else int(n_valid)
    ok = np.arange(len(u)) < n
    rows = np.asarray(impact_rows, int)
    for ax, upper in zip(axes, (False, True)):
        sel = (u[:, 2] >= 0) if upper else (u[:, 2] < 0)
        x, y = hemisphere_xy(u, upper)
        _frame(ax)
        for m, _, style in MODE_STYLES:
            k = sel & ok & (mode == m)
            if k.any():
                ax.scatter(x[k], y[k], lw=0, **style)
        if (sel & ~ok).any():
            ax.scatter(x[sel & ~ok], y[sel & ~ok], s=0.6, color="0.72", lw=0)
        here = rows[sel[rows]] if rows.size else rows
        if here.size:
            ax.plot(x[here], y[here], **IMPACT_MARKER)
        _finish(ax, upper)
    handles = [Line2D([], [], marker="o", ls="none", ms=4, color=style["color"], alpha=style.get("alpha", 1.0),
                      label=text) for m, text, style in MODE_STYLES if (ok & (mode == m)).any()]
    if (~ok).any():
        handles.append(Line2D([], [], marker="o", ls="none", ms=4, color="0.72",
                              label="after the model's validity ended (not physical)"))
    if rows.size:
        what = f"{impacts} impacts" if impacts is not None else "impacts"
        handles.append(Line2D([], [], label=f"{what}: the point at the end of each step with any ({rows.size} "
                              f"steps)", **IMPACT_MARKER))
    axes[0].figure.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=8, frameon=False)


CAPTION = ("equal-area projection of each hemisphere; centre = bottom resp. top, circle = equator, "
           "x_ch to the right")
