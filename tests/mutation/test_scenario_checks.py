"""Scenario files (ballmill.scenario.spec): every check, each mistake reported with the file,
the key and what was expected, word for word; table sources; the default record. Against
the model descriptions of the pythonfmu slaves written in-process (no FMU is built), for the
mutants of the scenario layer that tests/test_scenarios.py does not reach without built
FMUs (docs/mutation.md)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import write_model_descriptions  # noqa: E402

from ballmill.scenario import spec  # noqa: E402
from ballmill.scenario.spec import ScenarioError  # noqa: E402

GOOD_EXPERIMENT = "[experiment]\nstart = 0.0\nstop = 1.0\nstep = 0.5\n"
DRIVE = '[instances.drive]\nfmu = "MotorStartup"\n'
BALL = '[instances.ball]\nfmu = "BallInShell"\n'


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    paths = write_model_descriptions(tmp_path_factory.mktemp("md"))
    return {name: read_model_description(str(p)) for name, p in paths.items()}


def problems_of(tmp_path, text, models, overrides=()):
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        spec.load(str(path), list(overrides), models)
    where = path.as_posix()
    assert all(p.startswith(where + ": ") or p.startswith("--set ") for p in info.value.problems)
    return [p[len(where) + 2:] if p.startswith(where) else p for p in info.value.problems]


def loaded(tmp_path, text, models):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return spec.load(str(path), [], models)


# -- experiment --------------------------------------------------------------------------
@pytest.mark.parametrize("experiment, expected", [
    ("stop = 1.0\nstep = 0.5", []),
    ("start = 0.0\nstep = 0.5", ["experiment.stop: expected a finite number of seconds, got None"]),
    ("start = true\nstop = 1.0\nstep = 0.5", ["experiment.start: expected a finite number of seconds, got True"]),
    ("start = 0.0\nstop = inf\nstep = 0.5", ["experiment.stop: expected a finite number of seconds, got inf"]),
    ("start = 0.0\nstop = 1.0\nstep = 'a'", ["experiment.step: expected a finite number of seconds, got 'a'"]),
    ("start = 1.0\nstop = 1.0\nstep = 0.5",
     ["experiment.stop: must be after experiment.start = 1.0, got 1.0",
      "experiment.step: must be in (0, stop - start = 0] s, got 0.5"]),
    ("start = 0.0\nstop = 1.0\nstep = 0.0", ["experiment.step: must be in (0, stop - start = 1] s, got 0.0"]),
    ("start = 0.0\nstop = 1.0\nstep = 1.0", []),
    ("start = 0.0\nstop = 1.0\nstep = 1.5", ["experiment.step: must be in (0, stop - start = 1] s, got 1.5"]),
])
def test_experiment_values(tmp_path, models, experiment, expected):
    text = f"[experiment]\n{experiment}\n" + DRIVE
    if expected:
        assert problems_of(tmp_path, text, models) == expected
    else:
        sc = loaded(tmp_path, text, models)
        assert (sc.start, sc.stop) == (0.0, 1.0) and sc.step in (0.5, 1.0)
        assert type(sc.start) is float


def test_instances_that_are_not_usable(tmp_path, models):
    text = GOOD_EXPERIMENT + """
