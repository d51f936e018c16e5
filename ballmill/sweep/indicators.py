"""Indicators of one point, and the validity of the model they are computed from.

A point's run is a `Record`: sampled time series named "instance.variable"
(the ball's outputs, the drive's kinematics and torque) plus how to turn a
window reference ("after", "drive.t0", ...) into seconds. From it:

* `validity(t, N, friction_ratio, mu)`: the model holds while the ball touches
  the wall (N > 0) and rolls (|F_t| <= mu N); (valid, t_invalid, first bad
  sample). The one place this rule lives (the FMU's latched `valid` output
  follows the same rule).
* `statistic`: max, min, range, amplitude, rms, mean, abs_max or integral of a
  series over a window [a, b] (seconds, or "start", "after", "stop",
  "instance.parameter", each optionally with an offset: "after+10"). It is None (not reported) when the window
  reaches a sample at or after t_invalid: a statistic over a span where the
  model does not hold is never reported as physics. Extrema inside the window
  are refined by the parabola through the sample and its two neighbours, so
  that a peak between samples is not cut off (error O(dt^3) instead of O(dt^2)).
* `builtin`: the mill designer's indicators (BUILTIN, with units), and custom
  ones (`spec.Indicator`) on any recorded or derived variable.

Derived variables: "BALL.rhoP" (radius of the contact point in Oxy [m]),
"BALL.theta_deg" (polar angle of the contact point from the lowest point,
atan2(|P - C| in Oxy, zC - zP), which needs no radii) [deg] and "BALL.slip_margin"
(mu N - |F_t| while N > 0, else N: the rolling condition's margin, as
outputs.validity) [N].

The grinding indicators (docs/design.md section 13): the mean grinding power after
the start-up (the ball's P_grind integrated over [after, stop] by the trapezoidal rule,
divided by that time), the fraction of that time the contact point spends in the
material bed (s_bed > 0), the grinding work per crank revolution (that integral
divided by the drive's revolutions psi / 2 pi over the same window) and the shell area
swept inside the bed (`swept_area`: the union of the ball's footprints, the shell points
within its angular radius asin(r / (R - r)) of the contact point, along the path while
s_bed > 0; it needs the references "BALL.r" and "BALL.R", and is reported only for a ball
with a bed, "BALL.bed" = 1: with the material everywhere it would be the area of the whole
path, a different measure, and on the wide rings of the bed-less scenarios it costs several
times the point's run). The margins
(slip_margin_min, N_min) are taken over the run up to and including the first sample
where the model stopped holding, so that a design that fails reports the margin it failed
by (<= 0) instead of nothing: what an optimiser's constraint needs.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

_OFFSET = re.compile(r"^(.+?)\s*([+-]\s*\d+(?:\.\d*)?(?:[eE][+-]?\d+)?)$")

# name -> (unit, description); the order is the order of the results' columns
BUILTIN = {
    "N_max": ("N", "largest normal force over the run"),
    "N_range_after": ("N", "variation of N after the start-up: max - min of N over [after, stop]"),
    "ring_inner": ("m", "inner radius of the ring of the contact point in Oxy after the start-up"),
    "ring_outer": ("m", "outer radius of the ring of the contact point in Oxy after the start-up"),
    "ring_width": ("m", "width of the ring: ring_outer - ring_inner"),
    "theta_min_deg": ("deg", "lowest polar angle of the contact point (from the bottom) after the start-up"),
    "theta_max_deg": ("deg", "highest polar angle of the contact point after the start-up"),
    "zP_max": ("m", "highest contact point over the run"),
    "friction_ratio_max": ("1", "largest |F_t| / N over the run (rolling needs <= mu)"),
    "T_drive_peak": ("N.m", "largest |T_drive| over the run, T_drive = J_total psi'' - M_reaction"),
    "T_drive_rms": ("N.m", "RMS of T_drive over the run"),
    "E_startup": ("J", "energy the drive delivers during the start-up: integral of T_drive psi' over [start, after]"),
    "P_drive_peak": ("W", "largest |P_drive| over the run, P_drive = T_drive psi'"),
    "P_grind_mean": ("W", "mean grinding power after the start-up: integral of P_grind over [after, stop] / its "
                          "duration"),
    "bed_fraction": ("1", "fraction of the time after the start-up the contact point is in the material bed "
                          "(s_bed > 0)"),
    "W_grind_rev": ("J", "grinding work per crank revolution after the start-up: integral of P_grind over "
                         "[after, stop] / the revolutions psi / 2 pi made in it"),
    "A_swept_bed": ("m2", "shell area swept inside the bed after the start-up: the union of the ball's footprints "
                          "(shell points within the ball's angular radius asin(r / (R - r)) of the contact point, "
                          "seen from the chamber's centre) along the path while s_bed > 0"),
    "slip_margin_min": ("N", "smallest rolling margin mu N - |F_t| (N where N <= 0) up to the first failure "
                             "(> 0: the ball kept rolling)"),
    "N_min": ("N", "smallest normal force up to the first failure, the lift-off margin (> 0: the ball kept "
                   "contact)"),
}
VALIDITY = {
    "valid": ("", "the model held over the whole run: N > 0 and |F_t| <= mu N at every sample"),
    "t_invalid": ("s", "first sample where it did not (None when valid)"),
}
VALIDITY_HYBRID = {  # evaluate_hybrid's: the hybrid model follows slip, flight and impacts
    "valid": ("", "the hybrid run reached the end (it stops early only on what it cannot follow, a Zeno "
                  "sequence of impacts)"),
    "t_invalid": ("s", "first sample the run did not reach (None when valid)"),
}


@dataclass
class Record:
    """One point's sampled run. ``series``: "instance.variable" -> array over ``t``;
    ``ball``/``drive``: instance names; ``mu``: friction coefficient; ``refs``: window
    references -> seconds ("start", "stop", "after" and every "instance.parameter")."""

    t: np.ndarray
    series: dict
    ball: str
    drive: str | None
    mu: float
    refs: dict = field(default_factory=dict)
    derived: dict = field(default_factory=dict)
    stopped_at: int | None = None  # a run that stopped early: the first sample it did not reach

    def get(self, name: str) -> np.ndarray:
        if name in self.series:
            return self.series[name]
        if name in self.derived:
            return self.derived[name]
        v = self._derive(name, slice(None))
        self.derived[name] = v
        return v

    def over(self, name: str, sl: slice) -> np.ndarray:
        """``get(name)[sl]``; a derived variable not yet derived is computed over sl only (element
        by element the same values: what an indicator over a window needs, not the whole run)."""
        if name in self.series:
            return self.series[name][sl]
        if name in self.derived:
            return self.derived[name][sl]
        return self._derive(name, sl)

    def _derive(self, name: str, sl: slice) -> np.ndarray:
        b = self.ball + "."
        s = self.series
        if name == b + "rhoP":
            v = np.hypot(s[b + "xP"][sl], s[b + "yP"][sl])
        elif name == b + "theta_deg":
            xP, yP, zP = s[b + "xP"][sl], s[b + "yP"][sl], s[b + "zP"][sl]
            v = np.degrees(np.arctan2(np.hypot(xP - s[b + "xC"][sl], yP - s[b + "yC"][sl]), s[b + "zC"][sl] - zP))
        elif name == b + "slip_margin":
            N = s[b + "N"][sl]
            ft = s.get(b + "Ft")
            with np.errstate(invalid="ignore", over="ignore"):
                margin = self.mu * N - ft[sl] if ft is not None else N * (self.mu - s[b + "friction_ratio"][sl])
            v = np.where(N > 0.0, margin, N)
        else:
            known = sorted(s) + [b + "rhoP", b + "theta_deg", b + "slip_margin"]
            raise KeyError(f"no recorded variable {name!r} (recorded: {', '.join(known)})")
        return v

    def time_of(self, ref) -> float:
        if isinstance(ref, (int, float)) and not isinstance(ref, bool):
            return float(ref)
        if ref in self.refs:
            return float(self.refs[ref])
        m = _OFFSET.match(str(ref))
        if m and m.group(1).strip() in self.refs:  # "after+10", "stop-5"
            return float(self.refs[m.group(1).strip()]) + float(m.group(2).replace(" ", ""))
        raise KeyError(f"window reference {ref!r}: not a number of seconds, 'start', 'after', 'stop' "
                       f"or a parameter of the scenario, optionally +- seconds "
                       f"(known: {', '.join(sorted(self.refs))})")


def validity(t, N, friction_ratio, mu: float):
    """(valid, t_invalid or None, index of the first bad sample or len(t)).
    Bad: N <= 0 (contact lost) or not friction_ratio <= mu (slip; NaN counts as bad)."""
    N = np.asarray(N, dtype=float)
    fr = np.asarray(friction_ratio, dtype=float)
    bad = ~((N > 0.0) & (fr <= mu))
    if not bad.any():
        return True, None, len(t)
    i = int(np.argmax(bad))
    return False, float(t[i]), i


def _refine(t, x, i, sign):
    """The extremum of the parabola through samples i-1, i, i+1 (sign +1: max, -1: min);
    the sample itself at the ends or when the parabola does not bend the right way."""
    if i <= 0 or i >= len(x) - 1:
        return float(x[i])
    # Python floats (the same IEEE doubles as numpy's, without numpy's per-scalar overhead)
    y0, y1, y2 = x[i - 1:i + 2].tolist()
    ta, tb, tc = t[i - 1:i + 2].tolist()
    h0, h1 = tb - ta, tc - tb
    if not (h0 > 0 and h1 > 0) or abs(h0 - h1) > 1e-9 * (h0 + h1):
        return y1
    curv = y0 - 2.0 * y1 + y2  # h^2 x''
    if sign * curv >= 0.0:
        return y1
    slope = 0.5 * (y2 - y0)  # h x'
    return y1 - slope * slope / (2.0 * curv)


def _window(rec: Record, a, b, n_valid: int):
    """Slice of the samples in [a, b], or None when they reach past the valid span or are empty."""
    ta, tb = rec.time_of(a), rec.time_of(b)
    t = rec.t
    eps = 1e-9 * max(1.0, abs(tb))
    i0 = int(t.searchsorted(ta - eps, side="left"))
    i1 = int(t.searchsorted(tb + eps, side="right"))
    if i1 <= i0 or i1 > n_valid:
        return None
    return slice(i0, i1)


def statistic(rec: Record, x: np.ndarray, stat: str, window, n_valid: int):
    """A statistic of x over the window, or None (see the module docstring)."""
    return _stat(rec.t, x, stat, _window(rec, window[0], window[1], n_valid))


def _ext(t, x, sl: slice, sign: int) -> float:
    """The largest (sign +1) or smallest (-1) value of x in the slice, refined by the parabola
    through its neighbours when it lies at an interior sample of the slice."""
    w = x[sl]
    i = int(w.argmax()) if sign > 0 else int(w.argmin())
    if 0 < i < len(w) - 1:
        return _refine(t, x, sl.start + i, sign)
    return float(w[i])


def _stat(t, x, stat: str, sl):
    if sl is None:
        return None
    if stat == "max":
        return _ext(t, x, sl, 1)
    if stat == "min":
        return _ext(t, x, sl, -1)
    if stat == "abs_max":
        return max(_ext(t, x, sl, 1), -_ext(t, x, sl, -1))
    if stat in ("range", "amplitude"):
        d = _ext(t, x, sl, 1) - _ext(t, x, sl, -1)
        return d if stat == "range" else 0.5 * d
    w = x[sl]
    if stat == "rms":
        return float(np.sqrt(w.dot(w) / len(w)))
    if stat == "mean":
        return float(w.mean())
    if stat == "integral":
        return _trapezoid(w, np.diff(t[sl])) if len(w) > 1 else 0.0
    raise ValueError(f"unknown statistic {stat!r}")


def _trapezoid(w, dt) -> float:
    """The trapezoidal rule's integral of the samples w over the time steps dt (len(w) - 1 of them)."""
    return float((0.5 * (w[1:] + w[:-1])).dot(dt))


