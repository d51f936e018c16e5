"""Shared fixtures.

``fmu_build_dir`` builds every FMU once per test session, both flavours, into a
temporary folder (never into the checkout's build/), with ``build_all(force=True)``.
``BALLMILL_TEST_FMU_DIR`` names a folder of FMUs already built (both flavours) to use instead.
``built_fmus`` maps model name -> FMU path and is parametrised over the flavours
(native: <dir>/<Model>.fmu, pythonfmu: <dir>/pythonfmu/<Model>.fmu), so that every
FMU-level test runs on both; ``fmus_of(flavour)`` gives one flavour's map.
``subplots_made``: the figures code under test makes (ballmill.plotting.figures.subplots), in
order, still readable after the code has saved them.

The test process loads pythonfmu FMUs, whose library destructor can corrupt the heap at
process exit (pythonfmu 0.7.0; see ``ballmill.cli.entry`` and docs/OTHER_TOOLS.md): after
pytest has reported, the session leaves with ``os._exit`` and pytest's own exit status, so
that the defect cannot turn a green run red at random. The defect itself is asserted on its
own, in a host process (tests/test_fmu_standalone.py, tests/conformance/test_exit.py).
"""
import json
import math
import os
import sys
from pathlib import Path

import pytest

FLAVOURS = ("native", "pythonfmu")



@pytest.fixture
def subplots_made(monkeypatch):
    """The figures made through ballmill.plotting.figures.subplots (where every PNG's figure is
    made) while the test runs, in order; still readable after they are saved."""
    from ballmill.plotting import figures

    kept, subplots = [], figures.subplots

    def recording(*a, **kw):
        fig, ax = subplots(*a, **kw)
        kept.append(fig)
        return fig, ax
    monkeypatch.setattr(figures, "subplots", recording)
    yield kept


@pytest.fixture(scope="session")
def fmu_build_dir(tmp_path_factory) -> Path:
    from ballmill.fmi.build import build_all

    if os.environ.get("MUTANT_UNDER_TEST"):
        # under mutmut (docs/mutation.md) every mutant would rebuild every FMU, and the FMUs
        # would bundle the mutated copy: the tests that need built FMUs do not run there
        pytest.skip("FMUs are not built under mutmut")
    prebuilt = os.environ.get("BALLMILL_TEST_FMU_DIR")
    if prebuilt:
        # the C mutation runner (tests/mutation/c/run.py) builds both flavours once and
        # rebuilds, per mutant, only the FMUs its mutated file goes into
        if not Path(prebuilt, "BallInShell.fmu").is_file():
            raise RuntimeError(f"BALLMILL_TEST_FMU_DIR={prebuilt}: no BallInShell.fmu there "
                               "(expected a folder written by ballmill build, both flavours)")
        return Path(prebuilt)
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


_EXIT_STATUS = []


def _pytest_is_the_program() -> bool:
    """True under `pytest` and `python -m pytest`; False when another program (mutmut, an
    IDE) runs pytest.main() inside its own process, which must go on after the session."""
    argv0 = Path(sys.argv[0])
    return argv0.name in ("pytest", "py.test") or (argv0.name == "__main__.py"
                                                   and argv0.parent.name == "pytest")


def pytest_sessionfinish(session, exitstatus):
    _EXIT_STATUS.append(int(exitstatus))


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """Last of all, after the report and every other plugin's clean-up: leave without the
    C-level exit handlers (pythonfmu's destructor), with the status pytest would return."""
    if _EXIT_STATUS and _pytest_is_the_program():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_EXIT_STATUS[-1])


def pytest_collection_modifyitems(config, items):
    """Under mutmut (docs/mutation.md) a test that starts a dask cluster hangs in mutmut's
    forked worker (the cluster's processes never report back, and a sleeping worker never
    reaches mutmut's CPU-time limit): such tests are skipped there. And a mutant's tests run
    fastest first (their durations from mutmut's stats run): mutmut stops at the first
    failure, so a mutant is killed by its cheapest catching test, not by whichever came first."""
    mutant = os.environ.get("MUTANT_UNDER_TEST")
    if not mutant:
        return
    if "__mutmut_" in mutant:
        durations = _mutmut_durations()  # once per session, not per item (the stats file is megabytes)
        items.sort(key=lambda item: durations.get(item.nodeid, math.inf))
    for item in items:
        if "dask" in item.name:
            item.add_marker(pytest.mark.skip(reason="no dask cluster in a mutmut worker"))


def _mutmut_durations() -> dict:
    """test node id -> its duration in mutmut's stats run: the forked worker inherits them from
    mutmut's process; otherwise (a mutant run by hand) they are read from mutmut-stats.json."""
    try:
        from mutmut.state import state
        durations = state().duration_by_test
    except ImportError:
        durations = {}
    if not durations and Path("mutmut-stats.json").is_file():
        durations = json.loads(Path("mutmut-stats.json").read_text())["duration_by_test"]
    return durations
