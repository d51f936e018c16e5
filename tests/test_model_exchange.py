"""Model Exchange through real importers: fmpy's simulate_fmu (CVode with its root finding
and time events) and a hand-written importer on fmpy's FMU2Model that integrates the
native FMUs' continuous states with scipy, checked against the library (ballmill.physics).

Tolerances: the importer integrates at a relative tolerance of 1e-10 (CVode) or 1e-11
(scipy's DOP853), the library at 1e-12 over a few pendulum periods, so the contact point
(R = 0.25 m) agrees to about 1e-9 m and N (about 5 N) to about 1e-8 N; the assertions
leave a factor 10-100 above what was measured (4.6e-10 m, 1e-8 N). An event located by
CVode's root finding agrees with the library's within 1e-7 s: the library's outputs sampled
every 0.1 ms, the crossing interpolated linearly, are 1e-8 s off (0.18832368651 s against
0.18832367833 s at 2 us, the value it converges to; CVode found 0.18832367665 s).
"""
import ctypes
import math

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy import simulate_fmu as _simulate_fmu
from fmpy.validation import validate_fmu
from scipy.integrate import solve_ivp

from ballmill.physics.drives.crank import Circle, CrankStartup, Fixed
from ballmill.physics.model import BallModel, simulate
from ballmill.physics.params import Ball

from tests.conformance.harness import Fmu

ME_MODELS = ("BallInShell", "MotorStartup", "InductionMotor", "Fig1Drive", "Structure")


def _quiet(*args):
    """fmpy's FMI 2.0 logger for simulate_fmu: its native proxy calls the last Python logger
    registered in the process, which an instance of another test may have left behind freed"""


def simulate_fmu(*args, **kwargs):
    return _simulate_fmu(*args, logger=_quiet, **kwargs)


@pytest.fixture(scope="module")
def native(fmus_of):
    return fmus_of("native")


@pytest.mark.parametrize("model", ME_MODELS)
def test_archive_holds_both_interfaces_and_validates(native, model):
    md = read_model_description(str(native[model]))
    assert md.modelExchange is not None and md.coSimulation is not None
    assert md.modelExchange.modelIdentifier == md.coSimulation.modelIdentifier == model
    assert validate_fmu(str(native[model])) == []


def _unique(r):
    """fmpy records an event's time twice (before and after): keep the first row of each time"""
    _, idx = np.unique(r["time"], return_index=True)
    return r[idx]


@pytest.mark.parametrize("law", ["quadratic", "scurve", "linear", "quintic"])
def test_motor_startup_me_is_the_start_up_law_with_time_events_at_0_and_t0(native, law):
    t0 = 1.3
    r = simulate_fmu(str(native["MotorStartup"]), fmi_type="ModelExchange", start_time=-0.5, stop_time=2.0,
                     output_interval=0.05, start_values={"t0": t0, "law": ["quadratic", "scurve", "linear",
                                                                           "quintic"].index(law) + 1},
                     record_events=True, output=["psi", "psi_dot", "psi_ddot", "ax1O", "ay1O"])
    # the time events: fmpy stopped exactly at t = 0 and t = t0 (not on its 0.05 s grid)
    assert 0.0 in r["time"] and t0 in r["time"]
    law_ = CrankStartup(t0=t0, law=law)
    for row in _unique(r):
        x, y, vx, vy, ax, ay = law_.state(float(row["time"]))
        assert row["ax1O"] == pytest.approx(ax, rel=1e-12, abs=1e-12)
        assert row["ay1O"] == pytest.approx(ay, rel=1e-12, abs=1e-12)


def _ball_me(native, stop, dt, **start):
    return simulate_fmu(str(native["BallInShell"]), fmi_type="ModelExchange", stop_time=stop,
                        output_interval=dt, start_values=start, relative_tolerance=1e-10,
                        output=["xC", "yC", "zC", "N", "Ft", "valid", "t_invalid"])


def test_ball_me_in_a_fixed_chamber_is_the_library_pendulum(native):
    d = Ball().d
    r = _unique(_ball_me(native, 2.0, 0.01, xC0=0.3 * d, yC0=0.05 * d, wz0=3.0))
    m = BallModel(Ball(), tol=1e-12)
    lib = simulate(m, Fixed(), 2.0, 0.01, m.initial(xC0=0.3 * d, yC0=0.05 * d, w0=(0.0, 0.0, 3.0)))
    assert np.allclose(r["time"], lib.t, rtol=0, atol=1e-12)
    for name in ("xC", "yC", "zC"):
        assert np.abs(r[name] - lib[name]).max() < 1e-8, name
    assert np.abs(r["N"] - lib["N"]).max() < 1e-6
    assert r["valid"].all()


