"""Benchmark section "Ball absorber as a co-simulation" of BENCHMARKS.md.

    ballmill bench --section absorber [--quick]     run only this section and splice it into the report

The coupling error of Structure + BallInShell under the scenario runner against the monolithic
structure + ball model, for communication steps H = 1, 2, 5, 10, 20 ms, with and without the
iteration of their algebraic loop, and the wall time of each run (the measurement and its
table are ballmill.studies.absorber_cosim's; this module only frames them as a report
section). Quick mode: 10 s of simulated time instead of 20 s.
"""
from __future__ import annotations

from pathlib import Path

from .report import splice_section

BEGIN, END = "<!-- section: absorber -->", "<!-- end of section: absorber -->"


def report(rows, strong, t_end: float, quick: bool) -> str:
    from ballmill.studies import absorber_cosim

    text = absorber_cosim.section(rows, strong, command="ballmill bench --section absorber"
                                  + (" --quick" if quick else ""), t_end=t_end)
    walls = ", ".join(f"{r['H'] * 1e3:g} ms {r['mode']} {r['wall']:.2f} s" for r in rows)
    return (f"{BEGIN}\n{text.rstrip()}\n\nWall time of each {t_end:g} s run (native FMUs through the runner, "
            f"on a shared machine): {walls}.\n{END}\n")


def splice(path: Path, section: str):
    """Put the section into the report at path (replacing an earlier one, else appended)."""
    splice_section(path, section, BEGIN, END)


def run_section(out: Path, quick: bool, progress=print) -> Path:
    from ballmill.studies import absorber_cosim

    t_end = 10.0 if quick else absorber_cosim.T_END
    rows = absorber_cosim.measure(t_end=t_end, progress=progress)
    strong = absorber_cosim.measure(steps=(0.005, 0.01, 0.02), t_end=t_end, mass=10.0, progress=progress)
    splice(out, report(rows, strong, t_end, quick))
    return out
