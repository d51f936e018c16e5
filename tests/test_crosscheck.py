"""The FMI cross-check files the build writes beside each native FMU (ballmill.fmi.crosscheck):
another importer, fmpy's simulate_fmu, given <Model>_in.csv and the settings of
<Model>_ref.opt, reproduces <Model>_ref.csv within the tolerance the .opt states; and the
files follow the cross-check rules (quoted header of declared names, the reference from
StartTime to StopTime every OutputIntervalLength, under 1 MB)."""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.fmi import crosscheck
from ballmill.fmi.build import fmu_path
from ballmill.scenario import fmucache


@pytest.mark.parametrize("name", sorted(crosscheck.REF_OUTPUTS))
def test_fmpy_reproduces_the_reference_from_the_input_file(fmu_build_dir, name):
    from fmpy import simulate_fmu
    from fmpy.util import read_csv

    fmu = fmu_path(name, fmu_build_dir)
    in_csv, opt_file, ref_csv = crosscheck.files(name, fmu_build_dir)
    opt = crosscheck.read_opt(opt_file)
    md = fmucache.model_description(fmu)
    de = md.defaultExperiment
    assert (opt["StartTime"], opt["StopTime"], opt["StepSize"]) == (float(de.startTime), float(de.stopTime),
                                                                     float(de.stepSize))
    header, ref = crosscheck.read_csv(ref_csv)
    declared = {v.name: v.causality for v in md.modelVariables}
    assert header[0] == "time" and 1 <= len(header) - 1 <= 10
    assert all(declared.get(h) == "output" for h in header[1:])
    in_header, _ = crosscheck.read_csv(in_csv)
    assert in_header[0] == "time" and all(declared.get(h) == "input" for h in in_header[1:])
    for f in (in_csv, ref_csv):
        assert f.stat().st_size < 1_000_000
    t = ref[:, 0]
    assert t[0] == opt["StartTime"] and t[-1] == opt["StopTime"]
    np.testing.assert_allclose(np.diff(t), opt["OutputIntervalLength"], rtol=1e-9)

    result = simulate_fmu(str(fmu), fmi_type="CoSimulation", start_time=opt["StartTime"],
                          stop_time=opt["StopTime"], output_interval=opt["StepSize"],
                          input=read_csv(str(in_csv)), output=header[1:])
    rows = np.searchsorted(result["time"], t - 1e-9)
    np.testing.assert_allclose(result["time"][rows], t, rtol=0, atol=1e-9)
    for j, column in enumerate(header[1:], start=1):
        got = np.asarray(result[column][rows], dtype=float)
        bound = opt["RelTol"] * np.max(np.abs(ref[:, j])) + opt["AbsTol"]
        err = np.max(np.abs(got - ref[:, j]))
        assert err <= bound, f"{name}.{column}: fmpy off the reference by {err:.3g} > {bound:.3g}"


def test_the_build_rewrites_missing_cross_check_files_and_otherwise_leaves_them(fmu_build_dir):
    """A cross-check file gone (or edited) is written again by the next build check, from the FMU
    already built (no FMU is rebuilt for it); an intact set costs the check nothing more than
    its stat calls: nothing is written."""
    from ballmill.fmi import build

    in_csv, opt, ref = crosscheck.files("MotorStartup", fmu_build_dir)
    before = ref.read_bytes()
    fmu_stat = fmu_path("MotorStartup", fmu_build_dir).stat().st_mtime_ns
    ref.unlink()
    said = []
    build.build_all(fmu_build_dir, log=said.append, only=True, names=["MotorStartup"])
    assert len(said) == 1 and said[0].startswith("wrote the FMI cross-check files of 1 FMU in "), said
    assert ref.read_bytes() == before  # the same FMU, the same run: the same reference
    assert fmu_path("MotorStartup", fmu_build_dir).stat().st_mtime_ns == fmu_stat
    said.clear()
    build.build_all(fmu_build_dir, log=said.append, only=True, names=["MotorStartup"])
    assert said == []
    assert build._fresh(fmu_build_dir, ("native",), {"MotorStartup"}) is not None  # the stat-only path
