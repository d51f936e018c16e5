"""A linear structure that carries the ball's cavity, and what excites it.

This module owns the structure side of docs/design.md section 11: the modal model
of one horizontal axis (`Mode`, `StructureAxis`), the two axes together
(`Structure`), and the excitations (`HarmonicForce`, `HarmonicGround`,
`GroundRecord`, `NoExcitation`). Plain Python, SI units, no FMI, no I/O
except `GroundRecord.from_csv`. The coupled structure + ball ODE is in
`ballmill.absorber.model`; the linear theory in `ballmill.absorber.linear`.

Modal model of one axis (x or y), coordinates q_j relative to the ground:

    M_j q_j'' + C_j q_j' + K_j q_j = psi_j F_ext - L_j a_g + phi_j F_ball

    K_j = M_j (2 pi f_j)^2,   C_j = 2 zeta_j M_j (2 pi f_j)

with phi_j the mode shape at the absorber (so the cavity moves by
x_O = sum phi_j q_j relative to the ground, and its absolute acceleration is
a_O = a_g + sum phi_j q_j''), psi_j the mode shape where the external force
F_ext acts, L_j = int m phi_j dm the participation of mode j in a ground
acceleration a_g. A single mass on a spring (the issue's structure) is one
mode with M_j = M, phi_j = psi_j = 1, L_j = M.

Excitations give (F_x, F_y, a_gx, a_gy) at time t through ``loads(t)``: an
external force on the structure [N] and the ground's acceleration [m/s2].
A ground record is used as an acceleration: the structure's coordinates are
relative to the ground, so nothing is differentiated and nothing needs to be
integrated to drive either the structure or the ball.
"""
from __future__ import annotations

import bisect
import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

from ballmill.physics.errors import ParameterError


def _finite(name, value, unit, positive=False, non_negative=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number in {unit}, got {name} = {value!r}") from None
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be finite, got {name} = {value!r} {unit}")
    if positive and v <= 0.0:
        raise ParameterError(f"{name} must be positive, got {name} = {value!r} {unit}")
    if non_negative and v < 0.0:
        raise ParameterError(f"{name} must be non-negative, got {name} = {value!r} {unit}")
    return v


@dataclass(frozen=True)
class Mode:
    """One mode of one horizontal axis.

    mass: modal mass M_j [kg]; frequency: undamped natural frequency f_j [Hz];
    damping: damping ratio zeta_j [1]; shape: mode shape phi_j at the absorber
    [1]; force_shape: psi_j where the external force acts (None: = shape);
    participation: L_j for ground acceleration [kg] (None: mass * shape, exact
    for a single mass and for a structure whose mass sits at the absorber).
    """

    mass: float
    frequency: float
    damping: float = 0.0
    shape: float = 1.0
    force_shape: float | None = None
    participation: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "mass", _finite("mode mass", self.mass, "kg", positive=True))
        object.__setattr__(self, "frequency", _finite("mode frequency", self.frequency, "Hz", positive=True))
        object.__setattr__(self, "damping", _finite("mode damping ratio", self.damping, "1", non_negative=True))
        object.__setattr__(self, "shape", _finite("mode shape at the absorber", self.shape, "1"))
        if self.force_shape is None:
            object.__setattr__(self, "force_shape", self.shape)
        else:
            object.__setattr__(self, "force_shape", _finite("mode shape at the force", self.force_shape, "1"))
        if self.participation is None:
            object.__setattr__(self, "participation", self.mass * self.shape)
        else:
            object.__setattr__(self, "participation",
                               _finite("mode participation", self.participation, "kg"))

    @property
    def omega(self) -> float:
        """Angular natural frequency [rad/s]."""
        return 2.0 * math.pi * self.frequency

    @property
    def stiffness(self) -> float:
        """K_j = M_j omega_j^2 [N/m]."""
        return self.mass * self.omega ** 2

    @property
    def damping_coefficient(self) -> float:
        """C_j = 2 zeta_j M_j omega_j [N s/m]."""
        return 2.0 * self.damping * self.mass * self.omega


@dataclass(frozen=True)
class StructureAxis:
    """The modes of one horizontal axis (at least one)."""

    modes: tuple = ()

    def __post_init__(self):
        modes = tuple(self.modes)
        if not modes:
            raise ParameterError("a structure axis needs at least one mode, got modes = ()")
        for i, md in enumerate(modes):
            if not isinstance(md, Mode):
                raise ParameterError(f"modes[{i}] must be a Mode, got {md!r}")
        object.__setattr__(self, "modes", modes)

    @classmethod
    def single(cls, mass: float, frequency: float, damping: float = 0.0) -> "StructureAxis":
        """A single mass on a spring and dashpot: one mode, shapes 1, L = M."""
        return cls((Mode(mass, frequency, damping),))

    @property
    def n(self) -> int:
        return len(self.modes)

    @property
    def flexibility(self) -> float:
        """G = sum phi_j^2 / M_j [1/kg]: the absorber point's acceleration per unit force
        there (the inverse of the mass the ball's force meets)."""
        return sum(md.shape ** 2 / md.mass for md in self.modes)


