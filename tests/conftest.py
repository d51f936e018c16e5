"""Shared fixtures.

``fmu_build_dir`` builds every FMU once per test session, both flavours, into a
temporary folder (never into the checkout's build/), with ``build_all(force=True)``.
``built_fmus`` maps model name -> FMU path and is parametrised over the flavours
(native: <dir>/<Model>.fmu, pythonfmu: <dir>/pythonfmu/<Model>.fmu), so that every
FMU-level test runs on both; ``fmus_of(flavour)`` gives one flavour's map.
"""
from pathlib import Path

import pytest

FLAVOURS = ("native", "pythonfmu")


@pytest.fixture(scope="session")
def fmu_build_dir(tmp_path_factory) -> Path:
    from ballmill.fmi.build import build_all

    build_dir = tmp_path_factory.mktemp("fmus")
    build_all(build_dir, force=True, log=lambda msg: None)
    return build_dir


@pytest.fixture(scope="session")
def fmus_of(fmu_build_dir):
    """flavour -> {model name: FMU path}."""
    from ballmill.fmi.build import fmu_path
    from ballmill.fmi.interface import INTERFACES

    def of(flavour: str) -> dict:
        return {name: fmu_path(name, fmu_build_dir, flavour) for name in sorted(INTERFACES)}
    return of


@pytest.fixture(scope="session", params=FLAVOURS)
def fmu_flavour(request) -> str:
    return request.param


@pytest.fixture(scope="session")
def built_fmus(fmus_of, fmu_flavour) -> dict:
    return fmus_of(fmu_flavour)
