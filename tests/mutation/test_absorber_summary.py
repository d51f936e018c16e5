"""ballmill.absorber.summary.structure_summary, every key and value, on small synthetic runs.

Each case is a hand-made time history on t = 0, 0.1, .., 1 s whose extremes sit on the
window's edges: the first sample of the window (t = after exactly), the run's last
sample, and a larger value on the sample just before the window that must not count.
The displacements and accelerations are 3-4-5 triangles, so the magnitudes and RMS
values are exact; the expected dicts are written out by hand, key for key (the keys are
what a study, a scenario's summary.json and a reader see).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.absorber.summary import structure_summary

T = [0.1 * i for i in range(11)]  # T[5] == 0.5 exactly
BIG = 1e3  # before the window (t = 0.4): must not count


def window(before, values):
    """A column: ``before`` on the five samples t < 0.5, then the window's six values."""
    return np.array([0.0, 0.0, 0.0, 0.0, before] + list(values), dtype=float)


def structure(scale=1.0, acc=1.0):
    """xO, yO [m], axO, ayO [m/s2]: in the window |(x, y)| = 3 at its first sample (x = -3),
    1 in the middle, 4 at its last (y = -4): peak 4, RMS sqrt(26 / 6), x peak 3, y peak 4;
    the accelerations are the displacements times 10 acc, but with x and y swapped."""
    x = [-3.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    y = [0.0, 0.0, 0.0, 0.0, 0.0, -4.0]
    return {"xO": window(BIG, [scale * v for v in x]), "yO": window(-BIG, [scale * v for v in y]),
            "axO": window(BIG, [10 * acc * scale * v for v in y]),
            "ayO": window(BIG, [10 * acc * scale * v for v in x])}


def own(scale=1.0):
    rms = math.sqrt(26.0 / 6.0)
    return {"displacement_peak_m": 4.0 * scale, "displacement_rms_m": rms * scale,
            "displacement_x_peak_m": 3.0 * scale, "displacement_y_peak_m": 4.0 * scale,
            "acceleration_peak_m_s2": 40.0 * scale, "acceleration_rms_m_s2": 10 * rms * scale,
            "acceleration_x_peak_m_s2": 40.0 * scale, "acceleration_y_peak_m_s2": 30.0 * scale}


def ball(N_low=None, ratio_at=(), ratio_before=0.25):
    """xP, yP [m], theta [rad], N [N], friction_ratio. The ball's excursion in the window
    is 0.05 at its first sample (a 3-4-5 triangle), its angle largest (pi / 6) there;
    N is smallest in the window (2 N) at the last sample; ``N_low``: (index, value) pairs
    put anywhere in the run; ``ratio_at``: (index, value) pairs of friction_ratio, which is
    ``ratio_before`` at t = 0.4 and largest in the window (0.3) at its first sample."""
    N = window(0.5, [10.0, 9.0, 8.0, 7.0, 6.0, 2.0])
    N[:4] = 5.0
    for i, v in N_low or ():
        N[i] = v
    ratio = window(ratio_before, [0.3, 0.1, 0.1, 0.1, 0.1, 0.2])
    for i, v in ratio_at:
        ratio[i] = v
    return {"xP": window(0.5, [0.03, 0.01, 0.0, 0.0, 0.0, 0.0]),
            "yP": window(0.5, [-0.04, 0.0, 0.0, 0.0, 0.0, 0.01]),
            "theta": window(1.0, [math.pi / 6, 0.1, 0.1, 0.1, 0.1, 0.1]),
            "N": N, "friction_ratio": ratio}


def check(got: dict, want: dict):
    assert sorted(got) == sorted(want)
    for k, v in want.items():
        if v is None or isinstance(v, bool):
            assert got[k] is v, k
        elif isinstance(v, float) and math.isnan(v):
            assert isinstance(got[k], float) and math.isnan(got[k]), k
        else:
            assert type(got[k]) is float, k
            assert got[k] == pytest.approx(v, rel=1e-14, abs=1e-300), k


def test_structure_alone_every_key_on_the_window_edges():
    check(structure_summary(T, structure(), after=0.5), {"from_s": 0.5, "to_s": 1.0, **own()})
    # after = 0 by default: the whole run, where the samples at t = 0.4 dominate
    big = math.hypot(BIG, BIG)
    got = structure_summary(T, structure())
    assert (got["from_s"], got["to_s"]) == (0.0, 1.0)
    assert got["displacement_peak_m"] == pytest.approx(big, rel=1e-14)
    assert got["displacement_x_peak_m"] == got["displacement_y_peak_m"] == BIG


def test_reduction_against_the_bare_structure():
    """Halved displacements (reductions 50 %), accelerations a quarter (75 %), and a bare
    structure that does not move (reductions undefined: nan, not a division by zero)."""
    bare = structure(scale=2.0)
    data = structure(scale=1.0)
    for k in ("axO", "ayO"):
        data[k] = data[k] * np.array([1.0] * 5 + [0.5] * 6)
    want = {"from_s": 0.5, "to_s": 1.0, **own()}
    for k in ("acceleration_peak_m_s2", "acceleration_rms_m_s2", "acceleration_x_peak_m_s2",
              "acceleration_y_peak_m_s2"):
        want[k] *= 0.5
    want.update({f"bare_{k}": v for k, v in own(2.0).items()})
    want.update({"reduction_displacement_peak_percent": 50.0, "reduction_displacement_rms_percent": 50.0,
                 "reduction_acceleration_peak_percent": 75.0, "reduction_acceleration_rms_percent": 75.0})
    check(structure_summary(T, data, bare, after=0.5), want)

    still = {k: window(BIG, [0.0] * 6) for k in ("xO", "yO", "axO", "ayO")}
    want = {"from_s": 0.5, "to_s": 1.0, **own()}
    want.update({f"bare_{k}": 0.0 for k in own()})
    want.update({f"reduction_{q}_percent": math.nan for q in
                 ("displacement_peak", "displacement_rms", "acceleration_peak", "acceleration_rms")})
    check(structure_summary(T, structure(), still, after=0.5), want)


# (name, N changes, friction ratio changes, mu, expected ball keys beyond the common ones);
# before the window N is 5 N and 0.5 N at t = 0.4 (smaller than the window's 2 N, not counted)
BALL_CASES = [
    # N between 0 and 1 N is contact; a ratio equal to mu is still rolling
    ("kept", [(2, 0.5)], [(7, 0.3)], 0.3,
     {"contact": True, "contact_lost_at_s": None, "mu": 0.3, "rolling": True, "slip_at_s": None}),
    # contact lost first where N is exactly 0 (t = 0.3, before the window: validity counts the
    # whole run), again at t = 0.8; slip first at t = 0.2 (before the window), again at 0.9
    ("lost", [(3, 0.0), (8, -1.0)], [(2, 0.31), (9, 0.5)], 0.3,
     {"contact": False, "contact_lost_at_s": 0.3, "mu": 0.3, "rolling": False,
      "slip_at_s": 0.2}),
    # a ratio that is not a number is not rolling: slip at t = 0.1
    ("nan ratio", [], [(1, math.nan)], 0.35,
     {"contact": True, "contact_lost_at_s": None, "mu": 0.35, "rolling": False, "slip_at_s": 0.1}),
    # no mu: no rolling verdict (and a ratio of 0.9 at t = 0.4, before the window, does not
    # count in friction_ratio_max)
    ("no mu", [(10, 0.0)], [], None, {"contact": False, "contact_lost_at_s": 1.0}),
]


@pytest.mark.parametrize("name, N_low, ratio_at, mu, more", BALL_CASES, ids=[c[0] for c in BALL_CASES])
def test_ball_keys_and_validity(name, N_low, ratio_at, mu, more):
    data = {**structure(), **ball(N_low, ratio_at, 0.9 if mu is None else 0.25)}
    want = {"from_s": 0.5, "to_s": 1.0, **own(), "ball_excursion_max_m": 0.05,
            "ball_angle_max_deg": 30.0, "N_min_N": 2.0 if name != "no mu" else 0.0,
            "friction_ratio_max": 0.3 if name != "lost" else 0.5}
    if name == "lost":
        want["N_min_N"] = -1.0
    want.update(more)
    check(structure_summary(T, data, mu=mu, after=0.5), want)


def test_the_window_is_compared_in_double_precision():
    """Times given in single precision: 'after' a round-off above the float32 sample at
    0.5 leaves that sample out (its peak x = -3 with it): the comparison is not rounded
    to the times' precision."""
    t32 = np.asarray(T, dtype=np.float32)
    after = float(t32[5]) + 1e-12
    assert np.float32(after) == t32[5]  # the same in single precision
    s = structure_summary(t32, structure(), after=after)
    assert s["displacement_x_peak_m"] == 1.0
    assert s["from_s"] == after and s["to_s"] == float(t32[-1])
