"""The scenario layer's checks and the SSP export without building an FMU: the model
descriptions come from the pythonfmu slaves' own `to_xml` (what a pythonfmu build puts in
the FMU, tests/mutation/inprocess.py), so that tests/test_scenarios.py's file checks and
tests/test_ssp_units.py's unit checks also run where mutmut can see them (docs/mutation.md).
The same tests run on the built FMUs in those files."""
from __future__ import annotations

import sys
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import write_model_descriptions  # noqa: E402
from test_scenarios import (  # noqa: E402,F401
    test_bad_experiment_values_are_reported_not_raised, test_scenario_mistakes_are_all_listed_with_file_and_key)
from test_ssp_units import (  # noqa: E402,F401
    test_every_connector_has_the_model_descriptions_kind_type_and_unit,
    test_every_parameter_binding_has_its_value_type_and_unit, test_every_unit_definition_matches_the_model_descriptions_and_si,
    test_model_descriptions_define_their_units_as_si_does)

from ballmill.scenario import spec, ssp  # noqa: E402
from ballmill.scenario.spec import ScenarioError  # noqa: E402


@pytest.fixture(scope="module")
def descriptions(tmp_path_factory):
    return write_model_descriptions(tmp_path_factory.mktemp("md"))


@pytest.fixture(scope="module")
def models(descriptions):
    return {name: read_model_description(str(p)) for name, p in descriptions.items()}


@pytest.fixture(scope="module")
def fmu_build_dir(descriptions, tmp_path_factory):
    """A folder of <Model>.fmu archives holding only the model description (enough for
    anything that reads one; nothing here loads a binary)."""
    d = tmp_path_factory.mktemp("fmus")
    for name, p in descriptions.items():
        with zipfile.ZipFile(d / f"{name}.fmu", "w") as z:
            z.write(p, "modelDescription.xml")
    return d


@pytest.fixture(scope="module")
def exported(models):
    """As in tests/test_ssp_units.py, with the scenarios loaded against these models."""
    out = {}
    for path in sorted(spec.SCENARIO_DIR.glob("*.toml")):
        sc = spec.load(str(path), [], models)
        if any(inst.fmu is None for inst in sc.instances.values()):
            continue
        out[sc.name] = (sc, models, ssp.build_ssd(sc, models).getroot())
    assert {"fast_start", "slow_start", "induction_start", "induction_soft_start"} <= set(out)
    return out


@pytest.mark.parametrize("override,fragment", [
    ("nosuch.r=0.02", "--set nosuch.r=0.02: no instance 'nosuch' (instances: drive, ball)"),
    ("ball.rr=0.02", "--set ball.rr=0.02: BallInShell has no parameter 'rr'"),
    ("ball.formulation=vector", "expected a Integer value, got 'vector'"),
    ("t0=3", "--set 't0=3': expected instance.parameter=value, e.g. drive.t0=30"),
    ("drive=3", "expected instance.parameter=value"),
])
def test_bad_set_is_reported_with_the_override(models, override, fragment):
    with pytest.raises(ScenarioError) as info:
        spec.load("fast_start", [override], models)
    assert any(fragment in p for p in info.value.problems), info.value.problems


@pytest.mark.parametrize("text, parsed", [
    ("drive.t0=1.5", ("drive", "t0", 1.5)), ("drive.t0 = 2", ("drive", "t0", 2)),
    ("ball.name=abc", ("ball", "name", "abc")), ("ball.flag=true", ("ball", "flag", True)),
    ("a.b.c=x=y", ("a", "b.c", "x=y")),
])
def test_an_override_is_parsed_as_a_toml_value_or_kept_as_text(text, parsed):
    assert spec.parse_override(text) == parsed


def test_overrides_reach_the_scenario(models):
    sc = spec.load("fast_start", ["drive.t0=1.0", "drive.n0=30", "ball.mu=0.5"], models)
    assert sc.instances["drive"].parameters["t0"] == 1.0
    assert sc.instances["drive"].parameters["n0"] == 30
    assert sc.instances["ball"].parameters["mu"] == 0.5
