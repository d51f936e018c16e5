"""Parameter validation: every impossible value raises ParameterError naming it."""
import math
import re

import pytest

from ballmill.physics import Ball, BallModel, CrankStartup, ParameterError, steel_ball_mass


def test_paper_defaults():
    b = Ball()
    assert (b.r, b.R, b.g) == (0.025, 0.25, 9.81)
    # docs/design.md section 1: steel, 7800 kg/m^3 -> m = 0.5105 kg
    assert b.m == pytest.approx(7800 * 4 / 3 * math.pi * 0.025**3, rel=1e-15)
    assert b.m == pytest.approx(0.5105, abs=5e-5)
    assert steel_ball_mass(0.025) == b.m
    assert b.d == pytest.approx(0.225, rel=1e-15)
    assert b.lam == pytest.approx(0.025 / 0.225, rel=1e-15)
    assert b.I == pytest.approx(0.4 * b.m * 0.025**2, rel=1e-15)
    # k = m r / (I + m r^2), written out from its definition
    assert b.k == pytest.approx(b.m * b.r / (b.I + b.m * b.r**2), rel=1e-14)


def test_ball_larger_than_chamber():
    with pytest.raises(ParameterError) as exc:
        Ball(r=0.3, R=0.25)
    msg = str(exc.value)
    assert "R must be larger than r" in msg
    assert "0.3" in msg and "0.25" in msg


def test_equal_radii_rejected():
    with pytest.raises(ParameterError, match="R must be larger than r"):
        Ball(r=0.25, R=0.25)


BAD_VALUES = [0.0, -1.0, math.nan, math.inf, -math.inf]


@pytest.mark.parametrize("name", ["m", "r", "R", "g", "mu"])
@pytest.mark.parametrize("value", BAD_VALUES, ids=["zero", "negative", "nan", "inf", "-inf"])
def test_non_positive_or_non_finite_rejected(name, value):
    with pytest.raises(ParameterError) as exc:
        Ball(**{name: value})
    msg = str(exc.value)
    # the message names the parameter as "<name> = <value>" (a bare "r" would be
    # found in any English sentence, so insist on the assignment form)
    assert re.search(rf"(^|[^A-Za-z_]){re.escape(name)} = ", msg), msg
    assert msg.startswith(f"{name} must be"), msg


def test_non_number_rejected():
    with pytest.raises(ParameterError, match="m must be a number"):
        Ball(m="heavy")


def test_parameter_error_is_a_value_error():
    assert issubclass(ParameterError, ValueError)


def test_valid_other_ball_accepted():
    b = Ball(r=0.01, R=0.1, m=0.1, g=1.62, mu=0.5)
    assert b.d == pytest.approx(0.09)
    assert b.with_(m=0.2).m == 0.2
    with pytest.raises(ParameterError, match="m must be positive"):
        b.with_(m=-0.2)


@pytest.mark.parametrize("formulation", ["vector", "paper"])
def test_initial_position_out_of_reach(formulation):
    model = BallModel(Ball(), formulation)
    with pytest.raises(ParameterError) as exc:
        model.initial(xC0=0.3)  # the centre lives on a sphere of radius 0.225 m
    msg = str(exc.value)
    assert "xC0" in msg and "0.3" in msg and "0.225" in msg
    with pytest.raises(ParameterError, match="xC0"):
        model.initial(xC0=0.2, yC0=0.2)  # each within reach, together not (0.283 m)
    # the boundary of the reachable disc itself is accepted by the vector formulation
    if formulation == "vector":
        model.initial(xC0=0.225)


@pytest.mark.parametrize("name", ["xC0", "yC0", "wx0", "wy0", "wz0"])
def test_initial_values_must_be_finite(name):
    model = BallModel(Ball())
    kwargs = {"xC0": 0.0, "yC0": 0.0, "w0": [0.0, 0.0, 0.0]}
    if name.startswith("w"):
        kwargs["w0"]["xyz".index(name[1])] = math.nan
    else:
        kwargs[name] = math.nan
    with pytest.raises(ParameterError, match=name):
        model.initial(**kwargs)


@pytest.mark.parametrize("name,value", [("l", 0.0), ("l", math.nan), ("t0", -1.0), ("n0", -5.0),
                                        ("n0", math.inf)])
def test_crank_parameters(name, value):
    with pytest.raises(ParameterError, match=rf"^{name} must be"):
        CrankStartup(**{name: value})
    CrankStartup(n0=0.0)  # a crank at rest is allowed
