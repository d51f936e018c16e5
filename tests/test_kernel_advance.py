"""BallModel.advance in the compiled kernel (ballmill.physics.fast.advance) when the
platform acceleration is InputReconstruction's cubic closure, as in the BallInShell FMU:
the same states, step sizes and work as the Python path, bit for bit, the same
failures, and FMUs that run (identically) with and without their bundled kernel."""
from __future__ import annotations

import copy
import math
import os
import pickle
import shutil
import textwrap
import zipfile

import numpy as np
import pytest

from ballmill.physics import (KERNEL_AVAILABLE, KERNEL_REASON, Ball, BallModel, BallState, CrankStartup,
                              Harmonic, InputReconstruction, KernelUnavailable, StepFailure, fast)
from host import run_host

needs_kernel = pytest.mark.skipif(not KERNEL_AVAILABLE, reason=f"compiled kernel unavailable: {KERNEL_REASON}")

FAST_START = CrankStartup(l=0.5, n0=60.0, t0=2.5)
SHAKE = Harmonic(x_amp=0.02, x_omega=9.0, y_amp=0.015, y_omega=6.5, x_phase=0.3, y_phase=-1.1)
LOSSY = Ball(rolling_resistance=1e-4, drag=0.5)
SETTINGS = [("RK45", {"tol": 1e-6}), ("RK45", {"tol": 1e-8}), ("DOP853", {"tol": 1e-9}),
            ("RK4", {"h_fixed": 1e-3})]
SETTING_IDS = [f"{m}-{list(o.values())[0]:g}" for m, o in SETTINGS]


def poly_accel(t0, xs, ys):
    """A closure with the contract of InputReconstruction._compile_accel's (accel.poly)."""
    x0, x1, x2, x3 = xs
    y0, y1, y2, y3 = ys

    def accel(t):
        s = t - t0
        return x0 + s * (x1 + s * (x2 + s * x3)), y0 + s * (y1 + s * (y2 + s * y3))
    accel.poly = (t0, tuple(xs), tuple(ys))
    return accel


def fmu_steps(model, mode, H, n, motion=FAST_START, corrector=True, points=None):
    """BallInShell.do_step's calls of BallModel.advance over n communication steps of H
    (corrector through the input window, then the predictor), exact motion samples.
    Returns every state advance produced, as (t, y bytes, h as hex), and the model's info."""
    rec = InputReconstruction(mode, points)
    state = model.initial(xC0=0.01)
    rec.push(0.0, *motion.state(0.0))
    history = [state]
    record = []
    t = 0.0
    for k in range(n):
        rec.set_horizon(H)
        rec.push(t, *motion.state(t))
        accel = rec.accel_function()
        times = rec.window()
        by_time = {st.t: st for st in history}
        if corrector and times[0] in by_time:
            out = [by_time[times[0]]]
            for tt in times[1:]:
                out.append(model.advance(out[-1], tt, accel))
            history = out
        else:
            history = [state]
        state = model.advance(history[-1], (k + 1) * H, accel)
        history = history + [state]
        record += [(st.t, st.y.tobytes(), float(st.h).hex() if st.h is not None else None)
                   for st in history[1:]]
        t = (k + 1) * H
    return record, model.info


def both(make, *args, **kwargs):
    """fmu_steps in Python and in the kernel (insisting), each on a fresh model."""
    a = fmu_steps(make("python"), *args, **kwargs)
    b = fmu_steps(make("c"), *args, **kwargs)
    return a, b


def test_closure_carries_its_polynomial():
    """The cubic closure's ``poly`` holds the values it computes with (same results in the
    same operation order); the Horner fallback of higher degrees has none."""
    rng = np.random.default_rng(3)
    for mode in ("derivatives", "positions", "hold"):
        rec = InputReconstruction(mode)
        for k in range(8):
            t = 0.013 * k
            rec.push(t, *FAST_START.state(t + 0.7))
            accel = rec.accel_function()
            t0, xs, ys = accel.poly
            assert all(type(v) is float for v in (t0, *xs, *ys))
            twin = poly_accel(t0, xs, ys)
            for tt in rng.uniform(t - 0.05, t + 0.05, 20):
                assert twin(float(tt)) == accel(float(tt))
                assert accel(float(tt)) == rec.accel(float(tt))
    rec = InputReconstruction("positions", points=8)
    for k in range(8):
        rec.push(0.01 * k, *FAST_START.state(0.01 * k))
    assert not hasattr(rec.accel_function(), "poly")


