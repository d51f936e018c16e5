"""The absorber study on the sweep layer (ballmill.sweep.absorber): `ballmill sweep absorber_frf`.

The FRF at 0.05 N against a two-degree-of-freedom closed form derived here (not
ballmill.absorber.linear), the bare column against the one-degree-of-freedom
closed form, the refinement rounds finding both split peaks, the tuning claim
(an undamped tuned ball's worse peak is above the bare structure's, damping
brings it under), the continued sweeps against the library's `sweep`, resume,
Dask against in-process, and the command line's frf.csv.
"""
import csv
import math

import numpy as np
import pytest

from ballmill.absorber import linear as lin
from ballmill.absorber.response import AbsorberCase, sweep as lib_sweep
from ballmill.absorber.structure import Structure
from ballmill.physics import Ball
from ballmill.sweep import StudyError, load, run_study

M, F_S, ZETA, R_BALL, M_BALL, G = 100.0, 0.8, 0.01, 0.025, 2.0, 9.81
F0 = 0.05


def closed_form(f, ball=True, F=F0, R=None, c_ball=0.0):
    """|x| of the structure under F sin(W t), derived from scratch: structure x (mass M,
    stiffness K, dashpot C), ball centre u relative to the cavity (rolling: spin u'/r,
    I = 2/5 m r^2), pendulum stiffness m g / (R - r), drag c_ball on u:

        [[M + m, m], [m, 7/5 m]] [x'', u''] + diag(C, c_ball) [x', u'] + diag(K, m g/(R - r)) [x, u] = [F, 0]

    solved by Cramer's rule. ball=False: F / |K - M W^2 + i C W|."""
    W = 2 * math.pi * np.asarray(f, dtype=float)
    K = M * (2 * math.pi * F_S) ** 2
    C = 2 * ZETA * M * 2 * math.pi * F_S
    if not ball:
        return F / np.abs(K - M * W ** 2 + 1j * C * W)
    R = R if R is not None else R_BALL + 5 * G / (7 * (2 * math.pi * F_S) ** 2)
    k_u = M_BALL * G / (R - R_BALL)
    a11 = K - (M + M_BALL) * W ** 2 + 1j * C * W
    a12 = -M_BALL * W ** 2
    a22 = k_u - 1.4 * M_BALL * W ** 2 + 1j * c_ball * W
    return np.abs(F * a22 / (a11 * a22 - a12 * a12))


def _peaks(f, a):
    f, a = np.asarray(f), np.asarray(a)
    o = np.argsort(f)
    f, a = f[o], a[o]
    return [(f[i], a[i], f[i + 1] - f[i - 1]) for i in range(1, len(f) - 1) if a[i] >= a[i - 1] and a[i] >= a[i + 1]]


def _true_peaks(lo, hi, **kw):
    f = np.linspace(lo, hi, 600001)  # 1e-6 Hz
    a = closed_form(f, **kw)
    return [(ff, aa) for ff, aa, _ in _peaks(f, a)]


