"""Structure FMU: a linear structure that carries a ball absorber's cavity and feels the ball.

A thin pythonfmu adapter over ballmill.absorber.structure (`Mode`, `StructureAxis`,
`Structure`, `StructureModel`; docs/design.md section 11). Like the drives it moves the chamber:
its outputs x1O .. ay1O are the cavity's absolute motion under BallInShell's input names,
so BallInShell (input_mode 1) takes them as they are; its inputs Fx_ball, Fy_ball take
BallInShell's Fx, Fy, so the two are coupled both ways. Per horizontal axis up to 3 modes
(interface.STRUCTURE_MODES; n_x >= 1, n_y >= 0):

    M_j q_j'' + C_j q_j' + K_j q_j = psi_j F_ext - L_j a_g + phi_j F_ball,

excited by a harmonic force F_ext = F0 sin(theta(t)) and/or a harmonic ground acceleration
ag0 sin(theta(t)) (theta = 2 pi (f_exc t + sweep_rate t^2 / 2): a slow linear sweep), plus a
ground-acceleration record fed by the master through the inputs ag_x, ag_y. The ground's
velocity and displacement are integrated from its acceleration (x1O = x_g + sum phi q, so
the cavity's position, velocity and acceleration are consistent, as BallInShell's input
check wants).

Over a communication step the inputs are extrapolated from the last input_order + 1
communication points (0 hold, 1 linear, 2 quadratic) and the state (modes, ground motion,
the work quadratures W_exc, W_damp, W_ball) is integrated by classical RK4 in
ceil(H / h_max) equal steps (drive_models/structure.c does the same arithmetic). The
accelerations ax1O, ay1O, ax_load, ay_load depend directly on Fx_ball, Fy_ball, ag_x, ag_y
(direct feedthrough, declared in the interface): setting those inputs between steps
recomputes every output at the FMU's time, so a master can iterate the algebraic loop
with the ball. A non-finite input, or outputs that would not be finite, refuse the step
(fmi2Discard) and keep the last good state.
"""
from __future__ import annotations

import os
import sys

# An earlier FMU in this process may have imported ballmill from its own, since deleted,
# resources folder (fmpy removes them after a run): forget it, so that the import below
# finds this FMU's copy (or an installed ballmill) again.
if not os.path.exists(getattr(sys.modules.get("ballmill"), "__file__", None) or os.curdir):
    for _name in [n for n in sys.modules if n.split(".")[0] == "ballmill"]:
        del sys.modules[_name]

import math

from ballmill.absorber.structure import Mode, StructureAxis, StructureModel
from ballmill.absorber.structure import Structure as Axes
from ballmill.fmi.interface import AXES, STRUCTURE, STRUCTURE_MODES
from ballmill.fmi.slave import Slave

INPUTS = ("Fx_ball", "Fy_ball", "ag_x", "ag_y")
N_EXTRA = 7  # x_g, v_gx, y_g, v_gy, W_exc, W_damp, W_ball after the modal states


def extrapolate(samples, t):
    """The inputs at t by the Lagrange polynomial through the samples (t_i, u_i) (the
    same operations as structure.c's extrapolate)."""
    n = len(samples)
    out = [0.0, 0.0, 0.0, 0.0]
    for i in range(n):
        w = 1.0
        ti = samples[i][0]
        for j in range(n):
            if j != i:
                w = w * (t - samples[j][0]) / (ti - samples[j][0])
        u = samples[i][1]
        for k in range(4):
            out[k] = out[k] + w * u[k]
    return out


