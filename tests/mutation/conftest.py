"""Fixtures of the tests written for mutmut's survivors (docs/mutation.md).

``native_fmus``: model name -> native FMU path, built once per content of the C sources and
the interface declaration outside the tree mutmut copies (tests/mutation/native_fmus.py), so
that tests that drive real FMUs through the scenario runner also run under mutmut, including
its stats run (MUTANT_UNDER_TEST=stats), unlike tests/conftest.py's ``fmu_build_dir``.
``native_models``: model name -> its parsed model description, parsed on first use (fmpy's
schema validation costs a good part of a second per model in each mutmut worker) and kept
by fmucache per content.
"""
from __future__ import annotations

from collections.abc import Mapping

import pytest

from native_fmus import native_fmus as _native_fmus


@pytest.fixture(scope="session")
def native_fmus() -> dict:
    from ballmill.fmi import native

    if not native.has_compiler():
        pytest.skip("no C compiler (cc, gcc, clang or $CC): the native FMUs cannot be built")
    return _native_fmus()


@pytest.fixture(scope="session")
def native_models(native_fmus) -> Mapping:
    from ballmill.scenario.runner import _Descriptions  # the runner's own lazy reader

    return _Descriptions(native_fmus)


@pytest.fixture
def figures(subplots_made):
    """The figures ballmill.scenario.report makes, in order (tests/conftest.py's subplots_made)."""
    return subplots_made
