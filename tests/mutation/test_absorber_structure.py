"""ballmill.absorber.structure: the modal structure and its excitations, value by value.

* Every refusal's text, word for word (the FMU adapters pass them on unchanged): the
  parameter's name, the value as given and its unit.
* Mode, StructureAxis and Structure: defaults, conversions, K = M omega^2, C = 2 zeta M omega,
  the flexibility sum phi^2 / M.
* The excitations: the chirp's phase theta = phase + 2 pi (f s + 1/2 rate s^2) and its
  instantaneous frequency, the per-axis components, a retuned excitation continuing with
  the same phase, a ground record's linear interpolation and its CSV reader.
* StructureModel on a two-mode x axis and a one-mode y axis with every coefficient
  different: the modal equations M q'' + C q' + K q = psi F - L a_g + phi F_ball written out
  by hand per mode, the cavity's motion x_O = sum phi q and a_O = a_g + sum phi q'', the
  energy and the powers.
"""
from __future__ import annotations

import math

import pytest

from ballmill.absorber.structure import (GroundRecord, HarmonicForce, HarmonicGround, Mode, NoExcitation,
                                         Structure, StructureAxis, StructureModel)
from ballmill.physics.errors import ParameterError

TWO_PI = 2.0 * math.pi


def refused(call, text):
    with pytest.raises(ParameterError) as err:
        call()
    assert str(err.value) == text


MODE_REFUSALS = [
    (dict(mass="heavy"), "mode mass must be a number in kg, got mode mass = 'heavy'"),
    (dict(mass=None), "mode mass must be a number in kg, got mode mass = None"),
    (dict(mass=math.inf), "mode mass must be finite, got mode mass = inf kg"),
    (dict(mass=0.0), "mode mass must be positive, got mode mass = 0.0 kg"),
    (dict(mass=-3), "mode mass must be positive, got mode mass = -3 kg"),
    (dict(frequency=math.nan), "mode frequency must be finite, got mode frequency = nan Hz"),
    (dict(frequency=0), "mode frequency must be positive, got mode frequency = 0 Hz"),
    (dict(damping=-0.01), "mode damping ratio must be non-negative, got mode damping ratio = -0.01 1"),
    (dict(damping=[0.1]), "mode damping ratio must be a number in 1, got mode damping ratio = [0.1]"),
    (dict(shape=-math.inf), "mode shape at the absorber must be finite, got mode shape at the absorber = -inf 1"),
    (dict(force_shape="x"), "mode shape at the force must be a number in 1, got mode shape at the force = 'x'"),
    (dict(force_shape=math.inf), "mode shape at the force must be finite, got mode shape at the force = inf 1"),
    (dict(participation=math.nan), "mode participation must be finite, got mode participation = nan kg"),
]


@pytest.mark.parametrize("bad, text", MODE_REFUSALS, ids=[t[:40] for _, t in MODE_REFUSALS])
def test_mode_refusals(bad, text):
    kw = dict(mass=10.0, frequency=1.0)
    kw.update(bad)
    refused(lambda: Mode(**kw), text)


def test_mode_values_and_defaults():
    md = Mode(8, 2, 0, -3)  # ints in, floats out; zero damping and a negative shape are legal
    assert (md.mass, md.frequency, md.damping, md.shape, md.force_shape, md.participation) == (8.0, 2.0, 0.0, -3.0, -3.0, -24.0)
    assert all(type(v) is float for v in (md.mass, md.frequency, md.damping, md.shape, md.force_shape,
                                          md.participation))
    md = Mode("40", 0.5, 0.02, shape=0.0, force_shape=-2, participation=-7)
    assert (md.mass, md.shape, md.force_shape, md.participation) == (40.0, 0.0, -2.0, -7.0)
    assert type(md.force_shape) is float and type(md.participation) is float
    w = TWO_PI * 0.5
    assert md.omega == pytest.approx(w, rel=1e-15)
    assert md.stiffness == pytest.approx(40.0 * w * w, rel=1e-15)
    assert md.damping_coefficient == pytest.approx(2 * 0.02 * 40.0 * w, rel=1e-15)


