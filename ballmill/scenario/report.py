"""Results of a scenario run: results.csv, summary.json and the plots.

The summary holds what a mill engineer reads first: the ball's pressure N
(over the run and after the start-up), the ring of the contact point in the
Oxy plane, the highest contact point, the peak reaction torque, whether the
model stayed valid (contact, rolling) and when it first failed, and the
wall time. A ball absorber scenario (``[summary] structure = "NAME"``, a
Structure instance) gets instead what a tower engineer reads
(ballmill.absorber.summary.structure_summary): peak and RMS displacement and
acceleration of the structure at the absorber, their reduction against the
bare structure (the same scenario without the ball, run by `ballmill run`),
the ball's largest excursion and whether it kept rolling; and a plot of the
structure's displacement with and without the ball.
A ball in a turning chamber (BallInShell with motion = 2: outputs
xP_ch, yP_ch, zP_ch) adds the fraction of the shell its contact point visits
(ballmill/plotting/shell.py) and the failure times interpolated between samples.
A hybrid ball (BallInShell with contact_model = 2: it slides, flies and strikes the shell, and stays
valid through all of it) adds the hybrid indicators (`hybrid`: the fractions of time rolling,
sliding and flying, the impacts, the friction and impact losses, per crank revolution where a
drive's psi is recorded; ballmill.sweep.indicators.hybrid computes them, as for the studies); its
time plots mark the sliding and the flight spans and the impacts (`mark_hybrid`) and its shell
drawing colours the path by mode (ballmill/plotting/shell.py's draw_modes).

Plots ([[plots]]): time series or x-y curves of recorded variables; ``kind =
"shell"``: the contact point's path on the chamber's sphere, two equal-area
hemispheres (``ball = "ball"``, the instance); ``kind = "slip_margin"``: the
ball's mu - friction_ratio (rolling while positive) with the first failure marked.
They show what the run used and found: titles filled from its parameters (spec.fill),
vertical lines at its parameters' values and labelled, on every time plot the span
after the ball model's validity ended shaded and labelled with why (validity_end), on
an x-y plot the start-up, the rest and the invalid rows in three colours (and the
summary's ring radii on the ring), labels and legends in words with units from the
FMUs' declaration (ballmill/plotting/labels.py) unless the scenario gives its own.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..plotting import labels, shell
from . import spec as _spec
from .runner import RunResult

SHELL_OUTPUTS = ("xP_ch", "yP_ch", "zP_ch")  # BallInShell's contact point in the chamber's axes


def _ball_instance(res: RunResult) -> str | None:
    sc = res.scenario
    name = sc.summary.get("ball")
    if name:
        return name
    for n, inst in sc.instances.items():
        if inst.fmu == "BallInShell":
            return n
    return None


def _parameter(res: RunResult, models, inst: str, param: str) -> float:
    """A parameter's value in the run: the scenario's, else the model's start value."""
    return float(_spec.parameter_value(res.scenario, models, inst, param))


def _after_time(res: RunResult, models) -> float:
    """Start of the 'after start-up' window: a number or 'instance.parameter'."""
    sc = res.scenario
    after = sc.summary.get("after", sc.start)
    if isinstance(after, str):
        inst, param = after.split(".", 1)
        return _parameter(res, models, inst, param)
    return float(after)


def _failures(res: RunResult, models, ball: str) -> dict:
    """{flag: time} of the first failure of the ball's `contact` and `rolling` outputs (None:
    never), between the samples where the flag first turns false: where the margin (N, resp.
    mu N - F_t) changes sign there, the zero of its linear interpolation, else that sample's
    time [s]."""
    t, cols = res.column("time"), set(res.columns)
    N = res.column(f"{ball}.N") if f"{ball}.N" in cols else None
    margins = {"contact": N}
    if N is not None and f"{ball}.Ft" in cols:
        mu = _parameter(res, models, ball, "mu")
        margins["rolling"] = np.where(N > 0, mu * N - res.column(f"{ball}.Ft"), N)
    out = {}
    for flag in ("contact", "rolling"):
        if f"{ball}.{flag}" not in cols:
            continue
        bad = np.flatnonzero(res.column(f"{ball}.{flag}") < 0.5)
        if not bad.size:
            out[flag] = None
            continue
        i, m = int(bad[0]), margins.get(flag)
        if i > 0 and m is not None and m[i - 1] > 0.0 >= m[i]:
            out[flag] = shell.first_failure(t[i - 1:i + 1], m[i - 1:i + 1])
        else:
            out[flag] = float(t[i])
    return out


