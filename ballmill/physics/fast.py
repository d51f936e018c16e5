"""The compiled kernel: `simulate`, and `BallModel.advance` on a polynomial input, in C.

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
library is loaded on first use (the first `simulate`, the first `advance`
below, or the first look at those names), not on import. Setting the
environment variable ``BALLMILL_NO_KERNEL=1`` (before that first use) switches
the kernel off.

`advance` does one `BallModel.advance` interval in the kernel when the
platform acceleration is InputReconstruction's cubic closure (``accel.poly``:
t0 and the coefficients; the kernel's motion BM_POLY evaluates it in the
closure's operation order): what the BallInShell FMU does twice per
communication step. It keeps a problem structure per model (rebuilt when the
model's integrator settings change) and returns the same y and step size, bit
for bit, and adds the same work to ``model.info``, as `Integrator.advance`
would. The FMUs bundle the built library (ballmill/fmi/build.py); where it
cannot be loaded they run in Python. ``BallModel(kernel="python")`` keeps a
model in Python.

`hybrid_run` runs `events.integrate` for the hybrid ball (hybrid.HybridBall) of a translating
or turning chamber in the kernel (bmh_simulate: the same rows, events and bookkeeping bit for bit), which
`hybrid.simulate_hybrid` selects by default where `hybrid_reason` says it can.

What stays in Python: the adaptive methods' initial step size (one call at the
start of a run, or when a state carries no step size, so that numpy's way of
summing is kept), and any interval the kernel cannot complete: `simulate` stops
at the last good output point and `advance` gives the interval back, and the
Python integrator redoes it, so that a failure raises exactly the Python path's
exception, with its message and step counts.
"""
from __future__ import annotations

import ctypes
import importlib.machinery
import math
import numbers
import os
import struct
from pathlib import Path

import numpy as np

from .drives.crank import LAWS, Circle, CrankStartup, Fixed, Harmonic
from .equations import VectorFormulation, _lossy, bed_constants, loss_constants
from .integrators import TABLEAUS, Integrator, StepStats
from .outputs import Outputs

__all__ = ["KERNEL_AVAILABLE", "KERNEL_REASON", "KERNEL_PATH", "KernelUnavailable", "applicable",
           "simulate"]

ABI = 6
NY = 6
NYMAX = 25  # BM_NYMAX: the integrators' largest state (the absorber's coupled one)
NOUT = len(Outputs._fields)
NS_MAX = 12
SOURCE = Path(__file__).with_name("_kernel.c")
KERNEL_HEADERS = ("crank_law.h",)  # beside _kernel.c, #included by it (setup.py's HEADERS)


class KernelUnavailable(RuntimeError):
    """``kernel="c"`` was asked for a run the compiled kernel cannot do (or it is not built)."""


class _Problem(ctypes.Structure):
    """ctypes mirror of bm_problem in _kernel.c (same fields, same order)."""

    _fields_ = [
        ("motion", ctypes.c_int), ("mp", ctypes.c_double * 9),
        ("rhs_lossy", ctypes.c_int),
        ("rhs_lam", ctypes.c_double), ("rhs_r", ctypes.c_double), ("rhs_g", ctypes.c_double),
        ("rhs_k", ctypes.c_double), ("rhs_loss", ctypes.c_double * 9),
        ("out_lossy", ctypes.c_int),
        ("o_lam", ctypes.c_double), ("o_r", ctypes.c_double), ("o_d", ctypes.c_double),
        ("o_R", ctypes.c_double), ("o_m", ctypes.c_double), ("o_g", ctypes.c_double),
        ("o_k", ctypes.c_double), ("o_mu", ctypes.c_double), ("o_cd", ctypes.c_double),
        ("o_delta", ctypes.c_double), ("o_loss", ctypes.c_double * 9),
        ("rhs_has_bed", ctypes.c_int), ("o_has_bed", ctypes.c_int),
        ("rhs_bed", ctypes.c_double * 3), ("o_bed", ctypes.c_double * 3),
        ("ns", ctypes.c_int), ("order", ctypes.c_int), ("adaptive", ctypes.c_int),
        ("has_e3", ctypes.c_int),
        ("A", ctypes.c_double * (NS_MAX * NS_MAX)), ("B", ctypes.c_double * NS_MAX),
        ("C", ctypes.c_double * NS_MAX), ("E", ctypes.c_double * (NS_MAX + 1)),
        ("E3", ctypes.c_double * (NS_MAX + 1)),
        ("tol", ctypes.c_double), ("h_fixed", ctypes.c_double), ("h_max", ctypes.c_double),
        ("max_steps", ctypes.c_longlong),
        ("scale", ctypes.c_double * NYMAX), ("tols", ctypes.c_double * NYMAX),
        ("form", ctypes.c_int), ("ny", ctypes.c_int), ("pap_d", ctypes.c_double),
        ("pap_margin", ctypes.c_double), ("mp_kin", ctypes.c_double * 20),
        ("nerr", ctypes.c_int),
    ]


