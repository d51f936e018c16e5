"""The absorber case of the sweep layer: response curves of a ball absorber, point by point on the engine.

This module owns the study case ``case = "absorber"`` (scenarios/studies/absorber_frf*.toml):
its parameters (a pseudo-scenario with instances ``structure``, ``ball``,
``excitation`` and ``sweep``), the evaluator that computes one point with the
monolithic structure + ball model (`ballmill.absorber.response.steady_state`:
no FMU, the algebraic loop solved exactly), the refinement rounds of the
frequency grid, the chains of the continued sweeps, and the files it writes
beside results.parquet: ``frf.csv`` and ``frf.png``.

Parameters (``--set`` / ``set = {...}`` / ``[grid]``, as for any study):

    structure.M, structure.f, structure.zeta, structure.both_axes
        one mode per horizontal axis: modal mass [kg], frequency [Hz], damping
        ratio; both_axes false: the structure does not move in y
    ball.r, ball.m, ball.R, ball.f_tune, ball.mu, ball.delta, ball.c_drag, ball.zeta, ball.seed_y
        radius [m], mass [kg], cavity radius [m] (0: tuned, R = r + 5 g / (7 (2 pi
        f_tune)^2), f_tune [Hz] 0: the structure's f), friction coefficient,
        rolling resistance [m], drag [N s/m], a linear damping ratio realised by
        drag (added to c_drag), the ball's start off the forcing plane [m] (lets
        an out-of-plane whirl show)
    excitation.F0, excitation.frequency, excitation.load
        amplitude [N] (or [m/s2] with load = "ground"), frequency [Hz] (the swept
        one), "force" (on the structure in x) or "ground" (ground acceleration in x)

Modes (``mode`` in the study file, ``--mode``):

* ``steady``: independent steady states, each from the linear steady state.
  After each round the evaluator's `next_points` asks
  `ballmill.absorber.response.refine` which frequencies to add around every
  local maximum of each curve (per combination of the other swept
  parameters) until a parabola through the three points around it agrees
  with the sampled height within ``refine_rtol`` or the spacing is
  ``df_min``; each round is one batch of tasks on the engine (Dask), so the
  refined points run in parallel too; at most ``refine_rounds`` rounds.
* ``up`` / ``down`` / ``both``: stepped sweeps; each point continues from the
  previous one's final state with the excitation's phase continued, so a
  response stays on its branch until the branch ends and jumps. The
  pseudo-parameter ``sweep.direction`` ("up", "down") is swept with the
  frequency; a whole sweep (one direction, one combination of the other
  parameters) is one chain, run in order in one task (chains run in
  parallel). No refinement: a finer step changes the path a sweep takes, so
  sweeps use the grid they are given.

Every point carries the bare structure's amplitude (closed form, exact: the
bare structure is linear) and the linear two-degree-of-freedom theory's
(`ballmill.absorber.linear`), the ball's validity over its last window
(rolling: |F_t|/N <= mu; contact: N > 0), its largest angle and amplitude.
"""
from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .evaluators import Evaluator, Prepared, register, register_case
from .spec import StudyError

FREQ = "excitation.frequency"
DIRECTION = "sweep.direction"

# instance -> parameter -> (default, unit, description)
PARAMS = {
    "structure": {
        "M": (100.0, "kg", "modal mass per axis"),
        "f": (0.8, "Hz", "natural frequency of the bare structure"),
        "zeta": (0.01, "1", "damping ratio of the bare structure"),
        "both_axes": (True, "", "the structure moves in y too (the same mode); false: only in x"),
    },
    "ball": {
        "r": (0.025, "m", "ball radius"),
        "m": (2.0, "kg", "ball mass"),
        "R": (0.0, "m", "cavity radius; 0: tuned to f_tune"),
        "f_tune": (0.0, "Hz", "frequency the cavity is tuned to when R = 0; 0: the structure's f"),
        "mu": (0.3, "1", "friction coefficient (rolling needs |F_t| <= mu N)"),
        "delta": (0.0, "m", "rolling resistance length"),
        "c_drag": (0.0, "N.s/m", "viscous drag on the ball's centre"),
        "zeta": (0.0, "1", "linear damping ratio of the ball, realised by drag (added to c_drag)"),
        "seed_y": (0.0, "m", "the ball starts this far off the forcing plane"),
    },
    "excitation": {
        "F0": (0.05, "N", "amplitude of the harmonic load in x (m/s2 for load = ground)"),
        "frequency": (0.8, "Hz", "excitation frequency"),
        "load": ("force", "", "force (on the structure) or ground (ground acceleration)"),
    },
    "sweep": {"direction": ("steady", "", "steady state, or the direction of a continued sweep (up, down)")},
}

