"""Whether the session's BallInShell takes the chamber's 3-D motion (parameter motion = 2,
issue 12 part 2, branch ballgen), which the turning scenarios (spinning_bowl, tumbling_drum,
fig1_machine) need: tests that run every scenario skip those, saying why, until it does."""
from __future__ import annotations

from pathlib import Path

TURNING_SCENARIOS = ("spinning_bowl", "tumbling_drum", "fig1_machine")


def missing(build_dir: Path) -> str:
    """'' when the BallInShell built in build_dir has the parameter motion, else why not."""
    from fmpy import read_model_description

    from ballmill.fmi.build import fmu_path

    md = read_model_description(str(fmu_path("BallInShell", build_dir, "pythonfmu")))
    if "motion" in {v.name for v in md.modelVariables}:
        return ""
    return "BallInShell has no parameter motion (the chamber's 3-D motion, branch ballgen) in this build"
