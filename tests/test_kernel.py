"""The compiled kernel (ballmill/physics/_kernel.c via ballmill.physics.fast)
against the Python path: same Trajectory, bit for bit, and the same failures."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ballmill.physics import (KERNEL_AVAILABLE, KERNEL_REASON, Ball, BallModel, Circle, CrankStartup,
                              Fixed, Harmonic, KernelUnavailable, Outputs, evaluate, fast, simulate)

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason=f"compiled kernel unavailable: {KERNEL_REASON}")

FAST_START = CrankStartup(l=0.5, n0=60.0, t0=2.5)
SHAKE = Harmonic(x_amp=0.02, x_omega=9.0, y_amp=0.015, y_omega=6.5, x_phase=0.3, y_phase=-1.1)
SETTINGS = [("DOP853", {"tol": 1e-9}), ("RK45", {"tol": 1e-7}), ("RK45", {"tol": 1e-10}),
            ("RK4", {"h_fixed": 0.005})]
LOSSY = Ball(rolling_resistance=1e-4, drag=0.5)


def run_both(make_model, motion, t_end, dt, state=None, outputs=True):
    """(python trajectory, kernel trajectory), each from a fresh model."""
    m_py, m_c = make_model(), make_model()
    st_py = state(m_py) if state else None
    st_c = state(m_c) if state else None
    a = simulate(m_py, motion, t_end, dt, state=st_py, outputs=outputs, kernel="python")
    b = simulate(m_c, motion, t_end, dt, state=st_c, outputs=outputs, kernel="c")
    return a, b


def assert_identical(a, b):
    """Same grid, states, outputs, status and work: bit for bit."""
    assert a.success == b.success and a.message == b.message
    assert a.info == b.info  # steps, rejected steps and evaluations
    assert a.t.shape == b.t.shape and np.array_equal(a.t, b.t)
    assert a.y.shape == b.y.shape
    assert np.array_equal(a.y, b.y), f"max |dy| = {np.max(np.abs(a.y - b.y)):.3g}"
    assert list(a.out) == list(b.out)
    for name in a.out:
        assert a.out[name].shape == b.out[name].shape, name
        assert np.array_equal(a.out[name], b.out[name], equal_nan=True), \
            f"{name}: max diff {np.nanmax(np.abs(a.out[name] - b.out[name])):.3g}"


def test_availability_is_reported():
    assert isinstance(KERNEL_AVAILABLE, bool)
    assert isinstance(KERNEL_REASON, str)
    assert KERNEL_AVAILABLE == (KERNEL_REASON == "")
    assert fast.KERNEL_AVAILABLE is KERNEL_AVAILABLE and fast.KERNEL_REASON == KERNEL_REASON
    assert (fast.KERNEL_PATH is not None) or not KERNEL_AVAILABLE


def test_the_kernel_compiles_as_installed_without_a_warning(tmp_path):
    """The kernel compiled as `pip install` compiles it (this Python's compiler and CFLAGS, -O3
    here, the module's defines, setup.py's rounding flags) gives no warning at -Wall -Wextra:
    the inlining -O3 does finds what -O2 does not (an array written past its end, a variable
    used before it is set), and setup.py's optional build would only print it. The native
    FMUs, which #include the kernel, are built at -O2 with -Werror (ballmill.fmi.native)."""
    import shlex
    import shutil
    import subprocess
    import sysconfig

    cc = shlex.split(sysconfig.get_config_var("CC") or "cc")
    if shutil.which(cc[0]) is None:
        pytest.skip(f"no C compiler {cc[0]!r}")
    from ballmill.physics import fast

    cmd = [*cc, *shlex.split(sysconfig.get_config_var("CFLAGS") or ""), "-Wall", "-Wextra", "-Werror",
           "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-DBALLMILL_KERNEL_MODULE",
           f"-I{sysconfig.get_paths()['include']}", "-c", str(fast.SOURCE), "-o", str(tmp_path / "k.o")]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0 and not proc.stderr, proc.stderr