class _Stats(ctypes.Structure):
    _fields_ = [("steps", ctypes.c_longlong), ("rejected", ctypes.c_longlong),
                ("nfev", ctypes.c_longlong)]


_dp = ctypes.POINTER(ctypes.c_double)


def source_hash(path: Path = SOURCE) -> int | None:
    """The first 60 bits of the sha256 of _kernel.c and the headers it includes
    (KERNEL_HEADERS), as setup.py embeds them in the build (None without _kernel.c: an FMU's
    bundle, checked when it was built, has none; a header missing beside it counts as empty, so
    the hash is not the build's)."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    import hashlib  # only here: importing it costs milliseconds

    for h in KERNEL_HEADERS:  # a header missing beside the source: not the tree the build came from
        header = path.with_name(h)
        data += header.read_bytes() if header.is_file() else b""
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
    lib, reason = _open(path)
    return lib, path, reason


def check_library(path: Path, source: Path = SOURCE) -> str:
    """'' when the library at ``path`` loads here and is a build of ``source`` for this
    fast.py (ABI, structure size, source hash), else why not. Ignores BALLMILL_NO_KERNEL
    (ballmill.fmi.build bundles only a library that passes)."""
    if source_hash(source) is None:
        return f"no kernel source {source} to check {Path(path).name} against"
    return _open(Path(path), source)[1]


def _open(path: Path, source: Path = SOURCE):
    """(library or None, reason): the library at path, loaded and checked; against the
    source only where the source is there (an FMU's bundle has none)."""
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as e:
        return None, f"cannot load {path.name}: {e}"
    try:
        lib.bm_abi.restype = ctypes.c_int
        lib.bm_problem_size.restype = ctypes.c_size_t
        lib.bm_source_hash.restype = ctypes.c_ulonglong
        abi, size, built_hash = lib.bm_abi(), lib.bm_problem_size(), lib.bm_source_hash()
    except AttributeError as e:
        return None, f"{path.name} is not the ballmill kernel ({e})"
    if abi != ABI or size != ctypes.sizeof(_Problem):
        return None, (f"{path.name} was built from another version of _kernel.c (ABI {abi}, "
                      f"problem size {size}; expected ABI {ABI}, size {ctypes.sizeof(_Problem)}); "
                      f"rebuild it: pip install -e .")
    src_hash = source_hash(source)
    if src_hash is not None and built_hash != src_hash:
        return None, (f"{path.name} is stale: it was built from a different _kernel.c than the one "
                      f"beside it; rebuild it: pip install -e .")
    P = ctypes.POINTER(_Problem)
    _declare(lib, {
        "bm_simulate": (ctypes.c_longlong, [P, _dp, ctypes.c_longlong, ctypes.c_longlong, ctypes.c_int,
                                            _dp, _dp, _dp, _dp, ctypes.POINTER(_Stats)]),
        # its arrays as addresses (study_run's buffers, one block per run: a numpy array's
        # ctypes pointer costs microseconds, a study calls this thousands of times)
        "bm_simulate_study": (ctypes.c_longlong, [P, ctypes.c_void_p, ctypes.c_longlong, ctypes.c_longlong,
                                                  ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                                  ctypes.c_double, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                                  ctypes.c_double, ctypes.POINTER(_Stats)]),
        "bm_advance_interval": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]),
        "bm_initial_step": (ctypes.c_double, [P, ctypes.c_double, _dp, ctypes.c_double]),
        "bm_eval_rhs": (None, [P, ctypes.c_double, _dp, _dp]),
        "bm_eval_motion": (None, [P, ctypes.c_double, _dp]),
        "bm_eval_outputs": (None, [P, _dp] + [ctypes.c_double] * 4 + [_dp]),
    })
    return lib, ""


def _declare(lib, functions: dict) -> None:
    """Give the library's functions their types: name -> (restype, argtypes)."""
    for name, (restype, argtypes) in functions.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes


def model_library(c_name: str, structure: type, what: str, functions: dict):
    """(library, '') with the functions of one of the kernel's other models declared
    (name -> (restype, argtypes)), after checking that the build's C structure of that
    model, ``c_name`` (its size: ``<c_name>_size()``), is the size of ``structure``, its
    ctypes mirror; or (None, why not). `what` names the functions in the message (e.g.
    "absorber functions")."""
    lib = _kernel()
    if lib is None:
        return None, f"compiled kernel unavailable: {_STATE[2]}"
    try:
        size_of = getattr(lib, c_name + "_size")
    except AttributeError:
        return None, f"the built kernel has no {what} (rebuild: pip install -e .)"
    size_of.restype = ctypes.c_size_t
    size = size_of()
    if size != ctypes.sizeof(structure):
        return None, (f"{c_name} size {size} != {ctypes.sizeof(structure)} "
                      f"(stale build; rebuild: pip install -e .)")
    _declare(lib, functions)
    return lib, ""


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
    # floats and ints first: numbers.Real's isinstance (an ABC) costs a microsecond a value
    return all(type(v) is float or type(v) is int or (isinstance(v, _REAL) and not isinstance(v, bool))
               for v in values)