@needs_kernel
@pytest.mark.parametrize("method,opts", SETTINGS, ids=SETTING_IDS)
@pytest.mark.parametrize("mode", ["derivatives", "positions"])
def test_fast_start_steps_identical(method, opts, mode):
    """The FMU's corrector and predictor over the whole fast start, H = 40 ms and 10 ms."""
    for H, n in ((0.04, 250), (0.01, 120)):
        a, b = both(lambda k: BallModel(Ball(), method=method, kernel=k, **opts), mode, H, n)
        assert len(a[0]) >= n
        assert a[0] == b[0]  # every state: time, y and the carried step, bit for bit
        assert a[1] == b[1]  # steps, rejected steps, evaluations


@needs_kernel
@pytest.mark.parametrize("method,opts", SETTINGS[1:], ids=SETTING_IDS[1:])
def test_losses_hold_input_and_shaking_identical(method, opts):
    for ball, mode, motion in ((LOSSY, "derivatives", FAST_START), (Ball(), "hold", FAST_START),
                               (LOSSY, "positions", SHAKE)):
        a, b = both(lambda k: BallModel(ball, method=method, kernel=k, **opts), mode, 0.005, 300,
                    motion=motion)
        assert a == b


@needs_kernel
def test_carried_step_offset_time_and_h_max():
    """A state with its own step size at an offset time; a step limit; states without a step."""
    def run(kernel):
        m = BallModel(Ball(), method="RK45", tol=1e-9, h_max=0.004, kernel=kernel)
        rec = InputReconstruction()
        rec.push(1.3, *FAST_START.state(1.3))
        rec.push(1.33, *FAST_START.state(1.33))
        accel = rec.accel_function()
        s = m.initial(xC0=0.02, w0=(1.0, -2.0, 0.5), t0=1.33)
        out = []
        for h in (0.0021, None, -1.0, math.inf, math.nan, 0.2):
            s.h = h
            new = m.advance(s, 1.37, accel)
            out.append((new.y.tobytes(), new.h))
        return out, m.info

    assert run("python") == run("c")


@needs_kernel
def test_the_kernel_does_the_work(monkeypatch):
    """auto: the cubic input goes to C; python: never; a motion's accel: always Python."""
    done = []
    real = fast.advance

    def spy(*args):
        r = real(*args)
        done.append(r is not None)
        return r

    monkeypatch.setattr(fast, "advance", spy)
    fmu_steps(BallModel(Ball(), method="RK45"), "derivatives", 0.02, 20)
    assert len(done) == 39 and all(done)  # 19 corrector and 20 predictor intervals, all in C
    done.clear()
    fmu_steps(BallModel(Ball(), method="RK45", kernel="python"), "derivatives", 0.02, 20)
    assert done == []
    m = BallModel(Ball())
    m.advance(m.initial(xC0=0.01), 0.1, FAST_START.accel)
    assert done == []


@needs_kernel
def test_failures_identical():
    """Failing intervals go back to Python: same exception and message, state and info untouched."""
    cases = [
        (dict(method="RK45"), poly_accel(0.0, (math.nan, 0.0, 0.0, 0.0), (0.0,) * 4)),  # non-finite input
        (dict(method="DOP853"), poly_accel(0.0, (1e300, 1e300, 0.0, 0.0), (0.0,) * 4)),  # overflow
        (dict(method="RK4"), poly_accel(0.0, (1e300, 1e300, 0.0, 0.0), (0.0,) * 4)),
    ]
    for opts, accel in cases:
        results = []
        for kernel in ("python", "c"):
            m = BallModel(Ball(), kernel=kernel, **opts)
            s = m.initial(xC0=0.01)
            s.h = 1e-3
            before = s.y.copy()
            with pytest.raises(StepFailure) as e:
                m.advance(s, 0.5, accel)
            assert np.array_equal(s.y, before) and s.h == 1e-3
            results.append((str(e.value), m.info))
        assert results[0] == results[1]
    # the step limit, after some good intervals
    results = []
    for kernel in ("python", "c"):
        m = BallModel(Ball(), method="RK45", tol=1e-10, kernel=kernel)
        m.integrator.max_steps = 2
        rec = InputReconstruction()
        s, t, msg = m.initial(xC0=0.01), 0.0, None
        for k in range(200):
            rec.push(t, *FAST_START.state(t))
            try:
                s = m.advance(s, t + 0.01, rec.accel_function())
            except StepFailure as e:
                msg = str(e)
                break
            t += 0.01
        results.append((k, msg, s.y.tobytes(), s.h, m.info))
    assert results[0] == results[1]
    assert "more than 2 internal steps" in results[0][1] and results[0][0] > 10


