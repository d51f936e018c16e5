"""The compiled kernel for monolithic runs: `simulate` in C when it can be.

``_kernel.c`` (beside this file) holds the vector formulation (with the
optional rolling resistance and drag), the outputs, the platform motions
CrankStartup / Fixed / Harmonic / Circle and the DOP853 / RK45 / RK4
integrators of this package, written in the operation order of the Python
code so that a run gives the Python path's results bit for bit: same steps,
same step sizes, same states, same outputs. setup.py builds it at install
time as the extension module ``ballmill.physics._kernel`` (optional: without
a C compiler the install still succeeds and everything runs in Python); this
module loads that file with ctypes.

`simulate(..., kernel="auto")` (the default) uses the kernel when it is built
and the run is one it covers (`applicable`), and Python otherwise;
``kernel="c"`` insists (`KernelUnavailable` with the reason), ``"python"``
never uses it. ``KERNEL_AVAILABLE`` / ``KERNEL_REASON`` / ``KERNEL_PATH`` say
whether the build is there and usable, why not, and which file it is. The
library is loaded on first use (the first `simulate`, or the first look at
those names), not on import: FMUs, which only advance a BallModel, never load
it. Setting the environment variable ``BALLMILL_NO_KERNEL=1`` (before that
first use) switches the kernel off.

What stays in Python: the adaptive methods' initial step size (one call at the
start of a run, so that numpy's way of summing is kept), and any interval the
kernel cannot complete: it stops at the last good output point and the Python
integrator redoes that interval, so that a failing run stops with exactly the
Python path's exception, message and step counts.
"""
from __future__ import annotations

import ctypes
import importlib.machinery
import math
import numbers
import os
from pathlib import Path

import numpy as np

from .drives import Circle, CrankStartup, Fixed, Harmonic
from .equations import VectorFormulation, _lossy, loss_constants
from .integrators import Integrator, TABLEAUS
from .outputs import Outputs

__all__ = ["KERNEL_AVAILABLE", "KERNEL_REASON", "KERNEL_PATH", "KernelUnavailable", "applicable",
           "simulate"]

ABI = 1
NY = 6
NOUT = len(Outputs._fields)
NS_MAX = 12
SOURCE = Path(__file__).with_name("_kernel.c")


class KernelUnavailable(RuntimeError):
    """``kernel="c"`` was asked for a run the compiled kernel cannot do (or it is not built)."""


class _Problem(ctypes.Structure):
    """ctypes mirror of bm_problem in _kernel.c (same fields, same order)."""

    _fields_ = [
        ("motion", ctypes.c_int), ("mp", ctypes.c_double * 8),
        ("rhs_lossy", ctypes.c_int),
        ("rhs_lam", ctypes.c_double), ("rhs_r", ctypes.c_double), ("rhs_g", ctypes.c_double),
        ("rhs_k", ctypes.c_double), ("rhs_loss", ctypes.c_double * 9),
        ("out_lossy", ctypes.c_int),
        ("o_lam", ctypes.c_double), ("o_r", ctypes.c_double), ("o_d", ctypes.c_double),
        ("o_R", ctypes.c_double), ("o_m", ctypes.c_double), ("o_g", ctypes.c_double),
        ("o_k", ctypes.c_double), ("o_mu", ctypes.c_double), ("o_cd", ctypes.c_double),
        ("o_delta", ctypes.c_double), ("o_loss", ctypes.c_double * 9),
        ("ns", ctypes.c_int), ("order", ctypes.c_int), ("adaptive", ctypes.c_int),
        ("has_e3", ctypes.c_int),
        ("A", ctypes.c_double * (NS_MAX * NS_MAX)), ("B", ctypes.c_double * NS_MAX),
        ("C", ctypes.c_double * NS_MAX), ("E", ctypes.c_double * (NS_MAX + 1)),
        ("E3", ctypes.c_double * (NS_MAX + 1)),
        ("tol", ctypes.c_double), ("h_fixed", ctypes.c_double), ("h_max", ctypes.c_double),
        ("max_steps", ctypes.c_longlong),
        ("scale", ctypes.c_double * NY), ("tols", ctypes.c_double * NY),
    ]


