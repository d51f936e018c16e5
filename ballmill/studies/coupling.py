"""Coupling error of the co-simulation against the communication step.

Runs the fast start through the real FMUs (fmpy master) for each input path
of BallInShell — derivative inputs (input_mode 1), positions only (2), hold
the acceleration (3) — at a range of communication steps, and compares the
contact point and N with a converged monolithic solution of the library on
the same grid; then measured motion: white noise on the positions (input_mode
2) or on measured accelerations (input_mode 4) at the default 2 ms step, with
the errors it causes and what `coupling_error` reports about them. Writes
docs/coupling.md and docs/figures/coupling_error.png.

    python -m ballmill.studies.coupling [--quick]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
PATHS = {  # input path -> (scenario, input_mode)
    "derivatives": ("fast_start", 1),
    "positions": ("fast_start_positions", 2),
    "hold": ("fast_start", 3),
}


def reference(t_end: float, dt: float):
    from ballmill.physics import Ball, BallModel, CrankStartup, simulate
    return simulate(BallModel(Ball(), tol=1e-13), CrankStartup(l=0.5, n0=60.0, t0=2.5), t_end, dt)


def measure(path: str, step: float, t_end: float):
    from ballmill.scenario import runner
    scenario, mode = PATHS[path]
    sc, models, paths = runner.prepare(scenario, [f"ball.input_mode={mode}"], log=lambda m: None)
    sc.step, sc.stop = step, t_end
    res = runner.run(sc, models, paths, progress=False, echo=False)
    ref = reference(t_end, step)
    n = min(len(ref.t), len(res.data))
    dP = np.sqrt(sum((res.column(f"ball.{c}")[:n] - ref[c][:n]) ** 2 for c in ("xP", "yP", "zP")))
    dN = np.abs(res.column("ball.N")[:n] - ref["N"][:n])
    return {"path": path, "step": step, "dP": float(dP.max()), "dN": float(dN.max()),
            "wall": res.wall_time, "success": res.success}


NOISE = {  # input path -> (input_mode, noisy inputs, unit, noise levels)
    "positions": (2, ("x1O", "y1O"), "m", (0.0, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4)),
    "accelerations": (4, ("ax1O", "ay1O"), "m/s2", (0.0, 1e-3, 1e-2, 1e-1, 1.0)),
}
NOISE_STEP, NOISE_T = 0.002, 5.0


def measure_noise(path: str, sigma: float, step: float = NOISE_STEP, t_end: float = NOISE_T, seed: int = 1):
    """Fast start through BallInShell.fmu (fmpy, no drive FMU: the crank law's exact
    motion plus white noise of sigma on the noisy inputs) against the monolithic
    reference: max contact-point and N errors, and the largest coupling_error reported."""
    import shutil

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from ballmill.fmi.build import build_all
    from ballmill.physics import CrankStartup

    mode, noisy, _, _ = NOISE[path]
    fmu = [f for f in build_all(log=lambda m: None) if f.stem == "BallInShell"][0]
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = extract(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="ball")
    slave.instantiate()
    law = CrankStartup(l=0.5, n0=60.0, t0=2.5)
    rng = np.random.default_rng(seed)
    names = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
    refs = [vr[n] for n in names]
    outs = [vr[n] for n in ("xP", "yP", "zP", "N", "coupling_error")]

    def feed(t):
        values = list(law.state(t))
        for n in noisy:
            values[names.index(n)] += sigma * rng.standard_normal()
        slave.setReal(refs, values)

    try:
        slave.setInteger([vr["input_mode"]], [mode])
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        feed(0.0)
        slave.exitInitializationMode()
        n = int(round(t_end / step))
        rows = [slave.getReal(outs)]
        for k in range(n):
            slave.doStep(k * step, step)
            feed((k + 1) * step)
            rows.append(slave.getReal(outs))
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(unzip, ignore_errors=True)
    got = np.array(rows)
    ref = reference(t_end, step)
    m = min(len(ref.t), len(got))
    dP = np.sqrt(sum((got[:m, j] - ref[c][:m]) ** 2 for j, c in enumerate(("xP", "yP", "zP"))))
    dN = np.abs(got[:m, 3] - ref["N"][:m])
    return {"path": path, "sigma": sigma, "dP": float(dP.max()), "dN": float(dN.max()),
            "ce": float(got[:m, 4].max()), "dP_rms": float(np.sqrt(np.mean(dP ** 2)))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps, 5 s of simulated time")
    ap.add_argument("--out", default=str(ROOT / "docs"), help="folder for coupling.md and figures/")
    args = ap.parse_args(argv)
    steps = [0.001, 0.004, 0.016] if args.quick else [0.0005, 0.001, 0.002, 0.005, 0.01, 0.02]
    t_end = 5.0 if args.quick else 10.0
    rows = []
    for path in PATHS:
        for h in steps:
            t0 = time.perf_counter()
            rows.append(measure(path, h, t_end))
            print(f"{path:12s} H = {h * 1e3:6.2f} ms  max|dP| = {rows[-1]['dP']:.3e} m  "
                  f"max|dN| = {rows[-1]['dN']:.3e} N  ({time.perf_counter() - t0:.1f} s)", flush=True)
    noise = []
    for path, (_, _, unit, levels) in NOISE.items():
        for sigma in (levels[::2] if args.quick else levels):
            t0 = time.perf_counter()
            noise.append(measure_noise(path, sigma, t_end=2.0 if args.quick else NOISE_T))
            x = noise[-1]
            print(f"noise {path:13s} sigma = {sigma:7.0e} {unit:5s} max|dP| = {x['dP']:.3e} m  "
                  f"max|dN| = {x['dN']:.3e} N  max coupling_error = {x['ce']:.3e} m "
                  f"({time.perf_counter() - t0:.1f} s)", flush=True)
    out = Path(args.out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    _figure(rows, out / "figures" / "coupling_error.png")
    _report(rows, t_end, out / "coupling.md", noise)
    return 0


def _order(rows, path):
    r = [x for x in rows if x["path"] == path]
    h = np.log([x["step"] for x in r])
    e = np.log([max(x["dP"], 1e-16) for x in r])
    return float(np.polyfit(h, e, 1)[0]) if len(r) > 1 else float("nan")


def _figure(rows, file):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for path, marker in zip(PATHS, "os^"):
        r = [x for x in rows if x["path"] == path]
        h = [x["step"] * 1e3 for x in r]
        axes[0].loglog(h, [x["dP"] for x in r], marker=marker, label=f"{path} (slope {_order(rows, path):.1f})")
        axes[1].loglog(h, [x["dN"] for x in r], marker=marker, label=path)
    axes[0].axhline(1e-5, color="grey", ls="--", lw=0.8)
    axes[1].axhline(1e-3, color="grey", ls="--", lw=0.8)
    axes[0].set(xlabel="communication step H [ms]", ylabel="max |P - P_ref| [m]",
                title="Contact point error, fast start")
    axes[1].set(xlabel="communication step H [ms]", ylabel="max |N - N_ref| [N]",
                title="Normal force error, fast start")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
        ax.legend()
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


GUIDE = """\
## What this means for a user

