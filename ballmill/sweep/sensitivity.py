"""`ballmill sensitivity STUDY.toml`: which parameters matter, by Sobol indices (SALib), the
points evaluated on Dask through the sweep's evaluators.

    [variables]                       # the parameters and the ranges they vary over (uniformly)
    "drive.t0" = [0.5, 8.0]
    "drive.n0" = [30.0, 90.0]

    [sensitivity]
    indicators = ["N_range_after", "ring_width", "valid"]   # any the points report (valid: 1 or 0)
    N = 1024                          # base sample, a power of 2: N (D + 2) evaluations for D parameters
    seed = 1                          # the scrambled Sobol' sequence and the bootstrap
    ci = 0.05                         # the widest 95 % half-width accepted before warning (below)
    resamples = 100                   # bootstrap resamples for the confidence intervals

The sample is Saltelli's (SALib.sample.sobol: matrices A, B and the D matrices A with
column i from B, first-order and total indices only); the indices are SALib.analyze.sobol's
(Saltelli 2010 for S1, Jansen for ST) with bootstrap 95 % confidence intervals. S1 is the
fraction of the indicator's variance a parameter explains alone, ST with all its
interactions; ST - S1 is what it does through the others.

An indicator that is not reported at every sample (the model stopped holding before its
window ended, or a point failed) has no indices: Sobol's estimators need every sample. The
command says how many samples lack it; narrow the ranges to where the model holds, or
study ``valid`` itself (whose indices say which parameters decide validity).

N is too small when an index's 95 % half-width exceeds ``ci``: indices are fractions of
the variance, and with ±0.05 two parameters whose indices differ by less than 0.1 cannot be
ranked. The command then warns, naming the index and the N that would bring its half-width
below ``ci`` (the half-width falls as 1/sqrt(N): N (half-width / ci)^2, to the next power of 2).

Outputs in DIR: results.parquet (every sample's evaluation, as `ballmill sweep` writes
them), sobol.parquet (indicator, parameter, S1, S1_conf, ST, ST_conf, N, evaluations),
sobol.png (bars of S1 and ST with their intervals, a panel per indicator); a table on
stdout.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import design
from .spec import StudyError

KEYS = {"indicators": "the indicators to analyse", "N": "base sample, a power of 2", "seed": "an integer",
        "ci": "the widest 95 % half-width accepted", "resamples": "bootstrap resamples"}
CONF_LEVEL = 0.95


@dataclass
class Analysis:
    ds: design.DesignStudy
    indicators: list
    N: int
    seed: int
    ci: float
    resamples: int

    def context(self) -> dict:
        return {"variables": {k: list(b) for k, b in self.ds.bounds.items()}, "N": self.N, "seed": self.seed}

    @property
    def problem(self) -> dict:
        return {"num_vars": len(self.ds.bounds), "names": self.ds.names,
                "bounds": [list(b) for b in self.ds.bounds.values()]}

    def sample(self) -> np.ndarray:
        from SALib.sample import sobol

        return sobol.sample(self.problem, self.N, calc_second_order=False, scramble=True, seed=self.seed)


def load(path: str, N=None, seed=None) -> Analysis:
    ds = design.load(path, "sensitivity")
    w = ds.where
    problems: list[str] = []
    design.check_keys(ds, KEYS, problems)
    for k, v in (("N", N), ("seed", seed)):
        if v is not None:
            ds.table[k] = v
    n = design.integer(ds, "N", 1024, problems, low=2)
    if n & (n - 1):
        problems.append(f"{w}: sensitivity.N: expected a power of 2 (Sobol' sequences balance at powers of 2), "
                        f"got {n} (e.g. {1 << round(math.log2(n))})")
    sd = design.integer(ds, "seed", 1, problems, low=0)
    res = design.integer(ds, "resamples", 100, problems, low=10)
    ci = ds.table.get("ci", 0.05)
    if not (design._number(ci) and 0 < ci < 1):
        problems.append(f"{w}: sensitivity.ci: expected a half-width in (0, 1), got {ci!r}")
    inds = ds.table.get("indicators")
    if not (isinstance(inds, list) and inds and all(isinstance(i, str) for i in inds)):
        problems.append(f"{w}: sensitivity.indicators: expected a list of indicator names, e.g. "
                        f"[\"N_range_after\", \"valid\"], got {inds!r}")
        inds = []
    elif len(set(inds)) != len(inds):
        problems.append(f"{w}: sensitivity.indicators: an indicator is listed twice in {inds}")
    if len(ds.bounds) < 2:
        problems.append(f"{w}: variables: Sobol indices need two parameters or more, got {ds.names}")
    if problems:
        raise StudyError(problems)
    return Analysis(ds, list(inds), n, sd, float(ci), res)


@dataclass
class Result:
    rows: list  # every evaluation
    table: list  # dicts: indicator, parameter, S1, S1_conf, ST, ST_conf, N, evaluations
    skipped: dict  # indicator -> why it has no indices
    warnings: list
    session: object
    wall_s: float
    plots: list = field(default_factory=list)


def run(an: Analysis, out_dir, *, scheduler=None, workers=None, batch=None, build_dir=None, progress=True,
        plots=True, log=None) -> Result:
    from SALib.analyze import sobol

    wall0 = time.perf_counter()
    X = an.sample()

    def check(known):
        problems = []
        for i, name in enumerate(an.indicators):
            design.check_indicator(an.ds, f"sensitivity.indicators[{i}]", name, known, problems)
        return problems

    session = design.Session(an.ds, out_dir, context=an.context(), check=check, scheduler=scheduler,
                             workers=workers, batch=batch, build_dir=build_dir, progress=progress,
                             total=len(X), log=log)
    try:
        rows = session.evaluate([dict(zip(an.ds.names, map(float, x))) for x in X])
    finally:
        session.close()
    table, skipped, warnings = [], {}, []
    for name in an.indicators:
        y = [design.value(r, name) for r in rows]
        missing = sum(v is None for v in y)
        if missing:
            failed = sum(r.get("status") != "ok" for r in rows)
            invalid = sum(r.get("status") == "ok" and not r.get("valid") for r in rows)
            why = [f"{invalid} left the model's validity" if invalid else "",
                   f"{failed} failed" if failed else "",
                   f"{missing - invalid - failed} valid, its window empty or past the stop"
                   if missing - invalid - failed else ""]
            skipped[name] = (f"not reported at {missing} of {len(rows)} samples ({', '.join(w for w in why if w)}): "
                             f"no indices; narrow the ranges or study 'valid'")
            continue
        Y = np.array(y, dtype=float)
        if np.ptp(Y) == 0.0:
            skipped[name] = f"the same value {Y[0]:g} at every sample: no variance to share out"
            continue
        Si = sobol.analyze(an.problem, Y, calc_second_order=False, num_resamples=an.resamples,
                           conf_level=CONF_LEVEL, print_to_console=False, seed=an.seed)
        for j, p in enumerate(an.ds.names):
            table.append({"indicator": name, "parameter": p, "S1": float(Si["S1"][j]),
                          "S1_conf": float(Si["S1_conf"][j]), "ST": float(Si["ST"][j]),
                          "ST_conf": float(Si["ST_conf"][j]), "N": an.N, "evaluations": len(X)})
    worst = max(table, key=lambda t: max(t["S1_conf"], t["ST_conf"]), default=None)
    if worst is not None and max(worst["S1_conf"], worst["ST_conf"]) > an.ci:
        hw = max(worst["S1_conf"], worst["ST_conf"])
        which = "S1" if worst["S1_conf"] >= worst["ST_conf"] else "ST"
        need = 1 << math.ceil(math.log2(an.N * (hw / an.ci) ** 2))
        warnings.append(f"N = {an.N} is too small: the 95 % interval of {which} of {worst['indicator']} over "
                        f"{worst['parameter']} is +-{hw:.3f}, wider than ci = {an.ci:g}; about N = {need} "
                        f"({need * (len(an.ds.names) + 2)} evaluations) would bring it below")
    out_dir = Path(out_dir)
    from . import engine as _eng

    cols = ["indicator", "parameter", "S1", "S1_conf", "ST", "ST_conf", "N", "evaluations"]
    _eng._write(_eng._table(table, cols, {}), out_dir / "sobol.parquet")
    res = Result(session.rows, table, skipped, warnings, session, time.perf_counter() - wall0)
    if plots and table:
        try:
            res.plots = [write_plot(an, session, table, out_dir)]
        except Exception as e:  # noqa: BLE001 - the results stand without their plot
            session.log(f"plot not written: {type(e).__name__}: {e}")
    return res


def write_plot(an: Analysis, session, table: list, out_dir: Path) -> Path:
    import textwrap

    from ..plotting import figures

    from .optimize import _label

    names = [n for n in an.indicators if any(t["indicator"] == n for t in table)]
    fig, axes = figures.subplots(len(names), 1, figsize=(max(6.0, 1.3 * len(an.ds.names) + 2.5), 3.2 * len(names) + 0.8),
                             squeeze=False, layout="tight")
    x = np.arange(len(an.ds.names))
    for ax, name in zip(axes.flat, names):
        rows = [t for t in table if t["indicator"] == name]
        ax.bar(x - 0.2, [t["S1"] for t in rows], 0.4, yerr=[t["S1_conf"] for t in rows], capsize=3,
               color="tab:blue", label="first order S1")
        ax.bar(x + 0.2, [t["ST"] for t in rows], 0.4, yerr=[t["ST_conf"] for t in rows], capsize=3,
               color="tab:orange", label="total ST")
        ax.set_xticks(x, an.ds.names)
        ax.set_ylabel("fraction of the variance [1]")
        ax.set_title(textwrap.fill(f"Sobol indices of {_label(session, name)}, N = {an.N}, "
                                   f"{int(CONF_LEVEL * 100)} % intervals", 80), fontsize=10)
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    study = session.study
    fig.suptitle(textwrap.fill(f"{study.name}: {study.description}" if study.description else study.name, 80),
                 fontsize=10)
    path = out_dir / "sobol.png"
    figures.save(fig, path)
    return path


def text_table(res: Result) -> str:
    lines = [f"{'indicator':<22} {'parameter':<18} {'S1':>7} {'+-':>6} {'ST':>7} {'+-':>6}"]
    for t in res.table:
        lines.append(f"{t['indicator']:<22} {t['parameter']:<18} {t['S1']:7.3f} {t['S1_conf']:6.3f} "
                     f"{t['ST']:7.3f} {t['ST_conf']:6.3f}")
    for name, why in res.skipped.items():
        lines.append(f"{name:<22} {why}")
    return "\n".join(lines)