# the results' columns of this evaluator (name -> (unit, description)), in order
INDICATORS = {
    "amplitude_m": ("m", "steady-state amplitude (first harmonic) of the structure at the cavity, with the ball"),
    "amplitude_bare_m": ("m", "the same structure without the ball (closed form, exact)"),
    "amplitude_linear_m": ("m", "with the ball, linear two-degree-of-freedom theory (5/7 m absorbing)"),
    "amplitude_err_m": ("m", "error estimate of amplitude_m (spread of the settling windows)"),
    "peak_m": ("m", "largest |x_O - mean| over the last window (harmonic fit)"),
    "amplitude_y_m": ("m", "first-harmonic amplitude of the structure in y (a whirling ball moves it)"),
    "phase_rad": ("rad", "phase of x_O's fundamental against the excitation"),
    "ball_amplitude_m": ("m", "first-harmonic amplitude of the ball centre's x relative to the cavity"),
    "ball_angle_max_deg": ("deg", "largest angle of the ball from the cavity's bottom (last window)"),
    "friction_ratio_max": ("1", "largest |F_t| / N over the last window (rolling needs <= mu)"),
    "N_min_N": ("N", "smallest normal force over the last window (contact needs > 0)"),
    "rolling": ("", "the ball rolled without slip throughout the last window"),
    "contact": ("", "the ball kept contact with the wall"),
    "converged": ("", "the amplitude settled (last windows agree to model.rtol)"),
    "periods": ("1", "excitation periods integrated for this point"),
    "t_end_s": ("s", "simulated time at the end of the point (a sweep's time runs on)"),
    "restarted": ("", "a sweep point that did not continue from its predecessor (it lost contact)"),
}

MODES = ("steady", "up", "down", "both")
MODEL = {"kind": "auto", "tolerance": 1e-9, "rtol": 1e-3, "max_periods": 400, "refine_rounds": 8,
         "refine_rtol": 0.003, "df_min": 2e-4}
POSITIVE = ("tolerance", "rtol", "max_periods", "refine_rtol", "df_min")
ERROR_METHOD = ("amplitude_err_m: spread of the last settling windows' amplitudes, or the Aitken "
                "extrapolation of their trend when larger")


# ----------------------------------------------------------------------------
# the pseudo-scenario
@dataclass
class _Instance:
    parameters: dict
    fmu: str | None = None


@dataclass
class CaseScenario:
    """What the engine reads of a scenario, for a built-in case: name, instances with
    their parameters (defaults with the study's fixed overrides in), the text its
    results depend on (hashed into the study's context)."""

    name: str
    instances: dict
    text: str
    case: str = "absorber"
    start: float = 0.0
    stop: float = 0.0
    connections: tuple = ()
    summary: dict = field(default_factory=dict)
    path: Path | None = None


def _check_value(inst: str, param: str, v, where: str) -> str:
    default, unit, _ = PARAMS[inst][param]
    u = f" {unit}" if unit else ""
    if isinstance(default, bool):
        return "" if isinstance(v, bool) else f"{where}: {inst}.{param}: expected true or false, got {v!r}"
    if isinstance(default, str):
        allowed = {"load": ("force", "ground"), "direction": ("steady", "up", "down")}[param]
        return "" if v in allowed else f"{where}: {inst}.{param}: expected one of {allowed}, got {v!r}"
    if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
        return f"{where}: {inst}.{param}: expected a finite number{u}, got {v!r}"
    if param in ("M", "f", "r", "m", "F0", "frequency") and not v > 0:
        return f"{where}: {inst}.{param} = {v!r}{u}: must be positive"
    if v < 0 and param not in ("seed_y",):
        return f"{where}: {inst}.{param} = {v!r}{u}: must not be negative"
    return ""