# the ball rolls up the wall from the bottom: it begins to slip (mu = 0.1) half-way up, or
# (mu = 100) just before it leaves the wall above the equator, where N -> 0 makes mu N < |F_t|
@pytest.mark.parametrize("wy0, mu, what", [(-20.0, 0.1, "t_first_slip"), (-100.0, 100.0, "t_invalid")])
def test_ball_me_reports_slip_and_lift_off_at_the_librarys_time(native, wy0, mu, what):
    r = _ball_me(native, 1.0, 0.01, wy0=wy0, mu=mu)
    m = BallModel(Ball(mu=mu), tol=1e-12)
    lib = simulate(m, Fixed(), 1.0, 1e-4, m.initial(w0=(0.0, wy0, 0.0)))
    expected = getattr(lib, what)
    assert expected is not None and expected > 0.05
    assert not r["valid"][-1]
    assert r["t_invalid"][-1] == pytest.approx(expected, abs=1e-7)
    before = r["time"] < expected - 1e-6
    assert r["valid"][before].all() and (r["t_invalid"][before] == 1e300).all()


@pytest.mark.parametrize("version", [2, 3], ids=["fmi2", "fmi3"])
def test_ball_me_discrete_outputs_change_only_at_events(native, version):
    """FMI: discrete variables change only at event instants. The ball rolled up the wall with
    mu = 100 slips, then leaves the wall; fmpy (record_events) records each event twice at its
    time, before and after the event update. `rolling`, `contact` and `valid` change only between
    those two rows: at the row before the update the raw judgement has already flipped (CVode
    stops past the indicator's root, eps beyond the boundary), and the outputs still hold."""
    path = native["BallInShell"] if version == 2 else native["BallInShell"].parent / "fmi3" / "BallInShell.fmu"
    r = simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=1.0, output_interval=0.01,
                     start_values=dict(wy0=-100.0, mu=100.0), relative_tolerance=1e-10, record_events=True,
                     output=["N", "Ft", "contact", "rolling", "valid"])
    t = r["time"]
    for name in ("rolling", "contact", "valid"):
        changed = np.flatnonzero(r[name][1:] != r[name][:-1])
        assert len(changed) == 1, (name, t[changed])  # one switch each, to false
        assert not r[name][-1]
        i = changed[0]
        assert t[i] == t[i + 1], (name, t[i], t[i + 1])  # the two rows of one event
    # at the slip event's first row the raw margin is already past the boundary
    i = np.flatnonzero(r["rolling"][1:] != r["rolling"][:-1])[0]
    assert 100.0 * r["N"][i] - r["Ft"][i] < 0 and r["rolling"][i]


