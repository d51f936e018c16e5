"""`ballmill optimize STUDY.toml`: the design variables that minimise or maximise indicators
under constraints, the points evaluated on Dask through the sweep's evaluators.

    [variables]
    "drive.t0" = [0.5, 10.0]
    "drive.n0" = [30.0, 90.0]

    [optimize]
    algorithm = "auto"        # "nsga2" (pymoo's NSGA-II), "de" (scipy's differential evolution);
                              # auto: NSGA-II for two objectives or more, DE for one
    population = 40           # designs per generation
    generations = 25          # generations, the first one included (evaluations <= population x generations)
    seed = 1                  # the same seed, the same designs in the same order (resume relies on it)

    [[objectives]]            # one or more; any indicator the study's points report
    indicator = "ring_width"
    goal = "max"              # or "min" (default)

    [[constraints]]           # any indicator, with a lower and/or an upper bound (its unit)
    indicator = "T_drive_peak"
    max = 2.0
    scale = 1.0               # optional: the violation is divided by it (default |bound|, 1 for 0)

The model's validity is always a constraint (no indicator is reported past the time the
model stops holding, and a design whose objectives are not defined cannot be ranked):
a design is feasible when it stays valid over the whole run and meets every bound.

Constraint values (pymoo's convention, g <= 0 feasible, dimensionless):

* validity: (stop - t_invalid) / (stop - start), 0 for a design that stays valid, 1 for
  one that fails (an exception, its message in the row); its margin column
  ``margin:valid`` = t_invalid - stop [s] (0 when valid);
* a bound: g = -margin / scale, margin = value - min or max - value (the smaller of the two
  for both bounds) in the indicator's unit, column ``margin:NAME``; where the indicator is not
  reported (the design left the model's validity before the indicator's window ended) the
  margin is empty and g = 0: the design is already infeasible through validity, which
  then orders it.

Every design thus has finite constraint values (never NaN), and its violation
(``violation``: the sum of the positive g) orders the infeasible ones, so that the
algorithms walk towards feasibility. The objective values of an infeasible design are not
used (both algorithms rank feasible designs first, infeasible ones by their violation).

Algorithms:

* NSGA-II (pymoo), through its ask-and-tell interface: each generation's designs go to the
  executor as one batch. The result: the Pareto set, the feasible designs no other
  feasible design evaluated in the study dominates (DIR/pareto.parquet).
* One objective: scipy's differential evolution (strategy best1bin, an initial Latin-
  hypercube population of ``population`` designs from the seed, ``generations`` - 1
  generations after it, no polishing). Chosen over Optuna because it adds no dependency
  (scipy is one already), it evaluates a whole generation in one vectorised call (one batch
  on Dask, constraints included), its result is a deterministic function of the seed and
  the evaluations (so that a resumed study ends where the uninterrupted one does), and it
  handles the constraints by feasibility rules on the violations above (Lampinen), where
  Optuna's default TPE sampler proposes one design at a time from a density model and
  reaches a known optimum only to within its sampling. Polishing (a gradient search after
  the last generation) is left off: it evaluates one design at a time, outside the
  batches. The result: the best feasible design.

Outputs in DIR: results.parquet (every evaluation: the variables, every indicator, the
margins, ``violation``, ``feasible``, ``generation``), pareto.parquet (the Pareto set or the
optimum), convergence.parquet (per generation: evaluations so far, feasible designs so
far, the best feasible value of each objective so far, the Pareto set's size),
pareto.png (objectives against each other: every feasible and infeasible design, the
Pareto set), convergence.png.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import design
from .spec import StudyError

ALGORITHMS = ("auto", "nsga2", "de")
SHOWN = 10  # designs of the Pareto set printed by the command
KEYS = {"algorithm": "auto, nsga2 or de", "population": "designs per generation",
        "generations": "generations, the first included", "seed": "an integer"}


@dataclass
class Objective:
    indicator: str
    goal: str  # "min" or "max"

    @property
    def sign(self) -> float:
        return 1.0 if self.goal == "min" else -1.0


@dataclass
class Constraint:
    indicator: str
    low: float | None
    high: float | None
    scale_low: float
    scale_high: float

    def margin(self, v: float) -> float:
        m = math.inf
        if self.low is not None:
            m = min(m, v - self.low)
        if self.high is not None:
            m = min(m, self.high - v)
        return m

    def g(self, v: float) -> float:
        g = -math.inf
        if self.low is not None:
            g = max(g, (self.low - v) / self.scale_low)
        if self.high is not None:
            g = max(g, (v - self.high) / self.scale_high)
        return g

    def text(self) -> str:
        parts = ([f"{self.indicator} >= {self.low:g}"] if self.low is not None else []) + \
            ([f"{self.indicator} <= {self.high:g}"] if self.high is not None else [])
        return " and ".join(parts)


@dataclass
class Problem:
    ds: design.DesignStudy
    algorithm: str
    population: int
    generations: int
    seed: int
    objectives: list
    constraints: list

    def context(self) -> dict:
        return {"algorithm": self.algorithm, "population": self.population, "generations": self.generations,
                "seed": self.seed, "variables": {k: list(b) for k, b in self.ds.bounds.items()},
                "objectives": [[o.indicator, o.goal] for o in self.objectives],
                "constraints": [[c.indicator, c.low, c.high, c.scale_low, c.scale_high] for c in self.constraints]}


def load(path: str, population=None, generations=None, seed=None) -> Problem:
    """The optimisation problem of a study file (command-line values replace the file's)."""
    import tomllib

    ds = design.load(path, "optimize")
    doc = tomllib.loads(Path(ds.where).read_text())
    w = ds.where
    problems: list[str] = []
    design.check_keys(ds, KEYS, problems)
    for k, v in (("population", population), ("generations", generations), ("seed", seed)):
        if v is not None:
            ds.table[k] = v
    algorithm = ds.table.get("algorithm", "auto")
    if algorithm not in ALGORITHMS:
        problems.append(f"{w}: optimize.algorithm: expected one of {', '.join(ALGORITHMS)}, got {algorithm!r}")
    pop = design.integer(ds, "population", 40, problems, low=5)
    gens = design.integer(ds, "generations", 25, problems, low=1)
    sd = design.integer(ds, "seed", 1, problems, low=0)
    objectives = []
    for key, o in design.tables(doc, "objectives", w, ("indicator", "goal"), "indicator and goal",
                                "expected one or more [[objectives]] with indicator and goal (min or max)",
                                problems, required=True):
        goal = o.get("goal", "min")
        if goal not in ("min", "max"):
            problems.append(f"{key}.goal: expected min or max, got {goal!r}")
        if not isinstance(o.get("indicator"), str):
            problems.append(f"{key}.indicator: expected an indicator's name, got {o.get('indicator')!r}")
            continue
        if o["indicator"] in [x.indicator for x in objectives]:
            problems.append(f"{key}.indicator: {o['indicator']!r} is an objective twice")
        objectives.append(Objective(o["indicator"], goal))
    constraints = []
    for key, c in design.tables(doc, "constraints", w, ("indicator", "min", "max", "scale"),
                                "indicator and min and/or max", "expected [[constraints]] tables", problems):
        name = c.get("indicator")
        if not isinstance(name, str):
            problems.append(f"{key}.indicator: expected an indicator's name, got {name!r}")
            continue
        if name == "valid":  # always a constraint; naming it changes nothing
            if "min" in c or "max" in c:
                problems.append(f"{key}: valid takes no bound (a design is valid or not)")
            continue
        lo, hi, scale = c.get("min"), c.get("max"), c.get("scale")
        for k, v in (("min", lo), ("max", hi)):
            if v is not None and not design._number(v):
                problems.append(f"{key}.{k}: expected a finite number (the indicator's unit), got {v!r}")
        if lo is None and hi is None:
            problems.append(f"{key}: a constraint on {name} needs min and/or max")
            continue
        if design._number(lo) and design._number(hi) and not lo < hi:
            problems.append(f"{key}: expected min < max, got min = {lo!r}, max = {hi!r}")
        if scale is not None and not (design._number(scale) and scale > 0):
            problems.append(f"{key}.scale: expected a positive number (the indicator's unit), got {scale!r}")
            continue
        if name in [x.indicator for x in constraints]:
            problems.append(f"{key}.indicator: {name!r} is constrained twice (give min and max in one table)")
        sl = float(scale) if scale else (abs(float(lo)) or 1.0 if design._number(lo) else 1.0)
        sh = float(scale) if scale else (abs(float(hi)) or 1.0 if design._number(hi) else 1.0)
        constraints.append(Constraint(name, float(lo) if design._number(lo) else None,
                                      float(hi) if design._number(hi) else None, sl, sh))
    if algorithm == "de" and len(objectives) > 1:
        problems.append(f"{w}: optimize.algorithm: de optimises one objective, the study has {len(objectives)} "
                        f"(use nsga2)")
    if problems:
        raise StudyError(problems)
    if algorithm == "auto":
        algorithm = "nsga2" if len(objectives) > 1 else "de"
    return Problem(ds, algorithm, pop, gens, sd, objectives, constraints)


# ----------------------------------------------------------------------------
# objectives and constraints of an evaluated design
class Scoring:
    """F and g of the rows (see the module docstring) and the columns they add."""

    def __init__(self, prob: Problem, sc):
        self.prob = prob
        self.start, self.stop = (float(sc.start), float(sc.stop)) if sc is not None else (0.0, 0.0)

    def extra(self, units: dict):
        return ([("margin:valid", "s")] + [(f"margin:{c.indicator}", units.get(c.indicator, ""))
                                           for c in self.prob.constraints]
                + [("violation", ""), ("feasible", ""), ("generation", "")])

    def g(self, row: dict) -> list[float]:
        span = self.stop - self.start
        if row.get("status") != "ok":
            gv = 1.0
        elif row.get("valid"):
            gv = 0.0
        else:
            gv = min(1.0, max(0.0, (self.stop - float(row["t_invalid"])) / span))
        out = [gv]
        for c in self.prob.constraints:
            v = design.value(row, c.indicator)
            out.append(0.0 if v is None and gv > 0 else (1.0 if v is None else c.g(v)))
        return out

    def annotate(self, row: dict):
        g = self.g(row)
        if row.get("status") != "ok":
            row["margin:valid"] = self.start - self.stop
        else:
            row["margin:valid"] = 0.0 if row.get("valid") else float(row["t_invalid"]) - self.stop
        for c in self.prob.constraints:
            v = design.value(row, c.indicator)
            row[f"margin:{c.indicator}"] = None if v is None else c.margin(v)
        row["violation"] = float(sum(max(0.0, x) for x in g))
        row["feasible"] = row["violation"] == 0.0 and all(
            design.value(row, o.indicator) is not None for o in self.prob.objectives)
        row["generation"] = int(row.get("generation") or 0)

    def F(self, row: dict) -> list[float]:
        """Objective values to minimise; +inf where not reported (infeasible designs only)."""
        out = []
        for o in self.prob.objectives:
            v = design.value(row, o.indicator)
            out.append(math.inf if v is None else o.sign * v)
        return out


def pareto_mask(F: np.ndarray) -> np.ndarray:
    """The rows of F (to minimise) that no other row dominates (<= in all, < in one); of
    identical rows, the first."""
    F = np.asarray(F, dtype=float)
    n = len(F)
    keep = np.ones(n, dtype=bool)
    for a in range(0, n, 256):  # blocks of rows against all rows: O(n^2) comparisons, vectorised
        Fi = F[a:a + 256, None, :]
        le, lt = np.all(F[None] <= Fi, axis=2), np.any(F[None] < Fi, axis=2)
        eq = np.all(F[None] == Fi, axis=2) & (np.arange(n)[None] < np.arange(a, min(n, a + 256))[:, None])
        keep[a:a + 256] = ~np.any((le & lt) | eq, axis=1)
    return keep


@dataclass
class Result:
    rows: list  # every evaluation
    best: list  # the Pareto set (or the optimum), rows
    convergence: list  # dicts per generation
    session: object
    algorithm: str
    message: str
    wall_s: float
    plots: list = field(default_factory=list)


def run(prob: Problem, out_dir, *, scheduler=None, workers=None, batch=None, build_dir=None, progress=True,
        plots=True, log=None) -> Result:
    wall0 = time.perf_counter()
    scoring: list[Scoring] = []

    def check(known):
        problems = []
        for i, o in enumerate(prob.objectives):
            design.check_indicator(prob.ds, f"objectives[{i}].indicator", o.indicator, known, problems)
        for i, c in enumerate(prob.constraints):
            design.check_indicator(prob.ds, f"constraints[{i}].indicator", c.indicator, known, problems)
        return problems

    def annotate(row):
        scoring[0].annotate(row)

    session = design.Session(prob.ds, out_dir, context=prob.context(), annotate=annotate, check=check,
                             extra=lambda units: Scoring(prob, None).extra(units),
                             scheduler=scheduler, workers=workers, batch=batch, build_dir=build_dir,
                             progress=progress, total=prob.population * prob.generations, log=log)
    scoring.append(Scoring(prob, session.sc))
    sco = scoring[0]
    names = prob.ds.names
    xl = np.array([prob.ds.bounds[k][0] for k in names])
    xu = np.array([prob.ds.bounds[k][1] for k in names])
    history: list[dict] = []
    seen: dict = {}
    front: list = []

    def evaluate(X: np.ndarray, generation: int) -> list[dict]:
        rows = session.evaluate([dict(zip(names, map(float, x))) for x in X], generation=generation)
        new = []
        for r in rows:
            if r["point_id"] not in seen:
                seen[r["point_id"]] = r
                new.append(r)
        front[:] = _best(prob, sco, front + new)
        line = _progress(prob, sco, list(seen.values()), generation, front)
        if history and history[-1]["generation"] == generation:  # (scipy's first call: one design)
            history[-1] = line
        else:
            history.append(line)
        return rows

    try:
        if prob.algorithm == "nsga2":
            message = _nsga2(prob, sco, xl, xu, evaluate)
        else:
            message = _de(prob, sco, xl, xu, evaluate)
    finally:
        rows = session.close()
    asked = [r for r in rows if r["point_id"] in seen]
    best = _best(prob, sco, asked)
    out_dir = Path(out_dir)
    _write_rows(best, session, out_dir / "pareto.parquet")
    _write_rows(history, None, out_dir / "convergence.parquet")
    files = []
    if plots:
        try:
            files = write_plots(prob, session, asked, best, history, out_dir)
        except Exception as e:  # noqa: BLE001 - the results stand without their plots
            session.log(f"plots not written: {type(e).__name__}: {e}")
    return Result(rows, best, history, session, prob.algorithm, message, time.perf_counter() - wall0, files)


def _progress(prob, sco, rows, generation, front: list) -> dict:
    """A generation's line of the convergence table; ``front``: the Pareto set of the rows
    before it (updated: the set of all rows is the set of the old set and the new rows)."""
    feas = [r for r in rows if r.get("feasible")]
    out = {"generation": generation, "evaluations": len(rows), "feasible": len(feas)}
    for o in prob.objectives:
        vals = [design.value(r, o.indicator) for r in feas]
        out[f"best:{o.indicator}"] = (min(vals) if o.goal == "min" else max(vals)) if vals else None
    if len(prob.objectives) > 1:
        out["pareto_size"] = len(front)
    return out


def _best(prob, sco, rows) -> list[dict]:
    """The feasible designs no other feasible one dominates, by the first objective (best first)."""
    feas = [r for r in rows if r.get("feasible")]
    if not feas:
        return []
    F = np.array([sco.F(r) for r in feas])
    keep = pareto_mask(F)
    best = [r for r, k in zip(feas, keep) if k]
    return sorted(best, key=lambda r: sco.F(r))


def _write_rows(rows, session, path: Path):
    from . import engine as _eng

    if session is not None:
        _eng._write(_eng._table(rows, session.cols, session.units), path)
        return
    cols = list(rows[0]) if rows else ["generation"]
    _eng._write(_eng._table(rows, cols, {}), path)


def _nsga2(prob, sco, xl, xu, evaluate) -> str:
    """NSGA-II by ask and tell: each generation one batch."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem as PymooProblem
    from pymoo.problems.static import StaticProblem

    problem = PymooProblem(n_var=len(xl), n_obj=len(prob.objectives), n_ieq_constr=1 + len(prob.constraints),
                           xl=xl, xu=xu)
    alg = NSGA2(pop_size=prob.population)
    alg.setup(problem, termination=("n_gen", prob.generations), seed=prob.seed, verbose=False)
    gen = 0
    while alg.has_next():
        pop = alg.ask()
        gen += 1
        rows = evaluate(pop.get("X"), gen)
        F = np.array([sco.F(r) for r in rows], dtype=float)
        G = np.array([sco.g(r) for r in rows], dtype=float)
        Evaluator().eval(StaticProblem(problem, F=F, G=G), pop)
        alg.tell(infills=pop)
    return f"NSGA-II, {gen} generations of {prob.population}"


def _de(prob, sco, xl, xu, evaluate) -> str:
    """scipy's differential evolution, vectorised: each generation (its constraints first, then
    the objective of its feasible designs, both from the same batch) one batch."""
    from scipy.optimize import NonlinearConstraint, differential_evolution
    from scipy.stats import qmc

    k = len(xl)
    state = {"gen": 0, "last": None}

    def rows_of(X):
        X = np.atleast_2d(np.asarray(X, dtype=float).T)  # (S, k)
        key = X.tobytes()
        if state["last"] is None or state["last"][0] != key:
            asked = state.setdefault("asked", set())
            # a new generation: a population call (scipy probes the constraints with one design
            # of the first population before it, and asks for the objective of the feasible
            # designs of a generation after their constraints)
            if len(X) > 1 and not all(tuple(x) in asked for x in X):
                state["gen"] += 1
            asked.update(map(tuple, X))
            state["last"] = (key, evaluate(X, max(1, state["gen"])))
        return state["last"][1]

    def f(x):
        x = np.asarray(x)
        rows = rows_of(x)
        F = np.array([sco.F(r)[0] for r in rows])
        return F if x.ndim == 2 else F[0]

    def g(x):
        x = np.asarray(x)
        G = np.array([sco.g(r) for r in rows_of(x)]).T  # (m, S)
        return G if x.ndim == 2 else G[:, 0]

    init = qmc.scale(qmc.LatinHypercube(d=k, seed=prob.seed).random(prob.population), xl, xu)
    res = differential_evolution(f, list(zip(xl, xu)), constraints=[NonlinearConstraint(g, -np.inf, 0.0)],
                                 vectorized=True, updating="deferred", init=init, maxiter=max(0, prob.generations - 1),
                                 rng=np.random.default_rng(prob.seed), polish=False, tol=0.0, atol=0.0)
    return f"differential evolution: {res.message} ({res.nit} generations after the first)"


# ----------------------------------------------------------------------------
# plots
def _label(session, name, width=None):
    from ..plotting import labels

    unit = session.indicators.get(name)
    desc = {k: d for k, (_, d) in session.setup.ev.indicators.items()}.get(name)
    return labels.label(None, name, unit=unit or None, description=desc, width=width)


def _log_if_wide(ax, axis: str, values) -> None:
    """A logarithmic axis for an objective whose values are all positive, span more than two
    decades and bunch at the low end (the median below a thirtieth of the largest): a front
    squeezed against the axis by a few far designs becomes readable; values spread evenly over
    their range keep a linear axis."""
    v = sorted(x for x in values if x is not None)
    if v and v[0] > 0.0 and v[-1] > 100.0 * v[0] and v[len(v) // 2] < v[-1] / 30.0:
        (ax.set_xscale if axis == "x" else ax.set_yscale)("log")


def write_plots(prob, session, rows, best, history, out_dir: Path) -> list[Path]:
    import textwrap

    from ..plotting import figures

    files = []
    objs = [o.indicator for o in prob.objectives]
    title = textwrap.fill(f"{session.study.name}: {session.study.description}" if session.study.description
                          else session.study.name, 80)
    if len(objs) >= 2:
        pairs = [(i, j) for i in range(len(objs)) for j in range(i + 1, len(objs))]
        fig, axes = figures.subplots(1, len(pairs), figsize=(6.0 * len(pairs), 5.0), squeeze=False, layout="tight")
        for ax, (i, j) in zip(axes.flat, pairs):
            a, b = objs[i], objs[j]
            feas = [r for r in rows if r.get("feasible")]
            inf = [r for r in rows if not r.get("feasible") and design.value(r, a) is not None
                   and design.value(r, b) is not None]
            if inf:
                ax.plot([design.value(r, a) for r in inf], [design.value(r, b) for r in inf], "x", color="tab:red",
                        ms=4, alpha=0.5, label=f"infeasible ({len(inf)})")
            ax.plot([design.value(r, a) for r in feas], [design.value(r, b) for r in feas], "o", color="0.7", ms=3,
                    label=f"feasible ({len(feas)})")
            front = sorted(best, key=lambda r: design.value(r, a))
            ax.plot([design.value(r, a) for r in front], [design.value(r, b) for r in front], "o-", color="tab:blue",
                    ms=5, lw=1.2, label=f"Pareto set ({len(front)})")
            ax.set_xlabel(_label(session, a, 50))
            ax.set_ylabel(_label(session, b, 50))
            for name, axis in ((a, "x"), (b, "y")):
                _log_if_wide(ax, axis, [design.value(r, name) for r in feas + inf])
            ax.set_title(f"Pareto front: {a} ({prob.objectives[i].goal}) against {b} ({prob.objectives[j].goal})",
                         fontsize=10)
            ax.legend(fontsize=8)
            ax.grid(alpha=0.3)
        fig.suptitle(title, fontsize=10)
        path = out_dir / "pareto.png"
        figures.save(fig, path)
        files.append(path)
    if history:
        fig, axes = figures.subplots(len(objs), 1, figsize=(7.0, 3.0 * len(objs) + 0.6), squeeze=False, layout="tight")
        gens = [h["generation"] for h in history]
        for ax, o in zip(axes.flat, prob.objectives):
            y = [np.nan if h[f"best:{o.indicator}"] is None else h[f"best:{o.indicator}"] for h in history]
            ax.plot(gens, y, "o-", ms=3, lw=1.2, label=f"best feasible ({o.goal})")
            ax.set_xlabel("generation")
            ax.set_ylabel(_label(session, o.indicator, 40))
            ax.set_title(f"Convergence: the best feasible {o.indicator} ({o.goal}) so far", fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle(title, fontsize=10)
        path = out_dir / "convergence.png"
        figures.save(fig, path)
        files.append(path)
    return files


def summary(prob: Problem, res: Result) -> dict:
    s = res.session
    names = prob.ds.names
    shown = res.best
    if len(shown) > SHOWN:  # a long Pareto set: SHOWN designs evenly along it (all in pareto.parquet)
        shown = [shown[i] for i in np.unique(np.linspace(0, len(shown) - 1, SHOWN).round().astype(int))]
    best = [{**{k: r[k] for k in names}, **{o.indicator: r.get(o.indicator) for o in prob.objectives},
             **{c.indicator: r.get(c.indicator) for c in prob.constraints}} for r in shown]
    out = {"study": s.study.name, "algorithm": res.message, "evaluator": s.setup.ev.kind,
           "executor": s.executor.name, "evaluations": len(s.order), "computed": s.computed,
           "reused (already in the results)": s.reused,
           "feasible": sum(1 for r in res.rows if r.get("feasible") and r["point_id"] in s.order),
           **({"pareto set size": len(res.best)} if len(prob.objectives) > 1 else {}),
           ("pareto set" if len(prob.objectives) > 1 else "optimum"): best if len(prob.objectives) > 1 else
           (best[0] if best else None),
           "results": str(s.out_dir / "results.parquet"), "pareto": str(s.out_dir / "pareto.parquet"),
           "plots": [str(p) for p in res.plots], "wall_s": round(res.wall_s, 3)}
    return json.loads(json.dumps(out, default=str))