def builtin(rec: Record, n_valid: int) -> dict:
    """The BUILTIN indicators of a record (None where not reported)."""
    b = rec.ball + "."
    t = rec.t
    after = _window(rec, "after", "stop", n_valid)  # each window found once
    run = _window(rec, "start", "stop", n_valid)
    st = lambda name, stat, sl: None if sl is None else _stat(t, rec.get(name), stat, sl)  # noqa: E731
    out = {"N_max": st(b + "N", "max", run), "N_range_after": st(b + "N", "range", after)}
    inner, outer = _extrema(rec, b + "rhoP", after)
    out.update(ring_inner=inner, ring_outer=outer,
               ring_width=None if inner is None or outer is None else outer - inner)
    low, high = _extrema(rec, b + "theta_deg", after)
    out.update(theta_min_deg=low, theta_max_deg=high,
               zP_max=st(b + "zP", "max", run), friction_ratio_max=st(b + "friction_ratio", "max", run))
    if rec.drive is not None and f"{rec.drive}.T_drive" in rec.series:
        d = rec.drive + "."
        out.update(T_drive_rms=st(d + "T_drive", "rms", run),
                   E_startup=st(d + "P_drive", "integral", _window(rec, "start", "after", n_valid)))
    else:
        out.update(T_drive_rms=None, E_startup=None)
    out.update(_mill(rec, n_valid, run, after))
    return {name: out[name] for name in BUILTIN}


