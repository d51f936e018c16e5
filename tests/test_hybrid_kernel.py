"""The hybrid ball (rolling, sliding, flight, impacts) in the compiled kernel (bmh_simulate in
ballmill/physics/_kernel.c via fast.hybrid_run) against the library's Python run on the
event-driven driver: the same grid, every output column, the same events (times, kinds, modes,
brackets, the maps' details), the same bookkeeping and work, bit for bit, in translating and turning chambers, in scenes that slide,
stick, leave the wall, fly and strike it."""
from __future__ import annotations

import numpy as np
import pytest

from ballmill.physics import (KERNEL_AVAILABLE, KERNEL_REASON, Ball, Circle, CrankStartup, Fixed, Harmonic,
                              KernelUnavailable, fast)
from ballmill.physics.hybrid import FLIGHT, ROLLING, Contact, simulate_hybrid
from ballmill.physics.turning.motions import Spin, Translation

pytestmark = pytest.mark.skipif(not KERNEL_AVAILABLE, reason=f"compiled kernel unavailable: {KERNEL_REASON}")

B = Ball()
DROP = ((0, 0, B.R - B.d + 0.05), (0, 0, 0), (0, 0, 0))
PLANE = Ball(r=0.025, R=1e8, mu=0.3)
GRAZE = Harmonic(x_amp=3.5 * 0.3 * 9.81 * (1 + 5e-5) / (4 * np.pi) ** 2, x_omega=4 * np.pi)  # test_hybrid's


def _both(*args, **kw):
    return (simulate_hybrid(*args, kernel="python", **kw), simulate_hybrid(*args, kernel="c", **kw))


def _identical(a, b):
    assert (a.success, a.message) == (b.success, b.message)
    assert a.info == b.info  # steps, rejected steps, evaluations
    assert np.array_equal(a.t, b.t)
    assert list(a.out) == list(b.out)
    for name in a.out:
        assert np.array_equal(a.out[name], b.out[name], equal_nan=True), \
            f"{name}: max diff {np.nanmax(np.abs(a.out[name] - b.out[name])):.3g}"
    assert a.events == b.events  # time, kind, modes, bracket width, the map's details
    assert (a.t_first_slip, a.t_first_flight) == (b.t_first_slip, b.t_first_flight)


@pytest.mark.parametrize("name, args, kw, kinds", [
    # slides on a plane (R = 1e8 m) until it rolls: a stick event
    ("slide-then-roll", (PLANE, Fixed(), 0.2, 0.01, Contact(mu_k=0.2)),
     dict(initial=((0, 0, 0.025), (1.0, 0, 0), (0, 0, 0))), {"stick"}),
    # dropped: flight, seven impacts, rest on the wall
    ("drop", (B, Fixed(), 0.5, 0.01, Contact(e_n=0.5)), dict(initial=DROP), {"impact"}),
    # the paper's fast start: rolling, sliding, rolling again, with the energy quadratures
    ("crank", (B, CrankStartup(t0=0.5), 0.5, 0.01, Contact(e_n=0.5)), {}, {"stick", "slip"}),
    # shaken: slips, leaves the wall, flies, strikes it with slip
    ("shaken", (Ball(mu=0.2), Harmonic(x_amp=0.05, x_omega=25.0), 0.5, 0.01, Contact(e_n=0.6, mu_k=0.15)),
     {}, {"slip", "leave", "impact"}),
    # a circling chamber: leaves the wall, strikes it until rest
    ("circle", (Ball(mu=0.1), Circle(l=0.05, w=20.0), 0.5, 0.01, Contact(e_n=0.6, mu_k=0.08)),
     {}, {"leave", "impact"}),
    # RK4 (fixed step, no end slope: the scan's is computed) through impacts with slip
    ("rk4-impacts", (Ball(mu=0.2), Harmonic(x_amp=0.05, x_omega=25.0), 0.5, 0.01, Contact(e_n=0.6, mu_k=0.15)),
     dict(method="RK4", h_fixed=2e-4), {"slip", "leave", "impact"}),
    # the rolling mode without the energy quadratures (rolling exactly as `simulate`), into
    # sliding and back
    ("no-energy", (B, CrankStartup(t0=0.5), 0.5, 0.01, Contact(e_n=0.5)), dict(energy=False), {"slip", "stick"}),
    # grazing slides (mu_k = mu, the rolling demand above mu N for 1.6 ms twice, the slip below
    # slip_eps): each ends by the grip guard where the demand falls back to mu N
    ("grazing", (Ball(R=1e8, mu=0.3), GRAZE, 0.5, 0.01, Contact()), {}, {"slip", "stick"}),
    # turning chambers (the general model rolling): a turntable's ball spun up to rolling,
    ("turntable", (Ball(R=1e6, mu=0.5), Spin(Omega=(0, 0, 2.0), A=(0, 0, 1e6)), 0.5, 0.01, Contact()),
     dict(initial=((0.1, 0, 0.025), (0, 0, 0), (0, 0, 0))), {"stick"}),
    # a drop into a spinning bowl, impacts until rest,
    ("bowl-drop", (B, Spin(Omega=(0, 0, 3.0), A=(0, 0, 0.25)), 0.6, 0.01, Contact(e_n=0.5)),
     dict(initial=((0, 0.05, 0.1), (0, 0, 0), (0, 0, 0))), {"impact"}),
    # a chamber spun fast about a horizontal axis: the ball slips, is carried up, leaves the
    # wall and strikes it
    ("horizontal-spin", (Ball(mu=0.05), Spin(Omega=(12.0, 0, 0), A=(0, 0, 0.25)), 1.0, 0.01,
                         Contact(e_n=0.5, mu_k=0.04)), {}, {"slip", "leave", "impact"}),
])
def test_kernel_gives_the_library_run_bit_for_bit(name, args, kw, kinds):
    a, b = _both(*args, **kw)
    _identical(a, b)
    assert a.success and {e.kind for e in a.events} == kinds, [(e.t, e.kind) for e in a.events]


