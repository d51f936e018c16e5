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

Plots ([[plots]]): time series or x-y curves of recorded variables; ``kind =
"shell"``: the contact point's path on the chamber's sphere, two equal-area
hemispheres (``ball = "ball"``, the instance); ``kind = "slip_margin"``: the
ball's mu - friction_ratio (rolling while positive) with the first failure marked.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..plotting import shell
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
    sc = res.scenario
    if param in sc.instances[inst].parameters:
        return float(sc.instances[inst].parameters[param])
    md = models[sc.instances[inst].fmu]
    return float(next(v.start for v in md.modelVariables if v.name == param))


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


def _shell_unit_vectors(res: RunResult, models, ball: str):
    R = _parameter(res, models, ball, "R")
    return shell.unit_vectors(*(res.column(f"{ball}.{v}") for v in SHELL_OUTPUTS), R)


def _stats(x):
    return {"min": float(np.min(x)), "max": float(np.max(x)), "range": float(np.ptp(x))} if len(x) else None


def _structure_data(res: RunResult, st: str) -> dict:
    c = res.column
    return {"xO": c(f"{st}.x_rel"), "yO": c(f"{st}.y_rel"), "axO": c(f"{st}.ax1O"), "ayO": c(f"{st}.ay1O")}


STRUCTURE_RECORD = ("x_rel", "y_rel", "ax1O", "ay1O")  # what an absorber summary needs of the structure


def _ball_parameter(res: RunResult, models, ball: str, name: str) -> float:
    inst = res.scenario.instances[ball]
    if name in inst.parameters:
        return float(inst.parameters[name])
    return float(next(v.start for v in models[inst.fmu].modelVariables if v.name == name))


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
        R = _ball_parameter(res, models, ball, "R")
        zP = res.column(f"{ball}.zP")
        data.update({"xP": res.column(f"{ball}.xP"), "yP": res.column(f"{ball}.yP"), "N": res.column(f"{ball}.N"),
                     "friction_ratio": res.column(f"{ball}.friction_ratio"),
                     "theta": np.arccos(np.clip(1.0 - zP / R, -1.0, 1.0))})
    base = None
    if bare is not None and bare.success and len(bare.data) == len(res.data):
        base = _structure_data(bare, st)
    mu = _ball_parameter(res, models, ball, "mu") if ball else None
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
    if absorber and len(res.data):
        out["structure"] = absorber_summary(res, models, bare)
    if ball and f"{ball}.N" in cols and len(res.data):
        t_all = res.column("time")
        # statistics over the model's valid span only (the rows before BallInShell's
        # latched valid became false); later rows stay in results.csv
        keep = np.ones(t_all.size, dtype=bool)
        if f"{ball}.valid" in cols:
            bad = np.flatnonzero(res.column(f"{ball}.valid") < 0.5)
            if bad.size:
                keep[bad[0]:] = False
                t_inv = float(res.column(f"{ball}.t_invalid")[bad[0]]) if f"{ball}.t_invalid" in cols \
                    else float(t_all[bad[0]])
                out["left_validity"] = True
                out["t_invalid_s"] = t_inv
                out["statistics_over"] = (f"the valid span only, t < {t_all[bad[0]]:.6g} s: the model's "
                                          f"validity ended at t_invalid = {t_inv:.6g} s (loss of contact, "
                                          f"slip or inconsistent inputs; see log); later rows are in "
                                          f"results.csv but not in these statistics")
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


def write_csv(res: RunResult, path: Path):
    header = ",".join(res.columns)
    np.savetxt(path, res.data, delimiter=",", header=header, comments="", fmt="%.12g")


