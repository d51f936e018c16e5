"""ballmill.absorber.linear against closed forms derived here, not read from the module.

* The ball on a one-mode axis is a classic tuned-mass damper in the coordinates (x, v):
  x the cavity, v = (1 + iota) u the absorbing mass m_a = m / (1 + iota) relative to it
  (module docstring). Its 2x2 harmonic equations, solved here, give the cavity's and the
  ball's complex amplitudes for a force and for a ground acceleration.
* On any number of modes the ball's own row of the equations ties u to the cavity:
  (m g / d - W^2 (1 + iota) m + i W c) u = W^2 m x_O (force), = W^2 m x_O - m (ground).
* Small numbers: omega_b^2 = g / ((1 + iota) (R - r)); zeta = c / (2 sqrt(k_u m_u));
  the rolling resistance's work per cycle 4 U / r * delta m g against pi c W U^2; decay
  time 1 / (zeta omega); the exact H-infinity optimum of a TMD on an undamped structure
  (Nishihara and Asami, J. Vib. Acoust. 124 (2002) 576).
"""
from __future__ import annotations

import cmath
import math
import warnings

import numpy as np
import pytest

from ballmill.absorber import linear as lin
from ballmill.absorber.structure import Mode, Structure, StructureAxis
from ballmill.physics import Ball

M, F_S, ZETA_S = 100.0, 0.8, 0.01
G, IOTA = 9.7, 0.5  # not the defaults, so that a dropped argument shows


def a_ball():
    """r = 25 mm, 2 kg, hollow-ish (iota = 0.5), g = 9.7, R - r = 0.3 m, drag 0.6 N s/m."""
    return Ball(r=0.025, R=0.325, m=2.0, g=G, inertia_factor=IOTA, drag=0.6, rolling_resistance=2e-4)


def tmd_response(W, ball, load="force", mass=M, f=F_S, zeta=ZETA_S):
    """(x, u) complex amplitudes per unit load: the classic 2-DOF TMD in (x, v)."""
    m, iota = ball.m, ball.inertia_factor
    m_a = m / (1 + iota)
    Mp = mass + iota * m / (1 + iota)
    w = 2 * math.pi * f
    k, c = mass * w * w, 2 * zeta * mass * w
    k_a = m * ball.g / ((1 + iota) ** 2 * (ball.R - ball.r))
    c_a = ball.drag / (1 + iota) ** 2
    A = np.array([[k - W * W * (Mp + m_a) + 1j * W * c, -W * W * m_a],
                  [-W * W * m_a, k_a - W * W * m_a + 1j * W * c_a]])
    rhs = [1.0, 0.0] if load == "force" else [-(mass + m), -m_a]
    x, v = np.linalg.solve(A, rhs)
    return x, v / (1 + iota)


def test_small_numbers_of_the_ball():
    b = a_ball()
    w_b = math.sqrt(G / ((1 + IOTA) * 0.3))
    assert lin.ball_frequency(b) == pytest.approx(w_b / (2 * math.pi), rel=1e-13)
    assert lin.ball_frequency(b) == pytest.approx(0.7389, abs=1e-4)  # 4.643 rad/s
    # zeta = c / (2 sqrt(k_u m_u)) of the ball's row: k_u = m g / d, m_u = (1 + iota) m
    zeta = 0.6 / (2 * math.sqrt(2.0 * G / 0.3 * (1 + IOTA) * 2.0))
    assert lin.damping_ratio_of_drag(b) == pytest.approx(zeta, rel=1e-13)
    assert lin.damping_ratio_of_drag(b) == pytest.approx(0.02154, abs=1e-5)
    # rolling resistance: per cycle of amplitude U the ball turns 4 U / r, against the
    # moment delta m g; a drag c dissipates pi c W U^2
    for f, U in ((0.7, 0.02), (1.3, 0.005)):
        c = lin.drag_equivalent_of_rolling_resistance(b, f, U)
        W = 2 * math.pi * f
        assert math.pi * c * W * U * U == pytest.approx(4 * U / 0.025 * 2e-4 * 2.0 * G, rel=1e-13)
    assert lin.drag_equivalent_of_rolling_resistance(b, 0.7, 0.02) == pytest.approx(
        4 * 2e-4 * 2.0 * G / (math.pi * 0.025 * 2 * math.pi * 0.7 * 0.02), rel=1e-13)