def _motion_params(motion):
    """(kind, parameters) of a motion the kernel knows, or (None, reason)."""
    tp = type(motion)
    if tp is CrankStartup:
        if not _reals(motion.l, motion.n0, motion.t0):
            return None, "CrankStartup with non-real parameters"
        if motion.law not in LAWS:
            return None, f"CrankStartup law {motion.law!r}"
        return 1, (float(motion.l), float(motion.w0), float(motion.t0), float(LAWS.index(motion.law)))
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
    why = _model_reason(model)
    if why:
        return why
    kind, _ = _motion_params(motion)
    if kind is None:
        return _motion_params(motion)[1]
    if state is not None and np.shape(state.y) != (NY,):
        return f"state of shape {np.shape(state.y)}"
    return ""


def _model_reason(model) -> str:
    """'' when the kernel reproduces this model's right-hand side and integrator, else why not."""
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
    return ""


def _problem(model, motion) -> _Problem:
    """The problem structure; ``motion=None``: no motion (`advance` passes its own)."""
    P = _Problem()
    P.form, P.ny = 0, NY  # the vector formulation (the paper's is the native FMU's only)
    if motion is not None:
        kind, mp = _motion_params(motion)
        P.motion = kind
        for i, v in enumerate(mp):
            P.mp[i] = v
    fb = model.form.ball
    P.rhs_lam, P.rhs_r, P.rhs_g, P.rhs_k = model.form._consts
    if _lossy(fb):
        P.rhs_lossy = 1
        P.rhs_loss[:] = [float(v) for v in model.form._loss]
        if model.form._bed is not None:
            P.rhs_has_bed = 1
            P.rhs_bed[:] = [float(v) for v in model.form._bed]
    b = model.ball
    P.o_lam, P.o_r, P.o_d, P.o_R, P.o_m, P.o_g = b.lam, b.r, b.d, b.R, b.m, b.g
    P.o_k, P.o_mu = b.k, b.mu
    if b.rolling_resistance or b.drag:
        P.out_lossy = 1
        P.o_cd = b.drag * b.d
        P.o_delta = b.rolling_resistance
        P.o_loss[:] = [float(v) for v in loss_constants(b)]
    if b.bed_depth is not None:
        P.o_has_bed = 1
        P.o_bed[:] = [float(v) for v in bed_constants(b)]
    fill_integrator(P, model.integrator)
    return P


def fill_integrator(P: _Problem, integ) -> None:
    """The integrator's part of a problem structure (tableau, tolerances, step bounds,
    scale of P.ny states), as the Python integrator computes with them."""
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
    P.scale[:P.ny] = integ.scale.tolist()
    P.tols[:P.ny] = (integ.tol * integ.scale).tolist()  # as the Python kernel's tol * scale
    P.nerr = integ.n_err or 0  # the states in the error norm (0: all)


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
    from .model import record_python

    return run_grid(_kernel().bm_simulate, _problem(model, motion), NOUT, model, model.rhs(motion.accel),
                    lambda *a: record_python(model, motion, *a), times, state, outputs)


