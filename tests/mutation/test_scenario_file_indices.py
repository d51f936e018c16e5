"""A scenario problem names the file's entry: after an unreadable connection or recorded
variable (reported itself), the problems of the entries that follow still carry their index
in the file (before: their index among the readable ones, so "connections[0]" named the
file's third entry). Against the native model descriptions (tests/mutation/native_fmus.py)."""
from __future__ import annotations

import pytest

from ballmill.scenario import spec

EXPERIMENT = "[experiment]\nstart = 0.0\nstop = 1.0\nstep = 0.5\n"
INSTANCES = '[instances.drive]\nfmu = "MotorStartup"\n[instances.ball]\nfmu = "BallInShell"\n'


def _problems(tmp_path, text, models):
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(spec.ScenarioError) as info:
        spec.load(str(path), [], models)
    where = path.as_posix() + ": "
    assert all(p.startswith(where) for p in info.value.problems)
    return [p[len(where):] for p in info.value.problems]


def test_connection_problems_carry_their_index_in_the_file(tmp_path, native_models):
    text = ('connections = ["drive.x1O ball.x1O", "drive -> ball.y1O", "drive.psi -> ball.x1O", '
            '"drive.x1O -> ball.nothing"]\n' + EXPERIMENT + INSTANCES)
    inputs = ", ".join(v.name for v in native_models["BallInShell"].modelVariables if v.causality == "input")
    assert _problems(tmp_path, text, native_models) == [
        "connections[0]: expected 'instance.output -> instance.input', got 'drive.x1O ball.x1O'",
        "connections[1]: expected 'instance.output -> instance.input', got 'drive -> ball.y1O'",
        "connections[2] (drive.psi -> ball.x1O): unit mismatch, rad -> m",
        f"connections[3] (drive.x1O -> ball.nothing): 'ball' has no input 'nothing' (inputs: {inputs})",
    ]


def test_record_problems_carry_their_index_in_the_file(tmp_path, native_models):
    text = EXPERIMENT + INSTANCES + '[record]\nvariables = ["zP", "ball.zP", "ball.nothing", "nodot", "drive.none"]\n'
    assert _problems(tmp_path, text, native_models) == [
        "record.variables[0]: expected 'instance.variable', got 'zP'",
        "record.variables[3]: expected 'instance.variable', got 'nodot'",
        "record.variables[2]: no variable ball.nothing",
        "record.variables[4]: no variable drive.none",
    ]
