"""The material bed (docs/design.md section 2, "The material bed"): the ground material's
resistance acts only while the contact point is below the bed's surface zP = h_bed, blended
over w_bed below it; the grinding power P_grind against a hand computation, the energy balance
of ball, drive and grinding to the integrator's tolerance, the 'no bed' and 'full bed'
readings bit for bit, both FMU flavours bit for bit with the bed on, and the pre-run check
refusing a bed deeper than the chamber."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ballmill.physics import KERNEL_AVAILABLE, Ball, BallModel, CrankStartup, Fixed, simulate
from ballmill.physics.equations import ROLLING_EPS, bed_constants, bed_share
from ballmill.physics.errors import ParameterError
from ballmill.physics.integrators import Integrator
from ballmill.physics.outputs import energy, evaluate

ROOT = Path(__file__).resolve().parents[1]
DELTA, C_DRAG, H_BED, W_BED = 1e-3, 0.5, 0.05, 0.01
BALL = Ball(rolling_resistance=DELTA, drag=C_DRAG, bed_depth=H_BED, bed_band=W_BED)
KERNELS = ["python"] + (["c"] if KERNEL_AVAILABLE else [])


def rolling_at(ball, zP, omega):
    """(n, w): the contact point at height zP in the x-z plane, the ball rolling about the y
    axis (perpendicular to n) at omega [rad/s]."""
    nz = zP / ball.R - 1.0
    return (math.sqrt(1.0 - nz * nz), 0.0, nz), (0.0, omega, 0.0)


# -- the resistance against a hand computation ----------------------------------------------
@pytest.mark.parametrize("zP, share", [(0.0, 1.0), (H_BED - W_BED, 1.0), (H_BED - W_BED / 2, 0.5),
                                       (H_BED, 0.0), (0.12, 0.0)])
def test_grinding_power_of_a_ball_rolling_through_the_bed_by_hand(zP, share):
    """A ball rolling at omega in a fixed chamber: its centre moves at r omega on the circle of
    radius d = R - r, so N = m (r^2 omega^2 / d - g n_z) and the material takes
    P = s (delta N omega^2 / sqrt(omega^2 + eps^2) + c (r omega)^2), about s (delta N omega +
    c r^2 omega^2), with the share s = 1 deeper than w_bed, 1/2 in the band's middle, 0 at
    and above the surface."""
    b, omega = BALL, 6.0
    n, w = rolling_at(b, zP, omega)
    o = evaluate(b, n, w, 0.0, 0.0)
    N = b.m * (b.r ** 2 * omega ** 2 / b.d - b.g * n[2])
    assert o.N == pytest.approx(N, rel=1e-12)
    P = share * (DELTA * N * omega ** 2 / math.sqrt(omega ** 2 + ROLLING_EPS ** 2) + C_DRAG * (b.r * omega) ** 2)
    assert o.s_bed == pytest.approx(share, abs=1e-12)  # zP -> n_z -> zP rounds
    assert o.P_grind == pytest.approx(P, rel=1e-12, abs=1e-300)
    assert o.P_grind == pytest.approx(share * (DELTA * N * omega + C_DRAG * b.r ** 2 * omega ** 2), rel=1e-7,
                                      abs=1e-300)
    assert o.P_diss == o.P_grind  # the rolling model dissipates into the material only
    if share == 0.0:  # above the surface: exactly the lossless ball's outputs
        lossless = evaluate(Ball(), n, w, 0.0, 0.0)
        assert (o.N, o.Fx, o.Fy, o.Fz, o.MAx, o.MAy, o.MAz, o.P_grind) == \
            (lossless.N, lossless.Fx, lossless.Fy, lossless.Fz, lossless.MAx, lossless.MAy, lossless.MAz, 0.0)


def test_the_share_is_smooth_and_exact_at_the_band_edges():
    """0 at and above the surface, 1 at and below w_bed under it, monotone and symmetric
    (s(x) + s(1 - x) = 1) in between, its slope at most 2 / w_bed."""
    bed = bed_constants(BALL)
    z = np.linspace(H_BED - 1.5 * W_BED, H_BED + 0.5 * W_BED, 4001)
    s = np.array([bed_share(bed, zz / BALL.R - 1.0) for zz in z])
    assert np.all(s[z >= H_BED] == 0.0) and np.all(s[z <= H_BED - W_BED] == 1.0)
    assert np.all(np.diff(s) <= 0.0)
    inside = (z > H_BED - W_BED) & (z < H_BED)
    middle = (z > H_BED - 0.9 * W_BED) & (z < H_BED - 0.1 * W_BED)  # at the edges s is flat to round-off
    assert np.all((s[middle] > 0.0) & (s[middle] < 1.0))
    x = (H_BED - z[inside]) / W_BED
    mirror = np.array([bed_share(bed, (H_BED - (1.0 - xx) * W_BED) / BALL.R - 1.0) for xx in x])
    assert np.max(np.abs(s[inside] + mirror - 1.0)) < 1e-12
    assert np.max(np.abs(np.diff(s) / np.diff(z))) <= 2.0 / W_BED * (1 + 1e-3)
    assert bed_share(None, 0.3) == 1.0


def test_ball_refuses_a_bed_outside_the_chamber_naming_the_value():
    with pytest.raises(ParameterError, match=r"bed_depth must be within \[0, 2 R\] = \[0, 0.5\] m .* "
                                             r"got bed_depth = 0.6 m"):
        Ball(bed_depth=0.6)
    with pytest.raises(ParameterError, match=r"bed_depth must be non-negative and finite, got bed_depth = -0.01 m"):
        Ball(bed_depth=-0.01)
    with pytest.raises(ParameterError, match=r"bed_band must be positive and finite, got bed_band = 0.0 m"):
        Ball(bed_depth=0.05, bed_band=0.0)


# -- what 'no bed' and 'a full bed' mean -------------------------------------------------------
CRANK = CrankStartup(l=0.5, n0=36.0, t0=2.5)


def run(ball, kernel, method="DOP853"):
    m = BallModel(ball, method=method, h_fixed=2e-3, kernel=kernel)
    return simulate(m, CRANK, 6.0, 0.01, kernel=kernel)


def same(a, b, names):
    assert np.array_equal(a.y, b.y)
    for name in names:
        assert np.array_equal(a[name], b[name]), name


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("method", ["DOP853", "RK4"])
def test_a_bed_of_depth_zero_is_no_material_bit_for_bit(kernel, method):
    """h_bed = 0: the contact point is never below the surface, so no resistance at all: the
    lossless ball's run, bit for bit, whatever delta and c_drag say."""
    empty = run(Ball(rolling_resistance=DELTA, drag=C_DRAG, bed_depth=0.0), kernel, method)
    lossless = run(Ball(), kernel, method)
    same(empty, lossless, ("xP", "yP", "zP", "N", "Fx", "Fy", "Fz", "M_reaction", "Ft"))
    assert np.all(empty["P_grind"] == 0.0) and np.all(empty["s_bed"] == 0.0)


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_bed_the_ball_never_leaves_is_the_material_everywhere_bit_for_bit(kernel):
    """A bed whose band lies above the ball's whole path (share 1 at every instant) gives the
    run with the material everywhere (bed_depth None, the behaviour before beds existed)
    bit for bit: the share multiplies by exactly 1."""
    everywhere = run(Ball(rolling_resistance=DELTA, drag=C_DRAG), kernel)
    full = run(Ball(rolling_resistance=DELTA, drag=C_DRAG, bed_depth=0.2, bed_band=0.01), kernel)
    assert everywhere["zP"].max() < 0.19  # the band is never reached
    same(everywhere, full, ("xP", "yP", "zP", "N", "Fx", "Fy", "Fz", "M_reaction", "MAx", "Ft", "P_diss", "P_grind"))
    assert np.all(everywhere["s_bed"] == 1.0) and np.all(full["s_bed"] == 1.0)


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_kernel_and_python_agree_bit_for_bit_with_the_bed(method):
    if not KERNEL_AVAILABLE:
        pytest.skip("compiled kernel unavailable")
    a, b = run(BALL, "python", method), run(BALL, "c", method)
    assert 0.1 < np.mean(a["s_bed"] == 0.0) < 0.9  # it crosses the surface
    same(a, b, [n for n in a.out])