[instances]
x = 3
[instances.both]
fmu = "MotorStartup"
table = "t.csv"
[instances.neither]
parameters = { l = 0.5 }
[instances.extra]
fmu = "MotorStartup"
foo = 1
bar = 2
"""
    assert problems_of(tmp_path, text, models) == [
        "instances.x: expected a table",
        'instances.both: needs exactly one of fmu = "Model" or table = "file.csv"',
        'instances.neither: needs exactly one of fmu = "Model" or table = "file.csv"',
        "instances.extra: unknown key(s) ['bar', 'foo']; expected fmu, table, parameters",
    ]


def test_no_instances(tmp_path, models):
    assert problems_of(tmp_path, GOOD_EXPERIMENT, models) == ["instances: a scenario needs at least one instance"]


def test_an_unknown_model(tmp_path, models):
    assert problems_of(tmp_path, GOOD_EXPERIMENT + '[instances.x]\nfmu = "Nope"\n', models) == [
        f"instances.x.fmu: unknown model 'Nope' (built models: {', '.join(sorted(models))})"]
    assert {"BallInShell", "MotorStartup"} <= set(models)


def test_parameter_types(tmp_path, models):
    text = GOOD_EXPERIMENT + DRIVE + "parameters = { l = 1, n0 = true, law = 2.0 }\n" + \
        BALL + "parameters = { formulation = 2, r = 'a' }\n"
    assert problems_of(tmp_path, text, models) == [
        "instances.drive.parameters.n0: expected a Real value, got True",
        "instances.drive.parameters.law: expected a Integer value, got 2.0",
        "instances.ball.parameters.r: expected a Real value, got 'a'",
    ]
    sc = loaded(tmp_path, GOOD_EXPERIMENT + DRIVE + "parameters = { l = 1, law = 2 }\n", models)
    assert sc.instances["drive"].parameters == {"l": 1, "law": 2}


def test_a_non_parameter_is_not_a_parameter(tmp_path, models):
    text = GOOD_EXPERIMENT + DRIVE + "parameters = { psi = 1.0, M_reaction = 0.0 }\n"
    got = problems_of(tmp_path, text, models)
    assert len(got) == 2
    assert got[0].startswith("instances.drive.parameters.psi: MotorStartup has no parameter 'psi' (parameters: l, ")
    assert got[1].startswith("instances.drive.parameters.M_reaction: MotorStartup has no parameter 'M_reaction'")


# -- connections ---------------------------------------------------------------------------
def test_connection_mistakes(tmp_path, models):
    text = 'connections = ["nobody.x -> ball.x1O", "drive.x1O -> ball.x1O", "drive.y1O -> ball.y1O", ' \
           '"drive.y1O -> ball.y1O", "ball.x1O -> drive.psi"]\n' + GOOD_EXPERIMENT + DRIVE + BALL
    outputs = ", ".join(v.name for v in models["BallInShell"].modelVariables if v.causality == "output")
    assert problems_of(tmp_path, text, models) == [
        "connections[0] (nobody.x -> ball.x1O): no instance 'nobody'",
        "connections[1] (drive.x1O -> ball.x1O): input ball.x1O is connected twice",
        "connections[3] (drive.y1O -> ball.y1O): input ball.y1O is connected twice",
        f"connections[4] (ball.x1O -> drive.psi): 'ball' has no output 'x1O' (outputs: {outputs})",
        "connections[4] (ball.x1O -> drive.psi): 'drive' has no input 'psi' (inputs: M_reaction)",
        "connections[4] (ball.x1O -> drive.psi): unit mismatch, m -> rad",
    ]


def test_connections_that_cannot_be_read(tmp_path, models):
    text = 'connections = ["drive.x1O -> ", "drive.x1O ball.x1O", "drive -> ball.x1O", ' \
           '"drive.x1O -> ball"]\n' + GOOD_EXPERIMENT + DRIVE + BALL
    assert problems_of(tmp_path, text, models) == [
        f"connections[{i}]: expected 'instance.output -> instance.input', got {t!r}"
        for i, t in enumerate(["drive.x1O -> ", "drive.x1O ball.x1O", "drive -> ball.x1O", "drive.x1O -> ball"])]


def test_units_must_match_and_a_unitless_side_matches_any(tmp_path, models):
    text = 'connections = ["drive.psi -> ball.x1O", "drive.T_drive -> ball.vx1O"]\n' + GOOD_EXPERIMENT + DRIVE + BALL
    assert problems_of(tmp_path, text, models) == [
        "connections[0] (drive.psi -> ball.x1O): unit mismatch, rad -> m",
        "connections[1] (drive.T_drive -> ball.vx1O): unit mismatch, N.m -> m/s",
    ]


# -- record and plots ----------------------------------------------------------------------
def test_record_and_plot_mistakes(tmp_path, models):
    text = GOOD_EXPERIMENT + DRIVE + """
[record]
variables = ["novar", "drive.nothing", "drive.psi"]

[[plots]]
y = ["drive.psi", "drive.T_drive"]
file = "a.png"