def test_axes_and_structures():
    refused(lambda: StructureAxis(()), "a structure axis needs at least one mode, got modes = ()")
    refused(lambda: StructureAxis([]), "a structure axis needs at least one mode, got modes = ()")
    refused(lambda: StructureAxis((Mode(1.0, 1.0), 3.5)), "modes[1] must be a Mode, got 3.5")
    refused(lambda: StructureAxis(("m",)), "modes[0] must be a Mode, got 'm'")
    a, b = Mode(100.0, 0.8, 0.01, shape=0.5), Mode(40.0, 2.3, 0.02, shape=-2.0)
    ax = StructureAxis([a, b])
    assert ax.modes == (a, b) and type(ax.modes) is tuple and ax.n == 2
    assert ax.flexibility == pytest.approx(0.25 / 100.0 + 4.0 / 40.0, rel=1e-15)
    one = StructureAxis.single(50.0, 1.2, 0.03)
    assert one.modes == (Mode(50.0, 1.2, 0.03, 1.0, 1.0, 50.0),) and one.n == 1
    assert StructureAxis.single(50.0, 1.2).modes[0].damping == 0.0
    refused(lambda: Structure(a), f"Structure.x must be a StructureAxis, got {a!r}")
    refused(lambda: Structure(ax, a), f"Structure.y must be a StructureAxis or None, got {a!r}")
    st = Structure(ax)
    assert st.y is None and st.axes == (ax, None) and st.n_states == 4
    st = Structure(ax, one)
    assert st.axes == (ax, one) and st.n_states == 6
    both = Structure.single(70.0, 0.9, 0.04)
    assert both.x == both.y == StructureAxis.single(70.0, 0.9, 0.04) and both.n_states == 4
    x_only = Structure.single(70.0, 0.9, 0.04, both_axes=False)
    assert x_only.x == StructureAxis.single(70.0, 0.9, 0.04) and x_only.y is None and x_only.n_states == 2
    assert Structure.single(70.0, 0.9).x.modes[0].damping == 0.0


# ---------------------------------------------------------------------------- excitations

HARMONIC_REFUSALS = [
    ("amplitude_x", math.inf, "amplitude_x must be finite, got amplitude_x = inf {unit}"),
    ("amplitude_y", "a lot", "amplitude_y must be a number in {unit}, got amplitude_y = 'a lot'"),
    ("phase", math.nan, "phase must be finite, got phase = nan rad"),
    ("phase_y", None, "phase_y must be a number in rad, got phase_y = None"),
    ("sweep_rate", -math.inf, "sweep_rate must be finite, got sweep_rate = -inf Hz/s"),
    ("t0", math.inf, "t0 must be finite, got t0 = inf s"),
    ("frequency", 0.0, "frequency must be positive, got frequency = 0.0 Hz"),
    ("frequency", -1, "frequency must be positive, got frequency = -1 Hz"),
    ("frequency", math.nan, "frequency must be finite, got frequency = nan Hz"),
]


@pytest.mark.parametrize("cls, unit", [(HarmonicForce, "N"), (HarmonicGround, "m/s2")])
def test_harmonic_refusals(cls, unit):
    for name, value, text in HARMONIC_REFUSALS:
        refused(lambda: cls(**{name: value}), text.format(unit=unit))