def test_frf_and_ball_frf_are_the_tuned_mass_damper():
    """One mode: the cavity's and the ball's complex amplitudes against the 2x2 TMD, for a
    force and a ground acceleration (and the default load is the force)."""
    b = a_ball()
    la = lin.LinearAbsorber(StructureAxis.single(M, F_S, ZETA_S), b)
    freqs = [0.3, 0.7, 0.72, 0.76, 0.8, 1.5]
    for load in ("force", "ground"):
        want = np.array([tmd_response(2 * math.pi * f, b, load) for f in freqs])
        assert np.allclose(la.frf(freqs, load), want[:, 0], rtol=1e-11, atol=0)
        assert np.allclose(la.ball_frf(freqs, load), want[:, 1], rtol=1e-11, atol=0)
    assert np.array_equal(la.ball_frf(freqs), la.ball_frf(freqs, "force"))
    assert np.array_equal(la.frf(freqs), la.frf(freqs, "force"))


def test_ball_frf_on_two_modes_obeys_the_balls_equation():
    """Two modes, force applied elsewhere (psi != phi): u is the last coordinate, tied to
    the cavity by the ball's own row, for both loads."""
    b = a_ball()
    ax = StructureAxis((Mode(100.0, 0.8, 0.01, shape=1.0, force_shape=0.6, participation=140.0),
                        Mode(40.0, 2.3, 0.02, shape=-0.5, force_shape=0.9, participation=-30.0)))
    la = lin.LinearAbsorber(ax, b)
    freqs = np.array([0.5, 0.72, 0.9, 2.2, 2.5])
    W = 2 * math.pi * freqs
    den = b.m * G / 0.3 - W * W * (1 + IOTA) * b.m + 1j * W * 0.6
    for load, extra in (("force", 0.0), ("ground", -b.m)):
        u = la.ball_frf(freqs, load)
        assert np.allclose(u, (W * W * b.m * la.frf(freqs, load) + extra) / den, rtol=1e-10, atol=0)
        # and not a modal coordinate: the response's other columns differ
        resp = la.response(freqs, load)
        assert np.array_equal(u, resp[:, 2])
        assert not np.allclose(u, resp[:, 1]) and not np.allclose(u, resp[:, 0])


def test_the_bare_structure_has_no_ball():
    bare = lin.LinearAbsorber(StructureAxis.single(M, F_S, ZETA_S))
    with pytest.raises(ValueError) as err:
        bare.ball_frf([0.8])
    assert str(err.value) == "the bare structure has no ball"