def validity_end(res: RunResult, ball: str, hybrid: bool = False):
    """Where the ball model's validity ended: (index of the first row with valid false, t_invalid
    [s] (the FMU's, else that row's time), why: "loss of contact", "slip", or "inconsistent
    inputs" when contact and rolling held at that row; "see log" without them; for a hybrid ball
    (``hybrid``: contact_model = 2, whose validity survives slip and flight) "inconsistent inputs or
    a Zeno sequence (the ball held on the wall from there)", what it cannot follow; a step it
    cannot integrate is refused, not latched), or None while valid (or without a recorded `valid`)."""
    cols = set(res.columns)
    if f"{ball}.valid" not in cols:
        return None
    bad = np.flatnonzero(res.column(f"{ball}.valid") < 0.5)
    if not bad.size:
        return None
    i = int(bad[0])
    t_inv = float(res.column(f"{ball}.t_invalid")[i]) if f"{ball}.t_invalid" in cols else float(res.column("time")[i])
    if hybrid:
        return i, t_inv, "inconsistent inputs or a Zeno sequence (the ball held on the wall from there)"
    flags = [f for f in ("contact", "rolling") if f"{ball}.{f}" in cols]
    failed = [f for f in flags if res.column(f"{ball}.{f}")[i] < 0.5]
    if "contact" in failed:  # rolling needs contact: it fails with it
        why = "loss of contact"
    elif failed:
        why = "slip"
    else:
        why = "inconsistent inputs" if flags else "loss of contact, slip or inconsistent inputs"
    return i, t_inv, why


def _shell_unit_vectors(res: RunResult, models, ball: str):
    R = _parameter(res, models, ball, "R")
    return shell.unit_vectors(*(res.column(f"{ball}.{v}") for v in SHELL_OUTPUTS), R)


def _stats(x):
    return {"min": float(np.min(x)), "max": float(np.max(x)), "range": float(np.ptp(x))} if len(x) else None


def _structure_data(res: RunResult, st: str) -> dict:
    c = res.column
    return {"xO": c(f"{st}.x_rel"), "yO": c(f"{st}.y_rel"), "axO": c(f"{st}.ax1O"), "ayO": c(f"{st}.ay1O")}


STRUCTURE_RECORD = ("x_rel", "y_rel", "ax1O", "ay1O")  # what an absorber summary needs of the structure


def absorber_summary(res: RunResult, models, bare: RunResult | None = None) -> dict:
    """structure_summary of an absorber run (statistics after [summary] after), with the
    bare structure's run when given."""
    from ballmill.absorber.summary import structure_summary

    sc = res.scenario
    st = sc.summary["structure"]
    ball = _ball_instance(res)
    data = _structure_data(res, st)
    t = res.column("time")
    if ball:
        R = _parameter(res, models, ball, "R")
        zP = res.column(f"{ball}.zP")
        data.update({"xP": res.column(f"{ball}.xP"), "yP": res.column(f"{ball}.yP"), "N": res.column(f"{ball}.N"),
                     "friction_ratio": res.column(f"{ball}.friction_ratio"),
                     "theta": np.arccos(np.clip(1.0 - zP / R, -1.0, 1.0))})
    base = None
    if bare is not None and bare.success and len(bare.data) == len(res.data):
        base = _structure_data(bare, st)
    mu = _parameter(res, models, ball, "mu") if ball else None
    after = _after_time(res, models)
    try:
        out = structure_summary(t, data, base, mu=mu, after=after)
    except ValueError as e:  # the run stopped before [summary] after: say so, do not fail the report
        return {"from_s": after, "statistics": f"none: {e}"}
    if bare is not None and base is None:
        out["bare_structure"] = f"the bare run did not complete: {bare.message}"
    return out