BallInShell is a predictor-corrector: over a step it extrapolates the
platform motion from the samples it has (predictor, which gives the outputs
at the end of the step); when the next inputs arrive it redoes the steps
inside its input window along the now interpolating fit (corrector), so
extrapolation errors do not accumulate in the state (`corrector = true`, the
default; see the parameter's description).

* **Derivative inputs (input_mode 1, the default).** A quintic through
  (x, v, a) at the last two communication points. The contact point's error
  falls as H^3 (1e-9 m at 2 ms, 1e-6 m at 20 ms). The force outputs at a
  communication point come from the predictor, so a kink in the drive law
  shows in them: the crank law's jerk jumps at t0, which costs N an error
  proportional to H (3e-4 N at 2 ms, 1.3e-3 N at 10 ms). Keep H <= 5 ms where
  N matters to 1e-3 N; the contact point allows 20 ms and more.
* **Positions only (input_mode 2)**, what a tool without derivative outputs
  or a measured CSV gives: a quintic through the last six positions, and the
  corrector redoes the last five steps. The crank law's acceleration jumps at
  t = 0 and its jerk at t0; positions cannot see either until the window has
  samples on both sides, and the error falls as H^2: 4e-6 m and 5e-4 N at
  1 ms, 1.6e-5 m and 1.1e-3 N at 2 ms. On motions without such kinks it is
  much smaller. Where you can, connect vx1O .. ay1O.
* **Hold (input_mode 3)** holds the acceleration over the step and has no
  corrector: first order, about 1 mm at 1 ms, as docs/design.md section 6 warns. Kept only
  as the baseline.
"""


NOISE_GUIDE = """\
## Measured motion: noise

A measured motion is noisy, and the input path decides what the noise does.
**Positions only (input_mode 2)** differentiate twice: the six-sample quintic
turns position noise sigma_x into acceleration noise of about
187 sigma_x / H^2 (at 2 ms, 1 um of noise gives tens of m/s2 of acceleration
error against the platform's 2.5 m/s2 and the ball's g), and the ball's
contact point and N follow it. Keep positions-only for smooth, noise-free
signals (a drive model, a CAD path), or filter them first. **Measured
accelerations (input_mode 4)** take ax1O, ay1O (an accelerometer) and
integrate: a(t) is the line between the samples (extrapolated over the step,
interpolated by the corrector), so noise sigma_a enters the ball's dynamics
once, never amplified; x1O, y1O serve only as the moment arm of M_reaction.
The table's "max coupling_error" is what the FMU reports during the run (the
last step's predicted against corrected contact point, plus the drift the
changes of the fitted acceleration leave, docs/conformance.md): it grows with
the noise and never under-reports it. With measured accelerations it is
about twice the largest measured error; with positions only it is a loose
upper bound (about 50 times), the warning sign that the inputs are too noisy
to differentiate: there 1 um of noise already costs 43 N of normal force.