def test_steady_state_is_the_harmonic_at_the_phase():
    """q = |X| sin(theta + arg X), q' = W |X| cos(theta + arg X) for a load A sin(theta):
    the default phase is 0 and the default load the force."""
    b = a_ball()
    axis = StructureAxis.single(M, F_S, ZETA_S)
    la = lin.LinearAbsorber(axis, b)
    A, f = 3.0, 0.74
    W = 2 * math.pi * f
    for load, theta in (("force", 0.0), ("force", 0.7), ("ground", 2.0)):
        x, u = (A * z for z in tmd_response(W, b, load))
        args = (A, f, theta, load) if theta else (A, f)
        if load == "ground":
            q, qd, uu, ud = la.steady_state(A, f, theta, load="ground")
        else:
            q, qd, uu, ud = la.steady_state(*args)
        assert q.shape == qd.shape == (1,)
        assert q[0] == pytest.approx(abs(x) * math.sin(theta + cmath.phase(x)), rel=1e-10)
        assert qd[0] == pytest.approx(W * abs(x) * math.cos(theta + cmath.phase(x)), rel=1e-10)
        assert uu == pytest.approx(abs(u) * math.sin(theta + cmath.phase(u)), rel=1e-10)
        assert ud == pytest.approx(W * abs(u) * math.cos(theta + cmath.phase(u)), rel=1e-10)
        assert type(uu) is float and type(ud) is float
    # the bare structure: a single mass, X = A / (K - W^2 M + i W C)
    q, qd, uu, ud = lin.LinearAbsorber(axis).steady_state(A, f, 0.7)
    w = 2 * math.pi * F_S
    X = A / (M * w * w - W * W * M + 1j * W * 2 * ZETA_S * M * w)
    assert q[0] == pytest.approx(abs(X) * math.sin(0.7 + cmath.phase(X)), rel=1e-10)
    assert qd[0] == pytest.approx(W * abs(X) * math.cos(0.7 + cmath.phase(X)), rel=1e-10)
    assert (uu, ud) == (0.0, 0.0)


def test_slowest_decay_time():
    """Two uncoupled modes: 1 / (zeta omega) of the slower; an undamped one never decays."""
    ax = StructureAxis((Mode(100.0, 0.8, 0.01), Mode(40.0, 2.3, 0.002)))
    t = lin.LinearAbsorber(ax).slowest_decay_time()
    assert type(t) is float
    assert t == pytest.approx(1 / (0.002 * 2 * math.pi * 2.3), rel=1e-9)  # 34.6 s, the second
    ax = StructureAxis((Mode(100.0, 0.8, 0.01), Mode(40.0, 2.3, 0.02)))
    assert lin.LinearAbsorber(ax).slowest_decay_time() == pytest.approx(1 / (0.01 * 2 * math.pi * 0.8), rel=1e-9)
    assert lin.LinearAbsorber(StructureAxis.single(M, F_S, 0.0)).slowest_decay_time() == math.inf


def test_linear_models_per_axis():
    b = a_ball()
    x, y = StructureAxis.single(M, F_S, ZETA_S), StructureAxis.single(50.0, 1.1, 0.02)
    mx, my = lin.linear_models(Structure(x, y), b)
    assert (mx.axis, mx.ball, my.axis, my.ball) == (x, b, y, b)
    mx, my = lin.linear_models(Structure(x, None), None)
    assert my is None and mx.axis is x and mx.ball is None and mx.M.shape == (1, 1)


def test_peak_of_outside_the_resonances_is_the_band_edge():
    """Above both peaks |x_O / F| falls: no peak inside [2, 3] Hz, the highest value is the
    band's lower edge, the TMD's |x| there (with the ball, not the bare structure's)."""
    b = a_ball()
    axis = StructureAxis.single(M, F_S, ZETA_S)
    got = lin.peak_of(axis, b, 2.0, 3.0)
    assert type(got) is float
    assert got == pytest.approx(abs(tmd_response(2 * math.pi * 2.0, b)[0]), rel=1e-11)
    bare = 1 / abs(M * (2 * math.pi) ** 2 * (F_S ** 2 - 4.0 + 2j * ZETA_S * F_S * 2.0))
    assert abs(got / bare - 1) > 1e-3


class Bowl:
    """A stand-in for peak_of: 1 + ((f_b - 0.75 Hz) / s_f)^2 + ((zeta_b - 0.1) / s_z)^2;
    records every (f_b, zeta_b, ball, f_lo, f_hi) it is asked about. Steep in the frequency
    and shallow in the damping (s_f = 1e-3, s_z = 1), the parameter tolerance (xatol 1e-6)
    decides where the search stops; steep in both (1e-3), the cost tolerance (fatol 1e-9)."""

    F, Z = 0.75, 0.1

    def __init__(self, s_f=1e-3, s_z=1.0):
        self.s_f, self.s_z = s_f, s_z
        self.calls = []

    def __call__(self, axis, ball, f_lo, f_hi):
        fb, zb = lin.ball_frequency(ball), lin.damping_ratio_of_drag(ball)
        self.calls.append((fb, zb, ball, f_lo, f_hi))
        return 1.0 + ((fb - self.F) / self.s_f) ** 2 + ((zb - self.Z) / self.s_z) ** 2