class _Stats(ctypes.Structure):
    _fields_ = [("steps", ctypes.c_longlong), ("rejected", ctypes.c_longlong),
                ("nfev", ctypes.c_longlong)]


_dp = ctypes.POINTER(ctypes.c_double)


def source_hash(path: Path = SOURCE) -> int | None:
    """The first 60 bits of the sha256 of _kernel.c, as setup.py embeds them in the build."""
    import hashlib

    try:
        data = path.read_bytes()
    except OSError:
        return None
    return int(hashlib.sha256(data).hexdigest()[:15], 16)


def _find_library() -> Path | None:
    here = Path(__file__).parent
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        p = here / f"_kernel{suffix}"
        if p.exists():
            return p
    return None


def _load():
    """(library or None, path or None, reason)."""
    if os.environ.get("BALLMILL_NO_KERNEL", "").strip() not in ("", "0"):
        return None, None, "switched off by the environment variable BALLMILL_NO_KERNEL"
    path = _find_library()
    if path is None:
        return None, None, ("not built: no ballmill/physics/_kernel extension next to fast.py "
                            "(installed without a C compiler? reinstall with one: pip install -e .)")
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as e:
        return None, path, f"cannot load {path.name}: {e}"
    try:
        lib.bm_abi.restype = ctypes.c_int
        lib.bm_problem_size.restype = ctypes.c_size_t
        lib.bm_source_hash.restype = ctypes.c_ulonglong
        abi, size, built_hash = lib.bm_abi(), lib.bm_problem_size(), lib.bm_source_hash()
    except AttributeError as e:
        return None, path, f"{path.name} is not the ballmill kernel ({e})"
    if abi != ABI or size != ctypes.sizeof(_Problem):
        return None, path, (f"{path.name} was built from another version of _kernel.c (ABI {abi}, "
                            f"problem size {size}; expected ABI {ABI}, size {ctypes.sizeof(_Problem)}); "
                            f"rebuild it: pip install -e .")
    src_hash = source_hash()
    if src_hash is not None and built_hash != src_hash:
        return None, path, (f"{path.name} is stale: it was built from a different _kernel.c than the one "
                            f"beside it; rebuild it: pip install -e .")
    lib.bm_simulate.restype = ctypes.c_longlong
    lib.bm_simulate.argtypes = [ctypes.POINTER(_Problem), _dp, ctypes.c_longlong, ctypes.c_longlong,
                                ctypes.c_int, _dp, _dp, _dp, _dp, ctypes.POINTER(_Stats)]
    lib.bm_initial_step.restype = ctypes.c_double
    lib.bm_initial_step.argtypes = [ctypes.POINTER(_Problem), ctypes.c_double, _dp, ctypes.c_double]
    lib.bm_eval_rhs.restype = None
    lib.bm_eval_rhs.argtypes = [ctypes.POINTER(_Problem), ctypes.c_double, _dp, _dp]
    lib.bm_eval_motion.restype = None
    lib.bm_eval_motion.argtypes = [ctypes.POINTER(_Problem), ctypes.c_double, _dp]
    lib.bm_eval_outputs.restype = None
    lib.bm_eval_outputs.argtypes = [ctypes.POINTER(_Problem), _dp] + [ctypes.c_double] * 4 + [_dp]
    return lib, path, ""


_STATE = None  # (library or None, path or None, reason), once loaded


def _kernel():
    """The loaded library (or None), loading it on first use."""
    global _STATE
    if _STATE is None:
        _STATE = _load()
    return _STATE[0]