# -- the energy balance ------------------------------------------------------------------------
def test_energy_balance_ball_drive_and_grinding_to_the_integrators_tolerance():
    """d/dt (the ball's kinetic + potential energy) = the drive's power on the ball
    (-M_reaction psi', the work of chamber and material carried with it) - P_grind. The
    ball's state and the two works integrated together (DOP853 at 1e-11) over a start-up
    whose contact point enters and leaves the bed many times: E(T) - E(0) - W_drive + E_grind
    stays within 1e-9 of the energy moved (1e-11 would hold: 2.5e-12 measured)."""
    ball = BALL
    model = BallModel(ball)
    form = model.form

    def f(t, z):
        x, y, vx, vy, ax, ay = CRANK.state(t)
        psi_dot = CRANK.angles(np.array([t]))[1][0]
        o = evaluate(ball, (z[0], z[1], z[2]), (z[3], z[4], z[5]), ax, ay, x, y)
        return form.derivative(z[:6].tolist(), ax, ay) + (-o.M_reaction * psi_dot, o.P_grind)

    integ = Integrator("DOP853", tol=1e-11, scale=list(model.integrator.scale) + [1.0, 1.0], project=form.project)
    s0 = model.initial()
    z = np.concatenate([s0.y, [0.0, 0.0]])
    E0 = energy(ball, z[:3], z[3:6], 0.0, 0.0)
    t, h, worst, moved, shares = 0.0, None, 0.0, 0.0, []
    for t_next in np.arange(0.05, 8.0001, 0.05):
        z, h, _ = integ.advance(f, t, z, float(t_next), h)
        t = float(t_next)
        _, _, vx, vy, ax, ay = CRANK.state(t)
        E = energy(ball, z[:3], z[3:6], vx, vy)
        worst = max(worst, abs(E - E0 - z[6] + z[7]))
        moved = max(moved, abs(z[6]), z[7])
        shares.append(evaluate(ball, z[:3], z[3:6], ax, ay).s_bed)
    shares = np.array(shares)
    assert np.any(shares == 0.0) and np.any(shares == 1.0) and np.any((shares > 0) & (shares < 1))
    # measured: W_drive 1.75 J, E_grind 0.126 J, the balance's worst residual 4.3e-12 J
    assert z[7] > 0.05 * z[6]  # the grinding work is a real share of the drive's
    assert worst < 1e-9 * moved, (worst, moved)
    # and the sampled power of the library's run integrates to the same grinding work
    tr = simulate(BallModel(ball, tol=1e-11), CRANK, 8.0, 0.001)
    p = tr["P_grind"]
    assert np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(tr.t)) == pytest.approx(z[7], rel=1e-4)