def scenario(set_=()) -> CaseScenario:
    """The absorber case with the fixed overrides ``set_`` ("inst.param=value") applied;
    StudyError names every unknown parameter or bad value."""
    from ..scenario import spec as _scen

    values = {inst: {p: d for p, (d, _, _) in ps.items()} for inst, ps in PARAMS.items()}
    problems = []
    for text in set_:
        try:
            inst, param, v = _scen.parse_override(text)
        except _scen.ScenarioError as e:
            problems += e.problems
            continue
        if inst not in PARAMS or param not in PARAMS[inst]:
            known = ", ".join(f"{i}.{p}" for i, ps in PARAMS.items() for p in ps)
            problems.append(f"--set {text}: the absorber case has no parameter {inst}.{param} (known: {known})")
            continue
        if isinstance(v, int) and not isinstance(v, bool) and isinstance(PARAMS[inst][param][0], float):
            v = float(v)
        why = _check_value(inst, param, v, "--set")
        if why:
            problems.append(why)
            continue
        values[inst][param] = v
    if problems:
        raise StudyError(problems)
    text = repr(sorted((i, sorted(ps.items())) for i, ps in values.items())) + " absorber case v1"
    return CaseScenario("absorber", {i: _Instance(ps) for i, ps in values.items()}, text)


def check_study(grid: dict, model: dict, mode: str, where: str) -> list[str]:
    """Problems of an absorber study's grid and model settings."""
    problems = []
    if FREQ not in grid:
        problems.append(f"{where}: grid: an absorber study sweeps {FREQ} (e.g. \"{FREQ}\" = \"0.5:1.1:61\" [Hz])")
    if DIRECTION in grid:
        problems.append(f"{where}: grid: {DIRECTION} comes from mode (steady, up, down, both), not from the grid")
    for key, vals in grid.items():
        inst, _, param = key.partition(".")
        if inst not in PARAMS or param not in PARAMS[inst]:
            problems.append(f"{where}: grid: the absorber case has no parameter {key}")
            continue
        for v in vals:
            why = _check_value(inst, param, float(v) if isinstance(v, int) and not isinstance(v, bool) else v, where)
            if why:
                problems.append(why)
                break
    rounds = model.get("refine_rounds")
    if not (isinstance(rounds, int) and not isinstance(rounds, bool) and rounds >= 0):
        problems.append(f"{where}: model.refine_rounds: expected a non-negative integer, got {rounds!r}")
    mp = model.get("max_periods")
    if not (isinstance(mp, int) and not isinstance(mp, bool) and mp >= 4):
        problems.append(f"{where}: model.max_periods: expected an integer >= 4 (excitation periods), got {mp!r}")
    return problems


def study_grid(grid: dict, mode: str) -> dict:
    """The grid with the sweep direction added for the sweep modes (first: it varies slowest)."""
    dirs = {"up": ["up"], "down": ["down"], "both": ["up", "down"]}.get(mode)
    grid = dict(grid)
    if FREQ in grid:  # 0.8200000000000001 -> 0.82: grids from start:stop:count read as written
        grid[FREQ] = [round(float(v), 9) if isinstance(v, (int, float)) and not isinstance(v, bool) else v
                      for v in grid[FREQ]]
    return {DIRECTION: dirs, **grid} if dirs else grid


class _Case:
    """The case as spec.build and the engine see it (module functions)."""

    MODES, MODEL, POSITIVE = MODES, MODEL, POSITIVE
    check_study = staticmethod(check_study)
    study_grid = staticmethod(study_grid)
    scenario = staticmethod(scenario)


# ----------------------------------------------------------------------------
# the evaluator
class AbsorberEvaluator(Evaluator):
    kind = "absorber"
    description = "monolithic structure + ball model (ballmill.absorber), steady states or continued sweeps"
    indicators = INDICATORS

    def check(self, sc):
        return "" if getattr(sc, "case", None) == "absorber" else \
            "not the absorber case (a study file with case = \"absorber\")"

    def prepare(self, sc, study, build_dir=None):
        m = study.model
        cls = AbsorberPrepared if study.mode == "steady" else AbsorberSweepPrepared
        others = [k for k in study.swept if k not in (FREQ, DIRECTION)]
        return cls(defaults={n: dict(i.parameters) for n, i in sc.instances.items()}, mode=study.mode,
                   tol=float(m["tolerance"]), rtol=float(m["rtol"]), max_periods=int(m["max_periods"]),
                   refine_rounds=int(m["refine_rounds"]), refine_rtol=float(m["refine_rtol"]),
                   df_min=float(m["df_min"]), others=others)


