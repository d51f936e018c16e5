"""The validity latch (docs/conformance.md, "validity"): valid is latched false from the
first loss of contact, slip or flagged input inconsistency until reset; t_invalid is its time."""
from __future__ import annotations

from .conftest import OK
from .inputs import feed, run_ball

H = 2e-3


def test_valid_is_latched_after_slip_and_contact_loss(open_fmu):
    """t0 = 0.5 s: the crank's start makes the ball slip at once (|F_t|/N = 0.366 > mu = 0.3)
    and it later leaves the wall; valid stays false however often contact comes back."""
    fmu, st = run_ball(open_fmu, [], t0=0.5)
    t_invalid = None
    t = 0.0
    for _ in range(1000):
        assert fmu.step(H, t) == OK
        t += H
        feed(fmu, t, t0=0.5)
        if not fmu.get("valid") and t_invalid is None:
            t_invalid = fmu.get("t_invalid")
            assert t_invalid <= t
        if t_invalid is not None:
            assert not fmu.get("valid") and fmu.get("t_invalid") == t_invalid
    assert t_invalid is not None and 0.0 <= t_invalid < 2.0
    assert "valid = false from t = " in fmu.messages()


def test_valid_stays_true_on_the_papers_fast_start(open_fmu):
    fmu, st = run_ball(open_fmu, [H] * 500)
    assert st == OK and fmu.get("valid") and fmu.get("t_invalid") == 1e300


def test_reset_clears_the_latch(open_fmu):
    fmu, st = run_ball(open_fmu, [H] * 600, t0=0.5)
    assert not fmu.get("valid")
    assert fmu.reset() == OK
    feed(fmu, 0.0)
    assert fmu.init() == OK
    assert fmu.get("valid") and fmu.get("t_invalid") == 1e300


def test_state_restore_brings_back_the_latch(open_fmu):
    fmu, st = run_ball(open_fmu, [H] * 10)
    assert fmu.get("valid")
    s = fmu.get_state()
    t = fmu.time
    for _ in range(5):
        assert fmu.step(H, t) == OK
        t += H
        feed(fmu, t, offset=1.0)  # a jump: flagged
    assert not fmu.get("valid")
    assert fmu.set_state(s) == OK
    assert fmu.get("valid")


def test_a_slip_at_the_first_communication_point_is_reported_at_that_time(open_fmu):
    """Started at 1 s with the ball at xC0 = 0.05 m during the crank's start-up, the ball
    slips at once (|F_t|/N = 0.3009 > mu = 0.3): the warning dates it at the start, 1 s,
    not in an interval since an earlier communication point (there is none)."""
    fmu, st = run_ball(open_fmu, [H] * 3, t_start=1.0, xC0=0.05)
    assert st == OK
    assert not fmu.get("valid") and fmu.get("t_invalid") == 1.0
    assert fmu.log[0] == (1, "BallInShell 'ballinshell': slip at t = 1 s: |F_t|/N = 0.3009 > mu = 0.3; "
                             "the ball would slide"), fmu.messages()
    assert "valid = false from t = 1 s (latched until reset)" in fmu.messages()
