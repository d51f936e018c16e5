"""ballmill.physics.turning: the ball in a chamber that moves in 3-D and turns (docs/design.md section 10).

``motions`` holds the chamber's prescribed rigid motions (`ChamberState`,
`Translation` of a platform motion, `Spin`, `Fig1Machine` with the `ConstantSpeed`
or crank start-up angle laws); ``model`` the general model's equations, outputs
(with the drives' reaction moments), energy and first integrals, `ChamberModel`
and the drivers `simulate_general` and `simulate_chamber`; ``kernel`` the same
model's compiled bmg_* functions of ``../_kernel.c`` (ctypes), which give the
Python path's trajectory bit for bit; ``reconstruction`` the chamber's motion between
communication points as the BallInShell FMU (motion = 2) sees it (`ChamberReconstruction`).
The translation-only ball model it falls back to for a `Translation` is
``ballmill.physics.model``.
"""
from .motions import (ARRANGEMENTS, SHAFTS, ChamberMotion, ChamberState, ConstantSpeed, Fig1Machine, SpeedRise,
                      Spin, Translation)
from .model import ChamberModel, ChamberOutputs, simulate_chamber, simulate_general

__all__ = [
    "ARRANGEMENTS", "SHAFTS", "ChamberMotion", "ChamberState", "ConstantSpeed", "Fig1Machine", "SpeedRise", "Spin",
    "Translation",
    "ChamberModel", "ChamberOutputs", "simulate_chamber", "simulate_general",
]
