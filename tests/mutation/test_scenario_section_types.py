"""A scenario section of the wrong TOML type is a reported problem with its key, not a
traceback (before: `master = 3`, `experiment = 3`, `record = 3`, `plots = [3]`, `summary = "x"`,
a plot's `x = 3` or an instance's `parameters = 3` raised AttributeError/TypeError/ValueError
out of `load`), nor read letter by letter (`connections = "a.x -> b.y"`, `record.variables =
"b.zP"`, a plot's `y = "b.zP"`); an instance name with a '.' cannot be connected or recorded
and is refused."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballmill.scenario import spec

EXPERIMENT = "[experiment]\nstop = 1.0\nstep = 0.5\n"
DRIVE = '[instances.drive]\nfmu = "MotorStartup"\n'


def _models():
    v = SimpleNamespace(name="psi", causality="output", type="Real", unit="rad")
    return {"MotorStartup": SimpleNamespace(modelVariables=[v])}


@pytest.mark.parametrize("top, tail, expected", [
    ("experiment = 3\n", DRIVE, ["experiment: expected a table, got 3"]),
    ("master = 3\n", EXPERIMENT + DRIVE, ["master: expected a table, got 3"]),
    ("record = 3\n", EXPERIMENT + DRIVE, ["record: expected a table, got 3"]),
    ("summary = 'x'\n", EXPERIMENT + DRIVE, ["summary: expected a table, got 'x'"]),
    ("connections = 'drive.psi -> drive.psi'\n", EXPERIMENT + DRIVE,
     ["connections: expected an array, got 'drive.psi -> drive.psi'"]),
    ("plots = 3\n", EXPERIMENT + DRIVE, ["plots: expected an array, got 3"]),
    ("plots = [3, {y = ['drive.nope'], file = 'a.png'}]\n", EXPERIMENT + DRIVE,
     ["plots[0]: expected a table, got 3", "plots[1]: 'drive.nope' is not recorded"]),
    ("plots = [3, {x = 5, file = 'a.png'}]\n", EXPERIMENT + DRIVE,  # the next plot is read on
     ["plots[0]: expected a table, got 3", "plots[1].x: expected a variable name, got 5"]),
    ("instances = 3\n", EXPERIMENT, ["instances: expected a table, got 3"]),
    ("", EXPERIMENT + DRIVE + "parameters = 3\n", ["instances.drive.parameters: expected a table of "
                                                   "parameter = value, got 3"]),
    ("", EXPERIMENT + DRIVE + "[record]\nvariables = 'drive.psi'\n",
     ["record.variables: expected an array of 'instance.variable', got 'drive.psi'"]),
    ("", EXPERIMENT + DRIVE + "[[plots]]\ny = 'drive.psi'\nfile = 'a.png'\n",
     ["plots[0].y: expected an array of variable names, got 'drive.psi'"]),
    ("", EXPERIMENT + DRIVE + "[[plots]]\nx = 3\ny = ['drive.psi', 2]\nfile = 'a.png'\n",
     ["plots[0].x: expected a variable name, got 3", "plots[0].y: expected an array of variable names, "
                                                     "got ['drive.psi', 2]"]),
    ("", EXPERIMENT + '[instances."dr.ive"]\nfmu = "MotorStartup"\n',
     ["instances.dr.ive: an instance name cannot contain '.' (connections and records split at the first '.')"]),
])
def test_a_section_of_the_wrong_type_is_reported(tmp_path, top, tail, expected):
    path = tmp_path / "s.toml"
    path.write_text(top + tail)
    for models in (_models(), None):  # with and without the model descriptions
        with pytest.raises(spec.ScenarioError) as info:
            spec.load(str(path), [], models)
        where = path.as_posix() + ": "
        got = [p[len(where):] for p in info.value.problems]
        want = expected if models is not None else [e for e in expected if "is not recorded" not in e]
        assert got == want