def run_grid(kernel_simulate, P, nout: int, model, f, record_python, times: np.ndarray, state,
             outputs: bool):
    """A grid run in the kernel, shared by `simulate` and turning.kernel.simulate:
    kernel_simulate (bm_simulate or bmg_simulate) with the problem P over ``times``,
    states of NY and outputs of `nout` fields, after the first interval's initial step
    taken by the Python integrator from the right-hand side f(t, y) as its advance would;
    record_python(times, state, i, ys, outs) does the intervals the kernel hands back.
    Returns (ys, outs or None, success, message, last)."""
    from .model import BallState

    n = len(times)
    ys = np.empty((n, NY))
    outs = np.empty((n, nout)) if outputs else None
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
    while True:
        last = kernel_simulate(ctypes.byref(P), p_times, n, start, record, p_y, p_h, p_ys, p_outs,
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
        ok, message, state = record_python(times, state, last + 1, ys, outs)
        if not ok:
            return ys[:last + 1], (outs[:last + 1] if outputs else None), False, message, last
        y[:] = state.y
        hbuf[0] = state.h if state.h is not None else math.nan
        extra_nfev = 0
        start, record = last + 1, 0
    info.steps += stats.steps
    info.rejected += stats.rejected
    info.nfev += stats.nfev
    return ys, outs, True, "completed", n - 1


class StudyRun:
    """A run of `study_run`: ``ys``, ``outs`` (rows 0..last are the run's), ``last``,
    ``stopped`` (the run ended at the first point where the model stops holding), ``failed``
    (the kernel could not do an interval: redo the point with `simulate`), ``err_P`` [m],
    ``err_N`` [N] (the run's own error estimate over its samples, or None: not asked),
    ``exceeded`` (the run ended where its contact-point estimate passed the limit asked)."""

    __slots__ = ("times", "ys", "outs", "last", "stopped", "failed", "err_P", "err_N", "exceeded")


def study_problem(model) -> _Problem | None:
    """The model's part of the kernel's problem (no motion), for `study_run` to reuse over
    many points with the same model, or None when the kernel cannot run the model."""
    return None if _model_reason(model) else _problem(model, None)


def study_run(model, motion, times: np.ndarray, state, estimate: bool, stop_mu: float | None,
              template: _Problem | None = None, limit: float | None = None) -> StudyRun:
    """`simulate`'s kernel loop over ``times`` for one point of a design study, in one kernel
    call (bm_simulate_study): the same samples as `simulate` (outputs included), and
    ``estimate`` (a fixed-step method): the run's global error estimated from its own states
    and derivatives (the local errors' effect on the contact point and on N, accumulated;
    bm_lerr in _kernel.c), and with ``limit`` [m] the run ends at the first sample where the
    contact point's estimate exceeds it (a run to be redone with a smaller step); ``stop_mu``:
    end at the first sample where N > 0 and friction_ratio <= stop_mu stop holding (None: run
    to the end). Call only when
    `applicable` says ''. No Python fallback: a run the kernel cannot finish comes back with
    ``failed`` set, for the caller to redo with `simulate`. ``template``:
    `study_problem(model)`, made once for many runs (the motion is filled in here)."""
    if template is None:
        P = _problem(model, motion)
    else:  # `study_problem(model)` with the motion's part filled in, as _problem fills it
        P = _Problem.from_buffer_copy(template)
        kind, mp = _motion_params(motion)
        P.motion = kind
        for i, v in enumerate(mp):
            P.mp[i] = v
    r = StudyRun()
    n = len(times)
    r.times = times = np.ascontiguousarray(times, dtype=float)
    # one block for the samples, the outputs, the state, the step and the estimate: one address
    # to find (in doubles: ys n x NY, outs n x NOUT, y NY, h 1, err 2)
    block = np.empty(n * (NY + NOUT) + NY + 3)
    a_ys, a_outs, a_y = n * NY, n * (NY + NOUT), n * (NY + NOUT) + NY
    r.ys, r.outs = block[:a_ys].reshape(n, NY), block[a_ys:a_outs].reshape(n, NOUT)
    block[a_outs:a_y] = state.y
    block[a_y] = state.h if state.h is not None else math.nan
    block[a_y + 1:] = 0.0
    base = block.ctypes.data
    stats = _Stats()
    last = _kernel().bm_simulate_study(ctypes.byref(P), times.ctypes.data, n, 0, 1, base + 8 * a_outs, base + 8 * a_y,
                                       int(stop_mu is not None), stop_mu if stop_mu is not None else 0.0, base,
                                       base + 8 * a_ys, base + 8 * (a_y + 1) if estimate else None,
                                       limit if estimate and limit is not None else 0.0, ctypes.byref(stats))
    r.last = int(last)
    o = r.outs[r.last]
    r.stopped = stop_mu is not None and r.last >= 0 and not (o[9] > 0.0 and o[18] <= stop_mu)
    r.err_P, r.err_N = (float(block[a_y + 1]), float(block[a_y + 2])) if estimate else (None, None)
    r.exceeded = limit is not None and r.err_P is not None and r.err_P > limit
    r.failed = r.last < n - 1 and not r.stopped and not r.exceeded
    info = model.info
    info.steps += stats.steps
    info.nfev += stats.nfev
    return r


# ----------------------------------------------------------------------------
# one interval: BallModel.advance with a polynomial platform acceleration
MOTION_POLY = 4  # BM_POLY in _kernel.c
_IO = 3 + NY + 9  # t, t_end, h, y, motion parameters (bm_advance_interval's io)


_BallState = None  # model.BallState, set on first use (model.py imports this module)


class _Advance:
    """What `advance` keeps per model: the problem structure and the buffers it
    hands the kernel, valid while ``key`` (the model's integrator settings) holds.
    One model, one buffer: a model is not advanced from two threads at once (an
    FMU instance has its own model; FMI does not call one instance concurrently)."""

    __slots__ = ("key", "why", "scale", "P", "io", "pack", "stats", "call", "args", "adaptive", "h_fixed")


def _advance_key(model, lib):
    """Everything of a model that the kernel's problem depends on (compared by value or
    identity); the Python path reads these afresh at every call, so a change rebuilds."""
    form, integ = model.form, model.integrator
    fd = getattr(form, "__dict__", {})
    return (lib, type(model), type(model).rhs, form, fd.get("_ball"), fd.get("derivative"), integ,
            integ.tab, integ.adaptive, integ.tol, integ.h_fixed, integ.h_max, integ.max_steps,
            id(integ.scale), integ.project, integ.check)


def _advance_setup(model, key, lib) -> _Advance:
    global _BallState
    from .model import BallModel, BallState

    _BallState = BallState
    c = _Advance()
    c.key = key
    c.scale = model.integrator.scale  # held, so that its id in the key cannot be reused
    c.why = _model_reason(model)
    if not c.why and type(model).rhs is not BallModel.rhs:
        c.why = "model with a replaced rhs"
    if not c.why:
        integ = model.integrator
        c.P = _problem(model, None)
        c.io = np.zeros(_IO)
        c.pack = struct.Struct(f"{_IO}d").pack_into
        c.stats = _Stats()
        # a function object of its own without argtypes, called with ready-made C arguments
        # (pointers into objects that c owns): the cheapest ctypes call
        c.call = lib._FuncPtr(("bm_advance_interval", lib))
        c.call.restype = ctypes.c_int
        c.args = (ctypes.byref(c.P), MOTION_POLY, ctypes.c_void_p(c.io.ctypes.data), ctypes.byref(c.stats))
        c.adaptive = bool(integ.adaptive)
        c.h_fixed = integ.h_fixed
    model.__dict__["_fast_advance"] = c
    return c


def advance_reason(model, state, t_end, accel) -> str:
    """'' when `advance` can do this interval in the kernel, else why not."""
    lib = _kernel()
    if lib is None:
        return f"compiled kernel unavailable: {_STATE[2]}"
    poly = getattr(accel, "poly", None)
    if poly is None:
        return ("platform acceleration without polynomial coefficients (the kernel takes "
                "InputReconstruction's cubic closure, accel.poly)")
    key = _advance_key(model, lib)
    c = model.__dict__.get("_fast_advance")
    if c is None or c.key != key:
        c = _advance_setup(model, key, lib)
    if c.why:
        return c.why
    y = state.y
    if type(y) is not np.ndarray or y.shape != (NY,) or y.dtype != np.float64:
        return f"state of shape {np.shape(y)} and type {getattr(y, 'dtype', type(y))}"
    if not (isinstance(state.t, float) and isinstance(t_end, float)):
        return "times that are not floats"
    return ""


def advance(model, state, t_end, accel):
    """`BallModel.advance` in the kernel, for a platform acceleration that is
    InputReconstruction's cubic closure (``accel.poly``): the new BallState with
    the same y and h bit for bit, and the same work added to ``model.info``; or
    None when Python must do the interval: the kernel cannot (`advance_reason`),
    there is nothing to integrate, or a step fails (Python then redoes the interval
    and raises with its own message; the state is a pure input, so nothing is lost)."""
    lib = _kernel()
    poly = getattr(accel, "poly", None)
    if lib is None or poly is None:
        return None
    key = _advance_key(model, lib)
    c = model.__dict__.get("_fast_advance")
    if c is None or c.key != key:
        c = _advance_setup(model, key, lib)
    if c.why:
        return None
    t, y = state.t, state.y
    if (type(y) is not np.ndarray or y.shape != (NY,) or y.dtype != np.float64
            or not (isinstance(t, float) and isinstance(t_end, float))):
        return None
    span = t_end - t
    if not span > 0.0:
        return None  # nothing to integrate (or a NaN time): Python's own early return
    h = state.h
    extra_nfev = 0
    if c.adaptive:
        if h is None or not (h > 0.0 and math.isfinite(h)):
            # the initial step, by the Python integrator (as its advance would)
            f = model.rhs(accel)
            y0 = np.array(y, dtype=float)
            f0 = f(t, y0)
            if not all(map(math.isfinite, f0)):
                return None
            h = model.integrator.initial_step(f, t, y0, np.asarray(f0, dtype=float), span)
            extra_nfev = 1
    else:
        h = math.nan  # RK4 does not read it
    io = c.io
    t0, xs, ys = poly
    c.pack(io, 0, t, t_end, h, *y.tolist(), t0, *xs, *ys)
    if not c.call(*c.args):
        return None
    st = c.stats
    info = model.info
    info.steps += st.steps
    info.rejected += st.rejected
    info.nfev += st.nfev + extra_nfev
    return _BallState(float(t_end), io[3:9].copy(), float(io[2]) if c.adaptive else c.h_fixed)


# ----------------------------------------------------------------------------
# outputs of one state: BallModel.outputs in the kernel
class _Outs:
    """What `outputs` keeps per model: the problem (only its ball part is read) and the
    buffers, valid while the model's ball and formulation are those it was made for."""

    __slots__ = ("ball", "form", "lib", "P", "Pref", "y", "o", "call")


_Outputs = None  # outputs.Outputs, set on first use


def _outputs_setup(model, lib):
    global _Outputs
    from .outputs import Outputs

    _Outputs = Outputs
    c = _Outs()
    c.ball, c.form, c.lib = model.ball, model.form, lib
    c.P = _problem(model, None)
    c.Pref = ctypes.byref(c.P)
    c.y = (ctypes.c_double * NY)()
    c.o = (ctypes.c_double * NOUT)()
    c.call = lib._FuncPtr(("bm_eval_outputs", lib))
    c.call.restype = None
    c.call.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_double, ctypes.c_double,
                       ctypes.c_double, ctypes.c_double, ctypes.c_void_p)
    model.__dict__["_fast_outputs"] = c
    return c


