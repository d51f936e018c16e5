"""Runs the benchmark sections in order and hands the results to the report."""
from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import analysis, cosim, flavours, literal, machine, micro, profiling, report, turning
from .compiled import Compiled
from .problem import KERNEL_FAMILY, Problem, prepare_library, reference, round_order, time_round_robin


@dataclass
class Config:
    quick: bool = False
    repeats: int = 9
    formulations: tuple = ("vector", "paper")
    tols: dict = field(default_factory=dict)  # method -> tolerances (adaptive) or steps (RK4)
    literal_rtols: tuple = ()
    micro_repeats: int = 7
    micro_min_time: float = 0.1
    startup_repeats: int = 5
    ref_tol: float = 1e-13
    check_tol: float = 1e-12
    independent_check: bool = True
    target: float = 1e-6
    cc: str = "gcc"
    compiled: bool = True
    cosim: bool = True  # the coupled fast start through fmpy (section 5)
    flavours: bool = True  # native vs pythonfmu FMUs, fmpy's floor, libcosim (section 6)

    @classmethod
    def full_run(cls):
        return cls(
            tols={"DOP853": (1e-3, 1e-5, 1e-7, 1e-9, 1e-11),
                  "RK45": (1e-3, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
                  "RK4": (1e-2, 5e-3, 2e-3, 1e-3, 5e-4)},
            # down to the tightest rtol scipy accepts (100 eps): where the literal program's
            # error stops falling (cosim.literal_floor)
            literal_rtols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 3e-11, 1e-11, 3e-12, 1e-12, 1e-13,
                           3e-14),
        )

    @classmethod
    def quick_run(cls):
        return cls(
            quick=True, repeats=3, micro_repeats=5, micro_min_time=0.02, startup_repeats=3,
            independent_check=False,
            tols={"DOP853": (1e-5, 1e-9), "RK45": (1e-3, 1e-7), "RK4": (1e-2, 5e-3, 2e-3)},
            literal_rtols=(1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12),
        )


