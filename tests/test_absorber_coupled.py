"""Structure + ball in one ODE (ballmill.absorber.model): the accelerations
against an independent Newton-Euler solve, the energy balance, ground records.

The Newton-Euler check writes every body's equation with the contact force F
as an unknown: the structure's modes (loaded by -F - F_d through the cavity),
Newton and Euler for the ball (with the rolling resistance as a couple
delta (F . n) w_t / s, linear in F), and the no-slip constraint at the
acceleration level, a_C = a_O + r (n' x omega + n x omega'). That is one
linear system in (q'', omega', F, a_C), solved with numpy at random states,
sharing nothing with the model's closed-form elimination but the inputs.
"""
import math

import numpy as np
import pytest

from ballmill.physics import Ball
from ballmill.absorber.model import StructureBall, simulate_absorber
from ballmill.physics.equations import ROLLING_EPS
from ballmill.physics.errors import ParameterError
from ballmill.absorber.structure import (GroundRecord, HarmonicForce, HarmonicGround, Mode,
                                        Structure, StructureAxis)

BALL = Ball(r=0.025, R=0.30, m=2.0)


def two_mode_structure():
    x = StructureAxis((Mode(100.0, 0.8, 0.01, shape=1.0, force_shape=0.7, participation=130.0),
                       Mode(60.0, 2.9, 0.02, shape=-0.6, force_shape=0.4, participation=-25.0)))
    y = StructureAxis((Mode(80.0, 0.75, 0.015, shape=0.9),))
    return Structure(x, y)


STRUCTURES = {
    "single": Structure.single(100.0, 0.8, 0.01),
    "two-mode": two_mode_structure(),
    "x-only": Structure(StructureAxis.single(50.0, 1.2, 0.02), None),
}
BALLS = {
    "lossless": BALL,
    "drag": BALL.with_(drag=0.8),
    "rolling": BALL.with_(rolling_resistance=2e-4),
    "both": BALL.with_(drag=0.5, rolling_resistance=1e-4),
}


def newton_euler(system: StructureBall, t, z, rolling=True):
    """(q''_x, q''_y, omega', N) from the full Newton-Euler system, one linear solve.
    The rolling resistance acts while N > 0: solved with it, and again without it
    when the N found is not positive."""
    b = system.ball
    m, r, d, I, g = b.m, b.r, b.d, b.I, b.g
    Fx, Fy, gx, gy = system.excitation.loads(t)
    axes = [ax for ax in system.structure.axes]
    nq = [ax.n if ax is not None else 0 for ax in axes]
    ib = system.ib
    n = np.array(z[ib:ib + 3])
    w = np.array(z[ib + 3:ib + 6])
    nd = (r / d) * np.cross(n, w)
    Fd = -b.drag * d * nd  # drag on the ball centre
    N_unknown = sum(nq) + 9
    A = np.zeros((N_unknown, N_unknown))
    rhs = np.zeros(N_unknown)
    iw, iF, iC = sum(nq), sum(nq) + 3, sum(nq) + 6
    row, col, off = 0, 0, 0
    phis = []
    for k, (ax, F_ext, ag) in enumerate(zip(axes, (Fx, Fy), (gx, gy))):
        if ax is None:
            phis.append(())
            continue
        nm = ax.n
        phis.append([(col + j, md.shape) for j, md in enumerate(ax.modes)])
        for j, md in enumerate(ax.modes):
            q, qd = z[off + j], z[off + nm + j]
            A[row, col + j] = md.mass
            A[row, iF + k] = md.shape  # + phi F_k: the cavity is loaded by -F - F_d
            rhs[row] = (md.force_shape * F_ext - md.participation * ag - md.damping_coefficient * qd
                        - md.stiffness * q - md.shape * Fd[k])
            row += 1
        col += nm
        off += 2 * nm
    # Newton: m a_C - F = m g_vec + F_d
    for i in range(3):
        A[row, iC + i] = m
        A[row, iF + i] = -1.0
        rhs[row] = Fd[i] + (-m * g if i == 2 else 0.0)
        row += 1
    # Euler about C: I omega' = r n x F + M_rr,  M_rr = delta (F . n) w_t / s  (while N > 0)
    cross_n = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    wt = w - (w @ n) * n
    s = math.sqrt(wt @ wt + ROLLING_EPS ** 2)
    Mrr = (b.rolling_resistance if rolling else 0.0) / s * np.outer(wt, n)
    A[row:row + 3, iw:iw + 3] = I * np.eye(3)
    A[row:row + 3, iF:iF + 3] = -r * cross_n - Mrr
    row += 3
    # no slip: a_C - a_O - r n x omega' = r n' x omega, a_O = a_g + sum phi q''
    A[row:row + 3, iC:iC + 3] = np.eye(3)
    A[row:row + 3, iw:iw + 3] = -r * cross_n
    for k in range(2):
        for c, phi in phis[k]:
            A[row + k, c] = -phi
    rhs[row:row + 3] = r * np.cross(nd, w) + np.array([gx, gy, 0.0])
    x = np.linalg.solve(A, rhs)
    N = -(x[iF:iF + 3] @ n)
    if rolling and b.rolling_resistance and N <= 0.0:
        return newton_euler(system, t, z, rolling=False)
    return x[:nq[0]], x[nq[0]:sum(nq)], x[iw:iw + 3], N