@needs_kernel
def test_settings_changed_after_first_use():
    """The kernel's problem is rebuilt when the integrator's settings change, as Python reads them anew."""
    def run(kernel):
        m = BallModel(Ball(), method="RK45", tol=1e-6, kernel=kernel)
        r1 = fmu_steps(m, "derivatives", 0.02, 30)[0]
        m.integrator.tol = 1e-10
        m.integrator.h_max = 0.003
        r2 = fmu_steps(m, "derivatives", 0.02, 30)[0]
        m.integrator.max_steps = 1
        with pytest.raises(StepFailure) as e:
            fmu_steps(m, "derivatives", 0.02, 30)
        return r1, r2, str(e.value), m.info

    assert run("python") == run("c")


@needs_kernel
def test_copied_and_pickled_models():
    m = BallModel(Ball(), method="RK45", kernel="c")
    fmu_steps(m, "derivatives", 0.02, 5)
    assert "_fast_advance" in m.__dict__
    for twin in (copy.deepcopy(m), pickle.loads(pickle.dumps(m))):
        assert "_fast_advance" not in twin.__dict__
        twin.info = type(m.info)()
        ref = BallModel(Ball(), method="RK45", kernel="python")
        assert fmu_steps(twin, "derivatives", 0.02, 20) == fmu_steps(ref, "derivatives", 0.02, 20)


def test_kernel_option(monkeypatch):
    with pytest.raises(ValueError, match="kernel must be one of"):
        BallModel(Ball(), kernel="fortran")
    rec = InputReconstruction()
    rec.push(0.0, *FAST_START.state(0.0))
    accel = rec.accel_function()
    with pytest.raises(KernelUnavailable, match="formulation 'paper'"):
        m = BallModel(Ball(), formulation="paper", kernel="c")
        m.advance(m.initial(), 0.01, accel)
    if KERNEL_AVAILABLE:
        with pytest.raises(KernelUnavailable, match="without polynomial coefficients"):
            m = BallModel(Ball(), kernel="c")
            m.advance(m.initial(), 0.01, FAST_START.accel)
    # nothing to integrate: no refusal, the state comes back as Python gives it
    m = BallModel(Ball(), kernel="c")
    s = m.initial()
    same = m.advance(s, 0.0, accel)
    assert same.t == 0.0 and np.array_equal(same.y, s.y) and same.h is None
    # without the kernel: 'auto' runs in Python with the same results, 'c' says why
    monkeypatch.setattr(fast, "_STATE", (None, None, "not built (test)"))
    a = fmu_steps(BallModel(Ball(), method="RK45"), "derivatives", 0.02, 50)
    b = fmu_steps(BallModel(Ball(), method="RK45", kernel="python"), "derivatives", 0.02, 50)
    assert a == b
    with pytest.raises(KernelUnavailable, match="not built \\(test\\)"):
        fmu_steps(BallModel(Ball(), kernel="c"), "derivatives", 0.02, 2)


# ----------------------------------------------------------------------------------------
# the FMUs

COUPLED = textwrap.dedent("""
    import json, sys
    import numpy as np
    from ballmill.scenario import runner
    import ballmill.physics.fast as fast
    build_dir, scenario, step, stop, out = sys.argv[1:6]
    sc, models, paths = runner.prepare(scenario, [], build_dir, log=lambda m: None, flavour="pythonfmu")
    sc.step, sc.stop = float(step), float(stop)
    res = runner.run(sc, models, paths, progress=False, echo=False)
    np.save(out, res.data)
    lib, path, reason = fast._STATE if fast._STATE else (None, None, "never loaded")
    finish({"success": res.success, "steps": res.steps, "columns": res.columns,
            "kernel": lib is not None, "reason": reason})
""")