def test_zeno_sequence_stops_with_the_same_message():
    """Impacts accumulating without a rest speed: the kernel stops at the same event with the
    library's message (the time, the count within the window)."""
    a, b = _both(B, Fixed(), 3.0, 0.01, Contact(e_n=0.9, v_rest=1e-300), initial=DROP, burst=20, max_rate=1e3)
    assert not b.success and "Zeno sequence: 20 events within" in b.message
    _identical(a, b)


def test_a_run_the_kernel_cannot_complete_is_redone_in_python(monkeypatch):
    """A shaking whose accelerations (1e300 m/s2) overflow the state: the kernel hands the run
    back and the Python driver reports the failure with its message."""
    from ballmill.physics import hybrid

    calls = []
    driver = hybrid.integrate
    monkeypatch.setattr(hybrid, "integrate", lambda *a, **k: calls.append(1) or driver(*a, **k))
    shake = Harmonic(x_amp=1.0, x_omega=1e150)
    with np.errstate(all="ignore"):
        a, b = _both(B, shake, 0.1, 0.01)
    assert calls == [1, 1]  # the Python run, and the kernel's run redone
    assert not b.success and "stopped at t = 0 s" in b.message
    _identical(a, b)


def test_auto_uses_the_kernel_and_c_refuses_what_it_does_not_cover(monkeypatch):
    calls = []
    run = fast.hybrid_run
    monkeypatch.setattr(fast, "hybrid_run", lambda *a, **k: calls.append(1) or run(*a, **k))
    tr = simulate_hybrid(B, Fixed(), 0.3, 0.01, Contact(e_n=0.5), initial=DROP)  # kernel="auto"
    assert calls == [1] and tr["mode"][0] == FLIGHT and tr["mode"][-1] == ROLLING
    simulate_hybrid(B, Translation(CrankStartup(t0=0.5)), 0.05, 0.01)  # a motion the kernel lacks: Python
    assert calls == [1]
    with pytest.raises(KernelUnavailable, match="chamber motion Translation"):
        simulate_hybrid(B, Translation(CrankStartup(t0=0.5)), 0.05, 0.01, kernel="c")
    with pytest.raises(ValueError, match="kernel must be one of"):
        simulate_hybrid(B, Fixed(), 0.1, 0.01, kernel="fortran")