@dataclass(frozen=True)
class Structure:
    """Both horizontal axes. ``y = None``: the structure does not move in y (the
    cavity follows the ground there)."""

    x: StructureAxis
    y: StructureAxis | None = None

    def __post_init__(self):
        if not isinstance(self.x, StructureAxis):
            raise ParameterError(f"Structure.x must be a StructureAxis, got {self.x!r}")
        if self.y is not None and not isinstance(self.y, StructureAxis):
            raise ParameterError(f"Structure.y must be a StructureAxis or None, got {self.y!r}")

    @classmethod
    def single(cls, mass: float, frequency: float, damping: float = 0.0, both_axes: bool = True):
        """The same single-mass axis in x and (when both_axes) in y."""
        ax = StructureAxis.single(mass, frequency, damping)
        return cls(ax, ax if both_axes else None)

    @property
    def axes(self):
        return (self.x, self.y)

    @property
    def n_states(self) -> int:
        """2 (q and q') per mode of each axis that moves."""
        return 2 * (self.x.n + (self.y.n if self.y is not None else 0))


# ---------------------------------------------------------------------------
# excitations: loads(t) -> (F_x, F_y, a_gx, a_gy)

@dataclass(frozen=True)
class NoExcitation:
    """Nothing pushes: free vibration."""

    def loads(self, t: float):
        return 0.0, 0.0, 0.0, 0.0

    def frequency(self, t: float) -> float:
        return 0.0


@dataclass(frozen=True)
class _Harmonic:
    """What a harmonic force and a harmonic ground acceleration share: the amplitudes
    per axis (in ``UNIT``), the phase law theta(t) of a linear chirp and its
    instantaneous frequency, and the retuning that continues it (see `HarmonicForce`)."""

    amplitude_x: float = 0.0
    frequency: float = 1.0
    amplitude_y: float = 0.0
    phase: float = 0.0
    phase_y: float = 0.0
    sweep_rate: float = 0.0
    t0: float = 0.0

    UNIT = ""  # of the amplitudes

    def __post_init__(self):
        for name, unit in (("amplitude_x", self.UNIT), ("amplitude_y", self.UNIT), ("phase", "rad"),
                           ("phase_y", "rad"), ("sweep_rate", "Hz/s"), ("t0", "s")):
            object.__setattr__(self, name, _finite(name, getattr(self, name), unit))
        object.__setattr__(self, "frequency", _finite("frequency", self.frequency, "Hz", positive=True))

    def theta(self, t: float) -> float:
        s = t - self.t0
        return self.phase + 2.0 * math.pi * s * (self.frequency + 0.5 * self.sweep_rate * s)

    def instantaneous_frequency(self, t: float) -> float:
        """[Hz]"""
        return self.frequency + self.sweep_rate * (t - self.t0)

    def _components(self, t: float):
        th = self.theta(t)
        return self.amplitude_x * math.sin(th), self.amplitude_y * math.sin(th + self.phase_y)

    def retuned(self, frequency: float, t: float):
        """The same excitation continuing at time t with a new steady frequency and the
        phase it has at t (for stepped sweeps)."""
        return type(self)(self.amplitude_x, frequency, self.amplitude_y,
                          math.fmod(self.theta(t), 2.0 * math.pi), self.phase_y, 0.0, t)


@dataclass(frozen=True)
class HarmonicForce(_Harmonic):
    """F_x = amplitude_x sin(theta(t)), F_y = amplitude_y sin(theta(t) + phase_y), with

        theta(t) = phase + 2 pi (frequency (t - t0) + 1/2 sweep_rate (t - t0)^2)

    i.e. an instantaneous frequency frequency + sweep_rate (t - t0) [Hz] that
    may vary slowly (a linear chirp; sweep_rate in Hz/s, 0 for a steady
    harmonic). ``phase`` [rad] lets a stepped sweep continue with the phase it
    had. Amplitudes in N."""

    UNIT = "N"
    kind = "force"

    def loads(self, t: float):
        fx, fy = self._components(t)
        return fx, fy, 0.0, 0.0


