"""The induction motor that feels the ball: coupling error and the starts compared.

    python -m ballmill.studies.induction [--quick] [--build-dir DIR]

1. Coupling error of the co-simulation InductionMotor <-> BallInShell (the
   scenario runner's Jacobi scheme through fmpy) against the monolithic
   solution of ballmill.physics.drives.coupled, for communication steps H and both
   ways of treating M_reaction over a step inside the motor (held, or
   extrapolated linearly from the last two communication points).
2. The starts compared, all monolithic (ballmill.physics.drives.coupled, and
   ballmill.physics.simulate for the kinematic law): direct on line, voltage
   ramp, frequency ramp, the paper's kinematic law, with and without losses
   to the ground material.

Prints the tables (markdown) and writes the figures into docs/figures/.
docs/induction_motor.md quotes the numbers.
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
MU = 0.3


# ---------------------------------------------------------------------------
# monolithic runs
# ---------------------------------------------------------------------------
def drive_for(start: str, model: str = "kloss", ramp_time: float = 2.5, **motor):
    from ballmill.physics.drives.induction import CrankDrive, InductionMotor
    return CrankDrive(motor=InductionMotor(start=start, ramp_time=ramp_time, **motor), model=model)


def coupled(start: str, t_end: float, dt: float, model: str = "kloss", ball=None, rtol: float = 1e-11,
            **motor):
    from ballmill.physics import Ball
    from ballmill.physics.drives.coupled import simulate_coupled
    return simulate_coupled(drive_for(start, model, **motor), ball or Ball(), t_end=t_end, dt=dt, rtol=rtol)


def kinematic(t_end: float, dt: float, ball=None, t0: float = 2.5):
    """The paper's law (MotorStartup) driving the ball, monolithic; same keys as coupled runs."""
    from ballmill.physics import Ball, BallModel, CrankStartup, simulate
    law = CrankStartup(l=0.5, n0=60.0, t0=t0)
    tr = simulate(BallModel(ball or Ball(), tol=1e-11), law, t_end, dt)
    data = dict(tr.out)
    data["psi_dot"] = np.array([law.angle(t)[1] for t in tr.t])
    data["psi_ddot"] = np.array([law.angle(t)[2] for t in tr.t])
    return tr.t, data


def first(t, mask):
    k = np.flatnonzero(mask)
    return float(t[k[0]]) if k.size else None


def start_metrics(t, d, last: float = 3.0) -> dict:
    """Start-up figures. The ball's figures (friction ratio, zP, ring, N, M_reaction) are
    taken over the model's valid span only: up to the first slip (|F_t| > mu N) or loss of
    contact (N <= 0), after which the rolling model no longer describes the ball; the ring
    and N over the ``last`` seconds of the run only if the valid span reaches them."""
    fr = np.where(np.isfinite(d["friction_ratio"]), d["friction_ratio"], np.inf)
    bad = (fr > MU) | (d["N"] <= 0.0)
    t_inv = first(t, bad)
    keep = t < t_inv if t_inv is not None else np.ones(t.size, dtype=bool)
    why = None if t_inv is None else ("slip" if fr[np.flatnonzero(bad)[0]] > MU and
                                      d["N"][np.flatnonzero(bad)[0]] > 0.0 else "lift-off")
    late = (t >= t[-1] - last - 1e-12) & keep
    full_late = bool(late.any()) and bool(keep[t >= t[-1] - last - 1e-12].all())
    rho = np.hypot(d["xP"], d["yP"])
    w_end = d["psi_dot"][-1]
    span = lambda x: x[keep] if keep.any() else x[:1]  # noqa: E731 - at least the first sample
    return {
        "t_95": first(t, d["psi_dot"] >= 0.95 * w_end),
        "psi_ddot_max": float(np.max(d["psi_ddot"])),
        "valid_until": t_inv, "why": why,
        "fr_max": float(np.max(span(fr))),
        "zP_max": float(np.max(span(d["zP"]))),
        "ring": (float(rho[late].min()), float(rho[late].max())) if full_late else None,
        "N_after": (float(d["N"][late].min()), float(d["N"][late].max())) if full_late else None,
        "M_peak": float(np.max(np.abs(span(d["M_reaction"])))),
        "w_end": float(w_end),
    }


# ---------------------------------------------------------------------------
# co-simulation
# ---------------------------------------------------------------------------
def cosim(scenario: str, step: float, t_end: float, overrides=(), build_dir=None):
    from ballmill.scenario import runner
    sc, models, paths = runner.prepare(scenario, list(overrides), build_dir, log=lambda m: None)
    sc.step, sc.stop = step, t_end
    res = runner.run(sc, models, paths, progress=False, echo=False)
    if not res.success:
        raise RuntimeError(f"{scenario} H = {step}: {res.message}")
    return res