def summarise(res: RunResult, models, bare: RunResult | None = None) -> dict:
    sc = res.scenario
    out = {"scenario": sc.name, "description": sc.description, "success": res.success,
           "message": res.message, "steps": res.steps, "wall_time_s": round(res.wall_time, 4),
           "startup_time_s": round(res.init_time, 4), "communication_step_s": sc.step,
           "parameters": {n: i.parameters for n, i in sc.instances.items()}}
    ball = _ball_instance(res)
    cols = set(res.columns)
    absorber = bool(sc.summary.get("structure"))
    hybrid = is_hybrid(res, models, ball)
    if absorber and len(res.data):
        out["structure"] = absorber_summary(res, models, bare)
    if ball and f"{ball}.N" in cols and len(res.data):
        t_all = res.column("time")
        # statistics over the model's valid span only (the rows before BallInShell's
        # latched valid became false); later rows stay in results.csv
        keep = np.ones(t_all.size, dtype=bool)
        if f"{ball}.valid" in cols:
            end = validity_end(res, ball, hybrid)
            if end is not None:
                i, t_inv, why = end
                keep[i:] = False
                out["left_validity"] = True
                out["t_invalid_s"] = t_inv
                out["invalid_reason"] = why
                out["statistics_over"] = (f"the valid span only, t < {t_all[i]:.6g} s: the model's "
                                          f"validity ended at t_invalid = {t_inv:.6g} s ({why}; see log); "
                                          f"later rows are in results.csv but not in these statistics")
            else:
                out["left_validity"] = False
                out["statistics_over"] = "the whole run (the model stayed valid throughout)"
        t = t_all[keep]
        after = _after_time(res, models)
        late = t >= after - 1e-12
        col = lambda v: res.column(f"{ball}.{v}")[keep]  # noqa: E731
        out["after_s"] = after
        out["valid_span_s"] = [float(t[0]), float(t[-1])] if t.size else None
        out["N"] = {"all": _stats(col("N")) if t.size else None,
                    "after": _stats(col("N")[late]) if late.any() else None}
        if {f"{ball}.xP", f"{ball}.yP"} <= cols and not absorber:
            rho = np.hypot(col("xP"), col("yP"))
            out["ring"] = {"inner_radius_m": float(rho[late].min()) if late.any() else None,
                           "outer_radius_m": float(rho[late].max()) if late.any() else None}
            out["ring"]["width_m"] = (out["ring"]["outer_radius_m"] - out["ring"]["inner_radius_m"]
                                      if late.any() else None)
        if f"{ball}.zP" in cols:
            out["zP_max_m"] = float(col("zP").max()) if t.size else None
        if f"{ball}.M_reaction" in cols and not absorber:  # a crank's torque: the mill's, not a tower's
            out["M_reaction_peak_abs_Nm"] = float(np.abs(col("M_reaction")).max()) if t.size else None
        t = t_all
        col = lambda v: res.column(f"{ball}.{v}")  # noqa: E731
        validity = {}
        if hybrid:  # slip and flight are the model's modes, not failures: the flags say which mode
            validity["note"] = ("the hybrid ball (contact_model = 2): slip, flight and impacts are followed and keep "
                                "the model valid; 'contact' and 'rolling' (where recorded) say when the ball first "
                                "left the wall and first stopped rolling, not failures")
        for flag in ("contact", "rolling"):
            if f"{ball}.{flag}" in cols:
                bad = np.flatnonzero(col(flag) < 0.5)
                validity[flag] = {"held_throughout": bool(bad.size == 0),
                                  "first_failure_s": float(t[bad[0]]) if bad.size else None}
        if f"{ball}.friction_ratio" in cols:
            fr = col("friction_ratio")
            validity["friction_ratio_max"] = float(fr[np.isfinite(fr) & (fr < 1e299)].max()) \
                if np.any(fr < 1e299) else None
        for flag, when in _failures(res, models, ball).items():
            if flag in validity:
                validity[flag]["first_failure_interpolated_s"] = when
        out["validity"] = validity
        if not absorber:
            out["indicators"] = mill_indicators(res, models, ball, hybrid)
        if hybrid:
            out["hybrid"] = hybrid_indicators(res, models, ball)
        if all(f"{ball}.{v}" in cols for v in SHELL_OUTPUTS):
            u = _shell_unit_vectors(res, models, ball)
            k = int(keep.sum())
            out["shell"] = {
                "visited_fraction_valid": shell.visited_fraction(u, k) if k else None,
                "visited_fraction_all": shell.visited_fraction(u),
                "cells": shell.N_CELLS,
                "measure": (f"fraction of {shell.N_CELLS} equal-area cells of the chamber's sphere that the "
                            f"contact point (chamber axes) visits at the recorded samples; 'valid': over the "
                            f"model's valid span, 'all': over the whole run (not physical after it)"),
                "z_ch_max_valid_m": float(col("zP_ch")[:k].max()) if k else None,
            }
    out["log"] = [m for m in res.messages if m["status"] != "ok"][:50]
    return out