def _random_scene(rng):
    """A random scene (seeded): ball, contact, one of the kernel's motions, a start at rest
    relative to the chamber or thrown in from inside it, a method."""
    mu = float(rng.uniform(0.05, 0.6))
    b = Ball(mu=mu, r=float(rng.uniform(0.01, 0.05)), R=float(rng.uniform(0.15, 0.4)))
    c = Contact(mu_k=mu * float(rng.uniform(0.5, 1.0)), e_n=float(rng.uniform(0.0, 0.9)),
                v_rest=float(rng.choice([0.01, 0.05])))
    motion = [lambda: Harmonic(x_amp=float(rng.uniform(0.01, 0.08)), x_omega=float(rng.uniform(5, 30)),
                               y_amp=float(rng.uniform(0, 0.05)), y_omega=float(rng.uniform(5, 30))),
              lambda: Circle(l=float(rng.uniform(0.02, 0.1)), w=float(rng.uniform(5, 25))),
              lambda: CrankStartup(l=float(rng.uniform(0.1, 0.5)), n0=float(rng.uniform(20, 80)),
                                   t0=float(rng.uniform(0.2, 1.0))),
              lambda: Spin(Omega=tuple(float(x) for x in rng.uniform(-10, 10, 3)), A=(0, 0, b.R))][
        int(rng.integers(0, 4))]()
    kw = {"method": str(rng.choice(["DOP853", "RK45", "RK4"])), "h_fixed": 5e-4, "tol": 1e-8,
          "energy": bool(rng.random() < 0.7)}
    if rng.random() < 0.5:  # thrown from 0.4 d below A with a random velocity and spin
        A = motion.A if isinstance(motion, Spin) else motion.state(0.0)[:2] + (b.R,)
        C = (A[0], A[1], A[2] - 0.4 * b.d)
        kw["initial"] = (C, tuple(float(x) for x in rng.uniform(-0.5, 0.5, 3)),
                         tuple(float(x) for x in rng.uniform(-5, 5, 3)))
    return (b, motion, 0.3, 0.01, c), kw


def test_random_scenes_bit_for_bit():
    """Ten seeded random scenes (motions, methods, starts, contact parameters), each identical.
    The same generator over 500 scenes (2200 events of every kind) found no difference."""
    rng = np.random.default_rng(22)
    kinds = set()
    for _ in range(10):
        args, kw = _random_scene(rng)
        a, b = _both(*args, **kw)
        _identical(a, b)
        kinds |= {e.kind for e in a.events}
    assert kinds == {"slip", "stick", "leave", "impact"}


def _chained(ball, motion, t_end, dt, contact, initial, **kw):
    """The kernel's one-interval entry (bmh_interval, the native BallInShell FMU's step with
    contact = 2) called once per grid interval, mode, state, step and bookkeeping carried from
    each call to the next: (the library's run, the chained rows)."""
    from ballmill.physics.hybrid import HybridBall

    ref = simulate_hybrid(ball, motion, t_end, dt, contact, initial=initial, kernel="python", **kw)
    system = HybridBall(ball, motion, contact, kw.get("method", "DOP853"), 1e-9, None, kw.get("energy", True),
                        kw.get("h_fixed", 1e-3))
    mode, y = system.start(0.0, *initial)
    step = fast.HybridInterval(system)
    rows, h = [system.sample(mode, 0.0, y)], None
    for t0, t1 in zip(ref.t[:-1], ref.t[1:]):
        status, mode, y, h, row = step.run(mode, t0, t1, y, h)
        assert status == 0, (t0, status)
        rows.append(row)
    return ref, np.array(rows, dtype=float)