def random_state(system, rng):
    ib = system.ib
    z = list(rng.normal(scale=0.05, size=system.ns))
    v = rng.normal(size=3)
    v[2] = -abs(v[2]) - 0.3  # lower part of the sphere: the wall presses
    n = v / np.linalg.norm(v)
    w = rng.normal(scale=3.0, size=3)
    return z + list(n) + list(w) + [0.0, 0.0, 0.0]


@pytest.mark.parametrize("sname", list(STRUCTURES))
@pytest.mark.parametrize("bname", list(BALLS))
def test_accelerations_match_newton_euler(sname, bname):
    rng = np.random.default_rng(7)
    exc = (HarmonicGround(13.0, 0.9, amplitude_y=-7.0) if sname == "single"
           else HarmonicForce(2000.0, 0.9, 1100.0))  # large: both signs of N occur
    system = StructureBall(STRUCTURES[sname], BALLS[bname], exc)
    worst, pressing = 0.0, 0
    for _ in range(40):
        z = random_state(system, rng)
        t = float(rng.uniform(0, 5))
        acc = system.accelerations(t, z)
        qx, qy, wd, N = newton_euler(system, t, z)
        pressing += N > 0.0
        got = np.concatenate([acc["qdd_x"], acc["qdd_y"], acc["dball"][3:]])
        ref = np.concatenate([qx, qy, wd])
        err = np.abs(got - ref).max() / max(1.0, np.abs(ref).max())
        worst = max(worst, err)
        # the acceleration the ball saw is the one the structure has (no lag)
        assert abs(acc["ax"] - acc["ax_struct"]) <= 1e-12 * max(1.0, abs(acc["ax"]))
        assert abs(acc["ay"] - acc["ay_struct"]) <= 1e-12 * max(1.0, abs(acc["ay"]))
    assert worst < 1e-11, worst
    assert 10 <= pressing < 40  # both branches of the rolling resistance were visited


def test_effective_mass_at_rest_is_two_sevenths():
    """At rest at the bottom the ball adds 2/7 of its mass to the structure's inertia
    (the rest is carried by its rolling): a static force F0 accelerates the structure
    by F0 / (M + 2/7 m) at the first instant."""
    M, F0 = 100.0, 3.0
    system = StructureBall(Structure.single(M, 0.8, 0.0), BALL, HarmonicForce(F0, 0.25, phase=math.pi / 2))
    z = list(system.initial().z)
    acc = system.accelerations(0.0, z)
    assert acc["ax"] == pytest.approx(F0 / (M + 2.0 / 7.0 * BALL.m), rel=1e-13)


def energy_run(system, t_end, x_ref, tol=1e-10, state=None):
    res = simulate_absorber(system, t_end, 0.05, state=state, tol=tol, x_ref=x_ref)
    assert res.success, res.message
    scale = max(np.abs(res["W_exc"]).max(), np.abs(res["E"] - res["E"][0]).max())
    return res, np.abs(res.energy_residual).max() / scale


