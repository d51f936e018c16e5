"""The one integration driver (ballmill/physics/events.py, docs/design.md sections 7 and 14):
every grid loop of the library runs on `events.integrate` (the rolling models' `simulate` and
`simulate_general`, the absorber's runs, the hybrid ball), and doing so changed no number.

The pins below were taken from the separate loops the driver replaced (each model's own loop
of `Integrator.advance` calls), as float.hex: the driver must reproduce them exactly, on the
Python path and in the compiled kernel (whose handed-back intervals run on the driver too)."""
from __future__ import annotations

import math

import pytest

from ballmill.absorber import linear as lin
from ballmill.absorber.model import StructureBall, simulate_absorber, simulate_structure
from ballmill.absorber.structure import GroundRecord, HarmonicForce, Structure
from ballmill.physics import KERNEL_AVAILABLE, Ball, BallModel, CrankStartup, Fixed, Integrator, simulate
from ballmill.physics.events import Plain, integrate
from ballmill.physics.hybrid import ROLLING, Contact, simulate_hybrid
from ballmill.physics.turning import model as tm
from ballmill.physics.turning.motions import Fig1Machine

G = 9.81
FAST = CrankStartup(l=0.5, n0=60.0, t0=2.5)
R_TUNED = lin.cavity_radius(0.8, 0.025)
RECORD = GroundRecord((0.0, 0.33, 1.0, 2.0), (0.0, 0.5, -0.2, 0.0), (0.0, 0.1, 0.0, 0.0))
KERNELS = ["python"] + (["auto"] if KERNEL_AVAILABLE else [])

# (number of samples, accepted steps, evaluations, then values as float.hex)
PINS = {
    "simulate DOP853": [301, 300, 3901, "0x1.d8213f1c10280p-4", "-0x1.97ad51bcf2488p-2",
                        "-0x1.15ea323797611p+5", "0x1.795d6a0172402p-1", "-0x1.462734cbc06dfp-2",
                        "-0x1.145e5748b0baap+6", "0x1.20b6a0247540fp+4", "0x1.1a601f75657c6p+0"],
    "simulate RK4": [301, 600, 2400, "0x1.d8214426cc6ffp-4", "-0x1.97ad521bba43ap-2",
                     "-0x1.15ea3201e5dd8p+5", "0x1.795d6e1988fefp-1", "-0x1.46273a6fcfdaep-2",
                     "-0x1.145e50c0f3690p+6", "0x1.20b69a2d9b4a6p+4", "0x1.1a601f1bb9bb9p+0"],
    "general fig1": [101, 100, "0x1.0677519d8d947p-2", "0x1.d6e871f976769p-1", "-0x1.306af6e86fd31p-2",
                     "-0x1.7fbe07dc20a91p+4", "-0x1.a237a43f96524p+1", "-0x1.08a39a1099e23p+5",
                     "0x1.5a354f17a414fp+2", "-0x1.01df8341a6076p+1"],
    "absorber": [61, 63, 817, "0x1.181f6a55df01ap-10", "0x1.4ef3fd277c2b6p-7", "0x1.c03243bc98033p-12",
                 "0x1.0bf6641f96889p-8", "-0x1.4c7b4a29ef904p-6", "-0x1.09fc3b54bfa6ap-7",
                 "-0x1.ffe0b09a01efep-1", "-0x1.d4b51ebe47156p-3", "0x1.24f13336ec6dcp-1",
                 "0x1.a9137d1cbdcfep-58", "0x1.6107fff02a15bp-7", "0x1.f0cea3f14896ep-11", "0x0.0p+0",
                 "0x1.39eb729796511p+4"],
    "absorber record": [21, 43, 586, "-0x1.d6f2e8d2804ffp-6", "-0x1.f80e088bf9820p-9",
                        "-0x1.314136d20886fp-8", "-0x1.ad2daa4b28140p-11", "-0x1.f4b8a3420fce3p-4",
                        "-0x1.10ed210624bf3p-6", "-0x1.fc169b6808ab0p-1", "0x1.7b3eccef166eep+1",
                        "-0x1.1080422909151p+4", "-0x1.43f73e4aae1a5p-4", "0x1.8fe97c80ba9c6p+0",
                        "0x1.7844748a36977p-3", "0x0.0p+0"],
    "structure record": [21, "-0x1.fe264cbfc651ap-6", "0x1.268bb044165cfp-7", "-0x1.511dfa1452fefp-8",
                         "0x1.2ffbc84c01206p-10", "0x1.74b5cc43dae76p+0", "0x1.8c6b7d5ee909cp-3",
                         "0x1.075fe504da4f9p+0"],
}