**Positions far from the origin (input_mode 2).** Positions given in map
coordinates, say 1e6 m from the origin, carry a round-off of ulp(1e6 m) =
1.2e-10 m, which the quintic amplifies into the fitted acceleration like
noise (up to 187 ulp(X) / H^2: 5e-3 m/s2 at 2 ms). Integrated back into the
ball's motion it costs little: over 2 s of the fast start at 2 ms the contact
point moves by 1e-10 .. 1e-8 m against the same run at the origin, and N by
1e-4 N. coupling_error covers it at every communication point (it adds the
round-off's worst effect over a step, (R/(R - r)) (5/7) 2 * 187 ulp(X), 3.4e-8 m
here, to the corrector's estimate and the drift; 3e-14 m near the origin, where
it changes nothing that shows). Every sample is used: spreading the fit's
nodes until the round-off alone stays below 1e-6 m/s2 would widen the window
to a second at 1e6 m, and its truncation error, invisible to the estimate,
would cost 0.1 m of contact point over 2 s (5e-3 m reported).
"""


def _report(rows, t_end, file, noise=()):
    lines = [
        "# Coupling error against the communication step",
        "",
        f"Fast start (t0 = 2.5 s, {t_end:g} s simulated), MotorStartup -> BallInShell through fmpy, "
        "against a monolithic library solution (DOP853, tol 1e-13) on the same grid. Written by "
        "`python -m ballmill.studies.coupling`.",
        "",
        "![coupling error](figures/coupling_error.png)",
        "",
        "| input path | H [ms] | max \\|dP\\| [m] | max \\|dN\\| [N] | wall [s] |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for x in rows:
        lines.append(f"| {x['path']} | {x['step'] * 1e3:g} | {x['dP']:.2e} | {x['dN']:.2e} | {x['wall']:.2f} |")
    lines += ["", "Observed order (slope of log error against log H): "
              + ", ".join(f"{p} {_order(rows, p):.1f}" for p in PATHS) + ".", ""]
    if noise:
        lines += ["## Noise on measured motion", "",
                  f"Fast start, {NOISE_T:g} s at H = {NOISE_STEP * 1e3:g} ms, BallInShell alone driven by the "
                  "crank law's exact motion plus white Gaussian noise on the noisy inputs (fixed seed), "
                  "against the same monolithic reference.", "",
                  "| input path | noisy inputs | sigma | max \\|dP\\| [m] | rms \\|dP\\| [m] | max \\|dN\\| [N] | "
                  "max coupling_error reported [m] |",
                  "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
        for x in noise:
            mode, inputs, unit, _ = NOISE[x["path"]]
            lines.append(f"| {x['path']} (input_mode {mode}) | {', '.join(inputs)} | {x['sigma']:g} {unit} | "
                         f"{x['dP']:.2e} | {x['dP_rms']:.2e} | {x['dN']:.2e} | {x['ce']:.2e} |")
        lines.append("")
    file.write_text("\n".join(lines) + "\n" + GUIDE + ("\n" + NOISE_GUIDE if noise else ""))


if __name__ == "__main__":
    raise SystemExit(main())
