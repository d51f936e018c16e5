"""The C mutation runner's --since: only the mutants of lines changed since a revision; and its
refusal of a results file drawn on other C (tests/mutation/c/run.py, docs/mutation.md "The C")."""
import importlib.util
import json
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


def test_a_results_file_drawn_on_other_c_is_refused_before_any_build(run, tmp_path, monkeypatch):
    """A mutant's number counts the file's mutants as the file is now: after a change above it
    the same id can name another change. A run whose results file records one of the mutants it
    would judge with another change stops before the scratch copy is built, naming the id, both
    changes and what to do; an id its files do not have is named too. A recorded change whose
    line only moved is the same mutant: that run goes on to build."""
    here = [dict(id="m.c:7", file="m.c", line=4, before="  x = a[i];", after="  x = a[i + 1];", path=""),
            dict(id="m.c:9", file="m.c", line=5, before="  s += x;", after="  /*s += x;*/", path="")]

    class Built(Exception):
        pass

    def setup(self, files):
        raise Built

    monkeypatch.setattr(run, "stratified", lambda files, gen, seed: [dict(m) for m in here])
    monkeypatch.setattr(run.shutil, "which", lambda name: "/bin/true")
    monkeypatch.setattr(run.Scratch, "setup", setup)
    results = tmp_path / "r.jsonl"
    moved = dict({k: here[1][k] for k in ("id", "file", "before", "after")}, line=3, verdict="survived")
    other = dict(id="m.c:7", file="m.c", line=3, before="  s = 0;", after="  s = 1;", verdict="killed")
    results.write_text(json.dumps(moved) + "\n" + json.dumps(other) + "\n")
    assert run.drawn_elsewhere(here, run.load_results(results)) == [
        "m.c:7 is recorded as 's = 1;' (line 3), here 'x = a[i + 1];' (line 4)"]

    def main(*ids):
        run.main(["--ids", *ids, "--results", str(results), "--scratch", str(tmp_path / "s")])

    with pytest.raises(SystemExit, match=r"--ids: no mutant m\.c:8 among"):
        main("m.c:8", "m.c:9")
    with pytest.raises(SystemExit, match=r"r\.jsonl was drawn on other C than this checkout's: 1 of the mutants "
                                         r"this run would judge or skip name other changes here \(m\.c:7 is "
                                         r"recorded as 's = 1;' \(line 3\), here 'x = a\[i \+ 1\];' \(line 4\)\)"):
        main("m.c:7", "m.c:9")
    with pytest.raises(Built):
        main("m.c:9")
