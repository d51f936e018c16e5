"""libcosim runs of an exported package, down to the sample reader (ballmill/scenario/ssp.py:
run_ssp_libcosim's grid and tolerance, observe_series, _get_real_samples), in this process
with the native MotorStartup of tests/mutation/native_fmus.py. The drive's linear law (law
3) is a closed form: psi_dot = w0 t / t0 up to t0, w0 after."""
from __future__ import annotations

import math
import tempfile
import zipfile

import numpy as np
import pytest

pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (the 'test' extra)")

from ballmill.scenario import runner, ssp  # noqa: E402
from runner_cases import load  # noqa: E402

TEXT = """
[experiment]
start = 0.0
stop = 0.03
step = 0.01
[instances.drive]
fmu = "MotorStartup"
parameters = { n0 = 90.0, t0 = 0.5, law = 3 }
"""
W0 = 2.0 * math.pi * 90.0 / 60.0


def psi_dot(t):
    return W0 * min(t, 0.5) / 0.5


@pytest.fixture()
def drive_package(tmp_path, native_models, native_fmus, monkeypatch):
    sc = load(tmp_path, TEXT, native_models, name="drive")
    monkeypatch.setattr(runner, "prepare", lambda *a, **k: (sc, native_models, native_fmus))
    return ssp.export_ssp("drive", tmp_path / "drive.ssp", log=lambda m: None)


def _execution(package, folder, step_ns):
    from libcosimpy.CosimExecution import CosimExecution

    ssp.ensure_libpython()
    ssp.set_libcosim_log_level("error")
    with zipfile.ZipFile(package) as z:
        z.extractall(folder)
    return CosimExecution.from_ssp_file(str(folder), step_size=step_ns)


def test_the_samples_as_libcosim_keeps_them(drive_package, tmp_path):
    execution = _execution(drive_package, tmp_path / "x", 10_000_000)
    (info,) = execution.slave_infos()
    idx = info.index
    refs = {v.name.decode(): v.reference for v in execution.slave_variables(idx)}
    collect = ssp.observe_series(execution, [("drive", "psi_dot"), ("drive", "psi")], 3)
    # before the first step libcosim has no samples: an error naming the slave and variable
    with pytest.raises(RuntimeError) as e:
        collect()
    assert str(e.value) == (f"libcosim: cannot read samples of slave {idx} variable {refs['psi_dot']}: "
                            f"No samples recorded yet!")
    assert execution.simulate_until(30_000_000)
    out = collect()
    assert list(out) == ["time", "drive.psi_dot", "drive.psi"]
    assert np.array_equal(out["time"], np.array([0, 10_000_000, 20_000_000, 30_000_000]) * 1e-9)
    assert np.allclose(out["drive.psi_dot"], [psi_dot(t) for t in (0.0, 0.01, 0.02, 0.03)], rtol=1e-12, atol=0)
    # the reader itself: step numbers and times as integers, values as doubles
    assert collect.observer is not None
    steps, times, values = ssp._get_real_samples(collect.observer, idx, refs["psi_dot"], 8)
    assert steps.dtype == np.int64 and list(steps) == [0, 1, 2, 3]
    assert times.dtype == np.int64 and list(times) == [0, 10_000_000, 20_000_000, 30_000_000]
    assert values.dtype == np.float64 and np.array_equal(values, out["drive.psi_dot"])
    # a variable that is not observed has no samples: three empty arrays, not an error
    steps, times, values = ssp._get_real_samples(collect.observer, idx, refs["T_drive"], 8)
    assert (steps.dtype, times.dtype, values.dtype) == (np.int64, np.int64, np.float64)
    assert steps.size == times.size == values.size == 0
    with pytest.raises(RuntimeError) as e:
        ssp._get_real_samples(collect.observer, idx + 7, 0, 8)
    assert str(e.value).startswith(f"libcosim: cannot read samples of slave {idx + 7} variable 0: ")


def test_series_sampled_on_other_steps_are_refused(drive_package, tmp_path, monkeypatch):
    execution = _execution(drive_package, tmp_path / "x", 10_000_000)
    collect = ssp.observe_series(execution, [("drive", "psi"), ("drive", "psi_dot"), ("drive", "T_drive")], 3)
    assert execution.simulate_until(30_000_000)
    real = ssp._get_real_samples
    calls = []

    def shifted(observer, slave, ref, n):
        steps, times, values = real(observer, slave, ref, n)
        calls.append(ref)
        return (steps + 1 if len(calls) == 3 else steps), times, values
    monkeypatch.setattr(ssp, "_get_real_samples", shifted)
    with pytest.raises(RuntimeError) as e:
        collect()
    assert str(e.value) == "libcosim sampled drive.T_drive at other steps than drive.psi"


