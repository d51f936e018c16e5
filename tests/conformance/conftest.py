"""The FMU flavours the conformance suite runs over (docs/conformance.md).

`flavours()` is the one place that says which builds of the models exist.
``pythonfmu`` (build/pythonfmu/<Model>.fmu) and ``native`` (the C FMUs,
build/<Model>.fmu), both written by `ballmill build`; or, when BALLMILL_TEST_FMU_DIR names
a folder, the FMUs already built there (the C mutation runner, tests/mutation/c/run.py).

A flavour also says which FMI status its refusals carry: the specification asks
for fmi2Error; pythonfmu 0.7.0 can only return fmi2Fatal from a refused call
other than fmi2DoStep (a Python exception) and fmi2Discard from a refused
fmi2DoStep (docs/OTHER_TOOLS.md), and the tests assert exactly that. After
pythonfmu's fmi2Fatal the instance is gone (pythonfmu releases its Python object
while reporting the exception; any later call on it, fmi2FreeInstance included,
touches freed memory), so a flavour also says whether an instance stays usable
after a refused call: the tests then check that it kept its state.
"""
from __future__ import annotations

import os
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
    paths: Callable[[], dict]  # model name -> FMU path (built on demand)
    refusal: int  # status of a refused call other than doStep (spec: ERROR)
    step_refusal: int  # status of a doStep refused for its arguments or phase (spec: ERROR)
    usable_after_refusal: bool  # the instance keeps its state after a refused call (spec: True)

    def __str__(self):
        return self.name


def _paths(flavour: str) -> dict:
    from ballmill.fmi.build import build_all, fmu_path

    prebuilt = os.environ.get("BALLMILL_TEST_FMU_DIR")  # as tests/conftest.py's fmu_build_dir
    if prebuilt:
        return {name: fmu_path(name, Path(prebuilt), flavour) for name in MODELS}
    paths = build_all(ROOT / "build", log=lambda msg: None, flavour=flavour)
    return {p.stem: p for p in paths}


def _pythonfmu_paths() -> dict:
    return _paths("pythonfmu")


def _native_paths() -> dict:
    return _paths("native")


def flavours() -> list[Flavour]:
    return [
        Flavour("pythonfmu", _pythonfmu_paths, refusal=FATAL, step_refusal=DISCARD, usable_after_refusal=False),
        Flavour("native", _native_paths, refusal=ERROR, step_refusal=ERROR, usable_after_refusal=True),
    ]


_CACHE: dict = {}


@pytest.fixture(scope="session", params=flavours(), ids=str)
def flavour(request) -> Flavour:
    return request.param


@pytest.fixture(scope="session")
def fmus(flavour) -> dict:
    if flavour.name not in _CACHE:
        _CACHE[flavour.name] = flavour.paths()
    return _CACHE[flavour.name]


@pytest.fixture
def open_fmu(fmus):
    """open_fmu(model, **parameters) -> harness.Fmu, freed after the test."""
    from .harness import Fmu

    opened = []

    def open_(model, /, **parameters):
        fmu = Fmu(fmus[model], model.lower(), **parameters)
        opened.append(fmu)
        return fmu
    yield open_
    for fmu in opened:
        fmu.free()
