"""ballmill.absorber.structure against closed forms: what the session-5 mutation run left alive.

* A single mass on a spring and dashpot (`Structure.single`) is the textbook damped
  oscillator: integrated from its own `derivative`, its free vibration follows
  q(t) = e^(-zeta w t) (q0 cos(wd t) + (v0 + zeta w q0) / wd sin(wd t)), wd = w sqrt(1 - zeta^2),
  and its energy falls at the rate the dashpot dissipates (dE/dt = -C q'^2, `powers`).
* A harmonic excitation's phase law: the instantaneous frequency is theta'(t) / 2 pi, and
  the amplitudes' per-axis components are A sin(theta); every number given as an int or
  a numeric string is stored as a float (the frequency too).
* A retuned excitation continues with the phase it has, reduced modulo 2 pi (never an odd
  multiple of pi off, which would flip the sign of the load).
* `StructureModel` keeps the structure it was built from (`.structure`).

Every value is computed inside the tests (mutmut maps mutants to what runs inside a test).
"""
from __future__ import annotations

import math

import pytest

from ballmill.absorber.structure import HarmonicForce, HarmonicGround, Structure, StructureModel

TWO_PI = 2.0 * math.pi


def _rk4(f, z, dt, n):
    for _ in range(n):
        k1 = f(z)
        k2 = f([a + 0.5 * dt * b for a, b in zip(z, k1)])
        k3 = f([a + 0.5 * dt * b for a, b in zip(z, k2)])
        k4 = f([a + dt * b for a, b in zip(z, k3)])
        z = [a + dt / 6.0 * (b + 2.0 * c + 2.0 * d + e) for a, b, c, d, e in zip(z, k1, k2, k3, k4)]
    return z


