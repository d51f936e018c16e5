"""The absorber_frf case: a ball absorber on a 0.8 Hz structure, response and tuning.

Structure M = 100 kg per axis, 0.8 Hz, damping ratio 0.01 (bare); steel-like
ball r = 0.025 m, m = 2.0 kg (2 % of M) in a cavity tuned to 0.8 Hz; a
harmonic force F0 sin(2 pi f t) on the structure in x. Runs the monolithic
structure + ball model (ballmill.absorber.model) through the response
layer (ballmill.absorber.response) and the linear theory
(ballmill.absorber.linear), and writes

    OUT/frf.csv          frequency_Hz, amplitude_m, amplitude_bare_m (+ error,
                         linear theory, validity) at F0 = 0.05 N, refined at the peaks
    OUT/sweeps.csv       up/down stepped sweeps at F0 = 1 N and 5 N (undamped and
                         optimally damped ball)
    OUT/tuning.csv       bare, tuned undamped, Den Hartog and optimum designs
    OUT/rolling.csv      a ball damped by rolling resistance alone, at several forces
    OUT/ground.json      the summary of a run under the synthetic ground record
    OUT/opt_frf.csv, OUT/timings.json   the optimum design's FRF at 0.05 N, the run times
    DOCS/absorber.md     the page, with its figures in DOCS/figures/absorber_*.png

    python -m ballmill.studies.absorber [--quick] [--out OUT] [--docs DOCS]

--quick: coarse grids, sweeps and rolling resistance at 1 N only (a few minutes).
--report-only: figures and page again from the data of an earlier run in OUT.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from ballmill.absorber import linear as lin
from ballmill.absorber.response import AbsorberCase, bare_amplitude, frf, sweep
from ballmill.absorber.summary import structure_summary
from ballmill.physics import Ball
from ballmill.absorber.model import StructureBall, simulate_absorber, simulate_structure
from ballmill.absorber.structure import GroundRecord, Structure

ROOT = Path(__file__).resolve().parents[2]
M, F_S, ZETA_S = 100.0, 0.8, 0.01
R_BALL, M_BALL = 0.025, 2.0
F_LO, F_HI = 0.5, 1.1
FRF_FORCE = 0.05


def structure() -> Structure:
    return Structure.single(M, F_S, ZETA_S)


def tuned_ball(**kw) -> Ball:
    """The issue's ball: cavity radius tuned to the structure's 0.8 Hz."""
    return Ball(r=R_BALL, R=lin.cavity_radius(F_S, R_BALL), m=M_BALL, **kw)


def case(force: float = FRF_FORCE, ball: Ball | None = None, seed_y: float = 0.0) -> AbsorberCase:
    return AbsorberCase(structure(), ball or tuned_ball(), force, seed_y=seed_y)


def frf_grid(quick: bool = False):
    """0.02 Hz over the band, 0.01 Hz around the split peaks; `frf` refines from there."""
    if quick:
        return np.round(np.concatenate([np.arange(F_LO, 0.7, 0.05), np.arange(0.7, 0.9, 0.02),
                                        np.arange(0.9, F_HI + 1e-9, 0.05)]), 6)
    return np.round(np.concatenate([np.arange(F_LO, 0.7, 0.02), np.arange(0.7, 0.9, 0.01),
                                    np.arange(0.9, F_HI + 1e-9, 0.02)]), 6)


def sweep_grid(quick: bool = False):
    if quick:
        return np.round(np.arange(0.70, 0.90 + 1e-9, 0.02), 6)
    return np.round(np.concatenate([np.arange(F_LO, 0.7, 0.02), np.arange(0.7, 0.9, 0.005),
                                    np.arange(0.9, F_HI + 1e-9, 0.02)]), 6)


class Progress:
    """One line per point on stderr: [done/total] what, frequency, amplitude, time."""

    def __init__(self, label: str, total: int):
        self.label, self.total, self.done, self.t0 = label, total, 0, time.perf_counter()

    def __call__(self, p):
        self.done += 1
        flag = "" if p.contact and p.rolling else (" SLIP" if p.contact else " CONTACT LOST")
        count = f"{self.done:3d}/{self.total}" if self.done <= self.total else f"{self.done:3d}, refining"
        print(f"\r[{count}] {self.label}: {p.frequency_Hz:.4f} Hz  "
              f"A = {p.amplitude_m * 1e3:8.4f} mm{flag}  ({time.perf_counter() - self.t0:5.1f} s)",
              end="", file=sys.stderr, flush=True)

    def close(self):
        print(file=sys.stderr, flush=True)


def run_frf(force: float = FRF_FORCE, ball: Ball | None = None, quick: bool = False, grid=None):
    """Rows of frf.csv for the ball (default the tuned, undamped one) at ``force``."""
    c = case(force, ball)
    grid = frf_grid(quick) if grid is None else grid
    prog = Progress(f"FRF {force:g} N", len(grid))
    pts = frf(c, grid, progress=prog)
    prog.close()
    f = np.array([p.frequency_Hz for p in pts])
    lin_x = np.abs(c.linear("x").frf(f)) * force
    bare = bare_amplitude(c, f)
    rows = []
    for p, a_lin, a_bare in zip(pts, lin_x, bare):
        rows.append({"frequency_Hz": p.frequency_Hz, "amplitude_m": p.amplitude_m,
                     "amplitude_bare_m": float(a_bare), "amplitude_err_m": p.amplitude_err_m,
                     "amplitude_linear_m": float(a_lin), "ball_amplitude_m": p.ball_amplitude_m,
                     "ball_angle_max_rad": p.ball_angle_max_rad,
                     "friction_ratio_max": p.friction_ratio_max, "N_min_N": p.N_min,
                     "rolling": p.rolling, "contact": p.contact, "converged": p.converged,
                     "periods": p.periods})
    return rows


ZOOM = (0.72, 0.77, 0.0025)  # the lower split peak, finer steps (F0 = 2 N)


def run_sweeps(force: float, ball: Ball, label: str, quick: bool = False, grid=None):
    """Up and down stepped sweeps; rows for sweeps.csv."""
    c = case(force, ball, seed_y=1e-6)  # a micrometre out of plane lets a whirl show
    grid = sweep_grid(quick) if grid is None else grid
    rows = []
    for direction, seq in (("up", grid), ("down", grid[::-1])):
        prog = Progress(f"{label} {force:g} N {direction}", len(seq))
        pts = sweep(c, seq, progress=prog, max_periods=160 if quick else 240)
        prog.close()
        for p in pts:
            r = p.row()
            rows.append({"design": label, "force_N": force, "direction": direction, **r})
    return rows


def designs():
    """(name, Ball) of the tuning comparison: tuned undamped, Den Hartog, numerical optimum."""
    ax = structure().x
    dh = lin.den_hartog_ball(ax, R_BALL, M_BALL)
    fb, zb, peak, opt = lin.optimum(ax, R_BALL, M_BALL, F_LO, F_HI)
    return [("tuned, undamped", tuned_ball()), ("Den Hartog", dh), ("optimum", opt)]


def tuning_rows():
    ax = structure().x
    bare = lin.LinearAbsorber(ax)
    bare_peak = max(a for _, a in bare.peaks(F_LO, F_HI))
    rows = [{"design": "bare structure", "R_m": math.nan, "f_ball_Hz": math.nan, "zeta_ball": math.nan,
             "drag_N_s_m": math.nan, "peak_m_per_N": bare_peak, "peak_vs_bare": 1.0}]
    for name, b in designs():
        pk = lin.peak_of(ax, b, F_LO, F_HI)
        rows.append({"design": name, "R_m": b.R, "f_ball_Hz": lin.ball_frequency(b),
                     "zeta_ball": lin.damping_ratio_of_drag(b), "drag_N_s_m": b.drag,
                     "peak_m_per_N": pk, "peak_vs_bare": pk / bare_peak})
    return rows


def tuning_map(n: int = 25):
    """Peak |x/F| [m/N] of the linear model over (f_ball / f_s, zeta_ball)."""
    ax = structure().x
    fr = np.linspace(0.94, 1.02, n)
    zs = np.linspace(0.0, 0.2, n)
    peak = np.empty((n, n))
    for i, z in enumerate(zs):
        for j, f in enumerate(fr):
            b = Ball(r=R_BALL, R=lin.cavity_radius(f * F_S, R_BALL), m=M_BALL)
            peak[i, j] = lin.peak_of(ax, b.with_(drag=lin.drag_for_damping_ratio(z, b)), F_LO, F_HI)
    return fr, zs, peak


def rolling_design(force: float = 1.0):
    """The optimum design with its drag replaced by the rolling resistance delta that
    dissipates as much (harmonic balance) at the ball amplitude the optimum ball has at
    its highest peak under ``force``: (ball, delta, peak frequency, ball amplitude U)."""
    opt = designs()[-1][1]
    L = lin.LinearAbsorber(structure().x, opt)
    fp = max(L.peaks(F_LO, F_HI), key=lambda p: p[1])[0]
    U = float(abs(L.ball_frf(fp)[0])) * force
    delta = opt.drag * math.pi * opt.r * 2 * math.pi * fp * U / (4 * opt.m * opt.g)
    return opt.with_(drag=0.0, rolling_resistance=delta), delta, fp, U


def rolling_rows(forces=(0.2, 1.0)):
    """FRFs of the rolling-resistance ball (`rolling_design` at 1 N) at several forces,
    with the harmonic-balance prediction (the linear model with c_eq(U) iterated to the
    ball amplitude U) beside each simulated point."""
    ball, delta, fp, U = rolling_design(1.0)
    ax = structure().x
    rows = []
    for F in forces:
        # a coarse start (refined at the peaks): with the rolling resistance's stiff
        # reversals a period costs about 20 times what it costs without
        for r in run_frf(force=F, ball=ball, grid=np.round(np.arange(0.6, 1.0 + 1e-9, 0.025), 6)):
            f = r["frequency_Hz"]
            Ul = max(r["ball_amplitude_m"], 1e-6)
            for _ in range(60):  # fixed point U -> c_eq(U) -> U
                c = lin.drag_equivalent_of_rolling_resistance(ball, f, Ul)
                Lm = lin.LinearAbsorber(ax, ball.with_(rolling_resistance=0.0, drag=c))
                Ul = max(float(abs(Lm.ball_frf(f)[0])) * F, 1e-9)
            rows.append({"force_N": F, "delta_m": delta, **r,
                         "amplitude_harmonic_balance_m": float(abs(Lm.frf(f)[0])) * F})
    return rows


def run_ground(ball: Ball, t_end: float = 60.0):
    rec = GroundRecord.from_csv(ROOT / "scenarios" / "data" / "ground_motion.csv")
    st = structure()
    res = simulate_absorber(StructureBall(st, ball, rec), t_end, 0.02, x_ref=1e-2)
    bare = simulate_structure(st, rec, t_end, 0.02, x_ref=1e-2)
    summary = structure_summary(res.t, res.data, bare.data, mu=ball.mu)
    summary["energy_residual_J"] = float(np.abs(res.energy_residual).max())
    return res, bare, summary


def write_csv(path: Path, rows):
    path.parent.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (int(v) if isinstance(v, bool) else v) for k, v in r.items()})


# ---------------------------------------------------------------------------
def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def figure_frf(rows, file):
    plt = _plt()
    c = case()
    f = np.linspace(F_LO, F_HI, 3001)
    fig, ax = plt.subplots(figsize=(9, 5))
    ax.plot(f, bare_amplitude(c, f) * 1e3, color="0.55", lw=1.2, label="bare structure (exact)")
    ax.plot(f, np.abs(c.linear().frf(f)) * FRF_FORCE * 1e3, "k--", lw=1.0,
            label="with ball, linear theory (2 DOF closed form)")
    fr = np.array([r["frequency_Hz"] for r in rows])
    a = np.array([r["amplitude_m"] for r in rows]) * 1e3
    ok = np.array([r["rolling"] and r["contact"] for r in rows])
    ax.plot(fr[ok], a[ok], "o", ms=3.5, color="tab:blue", label="with ball, simulated (rolling, valid)")
    if (~ok).any():
        ax.plot(fr[~ok], a[~ok], "x", ms=6, color="tab:red", label="simulated, ball slips or leaves the wall")
    ax.set(xlabel="excitation frequency [Hz]", ylabel="steady-state amplitude of the structure [mm]",
           title=f"Ball absorber on a {F_S} Hz structure, F0 = {FRF_FORCE} N (m/M = 2 %, undamped ball)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def figure_sweeps(rows, file, design="tuned, undamped", xlim=(F_LO, F_HI), ball: Ball | None = None,
                  title: str | None = None):
    """Amplitude / F0 of the up and down sweeps of one design, a panel per force; filled
    markers settled, hollow did not (quasi-periodic or still drifting: the last window's
    amplitude), squares the structure's y amplitude where the ball whirls."""
    plt = _plt()
    forces = sorted({r["force_N"] for r in rows if r["design"] == design})
    fig, axes = plt.subplots(1, len(forces), figsize=(7.5 * len(forces), 5), squeeze=False)
    c = case(ball=ball)
    f = np.linspace(F_LO, F_HI, 3001)
    for ax, F in zip(axes[0], forces):
        ax.plot(f, bare_amplitude(c, f) / FRF_FORCE * 1e3, color="0.6", lw=1.0, label="bare structure")
        ax.plot(f, np.abs(c.linear().frf(f)) * 1e3, "k--", lw=0.9, label="linear theory, this ball")
        for direction, color, mk in (("up", "tab:blue", "^"), ("down", "tab:orange", "v")):
            rs = [r for r in rows if r["design"] == design and r["force_N"] == F and r["direction"] == direction]
            rs.sort(key=lambda r: r["frequency_Hz"])
            fr = np.array([r["frequency_Hz"] for r in rs])
            a = np.array([r["amplitude_m"] for r in rs]) / F * 1e3
            valid = np.array([r["contact"] for r in rs])
            roll = np.array([r["rolling"] for r in rs])
            conv = np.array([r["converged"] for r in rs])
            ax.plot(fr[valid], a[valid], "-", lw=0.8, color=color)
            ax.plot(fr[valid & conv], a[valid & conv], mk, ms=4, color=color, label=f"sweep {direction}")
            if (valid & ~conv).any():
                ax.plot(fr[valid & ~conv], a[valid & ~conv], mk, ms=5, mfc="none", color=color,
                        label=f"sweep {direction}: did not settle (last window)")
            ay = np.array([r["amplitude_y_m"] for r in rs]) / F * 1e3
            whirl = valid & (ay > 0.1 * a)
            if whirl.any():
                ax.plot(fr[whirl], ay[whirl], "s", ms=3, mfc="none", color=color,
                        label=f"sweep {direction}: y amplitude (ball whirls)")
            slip = valid & ~roll
            if slip.any():
                ax.plot(fr[slip], a[slip], "o", ms=9, mfc="none", color="tab:purple",
                        label=f"ball slips (|F_t| > mu N), {direction}")
            if (~valid).any():
                ax.plot(fr[~valid], np.full((~valid).sum(), 0.2), "x", ms=7, color="tab:red",
                        label=f"ball leaves the wall, {direction}")
        ax.set(xlabel="excitation frequency [Hz]", ylabel="amplitude / F0 [mm/N]",
               title=f"{title or design + ' ball'}, F0 = {F:g} N", xlim=xlim)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def figure_tuning(fr, zs, peak, trows, opt_rows, file):
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.2))
    ax = axes[0]
    bare_peak = trows[0]["peak_m_per_N"]
    cs = ax.contourf(fr, zs, peak / bare_peak, levels=np.linspace(0.2, 1.2, 21), cmap="viridis", extend="both")
    fig.colorbar(cs, ax=ax, label="highest peak / bare structure's peak")
    for r, mk in zip(trows[1:], "o^*"):
        ax.plot(r["f_ball_Hz"] / F_S, r["zeta_ball"], mk, color="w", mec="k", ms=9, label=r["design"])
    ax.set(xlabel="ball frequency / structure frequency", ylabel="ball damping ratio (drag)",
           title="Linear theory: the highest peak over (tuning, damping)")
    ax.legend(fontsize=8)
    ax = axes[1]
    f = np.linspace(F_LO, F_HI, 3001)
    st = structure()
    ax.plot(f, np.abs(lin.LinearAbsorber(st.x).frf(f)) * 1e3, color="0.55", label="bare structure")
    for (name, b), style in zip(designs(), ("k:", "C1--", "C0-")):
        ax.plot(f, np.abs(lin.LinearAbsorber(st.x, b).frf(f)) * 1e3, style, label=f"{name} (linear)")
    if opt_rows:
        ax.plot([r["frequency_Hz"] for r in opt_rows], [r["amplitude_m"] / FRF_FORCE * 1e3 for r in opt_rows],
                "o", ms=3.5, color="C0", label="optimum, simulated at 0.05 N")
    ax.set(xlabel="excitation frequency [Hz]", ylabel="|x / F| [mm/N]", title="Designs compared",
           ylim=(0, 25))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def figures_of_sweeps(sweep_rows, docs: Path):
    """The three sweep figures (undamped ball; optimum ball; the zoom at 2 N)."""
    figure_sweeps(sweep_rows, docs / "figures" / "absorber_sweeps.png")
    figure_sweeps(sweep_rows, docs / "figures" / "absorber_sweeps_optimum.png", design="optimum",
                  ball=designs()[-1][1])
    if any(r["design"] == "tuned, undamped, zoom" for r in sweep_rows):
        figure_sweeps(sweep_rows, docs / "figures" / "absorber_sweeps_zoom.png",
                      design="tuned, undamped, zoom", xlim=(ZOOM[0], ZOOM[1]),
                      title="tuned, undamped ball (zoom)")


