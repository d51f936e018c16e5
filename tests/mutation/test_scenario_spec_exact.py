"""Scenario files (ballmill.scenario.spec), the checks tests/mutation/test_scenario_checks.py
leaves open, word for word: the error's text, a scenario found by a relative name, --set
overrides, dotted variable names, the [master] section, the description, the checks of
parameters (String, Boolean, on a table), of connections and records called without the
file's indices, of the default record's types, and of plots (kinds, the ball of a shell or
slip_margin plot, what they need recorded, their file). Against small hand-written model
descriptions (only name, causality, type and unit are read), so each test is a few ms.
"""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballmill.scenario import spec
from ballmill.scenario.spec import ScenarioError

EXPERIMENT = "[experiment]\nstart = 0.0\nstop = 1.0\nstep = 0.5\n"
DRIVE = '[instances.drive]\nfmu = "MotorStartup"\n'
BALL = '[instances.b]\nfmu = "BallInShell"\n'


def _var(name, causality, type_="Real", unit=None):
    return SimpleNamespace(name=name, causality=causality, type=type_, unit=unit, start=None, min=None, max=None,
                           variability="fixed" if causality == "parameter" else "continuous")


def _models():
    ball = [_var("x1O", "input", unit="m"), _var("ax1O", "input", unit="m/s2"),
            _var("r", "parameter", unit="m"), _var("formulation", "parameter", "Integer"),
            _var("label", "parameter", "String"), _var("flag", "parameter", "Boolean"),
            _var("xP_ch", "output", unit="m"), _var("yP_ch", "output", unit="m"),
            _var("zP_ch", "output", unit="m"), _var("N", "output", unit="N"), _var("Ft", "output", unit="N"),
            _var("friction_ratio", "output"), _var("count", "output", "Integer"),
            _var("valid", "output", "Boolean"), _var("tag", "output", "String")]
    drive = [_var("t0", "parameter", unit="s"), _var("x1O", "output", unit="m"),
             _var("psi", "output", unit="rad"), _var("M_reaction", "input", unit="N.m")]
    return {"BallInShell": SimpleNamespace(modelVariables=ball),
            "MotorStartup": SimpleNamespace(modelVariables=drive)}


