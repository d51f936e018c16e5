"""Fixtures of the tests written for mutmut's survivors (docs/mutation.md).

``native_fmus``: model name -> native FMU path, built once per content of the C sources and
the interface declaration outside the tree mutmut copies (tests/mutation/native_fmus.py), so
that tests that drive real FMUs through the scenario runner also run under mutmut, including
its stats run (MUTANT_UNDER_TEST=stats), unlike tests/conftest.py's ``fmu_build_dir``.
``native_models``: model name -> its parsed model description (fmucache, once per content).
"""
from __future__ import annotations

import pytest

from native_fmus import native_fmus as _native_fmus


@pytest.fixture(scope="session")
def native_fmus() -> dict:
    return _native_fmus()


@pytest.fixture(scope="session")
def native_models(native_fmus) -> dict:
    from ballmill.scenario import fmucache

    return {name: fmucache.model_description(path) for name, path in native_fmus.items()}