def coupling_errors(res, ref, t_ref, window=None) -> dict:
    t = res.column("time")
    idx = np.rint(t / (t_ref[1] - t_ref[0])).astype(int)
    keep = np.ones_like(t, dtype=bool) if window is None else (t <= window + 1e-12)
    idx, tt = idx[keep], t[keep]
    assert np.allclose(t_ref[idx], tt, atol=1e-9)

    def err(name, ref_name):
        return float(np.max(np.abs(res.column(name)[keep] - ref[ref_name][idx])))
    dP = np.sqrt(sum((res.column(f"ball.{c}")[keep] - ref[c][idx]) ** 2 for c in ("xP", "yP", "zP")))
    return {"psi_dot": err("motor.psi_dot", "psi_dot"), "P": float(dP.max()), "N": err("ball.N", "N"),
            "M": err("ball.M_reaction", "M_reaction"), "T": err("motor.T_motor", "T_motor"),
            "wall": res.wall_time}


CASES = {  # name -> (scenario, overrides, reference kwargs, t_end, comparison window)
    "soft start (V/f ramp 2.5 s), Kloss": ("induction_soft_start", (), dict(start="frequency_ramp"), 10.0, None),
    "direct on line, Kloss": ("induction_start", (), dict(start="dol"), 0.7, None),
    "direct on line, dq": ("induction_start", ("motor.model=2",), dict(start="dol", model="dq"), 0.7, None),
}


def coupling_study(steps, build_dir=None, quick=False):
    rows = []
    for case, (scenario, overrides, ref_kw, t_end, window) in CASES.items():
        if quick:
            t_end = min(t_end, 2.0)
        dt_ref = 5e-4
        t0 = time.perf_counter()
        ref = coupled(t_end=t_end, dt=dt_ref, **ref_kw)
        print(f"  reference {case}: {time.perf_counter() - t0:.1f} s, energy residual "
              f"{np.max(np.abs(ref.energy_residual)):.2e} J", flush=True)
        for m_input in (1, 2):
            for h in steps:
                res = cosim(scenario, h, t_end, list(overrides) + [f"motor.M_input={m_input}"], build_dir)
                e = coupling_errors(res, ref.data, ref.t, window)
                e.update(case=case, H=h, M_input={1: "hold", 2: "linear"}[m_input])
                rows.append(e)
                print(f"  {case:38s} {e['M_input']:6s} H = {h * 1e3:5.2f} ms  psi' {e['psi_dot']:.2e}  "
                      f"P {e['P']:.2e}  N {e['N']:.2e}  M {e['M']:.2e}  ({e['wall']:.1f} s)", flush=True)
    return rows


def order(rows, case, m_input, key="P"):
    r = [x for x in rows if x["case"] == case and x["M_input"] == m_input]
    if len(r) < 2:
        return float("nan")
    return float(np.polyfit(np.log([x["H"] for x in r]), np.log([max(x[key], 1e-300) for x in r]), 1)[0])


