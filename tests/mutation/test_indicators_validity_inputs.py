"""ballmill.sweep.indicators.validity on the inputs a reader hands it: what the session-5
mutation run left alive.

`validity` converts N and the friction ratio to float arrays before it judges them, so a
missing sample (None, as a results table with gaps gives it) counts as bad exactly like NaN,
and numbers read as text are judged by their values. The rule itself: a sample is bad when
N <= 0 (contact lost) or not |F_t| / N <= mu (slip; NaN is bad); the answer is
(valid, t of the first bad sample or None, its index or len(t)).
"""
from __future__ import annotations

import math

import pytest

from ballmill.sweep.indicators import validity

T = [0.0, 0.5, 1.0, 1.5]

CASES = [
    # N, friction ratio, mu, answer
    ([2.0, 1.0, 3.0, 4.0], [0.1, 0.2, 0.3, 0.1], 0.3, (True, None, 4)),
    ([2.0, None, 3.0, 4.0], [0.1, 0.2, 0.3, 0.1], 0.3, (False, 0.5, 1)),      # N missing: bad
    ([2.0, 1.0, 3.0, None], [0.1, 0.2, 0.3, 0.1], 0.3, (False, 1.5, 3)),
    ([2.0, 1.0, 3.0, 4.0], [0.1, 0.2, None, 0.1], 0.3, (False, 1.0, 2)),      # ratio missing: bad
    ([2.0, 1.0, 3.0, 4.0], [None, 0.2, 0.3, 0.1], 0.3, (False, 0.0, 0)),
    ([2.0, 1.0, math.nan, 4.0], [0.1, 0.2, 0.3, None], 0.3, (False, 1.0, 2)),  # the first of two
    (["2", "1.5", "0", "4"], [0.1, 0.2, 0.3, 0.1], 0.3, (False, 1.0, 2)),     # text: by value (N = 0)
    (["2", "1.5", "3e0", "4"], ["0.1", "0.2", "0.30", "0.1"], 0.3, (True, None, 4)),
    ([2.0, 1.0, 3.0, 4.0], ["0.1", "0.31", "0.2", "0.1"], 0.3, (False, 0.5, 1)),  # text: slip
]


@pytest.mark.parametrize("N, ratio, mu, want", CASES, ids=[str(i) for i in range(len(CASES))])
def test_validity_judges_missing_and_text_samples_by_value(N, ratio, mu, want):
    got = validity(T, N, ratio, mu)
    assert got == want
    assert type(got[0]) is bool and type(got[2]) is int
    assert got[1] is None or type(got[1]) is float
