"""The FMI cross-check files of each native FMU's default experiment, written by the build.

For every native FMU build/<Model>.fmu the build writes, into build/crosscheck/<Model>/ (the
layout of one model folder of the FMI Cross-Check repository, github.com/modelica/fmi-cross-check,
fmus/2.0/cs/<platform>/<tool>/<version>/<Model>/, without the FMU itself):

* ``<Model>_in.csv``: the input signals, for every model (all five have inputs): the first
  column the time, then every input by its name in modelDescription.xml (those the
  experiment does not move at their start values). The rows are the
  communication points of the experiment, so that the cross-check's linear interpolation
  between rows hands the FMU exactly these values at every communication point;
  an experiment that keeps every input at its start value has two rows (start and stop);
* ``<Model>_ref.opt``: StartTime, StopTime, StepSize (the communication step) of the
  FMU's DefaultExperiment, RelTol and AbsTol (what a reproduction must meet: at every row,
  for every column, |value - reference| <= RelTol * max|reference column| + AbsTol), and
  OutputIntervalLength (the spacing of the reference rows);
* ``<Model>_ref.csv``: the reference solution: the time, then at most ten of the FMU's
  outputs (`REF_OUTPUTS`), every OutputIntervalLength from StartTime to StopTime, from a run
  of this FMU's co-simulation interface by the project's own master (`ballmill.scenario.runner`,
  the inputs from <Model>_in.csv as a table source) with the start values of every parameter.

CSV as the cross-check rules want it: comma separated, the header's names in double quotes,
numbers as C floating-point literals (the shortest text that reads back to the same double),
Booleans as 0 and 1, each file under 1 MB (checked here).

The inputs of each experiment (`inputs`):
* BallInShell: the platform motion of the crank start-up law with MotorStartup's start values
  (l = 0.5 m, n0 = 60 1/min, t0 = 2.5 s): x1O, y1O, vx1O, vy1O, ax1O, ay1O;
* MotorStartup and InductionMotor: a load torque on the crank, M_reaction(t) =
  -LOAD_NM * sin^2(pi t / (stop - start)), smooth, 0 at both ends;
* Fig1Drive and Structure: every input at its start value (no ball, no ground record).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

FOLDER = "crosscheck"
REL_TOL, ABS_TOL = 1e-6, 1e-9
MAX_ROWS = 1000  # reference rows at most (OutputIntervalLength: a whole number of communication steps)
MAX_BYTES = 1_000_000  # the cross-check rules' limit per CSV file
LOAD_NM = 0.5  # [N m] the largest load torque of the drives' experiments
GENERATOR = Path(__file__).resolve()
REF_OUTPUTS = {
    "BallInShell": ("xP", "yP", "zP", "N", "Ft", "M_reaction", "friction_ratio", "P_diss", "valid"),
    "MotorStartup": ("psi", "psi_dot", "psi_ddot", "x1O", "y1O", "ax1O", "ay1O", "T_drive", "P_drive"),
    "InductionMotor": ("psi", "psi_dot", "x1O", "y1O", "w_motor", "slip", "T_motor", "I_motor", "P_el", "W_motor"),
    "Fig1Drive": ("phi", "phi_dot", "psi", "psi_dot", "x1O", "y1O", "z1O", "Omega_z", "T_frame", "T_crank"),
    "Structure": ("x1O", "y1O", "ax1O", "x_rel", "y_rel", "x_load", "E", "W_exc", "W_damp", "f_inst"),
}


class CrossCheckError(RuntimeError):
    """The default experiment could not be run or its files would break the rules."""


def folder(name: str, base: Path) -> Path:
    return Path(base) / FOLDER / name


def files(name: str, base: Path) -> list[Path]:
    """The files the build writes for this model: _in.csv, _ref.opt, _ref.csv."""
    d = folder(name, base)
    return [d / f"{name}_in.csv", d / f"{name}_ref.opt", d / f"{name}_ref.csv"]


def experiment(name: str) -> tuple[float, float, float, float]:
    """(start, stop, step, output interval) [s] of the model's default experiment."""
    from .interface import INTERFACES

    start, stop, step = INTERFACES[name].default_experiment
    n = int(round((stop - start) / step))
    every = max(1, math.ceil(n / MAX_ROWS))
    return float(start), float(stop), float(step), every * step