def _extrema(rec: Record, name: str, sl) -> tuple:
    """(min, max) of a variable over the samples sl, as `_stat`'s, a derived one computed over sl
    only; (None, None) for no window."""
    if sl is None:
        return None, None
    t, x, w = rec.t[sl], rec.over(name, sl), slice(0, sl.stop - sl.start)
    return _ext(t, x, w, -1), _ext(t, x, w, 1)


MILL = ("T_drive_peak", "P_drive_peak", "P_grind_mean", "bed_fraction", "W_grind_rev", "A_swept_bed",
        "slip_margin_min", "N_min")


def mill(rec: Record, n_valid: int) -> dict:
    """The indicators a mill is designed by (MILL: the drive's peaks, the grinding ones, the
    margins), from whatever the record holds (None for what it lacks); `builtin` reports them
    among the others and the scenario summary (ballmill.scenario.report) on their own."""
    return _mill(rec, n_valid, _window(rec, "start", "stop", n_valid), _window(rec, "after", "stop", n_valid))


def _mill(rec: Record, n_valid: int, run, after) -> dict:
    """`mill` with the windows [start, stop] and [after, stop] found by the caller."""
    b = rec.ball + "."
    t = rec.t
    st = lambda name, stat, sl: None if sl is None else _stat(t, rec.get(name), stat, sl)  # noqa: E731
    d = f"{rec.drive}." if rec.drive is not None else None
    out = {"T_drive_peak": st(d + "T_drive", "abs_max", run) if d and d + "T_drive" in rec.series else None,
           "P_drive_peak": st(d + "P_drive", "abs_max", run) if d and d + "P_drive" in rec.series else None}
    out.update(grinding(rec, after))
    # the margins: up to and including the first failure (the sample that failed)
    upto = _window(rec, "start", "stop", len(t))
    if upto is not None:
        upto = slice(upto.start, min(upto.stop, n_valid + 1))
    friction = b + "Ft" in rec.series or b + "friction_ratio" in rec.series
    out["slip_margin_min"] = st(b + "slip_margin", "min", upto) if friction else None
    out["N_min"] = st(b + "N", "min", upto)
    return out