def run(cfg: Config, root: Path, out: Path, figures: Path, work: Path, progress):
    t_start = time.perf_counter()
    problem = Problem()
    data = {"cfg": cfg, "problem": problem, "root": root, "out": out, "figures": figures, "work": work}
    progress(f"ballmill bench ({'quick' if cfg.quick else 'full'}): report -> {out}")
    data["machine"] = machine.info(root, cfg.cc)
    from ballmill.physics import fast

    data["kernel_info"] = {"available": fast.KERNEL_AVAILABLE, "reason": fast.KERNEL_REASON,
                           "path": fast.KERNEL_PATH}
    data["machine"].append(("ballmill C kernel", f"built: {fast.KERNEL_PATH.name}" if fast.KERNEL_AVAILABLE
                            else f"not available: {fast.KERNEL_REASON}"))
    data["load_start"] = machine.load()

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
    data["tableaus_match_scipy"] = tableaus_match_scipy()
    lib = []
    for form in cfg.formulations:
        for method, params in cfg.tols.items():
            for p in params:
                lib.append(prepare_library(problem, ref.sample, form, method, p))
    kern = []  # the same vector settings through simulate(kernel="c")
    if fast.KERNEL_AVAILABLE:
        for method, params in cfg.tols.items():
            for p in params:
                kern.append(prepare_library(problem, ref.sample, "vector", method, p, kernel="c"))
    else:
        progress(f"library (C kernel): skipped, {fast.KERNEL_REASON}")
    lit = [literal.prepare(problem, ref.sample, rtol) for rtol in cfg.literal_rtols]
    progress(f"library ({len(lib)} settings in Python, {len(kern)} through the C kernel) and paper-literal "
             f"({len(lit)} settings): errors done; timing {cfg.repeats} rounds, one run of every setting "
             f"per round")
    time_round_robin(lib + kern + lit, cfg.repeats, progress)
    for r in lib + kern:
        fam = r.family[9:-1]
        progress(f"library {fam:8s} {r.method:6s} {r.setting:12s} |dP| {r.err_P:9.2e} m  "
                 f"|dN| {r.err_N:9.2e} N  {r.wall * 1e3:8.3f} ms" if r.ok else
                 f"library {fam:8s} {r.method:6s} {r.setting:12s} {r.message}")
    for r in lit:
        progress(f"paper-literal {r.setting:12s}      |dP| {r.err_P:9.2e} m  |dN| {r.err_N:9.2e} N  "
                 f"{r.wall * 1e3:8.1f} ms" if r.ok else f"paper-literal {r.setting:12s} {r.message}")
    data["library"] = lib
    data["kernel"] = kern
    data["kernel_same"] = same_results(kern, lib)
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
        same = same_results(comp, lib)  # does the C program reproduce the library (same algorithm)?
        ref_c = c.bench(ref.sample, "DOP853", cfg.ref_tol, 3)
        data["compiled_info"] = {"compile_time": c.compile_time, "empty_run": c.empty_run,
                                 "command": c.command, "src": c.src, "same": same, "ref": ref_c}
    elif cfg.compiled:
        progress(f"compiled: {cfg.cc} not found, peer skipped")
    data["compiled"] = comp

    # 4. analysis -----------------------------------------------------------------
    families = {
        "library (vector)": [r for r in lib if r.family == "library (vector)"],
        "library (paper)": [r for r in lib if r.family == "library (paper)"],
        "paper-literal": lit,
    }
    if kern:
        families[KERNEL_FAMILY] = kern
    if comp:
        families["compiled (C)"] = comp
    data["families"] = families
    data["fronts"] = {k: analysis.pareto(v) for k, v in families.items()}
    data["at_target"] = {k: analysis.time_at_error(v, cfg.target) for k, v in families.items()}

    # headline: the front points that decide it, re-timed interleaved -------------------
    data["headline"] = headline(data, cfg, progress)

    # 5. where the time goes ---------------------------------------------------------
    at_lib = data["at_target"]["library (vector)"]
    prof_settings = []
    if at_lib.cheapest is not None:
        c0 = at_lib.cheapest
        prof_settings.append((c0.family.split("(")[1].rstrip(")"), c0.method, c0.param))
    if ("vector", "DOP853", 1e-9) not in prof_settings:
        prof_settings.append(("vector", "DOP853", 1e-9))
    data["profile"] = []
    for form, method, p in prof_settings:
        progress(f"profile: library {form} {method} {p:g}")
        swept = next((r for r in lib if r.family == f"library ({form})" and r.method == method
                      and r.param == p and r.ok), None)
        dec = profiling.decomposition(problem, form, method, p, cfg.repeats,
                                      min_time=cfg.micro_min_time, repeats_unit=cfg.micro_repeats,
                                      total=swept.wall if swept else None)
        total, top = profiling.cprofile_top(problem, form, method, p)
        data["profile"].append(((form, method, p), dec, total, top))

    # 6. co-simulation through fmpy ------------------------------------------------
    data["cosim_lines"] = []
    if cfg.cosim:
        progress("co-simulation: the fast start as MotorStartup -> BallInShell through fmpy")
        rows = cosim.coupled(cfg.repeats if cfg.quick else 5, cfg.quick, progress)
        for r in rows:
            progress(f"coupled {r['setting']:44s} H {r['step'] * 1e3:5.1f} ms  |dP| {r['dP']:9.2e} m  "
                     f"|dN| {r['dN']:9.2e} N  {r['wall']:.3f} s")
        progress("co-simulation: process start to the first communication step")
        start = cosim.startup(cfg.startup_repeats)
        progress("co-simulation: cold (first run in a process) and warm whole runs")
        cw = cosim.cold_warm(3 if cfg.quick else 5)
        breakdown = cosim.load_breakdown(5 if cfg.quick else 15)
        progress("co-simulation: against the paper-literal program at matched contact-point errors")
        match = cosim.matched(lit, rows, cfg.repeats if cfg.quick else 9, progress)
        floor = cosim.literal_floor(lit, ref.sample.P, problem.grid, problem.drive.t0)
        progress("co-simulation: cost of each scene choice per communication step")
        scene, forces = cosim.scene_costs(3 if cfg.quick else 5)
        data["cosim_lines"] = cosim.report(rows, start, scene, forces, cw, match, floor, breakdown)
        data["cosim_rows"] = rows
        data["cosim_match"] = match

    # 7. a chamber that turns ------------------------------------------------------
    progress("turning chamber: cost per step of the general model against the translation-only one")
    data["turning_lines"] = turning.report(turning.measure(3 if cfg.quick else 7, cfg.micro_min_time))

    # 8. the two FMU flavours ------------------------------------------------------
    data["flavour_lines"] = []
    if cfg.flavours:
        data["flavour_lines"] = flavours.section(
            cfg.repeats if cfg.quick else 5, cfg.quick,
            lambda err: analysis.time_at_error(lit, err).time, progress)

    figures.mkdir(parents=True, exist_ok=True)
    fig = figures / "error_vs_time.png"
    analysis.figure(lib + kern + lit + comp, fig, cfg.target)
    data["figure"] = fig
    progress(f"figure: {fig}")
    data["load_end"] = machine.load()
    data["runtime"] = time.perf_counter() - t_start
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(report.markdown(data))
    return data