def outputs(model, state, ax, ay, xO, yO):
    """`BallModel.outputs` (outputs.evaluate) in the kernel, the same Outputs bit for bit
    (bm_outputs keeps evaluate's operation order), or None when Python must do it: no
    kernel, a formulation other than the library's 'vector' one (whose y is n, omega), a
    state that is not 6 floats."""
    lib = _kernel()
    if lib is None:
        return None
    c = model.__dict__.get("_fast_outputs")
    if c is None or c.ball is not model.ball or c.form is not model.form or c.lib is not lib:
        if type(model.form) is not VectorFormulation or type(model.form).to_nw is not VectorFormulation.to_nw:
            return None
        c = _outputs_setup(model, lib)
    y = state.y
    if type(y) is not np.ndarray or y.shape != (NY,) or y.dtype != np.float64:
        return None
    c.y[:] = y.tolist()
    c.call(c.Pref, c.y, ax, ay, xO, yO, c.o)
    o = c.o[:]
    return _Outputs(*o[:19], o[19] != 0.0, o[20] != 0.0, *o[21:])


# ----------------------------------------------------------------------------
# single evaluations (tests)
def eval_rhs(P: _Problem, t: float, y) -> tuple:
    yy = np.ascontiguousarray(y, dtype=float)
    f = np.empty(NY)
    _kernel().bm_eval_rhs(ctypes.byref(P), t, yy.ctypes.data_as(_dp), f.ctypes.data_as(_dp))
    return tuple(f.tolist())


