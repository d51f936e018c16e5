"""The C master that `ballmill bench` times the native FMUs with (ballmill/bench/coupled_host.c)
runs the coupled fast start as `ballmill run` does: the same contact point, so the time it
reports is the time of the right work."""
from __future__ import annotations

import shutil

import pytest

from ballmill.bench import flavours
from ballmill.scenario import runner

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc)")


def test_c_master_runs_the_fast_start_as_ballmill_run(fmu_build_dir):
    stop = 3.0  # past t0 = 2.5 s, where the start-up law's jerk jumps
    host = flavours.fmus_in_c_host(1, stop, build_dir=fmu_build_dir)
    assert host is not None and host["steps"] == 1500 and host["cycles"] == 1
    sc, models, paths = runner.prepare("fast_start", [], fmu_build_dir, log=lambda m: None)
    sc.step, sc.stop = flavours.H, stop
    sc.record = [("ball", "zP")]
    res = runner.run(sc, models, paths, progress=False, echo=False)
    assert res.success
    # the same calls in the same order on the same binaries (Jacobi: read all, set all, step
    # all; one initialisation pass settles this loop): the same number, bit for bit
    assert host["zP"] == res.column("ball.zP")[-1]
    # and the fast start's contact point: the coupling error at 2 ms is about 1e-9 m (BENCHMARKS.md)
    assert abs(host["zP"] - host["zP_ref"]) < 1e-8
    assert host["both"] > 0.0 and host["ball"] > 0.0 and host["drive"] > 0.0


def test_the_do_nothing_fmu_builds_clean_and_echoes(tmp_path):
    """The bench's floor FMU (ballmill/bench/null_model.c) over the shared plumbing: compiled at
    -Wall -Wextra without a warning (the build refuses warnings), and y follows u step by step."""
    from pathlib import Path

    from fmpy import simulate_fmu

    from ballmill.fmi import native

    fmu = native.build_native("Null", tmp_path, flavours.NULL, Path(flavours.__file__).with_name("null_model.c"))
    res = simulate_fmu(str(fmu), stop_time=0.01, step_size=0.002, output_interval=0.002,
                       input=_ramp(), output=["y"])
    assert list(res["y"][1:]) == pytest.approx(list(res["time"][:-1]), abs=1e-15)


def _ramp():
    import numpy as np
    t = np.arange(0.0, 0.0101, 0.002)
    return np.array(list(zip(t, t)), dtype=[("time", float), ("u", float)])
