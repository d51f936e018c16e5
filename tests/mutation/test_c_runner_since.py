"""The C mutation runner's --since: only the mutants of lines changed since a revision
(tests/mutation/c/run.py, docs/mutation.md "The C")."""
import importlib.util
import subprocess
from pathlib import Path

import pytest

RUN = Path(__file__).resolve().parent / "c" / "run.py"


@pytest.fixture(scope="module")
def run():
    spec = importlib.util.spec_from_file_location("cmut_run", RUN)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def git(repo, *args):
    return subprocess.run(["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                          check=True, capture_output=True, text=True).stdout.strip()


def test_changed_lines_are_the_new_side_of_each_hunk(run, tmp_path):
    git(tmp_path, "init", "-q")
    old = [f"int a{i} = {i};" for i in range(1, 11)]
    (tmp_path / "m.c").write_text("\n".join(old) + "\n")
    (tmp_path / "gone.c").write_text("int g;\n")
    git(tmp_path, "add", ".")
    git(tmp_path, "commit", "-q", "-m", "one")
    base = git(tmp_path, "rev-parse", "HEAD")
    new = list(old)
    new[1] = "int a2 = 20;"              # line 2 rewritten
    del new[4]                           # old line 5 deleted: nothing to mutate there
    new[6:6] = ["int b1;", "int b2;"]    # two lines added after old line 7: new lines 7 and 8
    (tmp_path / "m.c").write_text("\n".join(new) + "\n")
    (tmp_path / "n.h").write_text("int n1;\nint n2;\nint n3;\n")  # a new file counts in full
    git(tmp_path, "add", ".")
    git(tmp_path, "commit", "-q", "-m", "two")
    assert run.changed_lines("m.c", base, root=tmp_path) == {2, 7, 8}
    assert run.changed_lines("n.h", base, root=tmp_path) == {1, 2, 3}
    assert run.changed_lines("gone.c", base, root=tmp_path) == set()
    with pytest.raises(SystemExit, match="nosuchrev"):
        run.changed_lines("m.c", "nosuchrev", root=tmp_path)