@pytest.mark.parametrize("cls", [HarmonicForce, HarmonicGround])
def test_harmonic_phase_law_components_and_retuning(cls):
    h = cls(3, 0.5, -2, 0.3, 1.1, 0.04, 2)  # ints in, floats out
    assert [type(getattr(h, k)) for k in ("amplitude_x", "frequency", "amplitude_y", "phase", "phase_y",
                                          "sweep_rate", "t0")] == [float] * 7
    assert cls().amplitude_x == 0.0 and cls().frequency == 1.0 and cls().amplitude_y == 0.0
    assert (cls().phase, cls().phase_y, cls().sweep_rate, cls().t0) == (0.0, 0.0, 0.0, 0.0)
    for t in (2.0, 3.7, 11.25):
        s = t - 2.0
        theta = 0.3 + TWO_PI * (0.5 * s + 0.02 * s * s)
        assert h.theta(t) == pytest.approx(theta, rel=1e-14, abs=1e-15)
        assert h.instantaneous_frequency(t) == pytest.approx(0.5 + 0.04 * s, rel=1e-15)
        fx, fy = 3.0 * math.sin(theta), -2.0 * math.sin(theta + 1.1)
        want = (fx, fy, 0.0, 0.0) if cls is HarmonicForce else (0.0, 0.0, fx, fy)
        assert h.loads(t) == pytest.approx(want, rel=1e-12, abs=1e-14)
    # retuned at t = 7: the same amplitudes and phase_y, the phase it has there (mod 2 pi),
    # the new steady frequency from t0 = 7, no sweep
    r = h.retuned(0.9, 7.0)
    assert type(r) is cls
    assert (r.amplitude_x, r.amplitude_y, r.phase_y, r.frequency, r.sweep_rate, r.t0) == (3.0, -2.0, 1.1, 0.9, 0.0, 7.0)
    assert r.phase == pytest.approx(math.fmod(0.3 + TWO_PI * (0.5 * 5 + 0.02 * 25), TWO_PI), rel=1e-13)
    assert 0.0 <= r.phase < TWO_PI
    assert r.theta(7.0) == pytest.approx(math.fmod(h.theta(7.0), TWO_PI), rel=1e-14)
    assert r.loads(7.0) == pytest.approx(h.loads(7.0), rel=1e-12, abs=1e-14)
    assert r.instantaneous_frequency(8.0) == 0.9


def test_no_excitation():
    assert NoExcitation().loads(3.0) == (0.0, 0.0, 0.0, 0.0)
    assert NoExcitation().frequency(3.0) == 0.0


RECORD_REFUSALS = [
    ((0.0,), (1.0,), (1.0,), "a ground record needs at least 2 samples and columns of equal length, "
                             "got 1 times, 1 ax, 1 ay"),
    ((0.0, 1.0), (1.0,), (1.0, 2.0), "a ground record needs at least 2 samples and columns of equal length, "
                                     "got 2 times, 1 ax, 2 ay"),
    ((0.0, 1.0), (1.0, 2.0), (1.0,), "a ground record needs at least 2 samples and columns of equal length, "
                                     "got 2 times, 2 ax, 1 ay"),
    ((0.0, math.nan), (1.0, 2.0), (0.0, 0.0), "ground record row 2: time nan s, ax 2.0, ay 0.0 m/s2 must be finite"),
    ((0.0, 1.0), (math.inf, 2.0), (0.0, 0.0), "ground record row 1: time 0.0 s, ax inf, ay 0.0 m/s2 must be finite"),
    ((0.0, 1.0), (1.0, 2.0), (0.0, -math.inf), "ground record row 2: time 1.0 s, ax 2.0, ay -inf m/s2 must be finite"),
    ((0.0, 1.0, 1.0), (0.0,) * 3, (0.0,) * 3, "ground record times must increase strictly, got t = 1.0 then 1.0 s at row 3"),
    ((0.0, 2.0, 1.0), (0.0,) * 3, (0.0,) * 3, "ground record times must increase strictly, got t = 2.0 then 1.0 s at row 3"),
]


@pytest.mark.parametrize("t, ax, ay, text", RECORD_REFUSALS, ids=[str(i) for i in range(len(RECORD_REFUSALS))])
def test_ground_record_refusals(t, ax, ay, text):
    refused(lambda: GroundRecord(t, ax, ay), text)
    refused(lambda: GroundRecord(t, ax, ay, source="quake.csv"), text + " (quake.csv)")


