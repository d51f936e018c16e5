"""`ballmill run --interface me`: the scenario master integrating every FMU's continuous
states as one ODE through FMI 2.0 Model Exchange (ballmill.scenario.me).

The coupled fast start (MotorStartup + BallInShell) against the monolithic library (the
ball driven by the exact crank law, DOP853 at tol 1e-13): with no communication step there is
no coupling error, so at the master's default tolerance (rtol = atol = 1e-10) the contact
point agrees to 1e-8 m and N to 1e-6 N, where co-simulation at the scenario's 2 ms step is
off by about 3e-4 N. The onset of slip is a state event located to the library's own root
of mu N - |F_t|; a scenario the Model Exchange path cannot run is refused before anything runs.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from ballmill import cli
from ballmill.physics import Ball, BallModel, CrankStartup, simulate
from ballmill.physics.model import BallState
from ballmill.scenario import runner

RECORD = [("ball", v) for v in ("xP", "yP", "zP", "N", "Ft", "M_reaction", "valid", "t_invalid")] + \
    [("drive", "T_drive")]


def _prepared(build_dir, *sets, stop, interface="me"):
    sc, models, paths = runner.prepare("fast_start", list(sets), build_dir, log=lambda m: None, interface=interface)
    sc.stop = stop
    sc.record = list(RECORD)
    return sc, models, paths


def _library(sc, stop):
    p, d = sc.instances["ball"].parameters, sc.instances["drive"].parameters
    ball = Ball(r=p["r"], R=p["R"], m=p["m"], mu=p["mu"])
    model = BallModel(ball, method="DOP853", tol=1e-13)
    crank = CrankStartup(l=d["l"], n0=d["n0"], t0=d["t0"])
    tr = simulate(model, crank, stop, sc.step)
    assert tr.success
    return model, crank, tr


@pytest.fixture(scope="module")
def fast_start(fmu_build_dir):
    """The fast start to 4 s (through the start-up's end at t0 = 2.5 s, a time event of the
    drive), through Model Exchange and co-simulation, and the library's solution."""
    sc, models, paths = _prepared(fmu_build_dir, stop=4.0)
    me = runner.run(sc, models, paths, progress=False, echo=False, interface="me")
    cs = runner.run(sc, models, paths, progress=False, echo=False, interface="cs")
    assert me.success and cs.success, (me.message, cs.message)
    return me, cs, _library(sc, 4.0)[2]


def _errors(res, tr):
    P = np.stack([res.column(f"ball.{v}") for v in ("xP", "yP", "zP")], axis=1)
    P_lib = np.stack([tr.out[v] for v in ("xP", "yP", "zP")], axis=1)
    return (float(np.max(np.linalg.norm(P - P_lib, axis=1))),
            float(np.max(np.abs(res.column("ball.N") - tr.out["N"]))))


def test_me_fast_start_matches_the_monolithic_library(fast_start):
    me, cs, tr = fast_start
    # recorded on the co-simulation's grid, which is the library's sampling
    assert np.array_equal(me.column("time"), cs.column("time"))
    np.testing.assert_allclose(me.column("time"), tr.t, rtol=0, atol=1e-12)
    assert me.interface == "me" and me.events >= 1  # the start-up law's switch at t0 = 2.5 s
    dP, dN = _errors(me, tr)
    assert dP <= 1e-8, f"contact point off the library's by {dP:.3g} m"
    assert dN <= 1e-6, f"N off the library's by {dN:.3g} N"
    # what Model Exchange removes: co-simulation's coupling error at the 2 ms step
    assert _errors(cs, tr)[1] > 1e-5


def test_me_reads_each_output_after_the_inputs_it_depends_on(fast_start):
    """The drive's torque T_drive = J_total psi'' - M_reaction (J_total = 0 here) follows the
    ball's M_reaction of the same instant: the connections are resolved in dependency order
    (drive motion -> ball -> M_reaction -> drive), not with a value one step old."""
    me, cs, _ = fast_start
    assert np.array_equal(me.column("drive.T_drive"), -me.column("ball.M_reaction"))
    assert not np.array_equal(cs.column("drive.T_drive"), -cs.column("ball.M_reaction"))


def test_me_locates_the_onset_of_slip_as_a_state_event(fmu_build_dir):
    """With mu = 0.12 the ball starts to slip at about 0.99 s: BallInShell's event indicator
    mu N - |F_t| crosses 0 there, and its t_invalid is the located event time, equal to the
    library's root of the same function to 1e-9 s (sampling the 2 ms grid would give ~1e-6 s)."""
    sc, models, paths = _prepared(fmu_build_dir, "ball.mu=0.12", stop=1.2)
    res = runner.run(sc, models, paths, progress=False, echo=False, interface="me")
    assert res.success, res.message
    assert res.column("ball.valid")[0] == 1.0 and res.column("ball.valid")[-1] == 0.0
    t_invalid = float(res.column("ball.t_invalid")[-1])
    model, crank, tr = _library(sc, 1.2)
    mu = sc.instances["ball"].parameters["mu"]
    margin = mu * tr.out["N"] - np.abs(tr.out["Ft"])
    k = int(np.argmax(margin < 0)) - 1
    assert k > 0
    start = BallState(float(tr.t[k]), tr.y[k], None)

    def g(s):
        st = model.advance(start, s, crank.accel) if s > start.t else start
        x, y, _, _, ax, ay = crank.state(s)
        o = model.outputs(st, ax, ay, x, y)
        return mu * o.N - abs(o.Ft)
    root = brentq(g, tr.t[k], tr.t[k + 1], xtol=1e-14)
    assert abs(t_invalid - root) <= 1e-9, (t_invalid, root)
    assert abs(tr.t_invalid - root) > 1e-7  # what the sampled library run says: coarser


