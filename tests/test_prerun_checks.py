"""Values checked before anything runs, as a user meets it: `ballmill run`, `ballmill
export-ssp` and `ballmill sweep` refuse a bad value (exit status 2) with every problem at
once, each naming where the value came from (the file's key, --set, --grid); the rules the
check reads (ballmill.fmi.interface) are those the FMUs enforce; a refusal the check cannot
foresee ends the run through legal FMI calls with the FMU's reason printed once; a sweep
whose points all fail exits non-zero with the first reason."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ballmill.fmi.interface import INTERFACES

ROOT = Path(__file__).resolve().parents[1]
ILLEGAL = "is not allowed in state"  # what the project's FMUs log for a call their state forbids


def ballmill(*args, cwd) -> subprocess.CompletedProcess:
    """The `ballmill` command of this checkout, as a user runs it."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "ballmill.cli", *map(str, args)], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


# -- ballmill run / export-ssp -------------------------------------------------------------
def test_run_refuses_bad_values_at_once_naming_each_set(tmp_path, fmu_build_dir):
    out = tmp_path / "out"
    p = ballmill("run", "fast_start", "--out", out, "--build-dir", fmu_build_dir, "--quiet",
                 "--set", "ball.r=-0.025", "--set", "drive.n0=-60", "--set", "drive.t0=abc", "--set", "ball.mu=0",
                 cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert "4 problem(s)" in p.stderr
    for problem in ("--set ball.r=-0.025: parameter r = -0.025 m is outside its accepted range [0, 1000] m",
                    "--set drive.n0=-60: parameter n0 = -60 1/min is outside its accepted range [0, 100000] 1/min",
                    "--set drive.t0=abc: expected a Real value, got 'abc'",
                    "--set ball.mu=0: BallInShell 'ball' needs mu > 0, got mu = 0"):
        assert problem in p.stderr, p.stderr
    assert "fast_start.toml: instances.drive.parameters.t0" not in p.stderr  # the --set is to blame
    assert ILLEGAL not in p.stderr and "running fast_start" not in p.stderr  # nothing ran
    assert not out.exists()


def test_export_ssp_refuses_a_value_the_fmu_would_refuse(tmp_path, fmu_build_dir):
    ssp = tmp_path / "fast_start.ssp"
    p = ballmill("export-ssp", "fast_start", ssp, "--build-dir", fmu_build_dir, "--set", "ball.r=0.3", cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert ("--set ball.r=0.3: BallInShell 'ball' needs r < R (the ball must fit in the chamber), got r = 0.3 m, "
            "R = 0.25 m (fast_start.toml)") in p.stderr
    assert not ssp.exists()


FOUR_MISTAKES = """
description = "four mistakes"
connections = ["drive.x1O -> ball.x1O", "drive.y1O -> ball.y1O"]
[experiment]
stop = 1.0
step = 0.002
[instances.drive]
fmu = "MotorStartup"
parameters = { t0 = "fast", n0 = -60.0 }
[instances.ball]
fmu = "BallInShell"
parameters = { r = 0.3 }
[instances.spare]
fmu = "MotorStartUp"
"""


def test_a_file_with_four_mistakes_shows_all_four_in_one_pass(tmp_path, fmu_build_dir):
    path = tmp_path / "four.toml"
    path.write_text(FOUR_MISTAKES)
    p = ballmill("run", path, "--out", tmp_path / "out", "--build-dir", fmu_build_dir, "--quiet", cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    where = path.as_posix()
    expected = [f"{where}: instances.spare.fmu: unknown model 'MotorStartUp'",
                f"{where}: instances.drive.parameters.t0: expected a Real value, got 'fast'",
                f"{where}: instances.drive.parameters.n0: parameter n0 = -60.0 1/min is outside its accepted "
                f"range [0, 100000] 1/min",
                f"{where}: instances.ball.parameters.r: BallInShell 'ball' needs r < R (the ball must fit in the "
                f"chamber), got r = 0.3 m, R = 0.25 m (default)"]
    assert "4 problem(s)" in p.stderr
    for problem in expected:
        assert problem in p.stderr, p.stderr


def test_a_refusal_the_check_cannot_foresee_ends_the_run_legally_and_says_it_once(tmp_path, fmu_build_dir):
    """Tb_ratio = 90 is within InductionMotor's range and rules, but no dq model fits that
    datasheet: the FMU refuses its initialisation. The master then frees the instances
    without fmi2Terminate (not allowed before the end of initialisation), and the FMU's
    reason appears once on stderr."""
    p = ballmill("run", "induction_start", "--out", tmp_path / "out", "--build-dir", fmu_build_dir, "--quiet",
                 "--set", "motor.Tb_ratio=90", cwd=tmp_path)
    assert p.returncode == 1, p.stderr
    assert p.stderr.count("no dq parameters reproduce the rated point") == 1, p.stderr
    assert ILLEGAL not in p.stderr and "fmi2Terminate" not in p.stderr


def test_the_master_terminates_exactly_the_initialised_instances(fmu_build_dir, monkeypatch):
    """fmi2Terminate after a refused step (stepFailed, stepComplete), never after a refused
    initialisation (fmi2Error; the pythonfmu flavour's fmi2Fatal, after which nothing may be
    called); the FMUs log no illegal call either way."""
    from fmpy.fmi2 import FMU2Slave

    from ballmill.scenario import runner
    terminated = []
    original = FMU2Slave.terminate

    def terminate(self):
        terminated.append(self.instanceName)
        return original(self)
    monkeypatch.setattr(FMU2Slave, "terminate", terminate)

    def run(scenario, *sets, flavour="native"):
        sc, models, paths = runner.prepare(scenario, list(sets), fmu_build_dir, log=lambda m: None, flavour=flavour)
        sc.stop = 0.02
        res = runner.run(sc, models, paths, progress=False, echo=False)
        assert not res.success
        assert not [m for m in res.messages if ILLEGAL in m["message"]], res.messages
        return res

    res = run("induction_start", "motor.Tb_ratio=90")
    assert "initialisation failed" in res.message and terminated == []
    # the pythonfmu motor refuses at fmi2ExitInitializationMode with fmi2Fatal; the law (a source,
    # initialised first) had completed its initialisation, the ball had not
    res = run("induction_start", "motor.Tb_ratio=90", flavour="pythonfmu")
    assert "(fatal). InductionMotor 'motor': initialisation failed" in res.message and terminated == ["law"]
    terminated.clear()
    res = run("fast_start", "ball.max_step=0.001")  # every step of 2 ms refused (fmi2Discard)
    assert "ball refused the step" in res.message
    assert sorted(terminated) == ["ball", "drive"]


# -- the declared rules are the FMUs' ------------------------------------------------------
# per model, for each of its rules in order: parameter values that break it and no rule before
VIOLATIONS = {
    "BallInShell": [{"r": 0.0}, {"R": 0.0}, {"m": 0.0}, {"g": 0.0}, {"mu": 0.0}, {"r": 0.3},
                    {"r": 0.25 * (1 - 1e-10)}, {"h_fixed": 0.0}, {"delta": 0.03}, {"c_drag": 1e5},
                    {"xC0": 0.23}, {"motion": 2, "formulation": 2}, {"motion": 2, "delta": 1e-3},
                    {"w_bed": 0.0}, {"bed": 1, "h_bed": 0.6}, {"motion": 2, "bed": 1},
                    {"motion": 2, "input_mode": 2}, {"integrator": 3, "h_fixed": 1e-7},
                    {"formulation": 2, "xC0": 0.22497}, {"mu_k": 5.0}, {"v_rest": 0.0},
                    {"contact_model": 2, "formulation": 2}, {"contact_model": 2, "c_drag": 1.0},
                    {"contact_model": 2, "bed": 1}],
    "MotorStartup": [{"l": 0.0}],
    "InductionMotor": [{"P_rated": 0.0}, {"n_rated": 0.0}, {"U_rated": 0.0}, {"f_rated": 0.0}, {"I_rated": 0.0},
                       {"J_rotor": 0.0}, {"ramp_time": 0.0}, {"cos_phi": 0.0}, {"eta": 0.0}, {"f_start": 1.0},
                       {"Rs_share": 1.0}, {"Tb_ratio": 1.0}, {"n_rated": 1500.0}, {"I_rated": 3.4}, {"l": 0.0}],
}


def test_every_declared_rule_is_refused_by_the_check_and_by_the_fmu(fmus_of):
    from fmpy import read_model_description
    from fmpy.fmi1 import FMICallException

    from ballmill.scenario import spec
    from fmu_instance import Instance

    declared = {name: len(i.rules) for name, i in INTERFACES.items() if i.rules}
    assert {name: len(v) for name, v in VIOLATIONS.items()} == declared  # every rule has its case
    paths = fmus_of("native")
    models = {name: read_model_description(str(paths[name])) for name in VIOLATIONS}
    for name, cases in VIOLATIONS.items():
        for k, (rule, values) in enumerate(zip(INTERFACES[name].rules, cases)):
            inst = spec.Instance("x", fmu=name, origins={p: f"--set x.{p}" for p in values})
            problems = spec.parameter_problems("x", inst, models, values)
            assert len(problems) == 1 and f"needs {rule.expected}, got" in problems[0], (name, k, problems)
            fmu = Instance(paths[name], f"rule{k}", **values)
            try:
                with pytest.raises(FMICallException):
                    fmu.initialize()
                assert any("initialisation failed" in text for _, text in fmu.messages), (name, k, fmu.messages)
            finally:
                fmu.fmu.freeInstance()
        # the defaults meet every rule
        defaults = {v.name: spec._start(v) for v in models[name].modelVariables if v.causality == "parameter"}
        assert all(rule.holds(defaults) for rule in INTERFACES[name].rules)


# -- ballmill sweep ------------------------------------------------------------------------
def test_a_sweep_checks_its_names_and_values_before_any_point_runs(tmp_path, fmu_build_dir):
    out = tmp_path / "sweep"
    p = ballmill("sweep", "fast_start", "--grid", "drive.t00=1,2", "--grid", "ball.r=0.1,0.3", "--set", "ball.mu=0",
                 "--out", out, "--build-dir", fmu_build_dir, "--quiet", cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert "3 problem(s)" in p.stderr
    for problem in ("--grid drive.t00=1,2: MotorStartup has no parameter 't00'",
                    "--grid ball.r=0.1,0.3: BallInShell 'ball' needs r < R (the ball must fit in the chamber), "
                    "got r = 0.3 m, R = 0.25 m (fast_start.toml)",
                    "--set ball.mu=0: BallInShell 'ball' needs mu > 0, got mu = 0"):
        assert problem in p.stderr, p.stderr
    assert not (out / "results.parquet").exists() and not (out / "study.json").exists()


def test_a_study_files_values_are_named_by_their_keys_and_a_sample_is_summarised(tmp_path, fmu_build_dir):
    from ballmill.sweep import spec as study

    path = tmp_path / "study.toml"
    path.write_text('scenario = "fast_start"\nset = { "ball.mu" = 0.0 }\n[grid]\n"ball.r" = [0.02, 0.3]\n')
    with pytest.raises(study.StudyError) as e:
        study.check_scenario(study.load(str(path), set_=["drive.n0=-1"]), fmu_build_dir)
    where = path.as_posix()
    assert sorted(e.value.problems) == sorted([
        f"{where}: set.ball.mu: BallInShell 'ball' needs mu > 0, got mu = 0.0",
        "--set drive.n0=-1: parameter n0 = -1 1/min is outside its accepted range [0, 100000] 1/min",
        f"{where}: grid.ball.r: BallInShell 'ball' needs r < R (the ball must fit in the chamber), got r = 0.3 m, "
        f"R = 0.25 m (fast_start.toml)"])
    # 40 sampled radii, those above R = 0.25 m refused: one line, with how many more
    sample = study.load("fast_start", sample={"method": "random", "points": 40, "seed": 3,
                                              "ranges": {"ball.r": "0.1:0.4"}})
    over = sorted(p["ball.r"] for p in sample.points() if p["ball.r"] >= 0.25)
    assert len(over) > 2
    with pytest.raises(study.StudyError) as e:
        study.check_scenario(sample, fmu_build_dir)
    first = next(p["ball.r"] for p in sample.points() if p["ball.r"] >= 0.25)
    assert e.value.problems == [
        f"--range ball.r=0.1:0.4: BallInShell 'ball' needs r < R (the ball must fit in the chamber), got r = {first!r} "
        f"m, R = 0.25 m (fast_start.toml) (and {len(over) - 1} more like it)"]


def test_a_reversed_range_is_refused_naming_the_option(tmp_path, fmu_build_dir):
    p = ballmill("sweep", "fast_start", "--grid", "drive.t0=4:1:3", "--out", tmp_path / "sweep",
                 "--build-dir", fmu_build_dir, "--quiet", cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert "--grid drive.t0=4:1:3: start:stop:count needs start < stop (a reversed range" in p.stderr


@pytest.mark.parametrize("grid, status, line", [
    # max_step below the 2 ms communication step: BallInShell refuses the first step
    ("ball.max_step=0.001,0.0015", 1, "all 2 points failed; the first (point 0: ball.max_step = 0.001): "
                                      "ArithmeticError: ball refused the step at t = 0 s (discard)"),
    ("ball.max_step=0.001,0", 0, "1 of 2 points failed; the first (point 0: ball.max_step = 0.001): "
                                 "ArithmeticError: ball refused the step at t = 0 s (discard)"),
])
def test_a_sweep_whose_points_fail_says_so_and_fails_when_all_do(tmp_path, fmu_build_dir, grid, status, line):
    out = tmp_path / "sweep"
    p = ballmill("sweep", "fast_start", "--model", "cosim", "--grid", grid, "--stop", "0.01", "--in-process",
                 "--no-plots", "--out", out, "--build-dir", fmu_build_dir, "--quiet", cwd=tmp_path)
    assert p.returncode == status, p.stderr
    assert f"ballmill sweep: {line}" in p.stderr
    assert (out / "results.parquet").exists()  # the failed rows are kept, with their reasons


def test_a_sweep_whose_points_all_fail_before_integrating_fails(tmp_path, fmu_build_dir):
    p = ballmill("sweep", "induction_start", "--grid", "motor.Tb_ratio=50,90", "--stop", "0.01", "--in-process",
                 "--no-plots", "--out", tmp_path / "sweep", "--build-dir", fmu_build_dir, "--quiet", cwd=tmp_path)
    assert p.returncode == 1, p.stderr
    assert "ballmill sweep: all 2 points failed; the first (point 0: motor.Tb_ratio = 50): " in p.stderr
    assert "no dq parameters reproduce the rated point" in p.stderr