def test_ground_record_interpolates_and_is_zero_outside():
    rec = GroundRecord([1, 2, 4], [0.0, 2.0, -1.0], [1.0, 0.0, 3.0], source="s")
    assert rec.t == (1.0, 2.0, 4.0) and rec.ax == (0.0, 2.0, -1.0) and rec.ay == (1.0, 0.0, 3.0)
    assert all(type(v) is float for v in rec.t) and type(rec.t) is tuple
    assert rec.duration == 3.0 and rec.breakpoints() == (1.0, 2.0, 4.0) and rec.kind == "ground"
    cases = [(0.5, (0.0, 0.0)), (1.0, (0.0, 1.0)), (1.5, (1.0, 0.5)), (2.0, (2.0, 0.0)), (2.5, (1.25, 0.75)),
             (3.5, (-0.25, 2.25)), (4.0, (-1.0, 3.0)), (4.0000001, (0.0, 0.0)), (9.0, (0.0, 0.0))]
    for t, (ax, ay) in cases:
        got = rec.loads(t)
        assert got[:2] == (0.0, 0.0)
        assert got[2:] == pytest.approx((ax, ay), rel=1e-14, abs=1e-15), t


def test_ground_record_from_csv(tmp_path):
    p = tmp_path / "g.csv"
    p.write_text("time,ax,ay,other\n0,0.5,-1\n0.5,1.5,2\n1.0,-0.5,0\n".replace(",-1\n", ",-1,7\n"))
    rec = GroundRecord.from_csv(p)
    assert rec.t == (0.0, 0.5, 1.0) and rec.ax == (0.5, 1.5, -0.5) and rec.ay[:2] == (-1.0, 2.0)
    assert rec.source == str(p)
    # other column names; ay absent, or not asked for: zero
    q = tmp_path / "h.csv"
    q.write_text("s,a_x\n0,1\n2,3\n")
    rec = GroundRecord.from_csv(q, time="s", ax="a_x")
    assert rec.t == (0.0, 2.0) and rec.ax == (1.0, 3.0) and rec.ay == (0.0, 0.0)
    rec = GroundRecord.from_csv(p, ay=None)
    assert rec.ay == (0.0, 0.0, 0.0)
    empty = tmp_path / "e.csv"
    empty.write_text("time,ax,ay\n")
    refused(lambda: GroundRecord.from_csv(empty), f"{empty}: no data rows")
    refused(lambda: GroundRecord.from_csv(q), f"{q}: column 'time' missing, found ['a_x', 's']")
    refused(lambda: GroundRecord.from_csv(q, time="s"), f"{q}: column 'ax' missing, found ['a_x', 's']")
    # one data row: the record's own refusal, naming the file
    one = tmp_path / "one.csv"
    one.write_text("time,ax,ay\n0,1,2\n")
    refused(lambda: GroundRecord.from_csv(one), "a ground record needs at least 2 samples and columns of "
                                                 f"equal length, got 1 times, 1 ax, 1 ay ({one})")
    # the csv module's own line handling: a quoted name with a CR LF inside is read verbatim
    crlf = tmp_path / "crlf.csv"
    crlf.write_bytes(b'time,"a\r\nx",ay\r\n0,1,2\r\n1,3,4\r\n')
    assert GroundRecord.from_csv(crlf, ax="a\r\nx").ax == (1.0, 3.0)
    bad = tmp_path / "b.csv"
    bad.write_text("time,ax,ay\n0,1,2\n1,x,2\n")
    refused(lambda: GroundRecord.from_csv(bad), f"{bad}: could not convert string to float: 'x'")
    bad.write_text("time,ax,ay\n0,1,2\n1,1,y\n")
    refused(lambda: GroundRecord.from_csv(bad), f"{bad}: could not convert string to float: 'y'")
    bad.write_text("time,ax,ay\n0,1,2\nt,1,2\n")
    refused(lambda: GroundRecord.from_csv(bad), f"{bad}: could not convert string to float: 't'")


# ---------------------------------------------------------------------------- the model

X1 = Mode(100.0, 0.8, 0.01, shape=1.5, force_shape=0.6, participation=140.0)
X2 = Mode(40.0, 2.3, 0.02, shape=-0.5, force_shape=0.9, participation=-30.0)
Y1 = Mode(70.0, 1.1, 0.03, shape=0.8, force_shape=1.3, participation=55.0)