@pytest.mark.parametrize("s_z", [1.0, 1e-3])
def test_optimum_search_start_tolerances_and_defaults(monkeypatch, s_z):
    """From Den Hartog's tuning (the first point asked about), Nelder-Mead stops within its
    tolerances of the minimum (xatol 1e-6: zeta_b within 3e-6 of a shallow minimum; fatol
    1e-9: the cost within 1e-8 of a steep one); the ball is built with g = 9.81 and
    iota = 0.4 by default, and nothing warns (every option is one Nelder-Mead knows)."""
    bowl = Bowl(1e-3, s_z)
    monkeypatch.setattr(lin, "peak_of", bowl)
    axis = StructureAxis.single(M, F_S, ZETA_S)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fb, zb, peak, ball = lin.optimum(axis, 0.025, 2.0, 0.6, 1.0)
    m_a, Mp = 2.0 / 1.4, M + 0.4 * 2.0 / 1.4
    f_main = F_S * math.sqrt(M / Mp)
    fr, zt, _ = lin.den_hartog(m_a / Mp)
    f0, z0 = bowl.calls[0][:2]
    assert (f0, z0) == (pytest.approx(f_main * fr, rel=1e-12), pytest.approx(zt, rel=1e-12))
    assert all(c[3:] == (0.6, 1.0) for c in bowl.calls)
    assert abs(fb - Bowl.F) < 1e-7 and abs(zb - Bowl.Z) < 3e-6, (fb - Bowl.F, zb - Bowl.Z)
    assert peak == bowl(axis, ball, 0.6, 1.0) and peak < 1 + 1e-8, peak - 1
    assert (ball.r, ball.m, ball.g, ball.inertia_factor) == (0.025, 2.0, 9.81, 0.4)
    assert ball.R == lin.cavity_radius(fb, 0.025)


@pytest.mark.parametrize("start", [(0.0, 0.05), (0.76, 0.0), (0.76, -0.01)])
def test_optimum_keeps_out_of_the_forbidden_region(monkeypatch, start):
    """A start with f_b = 0 or a negative damping ratio is penalised, not evaluated (f_b = 0
    has no cavity); zeta_b = 0 is a legal ball and is evaluated."""
    bowl = Bowl()
    monkeypatch.setattr(lin, "peak_of", bowl)
    fb, zb, peak, ball = lin.optimum(StructureAxis.single(M, F_S, ZETA_S), 0.025, 2.0, 0.6, 1.0, start=start)
    assert all(c[0] > 0 for c in bowl.calls)
    if start[1] == 0.0:
        assert bowl.calls[0][:2] == (pytest.approx(0.76, rel=1e-13), 0.0)
    else:
        assert all(c[1] > 0 for c in bowl.calls)
    if start[1] >= 0.0:
        assert abs(fb - Bowl.F) < 1e-6 and abs(zb - Bowl.Z) < 1e-4


def test_cavity_radius_and_its_refusals():
    # R = r + g / ((1 + iota) (2 pi f)^2), g = 9.81 and iota = 0.4 by default
    assert lin.cavity_radius(0.5, 0.03) == pytest.approx(0.03 + 9.81 / (1.4 * math.pi ** 2), rel=1e-14)
    assert lin.cavity_radius(0.5, 0.03, G, IOTA) == pytest.approx(0.03 + G / (1.5 * math.pi ** 2), rel=1e-14)
    for bad in (0.0, -0.5, math.inf, math.nan):
        with pytest.raises(ValueError) as err:
            lin.cavity_radius(bad, 0.03)
        assert str(err.value) == f"frequency must be positive and finite, got {bad!r} Hz"