# -- the FMUs ------------------------------------------------------------------------------------
@pytest.mark.parametrize("overrides", [
    (),
    ("ball.formulation=2", "ball.integrator=3", "ball.h_fixed=5e-4"),
], ids=["vector-RK45", "paper-RK4"])
def test_both_flavours_agree_bit_for_bit_with_the_bed_on(fmu_build_dir, overrides):
    """The grinding scenario with its bed's surface lowered to 2 cm, so that the contact point
    enters the band and leaves the bed within the compared 1.5 s."""
    from test_flavours import _run, _same

    sets = ("ball.h_bed=0.02",) + overrides
    a = _run("grinding", fmu_build_dir, "native", sets, stop=1.5)
    b = _run("grinding", fmu_build_dir, "pythonfmu", sets, stop=1.5)
    assert a.success, a.message
    share = a.column("ball.s_bed")
    assert np.any(share == 0.0) and np.any(share == 1.0) and np.any((share > 0.0) & (share < 1.0))
    assert np.all(a.column("ball.P_grind")[share == 0.0] == 0.0)
    _same(a, b)


def test_the_pre_run_check_refuses_a_bed_deeper_than_the_chamber(tmp_path, fmu_build_dir):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    p = subprocess.run([sys.executable, "-m", "ballmill.cli", "run", "grinding", "--out", str(tmp_path / "out"),
                        "--build-dir", str(fmu_build_dir), "--quiet", "--set", "ball.h_bed=0.6"],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert p.returncode == 2, p.stderr
    assert ("--set ball.h_bed=0.6: BallInShell 'ball' needs h_bed <= 2 R with bed = 1 (the bed's surface lies "
            "between the chamber's lowest and highest points), got") in p.stderr, p.stderr
    assert "h_bed = 0.6 m" in p.stderr and "R = 0.25 m" in p.stderr
    assert not (tmp_path / "out").exists()


# -- the indicators ------------------------------------------------------------------------------
def synthetic(N, friction=lambda t: 0.2 + 0.1 * np.sin(t), t_end=10.0, dt=0.01):
    """A Record with closed-form series: P_grind = 3 + 2 sin(2 pi t) W, in the bed while
    sin(2 pi t) > 1/2 (a third of each second), psi = 2 pi 0.6 t, T_drive = 2 sin(3 t) N m,
    friction |F_t| 0.2 + 0.1 sin(t) N unless given; N given."""
    from ballmill.sweep.indicators import Record

    t = np.round(np.arange(0.0, t_end + dt / 2, dt), 12)
    wave = np.sin(2 * np.pi * t)
    psi_dot = 2 * np.pi * 0.6
    T = 2.0 * np.sin(3.0 * t)
    Nv = N(t)
    Ft = friction(t)
    series = {"b.P_grind": 3.0 + 2.0 * wave, "b.s_bed": np.where(wave > 0.5, 0.7, 0.0), "b.N": Nv, "b.Ft": Ft,
              "b.friction_ratio": np.where(Nv > 0, Ft / np.where(Nv > 0, Nv, 1.0), np.inf),
              "d.psi": psi_dot * t, "d.psi_dot": np.full_like(t, psi_dot), "d.T_drive": T, "d.P_drive": T * psi_dot}
    return Record(t, series, "b", "d", 0.3, {"start": 0.0, "stop": t_end, "after": 2.0})


def test_mill_indicators_against_a_hand_computation():
    from ballmill.sweep import indicators as ind

    rec = synthetic(lambda t: 5.0 + np.cos(t))
    valid, _, n_valid = ind.validity(rec.t, rec.get("b.N"), rec.get("b.friction_ratio"), rec.mu)
    assert valid
    v = ind.mill(rec, n_valid)
    # [2, 10] s holds 8 whole periods of the sine: the mean is 3 W (trapezoidal rule: exact to 1e-12 here)
    assert v["P_grind_mean"] == pytest.approx(3.0, rel=1e-9)
    # sin > 1/2 a third of the time; the samples resolve the edges to dt = 0.01 s per crossing
    assert v["bed_fraction"] == pytest.approx(1.0 / 3.0, abs=2 * 0.01 * 16 / 8)
    assert v["W_grind_rev"] == pytest.approx(3.0 * 8.0 / (0.6 * 8.0), rel=1e-9)  # 24 J over 4.8 revolutions
    assert v["T_drive_peak"] == pytest.approx(2.0, rel=1e-6)  # parabola-refined peak of 2 sin(3 t)
    assert v["P_drive_peak"] == pytest.approx(2.0 * 2 * np.pi * 0.6, rel=1e-6)
    tt = np.linspace(0.0, 10.0, 200001)
    assert v["slip_margin_min"] == pytest.approx(np.min(0.3 * (5.0 + np.cos(tt)) - 0.2 - 0.1 * np.sin(tt)), abs=1e-7)
    assert v["N_min"] == pytest.approx(4.0, abs=1e-7)


def test_a_design_that_loses_contact_reports_the_margin_it_failed_by():
    """N = 1 - 0.21 t reaches 0 at t = 4.7619 s (no friction force: rolling holds while N > 0):
    the statistics after the start-up are not reported (their window reaches past the failure),
    the margins are, over the samples up to the first failed one: N_min = N(4.77 s) = -0.0017 N,
    and the slip margin there is N too."""
    from ballmill.sweep import indicators as ind

    rec = synthetic(lambda t: 1.0 - 0.21 * t, friction=lambda t: 0.0 * t)
    valid, t_invalid, n_valid = ind.validity(rec.t, rec.get("b.N"), rec.get("b.friction_ratio"), rec.mu)
    assert not valid
    v = ind.mill(rec, n_valid)
    assert v["P_grind_mean"] is None and v["W_grind_rev"] is None and v["bed_fraction"] is None
    assert v["N_min"] == pytest.approx(1.0 - 0.21 * 4.77, abs=1e-12) and v["N_min"] < 0.0
    assert v["slip_margin_min"] == v["N_min"]
    assert t_invalid == pytest.approx(4.77)


def path_record(theta, phi, in_bed, R=0.25, r=0.025, bed=1):
    """A Record whose contact point runs over the chamber's shell along the polar angle theta(t)
    (from the bottom) and the longitude phi(t) (t = 0 .. 10 s by 0.005 s, the window after 2 s),
    in the bed where in_bed(t); the ball rolls (N = 5 N, no friction force)."""
    from ballmill.sweep.indicators import Record

    t = np.round(np.arange(0.0, 10.0 + 0.0025, 0.005), 12)
    th, ph = theta(t), phi(t)
    n = np.column_stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)])
    P, C = R * n, (R - r) * n  # from the chamber's centre
    series = {f"b.{k}P": P[:, j] + (0.0, 0.0, R)[j] for j, k in enumerate("xyz")}
    series.update({f"b.{k}C": C[:, j] + (0.0, 0.0, R)[j] for j, k in enumerate("xyz")})
    series.update({"b.s_bed": np.where(in_bed(t), 0.4, 0.0), "b.N": np.full_like(t, 5.0), "b.Ft": 0.0 * t,
                   "b.friction_ratio": 0.0 * t, "b.P_grind": 0.0 * t})
    return Record(t, series, "b", None, 0.3, {"start": 0.0, "stop": 10.0, "after": 2.0, "b.R": R, "b.r": r,
                                              "b.bed": bed})


