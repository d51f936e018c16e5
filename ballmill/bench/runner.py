"""Runs the benchmark sections in order and hands the results to the report."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import analysis, literal, machine, micro, profiling, report
from .compiled import Compiled
from .problem import Problem, bench_library, reference


@dataclass
class Config:
    quick: bool = False
    repeats: int = 5
    formulations: tuple = ("vector", "paper")
    tols: dict = field(default_factory=dict)  # method -> tolerances (adaptive) or steps (RK4)
    literal_rtols: tuple = ()
    micro_repeats: int = 7
    micro_min_time: float = 0.2
    startup_repeats: int = 5
    ref_tol: float = 1e-13
    check_tol: float = 1e-12
    independent_check: bool = True
    target: float = 1e-6
    cc: str = "gcc"
    compiled: bool = True

    @classmethod
    def full(cls):
        return cls(
            tols={"DOP853": (1e-3, 1e-5, 1e-7, 1e-9, 1e-11),
                  "RK45": (1e-3, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
                  "RK4": (1e-2, 5e-3, 2e-3, 1e-3, 5e-4)},
            literal_rtols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11),
        )

    @classmethod
    def quick(cls):
        return cls(
            quick=True, repeats=3, micro_repeats=5, micro_min_time=0.03, startup_repeats=3,
            independent_check=False,
            tols={"DOP853": (1e-5, 1e-9), "RK45": (1e-3, 1e-7), "RK4": (1e-2, 5e-3, 2e-3)},
            literal_rtols=(1e-6, 1e-7, 1e-8, 1e-9),
        )


def run(cfg: Config, root: Path, out: Path, figures: Path, work: Path, progress):
    t_start = time.perf_counter()
    problem = Problem()
    data = {"cfg": cfg, "problem": problem, "root": root, "out": out, "figures": figures, "work": work}
    progress(f"ballmill bench ({'quick' if cfg.quick else 'full'}): report -> {out}")
    data["machine"] = machine.info(root, cfg.cc)

    # 1. micro ---------------------------------------------------------------
    progress("micro: right-hand sides")
    data["micro_rhs"] = micro.rhs_cases(problem, cfg.micro_repeats, cfg.micro_min_time)
    progress("micro: one communication step of BallModel.advance")
    data["micro_adv"] = micro.advance_cases(problem, cfg.micro_repeats, cfg.micro_min_time)
    progress("micro: process start-up (fresh interpreters)")
    data["startup"] = micro.startup(root, cfg.startup_repeats)

    # 2. reference and library grid -------------------------------------------
    progress(f"reference: library DOP853 tol {cfg.ref_tol:g} and convergence checks")
    ref = reference(problem, cfg.ref_tol, cfg.check_tol, independent=cfg.independent_check)
    data["ref"] = ref
    lib = []
    for form in cfg.formulations:
        for method, params in cfg.tols.items():
            for p in params:
                r = bench_library(problem, ref.sample, form, method, p, cfg.repeats)
                lib.append(r)
                progress(f"library {form:6s} {method:6s} {r.setting:12s} |dP| {r.err_P:9.2e} m  "
                         f"|dN| {r.err_N:9.2e} N  {r.wall * 1e3:8.1f} ms")
    data["library"] = lib

    # 3a. paper-literal ---------------------------------------------------------
    lit = []
    for rtol in cfg.literal_rtols:
        r = literal.bench(problem, ref.sample, rtol, cfg.repeats)
        lit.append(r)
        if r.ok:
            progress(f"paper-literal rtol {rtol:7.0e}     |dP| {r.err_P:9.2e} m  |dN| {r.err_N:9.2e} N  "
                     f"{r.wall * 1e3:8.1f} ms")
        else:
            progress(f"paper-literal rtol {rtol:7.0e}     {r.message}")
    data["literal"] = lit
    progress("paper-literal: N by the paper's own route (cubic splines, rtol 1e-12)")
    data["spline"] = literal.spline_error(problem, ref.sample)

    # 3b. compiled ----------------------------------------------------------------
    comp = []
    data["compiled_info"] = None
    if cfg.compiled and Compiled.available(cfg.cc):
        c = Compiled(problem, work, cfg.cc)
        progress(f"compiled: generating {c.src} and compiling")
        c.build()
        c.measure_empty(max(cfg.repeats, 5))
        progress(f"compiled: compile {c.compile_time:.2f} s, empty run {c.empty_run * 1e3:.2f} ms")
        for method, params in cfg.tols.items():
            for p in params:
                r = c.bench(ref.sample, method, p, cfg.repeats)
                comp.append(r)
                progress(f"compiled        {method:6s} {r.setting:12s} |dP| {r.err_P:9.2e} m  "
                         f"|dN| {r.err_N:9.2e} N  {r.wall * 1e3:8.3f} ms")
        same = []  # does the C program reproduce the library (same algorithm)?
        libv = {(r.method, r.param): r for r in lib if r.family == "library (vector)"}
        for r in comp:
            twin = libv.get((r.method, r.param))
            if twin is not None and "sample" in twin.extra and r.ok:
                a, b = twin.extra["sample"], r.extra["sample"]
                dP = float(np.max(np.linalg.norm(a.P - b.P, axis=1)))
                same.append((r.method, r.setting, dP, float(np.max(np.abs(a.N - b.N))),
                             (twin.steps, twin.nfev), (r.steps, r.nfev)))
        ref_c = c.bench(ref.sample, "DOP853", cfg.ref_tol, 3)
        data["compiled_info"] = {"compile_time": c.compile_time, "empty_run": c.empty_run,
                                 "command": c.command, "src": c.src, "same": same, "ref": ref_c}
    elif cfg.compiled:
        progress(f"compiled: {cfg.cc} not found, peer skipped")
    data["compiled"] = comp

    # 4. analysis -----------------------------------------------------------------
    families = {
        "library (any setting)": lib,
        "library (vector)": [r for r in lib if r.family == "library (vector)"],
        "library (paper)": [r for r in lib if r.family == "library (paper)"],
        "paper-literal": lit,
    }
    if comp:
        families["compiled (C)"] = comp
    data["families"] = families
    data["fronts"] = {k: analysis.pareto(v) for k, v in families.items()}
    data["at_target"] = {k: analysis.time_at_error(v, cfg.target) for k, v in families.items()}

    # 5. where the time goes ---------------------------------------------------------
    at_lib = data["at_target"]["library (any setting)"]
    prof_settings = []
    if at_lib.cheapest is not None:
        c0 = at_lib.cheapest
        prof_settings.append((c0.family.split("(")[1].rstrip(")"), c0.method, c0.param))
    if ("vector", "DOP853", 1e-9) not in prof_settings:
        prof_settings.append(("vector", "DOP853", 1e-9))
    data["profile"] = []
    for form, method, p in prof_settings:
        progress(f"profile: library {form} {method} {p:g}")
        dec = profiling.decomposition(problem, form, method, p, cfg.repeats,
                                      min_time=cfg.micro_min_time / 2)
        total, top = profiling.cprofile_top(problem, form, method, p)
        data["profile"].append(((form, method, p), dec, total, top))

    figures.mkdir(parents=True, exist_ok=True)
    fig = figures / "error_vs_time.png"
    analysis.figure(lib + lit + comp, fig, cfg.target)
    data["figure"] = fig
    progress(f"figure: {fig}")
    data["runtime"] = time.perf_counter() - t_start
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(report.markdown(data))
    return data