@dataclass
class AbsorberPrepared(Prepared):
    defaults: dict
    mode: str
    tol: float
    rtol: float
    max_periods: int
    refine_rounds: int
    refine_rtol: float
    df_min: float
    others: list  # swept parameters besides the frequency and direction
    timing: dict = field(default_factory=lambda: {"integration": 0.0})
    rounds_done: int = 0
    generic_plots = False  # the engine's curves.png: frf.png says it better

    @property
    def model(self):
        how = ("independent steady states, refined at the peaks" if self.mode == "steady"
               else f"stepped sweeps ({self.mode}) continuing from state to state")
        return (f"absorber: monolithic structure + ball (ballmill.absorber), DOP853 tol {self.tol:g}, "
                f"{how}, settled to {self.rtol:g}")

    def values(self, params: dict) -> dict:
        vals = {i: dict(ps) for i, ps in self.defaults.items()}
        for key, v in params.items():
            inst, p = key.split(".", 1)
            if inst not in vals or p not in vals[inst]:
                raise ValueError(f"{key}: the absorber case has no such parameter")
            vals[inst][p] = v
        return vals

    def case_of(self, params: dict):
        """(AbsorberCase, frequency [Hz], direction) of a point."""
        from ..absorber import linear as lin
        from ..absorber.response import AbsorberCase
        from ..absorber.structure import Structure
        from ..physics import Ball

        v = self.values(params)
        s, b, e = v["structure"], v["ball"], v["excitation"]
        st = Structure.single(float(s["M"]), float(s["f"]), float(s["zeta"]), both_axes=bool(s["both_axes"]))
        R = float(b["R"]) or lin.cavity_radius(float(b["f_tune"]) or float(s["f"]), float(b["r"]))
        ball = Ball(r=float(b["r"]), R=R, m=float(b["m"]), mu=float(b["mu"]),
                    rolling_resistance=float(b["delta"]), drag=float(b["c_drag"]))
        if b["zeta"]:
            ball = ball.with_(drag=ball.drag + lin.drag_for_damping_ratio(float(b["zeta"]), ball))
        case = AbsorberCase(st, ball, float(e["F0"]), seed_y=float(b["seed_y"]), tol=self.tol, load=e["load"])
        return case, float(e["frequency"]), v["sweep"]["direction"]

    def _point(self, case, f, state=None, theta=0.0):
        from ..absorber.response import steady_state

        c0 = time.perf_counter()
        p = steady_state(case, f, state=state, theta=theta, rtol=self.rtol, max_periods=self.max_periods)
        self.timing["integration"] = self.timing.get("integration", 0.0) + time.perf_counter() - c0
        return p

    @staticmethod
    def _row(case, p) -> dict:
        from ..absorber.response import bare_amplitude

        f = p.frequency_Hz
        return {"amplitude_m": p.amplitude_m, "amplitude_bare_m": float(bare_amplitude(case, f)[0]),
                "amplitude_linear_m": float(abs(case.linear_frf(f)[0])) * case.force,
                "amplitude_err_m": p.amplitude_err_m, "peak_m": p.peak_m, "amplitude_y_m": p.amplitude_y_m,
                "phase_rad": p.phase_rad, "ball_amplitude_m": p.ball_amplitude_m,
                "ball_angle_max_deg": math.degrees(p.ball_angle_max_rad),
                "friction_ratio_max": p.friction_ratio_max, "N_min_N": p.N_min, "rolling": bool(p.rolling),
                "contact": bool(p.contact), "converged": bool(p.converged), "periods": p.periods,
                "t_end_s": p.t_end, "restarted": bool(p.restarted),
                "valid": bool(p.rolling and p.contact), "t_invalid": None}

    def run(self, params):
        case, f, _ = self.case_of(params)
        p = self._point(case, f)
        return self._row(case, p), {"model": self.model, "error_P_m": None, "error_N_N": None,
                                     "error_method": ERROR_METHOD}

    def evaluate(self, rec, custom):
        return rec

    # -- refinement rounds ---------------------------------------------------------
    def next_points(self, rows: list[dict]) -> list[dict]:
        """The frequencies to add (one round): `refine` on each curve (rows with the same
        values of the other swept parameters), over the points that were computed."""
        from ..absorber.response import refine

        if self.rounds_done >= self.refine_rounds:
            return []
        self.rounds_done += 1
        groups: dict = {}
        for r in rows:
            if r.get("status") != "ok" or r.get("amplitude_m") is None:
                continue
            key = tuple((k, r[k]) for k in self.others)
            groups.setdefault(key, {})[float(r[FREQ])] = float(r["amplitude_m"])
        new = []
        for key, curve in groups.items():
            fs = sorted(curve)
            for f in refine(fs, [curve[x] for x in fs], rtol=self.refine_rtol, df_min=self.df_min):
                if f not in curve:
                    new.append({**dict(key), FREQ: float(f)})
        return new

    # -- files beside results.parquet ----------------------------------------------------
    def write_outputs(self, study, rows, out_dir, plots=True, log=print):
        path = Path(out_dir) / "frf.csv"
        table = frf_rows(self, rows)
        write_csv(path, table)
        files = [path]
        if plots and table:
            try:
                files.append(plot_frf(self, study, table, Path(out_dir) / "frf.png"))
            except Exception as e:  # noqa: BLE001 - the results stand without their plot
                log(f"frf.png not written: {type(e).__name__}: {e}")
        return files


