"""The physics' refusals, word for word: the bad value, its name, its unit and what was
expected (the project's standard for errors), and the paper formulation's limits exactly at
their edges. Written for mutants of the messages and boundaries that the rest of the
suite let through (docs/mutation.md)."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, CrankStartup, FormulationLimitError, ParameterError
from ballmill.physics.equations import PaperFormulation

BALL = Ball()


@pytest.mark.parametrize("kwargs, message", [
    ({"l": -0.5}, "l must be positive and finite, got l = -0.5 m"),
    ({"l": 0.0}, "l must be positive and finite, got l = 0.0 m"),
    ({"n0": -60.0}, "n0 must be non-negative and finite, got n0 = -60.0 1/min"),
    ({"n0": math.inf}, "n0 must be non-negative and finite, got n0 = inf 1/min"),
    ({"t0": 0.0}, "t0 must be positive and finite, got t0 = 0.0 s"),
    ({"t0": math.nan}, "t0 must be positive and finite, got t0 = nan s"),
])
def test_crank_law_refusals(kwargs, message):
    with pytest.raises(ParameterError) as e:
        CrankStartup(**kwargs)
    assert str(e.value) == message


def test_crank_law_accepts_its_edges():
    assert CrankStartup(n0=0.0).w0 == 0.0  # standing still is allowed
    assert CrankStartup(l=1e-9, t0=1e-9).angle(1.0)[1] == pytest.approx(2 * math.pi)


@pytest.mark.parametrize("kwargs, message", [
    ({"r": 0.0}, "r must be positive and finite, got r = 0.0 m"),
    ({"R": -1.0}, "R must be positive and finite, got R = -1.0 m"),
    ({"m": math.inf}, "m must be positive and finite, got m = inf kg"),
    ({"g": 0.0}, "g must be positive and finite, got g = 0.0 m/s2"),
    ({"mu": 0.0}, "mu must be positive and finite, got mu = 0.0 1"),
    ({"inertia_factor": -0.4}, "inertia_factor must be positive and finite, got inertia_factor = -0.4 1"),
    ({"rolling_resistance": -1e-4},
     "rolling_resistance must be non-negative and finite, got rolling_resistance = -0.0001 m"),
    ({"drag": math.nan}, "drag must be non-negative and finite, got drag = nan N s/m"),
    ({"r": "big"}, "r must be a number in m, got 'big'"),
    ({"drag": None}, "drag must be a number in N s/m, got None"),
    ({"r": 0.3, "R": 0.25}, "R must be larger than r (the ball must fit in the chamber), got r = 0.3 m, "
                            "R = 0.25 m"),
])
def test_ball_refusals(kwargs, message):
    with pytest.raises(ParameterError) as e:
        Ball(**kwargs)
    assert str(e.value) == message


def test_ball_with_keeps_every_other_value():
    b = Ball(r=0.02, R=0.2, m=0.3, g=9.7, mu=0.25, inertia_factor=0.5, rolling_resistance=1e-4, drag=0.1)
    for change in ({"mu": 0.4}, {"r": 0.03}, {"R": 0.3}, {"drag": 0.0}):
        c = b.with_(**change)
        for name in ("r", "R", "m", "g", "mu", "inertia_factor", "rolling_resistance", "drag"):
            assert getattr(c, name) == change.get(name, getattr(b, name)), (change, name)
    with pytest.raises(ParameterError, match="R must be larger than r"):
        b.with_(r=0.2)


def test_cramer_refuses_losses():
    with pytest.raises(ValueError) as e:
        PaperFormulation(Ball(drag=0.1), cramer=True)
    assert str(e.value) == ("cramer=True solves the paper's lossless 3x3 system only; with "
                            "rolling_resistance or drag use cramer=False (closed form)")
    assert PaperFormulation(BALL, cramer=True).cramer is True
    assert PaperFormulation(BALL).cramer is False


def test_paper_formulation_start_margin_edges():
    form = PaperFormulation(BALL, equator_margin=0.25)
    d = BALL.d
    y = form.from_nw((0.0, 0.0, -0.25 - 1e-12), (1.0, 2.0, 3.0))  # just inside the allowed region
    assert y.dtype == np.float64 and y.tolist() == [0.0, 0.0, 1.0, 2.0, 3.0]
    # exactly on the margin: accepted, as `check` accepts R - zC = margin (R - r) during a run
    form.from_nw((math.sqrt(1 - 0.25 ** 2), 0.0, -0.25), (0.0, 0.0, 0.0))
    for nz in (-0.25 + 1e-12, -0.1):
        with pytest.raises(FormulationLimitError) as e:
            form.from_nw((math.sqrt(1 - nz * nz), 0.0, nz), (0.0, 0.0, 0.0))
        assert str(e.value) == (f"paper formulation: the ball starts at n_z = {nz:.6g}, within the margin "
                                f"0.25 of the chamber's equator (its coordinates need n_z < -0.25); "
                                f"use formulation 'vector'")
    assert d > 0


def test_paper_formulation_stops_below_the_equator_with_the_angle():
    form = PaperFormulation(BALL, equator_margin=0.1)
    d = BALL.d
    s = 0.05 * d  # R - zC: 0.05 (R - r), inside the margin 0.1
    xC = math.sqrt(d * d - s * s)
    with pytest.raises(FormulationLimitError) as e:
        form.check(np.array([xC, 0.0, 0.0, 0.0, 0.0]))
    angle = math.degrees(math.asin(0.05))
    msg = str(e.value)
    assert msg.startswith(f"paper formulation stopped: the ball centre is {angle:.2f} deg below the "
                          f"chamber's equator (R - zC = {s:.4g} m < 0.1 (R - r))"), msg
    assert re.search(r"2\.87 deg", msg)
    form.check(np.array([math.sqrt(d * d - (0.1 * d) ** 2) * (1 - 1e-9), 0.0, 0.0, 0.0, 0.0]))  # at the edge: on


def test_paper_coordinates_end_at_the_equator():
    form = PaperFormulation(BALL)
    d = BALL.d
    for xC in (d, d * (1 + 1e-9)):
        with pytest.raises(FormulationLimitError) as e:
            form.to_nw(np.array([xC, 0.0, 0.0, 0.0, 0.0]))
        assert f"(xC, yC) = ({xC:.6g}, 0) m lies at or beyond the chamber's equator" in str(e.value)
        with pytest.raises(FormulationLimitError):
            form.derivative([xC, 0.0, 0.0, 0.0, 0.0], 0.0, 0.0)
    # just inside, the depth is the square root, not the error
    n, _ = form.to_nw(np.array([d * (1 - 1e-6), 0.0, 0.0, 0.0, 0.0]))
    assert n[2] == pytest.approx(-math.sqrt(1 - (1 - 1e-6) ** 2), rel=1e-9)
    f = form.derivative([d * 0.6, 0.0, 0.0, 1.0, 0.0], 0.0, 0.0)
    assert f[0] == pytest.approx(BALL.lam * 1.0 * 0.8 * d, rel=1e-12)  # xC' = lam wy s, s = 0.8 d


def test_initial_state_refusals():
    m = BallModel(BALL)
    with pytest.raises(ParameterError) as e:
        m.initial(xC0=math.nan)
    assert str(e.value) == "xC0 must be finite, got xC0 = nan"
    with pytest.raises(ParameterError) as e:
        m.initial(w0=(0.0, math.inf, 0.0))
    assert str(e.value) == "wy0 must be finite, got wy0 = inf"
    with pytest.raises(ParameterError, match=r"initial position out of reach: .* R - r = 0\.225 m"):
        m.initial(xC0=0.2, yC0=0.2)
    assert m.initial(xC0=BALL.d).y[2] == pytest.approx(0.0, abs=1e-12)  # on the equator: reachable


def test_paper_formulation_check_accepts_exactly_the_margin():
    """R - zC == margin (R - r) exactly is still allowed (the refusal is strictly below)."""
    d = BALL.d
    for xC in np.linspace(0.97 * d, 0.99 * d, 200):  # a depth whose margin * d is exact
        depth = math.sqrt(d * d - xC * xC)
        margin = depth / d
        if margin * d == depth:
            break
    assert margin * d == depth
    form = PaperFormulation(BALL, equator_margin=margin)
    form.check(np.array([xC, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(FormulationLimitError):
        form.check(np.array([xC * (1 + 1e-12), 0.0, 0.0, 0.0, 0.0]))


def test_ball_refuses_a_chamber_that_it_all_but_fills():
    with pytest.raises(ParameterError) as e:
        Ball(r=2.0 - 1e-9, R=2.0)  # (R - r) / R = 5e-10 < 1e-9
    assert str(e.value) == f"R - r must be at least 1e-9 R, got r = {2.0 - 1e-9!r} m, R = 2.0 m"
    assert Ball(r=2.0 - 4e-9, R=2.0).d > 0.0  # 2e-9 of R: allowed


@pytest.mark.parametrize("name", ["xC0", "yC0", "wx0", "wy0", "wz0"])
def test_each_initial_value_is_named(name):
    values = dict(xC0=0.01, yC0=0.02, w0=[1.0, 2.0, 3.0])
    if name.startswith("w"):
        values["w0"][{"wx0": 0, "wy0": 1, "wz0": 2}[name]] = math.nan
    else:
        values[name] = math.nan
    with pytest.raises(ParameterError) as e:
        BallModel(BALL).initial(**values)
    assert str(e.value) == f"{name} must be finite, got {name} = nan"
