"""The general model's compiled functions (bmg_* in _kernel.c, via
ballmill.physics.turning.kernel) against the Python path (turning.py, chamber.py):
same trajectories, outputs and work, bit for bit; and the cases that stay in Python."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ballmill.physics import KERNEL_AVAILABLE, KERNEL_REASON, Ball, CrankStartup, Harmonic
from ballmill.physics.turning import kernel as fast_turning, model as turning
from ballmill.physics.turning.motions import ConstantSpeed, Fig1Machine, Spin, Translation

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason=f"compiled kernel unavailable: {KERNEL_REASON}")

BALL = Ball()
MOTIONS = {
    "bowl": Spin((0.0, 0.0, 3.0), (0.0, 0.0, 0.25)),
    "drum": Spin((0.8, 0.0, 0.0), (0.0, 0.0, 0.25)),
    "tilted": Spin((0.3, -1.1, 2.0), (0.2, -0.1, 0.4)),
    "fig1": Fig1Machine(),
    "fig1-parallel": Fig1Machine(arrangement="parallel", centre=(0.1, 0.0, 0.6)),
    "fig1-startup-frame": Fig1Machine(frame=CrankStartup(l=1.0, n0=12.0, t0=1.5),
                                      crank=CrankStartup(l=0.3, n0=80.0, t0=1.0), centre=(0.0, 0.2, -0.1)),
    "fig1-const-crank": Fig1Machine(frame=ConstantSpeed(-0.4, 0.2), crank=ConstantSpeed(5.0, 1.0), l=0.4),
}
SETTINGS = [("DOP853", {"tol": 1e-9}), ("RK45", {"tol": 1e-8}), ("RK4", {"h_fixed": 0.004})]


def run_both(motion, method, opts, t_end=4.0, dt=0.01, x=(0.04, -0.03), outputs=True):
    out = []
    for kernel in ("python", "c"):
        m = turning.ChamberModel(BALL, method=method, **opts)
        st = m.initial(motion, *x, w_rel=(0.5, -1.0, 2.0))
        out.append(turning.simulate_general(m, motion, t_end, dt, st, outputs=outputs, kernel=kernel))
    return out


def assert_identical(a, b):
    assert a.success == b.success and a.message == b.message
    assert a.info == b.info
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.y, b.y), f"max |dy| = {np.max(np.abs(a.y - b.y)):.3g}"
    assert list(a.out) == list(b.out)
    for name in a.out:
        assert np.array_equal(a.out[name], b.out[name], equal_nan=True), name


@needs_kernel
@pytest.mark.parametrize("method,opts", SETTINGS, ids=[s[0] for s in SETTINGS])
@pytest.mark.parametrize("name", list(MOTIONS))
def test_general_runs_identical(name, method, opts):
    a, b = run_both(MOTIONS[name], method, opts)
    assert a.success
    assert_identical(a, b)


@needs_kernel
def test_no_outputs_and_h_max():
    for kernel_runs in (run_both(MOTIONS["fig1"], "DOP853", {"tol": 1e-10, "h_max": 0.003}, outputs=False),):
        a, b = kernel_runs
        assert not a.out and not b.out
        assert_identical(a, b)


@needs_kernel
@pytest.mark.parametrize("name", list(MOTIONS))
def test_single_evaluations_identical(name):
    """Motion state, right-hand side and outputs at random states: the same floats (before
    t = 0 too, where the start-up laws hold everything at rest)."""
    mo = MOTIONS[name]
    m = turning.ChamberModel(BALL)
    G = fast_turning.problem(m, mo)
    rng = np.random.default_rng(7)
    for t in (-0.5, 0.0, 0.8, 2.5, 3.7, 11.0):
        cs = mo.state(t)
        assert fast_turning.eval_state(G, t) == tuple(float(v) for v in cs)
        n = rng.normal(size=3)
        y = [*(n / np.linalg.norm(n)), *rng.normal(scale=20.0, size=3)]
        assert fast_turning.eval_rhs(G, t, y) == turning.derivative(m._c, y, mo.accel(t))
        py = tuple(float(v) for v in turning.evaluate(BALL, y, cs))
        assert fast_turning.eval_outputs(G, y, cs) == py


@needs_kernel
def test_a_contact_loss_does_not_stop_the_math():
    """The Fig. 1 machine loses contact (N < 0; reported, not an integration failure):
    friction_ratio is inf there in both paths."""
    a, b = run_both(MOTIONS["fig1"], "DOP853", {"tol": 1e-9}, t_end=10.0, x=(0.0, 0.0))
    assert_identical(a, b)
    assert (a["N"] <= 0).any() and np.isinf(a["friction_ratio"]).any()


def test_what_stays_in_python():
    m = turning.ChamberModel(BALL)
    assert "Translation" in fast_turning.applicable(m, Translation(Harmonic(0.1, 1.0)))
    assert "angle law" in fast_turning.applicable(m, Fig1Machine(frame=_Law()))
    with pytest.raises(fast_turning.KernelUnavailable):
        turning.simulate_general(m, Translation(Harmonic(0.1, 1.0)), 1.0, 0.1, kernel="c")
    # kernel="auto" falls back to Python for such a motion, with the same physics
    tr = turning.simulate_general(m, Fig1Machine(frame=_Law()), 1.0, 0.1)
    ref = turning.simulate_general(turning.ChamberModel(BALL), Fig1Machine(), 1.0, 0.1, kernel="python")
    assert np.array_equal(tr.y, ref.y)


class _Law:
    """ConstantSpeed(0.5) by another name: a law the kernel does not know."""

    def angle(self, t):
        return 0.0 + 0.5 * t, 0.5, 0.0

    def __repr__(self):
        return "_Law()"


@needs_kernel
def test_failure_is_handed_to_python():
    """A step that fails in C is redone in Python, which stops with its own message."""
    m_py = turning.ChamberModel(BALL, method="DOP853", kernel="python")
    m_c = turning.ChamberModel(BALL, method="DOP853", kernel="c")
    mo = Spin((0.0, 0.0, 1e150), (0.0, 0.0, 0.25))  # omega' overflows
    res = []
    for m, k in ((m_py, "python"), (m_c, "c")):
        st = m.initial(mo, 0.02, 0.0)
        st.h = 1e-3
        res.append(turning.simulate_general(m, mo, 0.1, 0.01, st, kernel=k))
    a, b = res
    assert not a.success and a.message == b.message and np.array_equal(a.y, b.y, equal_nan=True)
    assert math.isfinite(a.y[0, 0])


@needs_kernel
def test_a_failure_along_a_reconstructed_motion_is_handed_to_python():
    """BallInShell's chamber (motion = 2) advances along the motion reconstructed from its
    inputs in the kernel (bmg_advance_poly): an interval the kernel cannot finish (here the
    work bound, one internal step) is redone in Python, which fails with its own message and
    leaves the state as it was; never a state at t_end made of a half-done interval."""
    from ballmill.physics.errors import StepFailure
    from ballmill.physics.turning.reconstruction import ChamberReconstruction, inputs_of

    class Kin:
        pass
    motion = Fig1Machine()
    for kernel in ("python", "auto"):
        m = turning.ChamberModel(BALL, method="DOP853", kernel=kernel, max_steps=1)
        rec = ChamberReconstruction("derivatives", R=0.25)
        s = m.initial(motion, 0.03, 0.0)
        y0 = s.y.copy()
        rec.set_horizon(0.05)
        rec.push(0.0, *inputs_of(motion.state(0.0), 0.25))
        kin = Kin()
        kin.accel = rec.accel_function()
        with pytest.raises(StepFailure, match=r"DOP853: more than 1 internal steps between t = 0\.03886\d* s "
                                              r"and 0\.05 s"):
            m.advance(s, 0.05, kin)
        assert s.t == 0.0 and np.array_equal(s.y, y0)
    assert "_fast_poly" in m.__dict__  # the kernel was asked first