def test_equivalent_tmd_of_a_scaled_damped_mode():
    """A mode of shape phi = 2 at the absorber: the mass, stiffness and damping seen there
    are M / phi^2, K / phi^2, C / phi^2; the ball's part m / (1 + iota), its spring
    m g / ((1 + iota)^2 d), its damper c / (1 + iota)^2."""
    b = a_ball()
    md = Mode(400.0, 0.8, 0.02, shape=2.0)
    tmd = lin.equivalent_tmd(StructureAxis((md,)), b)
    w = 2 * math.pi * 0.8
    assert tmd.M_main == pytest.approx(100.0 + IOTA * 2.0 / (1 + IOTA), rel=1e-14)
    assert tmd.m_a == pytest.approx(2.0 / 1.5, rel=1e-14)
    assert tmd.k_main == pytest.approx(100.0 * w * w, rel=1e-14)
    assert tmd.c_main == pytest.approx(2 * 0.02 * 100.0 * w, rel=1e-14)
    assert tmd.k_a == pytest.approx(2.0 * G / (1.5 ** 2 * 0.3), rel=1e-14)
    assert tmd.c_a == pytest.approx(0.6 / 1.5 ** 2, rel=1e-14)
    # and its derived numbers: the ball's own frequency and damping ratio, the mode's
    assert tmd.f_a == pytest.approx(lin.ball_frequency(b), rel=1e-13)
    assert tmd.zeta_a == pytest.approx(lin.damping_ratio_of_drag(b), rel=1e-13)
    assert tmd.mu == pytest.approx((2.0 / 1.5) / (100.0 + 2.0 / 3.0), rel=1e-14)
    assert tmd.f_main == pytest.approx(0.8 * math.sqrt(100.0 / tmd.M_main), rel=1e-14)
    assert tmd.zeta_main == pytest.approx(0.02 * math.sqrt(100.0 / tmd.M_main), rel=1e-13)
    with pytest.raises(ValueError) as err:
        lin.equivalent_tmd(StructureAxis((md, Mode(40.0, 2.3))), b)
    assert str(err.value) == "the equivalent TMD is defined for one mode, the axis has 2"


def test_den_hartog_ball_carries_its_arguments():
    """A big ball (r = 0.3 m, larger than the default cavity) with g, iota and extra ball
    parameters that are not the defaults: tuned to f_main / (1 + mu) with the mu and f_main
    of a ball of that iota, its drag from Den Hartog's damping ratio, the rest passed on."""
    axis = StructureAxis.single(2000.0, 0.5, 0.0)
    b = lin.den_hartog_ball(axis, 0.3, 40.0, g=G, inertia_factor=IOTA, mu=0.5, rolling_resistance=1e-4)
    m_a, Mp = 40.0 / 1.5, 2000.0 + IOTA * 40.0 / 1.5
    mu = m_a / Mp
    f_main = 0.5 * math.sqrt(2000.0 / Mp)
    fr, zeta, _ = lin.den_hartog(mu)
    assert (b.r, b.m, b.g, b.inertia_factor, b.mu, b.rolling_resistance) == (0.3, 40.0, G, IOTA, 0.5, 1e-4)
    assert b.R == pytest.approx(0.3 + G / (1.5 * (2 * math.pi * f_main * fr) ** 2), rel=1e-13)
    assert lin.ball_frequency(b) == pytest.approx(f_main / (1 + mu), rel=1e-13)
    assert lin.damping_ratio_of_drag(b) == pytest.approx(zeta, rel=1e-13)
    # any size: a 10 mm ball on a 10 Hz mode (its cavity smaller than the default ball) and
    # a 12 m ball (larger than g in metres), each tuned to f_main / (1 + mu)
    for axis, r, m in ((StructureAxis.single(5.0, 10.0), 0.01, 0.1), (StructureAxis.single(1e6, 0.2), 12.0, 5e4)):
        b = lin.den_hartog_ball(axis, r, m)
        tmd = lin.equivalent_tmd(axis, b)
        assert b.r == r and b.R > r
        assert lin.ball_frequency(b) == pytest.approx(tmd.f_main / (1 + tmd.mu), rel=1e-13)


