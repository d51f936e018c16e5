"""Shared fixtures.

``fmu_build_dir`` builds every FMU once per test session into a temporary
folder (never into the checkout's build/), with ``build_all(force=True)``;
``built_fmus`` maps model name -> FMU path.
"""
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def fmu_build_dir(tmp_path_factory) -> Path:
    from ballmill.fmi.build import build_all

    build_dir = tmp_path_factory.mktemp("fmus")
    build_all(build_dir, force=True, log=lambda msg: None)
    return build_dir


@pytest.fixture(scope="session")
def built_fmus(fmu_build_dir) -> dict:
    return {p.stem: p for p in sorted(Path(fmu_build_dir).glob("*.fmu"))}