def eval_initial_step(P: _Problem, t: float, y, span: float) -> float:
    """bm_initial_step: the C twin of Integrator.initial_step that the benchmark's standalone
    program (ballmill/bench/compiled.py) starts its adaptive runs with."""
    yy = np.ascontiguousarray(y, dtype=float)
    return _kernel().bm_initial_step(ctypes.byref(P), t, yy.ctypes.data_as(_dp), span)


def eval_motion(P: _Problem, t: float) -> tuple:
    o = np.empty(6)
    _kernel().bm_eval_motion(ctypes.byref(P), t, o.ctypes.data_as(_dp))
    return tuple(o.tolist())


def eval_outputs(P: _Problem, y, ax, ay, xO=0.0, yO=0.0) -> tuple:
    yy = np.ascontiguousarray(y, dtype=float)
    o = np.empty(NOUT)
    _kernel().bm_eval_outputs(ctypes.byref(P), yy.ctypes.data_as(_dp), ax, ay, xO, yO, o.ctypes.data_as(_dp))
    return tuple(o.tolist())


# ----------------------------------------------------------------------------
# the hybrid ball (hybrid.HybridBall on events.integrate) in the kernel: bmh_simulate
_HPROBLEM = None


def _hproblem_type():
    """ctypes mirror of bmh_problem in _kernel.c (built on first use: it holds turning.kernel's
    _GProblem, and turning.kernel imports this module)."""
    global _HPROBLEM
    if _HPROBLEM is None:
        from .turning.kernel import _GProblem

        class _HProblem(ctypes.Structure):
            _fields_ = [("roll", _Problem), ("turning", ctypes.c_int), ("gen", _GProblem), ("free", _Problem)] + [
                (name, ctypes.c_double) for name in ("R", "r", "d", "m", "g", "Ib", "lam", "mu", "mu_k", "e_n",
                                                     "v_rest", "slip_eps", "kt", "gap_res",
                                                     "creep_eps")] + [
                ("energy", ctypes.c_int), ("scan", ctypes.c_int), ("burst", ctypes.c_int),
                ("xtol", ctypes.c_double), ("max_rate", ctypes.c_double), ("zeno_hold", ctypes.c_int)]
        _HPROBLEM = _HProblem
    return _HPROBLEM


HYBRID_NCOL = 26  # HybridBall.COLUMNS
HYBRID_NEV = 18  # doubles of an event record: t, kind, modes before/after, width, n, details
HYBRID_KINDS = ("slip", "leave", "stick", "impact")  # BMH_SLIP.. BMH_IMPACT
# the details of an event record's fields 8.. (NaN: the map did not set it); flags as bools
_DETAILS = (("v_n", 8, 1, float), ("slip", 9, 1, float), ("stick", 10, 1, bool), ("E_loss", 11, 1, float),
            ("rest", 12, 1, bool), ("slip_removed", 13, 1, float), ("seed", 14, 3, tuple),
            ("grazing", 17, 1, bool))