def _env(no_kernel: bool):
    env = dict(os.environ)
    env.pop("BALLMILL_NO_KERNEL", None)
    if no_kernel:
        env["BALLMILL_NO_KERNEL"] = "1"
    return env


@needs_kernel
@pytest.mark.parametrize("scenario,step", [("fast_start", 0.04), ("fast_start_positions", 0.01)])
def test_coupled_fast_start_identical_without_the_kernel(fmu_build_dir, tmp_path, scenario, step):
    """The two-FMU fast start through ballmill's master: the same recorded outputs, bit for bit,
    with the kernel and with BALLMILL_NO_KERNEL=1."""
    runs = {}
    for no_kernel in (False, True):
        out = tmp_path / f"data_{no_kernel}.npy"
        info = run_host(COUPLED, [fmu_build_dir, scenario, step, "10.0" if step >= 0.04 else "3.0", out],
                        tmp_path / f"info_{no_kernel}.json", env=_env(no_kernel))
        assert info["success"]
        runs[no_kernel] = (info, np.load(out))
    (on, a), (off, b) = runs[False], runs[True]
    assert on["kernel"] and not off["kernel"] and "BALLMILL_NO_KERNEL" in off["reason"]
    assert on["columns"] == off["columns"] and on["steps"] == off["steps"] > 200
    assert a.shape == b.shape and np.array_equal(a, b)
    assert np.ptp(a[:, on["columns"].index("ball.zP")]) > 1e-3  # the ball did move


STANDALONE = textwrap.dedent("""
    import json, sys
    # hide the installed (editable) ballmill: only the FMU's bundled copy may be used
    sys.meta_path[:] = [f for f in sys.meta_path if "ballmill" not in str(getattr(f, "__module__", ""))
                        and "ballmill" not in type(f).__module__]
    sys.path[:] = [p for p in sys.path if p not in ("", ".") and not p.endswith("/main")]
    for name in [n for n in sys.modules if n.split(".")[0] == "ballmill"]:
        del sys.modules[name]
    import numpy as np
    from fmpy import simulate_fmu
    unzipdir, out = sys.argv[1:3]
    # the fast start's platform motion (CrankStartup(0.5, 60, 2.5)) as the input signal
    w0, t0, l = 2 * np.pi * 60.0 / 60.0, 2.5, 0.5
    t = np.linspace(0.0, 3.0, 3001)
    u = 1.0 - np.minimum(t, t0) / t0
    psi = np.where(t <= t0, -w0 * (t - t0) ** 3 / (3 * t0 * t0) + w0 * t - w0 * t0 / 3, 2 / 3 * w0 * t0 + w0 * (t - t0))
    wd = np.where(t <= t0, w0 * (1 - u * u), w0)
    wdd = np.where(t <= t0, 2 * w0 * u / t0, 0.0)
    c, s = np.cos(psi), np.sin(psi)
    sig = np.array(list(zip(t, l * c, l * s, -l * s * wd, l * c * wd, -l * (s * wdd + c * wd * wd),
                            l * (c * wdd - s * wd * wd))),
                   dtype=[("time", float)] + [(n, float) for n in ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")])
    r = simulate_fmu(unzipdir, stop_time=3.0, output_interval=0.02, input=sig, start_values={"xC0": 0.02},
                     output=["xP", "yP", "zP", "N", "Fx", "M_reaction", "wz", "friction_ratio"])
    np.save(out, np.array(r.tolist()))
    fast = sys.modules["ballmill.physics.fast"]
    lib, path, reason = fast._STATE if fast._STATE else (None, None, "never loaded")
    finish({"ball_from": sys.modules["ballmill"].__file__, "kernel": lib is not None,
            "path": str(path), "reason": reason})
""")


def _standalone(unzipdir, out, no_kernel=False):
    info = run_host(STANDALONE, [unzipdir, out], str(out) + ".json", cwd=unzipdir, env=_env(no_kernel))
    return info, np.load(out)