class Structure(Slave):
    """Linear modal structure (up to 3 modes per horizontal axis) carrying the ball's cavity."""

    description = STRUCTURE.description

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.declare(STRUCTURE)
        self._sm = None
        self._z = None
        self._samples = []

    # -- life cycle --------------------------------------------------------
    def build(self):
        axes = []
        for a in AXES:
            n = getattr(self, f"n_{a}")
            if a == "x" and n < 1:
                raise ValueError(f"n_x must be at least 1 (the axis the structure moves in), got n_x = {n}")
            modes = []
            for j in range(1, n + 1):
                try:
                    modes.append(Mode(getattr(self, f"M_{a}{j}"), getattr(self, f"f_{a}{j}"),
                                      getattr(self, f"zeta_{a}{j}"), getattr(self, f"phi_{a}{j}"),
                                      getattr(self, f"psi_{a}{j}"), getattr(self, f"L_{a}{j}")))
                except ValueError as e:
                    raise ValueError(f"mode {j} of axis {a} (M_{a}{j}, f_{a}{j}, zeta_{a}{j}): {e}") from None
            axes.append(StructureAxis(tuple(modes)) if modes else None)
        self._sm = StructureModel(Axes(axes[0], axes[1]))
        self._order = self.input_order
        if self._order not in (0, 1, 2):
            raise ValueError(f"input_order must be one of [0, 1, 2], got {self._order!r}")
        self._w = 2.0 * math.pi

    def start(self):
        self._z = [0.0] * (self._sm.n_states + N_EXTRA)
        u = self._input_values()
        if not all(math.isfinite(v) for v in u):
            raise ValueError(f"inputs {dict(zip(INPUTS, u))} must be finite")
        self._samples = [(self._time, u)]
        self._publish(self._time, self._z, u)

    def _input_values(self):
        return [float(getattr(self, name)) for name in INPUTS]

    # -- the model ---------------------------------------------------------
    def _theta(self, t):
        return self._w * t * (self.f_exc + 0.5 * self.sweep_rate * t)

    def _loads(self, t, u):
        """(F_x, F_y, a_gx, a_gy) at t for the inputs u."""
        th = self._theta(t)
        s, sy = math.sin(th), math.sin(th + self.phase_y)
        return (self.F0_x * s, self.F0_y * sy, self.ag0_x * s + u[2], self.ag0_y * sy + u[3])

    def _structure(self, t, z, u):
        """(n_states, the structure's states, loads, their derivative) at t for the inputs u."""
        sm = self._sm
        ns = sm.n_states
        zs = z[:ns]
        loads = self._loads(t, u)
        return ns, zs, loads, sm.derivative(t, zs, u[0], u[1], loads)

    def _rhs(self, t, z, u):
        sm = self._sm
        ns, zs, loads, dz = self._structure(t, z, u)
        _, _, vx, vy, _, _ = sm.cavity(t, zs, u[0], u[1], loads)
        P_exc, P_damp = sm.powers(zs, loads)
        return dz + [z[ns + 1], loads[2], z[ns + 3], loads[3], P_exc, P_damp, u[0] * vx + u[1] * vy]

    def _rk4(self, t, t_end, z, samples):
        n = max(1, math.ceil((t_end - t) / self.h_max * (1.0 - 1e-12)))
        h = (t_end - t) / n
        m = len(z)
        for i in range(n):
            ta = t + i * h
            tb = t_end if i == n - 1 else t + (i + 1) * h
            tm = ta + 0.5 * h
            ua, um, ub = extrapolate(samples, ta), extrapolate(samples, tm), extrapolate(samples, tb)
            k1 = self._rhs(ta, z, ua)
            k2 = self._rhs(tm, [z[j] + 0.5 * h * k1[j] for j in range(m)], um)
            k3 = self._rhs(tm, [z[j] + 0.5 * h * k2[j] for j in range(m)], um)
            k4 = self._rhs(tb, [z[j] + h * k3[j] for j in range(m)], ub)
            z = [z[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]) for j in range(m)]
        return z

    def _publish(self, t, z, u):
        sm = self._sm
        ns, zs, loads, dz = self._structure(t, z, u)
        values = {}
        for k, (a, (cs, off, n)) in enumerate(zip(AXES, sm._axes)):
            g, vg = z[ns + 2 * k], z[ns + 2 * k + 1]
            rel = sum(c[3] * zs[off + j] for j, c in enumerate(cs))
            vrel = sum(c[3] * zs[off + n + j] for j, c in enumerate(cs))
            acc = loads[2 + k] + sum(c[3] * dz[off + n + j] for j, c in enumerate(cs))
            values[f"{a}1O"] = g + rel
            values[f"v{a}1O"] = vg + vrel
            values[f"a{a}1O"] = acc
            for j in range(STRUCTURE_MODES):
                values[f"q_{a}{j + 1}"] = zs[off + j] if j < n else 0.0
            values[f"{a}_rel"] = rel
            values[f"{a}_load"] = sum(c[4] * zs[off + j] for j, c in enumerate(cs))
            values[f"a{a}_load"] = loads[2 + k] + sum(c[4] * dz[off + n + j] for j, c in enumerate(cs))
            values[f"{a}g"] = g
            values[f"v{a}g"] = vg
            values[f"ag{a}_total"] = loads[2 + k]
            values[f"F{a}_exc"] = loads[k]
        values["f_inst"] = self.f_exc + self.sweep_rate * t
        values["E"] = sm.energy(zs)
        values["W_exc"], values["W_damp"], values["W_ball"] = z[ns + 4], z[ns + 5], z[ns + 6]
        checked = [(name, self.finite(name, v)) for name, v in values.items()]
        for name, v in checked:
            setattr(self, name, v)

    # -- stepping ----------------------------------------------------------
    def step(self, t, t_end):
        u = self._input_values()
        for name, v in zip(INPUTS, u):
            if not math.isfinite(v):
                return self.discard(f"{self.who}: input {name} must be finite, got {v!r} at t = {t:.9g} s; "
                                    f"step refused, last good state kept")
        samples = [smp for smp in self._samples if smp[0] < t][-self._order:] if self._order else []
        samples.append((t, u))
        try:
            z = self._rk4(t, t_end, self._z, samples)
            self._publish(t_end, z, extrapolate(samples, t_end))
        except ArithmeticError as e:
            return self.discard(f"{self.who}: step from t = {t:.9g} s refused, last good state kept: {e}")
        self._z, self._samples = z, samples
        return True

    def inputs_set(self):
        """Direct feedthrough: every output at the FMU's time from the state and the inputs
        just set (the accelerations depend on Fx_ball, Fy_ball, ag_x, ag_y)."""
        if self._z is None:
            return
        u = self._input_values()
        if not all(math.isfinite(v) for v in u):
            return  # the next step refuses them
        try:
            self._publish(self._time, self._z, u)
        except ArithmeticError:
            pass

    # -- state save/restore ------------------------------------------------
    def internal_state(self):
        return {"z": list(self._z), "samples": [[t, list(u)] for t, u in self._samples]}

    def restore_internal_state(self, s):
        z = s["z"]
        if not (isinstance(z, list) and len(z) == self._sm.n_states + N_EXTRA
                and all(isinstance(v, (int, float)) and math.isfinite(v) for v in z)):
            raise ValueError(f"state z has {len(z) if isinstance(z, list) else z!r} values, expected "
                             f"{self._sm.n_states + N_EXTRA} finite numbers for n_x = {self.n_x}, n_y = {self.n_y}")
        samples = s["samples"]
        ok = isinstance(samples, list) and 1 <= len(samples) <= 3 and all(
            isinstance(p, list) and len(p) == 2 and isinstance(p[0], (int, float)) and math.isfinite(p[0])
            and isinstance(p[1], list) and len(p[1]) == 4
            and all(isinstance(v, (int, float)) and math.isfinite(v) for v in p[1]) for p in samples)
        if not ok:
            raise ValueError(f"input samples {samples!r}: expected 1 to 3 pairs [t, [4 finite inputs]]")
        if samples[-1][0] > self._time * (1.0 + 1e-12) + 1e-12:
            raise ValueError(f"the newest input sample is at t = {samples[-1][0]!r} s, after the FMU time "
                             f"{self._time!r} s")
        self._z = [float(v) for v in z]
        self._samples = [(float(t), [float(v) for v in u]) for t, u in samples]
