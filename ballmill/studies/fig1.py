"""The whole machine of the paper's Fig. 1, and two scenes that pin the general model down.

    python -m ballmill.studies.fig1 [--dt 0.001] [--csv out/fig1] [--figures docs/figures]

Runs three scenes through the physics library (ballmill.physics.turning.model.simulate_chamber,
monolithic, DOP853 tol 1e-10), 0 to 10 s, with r = 0.025 m, R = 0.25 m,
m = 0.5105088062083415 kg, g = 9.81 m/s2, mu = 0.3:

* spinning_bowl: A fixed, Omega = (0, 0, 3) rad/s, the ball co-rotating at xC0 = 0.05 m;
* tumbling_drum: A fixed, Omega = (0.8, 0, 0) rad/s, the ball co-rotating at the bottom;
* fig1_machine: frame angle phi = 0.5 rad/s t about the fixed x axis, the crank
  parallelogram (l = 0.5 m, the paper's start-up law n0 = 60 1/min, t0 = 2.5 s) relative
  to the frame, crank axes perpendicular to the shaft; the ball co-rotating at the bottom.

Writes docs/fig1_machine.md with the numbers (closed-form anchors against the runs, when
contact and rolling first fail, the fraction of the shell the contact point visits) and
the figures docs/figures/fig1_*.png; the time series as CSV in --csv (one file a scene).

The visited fraction (ballmill/plotting/shell.py, shared with the scenario reports): the
shell is cut into N_CELLS cells of equal area (Archimedes: N_BANDS bands of equal height in
the chamber's z times N_SECTORS equal sectors of longitude, each 4 pi R^2 / N_CELLS, about a
ball's radius across); a cell is visited when the contact point (in the chamber's axes,
sampled every dt, at most a few mm apart) falls in it. Reported up to the first failure of
rolling (the model's validity) and, for reference only, over the whole run.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from ballmill.physics import Ball, CrankStartup
from ballmill.physics.turning import model as turning
from ballmill.physics.turning.motions import ConstantSpeed, Fig1Machine, Spin
from ballmill.plotting.shell import CAPTION as SHELL_CAPTION
from ballmill.plotting.shell import N_BANDS, N_CELLS, N_SECTORS, cells, draw_hemispheres, first_failure, \
    visited_curve, visited_fraction  # noqa: F401 (cells: part of this study's measure, tested here)

ROOT = Path(__file__).resolve().parents[2]
BALL = Ball(r=0.025, R=0.25, m=0.5105088062083415, g=9.81, mu=0.3)
T_END = 10.0
TOL = 1e-10


def scenes():
    A = (0.0, 0.0, BALL.R)
    return {
        "spinning_bowl": (Spin((0.0, 0.0, 3.0), A), 0.05),
        "tumbling_drum": (Spin((0.8, 0.0, 0.0), A), 0.0),
        "fig1_machine": (Fig1Machine(frame=ConstantSpeed(0.5), crank=CrankStartup(l=0.5, n0=60.0, t0=2.5)), 0.0),
    }


def run(name, dt):
    motion, xC0 = scenes()[name]
    tr = turning.simulate_chamber(BALL, motion, T_END, dt, xC0=xC0, tol=TOL)
    if not tr.success:
        raise RuntimeError(f"{name}: {tr.message}")
    return motion, tr


# --------------------------------------------------------------------------- measures
def unit_on_shell(tr):
    """The contact point as a unit vector from the chamber's centre, chamber axes."""
    R = BALL.R
    return np.column_stack([tr["Pch_x"] / R, tr["Pch_y"] / R, tr["Pch_z"] / R - 1.0])


def slip_margin(tr):
    """mu N - |F_t| [N]: positive while the ball rolls (and N > 0)."""
    return BALL.mu * tr["N"] - tr["Ft"]


