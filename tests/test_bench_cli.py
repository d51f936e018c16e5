"""`ballmill bench --section NAME`: every section the help offers runs its own module's
run_section (and only that one), with the arguments its signature asks for."""
import importlib

import pytest

from ballmill import bench


@pytest.mark.parametrize("name", list(bench.SECTIONS))
def test_each_section_runs_its_module_and_no_other(name, tmp_path, monkeypatch):
    called = []
    for other, (module, _, _) in bench.SECTIONS.items():
        m = importlib.import_module(f"ballmill.bench.{module}")
        monkeypatch.setattr(m, "run_section", lambda *a, _n=other, **k: called.append((_n, a)))
    out = tmp_path / "B.md"
    assert bench.main(["--section", name, "--out", str(out), "--quick"]) == 0
    assert [n for n, _ in called] == [name]
    assert called[0][1][0] == out.resolve()  # every section splices into the report it was given


def test_an_unknown_section_is_refused_with_the_choices(capsys):
    with pytest.raises(SystemExit) as e:
        bench.main(["--section", "nope"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "'nope'" in err and all(name in err for name in bench.SECTIONS)