@pytest.mark.parametrize("name, args, kw", [
    # slips at once (the initial step of the sliding mode's 11 states), sticks, rolls without
    # the quadratures
    ("crank", (B, CrankStartup(t0=0.5), 0.3, 0.01, Contact(e_n=0.5)), dict(energy=False)),
    # impacts, rebounds across grid points (the rebound flag carried), rest
    ("drop", (B, Fixed(), 0.4, 0.01, Contact(e_n=0.5)), {}),
    # a turning chamber: slip, leave, impacts
    ("horizontal-spin", (Ball(mu=0.05), Spin(Omega=(12.0, 0, 0), A=(0, 0, 0.25)), 0.6, 0.01,
                         Contact(e_n=0.5, mu_k=0.04)), {}),
])
def test_the_interval_entry_chained_over_the_grid_gives_the_run_bit_for_bit(name, args, kw):
    ball, motion = args[0], args[1]
    if name == "drop":
        initial = DROP
    elif name == "crank":  # at rest at the bottom of the chamber at O = (l, 0)
        initial = ((motion.state(0.0)[0], 0.0, ball.R - ball.d), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    else:  # co-rotating at the bottom of the spinning chamber
        initial = ((0.0, 0.0, 0.25 - ball.d), (0.0, 12.0 * ball.d, 0.0), (12.0, 0.0, 0.0))
    ref, rows = _chained(*args, initial=initial, **kw)
    assert ref.success and len(ref.events) >= 2
    from ballmill.physics.hybrid import HybridBall
    for j, col in enumerate(HybridBall.COLUMNS):
        assert np.array_equal(rows[:, j], ref.out[col], equal_nan=True), col


def test_the_hold_in_a_moving_chamber_removes_the_velocity_relative_to_the_wall_bit_for_bit():
    """The same drop in a chamber circling slowly (Circle l = 0.5 m, w = 0.2 rad/s: 0.1 m/s,
    0.02 m/s2; the ball given the chamber's velocity): the Zeno stop still comes (62 events) and
    the hold removes the normal velocity relative to the moving wall, v_A included, and carries
    the torque quadrature Lq on (not 0 here: v_A x v_C has a z component), the kernel's run the
    library's bit for bit; the energy balance, with the chamber's work, within 1e-10 J
    (measured 1.4e-11 J: the work quadrature's error at tol 1e-9)."""
    b = Ball(mu=0.02)
    l, w = 0.5, 0.2
    args = (b, Circle(l=l, w=w), 2.5, 0.01, Contact(e_n=0.9, v_rest=1e-300))
    kw = dict(initial=((l + 0.03, 0, b.R - b.d + 0.05), (0, l * w, 0), (0, 0, 0)), burst=20, max_rate=1e3)
    a, c = _both(*args, **kw, on_zeno="hold")
    _identical(a, c)
    assert a.success and a.message.startswith("held on the wall, rolling only, from t = 1.866")
    assert np.max(np.abs(a.energy_residual)) < 1e-10


def test_a_zeno_sequence_can_hold_the_ball_on_the_wall_instead_bit_for_bit():
    """on_zeno = "hold" (what the BallInShell FMU does): the same drop, off-centre onto a wall
    with mu = 0.02, holds the ball on the wall at the event that made the Zeno stop (the 'stop'
    run's last event, its message named in the run's) and goes on to the end with success: rolling
    only (mode 1, slip 0, gap 0 to round-off, no event after the hold), although rolling's |F_t|/N exceeds mu
    there (the slip guard is off while held; measured 0.0208); the energy balance holds through
    the hold (measured 1.6e-15 J); the kernel's run is the library's bit for bit."""
    b = Ball(mu=0.02)
    args = (b, Fixed(), 2.5, 0.01, Contact(e_n=0.9, v_rest=1e-300))
    kw = dict(initial=((0.03, 0, b.R - b.d + 0.05), (0, 0, 0), (0, 0, 0)), burst=20, max_rate=1e3)
    a, c = _both(*args, **kw, on_zeno="hold")
    _identical(a, c)
    stop = simulate_hybrid(*args, **kw, kernel="python")
    t_held = stop.events[-1].t
    assert not stop.success and a.success and a.t[-1] == 2.5 and a.events == stop.events
    assert a.message == f"held on the wall, rolling only, from t = {t_held:.9g} s: " + stop.message.split(": ", 1)[1]
    after = a.t > t_held
    assert np.all(a["mode"][after] == ROLLING) and np.all(a["slip_speed"][after] == 0.0)
    assert np.max(np.abs(a["gap"][after])) < 1e-15  # |C - A| = R - r to round-off
    assert np.max(a["Ft"][after] / a["N"][after]) > 0.02
    assert np.max(np.abs(a.energy_residual)) < 1e-12