@dataclass
class AbsorberSweepPrepared(AbsorberPrepared):
    """Stepped sweeps: each chain (one direction, one combination of the other swept
    parameters) runs in order in one task, each point from the previous one's state."""

    carry: tuple | None = None  # (chain, state, phase) after the last point run here
    next_points = None  # no refinement of sweeps (module docstring)

    def chain_key(self, params):
        key = tuple((k, params[k]) for k in self.others) + (params[DIRECTION],)
        f = float(params[FREQ])
        return key, (f if params[DIRECTION] == "up" else -f)

    def begin_batch(self):
        self.carry = None

    def run(self, params):
        case, f, direction = self.case_of(params)
        chain = self.chain_key(params)[0]
        state, theta, first = None, 0.0, True
        if self.carry is not None and self.carry[0] == chain:
            _, state, theta = self.carry
            first = False
        self.carry = None  # a failure below starts the chain's next point afresh
        p = self._point(case, f, state=state, theta=theta)
        p.restarted = state is None and not first
        # where the ball left the wall the rolling model ended: the next point starts afresh
        self.carry = (chain, p.state, p.theta_end) if p.contact else (chain, None, 0.0)
        p.state = None
        return self._row(case, p), {"model": self.model, "error_P_m": None, "error_N_N": None,
                                     "error_method": ERROR_METHOD}


# ----------------------------------------------------------------------------
# frf.csv and frf.png
FRF_COLUMNS = ("frequency_Hz", "amplitude_m", "amplitude_bare_m", "amplitude_linear_m", "amplitude_err_m",
               "F0", "direction", "valid", "rolling", "contact", "converged", "ball_amplitude_m",
               "ball_angle_max_deg", "friction_ratio_max", "N_min_N", "amplitude_y_m", "periods", "restarted",
               "status", "message")


def frf_rows(prepared: AbsorberPrepared, rows: list[dict]) -> list[dict]:
    """The rows of frf.csv: one per point, the other swept parameters first, then by direction
    (steady, up, down) in the order a sweep ran (down: descending frequency)."""
    out = []
    for r in rows:
        v = prepared.values({k: r[k] for k in prepared.others + [FREQ] + (
            [DIRECTION] if DIRECTION in r else []) if r.get(k) is not None})
        d = {k: r.get(k) for k in prepared.others}
        d.update({"frequency_Hz": r.get(FREQ), "amplitude_m": r.get("amplitude_m"),
                  "amplitude_bare_m": r.get("amplitude_bare_m"), "amplitude_linear_m": r.get("amplitude_linear_m"),
                  "amplitude_err_m": r.get("amplitude_err_m"), "F0": v["excitation"]["F0"],
                  "direction": v["sweep"]["direction"]})
        for k in FRF_COLUMNS:
            if k not in d:
                d[k] = r.get(k)
        out.append(d)
    order = {"steady": 0, "up": 1, "down": 2}

    def key(d):
        f = d["frequency_Hz"] if d["frequency_Hz"] is not None else math.inf
        return tuple(repr(d[k]) for k in prepared.others) + (order[d["direction"]],
                                                             -f if d["direction"] == "down" else f)
    return sorted(out, key=key)


def write_csv(path: Path, rows: list[dict]):
    path.parent.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0]) if rows else list(FRF_COLUMNS)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if v is None else int(v) if isinstance(v, bool) else v) for k, v in r.items()})
    tmp.replace(path)


