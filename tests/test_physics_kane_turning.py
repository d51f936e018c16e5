"""An independent derivation of the general (turning-chamber) model with Kane's method
(sympy.physics.mechanics), compared with ballmill.physics.turning.model at random states.

Nothing of the library's algebra is used. The model, from scratch:

* inertial frame N, z up; the chamber centre A at (Ax(t), Ay(t), Az(t)), the chamber
  turning with angular velocity Omega(t) = (Ox(t), Oy(t), Oz(t)) in N (prescribed);
* q1, q2 place the ball centre: frame Bn rotated from N by q1 about x then q2 about
  the new y, C = A - (R - r) Bn.z (so n = -Bn.z);
* generalized speeds u1..u3: the ball's absolute angular velocity in N; u4 = q1',
  u5 = q2' dependent;
* no slip: the ball's material point at P = C - r Bn.z has the velocity of the
  chamber's material point there, A' + Omega x (P - A). The tangential components
  are the (now non-homogeneous) nonholonomic constraints; the normal one vanishes;
* load: gravity at C. The contact force is a constraint force and drops out.

Then q', u' from KanesMethod's full mass matrix and forcing, with A'', A', Omega',
Omega replaced by numbers; n' = dn/dq q'. The contact force follows from Newton with
Kane's a_C and is compared with the library's outputs as well.
"""
import functools
import math

import numpy as np
import pytest

sp = pytest.importorskip("sympy")
me = pytest.importorskip("sympy.physics.mechanics")

from ballmill.physics import Ball  # noqa: E402
from ballmill.physics.turning import model as turning  # noqa: E402
from ballmill.physics.turning.motions import ChamberState  # noqa: E402


@functools.lru_cache(maxsize=1)
def kane_model():
    q1, q2 = me.dynamicsymbols("q1 q2")
    u1, u2, u3, u4, u5 = me.dynamicsymbols("u1:6")
    Ax, Ay, Az, Ox, Oy, Oz = me.dynamicsymbols("Ax Ay Az Ox Oy Oz")
    t = me.dynamicsymbols._t
    r, R, m, g = sp.symbols("r R m g", positive=True)
    acc = sp.symbols("aAx aAy aAz", real=True)
    vel = sp.symbols("vAx vAy vAz", real=True)
    om = sp.symbols("Omx Omy Omz", real=True)
    omd = sp.symbols("Omdx Omdy Omdz", real=True)

    N = me.ReferenceFrame("N")
    Bn = N.orientnew("Bn", "Body", (q1, q2, 0), "XYZ")
    ball_frame = me.ReferenceFrame("Bf")
    ball_frame.set_ang_vel(N, u1 * N.x + u2 * N.y + u3 * N.z)
    Omega = Ox * N.x + Oy * N.y + Oz * N.z

    O1 = me.Point("O1")
    O1.set_vel(N, 0)
    A = O1.locatenew("A", Ax * N.x + Ay * N.y + Az * N.z)
    A.set_vel(N, A.pos_from(O1).dt(N))
    C = A.locatenew("C", -(R - r) * Bn.z)
    C.set_vel(N, C.pos_from(O1).dt(N))
    P = C.locatenew("P", -r * Bn.z)
    P.v2pt_theory(C, N, ball_frame)

    qdots = {q1.diff(t): u4, q2.diff(t): u5}
    kd = [q1.diff(t) - u4, q2.diff(t) - u5]
    chamber_point = A.vel(N) + Omega.cross(P.pos_from(A))
    slip = P.vel(N) - chamber_point
    constraints = [sp.expand(slip.dot(Bn.x).subs(qdots)), sp.expand(slip.dot(Bn.y).subs(qdots))]
    assert sp.simplify(slip.dot(Bn.z).subs(qdots)) == 0

    I = sp.Rational(2, 5) * m * r**2
    ball = me.RigidBody("ball", C, ball_frame, m, (me.inertia(N, I, I, I), C))
    KM = me.KanesMethod(N, q_ind=[q1, q2], u_ind=[u1, u2, u3], kd_eqs=kd,
                        u_dependent=[u4, u5], velocity_constraints=constraints)
    KM.kanes_equations([ball], [(C, -m * g * N.z)])

    prescribed = {}
    for f, a_, v_ in zip((Ax, Ay, Az), acc, vel):
        prescribed[f.diff(t, 2)] = a_
        prescribed[f.diff(t)] = v_
    for f, od in zip((Ox, Oy, Oz), omd):
        prescribed[f.diff(t)] = od

    def fix(expr):
        expr = expr.subs(prescribed)
        return expr.subs(dict(zip((Ox, Oy, Oz), om)))

    MM, FF = fix(KM.mass_matrix_full), fix(KM.forcing_full)
    left = me.find_dynamicsymbols(MM) | me.find_dynamicsymbols(FF)
    assert left <= {q1, q2, u1, u2, u3, u4, u5, Ax, Ay, Az}, left

    A_dep, b_dep = sp.linear_eq_to_matrix([fix(c) for c in constraints], [u4, u5])
    n_vec = (-Bn.z).to_matrix(N)
    udots = [u.diff(t) for u in (u1, u2, u3, u4, u5)]
    ud_syms = sp.symbols("ud1:6")
    aC = fix(C.acc(N).to_matrix(N).subs(qdots)).subs(dict(zip(udots, ud_syms)))

    qs, us = [q1, q2], [u1, u2, u3, u4, u5]
    ext = [Ax, Ay, Az] + list(vel) + list(acc) + list(om) + list(omd) + [r, R, m, g]
    return {
        "M": sp.lambdify(qs + us + ext, MM, "numpy"),
        "F": sp.lambdify(qs + us + ext, FF, "numpy"),
        "Adep": sp.lambdify(qs + [u1, u2, u3] + ext, A_dep, "numpy"),
        "bdep": sp.lambdify(qs + [u1, u2, u3] + ext, b_dep, "numpy"),
        "n": sp.lambdify(qs, n_vec, "numpy"),
        "J": sp.lambdify(qs, n_vec.jacobian(qs), "numpy"),
        "aC": sp.lambdify(qs + us + list(ud_syms) + ext, aC, "numpy"),
    }