def figure_rolling(rows, file):
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 5))
    f = np.linspace(F_LO, F_HI, 3001)
    st = structure()
    ax.plot(f, np.abs(lin.LinearAbsorber(st.x).frf(f)) * 1e3, color="0.6", lw=1.0, label="bare structure")
    opt = designs()[-1][1]
    ax.plot(f, np.abs(lin.LinearAbsorber(st.x, opt).frf(f)) * 1e3, "k--", lw=1.0,
            label="optimum drag ball (linear)")
    for F, color in zip(sorted({r["force_N"] for r in rows}), ("C0", "C1", "C3")):
        rs = sorted((r for r in rows if r["force_N"] == F), key=lambda r: r["frequency_Hz"])
        fr = [r["frequency_Hz"] for r in rs]
        ax.plot(fr, [r["amplitude_m"] / F * 1e3 for r in rs], "o-", ms=3, lw=0.8, color=color,
                label=f"rolling resistance only, F0 = {F:g} N (simulated)")
        ax.plot(fr, [r["amplitude_harmonic_balance_m"] / F * 1e3 for r in rs], ":", lw=1.2, color=color,
                label=f"harmonic balance, F0 = {F:g} N")
    ax.set(xlabel="excitation frequency [Hz]", ylabel="amplitude / F0 [mm/N]", xlim=(0.6, 1.0),
           title=f"A ball damped by rolling resistance alone (delta = {rows[0]['delta_m'] * 1e3:.3f} mm)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def figure_ground(res, bare, file):
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    axes[0].plot(res.t, res["agx"], lw=0.7, label="ground acceleration x")
    axes[0].set(ylabel="a_g [m/s2]")
    axes[1].plot(bare.t, bare["xO"] * 1e3, color="0.55", lw=0.9, label="bare structure")
    axes[1].plot(res.t, res["xO"] * 1e3, color="C0", lw=0.9, label="with the optimum ball")
    axes[1].set(ylabel="x_O relative to ground [mm]")
    axes[2].plot(res.t, np.degrees(res["theta"]), color="C3", lw=0.9)
    axes[2].set(ylabel="ball angle from bottom [deg]", xlabel="time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=8)
    axes[0].set_title("Synthetic ground record (scenarios/data/ground_motion.csv)")
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------------
def _ranges(freqs, gap: float = 0.0051) -> str:
    """'0.745-0.770, 0.785 Hz' from a sorted list of frequencies (runs closer than gap)."""
    if not freqs:
        return "no point"
    out, start, prev = [], freqs[0], freqs[0]
    for f in list(freqs[1:]) + [None]:
        if f is not None and f - prev <= gap:
            prev = f
            continue
        out.append(f"{start:.3f}" if start == prev else f"{start:.3f}-{prev:.3f}")
        if f is not None:
            start = prev = f
    return ", ".join(out) + " Hz"


def hysteresis(rows, design, force, threshold: float = 0.1):
    """Frequencies where the up and down sweeps both settled, validly, on amplitudes that
    differ by more than ``threshold`` (relative): two stable branches, bounded by the jumps.
    Returns [(f, A_up, A_down)]."""
    by = {}
    for r in rows:
        if r["design"] == design and r["force_N"] == force and r["contact"] and r["converged"]:
            by.setdefault(r["frequency_Hz"], {})[r["direction"]] = r["amplitude_m"]
    out = []
    for f in sorted(by):
        d = by[f]
        if "up" in d and "down" in d and abs(d["up"] - d["down"]) > threshold * min(d["up"], d["down"]):
            out.append((f, d["up"], d["down"]))
    return out


def report(file, frf_rows, sweep_rows, trows, ground_summary, opt_rows, timings, quick, rr_rows=()):
    one = [r for r in sweep_rows if r["design"] == "tuned, undamped" and r["force_N"] == 1.0]
    calm_1n = bool(one) and not hysteresis(sweep_rows, "tuned, undamped", 1.0) and not any(
        r["amplitude_y_m"] > 0.1 * r["amplitude_m"] for r in one if r["contact"])
    c = case()
    L = c.linear()
    tmd = lin.equivalent_tmd(structure().x, tuned_ball())
    peaks_lin = L.peaks(F_LO, F_HI)
    bare_peak = trows[0]["peak_m_per_N"]
    widths, misread = [], 0.0
    for fp, hp in peaks_lin:
        ff = np.linspace(fp - 0.02, fp + 0.02, 40001)
        above = ff[np.abs(L.frf(ff)) > hp / math.sqrt(2)]
        widths.append(above.max() - above.min())
    for off in np.linspace(0.0, 0.005, 21):  # uniform 0.005 Hz grids, every offset
        fu = np.arange(F_LO + off, F_HI, 0.005)
        au = np.abs(L.frf(fu))
        for fp, hp in peaks_lin:
            misread = max(misread, 1.0 - au[np.abs(fu - fp) < 0.01].max() / hp)
    f = np.array([r["frequency_Hz"] for r in frf_rows])
    a = np.array([r["amplitude_m"] for r in frf_rows])
    al = np.array([r["amplitude_linear_m"] for r in frf_rows])
    rel = np.abs(a / al - 1)
    big = al > 0.01 * al.max()
    sim_peaks = []
    for fp, _ in peaks_lin:
        near = np.abs(f - fp) < 0.02
        i = np.argmax(np.where(near, a, -1))
        sim_peaks.append((f[i], a[i]))
    fmt = lambda v: f"{v:.4g}"  # noqa: E731
    lines = [
        "# Ball absorber on a structure: response curves and tuning",
        "",
        "Written by `python -m ballmill.studies.absorber`" + (" --quick (coarse grids)" if quick else "")
        + "; data in `frf.csv`, `sweeps.csv`, `tuning.csv`, `ground.json` of its `--out` folder. "
        "The model is the monolithic structure + ball ODE of `ballmill/absorber/model.py` (the ball's "
        "vector equations with the cavity's acceleration solved together with the structure's at every "
        "instant), the response layer `ballmill/absorber/response.py` and the linear theory "
        "`ballmill/absorber/linear.py`.",
        "",
        "## The case (`absorber_frf`)",
        "",
        f"Structure: one mode per horizontal axis, M = {M:g} kg, {F_S} Hz, damping ratio {ZETA_S} (bare). "
        f"Ball: r = {R_BALL} m, m = {M_BALL} kg (2 % of M), I = 2/5 m r^2, cavity R = {c.ball.R:.4f} m so that "
        f"sqrt(5 g / (7 (R - r))) = 2 pi x {F_S} Hz (R - r = {c.ball.d:.4f} m). Force F0 sin(2 pi f t) "
        "on the structure in x. No rolling resistance and no drag unless said.",
        "",
        "## What the linear theory says",
        "",
        "The rolling ball is a tuned-mass damper, but not of mass m. To second order its kinetic energy "
        "is 1/2 m (x' + u')^2 + 1/2 (2/5) m u'^2 (u: ball centre against the cavity, spin u'/r), and "
        "with u = (5/7) v this is 1/2 (2/7) m x'^2 + 1/2 (5/7) m (x' + v')^2: the structure carries 2/7 "
        "of the ball rigidly and 5/7 of it absorbs. The equivalent classic absorber has "
        f"m_a = {tmd.m_a:.4f} kg on a structure of {tmd.M_main:.3f} kg, mass ratio mu = {tmd.mu:.5f} "
        "(not m/M = 0.02), stiffness m g / ((7/5)^2 (R - r)), and drag c acts as c_a = (5/7)^2 c. "
        "(`ballmill.absorber.linear`; the tests check the coupled accelerations against a Newton-Euler "
        "solve and the equivalence against the TMD's characteristic equation.)",
        "",
        "* **An undamped tuned ball splits the resonance into two peaks**, here at "
        + " and ".join(f"{fp:.4f} Hz" for fp, _ in peaks_lin)
        + f", with an antiresonance at {F_S} Hz where the structure stands still.",
        f"* **With little structural damping the worse of them can exceed the bare structure's peak**: "
        f"{max(p for _, p in peaks_lin) * 1e3:.2f} mm/N against {bare_peak * 1e3:.2f} mm/N here "
        f"(+{(max(p for _, p in peaks_lin) / bare_peak - 1) * 100:.1f} %). The peaks are narrow "
        f"(half-power widths {' and '.join(f'{w * 1e3:.1f}' for w in widths)} mHz): a uniform 0.005 Hz "
        f"grid misreads their height by up to {misread * 100:.0f} % depending on where its points fall, "
        "so the grid is refined where the curve peaks.",
        "* **Damping is what makes an absorber**: with the ball damped as Den Hartog prescribes the "
        f"highest peak falls to {trows[2]['peak_vs_bare'] * 100:.1f} % of the bare structure's "
        "(table below).",
        "",
        "## Frequency response at F0 = 0.05 N",
        "",
        "![FRF](figures/absorber_frf.png)",
        "",
        f"{len(frf_rows)} independent steady states ({timings['frf']:.0f} s on this machine). Each starts from "
        "the linear steady state, runs windows of 4 excitation periods, fits each window's cavity motion "
        "with a mean and three harmonics, and stops when the fundamental amplitude of the last K "
        "windows agrees to 1e-3, K (3-10) chosen so that they span a beat of the slowest transient "
        "against the forcing, or its decay time. The error estimate (`amplitude_err_m`) is their spread, "
        "or an Aitken extrapolation of their trend when larger; started from rest (the hardest case) at "
        "seven frequencies, the true error was at most 1.25 times the estimate. The grid (0.01 Hz around the peaks) is refined around "
        "every local maximum until a parabola through the three points around it agrees with the sampled "
        "height to 0.3 % (or the spacing is 0.2 mHz).",
        "",
        f"* Largest deviation from the linear closed form where the amplitude is above 1 % of the peak: "
        f"{rel[big].max() * 100:.3f} % (the test asks for 2 %). Largest error estimate: "
        f"{max(r['amplitude_err_m'] / r['amplitude_m'] for r in frf_rows if r['amplitude_m'] > 0) * 100:.3f} % "
        "of the amplitude.",
        "* Peaks: " + "; ".join(
            f"linear {fp:.4f} Hz, {pp * FRF_FORCE * 1e3:.4f} mm; simulated {fs_:.4f} Hz, {as_ * 1e3:.4f} mm"
            for (fp, pp), (fs_, as_) in zip(peaks_lin, sim_peaks)) + ".",
        f"* Validity: the ball rolls everywhere (largest friction ratio "
        f"{max(r['friction_ratio_max'] for r in frf_rows):.3f} against mu = {c.ball.mu}), largest angle "
        f"{math.degrees(max(r['ball_angle_max_rad'] for r in frf_rows)):.2f} deg.",
        "",
        "## Nonlinear departure: F0 = 1 N and 5 N",
        "",
        "![sweeps](figures/absorber_sweeps.png)",
        "",
        "Stepped sweeps up and down (0.005 Hz steps between 0.7 and 0.9 Hz, 0.02 Hz outside), each point "
        "continuing from the previous one's final state with the force's phase continued, at most 240 "
        "periods a point; amplitudes divided by F0 so that the linear theory is one curve. The ball "
        "starts a micrometre off the forcing plane so that an out-of-plane instability can show. Filled "
        "markers settled (1e-3), hollow ones did not (the last window's amplitude is shown), squares are "
        "the structure's amplitude in y where the ball whirls.",
        "",
        "What the nonlinear model shows: the pendulum softens with amplitude (its frequency falls), so the "
        "peaks lean to lower frequencies" + ("; at 1 N that is all this grid sees" if calm_1n else "")
        + ". With more force (2 N in the "
        "zoom below, 5 N) the ball's planar swing loses stability near the split peaks and it whirls, "
        "circling in the cavity and moving the symmetric structure in y as much as in x; whirling and "
        "planar branches coexist, so up and down sweeps end on different branches (the jumps); many "
        "responses there do not settle (quasi-periodic), and at 5 N the ball leaves the wall near the "
        "lower peak. An undamped ball is no absorber at these forces.",
        "",
    ]
    forces = sorted({r["force_N"] for r in sweep_rows if r["design"] == "tuned, undamped"})
    for F in forces:
        rs = [r for r in sweep_rows if r["design"] == "tuned, undamped" and r["force_N"] == F]
        hy = hysteresis(sweep_rows, "tuned, undamped", F)
        lost = sorted({r["frequency_Hz"] for r in rs if not r["contact"]})
        slip = sorted({r["frequency_Hz"] for r in rs if r["contact"] and not r["rolling"]})
        whirl = sorted({r["frequency_Hz"] for r in rs if r["contact"] and r["amplitude_y_m"] > 0.1 * r["amplitude_m"]})
        unsettled = sorted({r["frequency_Hz"] for r in rs if r["contact"] and not r["converged"]})
        top = {}
        for d in ("up", "down"):
            ok = [r for r in rs if r["direction"] == d and r["contact"] and r["converged"]]
            if ok:
                top[d] = max(ok, key=lambda r: r["amplitude_m"])
        lines.append(
            f"* **F0 = {F:g} N**: highest settled points " + ", ".join(
                f"{d} {top[d]['amplitude_m'] / F * 1e3:.2f} mm/N at {top[d]['frequency_Hz']:.3f} Hz" for d in top)
            + "; up and down sweeps settle on different branches (more than 10 % apart) at "
            + (", ".join(f"{f:.4f} Hz ({au / F * 1e3:.2f} up, {ad / F * 1e3:.2f} down mm/N)" for f, au, ad in hy)
               if hy else "no point of this grid")
            + "; the ball leaves the wall at " + _ranges(lost) + "; slips at " + _ranges(slip)
            + "; whirls (the structure's y amplitude above 10 % of its x amplitude) at " + _ranges(whirl)
            + "; does not settle within the period limit (quasi-periodic or still drifting; "
            "`amplitude_err_m` says by how much) at " + _ranges(unsettled) + ".")
    zr = [r for r in sweep_rows if r["design"] == "tuned, undamped, zoom"]
    if zr:
        F = zr[0]["force_N"]
        hy = hysteresis(sweep_rows, "tuned, undamped, zoom", F)
        whirl = sorted({r["frequency_Hz"] for r in zr if r["contact"] and r["amplitude_y_m"] > 0.1 * r["amplitude_m"]})
        lines += ["", f"![sweeps, zoom](figures/absorber_sweeps_zoom.png)", "",
                  f"* **Zoom, F0 = {F:g} N, {ZOOM[2] * 1e3:g} mHz steps over the lower peak**: up and down "
                  "sweeps settle on different branches at "
                  + (", ".join(f"{f:.4f} Hz ({au / F * 1e3:.2f} up, {ad / F * 1e3:.2f} down mm/N)" for f, au, ad in hy)
                     if hy else "no point")
                  + "; the ball whirls at " + _ranges(whirl, gap=0.0026) + "; does not settle at "
                  + _ranges(sorted({r["frequency_Hz"] for r in zr if r["contact"] and not r["converged"]}), gap=0.0026)
                  + "; leaves the wall at " + _ranges(sorted({r["frequency_Hz"] for r in zr if not r["contact"]}),
                                                      gap=0.0026) + "."]
    lines += [
        "",
        "Where the ball leaves the wall the rolling model ends: such points are marked and not plotted as "
        "amplitudes, and the sweep's next point starts afresh (from the linear steady state, or from rest "
        "where that would put the ball beyond a quarter of R - r). What a ball does after it leaves the "
        "wall is outside this model.",
        "",
        "## Tuning",
        "",
        "![tuning](figures/absorber_tuning.png)",
        "",
        "The cavity radius that tunes the ball to a structure mode of frequency f: "
        "R = r + 5 g / (7 (2 pi f)^2) (`cavity_radius`). The reference is the classic tuned-mass damper "
        "optimum of Den Hartog for an undamped structure, applied to the equivalent absorber "
        "(mu = 5/7 m / (M + 2/7 m)): f_ball = f_main / (1 + mu), zeta = sqrt(3 mu / (8 (1 + mu))) "
        "(the ball's own damping ratio), "
        "peak |x| k / F = sqrt(1 + 2/mu). The search (`optimum`) minimises the highest peak of the "
        "linear model with the structure's own damping, over the ball's frequency (R) and damping ratio "
        "(realised by the drag c_drag = 2 (7/5) m omega_b zeta).",
        "",
        "| design | R [m] | ball f [Hz] | ball zeta | c_drag [N s/m] | highest peak [mm/N] | vs bare |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in trows:
        lines.append(f"| {r['design']} | {fmt(r['R_m'])} | {fmt(r['f_ball_Hz'])} | {fmt(r['zeta_ball'])} | "
                     f"{fmt(r['drag_N_s_m'])} | {r['peak_m_per_N'] * 1e3:.3f} | {r['peak_vs_bare'] * 100:.1f} % |")
    if opt_rows:
        o = np.array([r["amplitude_m"] for r in opt_rows])
        ol = np.array([r["amplitude_linear_m"] for r in opt_rows])
        lines += ["", f"The optimum design simulated at 0.05 N ({len(opt_rows)} points) follows its linear "
                  f"curve within {np.abs(o / ol - 1).max() * 100:.3f} %; its highest simulated point is "
                  f"{o.max() / FRF_FORCE * 1e3:.3f} mm/N."]
    opt_sw = [r for r in sweep_rows if r["design"] == "optimum"]
    if opt_sw:
        lines += ["", "![sweeps, optimum ball](figures/absorber_sweeps_optimum.png)", ""]
        for F in sorted({r["force_N"] for r in opt_sw}):
            rs = [r for r in opt_sw if r["force_N"] == F and r["contact"]]
            top = max(r["amplitude_m"] for r in rs) / F
            lines.append(f"At F0 = {F:g} N the optimum ball's highest point is {top * 1e3:.3f} mm/N "
                         f"({top / bare_peak * 100:.1f} % of the bare peak; the drag is linear, the "
                         f"pendulum's softening is what remains), largest ball angle "
                         f"{math.degrees(max(r['ball_angle_max_rad'] for r in rs)):.1f} deg, "
                         f"friction ratio up to {max(r['friction_ratio_max'] for r in rs):.3f}.")
    g = ground_summary
    lines += [
        "",
        "Rolling resistance is not a linear damper: its moment delta N is Coulomb-like, so over a cycle "
        "of ball amplitude U it dissipates what a drag c_eq = 4 delta m g / (pi r Omega U) would "
        "(`drag_equivalent_of_rolling_resistance`): strong damping for small swings, weak for large "
        "ones, and below a threshold the ball does not roll at all (the regularised model lets it creep "
        "at micrometres). A ball damped by its rolling resistance alone is therefore tuned for one "
        "amplitude.",
    ]
    if rr_rows:
        d = rr_rows[0]["delta_m"]
        lines += [
            "",
            "![rolling resistance](figures/absorber_rolling.png)",
            "",
            f"Here the optimum design's drag is replaced by delta = {d * 1e3:.3f} mm, the rolling resistance "
            "that dissipates as much as the optimum drag at the ball amplitude of the optimum design's "
            "highest peak under 1 N. Simulated (0.025 Hz grid, refined at the peaks) against harmonic balance "
            "(the linear model with c_eq at the ball's amplitude, iterated):",
            "",
            "| F0 [N] | highest point [mm/N] | vs bare peak | harmonic balance there [mm/N] | largest deviation from harmonic balance |",
            "| ---: | ---: | ---: | ---: | ---: |",
        ]
        for F in sorted({r["force_N"] for r in rr_rows}):
            rs = [r for r in rr_rows if r["force_N"] == F]
            top = max(rs, key=lambda r: r["amplitude_m"])
            dev = max(abs(r["amplitude_m"] / r["amplitude_harmonic_balance_m"] - 1) for r in rs)
            lines.append(f"| {F:g} | {top['amplitude_m'] / F * 1e3:.3f} | {top['amplitude_m'] / F / bare_peak * 100:.1f} % | "
                         f"{top['amplitude_harmonic_balance_m'] / F * 1e3:.3f} | {dev * 100:.1f} % |")
    lines += [
        "",
        "## A measured excitation: ground acceleration",
        "",
        "![ground](figures/absorber_ground.png)",
        "",
        "`scenarios/data/make_ground_motion.py` writes `ground_motion.csv`, a synthetic two-component "
        "earthquake record (accelerations only, 100 Hz). The structure's coordinates are relative to the "
        "ground, so the record drives the structure (load -L a_g) and the ball (cavity acceleration "
        "a_g + x_O'') as it is: nothing is differentiated, nothing integrated. The optimum ball against "
        f"the bare structure, {g['to_s']:.0f} s (`ballmill.absorber.summary.structure_summary`):",
        "",
        "| quantity | bare | with ball | reduction |",
        "| --- | ---: | ---: | ---: |",
    ]
    for k, unit, scale in (("displacement_peak_m", "mm", 1e3), ("displacement_rms_m", "mm", 1e3),
                           ("acceleration_peak_m_s2", "m/s2", 1), ("acceleration_rms_m_s2", "m/s2", 1)):
        red = g[f"reduction_{k.rsplit('_m', 1)[0]}_percent"]
        lines.append(f"| {k.rsplit('_m', 1)[0].replace('_', ' ')} [{unit}] | {g['bare_' + k] * scale:.3f} | "
                     f"{g[k] * scale:.3f} | {red:.1f} % |")
    lines += [
        "",
        f"Ball: largest excursion of the contact point from the bottom {g['ball_excursion_max_m'] * 1e3:.1f} mm "
        f"({g['ball_angle_max_deg']:.1f} deg), smallest normal force {g['N_min_N']:.2f} N, largest friction "
        f"ratio {g['friction_ratio_max']:.3f} (mu = {g['mu']}): it "
        + ("rolls and keeps contact throughout." if g["rolling"] and g["contact"] else "leaves its validity (see ground.json).")
        + f" Energy balance of the run closes to {g['energy_residual_J']:.1e} J.",
        "",
        "## Interfaces for what comes next",
        "",
        "* **The Structure FMU** (`drive_models/structure.c`, `drive_models/structure_fmu.py`) wraps "
        "`ballmill.absorber.structure.StructureModel`, with the ball's horizontal force (BallInShell's `Fx, Fy`) "
        "as input and the cavity's motion as output. Its acceleration output feeds through from the force "
        "input, a_O = a_free + G F_b: the algebraic loop the scenario runner iterates, with `simulate_absorber` "
        "(structure + ball in one ODE, the loop solved exactly) as the reference for its coupling error (the "
        "last section, `python -m ballmill.studies.absorber_cosim`).",
        "* **The sweep layer** runs these curves as design studies: `ballmill sweep absorber_frf --out DIR` "
        "(this page's FRF at 0.05 N: independent steady states, the grid refined around every peak in rounds, "
        "each round one batch of tasks on Dask) and `ballmill sweep absorber_frf_nonlinear --out DIR` (the "
        "sweeps up and down at 1 N and 5 N, each sweep one task) write `DIR/frf.csv` (`frequency_Hz`, "
        "`amplitude_m`, `amplitude_bare_m`, the linear theory, validity) and `DIR/frf.png` "
        "(`ballmill.sweep.absorber`; the study files are in scenarios/studies/).",
        "* **A tower summary** is `ballmill.absorber.summary.structure_summary(t, data, bare, mu)`; `ballmill run tower_absorber` writes it (with a second run of the bare structure).",
        "",
        "## Run times (2 shared cores)",
        "",
        "The coupled model runs in the compiled kernel (`ballmill/absorber/kernel.py`: the right-hand side "
        "and the integrator in C, bit for bit the Python path) wherever the excitation is harmonic; the "
        "ground record runs in Python. Tolerance 1e-9. "
        f"Measured in this run: {timings['frf'] / max(1, sum(r['periods'] for r in frf_rows)) * 1e3:.2f} ms of "
        "wall time per excitation period in the FRF at 0.05 N, "
        f"{timings['sweeps, undamped ball'] / max(1, sum(r['periods'] for r in sweep_rows if r['design'] == 'tuned, undamped')) * 1e3:.2f} ms "
        "in the sweeps of the undamped ball (larger motions, smaller steps). A point that settles from the "
        "linear steady state needs 12-40 periods; a sweep point must wait out the transient its frequency "
        "step starts (decay time 1/(zeta omega) = 40 s, 32 periods, for the split modes of the undamped "
        "ball), 100-240 periods. Wall times: "
        + ", ".join(f"{k}: {v:.0f} s" for k, v in timings.items()) + " (on 2 cores shared with other "
        "jobs; in pure Python, before the compiled path, the undamped sweeps took 655 s and the rolling "
        "resistance 439 s).",
        "",
    ]
    text = "\n".join(lines) + "\n"
    # keep the co-simulation section that ballmill.studies.absorber_cosim splices in
    from .absorber_cosim import END, START
    old = file.read_text() if file.exists() else ""
    if START in old and END in old:
        text += "\n" + old[old.index(START):old.index(END) + len(END)] + "\n"
    file.write_text(text)


def read_csv(path: Path):
    """Rows of a CSV written by `write_csv`, numbers as floats, flags as bools."""
    flags = {"rolling", "contact", "converged", "restarted"}
    text = {"design", "direction"}
    rows = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            rows.append({k: (v if k in text else bool(int(v)) if k in flags else float(v)) for k, v in r.items()})
    return rows


def report_from_data(out: Path, docs: Path, quick: bool = False) -> None:
    """Figures and page again from the data a full run left in ``out`` (no sweeps rerun;
    the ground record's 60 s run is repeated for its figure)."""
    frf_rows = read_csv(out / "frf.csv")
    sweep_rows = read_csv(out / "sweeps.csv")
    trows = read_csv(out / "tuning.csv")
    trows[0]["design"] = "bare structure"
    opt_rows = read_csv(out / "opt_frf.csv")
    rr_rows = read_csv(out / "rolling.csv") if (out / "rolling.csv").exists() else []
    timings = json.loads((out / "timings.json").read_text())
    figure_frf(frf_rows, docs / "figures" / "absorber_frf.png")
    figures_of_sweeps(sweep_rows, docs)
    fr, zs, peak = tuning_map(15 if quick else 25)
    figure_tuning(fr, zs, peak, trows, opt_rows, docs / "figures" / "absorber_tuning.png")
    if rr_rows:
        figure_rolling(rr_rows, docs / "figures" / "absorber_rolling.png")
    res, bare, summary = run_ground(designs()[-1][1], 30.0 if quick else 60.0)
    figure_ground(res, bare, docs / "figures" / "absorber_ground.png")
    report(docs / "absorber.md", frf_rows, sweep_rows, trows, summary, opt_rows, timings, quick, rr_rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse grids, 1 N sweeps only")
    ap.add_argument("--out", default=str(ROOT / "out" / "absorber"), help="folder for the CSV/JSON data")
    ap.add_argument("--docs", default=str(ROOT / "docs"), help="folder for absorber.md and figures/")
    ap.add_argument("--report-only", action="store_true",
                    help="rebuild the figures and the page from the data of an earlier run in --out")
    args = ap.parse_args(argv)
    out, docs = Path(args.out), Path(args.docs)
    (docs / "figures").mkdir(parents=True, exist_ok=True)
    out.mkdir(parents=True, exist_ok=True)
    if args.report_only:
        report_from_data(out, docs, args.quick)
        print(f"wrote {docs / 'absorber.md'} from the data in {out}", file=sys.stderr)
        return 0
    timings = {}

    t0 = time.perf_counter()
    frf_rows = run_frf(quick=args.quick)
    timings["frf"] = time.perf_counter() - t0
    write_csv(out / "frf.csv", frf_rows)
    figure_frf(frf_rows, docs / "figures" / "absorber_frf.png")

    t0 = time.perf_counter()
    trows = tuning_rows()
    write_csv(out / "tuning.csv", trows)
    opt = designs()[-1][1]
    opt_rows = run_frf(ball=opt, quick=True)
    write_csv(out / "opt_frf.csv", opt_rows)
    fr, zs, peak = tuning_map(15 if args.quick else 25)
    figure_tuning(fr, zs, peak, trows, opt_rows, docs / "figures" / "absorber_tuning.png")
    timings["tuning"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    sweep_rows = []
    for F in ((1.0,) if args.quick else (1.0, 5.0)):
        sweep_rows += run_sweeps(F, tuned_ball(), "tuned, undamped", quick=args.quick)
    if not args.quick:
        zoom = np.round(np.arange(ZOOM[0], ZOOM[1] + 1e-9, ZOOM[2]), 6)
        sweep_rows += run_sweeps(2.0, tuned_ball(), "tuned, undamped, zoom", grid=zoom)
    timings["sweeps, undamped ball"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    for F in ((1.0,) if args.quick else (1.0, 5.0)):
        sweep_rows += run_sweeps(F, opt, "optimum", quick=args.quick)
    timings["sweeps, optimum ball"] = time.perf_counter() - t0
    write_csv(out / "sweeps.csv", sweep_rows)
    figures_of_sweeps(sweep_rows, docs)

    t0 = time.perf_counter()
    rr_rows = rolling_rows(forces=(1.0,) if args.quick else (0.2, 1.0))
    write_csv(out / "rolling.csv", rr_rows)
    figure_rolling(rr_rows, docs / "figures" / "absorber_rolling.png")
    timings["rolling resistance"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    res, bare, summary = run_ground(opt, 30.0 if args.quick else 60.0)
    (out / "ground.json").write_text(json.dumps(summary, indent=1) + "\n")
    figure_ground(res, bare, docs / "figures" / "absorber_ground.png")
    timings["ground record"] = time.perf_counter() - t0

    (out / "timings.json").write_text(json.dumps(timings, indent=1) + "\n")
    report(docs / "absorber.md", frf_rows, sweep_rows, trows, summary, opt_rows, timings, args.quick,
           rr_rows)
    print(f"wrote {out / 'frf.csv'} and {docs / 'absorber.md'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
