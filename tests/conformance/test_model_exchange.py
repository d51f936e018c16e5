"""Model Exchange calls a hostile importer tries, on the native FMUs that have Model
Exchange (docs/conformance.md): each refused with fmi2Error and a message naming the
call, the value and what was expected, the instance keeping its state; and the calls an
importer may make that change nothing (an event update with no event pending)."""
import ctypes

import numpy as np
import pytest

from .conftest import ERROR, OK, fmi3_paths
from .conftest import native_paths as _native_build
from .harness import Fmu, driver, fmi_name

from .conftest import MODELS as ME_MODELS  # every model has Model Exchange
STATEFUL = ("BallInShell", "InductionMotor", "Structure")


@pytest.fixture(scope="module")
def native_paths(fmu_build_dir):
    return _native_build(fmu_build_dir)


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def version(request):
    return request.param


@pytest.fixture(scope="module")
def me_paths(native_paths, version):
    """the archives of FMI version `version`: build/<Model>.fmu or build/fmi3/<Model>.fmu"""
    return native_paths if version == 2 else fmi3_paths(native_paths)


def _open(path, name, version, **parameters):
    return driver(version)(path, name, interface="me", **parameters)


def _ptr(a):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _running(path, name="me", version=2, **parameters):
    """An ME instance after initialisation, in continuous-time mode"""
    f = _open(path, name, version, **parameters)
    assert f.init() == OK, f.messages()
    assert f.call("newDiscreteStates")[0] == OK
    assert f.call("enterContinuousTimeMode")[0] == OK
    return f


def _nx(f):
    return f.md.numberOfContinuousStates


def _states(f):
    x = np.zeros(_nx(f))
    assert f.call("getContinuousStates", _ptr(x), _nx(f))[0] == OK
    return x


@pytest.mark.parametrize("call", ["getDerivatives", "getContinuousStates"])
@pytest.mark.parametrize("model", STATEFUL)
def test_get_derivatives_before_initialisation_is_refused(me_paths, version, model, call):
    f = _open(me_paths[model], "me", version)
    try:
        dx = np.zeros(_nx(f))
        assert f.call(call, _ptr(dx), _nx(f))[0] == ERROR
        name = call[0].upper() + call[1:]
        assert f"{fmi_name(version, name)} is not allowed in state {fmi_name(version, 'instantiated')}" \
            in f.messages()
        assert f.init() == OK  # the instance stays usable
    finally:
        f.free()


@pytest.mark.parametrize("model", ("BallInShell", "MotorStartup"))
def test_enter_event_mode_before_initialisation_is_refused(me_paths, version, model):
    f = _open(me_paths[model], "me", version)
    try:
        assert f.call("enterEventMode")[0] == ERROR
        assert f"{fmi_name(version, 'EnterEventMode')} is not allowed in state {fmi_name(version, 'instantiated')}" \
            in f.messages()
        assert f.init() == OK  # the instance stays usable
    finally:
        f.free()


@pytest.mark.parametrize("model", ME_MODELS)
def test_set_time_backwards_is_refused_and_time_kept(me_paths, version, model):
    f = _running(me_paths[model], version=version)
    try:
        assert f.call("setTime", 0.2)[0] == OK
        assert f.call("setTime", 0.15)[0] == OK  # within the step: a solver may go back
        assert f.call("setTime", 0.2)[0] == OK
        assert f.call("completedIntegratorStep")[0] == OK
        n = len(f.log)
        st, _ = f.call("setTime", 0.1)
        assert st == ERROR
        msg = f.messages(n)
        assert "time = 0.1 s refused" in msg and "before the last accepted time 0.2 s" in msg, msg
        st, _ = f.call("setTime", float("nan"))
        assert st == ERROR and "time = nan s refused: it must be finite" in f.messages(n)
    finally:
        f.free()


@pytest.mark.parametrize("model, k, text", [("BallInShell", 4, "w_y = nan rad/s refused"),
                                            ("InductionMotor", 1, "s_psi_dot = nan rad/s refused"),
                                            ("Structure", 6, "s_qd_x1 = nan m/s refused")])
def test_nan_continuous_state_is_refused_and_states_kept(me_paths, version, model, k, text):
    f = _running(me_paths[model], version=version)
    try:
        nx = _nx(f)
        before = _states(f)
        bad = before.copy()
        bad[k] = np.nan
        n = len(f.log)
        assert f.call("setContinuousStates", _ptr(bad), nx)[0] == ERROR
        msg = f.messages(n)
        assert text in msg and "must be finite" in msg, msg
        assert np.array_equal(_states(f), before)
        assert f.call("setContinuousStates", _ptr(before), nx - 1)[0] == ERROR
        assert f"nx = {nx - 1} refused: this FMU has {nx}" in f.messages(n)
    finally:
        f.free()