def test_a_variable_libcosim_will_not_observe(drive_package, tmp_path, monkeypatch):
    from libcosimpy.CosimObserver import CosimObserver

    execution = _execution(drive_package, tmp_path / "x", 10_000_000)
    monkeypatch.setattr(CosimObserver, "start_time_series", lambda self, *a: False)
    with pytest.raises(RuntimeError) as e:
        ssp.observe_series(execution, [("drive", "psi")], 3)
    assert str(e.value) == "libcosim cannot observe drive.psi"


def test_grids_of_one_step_of_whole_seconds_and_of_nanoseconds(drive_package, monkeypatch):
    prefixes = []
    real_tmp = tempfile.TemporaryDirectory

    def spy(*args, **kwargs):
        prefixes.append(kwargs.get("prefix"))
        return real_tmp(*args, **kwargs)
    monkeypatch.setattr(tempfile, "TemporaryDirectory", spy)
    one = ssp.run_ssp_libcosim(drive_package, step=0.05, stop=0.05, record=[("drive", "psi_dot")])
    assert np.array_equal(one["time"], [0.0, 0.05])
    assert np.allclose(one["drive.psi_dot"], [0.0, psi_dot(0.05)], rtol=1e-12)
    # 1 s steps: 10^9 ns exactly
    whole = ssp.run_ssp_libcosim(drive_package, step=1.0, stop=2.0, record=[("drive", "psi_dot")])
    assert np.array_equal(whole["time"], [0.0, 1.0, 2.0])
    assert np.allclose(whole["drive.psi_dot"], [0.0, W0, W0], rtol=1e-12)
    assert prefixes == ["ballmill_ssp_", "ballmill_ssp_"]
    # stop may miss a whole number of steps by 1 ns at most: 7 ns in 3 ns steps runs to 6 ns
    ns = ssp.run_ssp_libcosim(drive_package, step=3e-9, stop=7e-9, record=[("drive", "psi_dot")])
    assert np.array_equal(np.round(ns["time"] * 1e9), [0.0, 3.0, 6.0])
    with pytest.raises(ValueError) as e:
        ssp.run_ssp_libcosim(drive_package, step=5e-9, stop=8e-9)
    assert str(e.value) == "stop = 8e-09 s is not a positive whole number of steps of 5e-09 s"


def test_a_package_libcosim_cannot_load(tmp_path):
    bad = tmp_path / "missing.ssp"
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("SystemStructure.ssd", """<?xml version='1.0' encoding='UTF-8'?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="m">
  <ssd:System name="m"><ssd:Elements>
    <ssd:Component name="gone" type="application/x-fmu-sharedlibrary" source="resources/Gone.fmu"/>
  </ssd:Elements></ssd:System>
  <ssd:DefaultExperiment startTime="0.0" stopTime="0.02"/>
</ssd:SystemStructureDescription>""")
    with pytest.raises(RuntimeError) as e:
        ssp.run_ssp_libcosim(bad, step=0.01, log_level="fatal")
    text = str(e.value)
    assert text.startswith(f"libcosim cannot load {bad}: ") and len(text) > len(f"libcosim cannot load {bad}: ")


def test_a_run_longer_than_libcosims_default_buffer_keeps_every_sample(drive_package):
    """libcosim's time-series observer keeps 10,000 samples unless told otherwise: a run of
    10,100 steps of 1 ns still starts at t = 0."""
    out = ssp.run_ssp_libcosim(drive_package, step=1e-9, stop=10_100e-9, record=[("drive", "psi")])
    assert len(out["time"]) == len(out["drive.psi"]) == 10_101
    assert out["time"][0] == 0.0 and round(out["time"][-1] * 1e9) == 10_100


def test_a_step_the_fmu_refuses_stops_the_libcosim_run(tmp_path, native_models, native_fmus, monkeypatch):
    """A structure whose ball force input is bound to 1e300 N refuses its first step."""
    from pathlib import Path

    from ballmill.scenario import spec

    sc = spec.Scenario(path=Path("s.toml"), name="s", description="", start=0.0, stop=0.03, step=0.01,
                       instances={"s": spec.Instance("s", fmu="Structure", parameters={"Fx_ball": 1e300})},
                       connections=[], record=[], plots=[], summary={})
    monkeypatch.setattr(runner, "prepare", lambda *a, **k: (sc, native_models, native_fmus))
    out = ssp.export_ssp("s", tmp_path / "s.ssp", log=lambda m: None)
    with pytest.raises(RuntimeError) as e:
        ssp.run_ssp_libcosim(out, record=[("s", "x1O")])
    assert str(e.value) == "libcosim stopped at t = 0 s: Simulation error: s: Step not complete\n"