def test_kernel_loads_on_first_use_only():
    """Importing the library (as an FMU does) does not load the shared library, nor does
    advancing with a motion's accel (only InputReconstruction's polynomial goes to C)."""
    import subprocess
    import sys

    code = ("import sys, ballmill.physics as p, ballmill.physics.fast as f\n"
            "from ballmill.physics import Ball, BallModel, CrankStartup\n"
            "m = BallModel(Ball()); m.advance(m.initial(), 0.01, CrankStartup().accel)\n"
            "assert f._STATE is None, 'loaded on import'\n"
            "print(p.KERNEL_AVAILABLE, f._STATE is not None)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == [str(KERNEL_AVAILABLE), "True"]


@needs_kernel
@pytest.mark.parametrize("method,opts", SETTINGS, ids=[f"{m}-{list(o.values())[0]:g}" for m, o in SETTINGS])
def test_fast_start_identical(method, opts):
    a, b = run_both(lambda: BallModel(Ball(), method=method, **opts), FAST_START, 10.0, 0.01)
    assert a.success and a.info.steps >= 1000
    assert_identical(a, b)


@needs_kernel
@pytest.mark.parametrize("method,opts", SETTINGS, ids=[f"{m}-{list(o.values())[0]:g}" for m, o in SETTINGS])
def test_harmonic_identical(method, opts):
    a, b = run_both(lambda: BallModel(Ball(), method=method, **opts), SHAKE, 6.0, 0.02,
                    state=lambda m: m.initial(xC0=0.05, yC0=-0.03, w0=(1.0, -2.0, 0.5)))
    assert a.success
    assert np.ptp(a["N"]) > 0.1  # the shaking matters
    assert_identical(a, b)


@needs_kernel
@pytest.mark.parametrize("motion", [Fixed(), Circle(l=0.3, w=5.0), CrankStartup(l=0.4, n0=45.0, t0=1.0)],
                         ids=["fixed", "circle", "crank"])
@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK4"])
def test_losses_and_other_motions_identical(motion, method):
    """Rolling resistance and drag, and the other motions; a swinging start."""
    a, b = run_both(lambda: BallModel(LOSSY, method=method, tol=1e-8, h_fixed=2e-3), motion, 3.0, 0.05,
                    state=lambda m: m.initial(xC0=0.1, w0=(0.0, 3.0, 0.2)))
    assert a.success
    assert np.max(a["P_diss"]) > 0.0
    assert_identical(a, b)


@needs_kernel
@pytest.mark.parametrize("law", ["quintic", "quadratic"], ids=["from_rest", "paper"])
def test_the_c_initial_step_is_the_pythons(law):
    """bm_initial_step (which starts the benchmark's standalone C program's adaptive runs)
    against Integrator.initial_step on the same right-hand side: the same step to round-off
    (C sums the norms in a loop, numpy pairwise). The quintic law starts with zero
    acceleration, so the ball at rest at the bottom has a vanishing derivative: the branch
    d1 < 1e-5 (h0 = 1e-6)."""
    model = BallModel(Ball(), method="RK45", tol=1e-9)
    P = fast.problem(model, CrankStartup(l=0.5, n0=60.0, t0=2.5, law=law))
    y0 = np.array(model.initial().y, dtype=float)

    def f(t, y):
        return np.array(fast.eval_rhs(P, t, y))
    for span in (0.01, 1e-7):
        h_py = model.integrator.initial_step(f, 0.0, y0, f(0.0, y0), span)
        assert fast.eval_initial_step(P, 0.0, y0, span) == pytest.approx(h_py, rel=1e-12, abs=0.0), span
    assert np.any(f(0.0, y0)) == (law != "quintic")


@needs_kernel
def test_the_c_initial_step_is_the_pythons_on_a_swinging_start():
    """A ball swinging off the bottom (n_x = 0.44) in a circling chamber: the starting step is
    the curvature's, h1 = (0.01 / d2)^(1/order) from the trial point y + h0 f(y), well below
    100 h0, so every component of the trial point shows in the step (a trial point with its
    n_x left at 0 gives 0.0108 s instead of 0.0185 s)."""
    model = BallModel(LOSSY, method="RK45", tol=1e-6)
    P = fast.problem(model, Circle(l=0.3, w=5.0))
    y0 = np.array(model.initial(xC0=0.1, w0=(0.0, 3.0, 0.2)).y, dtype=float)
    assert y0[0] == pytest.approx(0.4444, abs=1e-4)

    def f(t, y):
        return np.array(fast.eval_rhs(P, t, y))
    f0 = f(0.0, y0)
    h_py = model.integrator.initial_step(f, 0.0, y0, f0, 1.0)
    sc = model.integrator._scale(y0, y0)
    h0 = 0.01 * math.sqrt(np.mean((y0 / sc) ** 2)) / math.sqrt(np.mean((f0 / sc) ** 2))
    assert h_py < 0.1 * (100 * h0)  # the curvature decides, not 100 h0 or the span
    assert fast.eval_initial_step(P, 0.0, y0, 1.0) == pytest.approx(h_py, rel=1e-12, abs=0.0)


@needs_kernel
@pytest.mark.parametrize("law", ["scurve", "linear", "quintic"])
def test_every_start_up_law_identical(law):
    """The crank's other start-up laws (the paper's quadratic one is FAST_START): their angle,
    speed and acceleration in the kernel's motion, through the whole start and after (a
    start-up time other than 1 s, where t / t0 and t t0 would agree)."""
    a, b = run_both(lambda: BallModel(Ball(), method="RK45", tol=1e-9),
                    CrankStartup(l=0.5, n0=60.0, t0=1.25, law=law), 1.5, 0.01)
    assert a.success and np.ptp(a["N"]) > 0.1
    assert_identical(a, b)


@needs_kernel
def test_carried_state_h_max_and_no_outputs():
    """A state that carries its step size, a step limit, an offset start time, no outputs."""
    def model():
        return BallModel(Ball(), method="RK45", tol=1e-9, h_max=0.004)

    def state(m):
        st = simulate(m, FAST_START, 1.0, 0.01, kernel="python")  # noqa: F841 - fills m.info
        s = m.initial(xC0=0.02)
        s.t, s.h = 0.37, 0.0021
        return s

    a, b = run_both(model, FAST_START, 4.0, 0.013, state=state, outputs=False)
    assert a.out == {} and b.out == {}
    assert_identical(a, b)


@needs_kernel
def test_midrun_failure_identical():
    """The step limit hit in the middle of the run: the kernel hands the failing interval
    to Python, so the run stops at the same point with the same message and counts."""
    def model():
        m = BallModel(Ball(), method="RK45", tol=1e-10)
        m.integrator.max_steps = 2
        return m

    a, b = run_both(model, FAST_START, 10.0, 0.01)
    assert not a.success
    assert "more than 2 internal steps" in a.message and a.message.startswith("stopped at t = ")
    assert 10 < len(a.t) < 1001
    assert_identical(a, b)


@needs_kernel
@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the outputs at t = 0 are NaN on both paths
def test_failure_on_the_first_interval_identical():
    """A non-finite platform acceleration: no step can help."""
    wild = Harmonic(x_amp=1e300, x_omega=1e10, x_phase=0.5)
    a, b = run_both(lambda: BallModel(Ball()), wild, 1.0, 0.1)
    assert not a.success and "non-finite derivative" in a.message
    assert len(a.t) == 1
    assert_identical(a, b)


@needs_kernel
def test_python_only_cases():
    """The paper formulation and unknown motions run in Python with kernel='auto' and are
    refused, with the reason, with kernel='c'."""
    paper = BallModel(Ball(), formulation="paper")
    assert "formulation 'paper'" in fast.applicable(paper, FAST_START)
    with pytest.raises(KernelUnavailable, match="formulation 'paper'"):
        simulate(paper, FAST_START, 1.0, 0.01, kernel="c")
    a = simulate(BallModel(Ball(), formulation="paper"), FAST_START, 1.0, 0.01)
    b = simulate(BallModel(Ball(), formulation="paper"), FAST_START, 1.0, 0.01, kernel="python")
    assert_identical(a, b)

    @dataclasses.dataclass(frozen=True)
    class Still:
        def state(self, t):
            return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0

        def accel(self, t):
            return 0.0, 0.0

    assert "Still" in fast.applicable(BallModel(Ball()), Still())
    with pytest.raises(KernelUnavailable, match="Still"):
        simulate(BallModel(Ball()), Still(), 1.0, 0.1, kernel="c")
    a = simulate(BallModel(Ball()), Still(), 1.0, 0.1)
    b = simulate(BallModel(Ball()), Fixed(), 1.0, 0.1, kernel="c")
    assert_identical(a, b)
    with pytest.raises(ValueError, match="kernel must be one of"):
        simulate(BallModel(Ball()), Fixed(), 1.0, 0.1, kernel="fortran")


@needs_kernel
def test_paper_formulation_failure_stays_in_python():
    """Over the equator the paper formulation stops with its message, kernel or not."""
    drive = Circle(l=0.5, w=7.0)
    a = simulate(BallModel(Ball(), formulation="paper"), drive, 5.0, 0.01)
    b = simulate(BallModel(Ball(), formulation="paper"), drive, 5.0, 0.01, kernel="python")
    assert not a.success and "equator" in a.message
    assert_identical(a, b)
    v = simulate(BallModel(Ball()), drive, 5.0, 0.01, kernel="c")  # the vector form goes on
    assert v.success and np.max(v["zC"]) > Ball().R


@needs_kernel
@pytest.mark.parametrize("ball", [Ball(), LOSSY], ids=["lossless", "lossy"])
def test_single_evaluations_identical(ball):
    """Right-hand side, outputs and motions one call at a time, on random states."""
    rng = np.random.default_rng(7)
    for motion in (FAST_START, SHAKE, Circle(l=0.3, w=5.0), Fixed()):
        model = BallModel(ball)
        P = fast.problem(model, motion)
        for t in np.concatenate([rng.uniform(-0.5, 4.0, 40), [0.0, 2.5, motion.__dict__.get("t0", 1.0)]]):
            t = float(t)
            assert fast.eval_motion(P, t) == tuple(motion.state(t))
            n = rng.normal(size=3)
            n /= np.linalg.norm(n)
            y = np.concatenate([n, rng.normal(scale=20.0, size=3)])
            ax, ay = motion.accel(t)
            assert fast.eval_rhs(P, t, y) == tuple(model.form.derivative(y.tolist(), ax, ay))
            x, yy, _, _, ax, ay = motion.state(t)
            ref = evaluate(ball, tuple(y[:3]), tuple(y[3:]), ax, ay, x, yy)
            got = fast.eval_outputs(P, y, ax, ay, x, yy)
            assert len(got) == len(Outputs._fields)
            assert got == tuple(float(v) for v in ref)


@needs_kernel
def test_build_matches_source():
    """The loaded build was compiled from the _kernel.c beside it (fast.py refuses a stale one)."""
    lib = fast._kernel()
    assert lib.bm_source_hash() == fast.source_hash()
    assert lib.bm_problem_size() == fast.ctypes.sizeof(fast._Problem)


def test_python_fallback_when_unavailable(monkeypatch):
    """Without the kernel, 'auto' runs in Python and 'c' says why not."""
    monkeypatch.setattr(fast, "_STATE", (None, None, "not built (test)"))
    a = simulate(BallModel(Ball()), FAST_START, 0.5, 0.01)
    b = simulate(BallModel(Ball()), FAST_START, 0.5, 0.01, kernel="python")
    assert_identical(a, b)
    with pytest.raises(KernelUnavailable, match="not built \\(test\\)"):
        simulate(BallModel(Ball()), FAST_START, 0.5, 0.01, kernel="c")
    assert math.isfinite(a["N"][-1])
