"""BallModel.outputs in the compiled kernel (fast.outputs) gives outputs.evaluate's
values bit for bit, with and without the ground material's losses; the fit's
coefficients are plain floats, the same as numpy's product."""
import math

import numpy as np
import pytest

from ballmill.physics import Ball, BallModel, BallState, InputReconstruction, fast
from ballmill.physics import outputs as _out

pytestmark = pytest.mark.skipif(not fast.KERNEL_AVAILABLE, reason="compiled kernel unavailable")

BALLS = [Ball(), Ball(rolling_resistance=1e-3), Ball(drag=0.5), Ball(rolling_resistance=2e-3, drag=0.2),
         Ball(r=0.01, R=0.2, m=0.3, mu=0.1)]


def _bits(a, b):
    return all((x == y and math.copysign(1, x) == math.copysign(1, y)) or (x != x and y != y)
               for x, y in zip(a, b))


@pytest.mark.parametrize("ball", BALLS, ids=range(len(BALLS)))
def test_outputs_bit_identical(ball):
    rng = np.random.default_rng(7)
    model = BallModel(ball)
    for i in range(3000):
        n = rng.standard_normal(3)
        n /= np.linalg.norm(n)
        if i % 3 == 0:
            n[2] = -abs(n[2])
        w = rng.standard_normal(3) * rng.choice([0.0, 1.0, 30.0, 300.0])
        st = BallState(0.0, np.concatenate([n, w]))
        ax, ay, xO, yO = (rng.standard_normal(4) * rng.choice([1.0, 50.0])).tolist()
        got = model.outputs(st, ax, ay, xO, yO)
        ref = _out.evaluate(ball, tuple(n.tolist()), tuple(w.tolist()), ax, ay, xO, yO)
        assert type(got) is type(ref)
        assert _bits(got, ref), (i, got, ref)
        assert type(got.contact) is bool and type(got.rolling) is bool
        assert got.contact == ref.contact and got.rolling == ref.rolling


def test_outputs_python_kernel_and_paper_fall_back():
    st = BallModel(Ball()).initial(0.05, 0.02, (1.0, -2.0, 0.5))
    ref = BallModel(Ball(), kernel="python").outputs(st, 1.0, 2.0, 0.3, 0.1)
    assert tuple(BallModel(Ball()).outputs(st, 1.0, 2.0, 0.3, 0.1)) == tuple(ref)
    paper = BallModel(Ball(), formulation="paper")
    sp = paper.initial(0.05, 0.02, (1.0, -2.0, 0.5))
    assert fast.outputs(paper, sp, 1.0, 2.0, 0.3, 0.1) is None
    assert paper.outputs(sp, 1.0, 2.0, 0.3, 0.1).N > 0


def test_fit_coefficients_are_the_correctly_rounded_inverse_times_the_samples():
    rng = np.random.default_rng(3)
    for mode in ("derivatives", "positions"):
        r = InputReconstruction(mode)
        for k in range(9):
            t = 0.04 * k + (rng.uniform(-1e-3, 1e-3) if k % 4 == 3 else 0.0)
            r.push(t, *rng.standard_normal(6).tolist())
            r.prepare()
            assert all(type(v) is float for v in r._cx + r._cy)
            s = r.nodes()
            tk, hs = s[-1][0], r._hs
            x_ref, y_ref = s[-1][1], s[-1][2]
            rows, bx, by = [], [], []
            for (t_, x, y, vx, vy, ax, ay) in s:
                tau = (t_ - tk) / hs
                rows.append((0, tau)); bx.append(x - x_ref); by.append(y - y_ref)
                if mode == "derivatives":
                    rows.append((1, tau)); bx.append(vx * hs); by.append(vy * hs)
                    rows.append((2, tau)); bx.append(ax * hs * hs); by.append(ay * hs * hs)
            inv = InputReconstruction._inverse(tuple(rows))
            # left-to-right dot products (what the native FMU's C does), positions relative
            # to the newest node's
            cx = [sum_lr(row, bx) for row in inv]
            cy = [sum_lr(row, by) for row in inv]
            cx[0] += x_ref
            cy[0] += y_ref
            assert r._cx == tuple(cx) and r._cy == tuple(cy)
            # the inverse: M inv = I to round-off, and each entry the float nearest the exact value
            M = np.array([[math.perm(j, der) * round(tau, 12) ** (j - der) if j >= der else 0.0
                           for j in range(len(rows))] for der, tau in rows])
            np.testing.assert_allclose(M @ np.array(inv), np.eye(len(rows)), atol=1e-9)
            assert np.max(np.abs(np.array(inv) - np.linalg.inv(M))) <= 1e-9 * np.max(np.abs(inv))


def sum_lr(row, b):
    acc = row[0] * b[0]
    for x, y in zip(row[1:], b[1:]):
        acc += x * y
    return acc
