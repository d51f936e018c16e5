"""SSP export and libcosim runs (ballmill/scenario/ssp.py: export_ssp's package, read_ssd,
the DefaultExperiment, run_ssp_libcosim, observe_series and its sample reader) in this
process, where mutmut sees them, with the native FMUs of tests/mutation/native_fmus.py (no
build under mutmut: export_ssp's `runner.prepare` is given the native FMUs). A short drive +
ball scenario runs in libcosim (the same Jacobi scheme as ballmill's runner) and agrees with
runner.run and with the drive's closed form; every refusal's message word for word."""
from __future__ import annotations

import zipfile

import numpy as np
import pytest

pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (the 'test' extra)")

from ballmill.scenario import runner, ssp  # noqa: E402
from runner_cases import linear_law, load  # noqa: E402

TEXT = """
description = "the drive on its own and a ball on it"
connections = ["drive.x1O -> ball.x1O", "drive.y1O -> ball.y1O", "drive.vx1O -> ball.vx1O", "drive.vy1O -> ball.vy1O",
               "drive.ax1O -> ball.ax1O", "drive.ay1O -> ball.ay1O", "ball.M_reaction -> drive.M_reaction"]
[experiment]
start = 0.0
stop = 0.05
step = 0.01
[instances.drive]
fmu = "MotorStartup"
parameters = { n0 = 90.0, t0 = 0.5, law = 3, J_crank = 0.02 }
[instances.ball]
fmu = "BallInShell"
parameters = { mu = 0.5, corrector = false }
"""


@pytest.fixture()
def package(tmp_path, native_models, native_fmus, monkeypatch):
    sc = load(tmp_path, TEXT, native_models, name="drive_ball")
    calls = []

    def prepare(name, overrides, build_dir, log):
        calls.append((name, overrides, build_dir))
        return sc, native_models, native_fmus
    monkeypatch.setattr(runner, "prepare", prepare)
    out = ssp.export_ssp("drive_ball", tmp_path / "sub" / "drive_ball.ssp", ["drive.n0=90"], tmp_path / "b",
                         log=lambda m: None)
    assert calls == [("drive_ball", ["drive.n0=90"], tmp_path / "b")]
    return sc, out


def test_the_package_holds_the_ssd_and_the_fmus(package, native_fmus):
    sc, out = package
    assert out.is_file() and out.name == "drive_ball.ssp"
    assert not out.with_name("drive_ball.ssp.part").exists()
    with zipfile.ZipFile(out) as z:
        assert sorted(z.namelist()) == ["SystemStructure.ssd", "resources/BallInShell.fmu", "resources/MotorStartup.fmu"]
        assert z.read("resources/MotorStartup.fmu") == native_fmus["MotorStartup"].read_bytes()
        assert z.read("SystemStructure.ssd").startswith(b"<?xml version='1.0' encoding='UTF-8'?>")
    root = ssp.read_ssd(out)
    assert root.tag == "{http://ssp-standard.org/SSP1/SystemStructureDescription}SystemStructureDescription"
    assert root.get("name") == "drive_ball"
    assert ssp._experiment(root) == (0.0, 0.05, 0.01)
    ssd = out.with_suffix(".ssd")
    with zipfile.ZipFile(out) as z:
        ssd.write_bytes(z.read("SystemStructure.ssd"))
    assert ssp.read_ssd(ssd).get("name") == "drive_ball"


def test_the_default_experiment_read_back():
    from xml.etree import ElementTree as ET

    ns = 'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"'
    bare = ET.fromstring(f'<ssd:SystemStructureDescription {ns}/>')
    assert ssp._experiment(bare) == (0.0, None, None)
    only = ET.fromstring(f'<ssd:SystemStructureDescription {ns}><ssd:DefaultExperiment startTime="0.5"/>'
                         f'</ssd:SystemStructureDescription>')
    assert ssp._experiment(only) == (0.5, None, None)
    none = ET.fromstring(f'<ssd:SystemStructureDescription {ns}><ssd:DefaultExperiment stopTime="2.0"/>'
                         f'</ssd:SystemStructureDescription>')
    assert ssp._experiment(none) == (0.0, 2.0, None)