def simpson_work(t, p, split=None):
    def simp(tt, f):
        h = tt[1] - tt[0]
        if (len(tt) - 1) % 2:
            return simp(tt[:-1], f[:-1]) + 0.5 * h * (f[-2] + f[-1])
        return h / 3.0 * (f[0] + f[-1] + 4.0 * f[1:-1:2].sum() + 2.0 * f[2:-1:2].sum())
    if split is None:
        return simp(t, p)
    k = int(np.argmin(np.abs(t - split)))
    return simp(t[:k + 1], p[:k + 1]) + simp(t[k:], p[k:])


# --------------------------------------------------------------------------- closed forms
def bowl_frequencies(Omega=3.0):
    """(s+, s-) in the fixed frame, rad/s (tests/test_turning.py::bowl_linear derives them)."""
    f = BALL.inertia_factor
    beta = Omega * f / (1.0 + f)
    w0 = BALL.omega_small
    root = math.sqrt(beta * beta / 4.0 + w0 * w0)
    return beta / 2.0 + root, beta / 2.0 - root


def measured_bowl_frequencies(t, y):
    """The two circular frequencies of z = (n_x + i n_y)(t) in the fixed frame, by a
    least-squares fit of A+ exp(i s+ t) + A- exp(i s- t) started from the closed form."""
    from scipy.optimize import least_squares

    z = y[:, 0] + 1j * y[:, 1]
    s0 = bowl_frequencies()

    def resid(p):
        sp_, sm, a, b, c, d = p
        m = (a + 1j * b) * np.exp(1j * sp_ * t) + (c + 1j * d) * np.exp(1j * sm * t)
        return np.concatenate([(m - z).real, (m - z).imag])
    z0 = z[0]
    p0 = [s0[0], s0[1], z0.real * 0.5, 0.0, z0.real * 0.5, 0.0]
    sol = least_squares(resid, p0)
    return sol.x[0], sol.x[1], float(np.sqrt(np.mean(sol.fun ** 2)) / abs(z0))


def drum_exact(t, Omega=0.8):
    from scipy.special import ellipj

    w0 = BALL.omega_small
    kappa = Omega / (2.0 * w0)
    return 2.0 * np.arcsin(kappa * ellipj(w0 * t, kappa * kappa)[0])


def drum_period(Omega=0.8):
    from scipy.special import ellipk

    kappa = Omega / (2.0 * BALL.omega_small)
    return 4.0 * ellipk(kappa * kappa) / BALL.omega_small


# --------------------------------------------------------------------------- figures
def figure_paths(runs, file):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(runs), 2, figsize=(8.6, 4.0 * len(runs)), layout="constrained")
    for row, (name, (motion, tr, m)) in zip(axes, runs.items()):
        sm = draw_hemispheres(row, unit_on_shell(tr), tr.t, m["t_slip"], T_END)
        row[0].set_ylabel(name, fontsize=11)
    fig.colorbar(sm, ax=axes, shrink=0.5, label="time [s]")
    fig.suptitle(f"Contact point on the shell in the chamber's axes\n({SHELL_CAPTION})", fontsize=10)
    fig.savefig(file, dpi=110)
    plt.close(fig)