def grinding(rec: Record, sl) -> dict:
    """P_grind_mean [W], bed_fraction [1], W_grind_rev [J] and A_swept_bed [m2] over the samples sl
    (None: not reported; also when the ball's P_grind, resp. s_bed, resp. the drive's psi, resp.
    the ball's radii "BALL.r", "BALL.R" among the record's references, is not recorded; the swept
    area also when the ball has no bed, "BALL.bed" != 1)."""
    b = rec.ball + "."
    out = dict.fromkeys(("P_grind_mean", "bed_fraction", "W_grind_rev", "A_swept_bed"))
    if sl is None or sl.stop - sl.start < 2:
        return out
    t = rec.t[sl]
    dt = np.diff(t)  # the window's steps, for both integrals
    if b + "s_bed" in rec.series:
        in_bed = rec.series[b + "s_bed"][sl] > 0.0
        out["bed_fraction"] = _trapezoid(in_bed.astype(float), dt) / float(t[-1] - t[0])
        r, R = rec.refs.get(b + "r"), rec.refs.get(b + "R")
        bed = rec.refs.get(b + "bed") == 1  # a bed of depth h_bed (with bed = 0 the material is everywhere)
        if bed and r is not None and R is not None and all(b + v in rec.series
                                                           for v in ("xP", "yP", "zP", "xC", "yC", "zC")):
            s = rec.series
            u = np.column_stack([s[b + "xP"][sl] - s[b + "xC"][sl], s[b + "yP"][sl] - s[b + "yC"][sl],
                                 s[b + "zP"][sl] - s[b + "zC"][sl]])
            out["A_swept_bed"] = swept_area(u, in_bed, R, footprint(r, R))
    if b + "P_grind" not in rec.series:
        return out
    work = _trapezoid(rec.series[b + "P_grind"][sl], dt)
    out["P_grind_mean"] = work / float(t[-1] - t[0])
    psi = rec.series.get(f"{rec.drive}.psi") if rec.drive is not None else None
    if psi is not None:
        turns = abs(float(psi[sl][-1] - psi[sl][0])) / (2.0 * math.pi)
        out["W_grind_rev"] = work / turns if turns > 0.0 else None
    return out