def test_libcosim_runs_the_package_as_the_runner_does(package, native_models, native_fmus):
    sc, out = package
    record = [("drive", "psi"), ("drive", "T_drive"), ("ball", "zP"), ("ball", "M_reaction")]
    lc = ssp.run_ssp_libcosim(out, record=record)
    assert list(lc) == ["time", "drive.psi", "drive.T_drive", "ball.zP", "ball.M_reaction"]
    assert np.allclose(lc["time"], [0.0, 0.01, 0.02, 0.03, 0.04, 0.05], rtol=0, atol=1e-12)
    for k, t in enumerate(lc["time"]):
        assert lc["drive.psi"][k] == pytest.approx(linear_law(90.0, 0.5, t)[0], rel=1e-12, abs=1e-15)
    sc.record = record
    ref = runner.run(sc, native_models, native_fmus, progress=False, echo=False)
    assert ref.success
    for name in ("drive.T_drive", "ball.zP", "ball.M_reaction"):
        assert np.allclose(lc[name][1:], ref.column(name)[1:], rtol=1e-9, atol=1e-12), name
    assert np.max(np.abs(lc["ball.M_reaction"])) > 1e-2
    # step and stop given: 2 steps of 20 ms
    short = ssp.run_ssp_libcosim(out, step=0.02, stop=0.04, record=[("drive", "psi_dot")], log_level=None)
    assert np.allclose(short["time"], [0.0, 0.02, 0.04], atol=1e-12)
    assert np.allclose(short["drive.psi_dot"], [linear_law(90.0, 0.5, t)[1] for t in (0.0, 0.02, 0.04)], rtol=1e-12)


def test_libcosim_refusals_are_named(package, tmp_path):
    sc, out = package
    with pytest.raises(ValueError) as e:
        ssp.run_ssp_libcosim(out, stop=0.025)
    assert str(e.value) == "stop = 0.025 s is not a positive whole number of steps of 0.01 s"
    with pytest.raises(ValueError) as e:
        ssp.run_ssp_libcosim(out, step=0.01, stop=0.004)
    assert str(e.value) == "stop = 0.004 s is not a positive whole number of steps of 0.01 s"
    with pytest.raises(KeyError) as e:
        ssp.run_ssp_libcosim(out, record=[("motor", "psi")])
    assert e.value.args[0] == "no instance 'motor' in the execution (instances: ball, drive)"
    with pytest.raises(KeyError) as e:
        ssp.run_ssp_libcosim(out, record=[("drive", "nothing")])
    assert e.value.args[0] == "instance 'drive' has no variable 'nothing'"
    with pytest.raises(ValueError) as e:
        ssp.run_ssp_libcosim(out, record=[("ball", "valid")])
    assert str(e.value) == "ball.valid: only Real variables can be recorded here"
    # a package without a DefaultExperiment's stop or step, and one that starts later
    for text, message in (("<ssd:DefaultExperiment startTime=\"0.0\"/>",
                           "give step and stop: the package's DefaultExperiment does not define them"),
                          ("<ssd:DefaultExperiment startTime=\"0.5\" stopTime=\"1.0\"/>",
                           "run_ssp_libcosim supports start time 0 only, the package starts at 0.5 s")):
        bad = tmp_path / "bad.ssp"
        with zipfile.ZipFile(bad, "w") as z:
            z.writestr("SystemStructure.ssd", '<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/'
                                              f'SSP1/SystemStructureDescription">{text}</ssd:SystemStructureDescription>')
        with pytest.raises(ValueError) as e:
            ssp.run_ssp_libcosim(bad, step=None if "0.0" in text else 0.1)
        assert str(e.value) == message


def test_this_python_shows_the_c_api():
    """The interpreter exports the CPython C API: nothing to load; a shared libpython, if
    this Python has one, is where sysconfig says."""
    import os
    import sysconfig

    assert ssp.ensure_libpython() is None
    path = ssp.libpython_path()
    if path is not None:
        assert os.path.exists(path) and os.path.dirname(path) == sysconfig.get_config_var("LIBDIR")