@pytest.mark.parametrize("model", STATEFUL)
def test_states_set_in_event_mode_are_refused(me_paths, version, model):
    f = _running(me_paths[model], version=version)
    try:
        before = _states(f)
        assert f.call("enterEventMode")[0] == OK
        x = before + 0.01
        n = len(f.log)
        assert f.call("setContinuousStates", _ptr(x), _nx(f))[0] == ERROR
        assert f"{fmi_name(version, 'SetContinuousStates')} is not allowed in state {fmi_name(version, 'eventMode')}" \
            in f.messages(n)
        assert np.array_equal(_states(f), before)
    finally:
        f.free()


@pytest.mark.parametrize("model", ME_MODELS)
def test_event_update_with_no_event_changes_nothing(me_paths, version, model):
    f = _running(me_paths[model], version=version)
    try:
        assert f.call("setTime", 0.3)[0] == OK
        before = f.outputs()
        assert f.call("enterEventMode")[0] == OK
        st, info = f.call("newDiscreteStates")
        assert st == OK
        assert not info[0]  # newDiscreteStatesNeeded / discreteStatesNeedUpdate
        assert f.outputs() == before
        assert [m for s, m in f.log if s > OK] == []
    finally:
        f.free()


def test_non_finite_input_refuses_the_evaluation(native_paths):
    f = _running(native_paths["BallInShell"], xC0=0.05)
    try:
        dx = np.zeros(6)
        assert f.call("getDerivatives", _ptr(dx), 6)[0] == OK
        good = dx.copy()
        assert f.set(ax1O=float("inf")) == OK
        n = len(f.log)
        assert f.call("getDerivatives", _ptr(dx), 6)[0] == ERROR
        assert "input ax1O = inf refused at t = 0.0 s: it must be finite" in f.messages(n)
        assert f.set(ax1O=0.0) == OK
        assert f.call("getDerivatives", _ptr(dx), 6)[0] == OK and np.array_equal(dx, good)
    finally:
        f.free()


@pytest.mark.parametrize("parameters, expected", [
    (dict(input_mode=2), "input_mode = 2 (supported: input_mode = 1 or 4"),
    (dict(input_mode=3), "input_mode = 3 (supported: input_mode = 1 or 4"),
    (dict(formulation=2), "formulation = 2 (supported: formulation = 1"),
    (dict(motion=2, input_mode=3), "motion = 2 (supported: motion = 1, a translating chamber")])
def test_configurations_me_cannot_run_are_refused_at_initialisation(me_paths, version, parameters, expected):
    f = _open(me_paths["BallInShell"], "me", version, **parameters)
    try:
        assert f.init() == ERROR
        assert "Model Exchange" in f.messages() and expected in f.messages()
    finally:
        f.free()


def test_model_exchange_refuses_the_hybrid_contact(me_paths, version):
    """contact_model = 2: the hybrid ball's states change with its mode (rolling's n, omega are
    one of them), so Model Exchange refuses it at initialisation, naming it."""
    f = _open(me_paths["BallInShell"], "me", version, contact_model=2)
    try:
        assert f.init() == ERROR
        assert "contact_model = 2" in f.messages(), f.messages()
    finally:
        f.free()


@pytest.mark.parametrize("model", STATEFUL)
def test_states_set_lower_or_higher_are_what_the_derivatives_see(me_paths, version, model):
    """After setContinuousStates, the derivatives are those of the states just set, whether each
    went up or down: the same as a second instance given those states directly."""
    f, g = _running(me_paths[model], "me_f", version), _running(me_paths[model], "me_g", version)
    try:
        x = _states(f)
        dx, dg = np.zeros(_nx(f)), np.zeros(_nx(f))
        assert f.call("getDerivatives", _ptr(dx), _nx(f))[0] == OK  # evaluated at x
        at_x = dx.copy()
        for shift in (-1e-3, 2e-3):
            y = x + shift * (1.0 + np.abs(x))
            if model == "BallInShell":  # its states are n (a unit vector) and omega: keep |n| = 1
                y[:3] = x[:3] + shift * np.array([0.05, 0.0, 0.0])
                y[:3] /= np.linalg.norm(y[:3])
            for inst in (f, g):
                assert inst.call("setContinuousStates", _ptr(y), _nx(f))[0] == OK
            assert f.call("getDerivatives", _ptr(dx), _nx(f))[0] == OK
            assert g.call("getDerivatives", _ptr(dg), _nx(f))[0] == OK
            assert np.array_equal(dx, dg) and not np.array_equal(dx, at_x), (shift, dx, dg, at_x)
    finally:
        f.free()
        g.free()


