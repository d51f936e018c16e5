"""ballmill/scenario/runner.py: `prepare` (the build it asks for, the paths and model
descriptions it hands on, the scenario it loads), the progress bar of a run that starts
later than 0, and the result's init_time and wall_time read from the clock (a fake clock
that advances 1 s per reading: the values are counts of readings, exact)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ballmill.fmi import build as _build
from ballmill.scenario import runner, spec
from runner_cases import direct, table


def test_prepare_builds_the_flavour_asked_and_loads_the_scenario(native_fmus, monkeypatch, tmp_path):
    calls = []

    def build_all(*args, **kwargs):
        calls.append((args, kwargs))
        return list(native_fmus.values())
    monkeypatch.setattr(_build, "build_all", build_all)
    logs = []
    sc, models, paths = runner.prepare("fast_start", ["drive.t0=1.5"], tmp_path, log=logs.append)
    assert calls == [((tmp_path,), {"log": logs.append, "flavour": "native", "only": True,
                                     "names": ["BallInShell", "MotorStartup"]})]
    assert paths == native_fmus and list(paths) == list(native_fmus)
    assert isinstance(models, runner._Descriptions) and list(models) == list(native_fmus)
    assert models["MotorStartup"].modelName == "MotorStartup"
    assert sc.name == "fast_start" and sc.instances["drive"].parameters["t0"] == 1.5
    assert {inst.fmu for inst in sc.instances.values()} == {"MotorStartup", "BallInShell"}
    # the defaults: no overrides, the default build folder, print, the native flavour
    calls.clear()
    sc, _, _ = runner.prepare("fast_start")
    assert calls == [((None,), {"log": print, "flavour": "native", "only": True,
                                 "names": ["BallInShell", "MotorStartup"]})]
    assert sc.instances["drive"].parameters["t0"] == 2.5
    # the scenario is checked against the model descriptions: a parameter the FMU lacks is refused
    with pytest.raises(spec.ScenarioError) as e:
        runner.prepare("fast_start", ["drive.nosuch=1"], tmp_path, log=logs.append)
    assert any(p.startswith("--set drive.nosuch=1: MotorStartup has no parameter") for p in e.value.problems), \
        e.value.problems
    calls.clear()
    runner.prepare("fast_start", flavour="pythonfmu")
    assert calls == [((None,), {"log": print, "flavour": "pythonfmu", "only": True,
                                 "names": ["BallInShell", "MotorStartup"]})]


def test_the_progress_of_a_run_that_starts_later_counts_from_its_start(native_models, native_fmus, capsys,
                                                                        monkeypatch):
    """100 steps from 0.25 s: the bar is updated every 50 steps, at half the run and at its end."""
    monkeypatch.setattr(runner.sys.stderr, "isatty", lambda: False)
    drive = {"drive": spec.Instance("drive", fmu="MotorStartup")}
    res = runner.run(direct(drive, [], [("drive", "psi")], start=0.25, stop=0.35, step=0.001), native_models,
                     native_fmus, progress=True, echo=False)
    assert res.success and res.steps == 100
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln]
    assert [ln.split("(")[0] for ln in lines] == ["   50.0%  t = 0.300 s  ", "  100.0%  t = 0.350 s  "]


class _Clock:
    """time.perf_counter for the runner: 1, 2, 3, ... s at successive readings."""

    def __init__(self):
        self.now = 0.0

    def perf_counter(self):
        self.now += 1.0
        return self.now


def test_init_and_wall_time_are_read_where_the_run_is(native_models, native_fmus, monkeypatch):
    """Readings: 1 the start, 2 initialised, 3 the progress bar's start; a run that ends with
    an exception after its initialisation keeps init_time = 2 - 1 (reading 4 is the unused
    fallback for a failure before it), the wall time is the last reading - 1."""
    tab = table("src", ["a"], [0.0, 0.03, 0.06, 0.1], [lambda t: 1.0 + t ** 3])
    structure = spec.Instance("structure", fmu="Structure", parameters={"input_order": 0})
    sc = direct({"src": tab, "structure": structure}, [("src", "a", "structure", "ag_x")],
                [("structure", "agx_total")], start=0.0, stop=0.2)
    clock = _Clock()
    monkeypatch.setattr(runner, "time", SimpleNamespace(perf_counter=clock.perf_counter))
    res = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert (res.success, res.steps) == (False, 11)
    assert (res.init_time, res.wall_time) == (1.0, 4.0)
    # a run that completes: initialised at reading 2, ended at reading 4
    clock.now = 0.0
    ok = runner.run(direct({"src": tab, "structure": spec.Instance("structure", fmu="Structure")},
                           [("src", "a", "structure", "ag_x")], [("structure", "agx_total")], start=0.0, stop=0.1),
                    native_models, native_fmus, progress=False, echo=False)
    assert ok.success and (ok.init_time, ok.wall_time) == (1.0, 3.0)
    assert np.isfinite(ok.data).all()