def test_modes_keep_the_oscillating_ones():
    """A bare axis of a slow mode (0.1 Hz: omega < 1 rad/s), a fast one and an overdamped
    one (zeta = 2: no frequency): the two that oscillate, ascending, with their ratios."""
    ax = StructureAxis((Mode(50.0, 2.0, 0.05), Mode(100.0, 0.1, 0.01), Mode(10.0, 1.0, 2.0)))
    f, z = lin.LinearAbsorber(ax).modes()
    assert np.allclose(f, [0.1, 2.0], rtol=1e-10) and np.allclose(z, [0.01, 0.05], rtol=1e-8)


def bare_peak(mass, f, zeta):
    """Frequency and height of |x / F| of a single mass: f sqrt(1 - 2 zeta^2), 1 / (2 zeta
    sqrt(1 - zeta^2) K)."""
    K = mass * (2 * math.pi * f) ** 2
    return f * math.sqrt(1 - 2 * zeta ** 2), 1 / (2 * zeta * math.sqrt(1 - zeta ** 2) * K)


PEAK_GRIDS = [  # (f_lo, f_hi, n): the 0.8 Hz, zeta 0.05 peak (0.79800 Hz) at index 1, 2, n - 2
    (0.75, 0.85, 3), (0.7, 0.9, 5), (0.79, 0.83, 5), (0.72, 0.82, 5), (0.5, 1.5, 4001)]


@pytest.mark.parametrize("f_lo, f_hi, n", PEAK_GRIDS)
def test_peaks_refine_to_the_closed_form(f_lo, f_hi, n):
    """On coarse grids the golden-section refinement, not the grid, gives the peak: to 1e-8
    of its frequency and 1e-12 of its height, wherever it falls in the grid."""
    la = lin.LinearAbsorber(StructureAxis.single(M, F_S, 0.05))
    fp, hp = bare_peak(M, F_S, 0.05)
    got = la.peaks(f_lo, f_hi, n=n) if n != 4001 else la.peaks(f_lo, f_hi)
    assert len(got) == 1
    assert got[0][0] == pytest.approx(fp, abs=1e-8)
    assert got[0][1] == pytest.approx(hp, rel=1e-12)
    assert type(got[0][1]) is float


def test_peaks_none_on_a_falling_or_flat_band():
    la = lin.LinearAbsorber(StructureAxis.single(M, F_S, 0.05))
    assert la.peaks(1.5, 3.0, n=50) == []  # falls from the band's start: no peak there
    assert la.peaks(0.1, 0.5, n=50) == []  # rises to the band's end: no peak there
    assert la.peaks(0.8, 0.8, n=5) == []  # one frequency: a flat band has no peak


def test_peaks_of_the_ground_response():
    """With the ball, a ground acceleration loads the ball too: its two peaks are not the
    force's. Each peak is the largest |frf| on a 1e-7 Hz grid around it (to 1e-12)."""
    la = lin.LinearAbsorber(StructureAxis.single(M, F_S, ZETA_S), a_ball())
    for load in ("ground", "force"):
        pk = la.peaks(0.6, 1.0, load, n=41)
        assert len(pk) == 2
        for fp, hp in pk:
            dense = fp + 1e-7 * np.arange(-200, 201)
            assert hp == pytest.approx(np.abs(la.frf(dense, load)).max(), rel=1e-12)
            assert hp >= np.abs(la.frf(dense, load)).max() * (1 - 1e-13)
        if load == "ground":
            ground = pk
    force = la.peaks(0.6, 1.0, "force", n=41)
    assert abs(ground[0][0] - force[0][0]) > 4e-4 and abs(ground[1][0] - force[1][0]) > 5e-5


