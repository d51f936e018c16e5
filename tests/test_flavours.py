"""The two flavours of each FMU (native C and the pythonfmu reference) give the same run,
bit for bit, on every scenario in scenarios/ (the first 2 s at the scenario's own step,
coupled through ballmill's fmpy master), and the same refusal where a run stops.

Bit for bit because the C mirrors the Python path's operation order: the kernel for the
ball's right-hand side, outputs and integrators; the input reconstruction's correctly
rounded inverse and left-to-right dot products (platform.py); numpy's order of summation
in the adaptive integrators' initial step; libm's pow where Python writes ``** 2``.
"""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.scenario import runner, spec

SCENARIOS = sorted(p.stem for p in spec.SCENARIO_DIR.glob("*.toml"))


def _run(name, build_dir, flavour, overrides=(), stop=2.0):
    sc, models, paths = runner.prepare(name, list(overrides), build_dir, log=lambda m: None, flavour=flavour)
    sc.stop = min(sc.stop, sc.start + stop)
    return runner.run(sc, models, paths, progress=False, echo=False)


def _same(a, b):
    assert a.success == b.success, (a.message, b.message)
    assert a.columns == b.columns and a.data.shape == b.data.shape
    for j, name in enumerate(a.columns):
        assert np.array_equal(a.data[:, j], b.data[:, j]), \
            (name, float(np.max(np.abs(a.data[:, j] - b.data[:, j]))))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_native_and_pythonfmu_flavours_agree_bit_for_bit(fmu_build_dir, scenario):
    a = _run(scenario, fmu_build_dir, "native")
    b = _run(scenario, fmu_build_dir, "pythonfmu")
    assert a.success, a.message
    assert len(a.data) > 100
    _same(a, b)


@pytest.mark.parametrize("overrides", [
    ("ball.formulation=2", "ball.integrator=1", "ball.tolerance=1e-10"),
    ("ball.integrator=3", "ball.input_mode=3"),
    ("ball.corrector=false", "ball.delta=1e-4", "ball.c_drag=0.05"),
    ("ball.formulation=2", "drive.n0=90", "drive.t0=1"),  # stops at the equator, in both
], ids=["paper-DOP853", "RK4-hold", "no-corrector-losses", "paper-to-the-equator"])
def test_flavours_agree_on_other_numerics(fmu_build_dir, overrides):
    a = _run("fast_start", fmu_build_dir, "native", overrides, stop=1.5)
    b = _run("fast_start", fmu_build_dir, "pythonfmu", overrides, stop=1.5)
    _same(a, b)