@pytest.mark.parametrize("input_mode", [1, 4])
def test_the_input_modes_model_exchange_runs_are_accepted(me_paths, version, input_mode):
    """input_mode 1 and 4 read the acceleration inputs as set, all Model Exchange needs."""
    f = _running(me_paths["BallInShell"], version=version, input_mode=input_mode, xC0=0.05)
    try:
        dx = np.zeros(_nx(f))
        assert f.call("getDerivatives", _ptr(dx), _nx(f))[0] == OK and np.any(dx != 0.0)
    finally:
        f.free()


# co-simulation answers the Model Exchange variables the archive publishes for both interfaces
# from its own state: (parameters, inputs while stepping, inputs set before the read)
CS_LOCALS = {
    "BallInShell": (dict(xC0=0.05, wy0=0.5), {}, dict(ax1O=0.3, ay1O=-0.2)),
    "InductionMotor": ({}, dict(M_reaction=2.0), dict(M_reaction=-3.0)),
    "Structure": ({}, dict(Fx_ball=4.0, Fy_ball=-2.0), dict(Fx_ball=-1.0, Fy_ball=5.0)),
}


def _cs_locals(f):
    """the co-simulation instance's continuous states, derivatives and event indicators, read by name"""
    md = f.md
    states = [d.variable.derivative.name for d in md.derivatives]
    ders = [d.variable.name for d in md.derivatives]
    indicators = [v.name for v in md.modelVariables if v.name.startswith("z_")]
    return [np.array([f.get(n) for n in names]) for names in (states, ders, indicators)]


@pytest.mark.parametrize("model", STATEFUL)
def test_co_simulation_reads_its_model_exchange_variables_from_its_own_state(me_paths, version, model):
    """a co-simulation instance's states are those it steps (their central difference over its
    own steps is its derivative), and its derivatives and event indicators are bit for bit what a
    Model Exchange instance set to the same time, states and inputs gives"""
    parameters, u_step, u_read = CS_LOCALS[model]
    cs = driver(version)(me_paths[model], "cs", **parameters)
    me = None
    try:
        assert cs.set(**u_step) == OK and cs.init() == OK
        h = 1e-3
        for _ in range(20):
            assert cs.step(h) == OK
        x0 = _cs_locals(cs)[0]
        assert cs.step(h) == OK
        x1, dx1, z1 = _cs_locals(cs)
        assert cs.step(h) == OK
        x2 = _cs_locals(cs)[0]
        # the derivative over the co-simulation's steps: central difference, error (h w)^2 / 6 for
        # the fastest rate w of the states that move (measured: 5e-6 of the largest derivative,
        # 8e-5 for the induction motor's fluxes); a state from elsewhere is off by order 1
        scale = np.abs(dx1).max()
        assert np.allclose((x2 - x0) / (2 * h), dx1, rtol=0, atol=5e-4 * scale), ((x2 - x0) / (2 * h), dx1)
        assert [m for s, m in cs.log if s > OK] == []
        # the inputs set now, the state of the last communication point
        dx_before = _cs_locals(cs)[1]
        assert cs.set(**u_read) == OK
        x, dx, z = _cs_locals(cs)
        assert np.array_equal(x, x2) and not np.array_equal(dx, dx_before)  # the inputs set now count
        # one read of the states, derivatives and outputs together gives each what its own read
        # gives (the Model Exchange variables come from the instance's work copy, the rest do not)
        kind = cs.vars[cs.md.derivatives[0].variable.name].type
        names = [n for n, v in cs.vars.items() if v.type == kind and v.causality in ("output", "local")]
        together = getattr(cs.fmu, "get" + cs.TYPES[kind][0])([cs.vars[n].valueReference for n in names])
        assert np.array_equal(np.array(together, dtype=float), [cs.get(n) for n in names], equal_nan=True)
        me = _running(me_paths[model], version=version, **parameters)
        assert me.set(**u_read) == OK
        assert me.call("setTime", cs.time)[0] == OK
        assert me.call("setContinuousStates", _ptr(x), len(x))[0] == OK
        dx_me = np.zeros(len(x))
        assert me.call("getDerivatives", _ptr(dx_me), len(x))[0] == OK
        assert np.array_equal(dx, dx_me), (dx, dx_me)
        if len(z):
            z_me = np.zeros(len(z))
            assert me.call("getEventIndicators", _ptr(z_me), len(z))[0] == OK
            assert np.array_equal(z, z_me), (z, z_me)
    finally:
        cs.free()
        if me is not None:
            me.free()


