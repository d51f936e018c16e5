"""The Structure FMU's generated rows of the one declaration (ballmill.fmi.interface:
`_mode_parameters`, `_structure_outputs`) against the specification written out here row by
row: names in value-reference order, causality, start value and its FMI type, the description
word for word (it is the model description's text a user reads), unit, bounds, the initial
dependencies and the direct feedthrough; and the declaration's refusal of a feedthrough that is
not among an output's dependencies.

These functions run when ballmill.fmi.interface is imported, before mutmut's workers fork, so
the tests call them again inside the test functions (docs/mutation.md)."""
from __future__ import annotations

import pytest

from ballmill.fmi.interface import STRUCTURE, STRUCTURE_MODES, Interface, Variable, _mode_parameters, \
    _structure_outputs


def _norm(row):
    """A row with the types of its numbers made visible (1 and 1.0 are different FMI types)."""
    name, causality, start, description = row[:4]
    extra = row[4] if len(row) > 4 else {}
    return (name, causality, type(start).__name__, start, description,
            tuple(sorted((k, type(v).__name__, v) for k, v in extra.items())))


def _expected_mode_parameters(a):
    n_text = " (at least 1)" if a == "x" else " (0: the cavity follows the ground in y)"
    rows = [(f"n_{a}", "parameter", 1, f"Number of modes of axis {a}{n_text}", dict(min=1 if a == "x" else 0, max=3))]
    for j, f in ((1, 0.8), (2, 2.5), (3, 4.5)):
        m = f"mode {j} of axis {a}"
        rows += [
            (f"M_{a}{j}", "parameter", 100.0, f"Modal mass M of {m}", dict(unit="kg", min=1e-12, max=1e15)),
            (f"f_{a}{j}", "parameter", f, f"Undamped natural frequency of {m}", dict(unit="Hz", min=1e-9, max=1e6)),
            (f"zeta_{a}{j}", "parameter", 0.01, f"Damping ratio of {m}", dict(unit="1", min=0.0, max=100.0)),
            (f"phi_{a}{j}", "parameter", 1.0, f"Shape of {m} at the absorber (the cavity moves by phi q)",
             dict(unit="1", min=-1e6, max=1e6)),
            (f"psi_{a}{j}", "parameter", 1.0, f"Shape of {m} where the external force acts (the load point: "
             f"x_load = sum psi q)", dict(unit="1", min=-1e6, max=1e6)),
            (f"L_{a}{j}", "parameter", 100.0, f"Participation L of {m} in a ground acceleration (M phi for a "
             f"single mass; set it with M)", dict(unit="kg", min=-1e15, max=1e15)),
        ]
    return rows


def _expected_structure_outputs():
    rows = []
    for a in ("x", "y"):
        rows += [
            (f"{a}1O", "output", 0.0, f"Cavity (absorber point) absolute position {a}: ground + sum phi q",
             dict(unit="m")),
            (f"v{a}1O", "output", 0.0, f"Cavity absolute velocity {a}", dict(unit="m/s")),
            (f"a{a}1O", "output", 0.0, f"Cavity absolute acceleration {a} (depends directly on F{a}_ball and "
             f"ag_{a})", dict(unit="m/s2", depends=(f"F{a}_ball", f"ag_{a}"), feedthrough=(f"F{a}_ball", f"ag_{a}"))),
        ]
    for a in ("x", "y"):
        rows += [(f"q_{a}{j}", "output", 0.0, f"Modal coordinate of mode {j} of axis {a} (relative to the ground)",
                  dict(unit="m")) for j in (1, 2, 3)]
        rows += [
            (f"{a}_rel", "output", 0.0, f"Cavity displacement {a} relative to the ground, sum phi q", dict(unit="m")),
            (f"{a}_load", "output", 0.0, f"Structure displacement {a} at the load point relative to the ground, "
             f"sum psi q", dict(unit="m")),
            (f"a{a}_load", "output", 0.0, f"Absolute acceleration {a} at the load point",
             dict(unit="m/s2", depends=(f"F{a}_ball", f"ag_{a}"), feedthrough=(f"F{a}_ball", f"ag_{a}"))),
            (f"{a}g", "output", 0.0, f"Ground displacement {a} (integrated from the ground acceleration from "
             f"rest at the start)", dict(unit="m")),
            (f"v{a}g", "output", 0.0, f"Ground velocity {a}", dict(unit="m/s")),
            (f"ag{a}_total", "output", 0.0, f"Ground acceleration {a}: harmonic part + input ag_{a}",
             dict(unit="m/s2", depends=(f"ag_{a}",), feedthrough=(f"ag_{a}",))),
            (f"F{a}_exc", "output", 0.0, f"External (harmonic) force on the structure, {a}", dict(unit="N")),
        ]
    return rows


@pytest.mark.parametrize("axis", ["x", "y"])
def test_mode_parameters_of_each_axis_as_specified(axis):
    rows = _mode_parameters(axis)
    assert STRUCTURE_MODES == 3 and len(rows) == 1 + 6 * 3
    assert [_norm(r) for r in rows] == [_norm(r) for r in _expected_mode_parameters(axis)]
    for row in rows:  # each a valid Variable (a known unit, a description)
        Variable(*row[:4], **row[4])


def test_structure_outputs_as_specified():
    rows = _structure_outputs()
    assert len(rows) == 2 * 3 + 2 * (3 + 7)
    assert [_norm(r) for r in rows] == [_norm(r) for r in _expected_structure_outputs()]
    variables = [Variable(*row[:4], **row[4]) for row in rows]
    assert [v.name for v in variables] == [v.name for v in STRUCTURE.of("output")][:len(variables)]


def test_a_feedthrough_outside_the_dependencies_is_refused():
    u = Variable("u", "input", 0.0, "u", unit="m")
    w = Variable("w", "input", 0.0, "w", unit="m")
    y = Variable("y", "output", 0.0, "y", unit="m", depends=("u",), feedthrough=("w", "u"))
    with pytest.raises(ValueError) as info:
        Interface("M", "d", (u, w, y))
    assert str(info.value) == "M.y: feedthrough ['u', 'w'] must be among its depends ['u']"
    ok = Interface("M", "d", (u, w, Variable("y", "output", 0.0, "y", unit="m", depends=("u", "w"),
                                             feedthrough=("w",))))
    assert ok["y"].feedthrough == ("w",)
