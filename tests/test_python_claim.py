"""The Python version the project claims is the one it runs on: pyproject.toml's
requires-python, the README's promise and the standard library the code imports agree."""
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def claimed_minimum() -> tuple[int, int]:
    spec = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["requires-python"]
    m = re.fullmatch(r">=\s*(\d+)\.(\d+)", spec.strip())
    assert m, f"requires-python {spec!r} is not a plain lower bound"
    return int(m[1]), int(m[2])


def test_requires_python_is_what_the_code_needs():
    # ballmill.scenario.spec imports tomllib, new in 3.11: no claim below it
    assert claimed_minimum() >= (3, 11)
    assert sys.version_info[:2] >= claimed_minimum()
    src = (ROOT / "ballmill" / "scenario" / "spec.py").read_text()
    assert "import tomllib" in src  # if this goes (tomli fallback), the claim may go down, proven on 3.10


def test_readme_promises_the_same_version():
    major, minor = claimed_minimum()
    readme = (ROOT / "README.md").read_text()
    promises = set(re.findall(r"Python ≥ (\d+\.\d+)", readme))
    assert promises == {f"{major}.{minor}"}, promises
