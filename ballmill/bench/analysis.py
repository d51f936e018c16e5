"""Pareto fronts, time at a target error, and the error-vs-time figure."""
from __future__ import annotations

import math
from dataclasses import dataclass

from .problem import RunResult


def usable(results):
    return [r for r in results if r.ok and math.isfinite(r.err_P) and math.isfinite(r.wall)]


def pareto(results, key="err_P"):
    """Settings not beaten by a faster and at least as accurate one, by wall time."""
    front, best = [], math.inf
    for r in sorted(usable(results), key=lambda r: (r.wall, getattr(r, key))):
        e = getattr(r, key)
        if e < best * (1.0 - 1e-3):  # an error smaller only in its last digits is no gain
            front.append(r)
            best = e
    return front


@dataclass
class AtError:
    target: float
    time: float | None  # interpolated on the front (log-log) or the cheapest meeting it
    how: str
    cheapest: RunResult | None  # cheapest setting with error <= target
    bracket: tuple | None  # the two front points interpolated between


def time_at_error(results, target: float, key: str = "err_P") -> AtError:
    front = pareto(results, key)
    meet = [r for r in front if getattr(r, key) <= target]
    if not meet:
        return AtError(target, None, "no setting reaches the target", None, None)
    best = meet[0]  # the front is sorted by time, errors falling
    i = front.index(best)
    if i == 0:
        return AtError(target, best.wall, "cheapest setting meeting it (the target is not bracketed: "
                       "every setting on the front is more accurate)", best, None)
    lo, hi = front[i - 1], best  # lo: faster, error above target
    e_lo, e_hi = getattr(lo, key), getattr(hi, key)
    if e_hi <= 0.0 or e_lo <= e_hi:
        return AtError(target, best.wall, "cheapest setting meeting it", best, None)
    u = (math.log(target) - math.log(e_lo)) / (math.log(e_hi) - math.log(e_lo))
    t = math.exp(math.log(lo.wall) + u * (math.log(hi.wall) - math.log(lo.wall)))
    return AtError(target, t, "log-log interpolation on the Pareto front", best, (lo, hi))


def retimed(at: AtError, wall_of) -> float | None:
    """The time at the target with other wall times for the same front points
    (e.g. an interleaved re-measurement): same bracket, same interpolation."""
    if at.time is None:
        return None
    if at.bracket:
        lo, hi = at.bracket
        e_lo, e_hi = lo.err_P, hi.err_P
        u = (math.log(at.target) - math.log(e_lo)) / (math.log(e_hi) - math.log(e_lo))
        return math.exp(math.log(wall_of(lo)) + u * (math.log(wall_of(hi)) - math.log(wall_of(lo))))
    return wall_of(at.cheapest)


FAMILY_STYLE = {
    "library (vector)": "tab:blue",
    "library (paper)": "tab:orange",
    "library (C kernel)": "tab:purple",
    "paper-literal": "tab:green",
    "compiled (C)": "tab:red",
}
FAMILY_LABEL = {"library (vector)": "library (vector, pure Python)",
                "library (paper)": "library (paper, pure Python)",
                "compiled (C)": "compiled peer (standalone C)"}
METHOD_MARKER = {"DOP853": "o", "RK45": "s", "RK4": "^", "solve_ivp RK45": "D"}
FLOOR = 1e-16


def figure(results, path, target: float = 1e-6, title: str = ""):
    """Error against wall time, log-log; one colour per family, one marker per method."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6))
    res = usable(results)
    groups = {}
    for r in res:
        groups.setdefault((r.family, r.method), []).append(r)
    for ax, key, unit in ((axes[0], "err_P", "max |P - P_ref| [m]"), (axes[1], "err_N", "max |N - N_ref| [N]")):
        for (fam, meth), rs in groups.items():
            rs = sorted(rs, key=lambda r: -r.param)  # along the family's curve: loose to tight
            ax.plot([r.wall for r in rs], [max(getattr(r, key), FLOOR) for r in rs],
                    color=FAMILY_STYLE.get(fam, "k"), marker=METHOD_MARKER.get(meth, "x"),
                    linestyle="-", linewidth=1.0, markersize=6, alpha=0.85)
        if key == "err_P":
            ax.axhline(target, color="0.4", linestyle="--", linewidth=1)
            ax.text(min(r.wall for r in res) * 1.05, target * 1.4,
                    f"target {target:g} m", color="0.3", fontsize=9)
        if any(getattr(r, key) < FLOOR for r in res):
            ax.text(max(r.wall for r in res), FLOOR * 2.5, "identical to the reference (same steps): drawn at 1e-16",
                    color="0.3", fontsize=8, ha="right")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time, median [s]  (10 s of simulated time)")
        ax.set_ylabel(unit)
        ax.grid(True, which="major", alpha=0.4)
        ax.grid(True, which="minor", alpha=0.12)
    handles = [Line2D([], [], color=c, linewidth=3, label=FAMILY_LABEL.get(f, f)) for f, c in FAMILY_STYLE.items()
               if any(r.family == f for r in res)]
    handles += [Line2D([], [], color="k", marker=m, linestyle="", label=k) for k, m in METHOD_MARKER.items()
                if any(r.method == k for r in res)]
    fig.legend(handles=handles, loc="lower center", ncol=math.ceil(len(handles) / 2), frameon=False,
               fontsize=9)
    fig.suptitle(title or "Fast start, 10 s: accuracy against wall time (lower left is better)")
    fig.tight_layout(rect=(0, 0.1, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)
