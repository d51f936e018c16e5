"""What a structural engineer reads off an absorber run: one flat summary.

This module owns the summary of a time history of structure + ball against
the bare structure under the same excitation: peak and RMS displacement and
acceleration of the structure at the absorber (per axis and of the horizontal
magnitude), their reduction against the bare structure, the ball's largest
excursion, and its validity (contact, rolling with the friction coefficient
mu, when each first failed). Plain arrays in, a dict of plain numbers out, so
that a study, a scenario runner or a Structure FMU's results can all use it.
"""
from __future__ import annotations

import math

import numpy as np


def _stats(prefix, unit, x, y):
    mag = np.hypot(x, y)
    return {f"{prefix}_peak_{unit}": float(mag.max()),
            f"{prefix}_rms_{unit}": float(math.sqrt(np.mean(mag * mag))),
            f"{prefix}_x_peak_{unit}": float(np.abs(x).max()),
            f"{prefix}_y_peak_{unit}": float(np.abs(y).max())}


def structure_summary(t, data: dict, bare: dict | None = None, mu: float | None = None,
                      after: float = 0.0) -> dict:
    """Summary over t >= after.

    data: arrays xO, yO (displacement relative to the ground) [m], axO, ayO
    (absolute acceleration) [m/s2] and, with a ball, xP, yP, theta [rad], N [N],
    friction_ratio; bare: the same structure without the ball (xO, yO, axO, ayO)
    on the same time grid.
    """
    t = np.asarray(t, dtype=float)
    sel = t >= after
    if not sel.any():  # a run that stopped before the window: no statistics, and a reason
        end = f"the results end at t = {float(t[-1])!r} s" if t.size else "there are no results"
        raise ValueError(f"no sample at or after t = {float(after)!r} s: {end}")
    s = {"from_s": float(after), "to_s": float(t[-1])}
    s.update(_stats("displacement", "m", data["xO"][sel], data["yO"][sel]))
    s.update(_stats("acceleration", "m_s2", data["axO"][sel], data["ayO"][sel]))
    if bare is not None:
        b = {}
        b.update(_stats("displacement", "m", bare["xO"][sel], bare["yO"][sel]))
        b.update(_stats("acceleration", "m_s2", bare["axO"][sel], bare["ayO"][sel]))
        for k, v in b.items():
            s[f"bare_{k}"] = v
        for name, k in (("displacement_peak", "displacement_peak_m"),
                        ("displacement_rms", "displacement_rms_m"),
                        ("acceleration_peak", "acceleration_peak_m_s2"),
                        ("acceleration_rms", "acceleration_rms_m_s2")):
            s[f"reduction_{name}_percent"] = 100.0 * (1.0 - s[k] / b[k]) if b[k] > 0 else math.nan
    if "theta" in data:
        th = data["theta"][sel]
        s["ball_excursion_max_m"] = float(np.hypot(data["xP"][sel], data["yP"][sel]).max())
        s["ball_angle_max_deg"] = float(np.degrees(th.max()))
        N = data["N"]
        ratio = data["friction_ratio"]
        s["N_min_N"] = float(N[sel].min())
        s["friction_ratio_max"] = float(ratio[sel].max())
        lost = np.nonzero(N <= 0.0)[0]
        s["contact"] = bool(lost.size == 0)
        s["contact_lost_at_s"] = float(t[lost[0]]) if lost.size else None
        if mu is not None:
            slip = np.nonzero(~(ratio <= mu))[0]
            s["mu"] = float(mu)
            s["rolling"] = bool(slip.size == 0)
            s["slip_at_s"] = float(t[slip[0]]) if slip.size else None
    return s