def _write(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def _problems(tmp_path, text, overrides=(), models="fake"):
    path = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        spec.load(str(path), list(overrides), _models() if models == "fake" else models)
    where = path.as_posix() + ": "
    return [p[len(where):] if p.startswith(where) else p for p in info.value.problems]


def _loaded(tmp_path, text, models="fake"):
    return spec.load(str(_write(tmp_path, text)), [], _models() if models == "fake" else models)


# -- the error and finding the file ---------------------------------------------------------
def test_the_error_lists_every_problem():
    e = ScenarioError(["a.toml: x: bad", "a.toml: y: worse"])
    assert e.problems == ["a.toml: x: bad", "a.toml: y: worse"]
    assert str(e) == "2 problem(s) in the scenario:\n  - a.toml: x: bad\n  - a.toml: y: worse"
    assert isinstance(e, ValueError)


def test_a_relative_name_without_toml(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.toml").write_text("")
    assert spec.resolve("mine") == spec.Path("mine.toml")
    assert spec.resolve("mine.toml") == spec.Path("mine.toml")


# -- --set ------------------------------------------------------------------------------------
@pytest.mark.parametrize("text, expected", [
    ("drive.t0=30", ("drive", "t0", 30)),
    (" drive.t0 = 2.5 ", ("drive", "t0", 2.5)),
    ("b.flag=true", ("b", "flag", True)),
    ("b.label=abc", ("b", "label", "abc")),  # not TOML: the text itself
    ('b.label="x=1.5"', ("b", "label", "x=1.5")),
    ("b.r.x=1", ("b", "r.x", 1)),  # the instance ends at the first dot
])
def test_an_override_is_read(text, expected):
    got = spec.parse_override(text)
    assert got == expected and type(got[2]) is type(expected[2])


@pytest.mark.parametrize("text", ["t0=1.5", "t0=a.b=c", "drive.t0", "t0", "=drive.t0"])
def test_an_override_without_instance_dot_parameter(text):
    with pytest.raises(ScenarioError) as info:
        spec.parse_override(text)
    assert info.value.problems == [f"--set {text!r}: expected instance.parameter=value, e.g. drive.t0=30"]


def test_every_bad_override_is_reported_with_the_files_problems(tmp_path):
    got = _problems(tmp_path, "[experiment]\nstop = 1.0\n" + DRIVE,
                    overrides=["t0=1", "nobody.x=1", "drive", "drive.t0=2"])
    assert got == ["experiment.step: expected a finite number of seconds, got None",
                   "--set 't0=1': expected instance.parameter=value, e.g. drive.t0=30",
                   "--set nobody.x=1: no instance 'nobody' (instances: drive)",
                   "--set 'drive': expected instance.parameter=value, e.g. drive.t0=30"]


def test_an_override_sets_the_parameter(tmp_path):
    path = _write(tmp_path, EXPERIMENT + DRIVE + "parameters = { t0 = 1.0 }\n")
    sc = spec.load(str(path), ["drive.t0=2.5"], _models())
    assert sc.instances["drive"].parameters == {"t0": 2.5}


# -- the file's sections ---------------------------------------------------------------------
def test_a_scenario_without_experiment(tmp_path):
    assert _problems(tmp_path, DRIVE) == ["experiment.stop: expected a finite number of seconds, got None",
                                          "experiment.step: expected a finite number of seconds, got None"]


def test_dotted_variable_names_keep_everything_after_the_first_dot(tmp_path):
    text = 'connections = ["a.b.c -> d.e.f"]\n[record]\nvariables = ["a.b.c", "d.e"]\n' + EXPERIMENT + \
        '[instances.a]\nfmu = "X"\n[instances.d]\nfmu = "Y"\n'
    sc = _loaded(tmp_path, text, models=None)
    assert sc.connections == [("a", "b.c", "d", "e.f")]
    assert sc.record == [("a", "b.c"), ("d", "e")]


def test_the_description(tmp_path):
    assert _loaded(tmp_path, 'description = "Fast start"\n' + EXPERIMENT + DRIVE).description == "Fast start"
    assert _loaded(tmp_path, EXPERIMENT + DRIVE).description == ""


@pytest.mark.parametrize("value, seconds", [(2, 2.0), (2.5, 2.5), ("a", 0.0), (True, 0.0), (None, 0.0)])
def test_a_bad_experiment_time_reads_as_zero(value, seconds):
    got = spec._seconds(value)
    assert got == seconds and type(got) is float


# -- [master] --------------------------------------------------------------------------------
def test_master_defaults_and_values(tmp_path):
    assert _loaded(tmp_path, EXPERIMENT + DRIVE).master == {
        "algebraic_loops": "iterate", "loop_tol": 1e-10, "loop_atol": 1e-14, "loop_max_iter": 50,
        "solver": "DOP853", "rtol": 1e-10, "atol": 1e-10}
    sc = _loaded(tmp_path, EXPERIMENT + DRIVE + "[master]\nalgebraic_loops = 'ignore'\nloop_tol = 0\n"
                 "loop_atol = 0.0\nloop_max_iter = 1\n")
    assert sc.master == {"algebraic_loops": "ignore", "loop_tol": 0, "loop_atol": 0.0, "loop_max_iter": 1, "solver": "DOP853", "rtol": 1e-10, "atol": 1e-10}
    sc = _loaded(tmp_path, EXPERIMENT + DRIVE + "[master]\nalgebraic_loops = 'iterate'\nloop_tol = 1\n"
                 "loop_atol = 1e-3\nloop_max_iter = 7\nsolver = 'BDF'\nrtol = 1e-6\natol = 1\n")
    assert sc.master == {"algebraic_loops": "iterate", "loop_tol": 1, "loop_atol": 1e-3, "loop_max_iter": 7,
                         "solver": "BDF", "rtol": 1e-6, "atol": 1}


@pytest.mark.parametrize("line, expected", [
    ("foo = 1", "master.foo: unknown key; expected one of ['algebraic_loops', 'atol', 'loop_atol', 'loop_max_iter', "
                "'loop_tol', 'rtol', 'solver']"),
    ("solver = 'CVode'", "master.solver: expected one of ['DOP853', 'RK45', 'Radau', 'BDF', 'LSODA'], got 'CVode'"),
    ("rtol = 0", "master.rtol: expected a finite number > 0, got 0"),
    ("atol = -1e-9", "master.atol: expected a finite number > 0, got -1e-09"),
    ("rtol = nan", "master.rtol: expected a finite number > 0, got nan"),
    ("atol = true", "master.atol: expected a finite number > 0, got True"),
    ("algebraic_loops = 'solve'", "master.algebraic_loops: expected one of ['iterate', 'ignore'], got 'solve'"),
    ("algebraic_loops = 1", "master.algebraic_loops: expected one of ['iterate', 'ignore'], got 1"),
    ("loop_max_iter = 0", "master.loop_max_iter: expected an integer >= 1, got 0"),
    ("loop_max_iter = -3", "master.loop_max_iter: expected an integer >= 1, got -3"),
    ("loop_max_iter = true", "master.loop_max_iter: expected an integer >= 1, got True"),
    ("loop_max_iter = 2.0", "master.loop_max_iter: expected an integer >= 1, got 2.0"),
    ("loop_tol = -1", "master.loop_tol: expected a finite number >= 0, got -1"),
    ("loop_tol = inf", "master.loop_tol: expected a finite number >= 0, got inf"),
    ("loop_tol = nan", "master.loop_tol: expected a finite number >= 0, got nan"),
    ("loop_tol = true", "master.loop_tol: expected a finite number >= 0, got True"),
    ("loop_atol = -1e-3", "master.loop_atol: expected a finite number >= 0, got -0.001"),
    ("loop_atol = inf", "master.loop_atol: expected a finite number >= 0, got inf"),
    ("loop_atol = true", "master.loop_atol: expected a finite number >= 0, got True"),
    ("loop_atol = 'a'", "master.loop_atol: expected a finite number >= 0, got 'a'"),
])
def test_master_mistakes(tmp_path, line, expected):
    assert _problems(tmp_path, EXPERIMENT + DRIVE + f"[master]\n{line}\n") == [expected]


# -- parameters ------------------------------------------------------------------------------
def test_parameters_after_an_unusable_instance_and_on_a_table(tmp_path):
    (tmp_path / "t.csv").write_text("time,ax\n0.0,1.0\n1.0,2.0\n")
    text = EXPERIMENT + "[instances.a]\nparameters = { t0 = 1.0 }\n" + DRIVE + "parameters = { nope = 1.0 }\n" + \
        '[instances.ground]\ntable = "t.csv"\nparameters = { gain = 2.0 }\n'
    assert _problems(tmp_path, text) == [
        'instances.a: needs exactly one of fmu = "Model" or table = "file.csv"',
        "instances.drive.parameters.nope: MotorStartup has no parameter 'nope' (parameters: t0)",
        "instances.ground.parameters.gain: a table has no parameter 'gain' (parameters: )",
    ]


def test_string_and_boolean_parameters(tmp_path):
    sc = _loaded(tmp_path, EXPERIMENT + BALL + "parameters = { label = 'x', flag = false, formulation = 2, r = 1 }\n")
    assert sc.instances["b"].parameters == {"label": "x", "flag": False, "formulation": 2, "r": 1}
    assert _problems(tmp_path, EXPERIMENT + BALL + "parameters = { label = 1, flag = 0 }\n") == [
        "instances.b.parameters.label: expected a String value, got 1",
        "instances.b.parameters.flag: expected a Boolean value, got 0",
    ]


# -- connections and records -----------------------------------------------------------------
def test_a_connection_from_an_unusable_instance_still_checks_its_input(tmp_path):
    text = 'connections = ["a.x -> b.nothing", "drive.x1O -> b.x1O"]\n' + EXPERIMENT + \
        "[instances.a]\n" + 'parameters = {}\n' + DRIVE + BALL
    assert _problems(tmp_path, text) == [
        'instances.a: needs exactly one of fmu = "Model" or table = "file.csv"',
        "connections[0] (a.x -> b.nothing): 'b' has no input 'nothing' (inputs: x1O, ax1O)",
    ]


def test_check_without_the_files_indices_numbers_the_entries(tmp_path):
    sc = _loaded(tmp_path, EXPERIMENT + DRIVE + BALL + '[record]\nvariables = ["b.N"]\n')
    sc.connections = [("drive", "x1O", "b", "x1O"), ("drive", "x1O", "b", "nothing")]
    sc.record = [("b", "N"), ("b", "nothing")]
    where = sc.path.as_posix()
    assert spec.check(sc, _models(), False) == [
        f"{where}: connections[1] (drive.x1O -> b.nothing): 'b' has no input 'nothing' (inputs: x1O, ax1O)",
        f"{where}: record.variables[1]: no variable b.nothing",
    ]


def test_the_default_record_is_every_real_integer_and_boolean_output(tmp_path):
    sc = _loaded(tmp_path, EXPERIMENT + DRIVE + BALL)
    assert sc.record == [("drive", "x1O"), ("drive", "psi"),
                         ("b", "xP_ch"), ("b", "yP_ch"), ("b", "zP_ch"), ("b", "N"), ("b", "Ft"),
                         ("b", "friction_ratio"), ("b", "count"), ("b", "valid")]


# -- plots -----------------------------------------------------------------------------------
NEEDS = "(BallInShell with motion = 2 has them)"


@pytest.mark.parametrize("instances, plots, expected", [
    # kinds: an unknown kind is reported and the next plot is still checked
    (DRIVE, [{"kind": "bogus"}, {"y": ["drive.nothing"], "file": "a.png"}],
     ["plots[0].kind: expected one of series, shell, slip_margin, got 'bogus'",
      "plots[1]: 'drive.nothing' is not recorded"]),
    # a series plot without y draws nothing but is fine; x defaults to time
    (DRIVE, [{"file": "a.png"}, {"x": "drive.psi", "y": ["drive.x1O"], "file": "b.png"}], []),
    # the ball by default: the first BallInShell instance, not the first instance
    (DRIVE + BALL, [{"kind": "shell", "file": "s.png"}, {"kind": "slip_margin", "file": "m.png"}], []),
    # a ball named explicitly must be a BallInShell (FMU) instance
    (DRIVE + BALL, [{"kind": "shell", "ball": "nope", "file": "s.png"}, {"kind": "shell", "file": "t.png"},
                    {"kind": "slip_margin", "ball": "ground", "file": "m.png"}, {"y": ["b.none"], "file": "a.png"}],
     ["plots[0].ball: a shell plot needs a BallInShell instance, got 'nope'",
      "plots[2].ball: a slip_margin plot needs a BallInShell instance, got 'ground'",
      "plots[3]: 'b.none' is not recorded"]),
    # without any BallInShell
    (DRIVE, [{"kind": "slip_margin", "file": "m.png"}],
     ["plots[0].ball: a slip_margin plot needs a BallInShell instance, got None"]),
    # what a shell or slip_margin plot needs recorded, and its file
    (DRIVE + BALL + '[record]\nvariables = ["b.N", "b.zP_ch"]\n',
     [{"kind": "shell", "file": "s.png"}, {"kind": "slip_margin"}, {"y": ["b.Ft"], "file": "a.png"}],
     [f"plots[0]: a shell plot needs b.xP_ch, b.yP_ch, b.Ft recorded {NEEDS}",
      f"plots[1]: a slip_margin plot needs b.friction_ratio, b.Ft recorded {NEEDS}",
      "plots[1].file: expected a PNG file name",
      "plots[2]: 'b.Ft' is not recorded"]),
    # a series plot of an unusable instance's variables is not reported again
    (DRIVE + "[instances.a]\nparameters = {}\n", [{"y": ["a.x", "a.x.y", "drive.nothing"], "file": "a.png"}],
     ['instances.a: needs exactly one of fmu = "Model" or table = "file.csv"',
      "plots[0]: 'drive.nothing' is not recorded"]),
])
def test_plots(tmp_path, instances, plots, expected):
    (tmp_path / "t.csv").write_text("time,ax\n0.0,1.0\n1.0,2.0\n")
    text = EXPERIMENT + instances + '[instances.ground]\ntable = "t.csv"\n'
    for plot in plots:
        text += "[[plots]]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in plot.items())
    if expected:
        assert _problems(tmp_path, text) == expected
    else:
        assert len(_loaded(tmp_path, text).plots) == len(plots)