def test_co_simulation_refuses_model_exchange_variables_of_a_configuration_me_does_not_run(native_paths):
    f = Fmu(native_paths["BallInShell"], "cs", formulation=2, xC0=0.05)
    try:
        assert f.init() == OK and f.step(0.01) == OK
        good = f.outputs()
        v = f.vars["der(w_x)"]
        st, _ = f.call("getReal", [v.valueReference])
        assert st == ERROR
        msg = f.messages()
        assert "der(w_x) refused" in msg and "formulation = 2" in msg and "formulation = 1" in msg, msg
        assert f.outputs() == good and f.step(0.01) == OK
    finally:
        f.free()


def test_a_serialised_me_state_with_a_byte_changed_is_refused(native_paths):
    f = _running(native_paths["BallInShell"], xC0=0.05)
    g = None
    try:
        assert f.call("setTime", 0.1)[0] == OK
        x = _states(f) * 1.001
        assert f.call("setContinuousStates", _ptr(x), 6)[0] == OK
        blob = f.serialize(f.get_state())
        ok, restored = f.deserialize(blob)
        assert ok == OK
        assert f.call("setContinuousStates", _ptr(x * 0.5), 6)[0] == OK
        assert f.set_state(restored) == OK and np.array_equal(_states(f), x)
        flipped = bytearray(blob)
        flipped[200] ^= 0x01
        n = len(f.log)
        status, _ = f.deserialize(bytes(flipped))
        assert status == ERROR and "checksum mismatch" in f.messages(n)
        # a state of a Model Exchange instance does not fit a co-simulation instance (opened
        # last: fmpy's logger proxy reports to the newest instance's log)
        g = Fmu(native_paths["BallInShell"], "cs")
        assert g.init() == OK
        status, _ = g.deserialize(blob)
        assert status == ERROR and "state refused" in g.messages()
    finally:
        f.free()
        if g is not None:
            g.free()


@pytest.mark.parametrize("model, text", [("MotorStartup", "input M_reaction must be finite, got nan N.m"),
                                         ("InductionMotor", "input M_reaction must be finite, got nan N.m"),
                                         ("Fig1Drive", "input Fx must be finite, got nan N"),
                                         ("Structure", "input Fx_ball must be finite, got nan")])
def test_a_non_finite_input_is_refused_at_the_next_read(me_paths, version, model, text):
    f = _running(me_paths[model], version=version)
    try:
        name = text.split()[1]
        good = f.outputs()
        assert f.set(**{name: float("nan")}) == OK
        n = len(f.log)
        v = next(v for v in f.vars.values() if v.causality == "output" and v.type in ("Real", "Float64"))
        assert f.call("getReal", [v.valueReference])[0] == ERROR
        assert text in f.messages(n), f.messages(n)
        assert f.set(**{name: 0.0}) == OK
        assert f.outputs() == good
    finally:
        f.free()


class _Importer:
    """A hand-written Model Exchange importer on an instance in continuous-time mode: scipy's
    solve_ivp on the FMU's derivatives, with the slip indicator (index 1) as a terminal event."""

    def __init__(self, f):
        self.f = f
        self.x, self.dx, self.z = np.zeros(6), np.zeros(6), np.zeros(2)

    def at(self, t, y):
        self.x[:] = y
        assert self.f.call("setTime", t)[0] == OK
        assert self.f.call("setContinuousStates", _ptr(self.x), 6)[0] == OK

    def rhs(self, t, y):
        self.at(t, y)
        self.f.call("getDerivatives", _ptr(self.dx), 6)
        return self.dx.copy()

    def slip(self, t, y):
        self.at(t, y)
        self.f.call("getEventIndicators", _ptr(self.z), 2)
        return self.z[1]

    def slip_root(self, t_end=0.3):
        """(t, states) where solve_ivp located the slip indicator's root"""
        from scipy.integrate import solve_ivp

        def slip(t, y):
            return self.slip(t, y)
        slip.terminal = True
        sol = solve_ivp(self.rhs, (0.0, t_end), _states(self.f), method="DOP853", rtol=1e-10, atol=1e-12,
                        events=slip)
        (t_root,), (y_root,) = sol.t_events[0], sol.y_events[0]
        return t_root, y_root