def _hex(x):
    return float(x).hex()


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("method, opts", [("DOP853", {"tol": 1e-9}), ("RK4", {"h_fixed": 0.005})])
def test_simulate_keeps_its_numbers(method, opts, kernel):
    m = BallModel(Ball(), method=method, **opts)
    tr = simulate(m, FAST, 3.0, 0.01, state=m.initial(xC0=0.02), kernel=kernel)
    got = [len(tr.t), tr.info.steps, tr.info.nfev] + [_hex(tr.y[k, j]) for k in (100, -1) for j in (0, 2, 5)]
    assert got + [_hex(tr["N"][-1]), _hex(tr["Ft"][150])] == PINS[f"simulate {method}"]


def test_a_stopped_simulate_keeps_its_message():
    """The paper formulation reaches its equator limit: the run ends at the last grid point
    reached, named in the message."""
    m = BallModel(Ball(), formulation="paper", method="RK45", tol=1e-8)
    tr = simulate(m, FAST, 4.0, 0.01, state=m.initial(xC0=0.05, yC0=0.02), kernel="python")
    assert not tr.success and len(tr.t) == 216 and _hex(tr.y[-1, 0]) == "-0x1.9de007424e567p-5"
    assert tr.message.startswith("stopped at t = 2.15 s: paper formulation stopped: the ball centre "
                                 "is 1.14 deg below the chamber's equator"), tr.message


@pytest.mark.parametrize("kernel", KERNELS)
def test_simulate_general_keeps_its_numbers(kernel):
    mo = Fig1Machine()
    cm = tm.ChamberModel(Ball(), kernel=kernel)
    tr = tm.simulate_general(cm, mo, 1.0, 0.01, cm.initial(mo, xC0=0.03), kernel=kernel)
    got = [len(tr.t), tr.info.steps] + [_hex(tr.y[-1, j]) for j in range(6)]
    assert got + [_hex(tr["N"][50]), _hex(tr["M1"][-1])] == PINS["general fig1"]


def test_absorber_keeps_its_numbers():
    sb = StructureBall(Structure.single(100.0, 0.8, 0.01), Ball(r=0.025, R=R_TUNED, m=2.0),
                       HarmonicForce(1.0, 0.75, amplitude_y=0.4))
    r = simulate_absorber(sb, 3.0, 0.05, kernel="python")
    assert [len(r.t), r.steps, r.nfev] + [_hex(v) for v in r.z[-1]] + [_hex(r["N"][10])] == PINS["absorber"]


def test_absorber_and_structure_land_on_a_ground_records_breakpoints():
    """A ground record's samples are breakpoints of its acceleration: the driver lands on each
    (`stops`), as the absorber's own loop did, with the same floats."""
    sb = StructureBall(Structure.single(100.0, 0.8, 0.01), Ball(r=0.025, R=R_TUNED, m=2.0), RECORD)
    r = simulate_absorber(sb, 2.0, 0.1)
    assert [len(r.t), r.steps, r.nfev] + [_hex(v) for v in r.z[-1]] == PINS["absorber record"]
    s = simulate_structure(Structure.single(100.0, 0.8, 0.01), RECORD, 2.0, 0.1)
    assert [len(s.t)] + [_hex(v) for v in s.z[-1]] + [_hex(s["E"][7])] == PINS["structure record"]


