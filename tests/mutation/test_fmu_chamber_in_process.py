"""tests/test_fmu_chamber.py's checks of BallInShell motion = 2 against the library (the
spinning bowl, the Fig. 1 machine's fourth order, motion = 2 with translation-only inputs as
motion = 1, the drive power from MO1 and F, the bowl's small oscillations) on the pythonfmu
slave in this process (tests/mutation/inprocess.py), where mutmut sees the adapter's motion = 2
code (docs/mutation.md). The same tests run on the built FMUs of both flavours in that file."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from test_fmu_chamber import (  # noqa: E402,F401
    test_drive_power_from_MO1_and_F_is_the_balls_energy_change,
    test_fig1_machine_against_the_library_converges_at_fourth_order,
    test_motion_2_with_translation_only_inputs_is_motion_1,
    test_spinning_bowl_against_the_library,
    test_spinning_bowl_small_oscillations_through_the_fmu_match_the_closed_form)
from inprocess import Opened as InProcessOpened  # noqa: E402


@pytest.fixture
def built_fmus():
    return {name: name for name in ("BallInShell", "MotorStartup", "InductionMotor")}


@pytest.fixture
def opened():
    return InProcessOpened()
