"""tests/test_fmu_outputs_vs_library.py (every output of every FMU against the physics
library, in each mode) on the pythonfmu flavour's slaves in this process
(tests/mutation/inprocess.py), where mutmut sees the adapters' code (docs/mutation.md).
The same tests run on the built FMUs of both flavours in that file."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from test_fmu_outputs_vs_library import *  # noqa: E402,F401,F403
from inprocess import Opened as InProcessOpened  # noqa: E402


@pytest.fixture
def fmu_path():
    return lambda name: name


@pytest.fixture
def opened():
    return InProcessOpened()