def test_stops_are_landed_on_and_not_sampled():
    """y' = |t - 0.3 s| (a kink at 0.3 s, as a ground record's at its samples): landing on
    0.3 s the method integrates each piece, a polynomial, exactly (y(0.5) = 0.065,
    y(1) = 0.29 to round-off), where stepping across the kink leaves an error the controller
    only bounds by its tolerance; the stop is not a row of the output."""
    def f(t, y):
        return (abs(t - 0.3),)

    integ = Integrator("RK45", tol=1e-6, scale=[1.0])
    plain = Plain(integ, f, lambda t, y: (t, float(y[0])))
    run = integrate(plain, 0, 0.0, [0.0], [0.0, 0.5, 1.0], stops=(0.3,))
    assert run.success and [r[0] for r in run.rows] == [0.0, 0.5, 1.0]
    assert abs(run.rows[1][1] - 0.065) < 1e-15 and abs(run.rows[2][1] - 0.29) < 1e-15
    crossed = integrate(plain, 0, 0.0, [0.0], [0.0, 0.5, 1.0])
    assert abs(crossed.rows[2][1] - 0.29) > 1e-12


def test_fixed_step_rk4_locates_impacts_on_its_own_steps():
    """The hybrid ball on RK4 with a fixed step (7 ms, not a divisor of the 10 ms grid): the
    drop's impacts at their closed-form times to 1e-10 s (free flight is a quadratic, which
    RK4 follows exactly), each located on the method's own step from the step's start."""
    b = Ball()
    h0, e = 0.05, 0.5
    tr = simulate_hybrid(b, Fixed(), 0.5, 0.01, Contact(e_n=e),
                         initial=((0, 0, b.R - b.d + h0), (0, 0, 0), (0, 0, 0)), method="RK4", h_fixed=0.007)
    impacts = tr.of_kind("impact")
    t1 = math.sqrt(2 * h0 / G)
    assert tr.success and len(impacts) == 7
    for k, ev in enumerate(impacts):
        assert abs(ev.t - (t1 + 2 * e * t1 * (1 - e ** k) / (1 - e))) < 1e-10 and ev.width <= 1e-10
    # fixed steps: 0.5 s at 7 ms, each shortened where a grid point or an event cuts it
    assert 0.5 / 0.007 < tr.info.steps < 0.5 / 0.007 + len(tr.t) + 2 * len(tr.events)
    assert tr["mode"][-1] == ROLLING


def test_a_bounce_sequence_near_e_1_ends_by_the_rest_rule_at_a_bounded_cost():
    """Dropped from h0 with e_n = 0.95 and a tiny v_rest = 1e-5 m/s (the event-rate cap opened
    wide, so only the model ends the sequence): the k-th impact comes at e^(k-1) v1, so the
    rest rule (rebound e v_k < v_rest) ends it at the K-th impact, K the first k with
    e^k v1 < v_rest (193 here): exactly K events, the last at t_inf - 2 t1 e^K / (1 - e).
    The hops shrink by four decades on the way, the work per hop does not: free flight is a
    quadratic the method follows to round-off, so the controller grows the step tenfold after
    the first (a quarter of the hop at most, `HybridBall.first_step`) and a hop takes two
    steps, one more where a grid point cuts it (measured: 2.2 per impact)."""
    b = Ball()
    h0, e, v_rest = 2e-3, 0.95, 1e-5
    v1, t1 = math.sqrt(2 * G * h0), math.sqrt(2 * h0 / G)
    K = next(k for k in range(1, 10 ** 4) if e ** k * v1 < v_rest)
    assert K == 193 and 0.99 < e ** K * v1 / v_rest < 1 < e ** (K - 1) * v1 / v_rest  # no tie
    t_inf = t1 * (1 + e) / (1 - e)
    tr = simulate_hybrid(b, Fixed(), 0.8, 0.01, Contact(e_n=e, v_rest=v_rest),
                         initial=((0, 0, b.R - b.d + h0), (0, 0, 0), (0, 0, 0)), burst=10 ** 9)
    impacts = tr.of_kind("impact")
    assert tr.success and len(tr.events) == len(impacts) == K
    assert impacts[-1].details["rest"] and not any(ev.details.get("rest") for ev in impacts[:-1])
    assert abs(impacts[-1].t - (t_inf - 2 * t1 * e ** K / (1 - e))) < 1e-9
    assert tr["mode"][-1] == ROLLING and tr["gap"][-1] == 0.0
    n_grid = len(tr.t) - 1
    assert tr.info.steps <= 2 * K + n_grid + 10, (tr.info, K, n_grid)
