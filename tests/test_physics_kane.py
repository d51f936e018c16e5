"""An independent derivation of the equations of motion with Kane's method
(sympy.physics.mechanics), compared with the library at random states.

Nothing of the library's algebra is used here. The model is set up from
scratch:

* inertial frame N, z up; the chamber centre A moves as (xO(t), yO(t), R)
  (prescribed, the chamber does not rotate);
* two generalized coordinates q1, q2 place the ball centre: a frame Bn is
  rotated from N by q1 about x then q2 about the new y, and C = A - (R - r) Bn.z;
* the ball's absolute angular velocity components in N are the generalized
  speeds u1, u2, u3 (the orientation itself is not needed: the inertia of a
  solid sphere is isotropic); u4 = q1', u5 = q2' are dependent speeds;
* no slip: the material point of the ball at the contact P = C - r Bn.z has
  the chamber's velocity (that of A). Its two tangential components (along
  Bn.x, Bn.y) are the nonholonomic constraints; the normal one vanishes
  identically because C stays on its sphere;
* loads: gravity -m g N.z at C. The contact force is a constraint force and
  drops out of Kane's equations.

Then q', u' follow from KanesMethod's full mass matrix and forcing vector,
solved numerically; n = -Bn.z and n' = dn/dq q'.
"""
import functools
import math
import time

import numpy as np
import pytest

sp = pytest.importorskip("sympy")
me = pytest.importorskip("sympy.physics.mechanics")

from ballmill.physics import Ball, VectorFormulation, evaluate  # noqa: E402


@functools.lru_cache(maxsize=1)
def kane_model():
    t_start = time.perf_counter()
    q1, q2 = me.dynamicsymbols("q1 q2")
    u1, u2, u3, u4, u5 = me.dynamicsymbols("u1:6")
    xO, yO = me.dynamicsymbols("xO yO")
    t = me.dynamicsymbols._t
    r, R, m, g = sp.symbols("r R m g", positive=True)
    ax, ay, vx, vy = sp.symbols("ax ay vx vy", real=True)

    N = me.ReferenceFrame("N")
    Bn = N.orientnew("Bn", "Body", (q1, q2, 0), "XYZ")
    ball_frame = me.ReferenceFrame("Bf")
    ball_frame.set_ang_vel(N, u1 * N.x + u2 * N.y + u3 * N.z)

    O1 = me.Point("O1")
    O1.set_vel(N, 0)
    A = O1.locatenew("A", xO * N.x + yO * N.y + R * N.z)
    A.set_vel(N, A.pos_from(O1).dt(N))
    C = A.locatenew("C", -(R - r) * Bn.z)
    C.set_vel(N, C.pos_from(O1).dt(N))
    P = C.locatenew("P", -r * Bn.z)
    P.v2pt_theory(C, N, ball_frame)  # the ball's material point at the contact

    kd = [q1.diff(t) - u4, q2.diff(t) - u5]
    qdots = {q1.diff(t): u4, q2.diff(t): u5}
    slip = P.vel(N) - A.vel(N)  # the chamber translates: its material point at P moves as A
    constraints = [sp.simplify(slip.dot(Bn.x).subs(qdots)), sp.simplify(slip.dot(Bn.y).subs(qdots))]
    # the normal component is identically zero (C stays on its sphere)
    assert sp.simplify(slip.dot(Bn.z).subs(qdots)) == 0

    I = sp.Rational(2, 5) * m * r**2
    ball = me.RigidBody("ball", C, ball_frame, m, (me.inertia(N, I, I, I), C))
    KM = me.KanesMethod(N, q_ind=[q1, q2], u_ind=[u1, u2, u3], kd_eqs=kd,
                        u_dependent=[u4, u5], velocity_constraints=constraints)
    KM.kanes_equations([ball], [(C, -m * g * N.z)])

    prescribed = {xO.diff(t, 2): ax, yO.diff(t, 2): ay, xO.diff(t): vx, yO.diff(t): vy}
    MM = KM.mass_matrix_full.subs(prescribed)
    FF = KM.forcing_full.subs(prescribed)
    left = me.find_dynamicsymbols(MM) | me.find_dynamicsymbols(FF)
    assert left <= {q1, q2, u1, u2, u3, u4, u5}, left

    # dependent speeds from the constraints (linear in u4, u5)
    A_dep, b_dep = sp.linear_eq_to_matrix(constraints, [u4, u5])
    n_vec = (-Bn.z).to_matrix(N)
    # acceleration of C (for the contact force, by Newton: F = m a_C + m g e_z)
    udots = [u.diff(t) for u in (u1, u2, u3, u4, u5)]
    ud_syms = sp.symbols("ud1:6")
    aC = C.acc(N).to_matrix(N).subs(prescribed).subs(qdots)
    aC = aC.subs(dict(zip(udots, ud_syms)))

    qs, us = [q1, q2], [u1, u2, u3, u4, u5]
    params = [r, R, m, g]
    f = {
        "M": sp.lambdify(qs + us + [ax, ay, vx, vy] + params, MM, "numpy"),
        "F": sp.lambdify(qs + us + [ax, ay, vx, vy] + params, FF, "numpy"),
        "Adep": sp.lambdify(qs + [u1, u2, u3] + params, A_dep, "numpy"),
        "bdep": sp.lambdify(qs + [u1, u2, u3] + params, b_dep, "numpy"),
        "n": sp.lambdify(qs, n_vec, "numpy"),
        "J": sp.lambdify(qs, n_vec.jacobian(qs), "numpy"),
        "aC": sp.lambdify(qs + us + list(ud_syms) + [ax, ay] + params, aC, "numpy"),
    }
    f["seconds"] = time.perf_counter() - t_start
    return f