BANDS_PER_FOOTPRINT = 8  # swept_area's bands of polar angle per footprint radius
CELLS_PER_FOOTPRINT = 10  # its cells of longitude per footprint radius (on the equator)


def footprint(r: float, R: float) -> float:
    """The ball's footprint on the shell [rad]: its angular radius seen from the chamber's centre,
    asin(r / (R - r)) (the shell points whose radius from the centre passes through the ball)."""
    return math.asin(min(1.0, r / (R - r)))


def swept_area(u, inside, R: float, alpha: float) -> float:
    """Area [m2] of the set of points of the sphere of radius R within angular distance alpha of
    the path u (unit vectors from the sphere's centre, rows) where ``inside`` holds, the arc
    between two consecutive inside samples included (great-circle arcs, subdivided to alpha / 4:
    between two caps so spaced the union's edge dips by at most 0.8 % of alpha).

    Computed on a grid of the sphere: bands of polar angle theta (from the bottom, -z)
    alpha / BANDS_PER_FOOTPRINT high, each cut into equal cells of longitude
    (alpha / CELLS_PER_FOOTPRINT on the equator); a cell is covered when its middle lies in a
    cap (the cap's half-width in longitude at the band's middle theta, closed form), and the
    area is the covered share of each band times the band's zone area 2 pi R^2 (cos theta_a -
    cos theta_b). The bands start and end at the path's extreme theta -+ alpha, so a zone of
    latitude comes out within the sag of the arcs between kept samples (0.1 %); a circle about a
    tilted axis within 1.1 % of its closed form, a wandering path within 0.2 % of a Monte Carlo
    count (tests/test_bed.py)."""
    u = np.asarray(u, float)
    inside = np.asarray(inside, bool)
    if not inside.any() or alpha <= 0.0:
        return 0.0
    u = u / np.linalg.norm(u, axis=1)[:, None]
    step = alpha / 4.0
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0))
    both = inside[:-1] & inside[1:]
    # samples closer than step along the path add nothing: keep one per step of arc length, and
    # every run's ends
    arc = np.cumsum(np.concatenate([[0.0], np.where(both, ang, 0.0)]))
    run = np.cumsum(np.concatenate([[1], ~both]))  # samples i, i + 1 lie in one run of the bed when both[i]
    ends = np.ones(len(u), bool)
    ends[1:-1] = ~(both[:-1] & both[1:])
    cell = np.floor(arc / step)
    keep = inside & (ends | np.concatenate([[True], cell[1:] != cell[:-1]]))
    u, run = u[keep], run[keep]
    # the arcs between consecutive kept samples of one run, subdivided to step (chords normalised
    # onto the sphere)
    both = run[:-1] == run[1:]
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0))
    k = np.where(both, np.ceil(ang / step).astype(int), 0)
    pts = [u]
    extra = np.maximum(k - 1, 0)  # points inserted in each arc
    if extra.any():
        seg = np.repeat(np.arange(len(k)), extra)
        j = np.arange(len(seg)) - np.repeat(np.cumsum(extra) - extra, extra) + 1  # 1 .. k - 1 in each arc
        frac = j / np.repeat(k, extra)
        mid = u[seg] + frac[:, None] * (u[seg + 1] - u[seg])
        pts.append(mid / np.linalg.norm(mid, axis=1)[:, None])
    p = np.concatenate(pts)
    theta = np.arccos(np.clip(-p[:, 2], -1.0, 1.0))
    phi = np.arctan2(p[:, 1], p[:, 0])
    order = np.argsort(theta)
    theta, phi = theta[order], phi[order]
    lo, hi = max(0.0, theta[0] - alpha), min(math.pi, theta[-1] + alpha)
    nb = max(1, int(math.ceil((hi - lo) / (alpha / BANDS_PER_FOOTPRINT))))
    edges = np.linspace(lo, hi, nb + 1)
    mids = 0.5 * (edges[:-1] + edges[1:])
    zone = 2.0 * math.pi * R * R * (np.cos(edges[:-1]) - np.cos(edges[1:]))  # each band's area
    # every (band, point) pair whose cap reaches the band's middle circle: the cap's half-width in
    # longitude there, cos(half) = (cos alpha - cos theta_b cos theta) / (sin theta_b sin theta)
    # (<= -1: the whole circle, also for a point at the pole within alpha; >= 1: none)
    first = np.searchsorted(theta, mids - alpha, side="left")
    count = np.searchsorted(theta, mids + alpha, side="right") - first
    band = np.repeat(np.arange(nb), count)
    j = np.arange(band.size) - np.repeat(np.cumsum(count) - count, count) + np.repeat(first, count)
    st, ct = np.sin(theta), np.cos(theta)
    c = (math.cos(alpha) - np.cos(mids)[band] * ct[j]) / np.maximum(np.sin(mids)[band] * st[j], 1e-300)
    hit = c < 1.0
    band, half, ph = band[hit], np.arccos(np.maximum(c[hit], -1.0)), phi[j[hit]]
    # each band's circle cut into cols cells of longitude; a cell is covered when its middle
    # lies in an interval [phi - half, phi + half] (counted on a difference array, summed along the band)
    cols = int(math.ceil(2.0 * math.pi / (alpha / CELLS_PER_FOOTPRINT)))
    width = 2.0 * math.pi / cols
    a = np.ceil((ph - half) / width - 0.5).astype(np.int64)  # first covered cell (may be < 0: wraps)
    n = np.floor((ph + half) / width - 0.5).astype(np.int64) - a + 1  # cells covered
    n = np.minimum(n, cols)
    a = np.mod(a, cols)
    b = a + n  # one past the last, up to 2 cols - 1 (the rest wraps to the band's start)
    row = band * (cols + 1)
    wrap = b > cols
    size = nb * (cols + 1)
    diff = (np.bincount(np.concatenate([row + a, row[wrap]]), minlength=size)
            - np.bincount(np.concatenate([row + np.minimum(b, cols), (row + b - cols)[wrap]]), minlength=size))
    # each row's marks sum to 0 (every interval ends in its own band): one running sum over all
    covered = np.count_nonzero((np.cumsum(diff) > 0).reshape(nb, cols + 1), axis=1)
    return float(zone.dot(covered) / cols)