def _hybrid_lib():
    HP = _hproblem_type()
    lib, why = model_library("bmh_problem", HP, "hybrid functions", {
        "bmh_simulate": (ctypes.c_longlong, [ctypes.POINTER(HP), _dp, ctypes.c_longlong,
                                             ctypes.POINTER(ctypes.c_int), _dp, _dp, _dp, _dp, _dp,
                                             ctypes.c_longlong, ctypes.POINTER(ctypes.c_longlong),
                                             ctypes.POINTER(ctypes.c_int), ctypes.POINTER(_Stats)]),
        "bmh_interval": (ctypes.c_int, [ctypes.POINTER(HP), ctypes.c_double, ctypes.c_double,
                                        ctypes.POINTER(ctypes.c_int), _dp, _dp, _dp, _dp, ctypes.c_longlong,
                                        ctypes.POINTER(ctypes.c_longlong), _dp, ctypes.POINTER(_Stats)]),
    })
    return lib, why


def hybrid_reason(system) -> str:
    """'' when `hybrid_run` can run this `hybrid.HybridBall` in the kernel, else why not."""
    lib, why = _hybrid_lib()
    if lib is None:
        return why
    if system.turning:
        from .turning import kernel as tk

        why = tk.applicable(system.rolling, system.motion)
    else:
        why = applicable(system.rolling, system.motion)
    if why:
        return why
    for integ in (system.integrator(0), system.integrator(1)):
        if type(integ) is not Integrator or integ.method not in TABLEAUS or integ.scale is None:
            return "integrator is not the library's Integrator with a scale"
    return ""


def _hybrid_problem(system, scan: int, xtol: float, burst: int, max_rate: float, on_zeno: str = "stop"):
    b = system.ball
    H = _hproblem_type()()
    if system.turning:
        from .turning import kernel as tk

        H.turning = 1
        H.gen = tk.problem(system.rolling, system.motion)
        H.roll = _problem(tk._IntegratorOnly(system.rolling), None)
    else:
        H.roll = _problem(system.rolling, system.motion)
    roll = system.integrator(1)  # rolling's integrator (with the quadratures when energy)
    H.roll.ny = roll.scale.size
    fill_integrator(H.roll, roll)
    free = system.integrator(0)
    H.free.form, H.free.ny = 2, free.scale.size  # BM_GENERIC: no projection
    fill_integrator(H.free, free)
    H.R, H.r, H.d, H.m, H.g, H.Ib, H.lam = b.R, b.r, b.d, b.m, b.g, b.I, b.lam
    H.mu, H.mu_k, H.e_n, H.v_rest, H.slip_eps = system.mu, system.mu_k, system.e_n, system.v_rest, system.slip_eps
    H.kt, H.gap_res, H.energy = system.kt, system._gap_res, int(system.energy)
    H.creep_eps = system.creep_eps
    H.scan, H.xtol, H.burst, H.max_rate = scan, xtol, burst, max_rate
    from .events import holds_on_zeno

    H.zeno_hold = int(holds_on_zeno(on_zeno))
    return H


