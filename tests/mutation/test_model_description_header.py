"""The pythonfmu flavour's modelDescription header and variable texts, as a tool reads them
(`Slave.to_xml` written to text and parsed): author and license, every variable's description
word for word from the one declaration (ballmill/fmi/interface.py), and the DefaultExperiment
(start, stop, step; no tolerance) from the declaration, for every model."""
from __future__ import annotations

import sys
from pathlib import Path
from xml.etree.ElementTree import fromstring, tostring

import pytest

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from inprocess import SCRIPTS, slave_class  # noqa: E402

from ballmill.fmi.interface import INTERFACES  # noqa: E402


@pytest.mark.parametrize("model", sorted(SCRIPTS))
def test_header_descriptions_and_default_experiment(model):
    slave = slave_class(model)(instance_name="header")
    root = fromstring(tostring(slave.to_xml(), encoding="unicode"))
    iface = INTERFACES[model]
    assert root.get("author") == "ballmill" and root.get("license") == "MIT"
    described = {sv.get("name"): sv.get("description") for sv in root.find("ModelVariables")}
    assert described == {v.name: v.description for v in iface.variables}
    (experiment,) = root.findall("DefaultExperiment")
    start, stop, step = iface.default_experiment
    assert {k: float(v) for k, v in experiment.attrib.items()} == {"startTime": start, "stopTime": stop,
                                                                  "stepSize": step}