[[plots]]
x = "drive.x1O"
y = ["drive.psi"]
"""
    assert problems_of(tmp_path, text, models) == [
        "record.variables[0]: expected 'instance.variable', got 'novar'",
        "record.variables[1]: no variable drive.nothing",  # its index in the file
        "plots[0]: 'drive.T_drive' is not recorded",
        "plots[1]: 'drive.x1O' is not recorded",
        "plots[1].file: expected a PNG file name",
    ]


def test_without_a_record_every_output_is_recorded(tmp_path, models):
    sc = loaded(tmp_path, GOOD_EXPERIMENT + DRIVE + BALL, models)
    want = [(inst, v.name) for inst, model in (("drive", "MotorStartup"), ("ball", "BallInShell"))
            for v in models[model].modelVariables if v.causality == "output"]
    assert sc.record == want
    sc = loaded(tmp_path, GOOD_EXPERIMENT + DRIVE + '[record]\nvariables = ["drive.psi"]\n', models)
    assert sc.record == [("drive", "psi")]


# -- table sources ---------------------------------------------------------------------------
def table_scenario(tmp_path, csv_text, name="t.csv"):
    (tmp_path / name).write_text(csv_text)
    return GOOD_EXPERIMENT + BALL + f'[instances.ground]\ntable = "{name}"\n' + \
        'connections = ["ground.ax -> ball.ax1O"]\n'


def test_a_table_source_is_read(tmp_path, models):
    text = GOOD_EXPERIMENT + BALL + '[instances.ground]\ntable = "t.csv"\n'
    text = 'connections = ["ground.ax -> ball.ax1O"]\n' + text
    (tmp_path / "t.csv").write_text("time, ax ,ay\n0.0,1.0,2.0\n0.5,3.0,4.0\n")
    sc = loaded(tmp_path, text, models)
    g = sc.instances["ground"]
    assert g.fmu is None and g.table == (tmp_path / "t.csv").resolve()
    assert g.columns == ["ax", "ay"]
    assert np.array_equal(g.data, [[0.0, 1.0, 2.0], [0.5, 3.0, 4.0]])
    assert ("ground", "ax") in sc.record and ("ground", "ay") in sc.record
    assert sc.connections == [("ground", "ax", "ball", "ax1O")]


@pytest.mark.parametrize("csv_text, expected", [
    (None, "no such file"),
    ("time,ax\n0.0,a\n", "t.csv: not a numeric CSV with one header line: "),
    ("t,ax\n0.0,1.0\n", "t.csv: expected a header 'time,signal,...' matching the columns, got ['t', 'ax']"),
    ("time,ax,ay\n0.0,1.0\n", "expected a header 'time,signal,...' matching the columns, got ['time', 'ax', 'ay']"),
    ("time\n0.0\n", "expected a header 'time,signal,...' matching the columns, got ['time']"),
    ("time,ax\n0.0,1.0\n0.5,nan\n0.7,1.0\n", "t.csv: non-finite value on line 3"),
    ("time,ax\n0.0,inf\n", "t.csv: non-finite value on line 2"),
    ("time,ax\n0.0,1.0\n0.0,1.0\n", "t.csv: the time column must increase strictly"),
    ("time,ax\n0.5,1.0\n0.0,1.0\n", "t.csv: the time column must increase strictly"),
])
def test_table_mistakes(tmp_path, models, csv_text, expected):
    text = GOOD_EXPERIMENT + BALL + '[instances.ground]\ntable = "t.csv"\n' + \
        '[record]\nvariables = ["ground.ax"]\n'
    text = 'connections = ["ground.ax -> ball.ax1O"]\n' + text
    if csv_text is not None:
        (tmp_path / "t.csv").write_text(csv_text)
    got = problems_of(tmp_path, text, models)
    assert len(got) == 1, got  # the broken table's connection and record are not reported again
    assert got[0].startswith("instances.ground.table: ") and expected in got[0], got


# -- files -----------------------------------------------------------------------------------
def test_a_scenario_by_name_path_or_unknown(tmp_path):
    assert spec.resolve("fast_start") == spec.SCENARIO_DIR / "fast_start.toml"
    assert spec.resolve("fast_start.toml") == spec.SCENARIO_DIR / "fast_start.toml"
    p = tmp_path / "mine.toml"
    p.write_text("")
    assert spec.resolve(str(p)) == p and spec.resolve(str(tmp_path / "mine")) == p
    with pytest.raises(ScenarioError) as info:
        spec.resolve("no_such_scenario")
    known = ", ".join(sorted(q.stem for q in spec.SCENARIO_DIR.glob("*.toml")))
    assert info.value.problems == [f"no_such_scenario: no such scenario file (scenarios here: {known})"]


def test_not_toml(tmp_path, models):
    got = problems_of(tmp_path, "this is = = not toml", models)
    assert len(got) == 1 and got[0].startswith("not valid TOML: ")


def test_every_shipped_scenario_loads(models):
    for path in sorted(spec.SCENARIO_DIR.glob("*.toml")):
        sc = spec.load(str(path), [], models)
        assert sc.name == path.stem and sc.path == path and sc.description
