"""ballmill.sweep: design studies, many runs of one scenario with parameters varied.

    ballmill sweep fast_start --grid drive.t0=1,2,2.5,3,4 --grid drive.n0=40:80:5 --out DIR
    ballmill sweep scenarios/studies/t0_n0.toml --out DIR

Layers (each module's docstring has the details):
* spec: the study (scenario, fixed overrides, grid or sample, model settings,
  custom indicators) and its points;
* indicators: validity of the model and the indicators of one point's run;
* evaluators: how a point is computed, a registry by kind of scenario (the
  monolithic compiled kernel for a closed-form crank drive, the co-simulation
  otherwise); new models register their own;
* absorber: the built-in absorber case (case = "absorber": structure + ball,
  steady states refined at the peaks or continued up/down sweeps, frf.csv);
* engine: batches on Dask (its local processes scheduler, workers forked from the
  command; a LocalCluster; a running cluster) or in this process, rounds, chains, resume,
  DIR/results.parquet, the plots (drawn in the command);
* plots: curves, heat maps (invalid regions hatched), scatter plots;
* design: studies that choose their own points (bounds of design variables), evaluated
  batch by batch through the engine's setup and executor, every evaluation in DIR and
  read back on a rerun; optimize (`ballmill optimize`: NSGA-II, differential evolution)
  and sensitivity (`ballmill sensitivity`: Sobol indices) on it.
"""
import importlib

__all__ = ["Indicator", "Outcome", "Study", "StudyError", "build", "columns", "load", "run_study"]
_FROM = {"Outcome": "engine", "columns": "engine", "run_study": "engine",
         "Indicator": "spec", "Study": "spec", "StudyError": "spec", "build": "spec", "load": "spec"}


def __getattr__(name):
    """The package's names, imported on first use: importing one module of the package (e.g.
    indicators, for a run's summary) does not import the engine and its dependencies."""
    if name in _FROM:
        value = getattr(importlib.import_module(f".{_FROM[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