def _plot_shell(res: RunResult, models, spec, plt):
    ball = spec.get("ball") or _ball_instance(res)
    t = res.column("time")
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
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    ax.plot(t, np.where(fr >= 1e299, np.nan, mu - fr), lw=0.8 if len(t) > 2000 else 1.2,
            label=f"mu - friction_ratio (mu = {mu:g})")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylim(-mu, 1.05 * mu)  # from rolling freely (mu) to well past slip; spikes beyond are cut
    fail = _failures(res, models, ball)
    for flag, style in (("rolling", ":"), ("contact", "--")):
        if fail.get(flag) is not None:
            ax.axvline(fail[flag], color="tab:red", ls=style, lw=1.0, label=f"{flag} first fails, "
                       f"t = {fail[flag]:.4f} s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(spec.get("ylabel", "slip margin mu - F_t / N [1] (cut at -mu)"))
    ax.set_title(spec.get("title", "Slip margin: the ball rolls while positive"))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def _save(fig, path: Path) -> None:
    """The figure as a PNG at 110 dpi, without redundant work: a figure laid out by
    ``tight_layout`` keeps a placeholder layout engine, which makes ``savefig`` draw the
    whole figure once more (text, ticks) before the real draw only to lay it out again;
    dropping it saves that draw and nothing else changes (the PNG is identical pixel for
    pixel). zlib level 1: the same pixels in about a third less encoding time (files ~10 % larger)."""
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        fig.set_layout_engine(None)
    fig.savefig(path, dpi=110, pil_kwargs={"compress_level": 1})


def plot(res: RunResult, out_dir: Path, models=None) -> list[Path]:
    """The scenario's [[plots]] as PNG files (``models``: the model descriptions, for the
    parameters the shell and slip-margin kinds need)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    for spec in res.scenario.plots:
        kind = spec.get("kind", "series")
        if kind in ("shell", "slip_margin"):
            fig = (_plot_shell if kind == "shell" else _plot_slip_margin)(res, models, spec, plt)
            path = out_dir / spec["file"]
            _save(fig, path)
            plt.close(fig)
            files.append(path)
            continue
        fig, ax = plt.subplots(figsize=(7.5, 4.8) if spec.get("aspect") != "equal" else (6.4, 6.4))
        xname = spec.get("x", "time")
        x = res.column(xname)
        for yname in spec["y"]:
            y = res.column(yname)
            y = np.where(np.abs(y) >= 1e299, np.nan, y)  # 1e300 stands for "infinite" (no contact)
            ax.plot(x, y, lw=0.8 if len(x) > 2000 else 1.2, label=yname)
        ax.set_xlabel(spec.get("xlabel", "time [s]" if xname == "time" else xname))
        ax.set_ylabel(spec.get("ylabel", ", ".join(spec["y"])))
        ax.set_title(spec.get("title", ""))
        if spec.get("aspect") == "equal":
            ax.set_aspect("equal", adjustable="datalim")
        for line in spec.get("vlines", []):
            ax.axvline(float(line), color="grey", ls="--", lw=0.8)
        if len(spec["y"]) > 1:
            ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = out_dir / spec["file"]
        _save(fig, path)
        plt.close(fig)
        files.append(path)
    return files


def plot_bare(res: RunResult, bare: RunResult, out_dir: Path) -> list[Path]:
    """The structure's displacement at the absorber with and without the ball."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    st = res.scenario.summary["structure"]
    files = []
    for axis in ("x", "y"):
        name = f"{st}.{axis}_rel"
        if name not in bare.columns or not np.any(bare.column(name)):
            continue
        fig, ax = plt.subplots(figsize=(7.5, 4.8))
        ax.plot(bare.column("time"), bare.column(name), lw=0.8, color="tab:red", label="bare structure")
        ax.plot(res.column("time"), res.column(name), lw=0.8, color="tab:blue", label="with the ball absorber")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"displacement {axis} at the absorber [m]")
        ax.set_title(f"Structure displacement {axis}, with and without the ball")
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = out_dir / f"structure_{axis}_with_without_ball.png"
        _save(fig, path)
        plt.close(fig)
        files.append(path)
    return files


def draw(res: RunResult, models, out_dir: Path, bare: RunResult | None = None) -> list[str]:
    """Every PNG of a run: the scenario's plots and, with the bare structure's run, the
    comparison with it; their file names."""
    out_dir.mkdir(parents=True, exist_ok=True)
    names = [p.name for p in plot(res, out_dir, models)] if len(res.data) > 1 else []
    if bare is not None and bare.success and len(bare.data) > 1:
        names += [p.name for p in plot_bare(res, bare, out_dir)]
    return names


def write_all(res: RunResult, models, out_dir: Path, bare: RunResult | None = None, plots=None) -> dict:
    """results.csv (and bare.csv), the plots and summary.json. ``plots``: when the plots are
    drawn elsewhere meanwhile (`ballmill run` draws them in a second process), a function
    returning their names, called once the rest is written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(res, out_dir / "results.csv")
    if bare is not None and bare.success and len(bare.data) > 1:
        write_csv(bare, out_dir / "bare.csv")
    summary = summarise(res, models, bare)
    summary["plots"] = plots() if plots is not None else draw(res, models, out_dir, bare)
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2, default=_json_default))
    return summary


def _json_default(o):
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {o!r}")