def plot_frf(prepared: AbsorberPrepared, study, table: list[dict], path: Path) -> Path:
    """The structure's amplitude with and without the ball on one figure (a panel per
    combination of the other swept parameters): the bare structure and the linear theory
    as curves, the simulated points as markers, points where the ball slips or leaves the
    wall marked."""
    from ..plotting import figures as plt

    groups: dict = {}
    for d in table:
        groups.setdefault(tuple((k, d[k]) for k in prepared.others), []).append(d)
    n = len(groups)
    fig, axes = plt.subplots(n, 1, figsize=(9, 4.6 * n), squeeze=False, layout="tight")
    style = {"steady": ("o", "tab:blue", "with ball, steady states"),
             "up": ("^", "tab:blue", "with ball, sweep up"), "down": ("v", "tab:orange", "with ball, sweep down")}
    for ax, (key, ds) in zip(axes[:, 0], groups.items()):
        ok = [d for d in ds if d["status"] == "ok" and d["amplitude_m"] is not None]
        fr = [d["frequency_Hz"] for d in ds if d["frequency_Hz"] is not None]
        params = dict(key)
        case, _, _ = prepared.case_of({**params, FREQ: 1.0})
        f = np.linspace(min(fr), max(fr), 3001)
        ax.plot(f, np.abs(case.linear_frf(f, ball=False)) * case.force * 1e3, color="0.55", lw=1.3,
                label="without the ball (bare structure, exact)")
        ax.plot(f, np.abs(case.linear_frf(f)) * case.force * 1e3, "k--", lw=0.9,
                label="with ball, linear theory (2 DOF closed form)")
        for direction in ("steady", "up", "down"):
            pts = [d for d in ok if d["direction"] == direction and d["contact"]]  # no amplitude past contact
            if not pts:
                continue
            mk, col, lab = style[direction]
            x = np.array([d["frequency_Hz"] for d in pts])
            y = np.array([d["amplitude_m"] for d in pts]) * 1e3
            conv = np.array([bool(d["converged"]) for d in pts])
            if direction != "steady":  # a sweep in the order it ran
                ax.plot(x, y, "-", color=col, lw=0.8, alpha=0.7)
            ay_ = np.array([d["amplitude_y_m"] or 0.0 for d in pts]) * 1e3
            if direction != "steady" and (ay_ > 0.1 * np.maximum(y, 1e-12)).any():  # a whirl moves it in y
                ax.plot(x, ay_, ":", color=col, lw=1.0, label=f"{lab}: amplitude in y (the ball whirls)")
            ax.plot(x[conv], y[conv], mk, ms=4, color=col, label=lab)
            if (~conv).any():
                ax.plot(x[~conv], y[~conv], mk, ms=5, mfc="none", color=col,
                        label=f"{lab}: did not settle (last window)")
        slip = [d for d in ok if d["contact"] and not d["rolling"]]
        lost = [d for d in ds if d["status"] == "ok" and not d["contact"]]
        if slip:
            ax.plot([d["frequency_Hz"] for d in slip], [d["amplitude_m"] * 1e3 for d in slip], "x", ms=8,
                    color="tab:red", mew=1.6, label="ball slips: rolling model not valid there")
        if lost:
            y0 = ax.get_ylim()[0]
            ax.plot([d["frequency_Hz"] for d in lost], [y0] * len(lost), "X", ms=8, color="darkred",
                    label="ball leaves the wall: no amplitude (outside the model)")
        failed = [d for d in ds if d["status"] != "ok"]
        if failed:
            y0 = ax.get_ylim()[0]
            ax.plot([d["frequency_Hz"] for d in failed if d["frequency_Hz"] is not None],
                    [y0] * len([d for d in failed if d["frequency_Hz"] is not None]), "s", color="k",
                    mfc="none", label="failed point (see results.parquet)")
        extra = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}" for k, v in key
                          if k != "excitation.F0")  # F0 leads the title anyway
        ball = case.ball
        ax.set_title(f"F0 = {case.force:g} {'N' if case.load == 'force' else 'm/s2'} ({case.load}), structure "
                     f"{case.structure.x.modes[0].mass:g} kg / {case.structure.x.modes[0].frequency:g} Hz / "
                     f"zeta {case.structure.x.modes[0].damping:g}; ball {ball.m:g} kg, R = {ball.R:.4f} m"
                     + (f"; {extra}" if extra else ""), fontsize=9)
        ax.set_xlabel("excitation frequency [Hz]")
        ax.set_ylabel("amplitude of the structure [mm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    import textwrap

    fig.suptitle(textwrap.fill(f"{study.name}: {study.description}" if study.description else study.name, 100),
                 fontsize=10)
    return plt.save(fig, path)


register_case("absorber", _Case)
register(AbsorberEvaluator(), before="crank-kernel")
