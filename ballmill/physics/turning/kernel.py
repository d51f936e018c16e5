"""The general (turning-chamber) model in the compiled kernel: what it owns.

The bmg_* functions of _kernel.c mirror model.py (right-hand side, outputs)
and motions.py (Spin, Fig1Machine with CrankStartup / ConstantSpeed laws) in
the Python code's operation order, and run the library's integrators with the
same step-size control; `simulate` here is model.simulate_general's loop in C
and gives the Python path's trajectory bit for bit (tests/test_turning_kernel.py).
The library is the one ballmill.physics.fast loads and checks (same build, same source hash);
this module only declares the general functions on it. As in ballmill.physics.fast, the
adaptive methods' initial step is Python's, and an interval the kernel cannot
complete is handed back to Python, which raises with its own message.
"""
from __future__ import annotations

import ctypes
import math
import numbers

import numpy as np

from .. import fast
from ..drives.crank import CrankStartup
from ..fast import KernelUnavailable, _Stats, _dp
from ..integrators import Integrator, TABLEAUS
from .motions import NSTATE, ConstantSpeed, Fig1Machine, Spin

__all__ = ["KernelUnavailable", "applicable", "simulate", "problem", "advance", "eval_rhs", "eval_state",
           "eval_outputs"]

NY = 6
NOUT = 28  # model.ChamberOutputs


class _GProblem(ctypes.Structure):
    """ctypes mirror of bmg_problem in _kernel.c."""

    _fields_ = [
        ("base", fast._Problem),
        ("kind", ctypes.c_int), ("sp", ctypes.c_double * 10),
        ("frame_law", ctypes.c_int), ("crank_law", ctypes.c_int), ("parallel", ctypes.c_int),
        ("frame_p", ctypes.c_double * 2), ("crank_p", ctypes.c_double * 2),
        ("l", ctypes.c_double), ("centre", ctypes.c_double * 3),
        ("c", ctypes.c_double * 6), ("oc", ctypes.c_double * 10),
        # BMG_POLY (the native BallInShell FMU's reconstructed chamber; not set from Python)
        ("poly", ctypes.c_double * 34), ("t0", ctypes.c_double), ("pos", ctypes.c_double * 18),
        ("om", ctypes.c_double * 12), ("Q", ctypes.c_double * 9),
    ]


_LIB = None  # (library, reason) once declared


def _lib():
    """The kernel library with the bmg_* functions declared, or None."""
    global _LIB
    if _LIB is None:
        G = ctypes.POINTER(_GProblem)
        _LIB = fast.model_library("bmg_problem", _GProblem, "general-model functions", {
            "bmg_simulate": (ctypes.c_longlong, [G, _dp, ctypes.c_longlong, ctypes.c_longlong, ctypes.c_int,
                                                 _dp, _dp, _dp, _dp, ctypes.POINTER(_Stats)]),
            "bmg_eval_rhs": (None, [G, ctypes.c_double, _dp, _dp]),
            "bmg_eval_state": (None, [G, ctypes.c_double, _dp]),
            "bmg_advance_poly": (ctypes.c_int, [G, _dp, ctypes.POINTER(_Stats)]),
            "bmg_eval_outputs": (None, [G, _dp, _dp, _dp]),
        })
    return _LIB[0]


def _real(*v):
    return all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x) for x in v)


def _law(law):
    """(kind, params) of an angle law the kernel knows, or (None, reason)."""
    if type(law) is CrankStartup and law.law == "quadratic" and _real(law.n0, law.t0):
        return 1, (float(law.w0), float(law.t0))
    if type(law) is ConstantSpeed and _real(law.w, law.angle0):
        return 0, (float(law.w), float(law.angle0))
    return None, f"angle law {law!r} (the kernel knows CrankStartup's quadratic law and ConstantSpeed)"


def _motion_reason(motion) -> str:
    tp = type(motion)
    if tp is Spin:
        return ""
    if tp is Fig1Machine:
        if motion.shaft != "x":
            return f"Fig1Machine with shaft {motion.shaft!r} (the kernel knows the horizontal x1 shaft)"
        for law in (motion.frame, motion.crank):
            kind, why = _law(law)
            if kind is None:
                return why
        return ""
    return f"chamber motion {tp.__name__} (the kernel knows Spin and Fig1Machine)"


def applicable(model, motion, state=None) -> str:
    """'' when `simulate` can run this model and motion in the kernel, else why not."""
    from .model import ChamberModel, _project

    if _lib() is None:
        return _LIB[1]
    if type(model) is not ChamberModel:
        return f"model class {type(model).__name__}"
    integ = model.integrator
    if type(integ) is not Integrator or integ.method not in TABLEAUS or integ.project is not _project:
        return "integrator is not the library's Integrator with ChamberModel's projection"
    if integ.scale is None or integ.scale.shape != (NY,):
        return "integrator without a 6-component scale"
    why = _motion_reason(motion)
    if why:
        return why
    if state is not None and np.shape(state.y) != (NY,):
        return f"state of shape {np.shape(state.y)}"
    return ""


def problem(model, motion) -> _GProblem:
    """The kernel's problem structure for a model and motion (checked with `applicable`)."""
    why = applicable(model, motion)
    if why:
        raise KernelUnavailable(why)
    G = _GProblem()
    # the integrator part, filled as fast.py fills it (its motion and ball fields are unused)
    base = fast._problem(_IntegratorOnly(model), None)
    ctypes.memmove(ctypes.byref(G.base), ctypes.byref(base), ctypes.sizeof(base))
    if type(motion) is Spin:
        G.kind = 1
        G.sp[:] = list(motion.Omega) + list(motion.A) + list(motion.axis) + [motion.rate]
    else:
        G.kind = 2
        G.frame_law, fp = _law(motion.frame)
        G.crank_law, cp = _law(motion.crank)
        G.frame_p[:], G.crank_p[:] = list(fp), list(cp)
        G.parallel = int(motion.parallel)
        G.l = motion.l
        G.centre[:] = list(motion.centre)
    G.c[:] = [float(v) for v in model._c]
    G.oc[:] = [float(v) for v in model._oc]
    return G