def test_event_indicators_have_hysteresis_so_a_restart_at_the_root_does_not_retrigger(native_paths):
    """The ball spun at wy0 = -20 rad/s begins to slip (mu = 0.1): an importer (scipy's
    solve_ivp on the FMU's derivatives) locates the root of the slip indicator, handles the event
    there and restarts at that very state. The indicator carries the hysteresis the FMI standard
    recommends: before the event it is mu N - |F_t| + eps (so its root lies eps past the boundary,
    where the ball does slip), after the event update mu N - |F_t| - eps, clearly negative: no
    second crossing at the restart. eps = 1e-10 m g (the ball's weight)."""
    from ballmill.physics.params import Ball
    f = _running(native_paths["BallInShell"], wy0=-20.0, mu=0.1)
    try:
        eps = 1e-10 * Ball().m * Ball().g
        imp = _Importer(f)
        slip, z = imp.slip, imp.z
        t_root, y_root = imp.slip_root()
        assert 0.188 < t_root < 0.189
        imp.at(t_root, y_root)
        raw = 0.1 * f.get("N") - f.get("Ft")
        assert slip(t_root, y_root) == pytest.approx(raw + eps, abs=1e-15)
        assert abs(raw + eps) < 1e-3 * eps  # the root: eps past the boundary
        assert f.call("enterEventMode")[0] == OK and f.call("newDiscreteStates")[0] == OK
        assert f.call("enterContinuousTimeMode")[0] == OK
        assert not f.get("valid") and f.get("t_invalid") == t_root
        after = slip(t_root, y_root)
        assert after == pytest.approx(raw - eps, abs=1e-15) and after < -1.9 * eps
        # the contact indicator is on its own side, shifted the other way (N > 0: no event)
        f.call("getEventIndicators", _ptr(z), 2)
        assert z[0] == pytest.approx(f.get("N") + eps, abs=1e-15)
    finally:
        f.free()


def test_discrete_outputs_change_only_at_the_event_update(me_paths, version):
    """FMI (2.0 section 3.1, 3.0 section 3.1): discrete variables change only at event instants.
    The spun ball's `rolling` is judged from mu N - |F_t|, which turns negative eps (the
    indicator's hysteresis) before the slip indicator crosses 0: at the root the importer
    located, the raw margin is already negative, yet `rolling` (and `valid`) keep the values of
    the last event until the event update; after it, `rolling` is false. The continuous outputs
    (N, Ft) follow every evaluation."""
    f = _running(me_paths["BallInShell"], version=version, wy0=-20.0, mu=0.1)
    try:
        imp = _Importer(f)
        x0 = _states(f)
        assert f.get("rolling") and f.get("contact") and f.get("valid")
        t_root, y_root = imp.slip_root()
        assert 0.188 < t_root < 0.189
        imp.at(t_root, y_root)
        raw = 0.1 * f.get("N") - f.get("Ft")
        assert raw < 0  # the ball slips here by the raw margin ...
        assert f.get("rolling") and f.get("contact") and f.get("valid")  # ... but no event has been handled
        assert f.call("enterEventMode")[0] == OK
        assert f.get("rolling")  # event mode entered: still the old values until the update
        assert f.call("newDiscreteStates")[0] == OK
        assert not f.get("rolling") and f.get("contact") and not f.get("valid")
        assert f.call("enterContinuousTimeMode")[0] == OK
        # states set where the ball would roll (the start's): no event handled, so `rolling`
        # stays false, while N and Ft are those of the states set
        n_root = f.get("N")
        imp.at(t_root, x0)
        assert 0.1 * f.get("N") - f.get("Ft") > 0 and f.get("N") != n_root
        assert not f.get("rolling")
    finally:
        f.free()


def test_a_model_exchange_call_on_a_co_simulation_instance_is_refused_naming_both(native_paths):
    f = Fmu(native_paths["MotorStartup"], "cs_instance")
    try:
        assert f.init() == OK
        n = len(f.log)
        set_time = f.fmu.dll.fmi2SetTime  # not among fmpy's co-simulation calls: the binary's own
        set_time.argtypes, set_time.restype = [ctypes.c_void_p, ctypes.c_double], ctypes.c_int
        assert set_time(f.fmu.component, 0.1) == ERROR
        assert f.messages(n) == ("MotorStartup 'cs_instance': fmi2SetTime is a Model Exchange function; "
                                 "this instance is co-simulation")
        assert f.step(1e-3) == OK  # the instance goes on
    finally:
        f.free()