def is_hybrid(res: RunResult, models, ball: str | None) -> bool:
    """Whether the ball is the hybrid one (BallInShell with contact_model = 2: spec.hybrid_balls)."""
    return bool(ball) and ball in _spec.hybrid_balls(res.scenario, models)


def _record(res: RunResult, models, ball: str):
    """The run as a ballmill.sweep.indicators.Record (the ball's and the drive's series, the
    window references), for the indicators the sweep computes."""
    from ..sweep import indicators as ind  # the module alone (ballmill.sweep imports lazily)

    sc = res.scenario
    t = res.column("time")
    series = {c: res.data[:, j] for j, c in enumerate(res.columns) if c != "time"}
    drive = next((si for si, sv, di, dv in sc.connections if di == ball and dv == "x1O"), None)
    mu = _parameter(res, models, ball, "mu")
    refs = {"start": float(t[0]), "stop": float(t[-1]), "after": _after_time(res, models)}
    for p in ("r", "R", "bed"):  # what the swept area needs (a model without them: not reported)
        try:
            refs[f"{ball}.{p}"] = _parameter(res, models, ball, p)
        except KeyError:
            pass
    return ind.Record(t, series, ball, drive, mu, refs)


def _hybrid_valid(res: RunResult, ball: str) -> int:
    """The rows a hybrid ball's statistics may use: up to the first with valid false (all: none)."""
    end = validity_end(res, ball, hybrid=True)
    return len(res.data) if end is None else end[0]


def _described(values: dict, table: dict) -> dict:
    from ..sweep import indicators as ind

    return {name: {"value": ind.clean(values[name]), "unit": table[name][0], "description": table[name][1]}
            for name in values}


def mill_indicators(res: RunResult, models, ball: str, hybrid: bool = False) -> dict:
    """The mill's design indicators (ballmill.sweep.indicators.mill: the drive's peak torque and
    power, the mean grinding power after the start-up, the fraction of time in the bed, the
    grinding work per crank revolution, the shell area swept inside the bed, the slip and
    lift-off margins), computed as the sweep
    computes them, each {"value": ..., "unit": ..., "description": ...} (value None where the run
    does not say: not recorded, or past the model's validity: the rolling rule N > 0 and
    |F_t| <= mu N, or for a hybrid ball, ``hybrid``, its latched `valid`, as the sweep's
    evaluate_hybrid)."""
    from ..sweep import indicators as ind

    rec = _record(res, models, ball)
    if hybrid:
        n_valid = _hybrid_valid(res, ball)
    else:
        N = rec.series[f"{ball}.N"]
        fr = rec.series.get(f"{ball}.friction_ratio", np.zeros_like(N))
        n_valid = ind.validity(rec.t, N, fr, rec.mu)[2]
    values = ind.mill(rec, n_valid)
    return _described({name: values[name] for name in ind.MILL}, ind.BUILTIN)


def hybrid_indicators(res: RunResult, models, ball: str) -> dict:
    """The hybrid ball's indicators (ballmill.sweep.indicators.hybrid, over the run [start, stop]:
    the fractions of time rolling, sliding and flying, n_impacts, v_impact_max, E_friction,
    E_impact, and per crank revolution where the drive's psi is recorded; t_first_slip,
    t_first_flight), each {"value", "unit", "description"}; None past the latched `valid`."""
    from ..sweep import indicators as ind

    return _described(ind.hybrid(_record(res, models, ball), _hybrid_valid(res, ball)), ind.HYBRID)


def write_csv(res: RunResult, path: Path):
    """The recorded columns as CSV: a header of the names, then every row with each value as
    "%.12g" (what numpy.savetxt(fmt="%.12g") writes, byte for byte), formatted in one operation
    over all the values rather than row by row. A column that holds the same float in every row
    (bit for bit: -0.0 is not 0.0; a quarter of fast_start's, parameters and flags) is formatted
    once, its text written into the row's format."""
    data = np.ascontiguousarray(res.data, dtype=float)
    if data.ndim == 1:
        data = data[:, None]
    if not data.shape[0]:
        Path(path).write_text(",".join(res.columns) + "\n", encoding="utf-8")
        return
    same = (data.view(np.uint64) == data[:1].view(np.uint64)).all(axis=0)
    row = ",".join(("%.12g" % v).replace("%", "%%") if c else "%.12g" for v, c in zip(data[0].tolist(), same))
    rows = "\n".join([row] * data.shape[0]) % tuple(data[:, ~same].ravel().tolist())
    Path(path).write_text(",".join(res.columns) + "\n" + rows + "\n", encoding="utf-8")