def modal(md):
    w = TWO_PI * md.frequency
    return md.mass, md.mass * w * w, 2 * md.damping * md.mass * w, md.shape, md.force_shape, md.participation


def test_structure_model_refuses_what_is_not_a_structure():
    refused(lambda: StructureModel(StructureAxis((X1,))),
            f"structure must be a Structure, got {StructureAxis((X1,))!r}")
    assert isinstance(StructureModel(Structure(StructureAxis((X1,)))).excitation, NoExcitation)


def test_initial_states():
    sm = StructureModel(Structure(StructureAxis((X1, X2)), StructureAxis((Y1,))))
    assert sm.n_states == 6 and sm.initial() == [0.0] * 6
    # layout (q_x1, q_x2, q_x1', q_x2', q_y1, q_y1')
    assert sm.initial([1, 2], [3, 4], 5, [6]) == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    assert sm.initial(qdx=(0.5, -0.5)) == [0.0, 0.0, 0.5, -0.5, 0.0, 0.0]
    assert sm.initial(qy=2) == [0.0, 0.0, 0.0, 0.0, 2.0, 0.0]
    assert sm.initial(qdy=[-1]) == [0.0, 0.0, 0.0, 0.0, 0.0, -1.0]
    assert all(type(v) is float for v in sm.initial([1, 2], [3, 4], 5, [6]))
    refused(lambda: sm.initial(qx=[1.0]), "qx needs 2 values (one per mode of axis x), got 1")
    refused(lambda: sm.initial(qdx=1.0), "qdx needs 2 values (one per mode of axis x), got 1")
    refused(lambda: sm.initial(qy=[1.0, 2.0]), "qy needs 1 values (one per mode of axis y), got 2")
    refused(lambda: sm.initial(qdy=[1.0, 2.0, 3.0]), "qdy needs 1 values (one per mode of axis y), got 3")
    x_only = StructureModel(Structure(StructureAxis((X1, X2))))
    assert x_only.n_states == 4 and x_only.initial([1, 2], [3, 4]) == [1.0, 2.0, 3.0, 4.0]
    assert x_only.flexibility == (pytest.approx(1.5 ** 2 / 100.0 + 0.25 / 40.0, rel=1e-15), 0.0)
    refused(lambda: x_only.initial(qy=[1.0]), "qy needs 0 values (one per mode of axis y), got 1")


class Loads:
    def __init__(self, loads):
        self.value = loads
        self.asked = []

    def loads(self, t):
        self.asked.append(t)
        return self.value


