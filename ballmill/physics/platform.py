"""Reconstructing the platform's motion between communication points.

A co-simulation FMU receives its inputs only at communication points t_k,
but the ball needs the platform acceleration a_O(t) for t in [t_k, t_k + H].
`InputReconstruction` keeps the last few samples and fits one polynomial per
axis through them, which it then extrapolates over the coming step:

* mode "derivatives": each sample brings x, v and a. Two samples give a
  quintic (Hermite) through (x, v, a) at t_{k-1} and t_k; a(t) is then a
  cubic and its extrapolation error is O(H^4).
* mode "positions": each sample brings x only (a measured motion, a tool
  without derivative outputs). Six samples give a quintic in x, a(t) again
  a cubic, O(H^4) on smooth motion; a jump in acceleration (the start of the
  paper's crank law at t = 0) is smeared over the window and costs O(H) there.
* mode "hold": a(t) = a_k over the step (zero-order hold): first order, the
  baseline of docs/design.md section 6; kept for measurements.
* mode "accelerations": each sample brings a measured a (x only for the
  outputs' moment arm): a(t) is the line through the last two samples
  (extrapolated over the coming step, interpolated by the corrector), so
  measurement noise on a enters the ball's dynamics once, never amplified
  by a derivative (docs/coupling.md has the noise-to-error map).

The step-size policy of the fit (docs/conformance.md, "reconstruction"):

* node choice: the fit uses the newest sample and, walking back, each older
  sample at least h/2 before the node chosen last (h: the coming step), up
  to ``points`` nodes, so a fit is never extrapolated over more than twice
  its last spacing; with no such older sample the fit is the newest sample's
  Taylor polynomial (x, v, a; a held) in modes "derivatives"/"accelerations";
* resolution: positions enter the fit relative to the newest sample
  (invariance to a constant offset); in mode "derivatives" the position rows
  of the older nodes are left out when the round-off of the positions,
  6 ulp(X) / w^2 (X the largest |x| of the nodes, w the window span), would
  exceed A_RES = 1e-6 m/s2 of acceleration (the fit then takes v and a), and
  the velocity rows too when 4 ulp(V) / w > A_RES; in mode "positions" every
  sample stays, whatever the positions' magnitude: the round-off of positions
  far from the origin, amplified in the fitted acceleration (by up to
  187 ulp(X) / h^2 for the 6-node quintic at node spacing h), is integrated
  twice back into the ball's motion, where it costs little (the contact point
  moves by 2e-9 m for a 1e6 m offset at 2 ms), and the fit's changes from step
  to step enter coupling_error's drift; spreading the nodes to keep that
  acceleration error below A_RES would widen the window to about a second at
  1e6 m, and its truncation error, which no estimate sees, is then 1e8 times
  larger (docs/coupling.md);
* consistency (mode "derivatives"): each new sample k is checked against the
  previous one with the Euler-Maclaurin residual
  r = x_k - x_{k-1} - H (v_{k-1} + v_k)/2 + H^2 (a_k - a_{k-1})/12 per axis
  (H = t_k - t_{k-1}); |r| > (a_tol + 0.01 |a|) H^2 / 6 + 8 ulp(X)
  is an inconsistency (|a|: the largest magnitude of (ax, ay) of the two samples;
  6 r / H^2 is the acceleration error the quintic would take from it):
  `push` returns its description; when 6 |r| / H^2 > a_tol + |a| (a jump: the
  error would exceed the acceleration itself) the history also restarts at
  sample k, so the jump never enters a fit.

Until enough samples exist the fit uses what it has (lower degree).

The fit is reproducible in C (the native BallInShell FMU, fmu_src/ballinshell.c, does
the same): the inverse of the constraint matrix is the exact inverse of the float
matrix built from the sample times rounded to 12 decimals, correctly rounded to floats,
and the coefficients are its rows' dot products with the samples, summed left to right.
"""
from __future__ import annotations

import math
from fractions import Fraction


from .errors import InputError

MODES = ("derivatives", "positions", "hold", "accelerations")