def swept(rec):
    from ballmill.sweep import indicators as ind

    return ind.mill(rec, len(rec.t))["A_swept_bed"]


def test_the_shell_area_swept_inside_the_bed_against_closed_forms():
    """The ball's footprint has the angular radius alpha = asin(r / (R - r)) (0.1113 rad for the
    paper's ball); the points within alpha of a latitude circle at theta form the zone between
    theta -+ alpha, area 2 pi R^2 (cos(theta - alpha) - cos(theta + alpha)) (Archimedes; the cap
    below theta + alpha when theta < alpha); of a
    circle about a tilted axis, the same; of half a latitude circle, half that zone plus a whole
    cap 2 pi R^2 (1 - cos alpha) (the two ends' half caps, each cut in half by its meridian);
    a path that never enters the bed sweeps nothing. Tolerances: the path between the samples
    kept (alpha / 4 apart) is their great-circle arc, which sags some 3e-4 rad off a latitude
    circle (0.1 % of the zone at 0.3 rad), and the grid's bands and cells (alpha / 8, alpha / 10)
    resolve a tilted circle's edges to about 1 %."""
    R, r = 0.25, 0.025
    alpha = math.asin(r / (R - r))
    assert alpha == pytest.approx(0.11134, abs=1e-5)
    zone = lambda th: 2 * math.pi * R ** 2 * (math.cos(th - alpha) - math.cos(th + alpha))  # noqa: E731
    turn = lambda t: 2 * np.pi * 0.4 * t  # noqa: E731  (0.4 revolutions per second: 3.2 in the window)
    always = lambda t: t >= 0.0  # noqa: E731
    for theta in (0.3, 0.7):
        assert swept(path_record(lambda t: theta + 0 * t, turn, always)) == pytest.approx(zone(theta), rel=2e-3)
    # closer to the bottom than alpha: the footprints cover the cap below theta + alpha
    assert swept(path_record(lambda t: 0.05 + 0 * t, turn, always)) == \
        pytest.approx(2 * math.pi * R ** 2 * (1 - math.cos(0.05 + alpha)), rel=2e-3)
    # a circle of angular radius beta about the axis a, tilted 0.3 rad from the downward vertical:
    # n = cos beta a + sin beta (cos s e1 + sin s e2)
    tilt, beta = 0.3, 0.5
    a, e1 = np.array([math.sin(tilt), 0.0, -math.cos(tilt)]), np.array([math.cos(tilt), 0.0, math.sin(tilt)])
    n = lambda t: (math.cos(beta) * a[:, None] + math.sin(beta) * (np.cos(turn(t)) * e1[:, None]  # noqa: E731
                                                                   + np.sin(turn(t)) * np.array([0, 1.0, 0])[:, None]))
    theta_t = lambda t: np.arccos(-n(t)[2])  # noqa: E731
    phi_t = lambda t: np.arctan2(n(t)[1], n(t)[0])  # noqa: E731
    assert swept(path_record(theta_t, phi_t, always)) == pytest.approx(zone(beta), rel=0.015)
    # half of each revolution in the bed, the other half above it (sin of the longitude > 0)
    half = swept(path_record(lambda t: 0.7 + 0 * t, turn, lambda t: np.sin(turn(t)) > 0.0))
    assert half == pytest.approx(zone(0.7) / 2 + 2 * math.pi * R ** 2 * (1 - math.cos(alpha)), rel=0.01)
    assert swept(path_record(lambda t: 0.7 + 0 * t, turn, lambda t: t < 0.0)) == 0.0
    # in the bed during the start-up only: nothing after it
    assert swept(path_record(lambda t: 0.7 + 0 * t, turn, lambda t: t < 1.5)) == 0.0
    # no bed (bed = 0, the material everywhere): not reported
    assert swept(path_record(lambda t: 0.7 + 0 * t, turn, always, bed=0)) is None


