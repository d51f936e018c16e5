"""Axis labels and legend entries in words with units, from the FMUs' interface declaration
(ballmill/fmi/interface.py): a variable's description, cut to its first clause, then its
name and unit, e.g. "Normal force of the chamber on the ball, N [N]". Shared by the
scenario reports (ballmill/scenario/report.py) and the sweep's plots (ballmill/sweep/plots.py).
"""
from __future__ import annotations

import re
import textwrap

_PAREN = re.compile(r"\s*\([^()]*\)")


def declared(fmu: str | None, name: str):
    """The declared Variable ``name`` of the FMU ``fmu`` (ballmill.fmi.interface), or None
    (a table column, an FMU or a variable not declared there)."""
    from ballmill.fmi.interface import INTERFACES

    iface = INTERFACES.get(fmu) if fmu else None
    return next((v for v in iface.variables if v.name == name), None) if iface else None


def short(description: str) -> str:
    """A description's first clause: parentheses dropped, cut at the first ':' or ';'."""
    text = _PAREN.sub("", description)
    return re.split(r"[:;]", text, maxsplit=1)[0].strip().rstrip(",.")


def unit_text(unit: str | None) -> str | None:
    """A declared unit as printed on a plot: 'N.m' -> 'N m', 'N.s/m' -> 'N s/m'."""
    return unit.replace(".", " ") if unit else None


def label(fmu: str | None, name: str, shown: str | None = None, unit: str | None = None,
          description: str | None = None, width: int | None = None) -> str:
    """"<first clause of the description>, <shown> [<unit>]" for the variable ``name`` of the FMU
    ``fmu`` (``shown``: the name to print, default ``name``); ``unit``/``description`` when the
    caller knows them (else from the declaration). Without a description: "<shown> [unit]".
    ``width``: wrap to lines of at most that many characters."""
    shown = name if shown is None else shown
    var = declared(fmu, name)
    if var is not None:
        description = var.description if description is None else description
        unit = var.unit if unit is None else unit
    u = unit_text(unit)
    text = f"{shown} [{u}]" if u else shown
    if description:
        text = f"{short(description)}, {text}"
    return textwrap.fill(text, width) if width else text