def test_peaks_follow_the_load_they_are_asked_for():
    """Two uncoupled modes; the second has no participation in a ground acceleration
    (L_2 = 0) but is pushed by the force (psi_2 = 0.9): the ground response has one peak
    (the first mode's), the force response two, each at its closed form."""
    ax = StructureAxis((Mode(100.0, 0.8, 0.02, shape=1.0, force_shape=1.0, participation=100.0),
                        Mode(40.0, 2.3, 0.02, shape=0.5, force_shape=0.9, participation=0.0)))
    la = lin.LinearAbsorber(ax)
    (fg, hg), = la.peaks(0.5, 3.0, "ground", n=501)
    fp, hp = bare_peak(100.0, 0.8, 0.02)
    assert fg == pytest.approx(fp, abs=2e-4)  # the second mode's tail moves it a little
    assert hg == pytest.approx(np.abs(la.frf(fg + 1e-7 * np.arange(-50, 51), "ground")).max(), rel=1e-12)
    force = la.peaks(0.5, 3.0, "force", n=501)
    assert len(force) == 2 and force[1][0] == pytest.approx(2.3 * math.sqrt(1 - 2 * 0.02 ** 2), abs=2e-3)


# the slowest last (a real search, about 3 s)
@pytest.fixture(scope="module")
def exact_optimum():
    """optimum() on an undamped one-mode axis (m / M = 0.2, g and iota not the defaults),
    run once with warnings as errors, and the Nishihara-Asami optimum of its TMD."""
    axis = StructureAxis.single(M, F_S, 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fb, zb, peak, ball = lin.optimum(axis, 0.02, 20.0, 0.5, 1.2, g=G, inertia_factor=IOTA)
    m_a = 20.0 / (1 + IOTA)
    Mp = M + IOTA * 20.0 / (1 + IOTA)
    mu = m_a / Mp
    f_main = math.sqrt(M * (2 * math.pi * F_S) ** 2 / Mp) / (2 * math.pi)
    gamma = 2 / (1 + mu) * math.sqrt(2 * (16 + 23 * mu + 9 * mu ** 2 + 2 * (2 + mu) * math.sqrt(4 + 3 * mu))
                                     / (3 * (64 + 80 * mu + 27 * mu ** 2)))
    zeta = 0.25 * math.sqrt((8 + 9 * mu - 4 * math.sqrt(4 + 3 * mu)) / (1 + mu))
    return axis, (fb, zb, peak, ball), (f_main * gamma, zeta)


def test_optimum_finds_the_exact_h_infinity_optimum(exact_optimum):
    axis, (fb, zb, peak, ball), (fb_exact, zeta_exact) = exact_optimum
    assert fb == pytest.approx(fb_exact, rel=1e-6)
    assert zb == pytest.approx(zeta_exact, rel=1e-5)
    # the peak it reports is the linear model's, at the optimum and no higher than the exact one's
    exact_ball = Ball(r=0.02, R=lin.cavity_radius(fb_exact, 0.02, G, IOTA), m=20.0, g=G, inertia_factor=IOTA)
    exact_ball = exact_ball.with_(drag=lin.drag_for_damping_ratio(zeta_exact, exact_ball))
    assert peak == pytest.approx(lin.peak_of(axis, exact_ball, 0.5, 1.2), rel=1e-8)


def test_optimum_returns_the_ball_it_found(exact_optimum):
    axis, (fb, zb, peak, ball), _ = exact_optimum
    assert (ball.r, ball.m, ball.g, ball.inertia_factor) == (0.02, 20.0, G, IOTA)
    assert ball.R == lin.cavity_radius(fb, 0.02, G, IOTA)
    assert lin.ball_frequency(ball) == pytest.approx(fb, rel=1e-13)
    assert lin.damping_ratio_of_drag(ball) == pytest.approx(zb, rel=1e-13)
    assert peak == lin.peak_of(axis, ball, 0.5, 1.2)
    assert all(type(v) is float for v in (fb, zb, peak))