def _plot_shell(res: RunResult, models, spec, plt):
    ball = spec.get("ball") or _ball_instance(res)
    t = res.column("time")
    if is_hybrid(res, models, ball):  # the path by mode, the impacts marked (shell.draw_modes)
        fig, axes = plt.subplots(1, 2, figsize=(9.0, 4.9), layout="constrained")
        n_ok = _hybrid_valid(res, ball)
        mode, count = res.column(f"{ball}.mode"), res.column(f"{ball}.n_impacts")
        shell.draw_modes(axes, _shell_unit_vectors(res, models, ball), mode, impact_rows(count[:n_ok]), n_ok,
                         impacts=int(count[n_ok - 1] - count[0]) if n_ok else 0)
        fig.suptitle(f"{spec.get('title', 'Contact point on the shell')}\n({shell.CAPTION})", fontsize=10)
        return fig
    fail = _failures(res, models, ball)
    t_fail = min((v for v in fail.values() if v is not None), default=None)
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 4.9), layout="constrained")
    # colours over the model's valid span (the path after a failure is grey)
    sm = shell.draw_hemispheres(axes, _shell_unit_vectors(res, models, ball), t, t_fail,
                                float(t[-1]) if t_fail is None else t_fail, fail_label="rolling or contact fails")
    fig.colorbar(sm, ax=axes, shrink=0.7, label="time [s]")
    fig.suptitle(f"{spec.get('title', 'Contact point on the shell')}\n({shell.CAPTION})", fontsize=10)
    return fig


def _plot_slip_margin(res: RunResult, models, spec, plt):
    ball = spec.get("ball") or _ball_instance(res)
    t = res.column("time")
    mu = _parameter(res, models, ball, "mu")
    fr = res.column(f"{ball}.friction_ratio")
    fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="tight")
    ax.plot(t, np.where(fr >= 1e299, np.nan, mu - fr), lw=0.8 if len(t) > 2000 else 1.2,
            label=f"mu - friction_ratio (mu = {mu:g})")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylim(-mu, 1.05 * mu)  # from rolling freely (mu) to well past slip; spikes beyond are cut
    # the rolling model's first failures (a hybrid ball slides and flies on: its marks show when)
    fail = {} if is_hybrid(res, models, ball) else _failures(res, models, ball)
    for flag, style in (("rolling", ":"), ("contact", "--")):
        if fail.get(flag) is not None:
            ax.axvline(fail[flag], color="tab:red", ls=style, lw=1.0, label=f"{flag} first fails, "
                       f"t = {fail[flag]:.4f} s")
    _mark_time(ax, res, models, float(t[-1]))
    ax.set_xlabel("time [s]")
    ax.set_ylabel(spec.get("ylabel", "slip margin mu - F_t / N [1] (cut at -mu)"))
    ax.set_title(spec.get("title", "Slip margin: the ball rolls while positive"))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


INVALID_SPAN = {"facecolor": "0.55", "alpha": 0.3, "lw": 0, "zorder": 2.5}  # over the curves: they show greyed
PATH_COLOURS = {"start-up": "tab:orange", "after": "tab:blue", "invalid": "0.7"}


def _declared(sc, name: str):
    """The declared Variable behind a recorded "instance.variable" (None for a table's column)."""
    inst, _, var = name.partition(".")
    return labels.declared(sc.instances[inst].fmu if inst in sc.instances else None, var)


def _shown(name: str, names=()) -> str:
    """A recorded variable's name as printed: the variable's, or "variable of instance" when
    another of ``names`` has a variable of the same name."""
    inst, _, var = name.partition(".")
    return var if sum(n.partition(".")[2] == var for n in names) <= 1 else f"{var} of {inst}"