# the hybrid ball's own indicators (a study with a [contact] table, evaluator "hybrid-kernel"), over
# the run [start, stop]; the record holds the hybrid model's columns (mode, the bookkeeping)
HYBRID = {
    "rolling_fraction": ("1", "fraction of the run [start, stop] the ball rolls (mode 1; trapezoidal rule on "
                              "the samples)"),
    "sliding_fraction": ("1", "fraction of the run the ball slides on the wall (mode 2)"),
    "flight_fraction": ("1", "fraction of the run the ball flies (mode 0)"),
    "n_impacts": ("1", "number of impacts on the shell over the run"),
    "v_impact_max": ("m/s", "largest approaching normal speed of an impact over the run (0 without impacts)"),
    "E_friction": ("J", "energy lost to sliding friction over the run (E_friction at the end - at the start)"),
    "E_impact": ("J", "energy lost in impacts over the run (E_impact at the end - at the start)"),
    "E_friction_rev": ("J", "energy lost to sliding friction per crank revolution over the run: E_friction at "
                            "the end / the revolutions psi / 2 pi"),
    "E_impact_rev": ("J", "energy lost in impacts per crank revolution over the run: E_impact at the end / the "
                          "revolutions"),
    "t_first_slip": ("s", "time of the first slip (None: the ball never slid)"),
    "t_first_flight": ("s", "time the ball first left the wall (None: never)"),
}


