"""Small scenarios for the tests of the co-simulation master (tests/mutation/test_runner_*.py):
closed forms of the drive law, cubic input tables, and scenarios built from TOML text
(checked by ballmill.scenario.spec against the native model descriptions) or directly (for
what the checker refuses, e.g. a unit mismatch that makes a deliberate loop)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ballmill.scenario import spec


def load(tmp_path: Path, text: str, models: dict, name: str = "case") -> spec.Scenario:
    """A scenario from TOML text, written to tmp_path and checked against the model descriptions."""
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return spec.load(str(path), [], models)


def direct(instances: dict, connections=(), record=(), start=0.0, stop=0.1, step=0.01, master=None,
           name="direct") -> spec.Scenario:
    """A scenario built without the checker: instances name -> spec.Instance."""
    return spec.Scenario(path=Path(f"{name}.toml"), name=name, description="", start=start, stop=stop,
                         step=step, instances=instances, connections=list(connections), record=list(record),
                         plots=[], summary={}, master={**spec.MASTER_DEFAULTS, **(master or {})})


def table(name: str, columns: list[str], times, functions) -> spec.Instance:
    """A table source with rows (t, f1(t), f2(t), ...) at the given times."""
    t = np.asarray(times, dtype=float)
    data = np.column_stack([t] + [np.array([f(x) for x in t]) for f in functions])
    return spec.Instance(name, columns=list(columns), data=data)


def write_csv(path: Path, columns: list[str], times, functions) -> Path:
    lines = [",".join(["time"] + list(columns))]
    for x in times:
        lines.append(",".join(repr(float(v)) for v in [x] + [f(x) for f in functions]))
    path.write_text("\n".join(lines) + "\n")
    return path


def linear_law(n0: float, t0: float, t: float) -> tuple[float, float, float]:
    """MotorStartup's law 3 (linear speed rise), angle, rate and acceleration at t <= t0."""
    w0 = 2.0 * math.pi * n0 / 60.0
    return 0.5 * w0 * t * t / t0, w0 * t / t0, w0 / t0


def quadratic_law(n0: float, t0: float, t: float) -> tuple[float, float, float]:
    """The paper's law (MotorStartup's law 1) at t <= t0: psi' = w0 (1 - (1 - t/t0)^2)."""
    w0 = 2.0 * math.pi * n0 / 60.0
    u = 1.0 - t / t0
    return w0 * (t - t0 * (1.0 - u ** 3) / 3.0), w0 * (1.0 - u * u), 2.0 * w0 * u / t0