def _var_label(sc, name: str, names=(), width: int | None = None) -> str:
    """A recorded variable in words with its unit, from its FMU's declaration (ballmill/plotting/
    labels.py); a table's column by its name."""
    if name == "time":
        return "time [s]"
    var = _declared(sc, name)
    if var is None:
        return name
    return labels.label(None, var.name, _shown(name, names), unit=var.unit, description=var.description, width=width)


def _common_label(sc, ys) -> str:
    """The y axis of several variables: their names with the unit they share, else each with its own."""
    units = [labels.unit_text(getattr(_declared(sc, y), "unit", None)) for y in ys]
    shown = [_shown(y, ys) if _declared(sc, y) is not None else y for y in ys]
    if len(set(units)) == 1 and units[0]:
        return f"{', '.join(shown)} [{units[0]}]"
    return ", ".join(f"{n} [{u}]" if u else n for n, u in zip(shown, units))


def invalid_label(end) -> str:
    """The legend entry of the span after the model's validity ended (validity_end's answer)."""
    return f"ball model not valid ({end[2]} at {end[1]:.4g} s)"


def _shade_invalid(ax, res: RunResult, t_end: float, hybrid: bool = False):
    """Shade and label the span after the ball model's validity ended on a time plot."""
    ball = _ball_instance(res)
    end = validity_end(res, ball, hybrid) if ball else None
    if end is not None:
        ax.axvspan(end[1], max(t_end, end[1]), label=invalid_label(end), **INVALID_SPAN)
    return end


# a hybrid ball's marks on a time plot: its modes off rolling shaded (under the curves), its impacts ticked
MODE_SPANS = ((2, "ball slides on the wall (mode 2)", "tab:orange"),
              (0, "ball in flight (mode 0)", "tab:purple"))
MODE_SPAN = {"alpha": 0.22, "lw": 0, "zorder": 0.5}
IMPACT_TICK = {"colors": "tab:red", "lw": 0.7, "zorder": 2.6}
IMPACT_TICK_HEIGHT = 0.06  # of the axes' height, from the bottom


def mode_spans(t, mode, m) -> list[tuple[float, float]]:
    """The spans [s] in which the ball is in mode ``m``, every instant counted in the mode of the
    sample nearest to it: a run of rows i..j in that mode spans from the midpoint between rows
    i - 1 and i to that between j and j + 1, cut to [t[0], t[-1]]. The spans of the modes tile
    the run, and their lengths are the trapezoidal rule's fractions (indicators.hybrid) times it."""
    t = np.asarray(t, float)
    inside = np.asarray(mode) == m
    if not inside.any():
        return []
    edges = np.concatenate([t[:1], 0.5 * (t[1:] + t[:-1]), t[-1:]])  # row i covers edges[i]..edges[i + 1]
    change = np.diff(np.concatenate([[0], inside.astype(np.int8), [0]]))
    return [(float(edges[a]), float(edges[b])) for a, b in zip(np.flatnonzero(change == 1),
                                                                np.flatnonzero(change == -1))]


def impact_rows(n_impacts) -> np.ndarray:
    """The rows at the end of a communication step in which one or more impacts happened (the
    cumulative n_impacts rose since the row before)."""
    n = np.asarray(n_impacts, float)
    return np.flatnonzero(np.diff(n) > 0) + 1


def impacts_label(n: int, steps: int) -> str:
    """The legend entry of the impact ticks: how many impacts, and in how many steps (one tick each)."""
    return f"impacts on the shell: {n}, ticked at the end of each step with any ({steps} steps)"


def mark_hybrid(ax, res: RunResult, models) -> bool:
    """On a time plot of a hybrid ball (contact_model = 2): its sliding and its flight spans shaded
    (mode_spans) and its impacts as thin ticks at the bottom (impact_rows), each in the legend,
    over the rows up to its latched `valid` (the rest is shaded as not valid). False otherwise."""
    from matplotlib.collections import PolyCollection

    ball = _ball_instance(res)
    if not is_hybrid(res, models, ball):
        return False
    n = _hybrid_valid(res, ball)
    t, mode = res.column("time")[:n], res.column(f"{ball}.mode")[:n]
    for m, text, colour in MODE_SPANS:
        spans = mode_spans(t, mode, m)
        if spans:
            ax.add_collection(PolyCollection([[(a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0)] for a, b in spans],
                                             transform=ax.get_xaxis_transform(), facecolors=colour,
                                             label=text, **MODE_SPAN), autolim=False)
    count = res.column(f"{ball}.n_impacts")[:n]
    rows = impact_rows(count)
    if rows.size:
        ax.vlines(t[rows], 0.0, IMPACT_TICK_HEIGHT, transform=ax.get_xaxis_transform(),
                  label=impacts_label(int(count[-1] - count[0]), rows.size), **IMPACT_TICK)
    return True