DEFAULT_POINTS = {"derivatives": 2, "positions": 6, "hold": 1, "accelerations": 2}
A_REL = 0.01  # consistency: relative part of the accepted acceleration error
A_RES = 1e-6  # m/s2: acceleration error input round-off may cause before the fit changes its data
ULP = 2.0 ** -52  # relative spacing of doubles
GAIN_POSITIONS = 187.0  # max over the coming step of sum |l_i''| of the 6-node quintic (unit spacing)
HISTORY_EXTRA = 6  # samples kept beyond `points`, for the node choice after short steps


def ulp(x: float) -> float:
    return ULP * max(abs(x), 1e-300)


def worst_residual(a_tol: float, H: float, a_mag: float, axes):
    """The consistency check of two samples H apart (module docstring): ``axes`` gives per
    axis (key, (x_p, x_q, v_p, v_q, a_p, a_q)), a_mag the larger |a| of the two samples.
    None where every axis agrees; else (key, r, limit, jump) of the axis whose residual r
    exceeds its limit by the largest factor, jump: 6 |r| / H^2 > a_tol + |a|."""
    worst = None
    for key, (xp, xq, vp, vq, ap, aq) in axes:
        r = xq - xp - 0.5 * H * (vp + vq) + H * H * (aq - ap) / 12.0
        a_scale = a_tol + A_REL * a_mag
        limit = a_scale * H * H / 6.0 + 8.0 * ulp(max(abs(xp), abs(xq)))
        if abs(r) > limit and (worst is None or abs(r) / limit > worst[0]):
            worst = (abs(r) / limit, key, r, limit)
    if worst is None:
        return None
    _, key, r, limit = worst
    return key, r, limit, 6.0 * abs(r) / (H * H) > a_tol + a_mag


class SampleHistory:
    """The history of input samples (time first, oldest first) and the fit's node choice
    (module docstring), shared by `InputReconstruction` and the turning chamber's
    reconstruction. A subclass sets ``mode``, ``points``, ``samples``, ``h_next`` and
    ``_dirty``, and says what its samples are: ``WHAT`` (for messages), ``NSAMPLE`` (values
    per sample, time included) and `sample_problem` (what is wrong with a stored sample
    besides its length and finiteness)."""

    WHAT = "platform"
    NSAMPLE = 7

    def sample_problem(self, smp) -> str | None:
        return None

    def get_state(self):
        return {"mode": self.mode, "points": self.points, "samples": [list(s) for s in self.samples]}

    def set_state(self, state):
        """Take back `get_state`'s data (ValueError if it does not fit this reconstruction)."""
        if state.get("mode") != self.mode or state.get("points") != self.points:
            raise ValueError(f"input reconstruction state for mode {state.get('mode')!r} with "
                             f"{state.get('points')!r} points, expected {self.mode!r} with {self.points}")
        samples = [tuple(float(v) for v in smp) for smp in state["samples"]]
        if not 1 <= len(samples) <= self.points + HISTORY_EXTRA:
            raise ValueError(f"input history of {len(samples)} samples, expected 1 to "
                             f"{self.points + HISTORY_EXTRA}")
        for smp in samples:
            if len(smp) != self.NSAMPLE or not all(math.isfinite(v) for v in smp):
                raise ValueError(f"input sample {smp!r}: expected {self.NSAMPLE} finite values")
            problem = self.sample_problem(smp)
            if problem:
                raise ValueError(f"input sample at t = {smp[0]!r} s: {problem}")
        if any(b[0] <= a[0] for a, b in zip(samples, samples[1:])):
            raise ValueError("input samples are not in increasing time order")
        self.samples = samples
        self._dirty = True

    def set_horizon(self, h: float):
        """The coming step [s]: the fit's nodes are chosen for it."""
        if h != self.h_next:
            self.h_next = float(h)
            self._dirty = True

    def nodes(self) -> list[tuple]:
        """The samples the fit uses (see the node choice in the module docstring)."""
        s = self.samples
        if not s:
            raise InputError(f"no {self.WHAT} sample has been set yet")
        spacing = 0.5 * self.h_next
        nodes = [s[-1]]
        for smp in reversed(s[:-1]):
            if len(nodes) == self.points:
                break
            if nodes[-1][0] - smp[0] >= spacing:
                nodes.append(smp)
        return nodes[::-1]

    def window(self) -> list[float]:
        """Times of the history samples from the fit's oldest node to the newest."""
        t_first = self.nodes()[0][0]
        return [smp[0] for smp in self.samples if smp[0] >= t_first]