def figure_signals(runs, file):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(5, 1, figsize=(9.0, 13.0), sharex=True)
    colours = {"spinning_bowl": "tab:blue", "tumbling_drum": "tab:green", "fig1_machine": "tab:red"}
    for name, (motion, tr, m) in runs.items():
        c = colours[name]
        axes[0].plot(tr.t, tr["N"], color=c, lw=0.9, label=name)
        axes[1].plot(tr.t, slip_margin(tr), color=c, lw=0.9, label=name)
        axes[2].plot(tr.t, tr["M1"], color=c, lw=0.9,
                     label=f"{name}: {'frame shaft (x axis)' if name == 'fig1_machine' else 'spin axis'}")
        if name == "fig1_machine":
            axes[3].plot(tr.t, tr["M2"], color=c, lw=0.9, label=f"{name}: cranks")
        axes[4].plot(tr.t, m["visited_curve"] * 100.0, color=c, lw=1.2, label=name)
        for ax in axes[:2]:
            if m["t_slip"] is not None:
                ax.axvline(m["t_slip"], color=c, ls=":", lw=1.0)
    axes[0].axhline(0.0, color="k", lw=0.6)
    axes[1].axhline(0.0, color="k", lw=0.6)
    axes[0].set_ylabel("N [N]")
    axes[1].set_ylabel("slip margin\nmu N - |F_t| [N]")
    axes[2].set_ylabel("drive 1 reaction\nmoment [N m]")
    axes[3].set_ylabel("crank reaction\nmoment [N m]")
    axes[4].set_ylabel("shell visited [%]")
    axes[4].set_xlabel("time [s]")
    axes[0].set_title("Normal force, slip margin (dotted: rolling first fails), drive reaction moments, "
                      "visited fraction", fontsize=10)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


# --------------------------------------------------------------------------- the study
def metrics(name, motion, tr):
    u = unit_on_shell(tr)
    t = tr.t
    margin = slip_margin(tr)
    t_contact = first_failure(t, tr["N"])
    t_slip = first_failure(t, margin)
    k_slip = None if t_slip is None else int(np.searchsorted(t, t_slip))
    split = 2.5 if name == "fig1_machine" else None
    work = simpson_work(t, tr["P_ball"], split)
    m = {
        "N_min": float(tr["N"].min()), "N_max": float(tr["N"].max()),
        "ratio_max": float(np.max(tr["friction_ratio"][:k_slip])) if k_slip != 0 else math.nan,
        "N_min_valid": float(tr["N"][:k_slip].min()) if k_slip != 0 else math.nan,
        "angle_max": float(np.degrees(np.arccos(np.clip(-tr.y[:, 2], -1.0, 1.0)).max())),
        "angle_max_valid": float(np.degrees(np.arccos(np.clip(-tr.y[:k_slip, 2], -1.0, 1.0)).max())),
        "t_contact": t_contact, "t_slip": t_slip,
        "visited_valid": visited_fraction(u, k_slip), "visited_all": visited_fraction(u),
        "visited_curve": visited_curve(u),
        "dE": float(tr["E"][-1] - tr["E"][0]), "work": float(work), "E_swing": float(np.ptp(tr["E"])),
        "zch_max": float(tr["Pch_z"].max()),
        "M1_max": float(np.abs(tr["M1"]).max()), "M2_max": float(np.abs(tr["M2"]).max()),
        "M1_max_valid": float(np.abs(tr["M1"][:k_slip]).max()) if k_slip else float(np.abs(tr["M1"]).max()),
        "M2_max_valid": float(np.abs(tr["M2"][:k_slip]).max()) if k_slip else float(np.abs(tr["M2"]).max()),
    }
    if isinstance(motion, Spin):
        J = np.array([turning.moving_energy(BALL, y, motion.Omega) for y in tr.y])
        m["J_drift"] = float(np.ptp(J))
        h = np.array([turning.jacobi(BALL, y, motion.Omega) for y in tr.y])
        m["h_drift"] = float(np.ptp(h))
    if name == "spinning_bowl":
        m["s_theory"] = bowl_frequencies()
        k = int(round(2.0 / (t[1] - t[0]))) + 1
        m["s_fit"] = measured_bowl_frequencies(t[:k], tr.y[:k])
    if name == "tumbling_drum":
        th = np.arctan2(tr.y[:, 1], -tr.y[:, 2])
        m["drum_err"] = float(np.abs(th - drum_exact(t)).max())
        m["drum_amp"] = float(np.abs(th).max())
        m["drum_amp_theory"] = 2.0 * math.asin(0.8 / (2.0 * BALL.omega_small))
        m["drum_period"] = drum_period()
    return m


def _t(v):
    return "never (0-10 s)" if v is None else f"{v:.4f} s"