def _mark_time(ax, res: RunResult, models, t_end: float):
    """Every time plot's marks: a hybrid ball's modes and impacts, the span after the ball
    model's validity ended."""
    return _shade_invalid(ax, res, t_end, mark_hybrid(ax, res, models))


def _vlines(ax, res: RunResult, models, spec):
    """The plot's vertical lines: a time [s], or "instance.parameter" drawn at the parameter's
    value in the run and labelled with it and its declared description."""
    sc = res.scenario
    for v in spec.get("vlines", []):
        if isinstance(v, str):
            inst, _, param = v.strip().partition(".")
            at = float(_spec.parameter_value(sc, models, inst, param))
            var = labels.declared(sc.instances[inst].fmu, param)
            what = labels.short(var.description) if var is not None else ""
            text = f"{param} = {at:g} s" + (f", {what[:1].lower()}{what[1:]}" if what else "")
        else:
            at, text = float(v), f"t = {float(v):g} s"
        ax.axvline(at, color="grey", ls="--", lw=0.8, label=text)


def _after_text(res: RunResult, after: float) -> str:
    ref = res.scenario.summary.get("after")
    return f"{ref.partition('.')[2]} = {after:g} s" if isinstance(ref, str) else f"{after:g} s"


def _draw_path(ax, res: RunResult, models, spec, lw, summary):
    """An x-y plot (a path, e.g. the contact point in Oxy): the start-up (before [summary] after)
    and the rest in two colours, the rows after the model's validity ended in grey; for the
    ball's xP, yP, the ring's inner and outer radii of the summary as circles."""
    sc = res.scenario
    t, x = res.column("time"), res.column(spec.get("x", "time"))
    ball = _ball_instance(res)
    end = validity_end(res, ball, is_hybrid(res, models, ball)) if ball else None
    n = end[0] if end is not None else t.size
    after = summary["after_s"] if summary and summary.get("after_s") is not None else _after_time(res, models)
    k = min(int(np.searchsorted(t, after - 1e-12)), n)  # the summary's window: t >= after - 1e-12
    a = _after_text(res, after)
    phases = [(0, k, f"start-up, t < {a}", PATH_COLOURS["start-up"]),
              (k, n, f"after the start-up, t \u2265 {a}" if k else ("model valid" if end else None),
               PATH_COLOURS["after"])]
    if end is not None:
        phases.append((n, t.size, invalid_label(end) + ", not physical", PATH_COLOURS["invalid"]))
    ys = spec["y"]
    for yname in ys:
        y = res.column(yname)
        y = np.where(np.abs(y) >= 1e299, np.nan, y)
        for i0, i1, text, colour in phases:
            if i1 > i0:
                if text and len(ys) > 1:
                    text = f"{_var_label(sc, yname, ys)}: {text}"
                ax.plot(x[i0:i1], y[i0:i1], lw=lw, color=colour, label=text)
    ring = (summary or {}).get("ring") or {}
    if ball and spec.get("x") == f"{ball}.xP" and list(ys) == [f"{ball}.yP"] \
            and ring.get("inner_radius_m") is not None:
        phi = np.linspace(0.0, 2.0 * np.pi, 361)
        for key, style, words in (("inner_radius_m", "--", "inner"), ("outer_radius_m", ":", "outer")):
            r = ring[key]
            ax.plot(r * np.cos(phi), r * np.sin(phi), style, color="k", lw=0.9,
                    label=f"ring's {words} radius {r:.4f} m (the summary's, t \u2265 {a})")


def _legend(ax):
    """The legend under the axes' x label (not over the curves), when anything is labelled
    (the figure laid out by ballmill.plotting.layout.OneAxes)."""
    from ..plotting import layout

    if ax.get_legend_handles_labels()[0]:
        layout.legend_below(ax, fontsize=8, frameon=False)


