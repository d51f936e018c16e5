"""The FMU flavours the conformance suite runs over (docs/conformance.md).

`flavours()` is the one place that says which builds of the models exist.
``pythonfmu`` (<build>/pythonfmu/<Model>.fmu), ``native`` (the C FMUs, FMI 2.0,
<build>/<Model>.fmu) and ``native3`` (the same C FMUs as FMI 3.0 archives,
<build>/fmi3/<Model>.fmu), all in the session's one build (tests/conftest.py's
``fmu_build_dir``: every FMU built once into a temporary folder, or the folder
BALLMILL_TEST_FMU_DIR names, as the C mutation runner tests/mutation/c/run.py does); never the
repository's build/ folder, which a concurrent `ballmill build` or a second pytest process
could be rewriting.

A flavour also says which FMI status its refusals carry: the specification asks
for fmi2Error; pythonfmu 0.7.0 can only return fmi2Fatal from a refused call
other than fmi2DoStep (a Python exception) and fmi2Discard from a refused
fmi2DoStep (docs/OTHER_TOOLS.md), and the tests assert exactly that. After
pythonfmu's fmi2Fatal the instance is gone (pythonfmu releases its Python object
while reporting the exception; any later call on it, fmi2FreeInstance included,
touches freed memory), so a flavour also says whether an instance stays usable
after a refused call: the tests then check that it kept its state.

A flavour's FMI version decides the driver (harness.Fmu or harness.Fmu3: `Flavour.open`)
and the function and state names its messages use (`Flavour.fn`); the statuses are
numbered alike in both versions (OK 0 .. Fatal 4).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pytest
# the host's pythonfmu (with its binaries) before any FMU puts its resources folder, which
# bundles pythonfmu's runtime without binaries, on sys.path: later builds need the former
import pythonfmu.builder  # noqa: F401

ROOT = Path(__file__).resolve().parents[2]
OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
MODELS = ("BallInShell", "MotorStartup", "InductionMotor", "Fig1Drive", "Structure")


@dataclass(frozen=True)
class Flavour:
    name: str
    paths: Callable[[Path], dict]  # the session's build folder -> {model name: FMU path}
    refusal: int  # status of a refused call other than doStep (spec: ERROR)
    step_refusal: int  # status of a doStep refused for its arguments or phase (spec: ERROR)
    usable_after_refusal: bool  # the instance keeps its state after a refused call (spec: True)
    fmi: int = 2  # the FMI version of the archives (2 or 3)

    def __str__(self):
        return self.name

    def open(self, path, name, **parameters):
        """a co-simulation instance of the FMU at `path`, driven through this flavour's FMI version"""
        from .harness import driver

        return driver(self.fmi)(path, name, **parameters)

    def fn(self, name: str) -> str:
        """an FMI function's name ("Terminate") or a state's ("terminated") as this flavour's
        messages write it"""
        from .harness import fmi_name

        return fmi_name(self.fmi, name)


def _paths(flavour: str, build_dir: Path) -> dict:
    from ballmill.fmi.build import fmu_path

    return {name: fmu_path(name, build_dir, flavour) for name in MODELS}


def fmi3_paths(paths: dict) -> dict:
    """the FMI 3.0 archives `ballmill build` writes beside the native FMI 2.0 ones (fmi3/)"""
    return {name: path.parent / "fmi3" / path.name for name, path in paths.items()}


def _pythonfmu_paths(build_dir: Path) -> dict:
    return _paths("pythonfmu", build_dir)


def native_paths(build_dir: Path) -> dict:
    return _paths("native", build_dir)


def _native3_paths(build_dir: Path) -> dict:
    return fmi3_paths(native_paths(build_dir))


def flavours() -> list[Flavour]:
    return [
        Flavour("pythonfmu", _pythonfmu_paths, refusal=FATAL, step_refusal=DISCARD, usable_after_refusal=False),
        Flavour("native", native_paths, refusal=ERROR, step_refusal=ERROR, usable_after_refusal=True),
        Flavour("native3", _native3_paths, refusal=ERROR, step_refusal=ERROR, usable_after_refusal=True, fmi=3),
    ]


@pytest.fixture(scope="session", params=flavours(), ids=str)
def flavour(request) -> Flavour:
    return request.param


@pytest.fixture(scope="session")
def fmus(flavour, fmu_build_dir) -> dict:
    return flavour.paths(fmu_build_dir)


@pytest.fixture
def open_fmu(fmus, flavour):
    """open_fmu(model, **parameters) -> harness.Fmu (or Fmu3), freed after the test."""
    opened = []

    def open_(model, /, **parameters):
        fmu = flavour.open(fmus[model], model.lower(), **parameters)
        opened.append(fmu)
        return fmu
    yield open_
    for fmu in opened:
        fmu.free()