# ---------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------
def figure_coupling(rows, file):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for case in CASES:
        for m_input, ls in (("hold", "--"), ("linear", "-")):
            r = [x for x in rows if x["case"] == case and x["M_input"] == m_input]
            if not r:
                continue
            h = [x["H"] * 1e3 for x in r]
            axes[0].loglog(h, [x["P"] for x in r], ls=ls, marker="o", label=f"{case}, {m_input}")
            axes[1].loglog(h, [x["psi_dot"] for x in r], ls=ls, marker="o", label=f"{case}, {m_input}")
    axes[0].set(xlabel="communication step H [ms]", ylabel="max |P - P_ref| [m]", title="Contact point")
    axes[1].set(xlabel="communication step H [ms]", ylabel="max |psi' - psi'_ref| [rad/s]",
                title="Crank speed")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def figure_starts(runs, file):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    for name, (t, d) in runs.items():
        fr = np.where(np.isfinite(d["friction_ratio"]) & (d["N"] > 0), d["friction_ratio"], np.nan)
        axes[0, 0].plot(t, d["psi_dot"], lw=1, label=name)
        axes[0, 1].plot(t, fr, lw=0.8, label=name)
        axes[1, 0].plot(t, d["N"], lw=0.8, label=name)
        axes[1, 1].plot(t, d["M_reaction"], lw=0.8, label=name)
    axes[0, 1].axhline(MU, color="k", ls="--", lw=0.8)
    axes[0, 1].set_ylim(0, 1.0)
    axes[0, 0].set(ylabel="crank speed psi' [rad/s]", title="Crank speed")
    axes[0, 1].set(ylabel="|F_t| / N [1]", title="Friction ratio (dashed: mu = 0.3; gaps: N <= 0)")
    axes[1, 0].set(ylabel="N [N]", title="Pressure of the ball on the chamber")
    axes[1, 1].set(ylabel="M_reaction [N m]", title="Reaction torque on the crank shaft")
    for ax in axes.flat:
        ax.set_xlabel("time [s]")
        ax.set_xlim(0, 5)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps and shorter runs")
    ap.add_argument("--build-dir", help="where the FMUs are built (default: build/)")
    ap.add_argument("--figures", default=str(ROOT / "docs" / "figures"))
    args = ap.parse_args(argv)
    build_dir = Path(args.build_dir) if args.build_dir else None
    figs = Path(args.figures)
    figs.mkdir(parents=True, exist_ok=True)
    from ballmill.physics import Ball

    # -- the starts, monolithic -------------------------------------------------
    t_end, dt = (6.0, 1e-3) if args.quick else (12.0, 1e-3)
    print("## The starts (monolithic)\n")
    runs = {}
    losses = Ball(rolling_resistance=1e-3, drag=0.5)
    for label, ball in (("no losses", Ball()), ("losses delta = 1 mm, c = 0.5 N s/m", losses)):
        print(f"### {label}\n")
        print("| start | t_95 [s] | max psi'' [rad/s2] | model valid until [s] | max friction ratio "
              "(valid span) | max zP (valid span) [m] | ring, last 3 s [m] | N, last 3 s [N] | "
              "max \\|M_reaction\\| (valid span) [N m] | final psi' [rad/s] |")
        print("| --- | ---: | ---: | --- | ---: | ---: | --- | --- | ---: | ---: |")
        cases = {"kinematic law t0 = 2.5 s (MotorStartup)": None, "direct on line": dict(start="dol"),
                 "direct on line, dq": dict(start="dol", model="dq"),
                 "voltage ramp 0.3 -> 1 in 2.5 s": dict(start="voltage_ramp"),
                 "frequency ramp 0 -> 50 Hz in 2.5 s": dict(start="frequency_ramp"),
                 "frequency ramp 0 -> 50 Hz in 5 s": dict(start="frequency_ramp", ramp_time=5.0)}
        for name, kw in cases.items():
            if kw is None:
                t, d = kinematic(t_end, dt, ball)
            else:
                r = coupled(t_end=t_end, dt=dt, ball=ball, rtol=1e-10, **kw)
                t, d = r.t, r.data
            if label == "no losses" and name in ("kinematic law t0 = 2.5 s (MotorStartup)", "direct on line",
                                                 "voltage ramp 0.3 -> 1 in 2.5 s",
                                                 "frequency ramp 0 -> 50 Hz in 2.5 s"):
                runs[name] = (t, d)
            m = start_metrics(t, d)
            fmt = lambda v: "never" if v is None else f"{v:.3f}"  # noqa: E731
            valid = "whole run" if m["valid_until"] is None else f"{m['valid_until']:.3f} ({m['why']})"
            ring = "invalid" if m["ring"] is None else f"{m['ring'][0]:.3f} .. {m['ring'][1]:.3f}"
            n_after = "invalid" if m["N_after"] is None else f"{m['N_after'][0]:.2f} .. {m['N_after'][1]:.2f}"
            print(f"| {name} | {fmt(m['t_95'])} | {m['psi_ddot_max']:.2f} | {valid} | "
                  f"{m['fr_max'] if m['fr_max'] < 1e3 else math.inf:.3f} | {m['zP_max']:.3f} | "
                  f"{ring} | {n_after} | {m['M_peak']:.2f} | {m['w_end']:.3f} |", flush=True)
        print()
    figure_starts(runs, figs / "induction_starts.png")

    # -- DOL at t = 0: the friction needed by hand ------------------------------
    drive = drive_for("dol")
    r0 = coupled(t_end=0.02, dt=1e-3, start="dol")
    a0 = drive.l * r0["psi_ddot"][0]
    print(f"DOL at t = 0: psi'' = {r0['psi_ddot'][0]:.4f} rad/s2, a_O = {a0:.4f} m/s2, friction ratio "
          f"{r0['friction_ratio'][0]:.5f} (by hand 2/7 a_O / g = {2 / 7 * a0 / 9.81:.5f})\n")

    # -- coupling error ------------------------------------------------------------
    steps = [0.001, 0.004] if args.quick else [0.0005, 0.001, 0.002, 0.005, 0.01]
    print("## Coupling error (Jacobi, fmpy) against the monolithic solution\n")
    rows = coupling_study(steps, build_dir, args.quick)
    print("\n| case | M_reaction over a step | H [ms] | max \\|d psi'\\| [rad/s] | max \\|dP\\| [m] | "
          "max \\|dN\\| [N] | max \\|dM_reaction\\| [N m] | max \\|dT_motor\\| [N m] | wall [s] |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for x in rows:
        print(f"| {x['case']} | {x['M_input']} | {x['H'] * 1e3:g} | {x['psi_dot']:.2e} | {x['P']:.2e} | "
              f"{x['N']:.2e} | {x['M']:.2e} | {x['T']:.2e} | {x['wall']:.2f} |")
    print()
    for case in CASES:
        print(f"order ({case}): " + ", ".join(
            f"{m}: P {order(rows, case, m):.2f}, psi' {order(rows, case, m, 'psi_dot'):.2f}"
            for m in ("hold", "linear")))
    figure_coupling(rows, figs / "induction_coupling_error.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