@pytest.mark.parametrize("bname", list(BALLS))
def test_energy_balance_force(bname):
    """Work of the force = change of energy + structure damping + ball losses, at a
    large amplitude (the ball swings ~30 deg), to the integrator's tolerance."""
    system = StructureBall(STRUCTURES["single"], BALLS[bname],
                           HarmonicForce(8.0, 0.86, amplitude_y=3.0, phase_y=1.0))
    res, rel = energy_run(system, 25.0, 1e-2)
    assert res["theta"].max() > 0.3  # not a small-amplitude check
    if bname != "lossless":
        assert res["W_ball"][-1] > 0.05 * res["W_exc"][-1]  # the losses are a real part of it
    assert res["W_damp"][-1] > 0
    assert rel < 2e-8, rel


def test_energy_balance_ground_and_two_modes():
    system = StructureBall(STRUCTURES["two-mode"], BALLS["both"],
                           HarmonicGround(0.4, 0.8, amplitude_y=0.2, phase_y=0.5))
    res, rel = energy_run(system, 20.0, 1e-2)
    assert rel < 2e-8, rel
    assert np.abs(res["W_exc"]).max() > 1.0


def test_energy_balance_detects_a_wrong_model():
    """The balance is sharp: leaving the ball's losses out of the books breaks it."""
    system = StructureBall(STRUCTURES["single"], BALLS["both"], HarmonicForce(8.0, 0.86))
    res, rel = energy_run(system, 10.0, 1e-2)
    d = res.data
    wrong = d["W_exc"] - (d["E"] - d["E"][0]) - d["W_damp"]
    assert np.abs(wrong).max() > 1e4 * np.abs(res.energy_residual).max()


def test_ground_record_equals_harmonic_ground(tmp_path):
    """A finely sampled record of a harmonic ground acceleration (read from CSV, linear
    interpolation, breakpoints hit) drives the model as the harmonic itself does, to
    the interpolation error (dt^2 W^2 / 8 ~ 2e-5 relative at 200 Hz)."""
    f, A = 0.65, 0.05
    harm = HarmonicGround(A, f)
    rate = 200.0
    ts = np.arange(0, 15.0 + 1e-9, 1 / rate)
    path = tmp_path / "g.csv"
    with open(path, "w") as fh:
        fh.write("time,ax,ay\n")
        for t in ts:
            fh.write(f"{t:.6f},{harm.loads(t)[2]!r},0\n")
    rec = GroundRecord.from_csv(path)
    s = STRUCTURES["single"]
    r1 = simulate_absorber(StructureBall(s, BALL, harm), 15.0, 0.05, x_ref=1e-2)
    r2 = simulate_absorber(StructureBall(s, BALL, rec), 15.0, 0.05, x_ref=1e-2)
    assert r1.success and r2.success
    scale = np.abs(r1["xO"]).max()
    assert np.abs(r1["xO"] - r2["xO"]).max() < 1e-4 * scale
    assert np.abs(r2.energy_residual).max() < 1e-8 * np.abs(r2["W_exc"]).max()


def test_ground_record_refuses_bad_data(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time,ax\n0,0\n0.1,nan\n")
    with pytest.raises(ParameterError, match="row 2"):
        GroundRecord.from_csv(p)
    p.write_text("time,ax\n0,0\n0,1\n")
    with pytest.raises(ParameterError, match="increase strictly"):
        GroundRecord.from_csv(p)
    p.write_text("t,ax\n0,0\n1,1\n")
    with pytest.raises(ParameterError, match="column 'time' missing"):
        GroundRecord.from_csv(p)


def test_parameters_are_checked():
    with pytest.raises(ParameterError, match="mode mass"):
        Mode(-1.0, 1.0)
    with pytest.raises(ParameterError, match="at least one mode"):
        StructureAxis(())
    with pytest.raises(ParameterError, match="frequency"):
        HarmonicForce(1.0, 0.0)
    system = StructureBall(STRUCTURES["single"], BALL)
    with pytest.raises(ParameterError, match="out of reach"):
        system.initial(xC0=1.0)