def _frf_csv(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def frf_study(tmp_path_factory):
    """The issue's study file on a coarser start grid (0.02 Hz over 0.70-0.90 Hz), refined."""
    out = tmp_path_factory.mktemp("frf")
    study = load("absorber_frf", grid={"excitation.frequency": "0.70:0.90:11"})
    res = run_study(study, out, scheduler="in-process", progress=False)
    return study, out, res


def test_frf_matches_the_linear_two_dof_closed_form(frf_study):
    study, out, res = frf_study
    rows = _frf_csv(out / "frf.csv")
    assert [k for k in rows[0]][:3] == ["frequency_Hz", "amplitude_m", "amplitude_bare_m"]
    assert len(rows) == res.computed > 11  # the refinement rounds added points
    f = np.array([float(r["frequency_Hz"]) for r in rows])
    a = np.array([float(r["amplitude_m"]) for r in rows])
    assert all(r["valid"] == "1" and r["converged"] == "1" and r["status"] == "ok" for r in rows)
    lin_a = closed_form(f)
    peak = max(a for _, a in _true_peaks(0.7, 0.9))
    # 2 % at every point; at the antiresonance (0.8 Hz: the tuned undamped ball holds the
    # structure still, linear amplitude 0) 2 % of 1 % of the peak, 2e-7 m; measured 2.2e-9 m there
    # (docs/absorber.md: 0.09 % where the amplitude is above 1 % of the peak)
    assert np.all(np.abs(a - lin_a) <= 0.02 * np.maximum(lin_a, 0.01 * peak)), np.abs(a / lin_a - 1).max()
    # the linear column is the same theory (ballmill.absorber.linear) to round-off
    assert np.allclose([float(r["amplitude_linear_m"]) for r in rows], lin_a, rtol=1e-9, atol=1e-15)


def test_bare_column_is_the_single_dof_closed_form(frf_study):
    _, out, _ = frf_study
    rows = _frf_csv(out / "frf.csv")
    f = np.array([float(r["frequency_Hz"]) for r in rows])
    bare = np.array([float(r["amplitude_bare_m"]) for r in rows])
    assert np.allclose(bare, closed_form(f, ball=False), rtol=1e-12, atol=0)
    assert closed_form(F_S, ball=False) == pytest.approx(F0 / (2 * ZETA * M * (2 * math.pi * F_S) ** 2), rel=1e-12)


def test_refinement_finds_both_split_peaks_within_one_percent(frf_study):
    _, out, _ = frf_study
    rows = _frf_csv(out / "frf.csv")
    f = [float(r["frequency_Hz"]) for r in rows]
    a = [float(r["amplitude_m"]) for r in rows]
    found = _peaks(f, a)
    true = _true_peaks(0.7, 0.9)
    assert len(true) == 2 and len(found) == 2, found
    for (fs, as_, width), (ft, at) in zip(found, true):
        assert abs(fs - ft) / ft < 0.01 and abs(fs - ft) < 1e-3  # within the spacing around the peak
        assert as_ == pytest.approx(at, rel=0.01)
        assert width < 0.004  # refined from the 0.02 Hz start grid
    # the start grid alone misses them by far: its highest points are more than 10 % low
    coarse = np.linspace(0.7, 0.9, 11)
    assert closed_form(coarse).max() < 0.9 * max(at for _, at in true)


def test_resume_recomputes_nothing_including_the_rounds(frf_study):
    study, out, res = frf_study
    again = run_study(load("absorber_frf", grid={"excitation.frequency": "0.70:0.90:11"}), out,
                      scheduler="in-process", progress=False, plots=False)
    assert again.computed == 0 and again.skipped == res.computed
    assert [r["point_id"] for r in again.rows] == [r["point_id"] for r in res.rows]


def test_tuning_claim_undamped_above_bare_damped_below():
    """Linear theory (linear.py): with zeta = 0.01 the undamped tuned ball's worse peak is
    above the bare structure's; a ball damped by Den Hartog's rule brings it far under.
    The simulated steady states (sweep layer, refined) say the same, within 1 %."""
    ax = Structure.single(M, F_S, ZETA).x
    bare_peak = max(a for _, a in lin.LinearAbsorber(ax).peaks(0.5, 1.1)) * F0
    tuned = Ball(r=R_BALL, R=lin.cavity_radius(F_S, R_BALL), m=M_BALL)
    tuned_peak = lin.peak_of(ax, tuned, 0.5, 1.1) * F0
    dh = lin.den_hartog_ball(ax, R_BALL, M_BALL)
    dh_peak = lin.peak_of(ax, dh, 0.5, 1.1) * F0
    assert tuned_peak > 1.05 * bare_peak  # 21.04 against 19.79 mm/N
    assert dh_peak < 0.25 * bare_peak  # 3.98 mm/N: 20 %

    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        und = run_study(load("absorber_frf", grid={"excitation.frequency": [0.745, 0.75, 0.755, 0.76]}),
                        Path(d) / "u", scheduler="in-process", progress=False, plots=False).rows
        damped = run_study(load("absorber_frf", set_=[f"ball.R={dh.R!r}", f"ball.c_drag={dh.drag!r}"],
                                grid={"excitation.frequency": "0.70:0.90:11"}),
                           Path(d) / "d", scheduler="in-process", progress=False, plots=False).rows
    sim_und = max(r["amplitude_m"] for r in und)
    assert sim_und == pytest.approx(tuned_peak, rel=0.01) and sim_und > 1.05 * bare_peak
    sim_dh = max(r["amplitude_m"] for r in damped)
    assert sim_dh == pytest.approx(dh_peak, rel=0.01) and sim_dh < 0.25 * bare_peak
    fd = np.array([r["excitation.frequency"] for r in damped])
    assert np.allclose([r["amplitude_m"] for r in damped],
                       closed_form(fd, R=dh.R, c_ball=dh.drag), rtol=0.02)


def test_continued_sweeps_are_the_library_sweeps():
    """mode = "both": each direction one chain, point after point from the previous state;
    rows equal ballmill.absorber.response.sweep's, on Dask as in-process."""
    import tempfile
    from pathlib import Path

    grid = [0.70, 0.72, 0.74]
    case = AbsorberCase(Structure.single(M, F_S, ZETA), Ball(r=R_BALL, R=lin.cavity_radius(F_S, R_BALL), m=M_BALL),
                        0.5, tol=1e-9)
    up = lib_sweep(case, grid, rtol=1e-3, max_periods=400)
    down = lib_sweep(case, grid[::-1], rtol=1e-3, max_periods=400)
    study = load("absorber_frf", set_=["excitation.F0=0.5"], grid={"excitation.frequency": grid}, mode="both")
    assert study.swept == ["sweep.direction", "excitation.frequency"]
    with tempfile.TemporaryDirectory() as d:
        loc = run_study(study, Path(d) / "l", scheduler="in-process", progress=False, plots=False)
        dsk = run_study(study, Path(d) / "k", workers=2, progress=False, plots=False)
        table = _frf_csv(Path(d) / "l" / "frf.csv")
    assert loc.batch == 3  # a chain is one task
    for rows in (loc.rows, dsk.rows):
        got = {(r["sweep.direction"], r["excitation.frequency"]): r for r in rows}
        for direction, pts in (("up", up), ("down", down)):
            for p in pts:
                r = got[(direction, p.frequency_Hz)]
                assert r["amplitude_m"] == p.amplitude_m and r["periods"] == p.periods
                assert r["t_end_s"] == p.t_end  # the sweep's time runs on through the chain
    assert [(r["direction"], float(r["frequency_Hz"])) for r in table] == \
        [("up", 0.70), ("up", 0.72), ("up", 0.74), ("down", 0.74), ("down", 0.72), ("down", 0.70)]


def test_study_errors_name_the_problem():
    with pytest.raises(StudyError, match="no parameter ball.radius"):
        run_study(load("absorber_frf", set_=["ball.radius=0.1"]), "/nonexistent-never-made", progress=False)
    with pytest.raises(StudyError, match="mode: expected one of"):
        load("absorber_frf", mode="sideways")
    with pytest.raises(StudyError, match="excitation.F0 = -1.0 N: must be positive"):
        run_study(load("absorber_frf", set_=["excitation.F0=-1"]), "/nonexistent-never-made", progress=False)
    from ballmill.sweep import build

    with pytest.raises(StudyError, match="sweeps excitation.frequency"):
        build("absorber", case="absorber", grid={"structure.zeta": [0.01]})
    with pytest.raises(StudyError, match="only a study of a built-in case"):
        load("fast_start", mode="up")


def test_command_line_writes_frf_csv(tmp_path):
    from ballmill.cli import main

    rc = main(["sweep", "absorber_frf", "--in-process", "--quiet", "--out", str(tmp_path),
               "--grid", "excitation.frequency=0.5,0.55,0.6"])
    assert rc == 0
    rows = _frf_csv(tmp_path / "frf.csv")
    for col in ("frequency_Hz", "amplitude_m", "amplitude_bare_m", "amplitude_linear_m", "valid", "rolling",
                "contact", "ball_amplitude_m", "ball_angle_max_deg"):
        assert col in rows[0]
    assert [float(r["frequency_Hz"]) for r in rows] == [0.5, 0.55, 0.6]
    f = np.array([0.5, 0.55, 0.6])
    assert np.allclose([float(r["amplitude_m"]) for r in rows], closed_form(f), rtol=0.02)
    assert (tmp_path / "frf.png").stat().st_size > 10000 and (tmp_path / "results.parquet").exists()


def test_contact_loss_is_marked_and_the_sweep_restarts(tmp_path):
    """40 N at the lower peak throws the ball off the wall within the first window: the row
    says so (contact, valid False) and the sweep's next point starts afresh (restarted)."""
    study = load("absorber_frf", set_=["excitation.F0=40"], grid={"excitation.frequency": [0.75, 0.76]}, mode="up")
    rows = run_study(study, tmp_path, scheduler="in-process", progress=False).rows
    assert [(r["contact"], r["valid"], r["converged"]) for r in rows] == [(False, False, False)] * 2
    assert all(r["N_min_N"] < 0 for r in rows)
    assert [r["restarted"] for r in rows] == [False, True]
    table = _frf_csv(tmp_path / "frf.csv")
    assert [(r["direction"], r["contact"], r["valid"]) for r in table] == [("up", "0", "0")] * 2