@pytest.mark.parametrize("both_axes", [False, True])
def test_single_mass_free_vibration_is_the_damped_oscillator(both_axes):
    M, f, zeta = 250.0, 0.8, 0.05
    st = Structure.single(M, f, zeta, both_axes=both_axes)
    sm = StructureModel(st)
    assert sm.structure is st  # the model keeps what it was built from
    assert sm.n_states == (4 if both_axes else 2)
    w = TWO_PI * f
    wd = w * math.sqrt(1.0 - zeta * zeta)
    q0, v0 = 0.03, -0.05
    z = sm.initial(qx=q0, qdx=v0, **({"qy": -q0, "qdy": 2 * v0} if both_axes else {}))
    # energy 1/2 M v^2 + 1/2 K q^2 with K = M w^2, and its rate -C v^2 with C = 2 zeta M w
    E0 = 0.5 * M * v0 * v0 + 0.5 * M * w * w * q0 * q0
    if both_axes:
        E0 += 0.5 * M * (2 * v0) ** 2 + 0.5 * M * w * w * q0 * q0
    assert sm.energy(z) == pytest.approx(E0, rel=1e-14)
    dz = sm.derivative(0.0, z, 0.0, 0.0)
    dEdt = sum(M * z[k + 1] * dz[k + 1] + M * w * w * z[k] * dz[k] for k in range(0, len(z), 2))
    P_exc, P_damp = sm.powers(z, (0.0, 0.0, 0.0, 0.0))
    assert P_exc == 0.0
    assert P_damp == pytest.approx(2 * zeta * M * w * (v0 * v0 + (4 * v0 * v0 if both_axes else 0.0)), rel=1e-14)
    assert dEdt == pytest.approx(-P_damp, rel=1e-12)
    # 1.5 periods with RK4 at 200 steps a period: error ~ (w dt)^4 ~ 1e-6 of the amplitude
    n, dt = 300, 1.0 / (200 * f)
    z = _rk4(lambda s: sm.derivative(0.0, s, 0.0, 0.0), z, dt, n)
    t = n * dt
    e = math.exp(-zeta * w * t)
    for q0_, v0_, k in ((q0, v0, 0), (-q0, 2 * v0, 2)) if both_axes else ((q0, v0, 0),):
        B = (v0_ + zeta * w * q0_) / wd
        q = e * (q0_ * math.cos(wd * t) + B * math.sin(wd * t))
        v = e * ((B * wd - zeta * w * q0_) * math.cos(wd * t) - (q0_ * wd + zeta * w * B) * math.sin(wd * t))
        assert z[k] == pytest.approx(q, abs=1e-6 * abs(q0_)), k
        assert z[k + 1] == pytest.approx(v, abs=1e-6 * w * abs(q0_)), k
    if not both_axes:
        # the cavity of a single mass is the mass: x_O = q, a_O = q'' (+ F_ball / M)
        cav = sm.cavity(t, z, 2.0, 7.0)
        acc = -w * w * z[0] - 2 * zeta * w * z[1]
        assert cav == pytest.approx((z[0], 0.0, z[1], 0.0, acc + 2.0 / M, 0.0), rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("cls", [HarmonicForce, HarmonicGround])
def test_phase_law_and_its_frequency_from_ints_and_strings(cls):
    # every field given as an int or a numeric string: stored as floats, the frequency too
    h = cls(2, 3, "-1", 0, "0.5", 0, 1)
    values = [getattr(h, k) for k in ("amplitude_x", "frequency", "amplitude_y", "phase", "phase_y",
                                      "sweep_rate", "t0")]
    assert values == [2.0, 3.0, -1.0, 0.0, 0.5, 0.0, 1.0]
    assert [type(v) for v in values] == [float] * 7
    g = cls(1.5, "0.25", sweep_rate="0.02", t0=-4)
    assert (g.frequency, g.sweep_rate, g.t0) == (0.25, 0.02, -4.0) and type(g.frequency) is float
    # theta'(t) / 2 pi is the instantaneous frequency (exact for the quadratic phase:
    # the central difference of a parabola is its derivative)
    for exc, t in ((h, 0.7), (h, 4.0), (g, 3.0), (g, 10.5)):
        d = 1e-3
        rate = (exc.theta(t + d) - exc.theta(t - d)) / (2 * d) / TWO_PI
        assert rate == pytest.approx(exc.instantaneous_frequency(t), rel=1e-9)
    assert h.instantaneous_frequency(5.0) == 3.0
    assert g.instantaneous_frequency(6.0) == pytest.approx(0.25 + 0.02 * 10.0, rel=1e-15)
    # the loads: A sin(theta) per axis, theta + phase_y for y
    th = TWO_PI * 3.0 * (1.3 - 1.0)
    want = (2.0 * math.sin(th), -1.0 * math.sin(th + 0.5))
    got = h.loads(1.3)
    assert (got[:2] if cls is HarmonicForce else got[2:]) == pytest.approx(want, rel=1e-12)
    assert (got[2:] if cls is HarmonicForce else got[:2]) == (0.0, 0.0)


@pytest.mark.parametrize("cls", [HarmonicForce, HarmonicGround])
@pytest.mark.parametrize("t", [5.0, 5.5, 7.5, 12.0])
def test_retuned_continues_with_the_phase_modulo_two_pi(cls, t):
    h = cls(3.0, 0.5, -2.0, 0.3, 1.1, 0.04, 2.0)
    s = t - 2.0
    theta = 0.3 + TWO_PI * (0.5 * s + 0.02 * s * s)
    r = h.retuned(0.9, t)
    phase = theta - TWO_PI * math.floor(theta / TWO_PI)
    assert r.phase == pytest.approx(phase, rel=1e-12)
    assert 0.0 <= r.phase < TWO_PI
    # the load continues without a jump, and then at the new steady frequency
    assert r.loads(t) == pytest.approx(h.loads(t), rel=1e-12, abs=1e-12)
    dt = 0.37
    th = phase + TWO_PI * 0.9 * dt
    want = (3.0 * math.sin(th), -2.0 * math.sin(th + 1.1))
    got = r.loads(t + dt)
    assert (got[:2] if cls is HarmonicForce else got[2:]) == pytest.approx(want, rel=1e-12, abs=1e-12)