def hybrid_run(system, mode: int, t: float, y, times, *, burst: int = 100, max_rate: float = 1e4,
               scan: int = 3, xtol: float = 1e-11, on_zeno: str = "stop"):
    """`events.integrate(system, mode, t, y, times, ...)` for a `hybrid.HybridBall` (checked
    with `hybrid_reason`) in the kernel: the same rows, events, bookkeeping (written back to
    the system) and work, bit for bit. Returns the `events.EventRun`, or None when a step
    fails (the caller runs the Python driver, which reports the failure as it does)."""
    from .events import Event, EventRun, zeno

    lib, _ = _hybrid_lib()
    H = _hybrid_problem(system, scan, xtol, burst, max_rate, on_zeno)
    times = np.ascontiguousarray(times, dtype=float)
    n = len(times)
    if not (n and times[0] == t):
        raise ValueError(f"hybrid_run samples from the start time: times[0] = {times[0] if n else None!r} "
                         f"s, expected t = {t!r} s")
    yy = np.zeros(NYMAX)
    y = np.asarray(y, dtype=float)
    yy[:y.size] = y
    stats = _Stats()
    h = math.nan
    integ, f = system.integrator(mode), system.rhs(mode)
    if integ.adaptive and n > 1:  # the first step: Python's initial step, as Integrator.steps takes it
        f0 = f(t, y)
        f0 = tuple(np.broadcast_to(np.asarray(f0, dtype=float), y.shape).tolist())
        if all(map(math.isfinite, f0)):
            h = integ.initial_step(f, t, y, np.asarray(f0, dtype=float), float(times[1]) - t)
            stats.nfev += 1
    book0 = system.bookkeeping()
    was_held = system.held
    cap = 4096
    while True:
        book = np.array(book0, dtype=float)
        rows = np.empty((n, HYBRID_NCOL))
        events = np.empty((cap, HYBRID_NEV))
        hbuf = np.array([h])
        c_mode, n_ev, status = ctypes.c_int(mode), ctypes.c_longlong(0), ctypes.c_int(0)
        st = _Stats(stats.steps, stats.rejected, stats.nfev)
        reached = lib.bmh_simulate(ctypes.byref(H), times.ctypes.data_as(_dp), n, ctypes.byref(c_mode),
                                   yy.ctypes.data_as(_dp), hbuf.ctypes.data_as(_dp), book.ctypes.data_as(_dp),
                                   rows.ctypes.data_as(_dp), events.ctypes.data_as(_dp), cap,
                                   ctypes.byref(n_ev), ctypes.byref(status), ctypes.byref(st))
        if status.value != 3:
            break
        cap *= 8
    if status.value == 1:
        return None
    system._set_book(book.tolist())
    evs = []
    for rec in events[:n_ev.value]:
        details = {}
        for name, i, k, tp in _DETAILS:
            if not math.isnan(rec[i]):
                details[name] = tuple(rec[i:i + k].tolist()) if k > 1 else tp(rec[i])
        details["n"] = tuple(rec[5:8].tolist())
        evs.append(Event(float(rec[0]), HYBRID_KINDS[int(rec[1])], int(rec[2]), int(rec[3]), float(rec[4]),
                         details))
    out_rows = [(int(r[0]), *r[1:21].tolist(), int(r[21]), *r[22:].tolist()) for r in rows[:reached]]
    run_stats = StepStats(st.steps, st.rejected, st.nfev)
    success, message, error = True, "completed", None
    if status.value == 2:
        error = zeno(evs, burst, max_rate)
        success, message = False, f"stopped at t = {evs[-1].t:.9g} s: {error}"
    held = zeno(evs, burst, max_rate) if system.held and not was_held else None  # no event after the hold
    ny = system.integrator(c_mode.value).scale.size
    return EventRun(times[:reached], out_rows, evs, success, message, run_stats, c_mode.value,
                    yy[:ny].copy(), float(hbuf[0]), float(times[reached - 1]), error, held)


class HybridInterval:
    """The kernel's one interval of the hybrid ball (bmh_interval: the native BallInShell FMU's
    step with contact = 2) for a `hybrid.HybridBall` (checked with `hybrid_reason`): ``run(mode,
    t, t_end, y, h)`` integrates t -> t_end as `events.integrate` over the grid (t, t_end) does
    (h None: the mode's initial step), the bookkeeping read from and written back to the system,
    the events' ring (the last ``burst``, for the Zeno guard) carried from one call to the next.
    Returns (status, mode, y, h, row): status 0 done (row: `HybridBall.sample` at t_end), 1 a
    step failed, 2 a Zeno sequence (mode, y, h, the system and the ring then unchanged; with
    on_zeno = "hold" the ball is held there instead, `hybrid.HybridBall.hold`, and the run goes on)."""

    def __init__(self, system, *, burst: int = 100, max_rate: float = 1e4, scan: int = 3, xtol: float = 1e-11,
                 on_zeno: str = "stop"):
        self.lib, why = _hybrid_lib()
        if self.lib is None:
            raise KernelUnavailable(why)
        self.system = system
        self.H = _hybrid_problem(system, scan, xtol, burst, max_rate, on_zeno)
        self.cap = max(burst, 1)
        self.events = np.zeros((self.cap, HYBRID_NEV))
        self.n_events = 0
        self.stats = _Stats()

    def run(self, mode: int, t: float, t_end: float, y, h=None):
        yy = np.zeros(NYMAX)
        y = np.asarray(y, dtype=float)
        yy[:y.size] = y
        book, events = np.array(self.system.bookkeeping()), self.events.copy()
        hbuf, row = np.array([math.nan if h is None else h]), np.empty(HYBRID_NCOL)
        c_mode, n_ev = ctypes.c_int(mode), ctypes.c_longlong(self.n_events)
        status = self.lib.bmh_interval(ctypes.byref(self.H), t, t_end, ctypes.byref(c_mode), yy.ctypes.data_as(_dp),
                                       hbuf.ctypes.data_as(_dp), book.ctypes.data_as(_dp),
                                       events.ctypes.data_as(_dp), self.cap, ctypes.byref(n_ev),
                                       row.ctypes.data_as(_dp), ctypes.byref(self.stats))
        if status:
            return status, mode, y, h, None
        self.system._set_book(book.tolist())
        self.events, self.n_events = events, n_ev.value
        ny = self.system.integrator(c_mode.value).scale.size
        return 0, c_mode.value, yy[:ny].copy(), float(hbuf[0]), tuple(row.tolist())