def markdown(runs, dt, wall, figs_rel):
    b, f = runs["spinning_bowl"][2], runs["fig1_machine"][2]
    d = runs["tumbling_drum"][2]
    L = ["# The whole machine of Fig. 1: a chamber that moves in space and turns\n",
         f"Generated by `python -m ballmill.studies.fig1` (dt = {dt:g} s, DOP853 tol {TOL:g}, "
         f"{wall:.1f} s wall). Physics: `ballmill.physics.turning.model` (equations and their derivation in "
         f"its docstring; docs/design.md section 10), motions `ballmill.physics.turning.motions`. Ball r = 0.025 m, "
         f"R = 0.25 m, m = 0.5105 kg, g = 9.81 m/s2, mu = 0.3; 0 to 10 s. This page runs the library "
         f"directly; the same scenes as FMU scenarios (Fig1Drive + BallInShell with motion = 2): "
         f"`ballmill run spinning_bowl` (tumbling_drum, fig1_machine).\n",
         "## The scenes\n",
         "| scene | chamber motion | ball at t = 0 |", "| --- | --- | --- |",
         "| spinning_bowl | A fixed, Omega = (0, 0, 3) rad/s | co-rotating, xC0 = 0.05 m, yC0 = 0 |",
         "| tumbling_drum | A fixed, Omega = (0.8, 0, 0) rad/s | co-rotating, at the bottom |",
         "| fig1_machine | frame phi = 0.5 rad/s t about x1; A = Rx(phi) (l cos psi, l sin psi, 0), "
         "l = 0.5 m, psi the paper's start-up (n0 = 60 1/min, t0 = 2.5 s); orientation Rx(phi) "
         "| co-rotating, at the bottom |", "",
         "Drive moments are the reaction moments the drives feel: the generalized force of the ball's "
         "load on each drive's coordinate, M_i = w_i . (P x F_s) + v_i . F_s (chamber.py). For the "
         "Fig. 1 machine, M1 is the frame shaft's (about the x1 axis through O1, the whole load's "
         "moment) and M2 the cranks' (the load's component along the platform's circular velocity "
         "times l). The power the drives deliver to the ball is -(M1 phi' + M2 psi').\n",
         "## Results\n",
         "| | spinning_bowl | tumbling_drum | fig1_machine |", "| --- | ---: | ---: | ---: |"]

    def row(label, fmt):
        L.append(f"| {label} | " + " | ".join(fmt(runs[n][2]) for n in ("spinning_bowl", "tumbling_drum",
                                                                         "fig1_machine")) + " |")
    row("rolling first fails (F_t > mu N, or N <= 0)", lambda m: _t(m["t_slip"]))
    row("contact first lost (N <= 0)", lambda m: _t(m["t_contact"]))
    row("smallest N while the model is valid [N]", lambda m: f"{m['N_min_valid']:.3f}")
    row("largest friction ratio F_t / N while valid (mu = 0.3)", lambda m: f"{m['ratio_max']:.3f}")
    row("N min / max over 0-10 s, valid or not [N]", lambda m: f"{m['N_min']:.3f} / {m['N_max']:.3f}")
    row("largest angle of the ball from the fixed frame's lowest point, while valid [deg]",
        lambda m: f"{m['angle_max_valid']:.1f}")
    row("highest contact point in the chamber's axes, z_ch, over 0-10 s [m]", lambda m: f"{m['zch_max']:.4f}")
    row(f"shell visited while the model is valid [% of {N_CELLS} equal-area cells]",
        lambda m: f"{100 * m['visited_valid']:.1f}")
    row("shell visited over 0-10 s, valid or not [%]", lambda m: f"{100 * m['visited_all']:.1f}")
    row("max reaction moment, drive 1, while valid [N m]", lambda m: f"{m['M1_max_valid']:.3f}")
    row("max reaction moment, cranks, while valid [N m]", lambda m: f"{m['M2_max_valid']:.3f}")
    row("E(10 s) - E(0) [J]", lambda m: f"{m['dE']:.6f}")
    row("work of the drives, integral of P_ball dt [J]", lambda m: f"{m['work']:.6f}")
    row("difference [J]", lambda m: f"{m['dE'] - m['work']:.1e}")
    L.append("")
    L += ["## Anchors: the runs against closed forms\n",
          "**Spinning bowl.** Linearised about the bottom (derivation in tests/test_turning.py, "
          "`bowl_linear`), z = (n_x + i n_y) obeys z'' - i beta z' + w0^2 z = 0 with beta = Omega I/(I + m r^2) "
          "= 2 Omega/7 and w0^2 = 5 g/(7 d): two circular modes s+- = beta/2 +- sqrt(beta^2/4 + w0^2) in the "
          "fixed frame, s+- - Omega in the chamber's.",
          f"Closed form: s+ = {b['s_theory'][0]:.4f}, s- = {b['s_theory'][1]:.4f} rad/s (chamber frame "
          f"{b['s_theory'][0] - 3:.4f}, {b['s_theory'][1] - 3:.4f}). Fitted to the first 2 s of this run "
          f"(amplitude 0.22 rad, so not small): s+ = {b['s_fit'][0]:.4f}, s- = {b['s_fit'][1]:.4f} rad/s, "
          f"rms misfit {b['s_fit'][2]:.1e} of the amplitude. The 1 mm version of this scene matches the "
          f"closed form to 1.2e-4 of its amplitude over 10 s (test).",
          "Relative equilibria in the rotating chamber: the centre fixed relative to the chamber at any "
          "polar angle theta, if the ball spins about n with s(theta) = (d Omega^2 cos theta - g)/(f r Omega) "
          "(I = f m r^2; -254 rad/s at theta = 0.4 here); without spin only cos theta = g/(d Omega^2), "
          "which needs Omega >= sqrt(g/d) = 6.6 rad/s, so at 3 rad/s the co-rotating ball swings about "
          "the bottom. Tested to 1e-7 m.",
          f"First integrals: the moving energy J = E - (R/r) I Omega . omega drifted {b['J_drift']:.1e} J, "
          f"the Jacobi integral E - Omega . L_A {b['h_drift']:.1e} J, while E varied by "
          f"{b['E_swing']:.2e} J.\n",
          "**Tumbling drum.** The motion stays in the plane x = 0 and is exactly a pendulum, "
          "th'' = -w0^2 sin th with th(0) = 0, th'(0) = Omega, whatever the drum's speed (derivation in "
          "tests/test_turning.py, `drum_exact`): no steady lag angle without losses; the only steady "
          "state is the ball rolling in place at the bottom, omega = (R/r) Omega + s n.",
          f"Amplitude 2 asin(Omega/(2 w0)) = {d['drum_amp_theory']:.5f} rad (run: {d['drum_amp']:.5f}), "
          f"period 4 K(kappa)/w0 = {d['drum_period']:.4f} s; largest deviation from the elliptic-function "
          f"solution over 10 s: {d['drum_err']:.1e} rad. Moving energy drift {d['J_drift']:.1e} J; the "
          f"Jacobi integral of the rotating frame is not an integral here (gravity turns in that frame) "
          f"and varies by {d['h_drift']:.2e} J.\n",
          "**Fig. 1 machine.** No closed form; the energy balance holds: E(10) - E(0) = "
          f"{f['dE']:.6f} J against the drives' work {f['work']:.6f} J (Simpson on the output grid, split "
          f"at the crank law's kink).\n",
          "## What the machine does\n",
          (f"The ball first stops rolling at t = {_t(f['t_slip'])}"
           + (f", and first leaves the wall (N <= 0) at t = {_t(f['t_contact'])}" if f["t_contact"] else
              ", and never leaves the wall")
           + f". Up to the first failure of rolling the contact point covers {100 * f['visited_valid']:.1f} % of "
             f"the shell; over the whole 10 s, were the ball held to the wall and rolling, "
             f"{100 * f['visited_all']:.1f} % (against {100 * b['visited_all']:.1f} % in the spinning bowl "
             f"and {100 * d['visited_all']:.1f} % in the drum). The model cannot continue with a sliding or "
             f"flying ball, so everything after the first failure (grey in the path figure) describes a "
             f"ball that would have to be held to the wall and is shown only to picture the motion the "
             f"machine imposes."),
          "",
          "Measure of the visited fraction: the shell cut into "
          f"{N_BANDS} bands of equal height in z_ch times {N_SECTORS} sectors of longitude, {N_CELLS} cells "
          f"of equal area ({4 * math.pi * BALL.R ** 2 / N_CELLS * 1e4:.2f} cm^2, about a ball's radius "
          "across); a cell counts once the contact point (sampled every dt, a few mm apart at most) "
          "has been in it.\n",
          "## Figures\n",
          f"![contact point paths]({figs_rel}/fig1_paths.png)\n",
          "The contact point's path on the shell in the chamber's axes, one row per scene: the lower "
          "hemisphere seen from above (the bottom in the centre), the upper one seen from below, both "
          "in Lambert's equal-area projection (equal areas on the sphere are equal areas in the "
          "picture; dashed circles at 30 and 60 degrees latitude), coloured by time.\n",
          f"![signals]({figs_rel}/fig1_signals.png)\n",
          "N, the slip margin mu N - |F_t| (rolling while positive), the reaction moment of drive 1 (the "
          "frame shaft for the machine, the spin axis for bowl and drum), the cranks' reaction moment, "
          "and the visited fraction over time.\n",
          "## Reproduce\n", "    python -m ballmill.studies.fig1\n"]
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m ballmill.studies.fig1", description=__doc__.split("\n")[0])
    ap.add_argument("--dt", type=float, default=0.001, help="output step [s] (default 0.001)")
    ap.add_argument("--figures", default=str(ROOT / "docs" / "figures"))
    ap.add_argument("--doc", default=str(ROOT / "docs" / "fig1_machine.md"))
    ap.add_argument("--csv", default=str(ROOT / "out" / "fig1"), help="folder for one CSV a scene")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    runs = {}
    names = list(scenes())
    for i, name in enumerate(names):
        print(f"[{i + 1}/{len(names)}] {name} ...", end="", flush=True)
        ts = time.perf_counter()
        motion, tr = run(name, args.dt)
        runs[name] = (motion, tr, metrics(name, motion, tr))
        print(f" {time.perf_counter() - ts:.1f} s", flush=True)
    figs = Path(args.figures)
    figs.mkdir(parents=True, exist_ok=True)
    figure_paths(runs, figs / "fig1_paths.png")
    figure_signals(runs, figs / "fig1_signals.png")
    csv = Path(args.csv)
    csv.mkdir(parents=True, exist_ok=True)
    for name, (motion, tr, m) in runs.items():
        cols = ["time"] + list(tr.out)
        data = np.column_stack([tr.t] + [tr.out[k] for k in tr.out])
        np.savetxt(csv / f"{name}.csv", data, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
    doc = Path(args.doc)
    try:
        rel = Path(__import__("os").path.relpath(figs, doc.parent)).as_posix()
    except ValueError:
        rel = figs.as_posix()
    doc.write_text(markdown(runs, args.dt, time.perf_counter() - t0, rel))
    f = runs["fig1_machine"][2]
    print(f"fig1_machine: rolling first fails {_t(f['t_slip'])}, contact first lost {_t(f['t_contact'])}, "
          f"visited {100 * f['visited_valid']:.1f} % while valid, {100 * f['visited_all']:.1f} % over 10 s")
    print(f"wrote {doc}, {figs / 'fig1_paths.png'}, {figs / 'fig1_signals.png'}, CSV in {csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