def plot(res: RunResult, out_dir: Path, models=None, summary: dict | None = None) -> list[Path]:
    """The scenario's [[plots]] as PNG files (``models``: the model descriptions, for the
    parameters the shell and slip-margin kinds and the vlines need; ``summary``: the run's
    summary, for the ring's radii and the statistics' window)."""
    from ..plotting import figures as plt  # Figure objects on Agg canvases, without pyplot

    files = []
    for spec in res.scenario.plots:
        kind = spec.get("kind", "series")
        if kind in ("shell", "slip_margin"):
            fig = (_plot_shell if kind == "shell" else _plot_slip_margin)(res, models, spec, plt)
        else:
            fig = _plot_series(res, models, spec, plt, summary)
        files.append(plt.save(fig, out_dir / spec["file"]))
    return files


def _plot_series(res: RunResult, models, spec, plt, summary):
    """Time series (x = "time": every curve, labelled vlines, the invalid span shaded) or a path
    (another x: _draw_path); labels in words with units unless the spec gives them."""
    sc = res.scenario
    equal = spec.get("aspect") == "equal"
    fig, ax = plt.subplots(figsize=(7.5, 4.8) if not equal else (6.4, 6.4), layout="one-axes")
    xname, ys = spec.get("x", "time"), spec["y"]
    x = res.column(xname)
    lw = 0.8 if len(x) > 2000 else 1.2
    names = [xname, *ys]
    if xname == "time":
        given = spec.get("legend") or [None] * len(ys)
        for yname, text in zip(ys, given):
            y = res.column(yname)
            y = np.where(np.abs(y) >= 1e299, np.nan, y)  # 1e300 stands for "infinite" (no contact)
            ax.plot(x, y, lw=lw, label=text or (_var_label(sc, yname, names) if len(ys) > 1 else None))
        _vlines(ax, res, models, spec)
        _mark_time(ax, res, models, float(x[-1]))
    else:
        _draw_path(ax, res, models, spec, lw, summary)
    ax.set_xlabel(spec.get("xlabel") or _var_label(sc, xname, names, width=70))
    ax.set_ylabel(spec.get("ylabel") or (_var_label(sc, ys[0], names, width=60) if len(ys) == 1
                                         else _common_label(sc, ys)))
    ax.set_title(spec.get("title", ""))
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    _legend(ax)
    return fig


def plot_bare(res: RunResult, bare: RunResult, out_dir: Path, models=None) -> list[Path]:
    """The structure's displacement at the absorber with and without the ball (``models``: the
    model descriptions, for a hybrid ball's marks)."""
    from ..plotting import figures as plt

    st = res.scenario.summary["structure"]
    files = []
    for axis in ("x", "y"):
        name = f"{st}.{axis}_rel"
        if name not in bare.columns or not np.any(bare.column(name)):
            continue
        fig, ax = plt.subplots(figsize=(7.5, 4.8), layout="tight")
        ax.plot(bare.column("time"), bare.column(name), lw=0.8, color="tab:red", label="bare structure")
        ax.plot(res.column("time"), res.column(name), lw=0.8, color="tab:blue", label="with the ball absorber")
        _mark_time(ax, res, models, float(res.column("time")[-1]))
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"displacement {axis} at the absorber [m]")
        ax.set_title(f"Structure displacement {axis}, with and without the ball")
        ax.legend()
        ax.grid(alpha=0.3)
        files.append(plt.save(fig, out_dir / f"structure_{axis}_with_without_ball.png"))
    return files


def draw(res: RunResult, models, out_dir: Path, bare: RunResult | None = None,
         summary: dict | None = None) -> list[str]:
    """Every PNG of a run: the scenario's plots and, with the bare structure's run, the
    comparison with it; their file names (``summary``: the run's, for the ring's radii and the
    statistics' window)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [p.name for p in plot(res, out_dir, models, summary)] if len(res.data) > 1 else []
    if bare is not None and bare.success and len(bare.data) > 1:
        names += [p.name for p in plot_bare(res, bare, out_dir, models)]
    return names


def write_all(res: RunResult, models, out_dir: Path, bare: RunResult | None = None) -> dict:
    """results.csv (and bare.csv), the plots and summary.json."""
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(res, out_dir / "results.csv")
    if bare is not None and bare.success and len(bare.data) > 1:
        write_csv(bare, out_dir / "bare.csv")
    summary = summarise(res, models, bare)
    summary["plots"] = draw(res, models, out_dir, bare, summary)
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2, default=_json_default))
    return summary


def _json_default(o):
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {o!r}")