@dataclass(frozen=True)
class HarmonicGround(_Harmonic):
    """Ground acceleration a_gx = amplitude_x sin(theta(t)), a_gy = amplitude_y
    sin(theta(t) + phase_y) [m/s2]; theta(t) as in `HarmonicForce`."""

    UNIT = "m/s2"
    kind = "ground"

    def loads(self, t: float):
        ax, ay = self._components(t)
        return 0.0, 0.0, ax, ay


@dataclass(frozen=True)
class GroundRecord:
    """A measured (or synthetic) ground acceleration, linearly interpolated
    between samples; zero before the first and after the last sample.

    t: sample times [s], strictly increasing; ax, ay: accelerations [m/s2].
    The acceleration drives the model directly (coordinates relative to the
    ground): no differentiation, and the record's velocity and displacement
    are never needed.
    """

    t: tuple = field(repr=False)
    ax: tuple = field(repr=False)
    ay: tuple = field(repr=False)
    source: str = ""

    kind = "ground"

    def __post_init__(self):
        t, ax, ay = (tuple(float(v) for v in s) for s in (self.t, self.ax, self.ay))
        if not (len(t) == len(ax) == len(ay)) or len(t) < 2:
            raise ParameterError(f"a ground record needs at least 2 samples and columns of equal "
                                 f"length, got {len(t)} times, {len(ax)} ax, {len(ay)} ay"
                                 + (f" ({self.source})" if self.source else ""))
        for i, (ti, a, b) in enumerate(zip(t, ax, ay)):
            if not (math.isfinite(ti) and math.isfinite(a) and math.isfinite(b)):
                raise ParameterError(f"ground record row {i + 1}: time {ti!r} s, ax {a!r}, ay {b!r} "
                                     f"m/s2 must be finite" + (f" ({self.source})" if self.source else ""))
            if i and not ti > t[i - 1]:
                raise ParameterError(f"ground record times must increase strictly, got t = {t[i - 1]!r} "
                                     f"then {ti!r} s at row {i + 1}" + (f" ({self.source})" if self.source else ""))
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "ax", ax)
        object.__setattr__(self, "ay", ay)

    @classmethod
    def from_csv(cls, path, time: str = "time", ax: str = "ax", ay: str | None = "ay") -> "GroundRecord":
        """Read columns ``time`` [s], ``ax`` and ``ay`` [m/s2] (ay may be missing: zero)."""
        path = Path(path)
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
        if not rows:
            raise ParameterError(f"{path}: no data rows")
        cols = rows[0].keys()
        for c in (time, ax):
            if c not in cols:
                raise ParameterError(f"{path}: column {c!r} missing, found {sorted(cols)}")
        try:
            tt = [float(r[time]) for r in rows]
            xx = [float(r[ax]) for r in rows]
            yy = [float(r[ay]) for r in rows] if ay and ay in cols else [0.0] * len(rows)
        except ValueError as e:
            raise ParameterError(f"{path}: {e}") from None
        return cls(tt, xx, yy, source=str(path))

    @property
    def duration(self) -> float:
        return self.t[-1] - self.t[0]

    def loads(self, t: float):
        ts = self.t
        if t < ts[0] or t > ts[-1]:
            return 0.0, 0.0, 0.0, 0.0
        i = bisect.bisect_right(ts, t) - 1
        if i >= len(ts) - 1:
            return 0.0, 0.0, self.ax[-1], self.ay[-1]
        w = (t - ts[i]) / (ts[i + 1] - ts[i])
        return (0.0, 0.0, self.ax[i] + w * (self.ax[i + 1] - self.ax[i]),
                self.ay[i] + w * (self.ay[i + 1] - self.ay[i]))

    def breakpoints(self):
        """Sample times: the interpolated acceleration has kinks there, so an
        integrator should land on them (``simulate_absorber`` does)."""
        return self.t


# ---------------------------------------------------------------------------
# the structure as a model: what the coupled ODE (model.py) and a Structure
# FMU both need