NEVER = 1e299  # at or above: the FMUs' "not yet" (1e300) of a time such as t_first_slip


def hybrid(rec: Record, n_valid: int) -> dict:
    """The HYBRID indicators over the samples [start, stop] up to n_valid (None where the run
    stopped before the window's end: the counts and energies are then not those of the run)."""
    b = rec.ball + "."
    out = dict.fromkeys(HYBRID)
    sl = _window(rec, "start", "stop", n_valid)
    if sl is None or sl.stop - sl.start < 2:
        return out
    t, mode = rec.t[sl], rec.series[b + "mode"][sl]
    span = float(t[-1] - t[0])
    for name, m in (("rolling_fraction", 1.0), ("sliding_fraction", 2.0), ("flight_fraction", 0.0)):
        inside = (mode == m).astype(float)
        out[name] = float((0.5 * (inside[1:] + inside[:-1])).dot(np.diff(t)) / span)
    last = sl.stop - 1  # the bookkeeping is cumulative: its value at the window's end
    out["n_impacts"] = float(rec.series[b + "n_impacts"][last] - rec.series[b + "n_impacts"][sl.start])
    out["v_impact_max"] = float(rec.series[b + "v_impact_max"][last])
    for name in ("t_first_slip", "t_first_flight"):
        v = float(rec.series[b + name][last])
        out[name] = v if math.isfinite(v) and abs(v) < NEVER else None  # NaN (library), 1e300 (FMU): never
    for name in ("E_friction", "E_impact"):
        e = rec.series[b + name]
        out[name] = float(e[last] - e[sl.start])
    psi = rec.series.get(f"{rec.drive}.psi") if rec.drive is not None else None
    if psi is not None:
        turns = abs(float(psi[last] - psi[sl.start])) / (2.0 * math.pi)
        if turns > 0.0:
            for name in ("E_friction", "E_impact"):
                out[name + "_rev"] = out[name] / turns
    return out


def evaluate_hybrid(rec: Record, custom=(), stopped_at: int | None = None) -> dict:
    """Every indicator of a hybrid run's record: BUILTIN and HYBRID, the custom ones, valid and
    t_invalid. The hybrid model follows slip, flight and impacts, so the rolling rule of
    `validity` does not apply: the run is valid unless it stopped early (``stopped_at``: the
    index of the first sample it did not reach, e.g. after a Zeno sequence), and a statistic
    whose window reaches past that sample is not reported."""
    n_valid = len(rec.t) if stopped_at is None else stopped_at
    out = builtin(rec, n_valid)
    out.update(hybrid(rec, n_valid))
    for ind in custom:
        out[ind.name] = statistic(rec, rec.get(ind.variable), ind.stat, ind.window, n_valid)
    out["valid"] = stopped_at is None
    out["t_invalid"] = None if stopped_at is None else float(rec.t[stopped_at])
    return out


def evaluate(rec: Record, custom=()) -> dict:
    """Every indicator of a record: BUILTIN, then the custom ones, then valid and t_invalid."""
    b = rec.ball + "."
    valid, t_invalid, n_valid = validity(rec.t, rec.get(b + "N"), rec.get(b + "friction_ratio"), rec.mu)
    out = builtin(rec, n_valid)
    for ind in custom:
        out[ind.name] = statistic(rec, rec.get(ind.variable), ind.stat, ind.window, n_valid)
    out["valid"] = valid
    out["t_invalid"] = t_invalid
    return out


def clean(v):
    """A float for the results (None for None, NaN and infinities)."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None
