"""Writes ground_motion.csv: a synthetic earthquake ground acceleration in two
horizontal directions, as an accelerometer would record it (columns time [s],
ax, ay [m/s2], 100 Hz, 40 s). Synthetic and reproducible: run
`python scenarios/data/make_ground_motion.py` to regenerate.

How: the spectral representation method (a sum of cosines with random phases,
fixed seed) of a Kanai-Tajimi ground spectrum with the Clough-Penzien
high-pass (little content below 0.25 Hz), shaped by
a Jennings-type envelope (2 s rise, strong motion to 12 s, exponential
decay), scaled to a peak ground acceleration of 0.5 m/s2 in x and 0.35 m/s2
in y, with a baseline correction so that the ground's velocity and displacement
end at zero. The soil's frequency (2.5 Hz, damping 0.6) puts the record's energy
around 0.5-4 Hz, so a 0.8 Hz structure is shaken near resonance.
"""
import math
from pathlib import Path

import numpy as np

RATE = 100.0  # samples per second
DURATION = 40.0  # s
PGA = (0.5, 0.35)  # m/s2, peak ground acceleration in x and y
SEED = 2026


def kanai_tajimi(f, fg=2.5, zg=0.6, ff=0.25, zf=0.6):
    """One-sided spectral shape (arbitrary scale) at frequency f [Hz]."""
    r = (f / fg) ** 2
    kt = (1 + 4 * zg ** 2 * r) / ((1 - r) ** 2 + 4 * zg ** 2 * r)
    q = (f / ff) ** 2
    cp = q ** 2 / ((1 - q) ** 2 + 4 * zf ** 2 * q)
    return kt * cp


def envelope(t):
    if t < 2.0:
        return (t / 2.0) ** 2
    if t < 12.0:
        return 1.0
    return math.exp(-0.25 * (t - 12.0))


def _integrate(t, a):
    """Cumulative trapezoid integral of a over t, starting at 0."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(t))])


def baseline(t, a, env):
    """Subtract (alpha + beta t / T) env(t) so that the ground's velocity and displacement
    both end at zero (a baseline correction: the record starts and ends at rest)."""
    T = t[-1]
    cols = [env, env * t / T]
    A = np.array([[_integrate(t, c)[-1] for c in cols],
                  [_integrate(t, _integrate(t, c))[-1] for c in cols]])
    b = np.array([_integrate(t, a)[-1], _integrate(t, _integrate(t, a))[-1]])
    alpha, beta = np.linalg.solve(A, b)
    return a - alpha * cols[0] - beta * cols[1]


def record():
    rng = np.random.default_rng(SEED)
    t = np.arange(int(DURATION * RATE) + 1) / RATE
    f = np.linspace(0.05, 20.0, 800)
    df = f[1] - f[0]
    amp = np.sqrt(2 * kanai_tajimi(f) * df)
    env = np.array([envelope(tt) for tt in t])
    out = []
    for pga in PGA:
        ph = rng.uniform(0, 2 * math.pi, f.size)
        a = np.cos(2 * math.pi * np.outer(t, f) + ph) @ amp * env
        a = baseline(t, a, env)
        out.append(a * pga / np.abs(a).max())
    return t, out[0], out[1]


if __name__ == "__main__":
    path = Path(__file__).with_name("ground_motion.csv")
    t, ax, ay = record()
    with open(path, "w") as fh:
        fh.write("time,ax,ay\n")
        for row in zip(t, ax, ay):
            fh.write(f"{row[0]:.2f},{row[1]:.6f},{row[2]:.6f}\n")
    print(f"wrote {path} ({len(t)} rows)")