def test_cli_refuses_me_for_fmus_without_model_exchange(fmu_build_dir, tmp_path, capsys):
    out = tmp_path / "out"
    rc = cli.main(["run", "fast_start", "--interface", "me", "--flavour", "pythonfmu", "--quiet",
                   "--build-dir", str(fmu_build_dir), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    for instance in ("instances.drive", "instances.ball"):
        assert instance in err
    assert "pythonfmu exports FMI 2.0 co-simulation only" in err and "--flavour native" in err
    assert not out.exists()  # refused before anything ran


def test_cli_me_configuration_the_fmu_refuses_stops_the_run_with_its_reason(fmu_build_dir, tmp_path, capsys):
    # input_mode 3 holds the inputs over a communication step: co-simulation only
    rc = cli.main(["run", "fast_start", "--interface", "me", "--quiet", "--set", "ball.input_mode=3",
                   "--set", "drive.t0=0.5", "--build-dir", str(fmu_build_dir), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 1
    assert "input_mode = 3" in err and "Model Exchange" in err


# --------------------------------------------------------------------------- work bounds
def _announcing(monkeypatch, model, first, gap):
    """A fault planted in one FMU as the master sees it: every fmi2NewDiscreteStates of `model`
    also announces a time event, at `first` s, then `gap` s after the one before (gap 0: the same
    instant again and again, an event loop; 1e-9 s: events a little apart, Zeno behaviour)."""
    from ballmill.scenario import me
    real_bare = me._bare
    due, now = [first], [0.0]

    def bare(fmu, name):
        fun = real_bare(fmu, name)
        if model not in str(fmu.modelIdentifier):
            return fun
        if name == "fmi2SetTime":  # the FMU's time, as the master sets it
            def set_time(comp, t):
                now[0] = t.value
                return fun(comp, t)
            return set_time
        if name != "fmi2NewDiscreteStates":
            return fun

        def announcing(comp, pinfo):
            status = fun(comp, pinfo)
            if now[0] >= due[0]:
                due[0] += gap
            info = pinfo._obj
            info.nextEventTimeDefined, info.nextEventTime = 1, due[0]
            return status
        return announcing
    monkeypatch.setattr(me, "_bare", bare)


@pytest.mark.parametrize("gap, bound, text", [
    (0.0, "MAX_EVENTS_AT_ONE_TIME", "events at t = 0.3 s without time advancing (MAX_EVENTS_AT_ONE_TIME): the "
     "model chatters; the last was instance drive (model MotorStartup)'s time event (nextEventTime = 0.3 s)"),
    (1e-9, "MAX_EVENTS_PER_INTERVAL", "30 events from t = 0.3 s to 0.30000003 s without reaching the next output "
     "point 0.302 s (MAX_EVENTS_PER_INTERVAL): instance drive (model MotorStartup)'s time event")])
def test_me_event_loop_stops_the_run_naming_time_instance_and_event(fmu_build_dir, monkeypatch, gap, bound, text):
    from ballmill.scenario import me
    monkeypatch.setattr(me, bound, 30)
    _announcing(monkeypatch, "MotorStartup", 0.3, gap)
    sc, models, paths = _prepared(fmu_build_dir, stop=0.5)
    res = runner.run(sc, models, paths, progress=False, echo=False, interface="me")
    assert not res.success
    assert res.message.startswith("the Model Exchange run stopped: ") and text in res.message, res.message
    t = res.column("time")
    assert t[-1] == pytest.approx(0.3, abs=1e-12)  # recorded up to the event, kept


def test_me_step_limit_stops_the_run_naming_the_fastest_state(fmu_build_dir, monkeypatch, tmp_path, capsys):
    """Derivatives that are not a function of (t, x) (planted: BallInShell's with noise of 1e-3
    rad/s2, as an input read before its source was set would make them) drive the integrator's
    step down: the run stops at the bound, naming the time and the state, with exit status 1."""
    from ballmill.scenario import me
    monkeypatch.setattr(me, "MAX_STEPS_PER_INTERVAL", 300)
    real_bare, rng = me._bare, np.random.default_rng(1)

    def bare(fmu, name):
        fun = real_bare(fmu, name)
        if name != "fmi2GetDerivatives" or "BallInShell" not in str(fmu.modelIdentifier):
            return fun

        def noisy(comp, pdx, nx):
            status = fun(comp, pdx, nx)
            for i in range(3, nx.value):
                pdx[i] += 1e-3 * rng.standard_normal()
            return status
        return noisy
    monkeypatch.setattr(me, "_bare", bare)
    rc = cli.main(["run", "fast_start", "--interface", "me", "--quiet", "--set", "drive.t0=0.5",
                   "--build-dir", str(fmu_build_dir), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 1
    assert "integrator took 300 steps from t = 0.0 s" in err and "without reaching the next output point 0.002 s" \
        in err, err
    assert "the fastest state is instance ball (model BallInShell)'s state w_" in err, err