def test_ball_me_in_a_circling_chamber_with_exact_inputs_is_the_library(native):
    """An importer that supplies the platform motion itself at every derivative call (here the
    circle's exact x1O..ay1O): the ball's states integrated by scipy agree with the library's run."""
    circle = Circle(l=0.02, w=2.0 * math.pi)
    f = Fmu(native["BallInShell"], "me_circle", interface="me")
    vr = {n: f.vars[n].valueReference for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O", "xC", "yC", "N")}
    try:
        def inputs(t):
            f.fmu.setReal([vr[n] for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")], list(circle.state(t)))
        inputs(0.0)
        assert f.init() == 0, f.messages()
        f.fmu.newDiscreteStates()
        f.fmu.enterContinuousTimeMode()
        x = np.zeros(6)
        dx = np.zeros(6)
        px, pdx = (a.ctypes.data_as(ctypes.POINTER(ctypes.c_double)) for a in (x, dx))
        f.fmu.getContinuousStates(px, 6)
        x0 = x.copy()

        def rhs(t, y):
            f.fmu.setTime(t)
            inputs(t)
            x[:] = y
            f.fmu.setContinuousStates(px, 6)
            f.fmu.getDerivatives(pdx, 6)
            return dx.copy()
        times = np.linspace(0.0, 1.5, 151)
        sol = solve_ivp(rhs, (0.0, 1.5), x0, method="DOP853", rtol=1e-11, atol=1e-13, t_eval=times)
        assert sol.success
        m = BallModel(Ball(), tol=1e-12)
        lib = simulate(m, circle, 1.5, 0.01, m.initial())
        d = Ball().d
        assert np.abs(sol.y[0] * d - lib["xC"]).max() < 1e-8
        assert np.abs(sol.y[1] * d - lib["yC"]).max() < 1e-8
        # the outputs at the last state the importer set: the library's N there
        f.fmu.setTime(1.5)
        inputs(1.5)
        x[:] = sol.y[:, -1]
        f.fmu.setContinuousStates(px, 6)
        assert f.get("N") == pytest.approx(lib["N"][-1], abs=1e-6)
    finally:
        f.free()


def test_fig1_drive_me_is_its_co_simulation_with_time_events(native):
    """No states: ME's outputs are co-simulation's (which tests/test_fig1drive.py checks against
    the library) at the same times, and fmpy stops at the laws' kinks."""
    start = dict(frame_law=1, t0_frame=0.72, t0=1.13, law=2)  # off fmpy's output grid
    names = ["phi", "phi_dot", "psi", "psi_ddot", "x1O", "az1O", "Omega_dot_z", "Omega_dot_x", "T_crank"]
    me = simulate_fmu(str(native["Fig1Drive"]), fmi_type="ModelExchange", stop_time=2.0, output_interval=0.05,
                      start_values=start, record_events=True, output=names)
    assert 0.72 in me["time"] and 1.13 in me["time"]
    cs = simulate_fmu(str(native["Fig1Drive"]), fmi_type="CoSimulation", stop_time=2.0, output_interval=0.05,
                      start_values=start, output=names)
    me = me[np.isin(me["time"], cs["time"])]
    me = _unique(me)
    assert np.array_equal(me["time"], cs["time"])
    for name in names:
        assert np.array_equal(me[name], cs[name]), name


@pytest.mark.parametrize("start_mode", [1, 2])
def test_induction_motor_me_is_the_library_run_up(native, start_mode):
    from ballmill.physics.drives.induction import CrankDrive, InductionMotor, simulate_runup
    r = simulate_fmu(str(native["InductionMotor"]), fmi_type="ModelExchange", stop_time=3.0,
                     output_interval=0.05, start_values=dict(start_mode=start_mode, ramp_time=1.0),
                     relative_tolerance=1e-10, record_events=True, output=["psi", "psi_dot", "T_motor", "W_motor"])
    if start_mode == 2:
        assert 1.0 in r["time"]  # the time event where the voltage ramp ends
    drive = CrankDrive(motor=InductionMotor(start=("dol", "voltage_ramp")[start_mode - 1], ramp_time=1.0))
    lib = simulate_runup(drive, 3.0, rtol=1e-12, atol=1e-12)
    r = _unique(r)
    y = lib.sol(r["time"])
    scale = float(np.abs(y[1]).max())  # crank speed, about 6.5 rad/s
    assert np.abs(r["psi_dot"] - y[1]).max() < 1e-7 * scale
    assert np.abs(r["psi"] - y[0]).max() < 1e-7 * scale * 3.0


def test_structure_me_is_the_library_structure(native):
    from ballmill.absorber.model import simulate_structure
    from ballmill.absorber.structure import HarmonicForce, Structure
    """At resonance (16 periods, the amplitude growing to 0.13 m) CVode's error grows with time:
    measured 4.6e-8 of the amplitude at relative_tolerance 1e-11 (4.5e-7 at 1e-10, 3e-6 at 1e-9:
    it follows the importer's tolerance, the library runs at 1e-12)."""
    r = _unique(simulate_fmu(str(native["Structure"]), fmi_type="ModelExchange", stop_time=20.0,
                             output_interval=0.1, start_values=dict(F0_x=10.0, n_y=0), relative_tolerance=1e-11,
                             output=["x_rel", "E", "W_exc"]))
    lib = simulate_structure(Structure.single(100.0, 0.8, 0.01, both_axes=False), HarmonicForce(10.0, 0.8), 20.0, 0.1,
                             tol=1e-12)
    x = np.asarray(lib.data["xO"])
    assert np.abs(r["x_rel"] - x).max() < 2e-7 * np.abs(x).max()
    assert np.abs(r["W_exc"] - np.asarray(lib.data["W_exc"])).max() < 1e-6 * np.abs(lib.data["W_exc"]).max()


@pytest.mark.parametrize("model, start", [("BallInShell", dict(xC0=0.05, wz0=2.0)), ("InductionMotor", {}),
                                          ("Structure", {})])
def test_derivatives_declare_the_inputs_they_depend_on(native, model, start):
    """ModelStructure/Derivatives lists, for each derivative, the inputs it depends on (with every
    state): changing one input at a time changes only derivatives that list it, and the ball's
    der(n) (kinematics of rolling) lists none while its der(w) lists ax1O, ay1O."""
    md = read_model_description(str(native[model]))
    declared = {d.variable.name: {v.name for v in d.dependencies} for d in md.derivatives}
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    f = Fmu(native[model], "deps", interface="me", **start)
    try:
        assert f.set(**{name: 0.3 for name in inputs if not name.startswith("Q")}) == 0
        assert f.init() == 0, f.messages()
        f.fmu.newDiscreteStates()
        f.fmu.enterContinuousTimeMode()
        f.fmu.setTime(0.01)
        nx = len(md.derivatives)
        dx = np.zeros(nx)
        p = dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        f.fmu.getDerivatives(p, nx)
        base = dx.copy()
        seen = set()
        for name in inputs:
            if name.startswith("Q"):  # the rotation matrix (motion = 2) stays a rotation
                continue
            old = f.get(name)
            assert f.set(**{name: old + 0.7}) == 0
            f.fmu.getDerivatives(p, nx)
            assert f.set(**{name: old}) == 0
            for d, a, b in zip(md.derivatives, base, dx):
                if a != b:
                    seen.add((d.variable.name, name))
                    assert name in declared[d.variable.name], (d.variable.name, name)
        assert seen  # the inputs do act on the derivatives
        if model == "BallInShell":
            assert {n for n, i in seen} == {"der(w_x)", "der(w_y)", "der(w_z)"}
            assert all(declared[f"der(n_{a})"] == {"n_x", "n_y", "n_z", "w_x", "w_y", "w_z"} for a in "xyz")
            assert declared["der(w_x)"] >= {"ax1O", "ay1O"} and "x1O" not in declared["der(w_x)"]
    finally:
        f.free()
