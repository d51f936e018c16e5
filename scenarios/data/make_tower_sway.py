"""Writes tower_sway.csv: a tower top swaying in two directions, as a data logger
would record it (positions only, 200 Hz). Synthetic and noise-free, so that the
example is reproducible; run `python scenarios/data/make_tower_sway.py` to regenerate."""
import math
from pathlib import Path

RATE = 200.0  # samples per second
DURATION = 30.0  # s


def sway(t):
    # first bending mode at 0.45 Hz, growing in over ~5 s (a gust), plus a weaker cross-wind mode
    env = 1.0 - math.exp(-t / 5.0)
    x = 0.01 * env * math.sin(2 * math.pi * 0.45 * t)
    y = 0.004 * env * math.sin(2 * math.pi * 0.40 * t + 0.7)
    return x, y


if __name__ == "__main__":
    path = Path(__file__).with_name("tower_sway.csv")
    n = int(DURATION * RATE)
    with open(path, "w") as fh:
        fh.write("time,x1O,y1O\n")
        for i in range(n + 1):
            t = i / RATE
            x, y = sway(t)
            fh.write(f"{t:.3f},{x:.9f},{y:.9f}\n")
    print(f"wrote {path} ({n + 1} rows)")