def __getattr__(name):  # KERNEL_AVAILABLE, KERNEL_REASON, KERNEL_PATH: computed on first use
    if name in ("KERNEL_AVAILABLE", "KERNEL_REASON", "KERNEL_PATH"):
        _kernel()
        lib, path, reason = _STATE
        return {"KERNEL_AVAILABLE": lib is not None, "KERNEL_REASON": reason, "KERNEL_PATH": path}[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ----------------------------------------------------------------------------
# what the kernel covers
_REAL = numbers.Real


def _reals(*values) -> bool:
    return all(isinstance(v, _REAL) and not isinstance(v, bool) for v in values)


def _motion_params(motion):
    """(kind, parameters) of a motion the kernel knows, or (None, reason)."""
    tp = type(motion)
    if tp is CrankStartup:
        if not _reals(motion.l, motion.n0, motion.t0):
            return None, "CrankStartup with non-real parameters"
        return 1, (float(motion.l), float(motion.w0), float(motion.t0))
    if tp is Fixed:
        return 0, ()
    if tp is Harmonic:
        v = (motion.x_amp, motion.x_omega, motion.y_amp, motion.y_omega, motion.x_phase, motion.y_phase)
        if not _reals(*v):
            return None, "Harmonic with non-real parameters"
        # the squares are taken here, by the objects' own **, as Harmonic.state does
        return 2, tuple(float(x) for x in v) + (float(motion.x_omega ** 2), float(motion.y_omega ** 2))
    if tp is Circle:
        if not _reals(motion.l, motion.w):
            return None, "Circle with non-real parameters"
        return 3, (float(motion.l), float(motion.w))
    return None, (f"platform motion {tp.__name__} (the kernel knows CrankStartup, Fixed, Harmonic "
                  f"and Circle exactly)")


def applicable(model, motion, state=None) -> str:
    """'' when `simulate` can run this model and motion in the kernel, else why not."""
    from .model import BallModel  # model.py imports this module lazily

    if _kernel() is None:
        return f"compiled kernel unavailable: {_STATE[2]}"
    if type(model) is not BallModel:
        return f"model class {type(model).__name__} (the kernel reproduces BallModel exactly)"
    form, integ = model.form, model.integrator
    if type(form) is not VectorFormulation:
        return f"formulation {getattr(form, 'name', type(form).__name__)!r} (the kernel does 'vector' only)"
    if type(integ) is not Integrator or integ.method not in TABLEAUS:
        return "integrator is not the library's Integrator"
    if integ.project != form.project or integ.check != form.check:
        return "integrator hooks differ from the formulation's project/check"
    if integ.scale is None or integ.scale.shape != (NY,):
        return "integrator without a 6-component scale"
    lossy = _lossy(form.ball)
    d = form.__dict__.get("derivative")
    if (d is not None) != lossy or (d is not None and getattr(d, "__func__", None)
                                    is not VectorFormulation._derivative_lossy):
        return "formulation with a replaced right-hand side"
    kind, _ = _motion_params(motion)
    if kind is None:
        return _motion_params(motion)[1]
    if state is not None and np.shape(state.y) != (NY,):
        return f"state of shape {np.shape(state.y)}"
    return ""


def _problem(model, motion) -> _Problem:
    P = _Problem()
    kind, mp = _motion_params(motion)
    P.motion = kind
    for i, v in enumerate(mp):
        P.mp[i] = v
    fb = model.form.ball
    P.rhs_lam, P.rhs_r, P.rhs_g, P.rhs_k = model.form._consts
    if _lossy(fb):
        P.rhs_lossy = 1
        P.rhs_loss[:] = [float(v) for v in model.form._loss]
    b = model.ball
    P.o_lam, P.o_r, P.o_d, P.o_R, P.o_m, P.o_g = b.lam, b.r, b.d, b.R, b.m, b.g
    P.o_k, P.o_mu = b.k, b.mu
    if b.rolling_resistance or b.drag:
        P.out_lossy = 1
        P.o_cd = b.drag * b.d
        P.o_delta = b.rolling_resistance
        P.o_loss[:] = [float(v) for v in loss_constants(b)]
    integ = model.integrator
    tab = integ.tab
    ns = tab.n_stages
    P.ns, P.order, P.adaptive = ns, tab.order, int(integ.adaptive)
    A = np.zeros((ns, ns))
    A[:, :] = tab.A[:ns, :ns]
    P.A[:ns * ns] = A.ravel().tolist()
    P.B[:ns] = [float(v) for v in tab.B]
    P.C[:ns] = [float(v) for v in tab.C]
    if tab.E is not None:
        P.E[:ns + 1] = [float(v) for v in tab.E]
    if tab.E3 is not None:
        P.has_e3 = 1
        P.E3[:ns + 1] = [float(v) for v in tab.E3]
    P.tol, P.h_fixed, P.h_max = float(integ.tol), float(integ.h_fixed), float(integ.h_max)
    P.max_steps = int(min(integ.max_steps, 2 ** 62))
    P.scale[:] = integ.scale.tolist()
    P.tols[:] = (integ.tol * integ.scale).tolist()  # as the Python kernel's tol * scale
    return P


def problem(model, motion) -> _Problem:
    """The kernel's problem structure for a model and motion (checked with `applicable`)."""
    why = applicable(model, motion)
    if why:
        raise KernelUnavailable(why)
    return _problem(model, motion)


# ----------------------------------------------------------------------------
def simulate(model, motion, times: np.ndarray, state, outputs: bool):
    """`model.simulate`'s loop over the grid ``times`` (times[0] = state.t) in the
    kernel; returns (ys, outs or None, success, message, last). Call only when
    `applicable` says ''."""
    from .model import BallState, record_python

    lib = _kernel()
    n = len(times)
    P = _problem(model, motion)
    ys = np.empty((n, NY))
    outs = np.empty((n, NOUT)) if outputs else None
    times = np.ascontiguousarray(times, dtype=float)
    y = np.array(state.y, dtype=float)
    hbuf = np.empty(1)
    stats = _Stats()
    integ = model.integrator
    h = state.h
    extra_nfev = 0
    if integ.adaptive and not (h is not None and h > 0.0 and math.isfinite(h)) and n > 1:
        # the first interval's initial step, by the Python integrator (as its advance would)
        span = float(times[1]) - state.t
        if span > 0.0:
            f = model.rhs(motion.accel)
            y0 = np.array(state.y, dtype=float)
            f0 = f(state.t, y0)
            if all(map(math.isfinite, f0)):
                h = integ.initial_step(f, state.t, y0, np.asarray(f0, dtype=float), span)
                extra_nfev = 1
    hbuf[0] = h if h is not None else math.nan
    p_ys = ys.ctypes.data_as(_dp)
    p_outs = outs.ctypes.data_as(_dp) if outputs else None
    p_times, p_y, p_h = times.ctypes.data_as(_dp), y.ctypes.data_as(_dp), hbuf.ctypes.data_as(_dp)
    info = model.info
    start, record = 0, 1
    success, message = True, "completed"
    while True:
        last = lib.bm_simulate(ctypes.byref(P), p_times, n, start, record, p_y, p_h, p_ys, p_outs,
                                ctypes.byref(stats))
        if last > 0 and extra_nfev:  # the first interval was done with the initial step from here
            stats.nfev += extra_nfev
            extra_nfev = 0
        if last == n - 1:
            break
        # the kernel could not do the interval last -> last + 1: Python does it (and raises)
        if last > start:
            state = BallState(float(times[last]), y.copy(), float(hbuf[0]))
        info.steps += stats.steps
        info.rejected += stats.rejected
        info.nfev += stats.nfev
        stats = _Stats()
        ok, message, state = record_python(model, motion, times, state, last + 1, ys, outs)
        if not ok:
            return ys[:last + 1], (outs[:last + 1] if outputs else None), False, message, last
        y[:] = state.y
        hbuf[0] = state.h if state.h is not None else math.nan
        extra_nfev = 0
        start, record = last + 1, 0
    info.steps += stats.steps
    info.rejected += stats.rejected
    info.nfev += stats.nfev
    return ys, outs, success, message, n - 1


# ----------------------------------------------------------------------------
# single evaluations (tests)
def eval_rhs(P: _Problem, t: float, y) -> tuple:
    yy = np.ascontiguousarray(y, dtype=float)
    f = np.empty(NY)
    _kernel().bm_eval_rhs(ctypes.byref(P), t, yy.ctypes.data_as(_dp), f.ctypes.data_as(_dp))
    return tuple(f.tolist())


def eval_motion(P: _Problem, t: float) -> tuple:
    o = np.empty(6)
    _kernel().bm_eval_motion(ctypes.byref(P), t, o.ctypes.data_as(_dp))
    return tuple(o.tolist())


def eval_outputs(P: _Problem, y, ax, ay, xO=0.0, yO=0.0) -> tuple:
    yy = np.ascontiguousarray(y, dtype=float)
    o = np.empty(NOUT)
    _kernel().bm_eval_outputs(ctypes.byref(P), yy.ctypes.data_as(_dp), ax, ay, xO, yO, o.ctypes.data_as(_dp))
    return tuple(o.tolist())
