"""BallInShell's warnings from a step (`BallInShell.step`), word for word, on the pythonfmu slave
in this process (tests/mutation/inprocess.py), where mutmut sees them: the coupling warning
(the contact point predicted over the last step against the corrected one, once per run), the
positions' resolution warning and the inconsistent-input warning with its latch of valid. Each is
an fmi2Warning, given once however often its cause comes back; the numbers in the text are the
published ones (coupling_error, t_invalid) and the inputs' own (|x1O| = l = 0.5 m, its
resolution 0.5 2^-52 m)."""
from __future__ import annotations

import sys
from pathlib import Path

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

from conformance.inputs import feed  # noqa: E402
from inprocess import OK, WARNING, InProcessFmu  # noqa: E402


def _run(name, steps, **parameters):
    """The crank law fed at every communication point; per step: (t_start, coupling_error after
    it, the log entries it wrote)."""
    f = InProcessFmu("BallInShell", name, **parameters)
    feed(f, 0.0)
    assert f.init() == OK, f.messages()
    t, rows = 0.0, []
    for h in steps:
        n = len(f.log)
        assert f.step(h, t) == OK, f.messages()
        rows.append((t, f.get("coupling_error"), f.log[n:]))
        t = t + h
        feed(f, t)
    return f, rows


def test_the_coupling_warning_names_the_error_and_the_threshold_once():
    f, rows = _run("cw", [0.02] * 6, coupling_warn=2e-10)
    warned = [(t, ce, log) for t, ce, log in rows if log]
    assert len(warned) == 1, rows
    t, ce, log = warned[0]
    assert t == 0.02 and ce > 1e-7  # the first corrected step
    assert log == [(WARNING, f"BallInShell 'cw': at t = 0.02 s the contact point predicted over the last step was "
                             f"off by {ce:.3g} m (> coupling_warn = 2e-10 m): the communication step is too long for "
                             f"how fast the platform motion changes; outputs between communication points carry "
                             f"errors of that size (warned once)")]
    assert all(ce > 2e-10 for _, ce, _ in rows[2:])  # still above the threshold: not warned again
    assert rows[0][1] == 0.0  # nothing to compare with after the first step
    # a threshold above every error: no warning
    _, rows = _run("cw2", [0.02] * 6, coupling_warn=2e-6)
    assert all(not log for _, _, log in rows) and max(ce for _, ce, _ in rows) > 1e-7


def test_the_resolution_warning_names_positions_resolution_and_window_once():
    f, rows = _run("rw", [1e-6] * 4)
    assert [log for _, _, log in rows] == [
        [], [(WARNING, "BallInShell 'rw': at t = 1e-06 s the positions (|x1O|, |y1O| up to 0.5 m, resolution "
                       "1.11e-16 m) over a window of 1e-06 s would give acceleration errors above 1e-6 m/s2: the "
                       "reconstruction uses the velocity and acceleration inputs there (warned once)")], [], []]
    assert f.get("valid") is True


def test_an_inconsistent_input_is_warned_once_and_latches_valid():
    f = InProcessFmu("BallInShell", "iw")
    feed(f, 0.0)
    assert f.init() == OK
    t = 0.0
    for k in range(14):
        assert f.step(0.01, t) == OK
        t += 0.01
        feed(f, t, noise=(lambda tt: {"vx1O": 1.0}) if k in (10, 12) else None)
    warnings = [m for s, m in f.log if s == WARNING]
    assert len(warnings) == 2, warnings
    t_bad = f.get("t_invalid")
    head = f"BallInShell 'iw': at t = {t_bad:.9g} s "
    assert warnings[0].startswith(head + "inputs x1O, vx1O, ax1O disagree between t = ")
    assert warnings[0].endswith("; the reconstruction restarts at the newer sample; flagged: valid = false "
                                "(warned once)")
    problem = warnings[0][len(head):-len("; flagged: valid = false (warned once)")]
    assert warnings[1] == f"BallInShell 'iw': valid = false from t = {t_bad:.9g} s (latched until reset): {problem}"
    assert abs(t_bad - 0.11) < 1e-12 and f.get("valid") is False
