"""Platform motions to feed BallInShell, computed here (no ballmill import needed):
the paper's crank start-up law x1O..ay1O (l = 0.5 m, n0 = 60 1/min, start-up time t0)."""
from __future__ import annotations

import math

INPUTS = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")


def crank(t, t0=2.5, l=0.5, n0=60.0):
    """(x, y, vx, vy, ax, ay) of the platform point at time t."""
    w0 = 2.0 * math.pi * n0 / 60.0
    if t <= t0:
        u = 1.0 - t / t0
        p = -w0 * (t - t0) ** 3 / (3.0 * t0 * t0) + w0 * t - w0 * t0 / 3.0
        pd, pdd = w0 * (1.0 - u * u), 2.0 * w0 * u / t0
    else:
        p, pd, pdd = 2.0 / 3.0 * w0 * t0 + w0 * (t - t0), w0, 0.0
    c, s = math.cos(p), math.sin(p)
    return (l * c, l * s, -l * pd * s, l * pd * c, l * (-pdd * s - pd * pd * c), l * (pdd * c - pd * pd * s))


def feed(fmu, t, offset=0.0, t0=2.5, noise=None):
    values = dict(zip(INPUTS, crank(t, t0)))
    values["x1O"] += offset
    if noise:
        for k, v in noise(t).items():
            values[k] += v
    assert fmu.set(**values) == 0


def run_ball(open_fmu, steps, t_start=0.0, offset=0.0, t0=2.5, **parameters):
    """BallInShell driven by the crank law over the given communication steps; returns the
    instance and the status of the first step that was not fmi2OK (0 if none)."""
    fmu = open_fmu("BallInShell", **parameters)
    feed(fmu, t_start, offset, t0)
    assert fmu.init(t_start) == 0, fmu.messages()
    t = t_start
    for h in steps:
        st = fmu.step(h, t)
        if st:
            return fmu, st
        t = t + h
        feed(fmu, t, offset, t0)
    return fmu, 0