def headline(data, cfg: Config, progress):
    """Re-time the settings that decide the headline (the front points around the
    target, library and paper-literal), round-robin so that both families see the
    same machine conditions; return per-family times at the target."""
    at = data["at_target"]
    chosen = {}
    retime = [f for f in ("library (vector)", KERNEL_FAMILY, "paper-literal") if f in at]
    for fam in retime:
        a = at[fam]
        pts = list(a.bracket) if a.bracket else ([a.cheapest] if a.cheapest is not None else [])
        for r in pts:
            if "rerun" in r.extra:
                chosen[id(r)] = r
    rounds = max(cfg.repeats, 3 if cfg.quick else 9)
    walls = {k: [] for k in chosen}
    progress(f"headline: re-timing {len(chosen)} settings interleaved, {rounds} rounds")
    order = list(chosen.items())
    for j in range(rounds):
        for k, r in round_order(order, j):
            t0 = time.perf_counter()
            r.extra["rerun"]()
            walls[k].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in walls.items()}

    def wall_of(r):
        return med.get(id(r), r.wall)

    out = {"rounds": rounds, "settings": [(r, med[k], walls[k]) for k, r in chosen.items()], "times": {}}
    for fam, a in at.items():
        out["times"][fam] = analysis.retimed(a, wall_of) if fam in retime else a.time
    return out


def same_results(results, lib):
    """Each result against the pure-Python library (vector) run of the same method and
    setting: (method, setting, max |dP|, max |dN|, (steps, nfev) Python, (steps, nfev) other)."""
    same = []
    libv = {(r.method, r.param): r for r in lib if r.family == "library (vector)"}
    for r in results:
        twin = libv.get((r.method, r.param))
        if twin is not None and "sample" in twin.extra and r.ok and "sample" in r.extra:
            a, b = twin.extra["sample"], r.extra["sample"]
            if a.P.shape != b.P.shape:
                continue
            dP = float(np.max(np.linalg.norm(a.P - b.P, axis=1)))
            same.append((r.method, r.setting, dP, float(np.max(np.abs(a.N - b.N))),
                         (twin.steps, twin.nfev), (r.steps, r.nfev)))
    return same


def tableaus_match_scipy() -> bool:
    """The library's embedded DOP853/RK45 coefficients equal scipy's, bit for bit."""
    from scipy.integrate._ivp import dop853_coefficients as dop
    from scipy.integrate._ivp.rk import RK45

    from ballmill.physics.integrators import TABLEAUS

    d, r, n = TABLEAUS["DOP853"], TABLEAUS["RK45"], dop.N_STAGES
    return bool(np.array_equal(d.A, dop.A[:n, :n]) and np.array_equal(d.B, dop.B)
                and np.array_equal(d.C, dop.C[:n]) and np.array_equal(d.E, dop.E5)
                and np.array_equal(d.E3, dop.E3) and np.array_equal(r.A[:, :RK45.A.shape[1]], RK45.A)
                and not r.A[:, RK45.A.shape[1]:].any() and np.array_equal(r.B, RK45.B)
                and np.array_equal(r.C, RK45.C) and np.array_equal(r.E, RK45.E))
