"""Coupling error of the ball absorber as a co-simulation: Structure + BallInShell FMUs under the
scenario runner's Jacobi master against the monolithic structure + ball model, with and without
the iteration of their algebraic loop.

This module owns that measurement (`measure`), its table and figure (`section`, written into
docs/absorber.md between the markers below by `python -m ballmill.studies.absorber_cosim`, and
spliced into BENCHMARKS.md by `ballmill bench`'s absorber section), and nothing else: the FMUs
are ballmill.fmi's, the master ballmill.scenario.runner's, the reference
ballmill.absorber.model.simulate_absorber (DOP853 at rtol 1e-12, the algebraic loop solved
exactly at every instant).

The case is scenarios/absorber_frf.toml (100 kg, 0.8 Hz, 1 % damping, a 2 kg ball tuned to
0.8 Hz, 0.05 N) excited at 0.8 Hz, run for T_END s from rest, with the Structure's internal RK4 at
h_max = 0.5 ms so that its own error stays below the coupling error. The error is the largest
difference over the run of the structure's displacement at the absorber and of the ball's
contact point (xP, yP). A second case, a 10 kg structure (mass ratio 20 %), shows what the
loop iteration is for: the plain Jacobi exchange is unstable there.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
STEPS = (0.001, 0.002, 0.005, 0.01, 0.02)
T_END = 20.0
REF_DT = 0.001
FREQUENCY = 0.8  # Hz: the excitation at the tuning frequency (the scenario's default is 0.7 Hz)
MODES = ("iterate", "ignore")
START, END = "<!-- absorber_cosim:start -->", "<!-- absorber_cosim:end -->"


def _reference(mass: float, t_end: float):
    from ballmill.absorber.linear import cavity_radius
    from ballmill.absorber.model import StructureBall, simulate_absorber
    from ballmill.absorber.structure import HarmonicForce, Structure
    from ballmill.physics import Ball

    ball = Ball(r=0.025, R=cavity_radius(0.8, 0.025), m=2.0, mu=0.3)
    sb = StructureBall(Structure.single(mass, 0.8, 0.01), ball, HarmonicForce(0.05, FREQUENCY))
    return simulate_absorber(sb, t_end, REF_DT, tol=1e-12, x_ref=1e-4)


def measure(steps=STEPS, t_end: float = T_END, mass: float = 100.0, modes=MODES, flavour: str = "native",
            build_dir: Path | None = None, progress=None) -> list[dict]:
    """One row per (H, mode): H [s], mode, x_err [m] (structure displacement), P_err [m]
    (contact point), x_max [m] (the reference's largest displacement), sweeps (Gauss-Seidel
    sweeps per communication point), success, wall [s]."""
    from ballmill.scenario import runner

    mono = _reference(mass, t_end)
    overrides = ["structure.h_max=0.0005", f"structure.f_exc={FREQUENCY}", f"structure.M_x1={mass}", f"structure.L_x1={mass}",
                 f"structure.M_y1={mass}", f"structure.L_y1={mass}"]
    sc, models, paths = runner.prepare("absorber_frf", overrides, build_dir=build_dir, log=lambda *a: None,
                                       flavour=flavour)
    sc.stop = t_end
    rows = []
    for H in steps:
        for mode in modes:
            sc.step = H
            sc.master = dict(sc.master, algebraic_loops=mode)
            wall = time.perf_counter()
            res = runner.run(sc, models, paths, progress=False, echo=False)
            wall = time.perf_counter() - wall
            t = res.column("time")
            idx = np.rint(t / REF_DT).astype(int)
            with np.errstate(all="ignore"):
                x_err = float(np.max(np.abs(res.column("structure.x_rel") - mono["xO"][idx])))
                P_err = float(np.max(np.hypot(res.column("ball.xP") - mono["xP"][idx],
                                              res.column("ball.yP") - mono["yP"][idx])))
            rows.append({"H": H, "mode": mode, "x_err": x_err if np.isfinite(x_err) else float("inf"),
                         "P_err": P_err if np.isfinite(P_err) else float("inf"),
                         "x_max": float(np.max(np.abs(mono["xO"]))), "sweeps": res.loop_sweeps / max(1, len(t)),
                         "success": res.success and len(t) == len(np.arange(0, t_end + H / 2, H)),
                         "message": res.message, "wall": wall, "mass": mass})
            if progress:
                progress(f"absorber co-simulation M = {mass:g} kg, H = {H * 1e3:g} ms, {mode}: "
                         f"x error {x_err:.3g} m")
    return rows


def orders(rows, mode: str, key: str = "x_err") -> list[float]:
    """Observed order between consecutive steps: log(e2 / e1) / log(H2 / H1)."""
    sel = [r for r in rows if r["mode"] == mode]
    return [float(np.log(b[key] / a[key]) / np.log(b["H"] / a["H"])) for a, b in zip(sel, sel[1:])]


def _fmt(x: float) -> str:
    return "diverges" if not np.isfinite(x) or x > 1.0 else f"{x:.2e}"


def figure(rows, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for mode, style in (("iterate", "o-"), ("ignore", "s--")):
        sel = [r for r in rows if r["mode"] == mode]
        H = [r["H"] * 1e3 for r in sel]
        ax.loglog(H, [r["x_err"] for r in sel], style, label=f"structure displacement, loop {mode}d"
                  if mode == "ignore" else "structure displacement, loop iterated")
        ax.loglog(H, [r["P_err"] for r in sel], style, alpha=0.6,
                  label="ball contact point, loop " + ("ignored" if mode == "ignore" else "iterated"))
    h = np.array([1.0, 20.0])
    ref = [r for r in rows if r["mode"] == "iterate"][0]
    ax.loglog(h, ref["x_err"] * (h / (ref["H"] * 1e3)) ** 3, "k:", label="slope 3")
    ax.set_xlabel("communication step H [ms]")
    ax.set_ylabel("largest error over the run [m]")
    ax.set_title("Structure + BallInShell co-simulation vs the monolithic model")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def section(rows, strong, figure_name: str | None = None, command: str = "", t_end: float = T_END) -> str:
    """The Markdown section: the error table against H, observed orders, the strong-coupling case."""
    by = {(r["H"], r["mode"]): r for r in rows}
    gain = [by[(H, "iterate")]["x_err"] / by[(H, "ignore")]["x_err"] for H in sorted({r["H"] for r in rows})]
    lines = ["## The absorber as a co-simulation: coupling error against the communication step", "",
             "Structure FMU + BallInShell FMU (`scenarios/absorber_frf.toml`: 100 kg, 0.8 Hz, 1 % damping, "
             "a 2 kg ball tuned to 0.8 Hz, 0.05 N, here at 0.8 Hz) under the scenario runner's Jacobi master, "
             f"native flavour, {t_end:g} s from rest, against the monolithic structure + ball model "
             "(`simulate_absorber`, DOP853 at 1e-12). The ball takes the cavity's position, velocity "
             "and acceleration (input_mode 1); the structure takes the ball's force, extrapolated "
             "quadratically over a step (input_order 2), and integrates by RK4 at h_max = 0.5 ms. "
             "The cavity's acceleration depends directly on the ball's force and the force on the "
             "acceleration: an algebraic loop, found by the master from the FMUs' ModelStructure and "
             "iterated at every communication point (`[master] algebraic_loops = \"iterate\"`, "
             "Gauss-Seidel sweeps to 1e-10) or left to the plain Jacobi exchange (`\"ignore\"`). "
             "Errors are the largest over the run; the largest displacement is "
             f"{rows[0]['x_max']:.3g} m." + (f" Command: `{command}`." if command else ""), "",
             "| H [ms] | displacement error, iterated [m] | contact point error, iterated [m] | "
             "sweeps per point | displacement error, ignored [m] | contact point error, ignored [m] |",
             "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    by = {(r["H"], r["mode"]): r for r in rows}
    for H in sorted({r["H"] for r in rows}):
        a, b = by.get((H, "iterate")), by.get((H, "ignore"))
        lines.append(f"| {H * 1e3:g} | {_fmt(a['x_err'])} | {_fmt(a['P_err'])} | {a['sweeps']:.1f} | "
                     f"{_fmt(b['x_err'])} | {_fmt(b['P_err'])} |")
    oi, on = orders(rows, "iterate"), orders(rows, "ignore")
    lines += ["", f"Observed order in H (displacement, between consecutive steps): iterated "
              f"{', '.join(f'{o:.2f}' for o in oi)}; ignored {', '.join(f'{o:.2f}' for o in on)}. "
              "Third order, as the quadratic extrapolation of the ball's force over a step gives "
              "(local error H^4 in the structure's state, global H^3); with input_order 1 it is "
              "second order, with 0 (hold) first. At this mass ratio (2 %, loop gain about "
              "(2/7) m / M = 0.006) the loop iteration multiplies the error by "
              f"{min(gain):.2f}-{max(gain):.2f}: the values "
              "exchanged at a communication point agree, instead of one side seeing the other's "
              "extrapolation.", ""]
    if strong:
        by = {(r["H"], r["mode"]): r for r in strong}
        lines += [f"With a {strong[0]['mass']:g} kg structure (mass ratio 20 %, loop gain about 0.06) "
                  "the plain Jacobi exchange is unstable, and only the iterated loop converges:", "",
                  "| H [ms] | displacement error, iterated [m] | displacement error, ignored [m] |",
                  "| ---: | ---: | ---: |"]
        for H in sorted({r["H"] for r in strong}):
            lines.append(f"| {H * 1e3:g} | {_fmt(by[(H, 'iterate')]['x_err'])} | "
                         f"{_fmt(by[(H, 'ignore')]['x_err'])} |")
        lines.append("")
    if figure_name:
        lines += [f"![coupling error against H]({figure_name})", ""]
    return "\n".join(lines)


def splice(path: Path, text: str) -> None:
    """Put text between the markers in path (appended with them when absent)."""
    old = path.read_text() if path.exists() else ""
    block = f"{START}\n{text.rstrip()}\n{END}"
    if START in old and END in old:
        new = old[:old.index(START)] + block + old[old.index(END) + len(END):]
    else:
        new = old.rstrip() + "\n\n" + block + "\n"
    path.write_text(new)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m ballmill.studies.absorber_cosim", description=__doc__.split("\n")[0])
    ap.add_argument("--docs", default=str(ROOT / "docs"), help="folder of absorber.md and figures/")
    ap.add_argument("--quick", action="store_true", help="10 s runs instead of 20 s")
    args = ap.parse_args(argv)
    docs = Path(args.docs)
    t_end = 10.0 if args.quick else T_END
    rows = measure(t_end=t_end, progress=lambda m: print(m, file=sys.stderr))
    strong = measure(steps=(0.005, 0.01, 0.02), t_end=t_end, mass=10.0,
                     progress=lambda m: print(m, file=sys.stderr))
    figure(rows, docs / "figures" / "absorber_cosim_error.png")
    splice(docs / "absorber.md", section(rows, strong, "figures/absorber_cosim_error.png",
                                         "python -m ballmill.studies.absorber_cosim"
                                         + (" --quick" if args.quick else ""), t_end))
    print(f"wrote {docs / 'absorber.md'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
