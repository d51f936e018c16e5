"""The coupled structure + ball model in the compiled kernel: what it owns.

The bma_* functions of ballmill/physics/_kernel.c mirror `StructureBall.rhs`
(model.py: the cavity's acceleration solved with the ball's load, on the
consistent rolling-resistance branch; the ball's vector equations with drag and
rolling resistance; the modal structure; the work quadratures) for a harmonic
force or ground acceleration (structure.HarmonicForce / HarmonicGround, sweep
rate included), in the Python code's operation order, and run the library's
integrators with the same step-size control. `simulate_grid` is
`simulate_absorber`'s loop over its output grid in C. The Python path stays the
reference: `simulate_absorber(kernel="python")`; tests/test_absorber_kernel.py
checks the right-hand side against it to round-off and whole runs to the
integration tolerance.

As in ballmill.physics.fast: the library is the one fast.py loads and checks
(same build, same source hash); the adaptive methods' initial step is Python's;
an interval the kernel cannot complete is handed back to Python, which redoes
it (and raises with its own message where it fails). Ground records (their
breakpoints), more than MODES modes per axis and states longer than the Python
integrator's SMALL_SYSTEM (16: its numpy path sums in another order) run in Python.
"""
from __future__ import annotations

import ctypes

import numpy as np

from ballmill.physics import fast
from ballmill.physics.equations import ROLLING_EPS, loss_constants
from ballmill.physics.fast import _Stats, _dp
from ballmill.physics.integrators import SMALL_SYSTEM, TABLEAUS, Integrator

from .structure import HarmonicForce, HarmonicGround

MODES = 4  # BMA_MODES
NY = 4 * MODES + 9  # BMA_NY (= BM_NYMAX, fast.NYMAX)
FORM = 3  # BM_ABSORBER: the integrator projects the ball's n (StructureBall.project)


class _AProblem(ctypes.Structure):
    """ctypes mirror of bma_problem in _kernel.c."""

    _fields_ = [
        ("base", fast._Problem), ("nm", ctypes.c_int * 2),
        ("mode", ctypes.c_double * (2 * MODES * 6)), ("G", ctypes.c_double * 2),
        ("ground", ctypes.c_int), ("exc", ctypes.c_double * 7), ("c", ctypes.c_double * 7),
        ("lossy", ctypes.c_int), ("delta", ctypes.c_double), ("J", ctypes.c_double),
        ("drag", ctypes.c_double), ("eps2", ctypes.c_double),
        ("loss_nr", ctypes.c_double * 9), ("loss", ctypes.c_double * 9),
    ]


_LIB = None  # (library or None, reason)


def _lib():
    """The kernel library with the bma_* functions declared, or None."""
    global _LIB
    if _LIB is None:
        A = ctypes.POINTER(_AProblem)
        _LIB = fast.model_library("bma_problem", _AProblem, "absorber functions", {
            "bma_simulate": (ctypes.c_longlong, [A, _dp, ctypes.c_longlong, _dp, _dp, _dp, ctypes.POINTER(_Stats)]),
            "bma_eval_rhs": (None, [A, ctypes.c_double, _dp, _dp]),
            "bma_eval_project": (ctypes.c_int, [A, _dp]),
        })
    return _LIB[0]


def applicable(system, integ) -> str:
    """'' when `simulate_grid` can run this system with this integrator, else why not."""
    from .model import StructureBall

    if _lib() is None:
        return _LIB[1]
    if type(system) is not StructureBall:
        return f"system class {type(system).__name__}"
    exc = system.excitation
    if type(exc) not in (HarmonicForce, HarmonicGround):
        return f"excitation {type(exc).__name__} (the kernel knows HarmonicForce and HarmonicGround)"
    for ax in system.structure.axes:
        if ax is not None and ax.n > MODES:
            return f"{ax.n} modes on an axis (the kernel takes at most {MODES})"
    if system.n_states > SMALL_SYSTEM:
        return (f"{system.n_states} states (the Python integrator sums larger systems with numpy, in "
                f"another order: the kernel covers up to {SMALL_SYSTEM}, e.g. 2 modes in x and 1 in y)")
    if type(integ) is not Integrator or integ.method not in TABLEAUS:
        return "integrator is not the library's Integrator"
    if getattr(integ.project, "__func__", None) is not type(system).project or integ.project.__self__ is not system:
        return "integrator without the system's projection"
    if integ.scale is None or integ.scale.shape != (system.n_states,):
        return f"integrator without a {system.n_states}-component scale"
    return ""


def problem(system, integ) -> _AProblem:
    """The kernel's problem structure (check `applicable` first)."""
    A = _AProblem()
    P = A.base
    P.form, P.ny = FORM, system.n_states
    fast.fill_integrator(P, integ)
    for a, (cs, off, nm) in enumerate(system.struct._axes):
        A.nm[a] = nm
        for j, c in enumerate(cs):  # (M, K, C, phi, psi, L)
            for i, v in enumerate(c):
                A.mode[(a * MODES + j) * 6 + i] = float(v)
    A.G[:] = [float(v) for v in system.struct.flexibility]
    exc = system.excitation
    A.ground = int(type(exc) is HarmonicGround)
    A.exc[:] = [float(exc.amplitude_x), float(exc.frequency), float(exc.amplitude_y), float(exc.phase),
                float(exc.phase_y), float(exc.sweep_rate), float(exc.t0)]
    A.c[:] = [float(v) for v in system._c]
    b = system.ball
    A.lossy = int(system.lossy)
    A.delta, A.J, A.drag, A.eps2 = float(system.delta), float(system.J), float(b.drag), ROLLING_EPS ** 2
    A.loss_nr[:] = [float(v) for v in system._loss_nr]
    A.loss[:] = [float(v) for v in loss_constants(b)]
    return A


def eval_rhs(A: _AProblem, t: float, z) -> tuple:
    """The compiled right-hand side at one point (tests)."""
    zz = np.ascontiguousarray(z, dtype=float)
    f = np.empty(A.base.ny)
    _lib().bma_eval_rhs(ctypes.byref(A), t, zz.ctypes.data_as(_dp), f.ctypes.data_as(_dp))
    return tuple(f.tolist())


def eval_project(A: _AProblem, z) -> list:
    """The compiled projection of n onto the unit sphere (tests)."""
    zz = np.array(z, dtype=float)
    _lib().bma_eval_project(ctypes.byref(A), zz.ctypes.data_as(_dp))
    return zz.tolist()


def simulate_grid(A: _AProblem, times: np.ndarray, zs: np.ndarray, start: int, h: float):
    """From the state zs[start] (at times[start]) with step h over times[start+1:]: fills
    zs[start+1 .. last]; returns (last, h there, steps, nfev). last < len(times) - 1: the
    kernel could not complete interval last -> last + 1 (Python redoes it)."""
    n = len(times) - start
    t = np.ascontiguousarray(times[start:], dtype=float)
    y = np.ascontiguousarray(zs[start], dtype=float).copy()
    out = np.zeros((n, A.base.ny))
    hh = ctypes.c_double(h)
    st = _Stats(0, 0, 0)
    last = _lib().bma_simulate(ctypes.byref(A), t.ctypes.data_as(_dp), n, y.ctypes.data_as(_dp),
                               ctypes.byref(hh), out.ctypes.data_as(_dp), ctypes.byref(st))
    if last > 0:
        zs[start + 1:start + last + 1] = out[1:last + 1]
    return start + int(last), float(hh.value), int(st.steps), int(st.nfev)