class _IntegratorOnly:
    """What fast._problem reads of a model, for the integrator part: the integrator, and a
    ball and formulation whose values the general functions do not read."""

    def __init__(self, model):
        from ..equations import VectorFormulation

        self.integrator = model.integrator
        self.ball = model.ball
        self.form = VectorFormulation(model.ball)


def simulate(model, motion, times: np.ndarray, state, outputs: bool):
    """model.simulate_general's loop in the kernel; returns (ys, outs or None, success,
    message, last). Call only when `applicable` says ''."""
    from .model import record_python

    return fast.run_grid(_lib().bmg_simulate, problem(model, motion), NOUT, model, model.rhs(motion),
                         lambda *a: record_python(model, motion, *a), times, state, outputs)


# one interval along a reconstructed motion (the BallInShell FMU with motion = 2)
NPOLY = 34  # reconstruction.NPOLY, BMG_NPOLY


class _Poly:
    """What `advance` keeps per model: the problem and the buffers, valid while ``key``
    (the model's integrator and constants) holds."""

    __slots__ = ("key", "why", "G", "io", "stats")


def _poly_key(model):
    integ = model.integrator
    return (type(model), integ, integ.tab, integ.adaptive, integ.tol, integ.h_fixed, integ.h_max,
            integ.max_steps, id(integ.scale), integ.project, model._c)


def advance(model, state, t_end, kin):
    """ChamberModel.advance in the kernel for a motion whose accel is ChamberReconstruction's
    kin closure (``kin.poly``): the new BallState, y and h the Python path's bit for bit, the
    work added to ``model.info``; or None when Python must do the interval (no kernel, nothing
    to integrate, or a step fails: Python redoes it and raises with its own message)."""
    from .model import BallState, ChamberModel, _project

    poly = getattr(kin, "poly", None)
    lib = _lib()
    if lib is None or poly is None or len(poly) != NPOLY or type(model) is not ChamberModel:
        return None
    key = _poly_key(model)
    c = model.__dict__.get("_fast_poly")
    if c is None or c.key != key:
        c = _Poly()
        c.key = key
        integ = model.integrator
        c.why = ("" if type(integ) is Integrator and integ.method in TABLEAUS and integ.project is _project
                 and integ.scale is not None and integ.scale.shape == (NY,) else "integrator")
        if not c.why:
            c.G = _GProblem()
            base = fast._problem(_IntegratorOnly(model), None)
            ctypes.memmove(ctypes.byref(c.G.base), ctypes.byref(base), ctypes.sizeof(base))
            c.G.c[:] = [float(v) for v in model._c]
            c.G.oc[:] = [float(v) for v in model._oc]
            c.io = np.zeros(3 + NY + NPOLY)
            c.stats = _Stats()
        model.__dict__["_fast_poly"] = c
    if c.why:
        return None
    t, y = state.t, state.y
    if type(y) is not np.ndarray or y.shape != (NY,) or not (isinstance(t, float) and isinstance(t_end, float)):
        return None
    span = t_end - t
    if not span > 0.0:
        return None
    integ = model.integrator
    h = state.h
    extra_nfev = 0
    if integ.adaptive:
        if h is None or not (h > 0.0 and math.isfinite(h)):
            f = model.rhs(_Accel(kin))
            y0 = np.array(y, dtype=float)
            f0 = f(t, y0)
            if not all(map(math.isfinite, f0)):
                return None
            h = integ.initial_step(f, t, y0, np.asarray(f0, dtype=float), span)
            extra_nfev = 1
    else:
        h = math.nan
    io = c.io
    io[0], io[1], io[2] = t, t_end, h
    io[3:3 + NY] = y
    io[3 + NY:] = poly
    if not lib.bmg_advance_poly(ctypes.byref(c.G), io.ctypes.data_as(_dp), ctypes.byref(c.stats)):
        return None
    st = c.stats
    model.info.steps += st.steps
    model.info.rejected += st.rejected
    model.info.nfev += st.nfev + extra_nfev
    return BallState(float(t_end), io[3:3 + NY].copy(), float(io[2]) if integ.adaptive else integ.h_fixed)


class _Accel:
    __slots__ = ("accel",)

    def __init__(self, kin):
        self.accel = kin


# single evaluations (tests, benchmark)
def eval_rhs(G: _GProblem, t: float, y) -> tuple:
    yy = np.ascontiguousarray(y, dtype=float)
    f = np.empty(NY)
    _lib().bmg_eval_rhs(ctypes.byref(G), t, yy.ctypes.data_as(_dp), f.ctypes.data_as(_dp))
    return tuple(f.tolist())


def eval_state(G: _GProblem, t: float) -> tuple:
    o = np.empty(NSTATE)
    _lib().bmg_eval_state(ctypes.byref(G), t, o.ctypes.data_as(_dp))
    return tuple(o.tolist())


def eval_outputs(G: _GProblem, y, cs) -> tuple:
    yy = np.ascontiguousarray(y, dtype=float)
    cc = np.ascontiguousarray(cs, dtype=float)
    o = np.empty(NOUT)
    _lib().bmg_eval_outputs(ctypes.byref(G), yy.ctypes.data_as(_dp), cc.ctypes.data_as(_dp),
                            o.ctypes.data_as(_dp))
    return tuple(o.tolist())