def test_the_swept_area_of_a_wandering_path_against_a_monte_carlo_count():
    """A path that wanders in polar angle (0.6 + 0.2 sin 2.3 t rad) while it goes round (3.77
    rad/s), in the bed on the half of the circle where sin(longitude) > 0: its footprints'
    union counted by 100000 random points of the zone it can reach, each within alpha of the
    path (densely sampled) or not. The count's standard error is 0.4 %, the grid's error 0.5 %."""
    from scipy.spatial import cKDTree

    R, r = 0.25, 0.025
    alpha = math.asin(r / (R - r))
    theta = lambda t: 0.6 + 0.2 * np.sin(2.3 * t)  # noqa: E731
    phi = lambda t: 3.77 * t  # noqa: E731
    in_bed = lambda t: np.sin(phi(t)) > 0.0  # noqa: E731
    area = swept(path_record(theta, phi, in_bed))
    t = np.linspace(2.0, 10.0, 40001)  # the window after the start-up, 0.1 mm apart on the shell
    t = t[in_bed(t)]
    th, ph = theta(t), phi(t)
    tree = cKDTree(np.column_stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)]))
    rng = np.random.default_rng(7)
    lo, hi = 0.4 - alpha, 0.8 + alpha
    z = rng.uniform(-math.cos(lo), -math.cos(hi), 100000)  # uniform on the sphere's zone
    lon = rng.uniform(0.0, 2 * math.pi, z.size)
    q = np.column_stack([np.sqrt(1 - z * z) * np.cos(lon), np.sqrt(1 - z * z) * np.sin(lon), z])
    near = np.isfinite(tree.query(q, distance_upper_bound=2 * math.sin(alpha / 2))[0])
    count = near.mean() * 2 * math.pi * R ** 2 * (math.cos(lo) - math.cos(hi))
    assert area == pytest.approx(count, rel=0.02)


