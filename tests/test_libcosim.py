"""The FMUs in a second FMI importer: libcosim (Open Simulation Platform), via libcosimpy.

(a) fast_start exported as an SSP package runs in libcosim and agrees with
    `ballmill run fast_start` (the fmpy-based runner) on the same grid;
    parameter bindings in the package are applied.
(b) the FMUs load directly as libcosim local slaves, take parameters set
    through libcosim, match fmpy single-instance runs, and several instances
    of each FMU in one execution stay independent.
(c) state save/restore: libcosimpy 0.0.6 (libcosimc 0.11.2) has no state
    export/import function, so there is nothing to test here; the FMUs' own
    get/set FMU state is exercised through fmpy elsewhere.

All FMUs come from one build for the whole process (the session's
fmu_build_dir, or a private copy of build/), never from build/ itself: a
rebuild there during the run would mix two versions in this process, and
pythonfmu imports each FMU's script once per process (a second version of
the same model would reuse the first one's class).
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest

pytest.importorskip("libcosimpy", reason="libcosimpy is not installed (pip install libcosimpy, "
                                         "part of the 'test' extra): libcosim tests skipped")

from ballmill.fmi import build as _build  # noqa: E402
from ballmill.scenario import runner, ssp  # noqa: E402

STEP = 0.002
P_TOL = 1e-5   # m: contact point, libcosim vs fmpy runner (same Jacobi scheme, same step)
N_TOL = 1e-3   # N: normal force
CONTACT = ("xP", "yP", "zP")


@pytest.fixture(scope="module")
def build_dir(request, tmp_path_factory):
    """The session's FMU build (conftest's fmu_build_dir) if there is one, so that
    every test in the process loads the same build; else a private copy of
    build/ (mtimes kept: rebuilt there only if out of date)."""
    try:
        return request.getfixturevalue("fmu_build_dir")
    except pytest.FixtureLookupError:
        pass
    d = tmp_path_factory.mktemp("fmus")
    for fmu in (_build.ROOT / "build").glob("*.fmu"):
        shutil.copy2(fmu, d / fmu.name)
    _build.build_all(d, log=lambda m: None)
    return d


def _quiet(_msg):
    pass


def _runner(name, overrides=(), build_dir=None, stop=None):
    sc, models, paths = runner.prepare(name, list(overrides), build_dir, log=_quiet)
    if stop is not None:
        sc.stop = stop
    res = runner.run(sc, models, paths, progress=False, echo=False)
    assert res.success, res.message
    return res


def _record():
    return [("ball", v) for v in CONTACT + ("N", "M_reaction")] + \
           [("drive", v) for v in ("x1O", "y1O", "ax1O", "ay1O", "T_drive")]


# -- (a) SSP package -----------------------------------------------------------

@pytest.fixture(scope="module")
def fast_start_ssp(build_dir, tmp_path_factory):
    return ssp.export_ssp("fast_start", tmp_path_factory.mktemp("ssp") / "fast_start.ssp",
                          build_dir=build_dir, log=_quiet)


def test_ssp_package_is_valid_ssp_1_0(fast_start_ssp):
    import zipfile

    from fmpy.ssp.ssd import read_ssd
    names = zipfile.ZipFile(fast_start_ssp).namelist()
    assert sorted(names) == ["SystemStructure.ssd", "resources/BallInShell.fmu", "resources/MotorStartup.fmu"]
    ssd = read_ssd(str(fast_start_ssp), validate=True)  # raises on a schema violation
    comps = {c.name: c for c in ssd.system.elements}
    assert set(comps) == {"drive", "ball"}
    assert comps["ball"].source == "resources/BallInShell.fmu"
    assert comps["ball"].type == "application/x-fmu-sharedlibrary"
    assert len(ssd.system.connections) == 7
    root = ssp.read_ssd(fast_start_ssp)
    ball = root.find("ssd:System/ssd:Elements/ssd:Component[@name='ball']", ssp.NS)
    units = {c.get("name"): c[0].get("unit") for c in ball.iterfind("ssd:Connectors/ssd:Connector", ssp.NS)}
    assert units["xP"] == "m" and units["N"] == "N" and units["M_reaction"] == "N.m"
    assert {u.get("name") for u in root.iterfind("ssd:Units/ssc:Unit", ssp.NS)} >= {"m", "N", "N.m", "1/min"}
    assert ssp._experiment(root) == (0.0, 10.0, STEP)
    params = {}
    for comp in root.iterfind("ssd:System/ssd:Elements/ssd:Component", ssp.NS):
        for par in comp.iterfind(".//ssv:Parameter", ssp.NS):
            params[(comp.get("name"), par.get("name"))] = float(par[0].get("value"))
    assert params == {("drive", "l"): 0.5, ("drive", "n0"): 60.0, ("drive", "t0"): 2.5,
                      ("ball", "r"): 0.025, ("ball", "R"): 0.25, ("ball", "m"): 0.5105088062083415,
                      ("ball", "mu"): 0.3}


def test_fast_start_in_libcosim_matches_runner(fast_start_ssp, build_dir):
    """The whole fast start (10 s, H = 2 ms) in libcosim against `ballmill run fast_start`.

    Both masters are fixed-step Jacobi schemes with the same step, so the
    coupling error is the same in both and cancels: what is left is
    floating-point noise (libcosim counts time in integer nanoseconds, the
    runner computes t0 + k H; the ball's adaptive integrator then takes
    slightly different internal steps): ~2e-11 m and ~1e-7 N measured.
    """
    lc = ssp.run_ssp_libcosim(fast_start_ssp, record=_record())
    ref = _runner("fast_start", build_dir=build_dir)
    t = ref.column("time")
    assert len(lc["time"]) == len(t) == 5001
    np.testing.assert_allclose(lc["time"], t, rtol=0, atol=1e-12)
    dP = np.sqrt(sum((lc[f"ball.{v}"] - ref.column(f"ball.{v}")) ** 2 for v in CONTACT))
    dN = np.abs(lc["ball.N"] - ref.column("ball.N"))
    print(f"\nfast_start libcosim vs fmpy runner: max|dP| = {dP.max():.3g} m, max|dN| = {dN.max():.3g} N")
    assert dP.max() < P_TOL
    assert dN.max() < N_TOL
    # the contact point moves by ~0.25 m: the comparison is not trivially of zeros
    assert np.ptp(ref.column("ball.xP")) > 0.3
    for v in ("x1O", "y1O", "ax1O", "ay1O"):
        np.testing.assert_allclose(lc[f"drive.{v}"], ref.column(f"drive.{v}"), rtol=0, atol=1e-9)
    # Torques agree from the first step on. At t = 0 they differ: libcosim
    # propagates initial values with the FMUs in Initialization Mode, where
    # MotorStartup still reports its start values (it computes its outputs in
    # exit_initialization_mode), so BallInShell leaves initialisation with a
    # zero platform acceleration and reports M_reaction(0) = 0 instead of
    # -0.183 N.m; MotorStartup's T_drive over the first step sees that value.
    # The ball's state is unaffected: its t = 0 sample is replaced at the first step.
    np.testing.assert_allclose(lc["ball.M_reaction"][1:], ref.column("ball.M_reaction")[1:], rtol=0, atol=1e-5)
    np.testing.assert_allclose(lc["drive.T_drive"][2:], ref.column("drive.T_drive")[2:], rtol=0, atol=1e-5)


def test_ssp_has_one_parameter_set_and_the_step_where_each_tool_reads_it(build_dir, tmp_path):
    """One named set across the components (an engine that applies one set by name, as
    libcosim does, gets every component's values), and the communication step both in
    the OSP annotation (libcosim) and in OMSimulator's fixed-step master annotation."""
    overrides = ["drive.n0=45.0", "ball.xC0=0.02"]
    pkg = ssp.export_ssp("fast_start", tmp_path / "tools.ssp", overrides, build_dir=build_dir, log=_quiet)
    root = ssp.read_ssd(pkg)
    by_name = {}
    for comp in root.iterfind("ssd:System/ssd:Elements/ssd:Component", ssp.NS):
        for pset in comp.iterfind(".//ssv:ParameterSet", ssp.NS):
            for par in pset.iterfind(".//ssv:Parameter", ssp.NS):
                by_name.setdefault(pset.get("name"), set()).add((comp.get("name"), par.get("name")))
    assert list(by_name) == [ssp.PARAMETER_SET]
    assert {("drive", "n0"), ("ball", "xC0"), ("drive", "t0"), ("ball", "R")} <= by_name[ssp.PARAMETER_SET]
    system = root.find("ssd:System", ssp.NS)
    assert [child.tag.split("}")[1] for child in system][-1] == "Annotations"  # after Connections
    master = system.find("ssd:Annotations/ssc:Annotation[@type='org.openmodelica']/oms:Annotations/"
                         "oms:SimulationInformation/oms:FixedStepMaster", ssp.NS)
    assert master is not None and float(master.get("stepSize")) == STEP
    from fmpy.ssp.ssd import read_ssd
    read_ssd(str(pkg), validate=True)  # still valid SSP 1.0


def test_ssp_parameter_bindings_are_applied(build_dir, tmp_path):
    """Non-default parameters (Real and Integer) reach the FMUs through the .ssd."""
    overrides = ["drive.n0=45.0", "drive.t0=1.0", "drive.l=0.4", "ball.xC0=0.02", "ball.integrator=2"]
    pkg = ssp.export_ssp("fast_start", tmp_path / "custom.ssp", overrides, build_dir=build_dir, log=_quiet)
    ints = [p for p in ssp.read_ssd(pkg).iterfind(".//ssv:Parameter", ssp.NS) if p.get("name") == "integrator"]
    assert len(ints) == 1 and ints[0][0].tag == f"{{{ssp.NS['ssv']}}}Integer" and ints[0][0].get("value") == "2"
    lc = ssp.run_ssp_libcosim(pkg, stop=1.0, record=_record() + [("drive", "n0"), ("ball", "xC0")])
    assert np.all(lc["drive.n0"] == 45.0) and np.all(lc["ball.xC0"] == 0.02)
    assert lc["drive.x1O"][0] == pytest.approx(0.4)
    ref = _runner("fast_start", overrides, build_dir=build_dir, stop=1.0)
    assert len(lc["time"]) == len(ref.column("time")) == 501
    dP = np.sqrt(sum((lc[f"ball.{v}"] - ref.column(f"ball.{v}")) ** 2 for v in CONTACT))
    assert dP.max() < P_TOL
    assert np.abs(lc["ball.N"] - ref.column("ball.N")).max() < N_TOL
    assert abs(lc["ball.xP"][0] - 0.02 * 0.25 / (0.25 - 0.025)) < 1e-12  # P on the ray A -> C


# -- (b) local slaves --------------------------------------------------------------

BALLS = {
    "ball_a": {"xC0": 0.05},
    "ball_b": {"xC0": -0.03, "yC0": 0.04, "R": 0.3, "integrator": 2},
    "ball_c": {"yC0": -0.02, "wz0": 5.0, "r": 0.03, "m": 0.9},
}
DRIVES = {
    "drive_a": {},
    "drive_b": {"l": 0.3, "n0": 90.0, "t0": 1.0},
}
BALL_OUT = ("xP", "yP", "zP", "N", "wz")
DRIVE_OUT = ("x1O", "y1O", "ax1O", "ay1O", "psi_dot")
STOP_B = 2.0


def _fmpy_single(path, start_values, outputs):
    from fmpy import simulate_fmu
    res = simulate_fmu(str(path), start_time=0.0, stop_time=STOP_B, output_interval=STEP,
                       start_values=start_values, output=list(outputs))
    return res


def test_local_slaves_take_parameters_and_stay_independent(build_dir):
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimSlave import CosimLocalSlave

    ssp.ensure_libpython()
    ssp.set_libcosim_log_level("warning")
    fmus = {"ball": build_dir / "BallInShell.fmu", "drive": build_dir / "MotorStartup.fmu"}
    execution = CosimExecution.from_step_size(int(round(STEP * 1e9)))
    slaves = []  # keep the CosimLocalSlave objects alive while the execution runs
    setups = [(name, "ball", pars) for name, pars in BALLS.items()] + \
             [(name, "drive", pars) for name, pars in DRIVES.items()]
    for name, kind, pars in setups:
        slave = CosimLocalSlave(fmu_path=str(fmus[kind]), instance_name=name)
        slaves.append(slave)
        idx = execution.add_local_slave(slave)
        assert idx >= 0, f"libcosim refused {fmus[kind].name} as '{name}'"
        refs = {v.name.decode(): v for v in execution.slave_variables(idx)}
        for p, value in pars.items():
            var = refs[p]
            if CosimVariableType(var.type) is CosimVariableType.INTEGER:
                assert execution.integer_initial_value(idx, var.reference, int(value))
            else:
                assert execution.real_initial_value(idx, var.reference, float(value))
    record = [(n, v) for n in BALLS for v in BALL_OUT] + [(n, v) for n in DRIVES for v in DRIVE_OUT]
    n_steps = int(round(STOP_B / STEP))
    collect = ssp.observe_series(execution, record, n_steps)
    assert execution.simulate_until(int(round(STOP_B * 1e9)))
    lc = collect()
    assert len(lc["time"]) == n_steps + 1

    worst = {}
    for name, kind, pars in setups:
        outs = BALL_OUT if kind == "ball" else DRIVE_OUT
        ref = _fmpy_single(fmus[kind], pars, outs)
        assert len(ref) == n_steps + 1
        np.testing.assert_allclose(lc["time"], ref["time"], rtol=0, atol=1e-12)
        for v in outs:
            d = np.abs(lc[f"{name}.{v}"] - ref[v]).max()
            worst[f"{name}.{v}"] = d
            assert d < (1e-6 if v == "N" else 1e-9), f"{name}.{v}: libcosim vs fmpy differ by {d:.3g}"
    print("\nlocal slaves, libcosim vs fmpy single-instance runs: max diff " +
          ", ".join(f"{k} {v:.2g}" for k, v in worst.items()))

    # the ball with xC0 = 0.05 in a still chamber oscillates through the bottom
    xa = lc["ball_a.xP"]
    assert xa.max() > 0.05 and xa.min() < -0.05
    assert np.count_nonzero(np.diff(np.sign(xa)) != 0) >= 2
    # instances with different parameters give different results
    for a, b in (("ball_a", "ball_b"), ("ball_a", "ball_c"), ("ball_b", "ball_c")):
        assert np.abs(lc[f"{a}.xP"] - lc[f"{b}.xP"]).max() > 1e-2 or \
            np.abs(lc[f"{a}.yP"] - lc[f"{b}.yP"]).max() > 1e-2
    assert np.abs(lc["ball_c.wz"]).max() > 1.0 and np.abs(lc["ball_a.wz"]).max() < 1e-9
    assert np.abs(lc["drive_a.x1O"] - lc["drive_b.x1O"]).max() > 0.1
    assert lc["drive_b.psi_dot"][-1] == pytest.approx(90.0 * 2 * np.pi / 60)