class InputReconstruction(SampleHistory):
    """Polynomial reconstruction of (x, y) of the platform from its samples."""

    def __init__(self, mode: str = "derivatives", points: int | None = None, a_tol: float = 1e-2):
        if mode not in MODES:
            raise ValueError(f"input mode must be one of {MODES}, got {mode!r}")
        self.mode = mode
        self.points = DEFAULT_POINTS[mode] if points is None else int(points)
        if self.points < 1 or self.points > 8:
            raise ValueError(f"points must be between 1 and 8, got {points!r}")
        if not (a_tol > 0 and math.isfinite(a_tol)):
            raise ValueError(f"a_tol must be positive and finite, got {a_tol!r} m/s2")
        self.a_tol = float(a_tol)
        self.samples: list[tuple] = []  # the history (t, x, y, vx, vy, ax, ay), oldest first
        self.h_next = 0.0  # the coming step the fit is made for (node choice)
        self.dropped: tuple | None = None  # (X, w) when the last fit left positions out
        self._t0 = 0.0
        self._hs = 1.0
        self._cx = self._cy = (0.0,)  # polynomial coefficients in tau = (t - t0)/hs
        self._nodes: list[tuple] = []
        self._dirty = True

    # -- samples ---------------------------------------------------------
    def push(self, t, x, y, vx=0.0, vy=0.0, ax=0.0, ay=0.0):
        """Record the inputs seen at communication point t. A second sample at
        the same t replaces the first. Raises InputError (state unchanged) on
        a non-finite value or a time earlier than the last sample. Returns None,
        or (mode "derivatives") the description of an inconsistency of the new
        sample with the previous one; the history then restarts at this sample."""
        sample = (float(t), float(x), float(y), float(vx), float(vy), float(ax), float(ay))
        names = ("t", "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
        for name, v in zip(names, sample):
            if not math.isfinite(v):
                raise InputError(f"input {name} must be finite, got {v!r} at t = {t!r} s")
        if self.samples and sample[0] < self.samples[-1][0]:
            raise InputError(f"inputs must come in time order: got t = {t!r} s after "
                             f"t = {self.samples[-1][0]!r} s")
        self._dirty = True
        if self.samples and sample[0] == self.samples[-1][0]:
            self.samples[-1] = sample
            prev = self.samples[-2] if len(self.samples) > 1 else None
        else:
            prev = self.samples[-1] if self.samples else None
            self.samples.append(sample)
            if len(self.samples) > self.points + HISTORY_EXTRA:
                del self.samples[0]
        if self.mode == "derivatives" and prev is not None and len(self.samples) > 1:
            problem = self.inconsistency(prev, self.samples[-1])
            if problem:
                if self._jump:  # the implied acceleration error exceeds the acceleration itself
                    self.samples[:] = [self.samples[-1]]
                return problem
        return None

    def inconsistency(self, p, q) -> str | None:
        """None if x, v and a of samples p and q agree (see the module docstring), else
        what disagrees, with the values and the threshold."""
        H = q[0] - p[0]
        a_mag = max(math.hypot(p[5], p[6]), math.hypot(q[5], q[6]))
        axes = (("x", (1, 3, 5)), ("y", (2, 4, 6)))
        worst = worst_residual(self.a_tol, H, a_mag,
                               (((axis, i, j, k), (p[i], q[i], p[j], q[j], p[k], q[k])) for axis, (i, j, k) in axes))
        self._jump = False
        if worst is None:
            return None
        (axis, i, j, k), r, limit, self._jump = worst
        restart = "; the reconstruction restarts at the newer sample" if self._jump else ""
        return (f"inputs {axis}1O, v{axis}1O, a{axis}1O disagree between t = {p[0]!r} s "
                f"({axis}1O = {p[i]!r} m, v{axis}1O = {p[j]!r} m/s, a{axis}1O = {p[k]!r} m/s2) and "
                f"t = {q[0]!r} s ({axis}1O = {q[i]!r} m, v{axis}1O = {q[j]!r} m/s, a{axis}1O = {q[k]!r} m/s2): "
                f"position residual {r:.3g} m, accepted |r| <= {limit:.3g} m "
                f"(input_tol = {self.a_tol:g} m/s2 + {A_REL:g} |a| of acceleration){restart}")

    # -- fit -----------------------------------------------------------
    def _fit(self):
        nodes = self._nodes = self.nodes()
        newest = nodes[-1]
        tk = newest[0]
        self._t0 = tk
        self._hs = (tk - nodes[-2][0]) if len(nodes) > 1 else 1.0
        self.dropped = None
        x_ref, y_ref = newest[1], newest[2]
        if self.mode == "hold" or (len(nodes) == 1 and self.mode != "positions"):
            _, x, y, vx, vy, ax, ay = newest
            self._cx, self._cy = (x, vx, 0.5 * ax), (y, vy, 0.5 * ay)
            self._hs = 1.0
        else:
            hs = self._hs
            w = tk - nodes[0][0]
            taus = tuple([(smp[0] - tk) / hs for smp in nodes])
            if self.mode == "positions":
                kind = "x"
            elif self.mode == "accelerations":
                kind = "a"
            else:
                X = max(abs(v) for smp in nodes for v in smp[1:3])
                V = max(abs(v) for smp in nodes for v in smp[3:5])
                if 6.0 * ulp(X) / (w * w) <= A_RES:
                    kind = "xva"
                else:
                    self.dropped = (X, w)
                    kind = "va" if 4.0 * ulp(V) / w <= A_RES else "a"
            inv = self._ROWS.get((kind, taus))
            if inv is None:
                inv = self._inverse_rows(kind, taus)
            bx, by = [], []
            last = len(nodes) - 1
            for i, (_, x, y, vx, vy, ax, ay) in enumerate(nodes):
                if kind in ("x", "xva") or i == last:
                    bx.append(x - x_ref)
                    by.append(y - y_ref)
                if kind == "x":
                    continue
                if kind == "xva" or i == last or kind == "va":
                    bx.append(vx * hs)
                    by.append(vy * hs)
                bx.append(ax * hs * hs)
                by.append(ay * hs * hs)
            cx = [_dot(row, bx) for row in inv]
            cy = [_dot(row, by) for row in inv]
            cx[0] += x_ref
            cy[0] += y_ref
            self._cx, self._cy = tuple(cx), tuple(cy)
        self._dirty = False
        # derivative coefficient tuples for fast evaluation
        self._dx = self._deriv(self._cx)
        self._dy = self._deriv(self._cy)
        self._ddx = self._deriv(self._dx)
        self._ddy = self._deriv(self._dy)
        self._accel_fn = self._compile_accel()

    def _compile_accel(self):
        """a(t) as a closure over the cubic's coefficients in physical time (the
        integrator calls it at every stage, so it avoids loops and attribute look-ups).

        The cubic closure carries its coefficients as ``accel.poly = (t0, (x0, x1, x2,
        x3), (y0, y1, y2, y3))`` (floats, the values it computes with): `BallModel.advance`
        then integrates in the compiled kernel, which evaluates a(t) in the same
        operation order. The Horner fallback (higher degrees) has no ``poly``."""
        hs, t0 = self._hs, self._t0
        ax = [c / hs ** (j + 2) for j, c in enumerate(self._ddx)]
        ay = [c / hs ** (j + 2) for j, c in enumerate(self._ddy)]
        if len(ax) > 4 or len(ay) > 4:
            horner = self._horner
            return lambda t: (horner(ax, t - t0), horner(ay, t - t0))
        x0, x1, x2, x3 = ax + [0.0] * (4 - len(ax))
        y0, y1, y2, y3 = ay + [0.0] * (4 - len(ay))

        def accel(t):
            s = t - t0
            return x0 + s * (x1 + s * (x2 + s * x3)), y0 + s * (y1 + s * (y2 + s * y3))
        accel.poly = (float(t0), (float(x0), float(x1), float(x2), float(x3)),
                      (float(y0), float(y1), float(y2), float(y3)))
        return accel

    _INVERSES: dict = {}  # constraint pattern -> inverse matrix; equal spacing repeats one pattern
    _ROWS: dict = {}  # (derivatives?, exact taus) -> the inverse, as _fit uses it

    @classmethod
    def _inverse_rows(cls, kind, taus):
        """The inverse for a fit of `kind` ("x": positions; "xva": x, v, a at every node;
        "va": v, a at every node and x at the newest; "a": a at every node and x, v at
        the newest) through nodes at taus (the newest at 0, last), rows in `_fit`'s order."""
        rows = []
        last = len(taus) - 1
        for i, tau in enumerate(taus):
            if kind in ("x", "xva") or i == last:
                rows.append((0, tau))
            if kind == "x":
                continue
            if kind in ("xva", "va") or i == last:
                rows.append((1, tau))
            rows.append((2, tau))
        inv = cls._inverse(tuple(rows))
        if len(cls._ROWS) < 1024:
            cls._ROWS[(kind, taus)] = inv
        return inv

    @classmethod
    def _inverse(cls, rows):
        """Inverse of the confluent Vandermonde matrix of the constraints (derivative order,
        tau): row i asks d^der/dtau^der of sum c_j tau^j at tau_i, with tau rounded to 12
        decimals. Exact (in rationals) for the float matrix, then correctly rounded: rows of
        floats. Cached per pattern."""
        key = tuple((der, round(tau, 12)) for der, tau in rows)
        inv = cls._INVERSES.get(key)
        if inv is None:
            n = len(key)
            M = [[Fraction(math.perm(j, der) * tau ** (j - der)) if j >= der else Fraction(0)
                  for j in range(n)] for der, tau in key]
            inv = tuple(tuple(float(x) for x in row) for row in _exact_inverse(M))
            if len(cls._INVERSES) < 256:
                cls._INVERSES[key] = inv
        return inv

    @staticmethod
    def _deriv(c):
        return tuple([j * c[j] for j in range(1, len(c))]) or (0.0,)

    @staticmethod
    def _horner(c, tau):
        acc = 0.0
        for v in reversed(c):
            acc = acc * tau + v
        return acc

    def prepare(self):
        """Fit the polynomials for the coming step (idempotent)."""
        if self._dirty:
            self._fit()

    def accel(self, t):
        """(ax, ay) [m/s2] at time t (beyond the last sample: extrapolation)."""
        if self._dirty:
            self._fit()
        return self._accel_fn(t)

    def accel_function(self):
        """The current fit's a(t) as a plain function, for an integrator's inner loop."""
        self.prepare()
        return self._accel_fn

    def motion(self) -> "ReconstructedPlatform":
        """The current fit as a platform motion (``state(t)``, ``accel(t)``) for the hybrid
        ball (`ReconstructedPlatform`), frozen: a later sample does not change it."""
        return ReconstructedPlatform(self)

    def state(self, t):
        """(x, y, vx, vy, ax, ay) of the reconstructed motion at time t."""
        self.prepare()
        tau = (t - self._t0) / self._hs
        hs = self._hs
        hz = self._horner
        return (hz(self._cx, tau), hz(self._cy, tau), hz(self._dx, tau) / hs, hz(self._dy, tau) / hs,
                hz(self._ddx, tau) / hs**2, hz(self._ddy, tau) / hs**2)


class ReconstructedPlatform:
    """The chamber's platform motion along one fit of `InputReconstruction`, for the hybrid
    ball (`hybrid.HybridBall`), whose sliding and flying ball needs the chamber's position
    A(t) and velocity v_A(t) as well as the acceleration the rolling model integrates.

    The acceleration is the fit's own closure a(t) (``accel``: the same floats the rolling
    model and the compiled kernel use). Position and velocity are that polynomial integrated
    exactly from the fit's own position x0 and velocity v0 at its reference time t0 (the
    newest node), so that v_A' = a and A' = v_A hold to round-off and a sliding ball's
    normal force, gap and impacts see the motion the rolling ball feels. Exact operation
    order (fmu_src/ballinshell.c repeats it operation for operation), per axis, with
    a_0..a_{n-1} the acceleration's coefficients in s = t - t0 (``accel.poly``'s four, or
    the fit's own list when it is longer), s = t - t0:

    * at construction: (x0, y0, vx0, vy0) = `InputReconstruction.state`(t0)[0:4], and
      p_j = a_j / D_j with D_j = (j + 1) (j + 2) as a double (2.0, 6.0, 12.0, 20.0, ...),
      q_j = a_j / (j + 1.0) (a_0 / 1.0, a_1 / 2.0, a_2 / 3.0, a_3 / 4.0, ...);
    * P(s) = p_0 + s * (p_1 + s * (... + s * p_{n-1})) and Q(s) likewise from q (Horner from
      the highest coefficient: acc = c_{n-1}; acc = c_j + s * acc for j = n-2 .. 0);
    * x(t) = x0 + s * (vx0 + s * P(s)), vx(t) = vx0 + s * Q(s); ax(t) = the closure's a(t);
      y likewise.

    ``state(t)`` returns (x, y, vx, vy, ax, ay), ``accel(t)`` (ax, ay), as the library's
    platform motions (drives.crank)."""

    __slots__ = ("t0", "x0", "y0", "vx0", "vy0", "px", "py", "qx", "qy", "accel")

    def __init__(self, rec: InputReconstruction):
        accel = rec.accel_function()
        poly = getattr(accel, "poly", None)
        if poly is not None:
            t0, ax, ay = poly[0], list(poly[1]), list(poly[2])
        else:  # the Horner fallback of _compile_accel: its coefficients, as it computes them
            hs, t0 = rec._hs, rec._t0
            ax = [c / hs ** (j + 2) for j, c in enumerate(rec._ddx)]
            ay = [c / hs ** (j + 2) for j, c in enumerate(rec._ddy)]
        self.t0 = float(t0)
        self.x0, self.y0, self.vx0, self.vy0 = rec.state(self.t0)[0:4]
        self.px = tuple(a / float((j + 1) * (j + 2)) for j, a in enumerate(ax))
        self.py = tuple(a / float((j + 1) * (j + 2)) for j, a in enumerate(ay))
        self.qx = tuple(a / (j + 1.0) for j, a in enumerate(ax))
        self.qy = tuple(a / (j + 1.0) for j, a in enumerate(ay))
        self.accel = accel

    @staticmethod
    def _horner(c, s):
        acc = c[-1]
        for j in range(len(c) - 2, -1, -1):
            acc = c[j] + s * acc
        return acc

    def state(self, t):
        s = t - self.t0
        hz = self._horner
        ax, ay = self.accel(t)
        return (self.x0 + s * (self.vx0 + s * hz(self.px, s)), self.y0 + s * (self.vy0 + s * hz(self.py, s)),
                self.vx0 + s * hz(self.qx, s), self.vy0 + s * hz(self.qy, s), ax, ay)


def _dot(row, b):
    """sum(row[j] * b[j]), left to right (the C reconstruction sums in this order)."""
    acc = row[0] * b[0]
    for j in range(1, len(row)):
        acc += row[j] * b[j]
    return acc


def _exact_inverse(M):
    """Inverse of a square matrix of Fractions by Gauss-Jordan elimination (exact)."""
    n = len(M)
    A = [list(row) + [Fraction(int(i == j)) for j in range(n)] for i, row in enumerate(M)]
    for col in range(n):
        piv = next((i for i in range(col, n) if A[i][col] != 0), None)
        if piv is None:
            raise InputError("the input samples do not determine the reconstruction "
                             "(two samples at the same time?)")
        A[col], A[piv] = A[piv], A[col]
        p = A[col][col]
        A[col] = [x / p for x in A[col]]
        for i in range(n):
            f = A[i][col]
            if i != col and f != 0:
                A[i] = [x - f * y for x, y in zip(A[i], A[col])]
    return [row[n:] for row in A]