def inputs(name: str, times: np.ndarray) -> dict[str, np.ndarray]:
    """The inputs the default experiment moves, name -> values at ``times`` (see the module's
    docstring); empty: every input keeps its start value."""
    from .interface import INTERFACES

    if name == "BallInShell":
        from ballmill.physics import CrankStartup

        drive = INTERFACES["MotorStartup"]
        crank = CrankStartup(l=drive["l"].start, n0=drive["n0"].start, t0=drive["t0"].start)
        rows = np.array([crank.state(float(t)) for t in times])
        return {v: rows[:, j] for j, v in enumerate(("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O"))}
    if name in ("MotorStartup", "InductionMotor"):
        start, stop = float(times[0]), float(times[-1])
        return {"M_reaction": -LOAD_NM * np.sin(math.pi * (times - start) / (stop - start)) ** 2}
    return {}


def _number(v: float) -> str:
    return repr(float(v)) if v != int(v) or abs(v) >= 1e16 else repr(float(v)).removesuffix(".0")


def _write_csv(path: Path, header, rows, booleans=()) -> None:
    lines = [",".join(f'"{h}"' for h in header)]
    for row in rows:
        lines.append(",".join(str(int(v)) if j in booleans else _number(v) for j, v in enumerate(row)))
    text = "\n".join(lines) + "\n"
    if len(text.encode()) > MAX_BYTES:
        raise CrossCheckError(f"{path.name} would be {len(text.encode())} bytes; the cross-check rules allow "
                              f"at most {MAX_BYTES}")
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text)
    tmp.replace(path)


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    """(column names, rows) of a cross-check CSV."""
    with open(path) as fh:
        header = [h.strip().strip('"') for h in fh.readline().split(",")]
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def read_opt(path: Path) -> dict[str, float]:
    out = {}
    for line in Path(path).read_text().splitlines():
        if "," in line:
            key, value = line.split(",", 1)
            out[key.strip()] = float(value.split("//")[0])
    return out


def write(name: str, fmu: Path, base: Path) -> list[Path]:
    """Write the three files of this model (see the module's docstring); return their paths."""
    from ballmill.scenario import fmucache, runner
    from ballmill.scenario import spec as _spec

    start, stop, step, interval = experiment(name)
    n = int(round((stop - start) / step))
    grid = np.array([start + k * step for k in range(n)] + [stop])  # the master's communication points
    moved = inputs(name, grid)
    md = fmucache.model_description(fmu)
    declared = {v.name: v for v in md.modelVariables}
    for v in list(moved) + list(REF_OUTPUTS[name]):
        if v not in declared:
            raise CrossCheckError(f"{name}: the cross-check names {v!r}, which {fmu} does not declare")
    in_csv, opt, ref_csv = files(name, base)
    in_csv.parent.mkdir(parents=True, exist_ok=True)
    ins = [v for v in md.modelVariables if v.causality == "input"]
    if moved:  # every input, those the experiment does not move at their start values
        _write_csv(in_csv, ["time", *(v.name for v in ins)],
                   np.column_stack([grid, *(moved[v.name] if v.name in moved else np.full(grid.size, float(v.start))
                                           for v in ins)]))
    else:  # every input at its start value: two rows
        _write_csv(in_csv, ["time", *(v.name for v in ins)],
                   [[t, *(float(v.start) for v in ins)] for t in (start, stop)])
    header, data = read_csv(in_csv)  # what an importer reads: the master runs on exactly that
    instances = {"in": _spec.Instance("in", table=in_csv, columns=header[1:], data=data),
                 "model": _spec.Instance("model", fmu=name)}
    sc = _spec.Scenario(path=in_csv, name=f"{name} default experiment", description="FMI cross-check reference",
                        start=start, stop=stop, step=step, instances=instances,
                        connections=[("in", c, "model", c) for c in header[1:]],
                        record=[("model", v) for v in REF_OUTPUTS[name]], plots=[], summary={})
    res = runner.run(sc, {name: md}, {name: fmu}, progress=False, echo=False)
    if not res.success:
        raise CrossCheckError(f"{name}: the default experiment did not run to its end: {res.message}")
    every = int(round(interval / step))
    rows = res.data[list(range(0, n, every)) + [n]]
    booleans = {j + 1 for j, v in enumerate(REF_OUTPUTS[name]) if declared[v].type in ("Boolean", "Integer")}
    _write_csv(ref_csv, res.columns[:1] + [v for _, v in sc.record], rows, booleans)
    tmp = opt.with_name(opt.name + ".part")
    tmp.write_text(f"StartTime, {start!r}\nStopTime, {stop!r}\nStepSize, {step!r}\nRelTol, {REL_TOL!r}\n"
                   f"AbsTol, {ABS_TOL!r}\nOutputIntervalLength, {interval!r}\n")
    tmp.replace(opt)
    return [in_csv, opt, ref_csv]