class StructureModel:
    """The structure's equations with the ball's force F_ball as an input.

    State zs = (q_x[0..nx), q_x'[0..nx), q_y[0..ny), q_y'[0..ny)) (y part absent
    when ``structure.y`` is None). Everything a Structure FMU would need:
    `derivative` (input: the ball's horizontal force on the cavity), `cavity`
    (outputs: the cavity's motion), and for the monolithic model the split
    a_O = a_free + G F_ball (`free_acceleration`, ``flexibility``).
    """

    def __init__(self, structure: Structure, excitation=None):
        if not isinstance(structure, Structure):
            raise ParameterError(f"structure must be a Structure, got {structure!r}")
        self.structure = structure
        self.excitation = excitation if excitation is not None else NoExcitation()
        # per axis: tuple of (M, K, C, phi, psi, L) and (offset of q, number of modes)
        self._axes = []
        off = 0
        for ax in structure.axes:
            if ax is None:
                self._axes.append(((), off, 0))
                continue
            cs = tuple((md.mass, md.stiffness, md.damping_coefficient, md.shape, md.force_shape,
                        md.participation) for md in ax.modes)
            self._axes.append((cs, off, ax.n))
            off += 2 * ax.n
        self.n_states = off
        self.flexibility = tuple(ax.flexibility if ax is not None else 0.0 for ax in structure.axes)

    def initial(self, qx=None, qdx=None, qy=None, qdy=None):
        """State at rest (or with the given modal displacements/velocities)."""
        zs = [0.0] * self.n_states
        for (cs, off, n), q, qd, name in zip(self._axes, (qx, qy), (qdx, qdy), "xy"):
            for vals, base, what in ((q, off, "q"), (qd, off + n, "qd")):
                if vals is None:
                    continue
                vals = [float(v) for v in (vals if hasattr(vals, "__len__") else [vals])]
                if len(vals) != n:
                    raise ParameterError(f"{what}{name} needs {n} values (one per mode of axis {name}), "
                                         f"got {len(vals)}")
                zs[base:base + n] = vals
        return zs

    def free_acceleration(self, zs, loads):
        """(a_free_x, a_free_y, r_x, r_y): the cavity's absolute acceleration without the
        ball's force, and each mode's acceleration without it (lists), for
        loads = excitation.loads(t)."""
        Fx, Fy, gx, gy = loads
        out = []
        for (cs, off, n), F, g in zip(self._axes, (Fx, Fy), (gx, gy)):
            a = g
            r = []
            for j, (M, K, C, phi, psi, L) in enumerate(cs):
                rj = (psi * F - L * g - C * zs[off + n + j] - K * zs[off + j]) / M
                r.append(rj)
                a += phi * rj
            out.append((a, r))
        return out[0][0], out[1][0], out[0][1], out[1][1]

    def derivative(self, t, zs, Fbx, Fby, loads=None):
        """dzs/dt for the ball's horizontal force (Fbx, Fby) on the cavity [N]."""
        if loads is None:
            loads = self.excitation.loads(t)
        _, _, rx, ry = self.free_acceleration(zs, loads)
        dz = [0.0] * self.n_states
        for (cs, off, n), r, Fb in zip(self._axes, (rx, ry), (Fbx, Fby)):
            for j, (M, K, C, phi, psi, L) in enumerate(cs):
                dz[off + j] = zs[off + n + j]
                dz[off + n + j] = r[j] + phi * Fb / M
        return dz

    def cavity(self, t, zs, Fbx, Fby, loads=None):
        """(x_O, y_O, vx_O, vy_O, ax_O, ay_O): the cavity's displacement and velocity
        relative to the ground [m, m/s] and its absolute acceleration [m/s2]."""
        if loads is None:
            loads = self.excitation.loads(t)
        ax0, ay0, _, _ = self.free_acceleration(zs, loads)
        Gx, Gy = self.flexibility
        pos, vel = [], []
        for cs, off, n in self._axes:
            pos.append(sum(c[3] * zs[off + j] for j, c in enumerate(cs)))
            vel.append(sum(c[3] * zs[off + n + j] for j, c in enumerate(cs)))
        return pos[0], pos[1], vel[0], vel[1], ax0 + Gx * Fbx, ay0 + Gy * Fby

    def energy(self, zs) -> float:
        """Kinetic + strain energy of the modes, relative to the ground [J]."""
        E = 0.0
        for cs, off, n in self._axes:
            for j, (M, K, C, phi, psi, L) in enumerate(cs):
                E += 0.5 * M * zs[off + n + j] ** 2 + 0.5 * K * zs[off + j] ** 2
        return E

    def powers(self, zs, loads):
        """(P_exc, P_damp): power of the external force and of the ground's inertial
        load -L_j a_g on the modes, and power dissipated in the modal dampers [W]."""
        Fx, Fy, gx, gy = loads
        P_exc = P_damp = 0.0
        for (cs, off, n), F, g in zip(self._axes, (Fx, Fy), (gx, gy)):
            for j, (M, K, C, phi, psi, L) in enumerate(cs):
                qd = zs[off + n + j]
                P_exc += qd * (psi * F - L * g)
                P_damp += C * qd * qd
        return P_exc, P_damp