def q_from_n(n):
    """Inverse of n(q) = (-sin q2, sin q1 cos q2, -cos q1 cos q2)."""
    return math.atan2(n[1], -n[2]), math.asin(-n[0])


def kane_rates(k, ball, n, w, ax, ay, vx=0.0, vy=0.0):
    """(n', omega', a_C) from Kane's equations."""
    q1, q2 = q_from_n(n)
    nq = np.asarray(k["n"](q1, q2), dtype=float).ravel()
    assert np.allclose(nq, n, atol=1e-14)
    p = (ball.r, ball.R, ball.m, ball.g)
    u45 = np.linalg.solve(np.asarray(k["Adep"](q1, q2, *w, *p), dtype=float),
                          np.asarray(k["bdep"](q1, q2, *w, *p), dtype=float).ravel())
    us = (*w, *u45)
    M = np.asarray(k["M"](q1, q2, *us, ax, ay, vx, vy, *p), dtype=float)
    F = np.asarray(k["F"](q1, q2, *us, ax, ay, vx, vy, *p), dtype=float).ravel()
    x = np.linalg.solve(M, F)  # q1', q2', u1' .. u5'
    n_dot = np.asarray(k["J"](q1, q2), dtype=float) @ x[:2]
    aC = np.asarray(k["aC"](q1, q2, *us, *x[2:], ax, ay, *p), dtype=float).ravel()
    return n_dot, x[2:5], aC


def random_states(seed, count, lower_only):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        if lower_only:
            n[2] = -abs(n[2])
        if abs(n[0]) > 0.95:  # q2 = +-90 deg is where these coordinates are singular
            continue
        w = rng.normal(scale=20.0, size=3)
        ax, ay = rng.normal(scale=10.0, size=2)
        out.append((n, w, ax, ay))
    return out


@pytest.fixture(scope="module")
def kane():
    return kane_model()


def test_kane_derivation_is_quick(kane):
    # derivation + lambdify measured at ~0.7 s; the budget is 20 s
    assert kane["seconds"] < 20.0


@pytest.mark.parametrize("lower_only", [True, False], ids=["lower-hemisphere", "whole-sphere"])
@pytest.mark.parametrize("ball", [Ball(), Ball(r=0.04, R=0.1, m=2.0, g=3.7)], ids=["paper", "other"])
def test_vector_formulation_matches_kane(kane, ball, lower_only):
    form = VectorFormulation(ball)
    for n, w, ax, ay in random_states(11 if lower_only else 12, 20, lower_only):
        n_dot, w_dot, _ = kane_rates(kane, ball, n, w, ax, ay)
        lib = np.array(form.derivative([*n, *w], ax, ay))
        # both are sums of products of O(1e2) numbers evaluated in double
        # precision; Kane's route also solves a 7x7 system: agreement to
        # 1e-10 of each vector's size is round-off with a wide margin
        # (measured: at most 2e-14 relative; with I = 0.41 m r^2 instead of
        # 0.4 the omega' error is 7e-3)
        assert np.linalg.norm(lib[:3] - n_dot) <= 1e-10 * max(np.linalg.norm(n_dot), 1e-3)
        assert np.linalg.norm(lib[3:] - w_dot) <= 1e-10 * np.linalg.norm(w_dot)


def test_kane_is_galilean(kane):
    """A constant chamber velocity must not change anything (only a_O enters)."""
    ball = Ball()
    for n, w, ax, ay in random_states(3, 5, True):
        a = np.concatenate(kane_rates(kane, ball, n, w, ax, ay)[:2])
        b = np.concatenate(kane_rates(kane, ball, n, w, ax, ay, vx=3.0, vy=-2.0)[:2])
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()


def test_contact_force_matches_kane_newton(kane):
    """The outputs' contact force against Newton's law applied to Kane's a_C."""
    ball = Ball()
    for n, w, ax, ay in random_states(5, 20, True):
        _, _, aC = kane_rates(kane, ball, n, w, ax, ay)
        F_ball = ball.m * (aC + np.array([0.0, 0.0, ball.g]))  # chamber's force on the ball
        o = evaluate(ball, n, w, ax, ay)
        F_out = -np.array([o.Fx, o.Fy, o.Fz])  # outputs: the ball's force on the chamber
        assert np.linalg.norm(F_out - F_ball) <= 1e-10 * np.linalg.norm(F_ball)
        assert o.N == pytest.approx(-F_ball @ n, rel=1e-9, abs=1e-9 * np.linalg.norm(F_ball))