def test_the_run_summary_reports_the_mill_indicators_with_units(fmu_build_dir):
    """The scenario summary's indicators (ballmill run: summary.json) by hand from the run's own
    columns: the grinding scenario's first 8 s (the start-up ends at 2.5 s)."""
    from ballmill.scenario import report, runner

    sc, models, paths = runner.prepare("grinding", [], fmu_build_dir, log=lambda m: None)
    sc.stop = 8.0
    res = runner.run(sc, models, paths, progress=False, echo=False)
    assert res.success
    ind = report.summarise(res, models)["indicators"]
    t = res.column("time")
    late = t >= 2.5 - 1e-12
    P = res.column("ball.P_grind")[late]
    work = np.sum(0.5 * (P[1:] + P[:-1]) * np.diff(t[late]))
    assert ind["P_grind_mean"] == {"value": pytest.approx(work / (8.0 - 2.5), rel=1e-12), "unit": "W",
                                   "description": pytest.approx(ind["P_grind_mean"]["description"])}
    psi = res.column("drive.psi")[late]
    assert ind["W_grind_rev"]["value"] == pytest.approx(work / ((psi[-1] - psi[0]) / (2 * np.pi)), rel=1e-12)
    assert ind["W_grind_rev"]["unit"] == "J"
    assert 0.2 < ind["bed_fraction"]["value"] < 0.9  # the ring dips into the 9 cm bed
    assert ind["N_min"]["value"] == pytest.approx(res.column("ball.N").min(), rel=1e-3)
    assert ind["T_drive_peak"]["value"] >= np.abs(res.column("drive.T_drive")).max()
    assert ind["slip_margin_min"]["unit"] == "N" and ind["slip_margin_min"]["value"] > 0.0
    # the footprints (angular radius asin(r / (R - r)) = 0.1113 rad) along the path below the 9 cm
    # surface: more than one footprint, less than the shell below the surface widened by one
    assert ind["A_swept_bed"]["unit"] == "m2"
    alpha = math.asin(0.025 / 0.225)
    assert math.pi * (0.25 * alpha) ** 2 < ind["A_swept_bed"]["value"] < 2 * math.pi * 0.25 * (0.09 + 0.25 * alpha)