def test_structure_model_equations_by_hand():
    """Every output of the model at one state and load against the modal equations."""
    exc = Loads((2.0, -3.0, 0.4, -0.7))  # F_x, F_y [N], a_gx, a_gy [m/s2]
    sm = StructureModel(Structure(StructureAxis((X1, X2)), StructureAxis((Y1,))), exc)
    zs = [0.01, -0.02, 0.3, 0.05, -0.04, 0.2]  # q_x1, q_x2, q_x1', q_x2', q_y1, q_y1'
    Fbx, Fby = 5.0, -1.5
    Fx, Fy, gx, gy = exc.value
    q = {"x1": (zs[0], zs[2], X1, Fx, gx), "x2": (zs[1], zs[3], X2, Fx, gx), "y1": (zs[4], zs[5], Y1, Fy, gy)}
    free = {}
    for k, (qq, qd, md, F, g) in q.items():
        Mj, Kj, Cj, phi, psi, L = modal(md)
        free[k] = (psi * F - L * g - Cj * qd - Kj * qq) / Mj
    ax_free = gx + 1.5 * free["x1"] - 0.5 * free["x2"]
    ay_free = gy + 0.8 * free["y1"]
    got = sm.free_acceleration(zs, exc.value)
    assert got[0] == pytest.approx(ax_free, rel=1e-13) and got[1] == pytest.approx(ay_free, rel=1e-13)
    assert got[2] == pytest.approx([free["x1"], free["x2"]], rel=1e-13)
    assert got[3] == pytest.approx([free["y1"]], rel=1e-13)

    dz = sm.derivative(1.25, zs, Fbx, Fby)
    assert exc.asked == [1.25]
    want = [zs[2], zs[3], free["x1"] + 1.5 * Fbx / 100.0, free["x2"] - 0.5 * Fbx / 40.0,
            zs[5], free["y1"] + 0.8 * Fby / 70.0]
    assert dz == pytest.approx(want, rel=1e-13)
    assert sm.derivative(9.0, zs, Fbx, Fby, loads=exc.value) == pytest.approx(want, rel=1e-13)
    assert exc.asked == [1.25]  # loads given: the excitation is not asked

    Gx, Gy = 1.5 ** 2 / 100.0 + 0.25 / 40.0, 0.8 ** 2 / 70.0
    assert sm.flexibility == (pytest.approx(Gx, rel=1e-15), pytest.approx(Gy, rel=1e-15))
    cav = sm.cavity(2.5, zs, Fbx, Fby)
    assert exc.asked == [1.25, 2.5]
    want = (1.5 * zs[0] - 0.5 * zs[1], 0.8 * zs[4], 1.5 * zs[2] - 0.5 * zs[3], 0.8 * zs[5],
            ax_free + Gx * Fbx, ay_free + Gy * Fby)
    assert cav == pytest.approx(want, rel=1e-13)
    # a_O = a_g + sum phi q'', with q'' from the derivative: the split a_free + G F_ball is exact
    assert cav[4] == pytest.approx(gx + 1.5 * dz[2] - 0.5 * dz[3], rel=1e-13)
    assert cav[5] == pytest.approx(gy + 0.8 * dz[5], rel=1e-13)
    assert sm.cavity(7.0, zs, Fbx, Fby, loads=exc.value) == pytest.approx(want, rel=1e-13)
    assert exc.asked == [1.25, 2.5]

    E = sum(0.5 * modal(md)[0] * qd ** 2 + 0.5 * modal(md)[1] * qq ** 2 for qq, qd, md, _, _ in q.values())
    assert sm.energy(zs) == pytest.approx(E, rel=1e-13)
    P_exc = sum(qd * (modal(md)[4] * F - modal(md)[5] * g) for _, qd, md, F, g in q.values())
    P_damp = sum(modal(md)[2] * qd * qd for _, qd, md, _, _ in q.values())
    assert sm.powers(zs, exc.value) == (pytest.approx(P_exc, rel=1e-13), pytest.approx(P_damp, rel=1e-13))


def test_structure_model_with_a_fixed_y_axis():
    """y = None: the cavity follows the ground in y (x_O = 0, a_O = a_g, no G F_ball)."""
    exc = Loads((1.0, 4.0, 0.2, -0.9))
    sm = StructureModel(Structure(StructureAxis((X1,))), exc)
    zs = [0.02, -0.1]
    Mj, Kj, Cj, phi, psi, L = modal(X1)
    r = (psi * 1.0 - L * 0.2 - Cj * zs[1] - Kj * zs[0]) / Mj
    assert sm.free_acceleration(zs, exc.value) == (pytest.approx(0.2 + phi * r, rel=1e-13), -0.9,
                                                   [pytest.approx(r, rel=1e-13)], [])
    assert sm.derivative(0.0, zs, 3.0, 8.0) == pytest.approx([zs[1], r + phi * 3.0 / Mj], rel=1e-13)
    assert sm.cavity(0.0, zs, 3.0, 8.0) == pytest.approx(
        (phi * zs[0], 0.0, phi * zs[1], 0.0, 0.2 + phi * r + phi * phi / Mj * 3.0, -0.9), rel=1e-13)
    assert sm.energy(zs) == pytest.approx(0.5 * Mj * zs[1] ** 2 + 0.5 * Kj * zs[0] ** 2, rel=1e-13)
    assert sm.powers(zs, exc.value) == (pytest.approx(zs[1] * (psi - L * 0.2), rel=1e-13),
                                        pytest.approx(Cj * zs[1] ** 2, rel=1e-13))