def kane_rates(k, ball, n, w, A, vA, aA, Om, Omd):
    """(n', omega', a_C) from Kane's equations."""
    q1, q2 = math.atan2(n[1], -n[2]), math.asin(-n[0])
    assert np.allclose(np.asarray(k["n"](q1, q2), dtype=float).ravel(), n, atol=1e-14)
    ext = (*A, *vA, *aA, *Om, *Omd, ball.r, ball.R, ball.m, ball.g)
    u45 = np.linalg.solve(np.asarray(k["Adep"](q1, q2, *w, *ext), dtype=float),
                          np.asarray(k["bdep"](q1, q2, *w, *ext), dtype=float).ravel())
    us = (*w, *u45)
    M = np.asarray(k["M"](q1, q2, *us, *ext), dtype=float)
    F = np.asarray(k["F"](q1, q2, *us, *ext), dtype=float).ravel()
    x = np.linalg.solve(M, F)
    n_dot = np.asarray(k["J"](q1, q2), dtype=float) @ x[:2]
    aC = np.asarray(k["aC"](q1, q2, *us, *x[2:], *ext), dtype=float).ravel()
    return n_dot, x[2:5], aC


def random_cases(seed, count):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        if abs(n[0]) > 0.95:  # q2 = +-90 deg: these coordinates are singular there
            continue
        w = rng.normal(scale=20.0, size=3)
        A, vA = rng.normal(scale=0.5, size=3), rng.normal(scale=2.0, size=3)
        aA, Om, Omd = rng.normal(scale=10.0, size=3), rng.normal(scale=3.0, size=3), rng.normal(scale=5.0, size=3)
        out.append((n, w, A, vA, aA, Om, Omd))
    return out


@pytest.fixture(scope="module")
def kane():
    return kane_model()


@pytest.mark.parametrize("ball", [Ball(), Ball(r=0.04, R=0.1, m=2.0, g=3.7)], ids=["paper", "other"])
def test_general_model_matches_kane(kane, ball):
    c = turning.constants(ball)
    worst = 0.0
    for n, w, A, vA, aA, Om, Omd in random_cases(21, 25):
        n_dot, w_dot, _ = kane_rates(kane, ball, n, w, A, vA, aA, Om, Omd)
        lib = np.array(turning.derivative(c, [*n, *w], (*aA, *Om, *Omd)))
        # sums of products of O(1e2)-O(1e3) numbers in double precision, and Kane's route
        # solves a 7x7 system: 1e-10 of each vector's size is round-off with a wide margin
        # (measured below 1e-13)
        e1 = np.linalg.norm(lib[:3] - n_dot) / max(np.linalg.norm(n_dot), 1e-3)
        e2 = np.linalg.norm(lib[3:] - w_dot) / np.linalg.norm(w_dot)
        worst = max(worst, e1, e2)
    assert worst <= 1e-10


def test_velocity_of_A_does_not_enter(kane):
    """Only a_A, Omega and Omega' enter the equations (a constant v_A changes nothing)."""
    ball = Ball()
    for n, w, A, vA, aA, Om, Omd in random_cases(4, 5):
        a = np.concatenate(kane_rates(kane, ball, n, w, A, vA, aA, Om, Omd)[:2])
        b = np.concatenate(kane_rates(kane, ball, n, w, A + 1.0, vA * 0.0 + 3.0, aA, Om, Omd)[:2])
        assert np.abs(a - b).max() <= 1e-11 * np.abs(a).max()


def test_contact_force_matches_kane_newton(kane):
    """turning.evaluate's force of the ball on the chamber against Newton with Kane's a_C."""
    ball = Ball()
    for n, w, A, vA, aA, Om, Omd in random_cases(6, 20):
        _, _, aC = kane_rates(kane, ball, n, w, A, vA, aA, Om, Omd)
        F_ball = ball.m * (aC + np.array([0.0, 0.0, ball.g]))
        cs = ChamberState(*A, *vA, *aA, *Om, *Omd, *np.eye(3).ravel(), *([0.0] * 14))
        o = turning.evaluate(ball, [*n, *w], cs)
        F_out = -np.array([o.Fx, o.Fy, o.Fz])
        assert np.linalg.norm(F_out - F_ball) <= 1e-10 * np.linalg.norm(F_ball)
        assert o.N == pytest.approx(-F_ball @ n, rel=1e-9, abs=1e-9 * np.linalg.norm(F_ball))