def test_fmu_bundles_the_kernel(fmus_of, tmp_path):
    """The FMUs carry the library built here when it is current (checked at build time, so
    the source stays out and the FMU does not hash it at load time), and nothing else compiled."""
    from ballmill.fmi.build import kernel_to_bundle

    lib, why = kernel_to_bundle()
    assert (lib is None) == bool(why)
    for fmu in fmus_of("pythonfmu").values():  # (the native FMUs carry C sources instead)
        names = zipfile.ZipFile(fmu).namelist()
        bundled = [n for n in names if n.startswith("resources/ballmill/physics/_kernel")]
        assert bundled == ([f"resources/ballmill/physics/{lib.name}"] if lib else []), bundled
        assert not [n for n in names if "__pycache__" in n or n.endswith((".c", ".h", ".o"))]
    if lib is not None:  # a library that is not the build of the source beside it is not bundled
        assert fast.check_library(lib) == ""
        stale = tmp_path / "_kernel.c"
        stale.write_text(fast.SOURCE.read_text() + "\n/* edited */\n")
        for h in fast.KERNEL_HEADERS:
            shutil.copy2(fast.SOURCE.with_name(h), tmp_path / h)
        assert "stale" in fast.check_library(lib, stale)
        # an edited header beside the unchanged source (the kernel #includes it): stale too
        shutil.copy2(fast.SOURCE, stale)
        assert fast.check_library(lib, stale) == ""
        header = tmp_path / fast.KERNEL_HEADERS[0]
        header.write_text(header.read_text() + "\n/* edited */\n")
        assert "stale" in fast.check_library(lib, stale)
        assert "no kernel source" in fast.check_library(lib, tmp_path / "missing.c")


@needs_kernel
def test_fmu_runs_with_a_missing_or_broken_kernel(fmus_of, tmp_path):
    """Standalone (no installed ballmill): the FMU loads its own kernel; with the library
    removed, damaged, stale (another _kernel.c put beside it) or switched off it runs in
    Python, with the same outputs bit for bit."""
    base = tmp_path / "intact"
    zipfile.ZipFile(fmus_of("pythonfmu")["BallInShell"]).extractall(base)
    physics = base / "resources" / "ballmill" / "physics"
    lib_name = next(p.name for p in physics.glob("_kernel*") if p.suffix != ".c")
    variants = {}
    for name in ("missing", "broken", "stale"):
        d = tmp_path / name
        shutil.copytree(base, d)
        p = d / "resources" / "ballmill" / "physics"
        if name == "missing":
            (p / lib_name).unlink()
        elif name == "broken":
            (p / lib_name).write_bytes(b"\x7fELF not really a library")
        else:
            (p / "_kernel.c").write_text(fast.SOURCE.read_text() + "\n/* edited */\n")
        variants[name] = d

    info, ref = _standalone(base, tmp_path / "intact.npy")
    assert "resources" in info["ball_from"] and str(base) in info["ball_from"]
    assert info["kernel"] and str(physics) in info["path"], info
    assert ref.shape[0] == 151 and np.ptp(ref[:, 3]) > 1e-4  # zP moved

    info, data = _standalone(base, tmp_path / "off.npy", no_kernel=True)
    assert not info["kernel"] and "BALLMILL_NO_KERNEL" in info["reason"]
    assert np.array_equal(data, ref)

    info, data = _standalone(variants["missing"], tmp_path / "missing.npy")
    assert not info["kernel"] and "not built" in info["reason"]
    assert np.array_equal(data, ref)

    info, data = _standalone(variants["broken"], tmp_path / "broken.npy")
    assert not info["kernel"] and "cannot load" in info["reason"]
    assert np.array_equal(data, ref)

    info, data = _standalone(variants["stale"], tmp_path / "stale.npy")
    assert not info["kernel"] and "stale" in info["reason"]
    assert np.array_equal(data, ref)


def test_state_type_and_time_checks():
    """Unusual states and times stay in Python (kernel='auto') with its results."""
    rec = InputReconstruction()
    rec.push(0.0, *FAST_START.state(0.0))
    accel = rec.accel_function()
    for kernel in ("auto", "python"):
        m = BallModel(Ball(), method="RK45", kernel=kernel)
        s = m.initial(xC0=0.01)
        st_int_time = BallState(0, s.y.copy(), None)
        a = m.advance(st_int_time, 1, accel)
        assert a.t == 1.0
    pa = BallModel(Ball(), method="RK45", kernel="python").advance(BallState(0, s.y.copy()), 1, accel)
    pb = BallModel(Ball(), method="RK45").advance(BallState(0, s.y.copy()), 1, accel)
    assert np.array_equal(pa.y, pb.y) and pa.h == pb.h
