"""An induction motor driving the crank through a gear: the drive that sags.

This module owns the motor side of docs/design.md section 4: the asynchronous
motor's torque (Kloss's formula, or a 4-state dq model as the higher
fidelity), its starter (direct on line, voltage ramp, V/f frequency ramp),
the crank shaft equation that closes the loop through the ball's reaction
torque, and the platform kinematics that follow from the crank angle.
Plain Python, SI units, no FMI, no I/O.

Conventions
-----------
- Gear ratio ``i`` = motor speed / crank speed: ``w_motor = i * psi'``. An
  ideal (lossless) gear then gives the crank the torque ``i * T_motor`` and
  the rotor's inertia appears on the crank shaft as ``i**2 * J_rotor``. The
  shaft equation, referred to the crank shaft, is

      J_total psi'' = i T_motor + M_reaction,
      J_total = J_crank + m_platform l^2 + i^2 J_rotor.

  Older notes wrote ``T_motor / i``; that is the same equation for the inverse
  definition of the ratio (crank speed / motor speed, i < 1, where the rotor
  appears as J_rotor / i^2). With ``w_motor = i psi'`` only ``i T_motor``
  conserves energy, and the tests check that balance.
- ``M_reaction`` is the torque of the load (the ball) on the crank shaft,
  positive counter-clockwise seen from above, the same sense as psi. The
  power the drive delivers to the load is ``-M_reaction * psi'``.
- The platform point O moves as x1O = l cos psi, y1O = l sin psi (it
  translates: its kinetic energy is 1/2 m_platform l^2 psi'^2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

# scipy (least_squares, brentq, solve_ivp) is imported where it is used: the FMU interface
# declaration reads this module's default parameter values, and that needs no scipy
from ..errors import ParameterError

START_MODES = ("dol", "voltage_ramp", "frequency_ramp")
DRIVE_MODELS = ("kloss", "dq")

RPM = 2.0 * math.pi / 60.0  # rad/s per 1/min


def _number(name, value, unit):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number in {unit}, got {name} = {value!r}") from None
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be finite, got {name} = {value!r} {unit}")
    return v


def _positive(name, value, unit):
    v = _number(name, value, unit)
    if v <= 0.0:
        raise ParameterError(f"{name} must be positive, got {name} = {value!r} {unit}")
    return v


def _non_negative(name, value, unit):
    v = _number(name, value, unit)
    if v < 0.0:
        raise ParameterError(f"{name} must be non-negative, got {name} = {value!r} {unit}")
    return v


def _fraction(name, value, lo_open=False, hi_open=False):
    v = _number(name, value, "1")
    lo_ok = v > 0.0 if lo_open else v >= 0.0
    hi_ok = v < 1.0 if hi_open else v <= 1.0
    if not (lo_ok and hi_ok):
        lo, hi = ("(0" if lo_open else "[0"), ("1)" if hi_open else "1]")
        raise ParameterError(f"{name} must lie in {lo}, {hi}, got {name} = {value!r}")
    return v


# --------------------------------------------------------------------------
# dq (Park) electrical model
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class DqParameters:
    """Per-phase equivalent-circuit parameters of the dq model (star
    equivalent, rotor referred to the stator) [ohm, H].

    Rs, Rr: stator and rotor resistance; Ls_sigma, Lr_sigma: leakage
    inductances; Lm: magnetising inductance. Build them yourself (from a
    no-load and locked-rotor test) or let `InductionMotor` fit them.
    """

    Rs: float
    Rr: float
    Ls_sigma: float
    Lr_sigma: float
    Lm: float

    def __post_init__(self):
        object.__setattr__(self, "Rs", _non_negative("Rs", self.Rs, "ohm"))
        for name, unit in (("Rr", "ohm"), ("Ls_sigma", "H"), ("Lr_sigma", "H"), ("Lm", "H")):
            object.__setattr__(self, name, _positive(name, getattr(self, name), unit))

    @property
    def Ls(self) -> float:
        """Stator self inductance Ls_sigma + Lm [H]."""
        return self.Ls_sigma + self.Lm

    @property
    def Lr(self) -> float:
        """Rotor self inductance Lr_sigma + Lm [H]."""
        return self.Lr_sigma + self.Lm


def _phasor_steady_state(dq: DqParameters, p: int, U_phase: float, w_el: float, slip: float):
    """Steady state of the T equivalent circuit at supply angular frequency w_el
    [rad/s], phase voltage U_phase [V rms] and slip: (torque [N m], stator
    current [A rms], cos phi, electrical power [W])."""
    Zs = dq.Rs + 1j * w_el * dq.Ls_sigma
    Zm = 1j * w_el * dq.Lm
    if slip == 0.0:
        Z = Zs + Zm
        I_s = U_phase / Z
        T = 0.0
    else:
        Zr = dq.Rr / slip + 1j * w_el * dq.Lr_sigma
        Z = Zs + Zm * Zr / (Zm + Zr)
        I_s = U_phase / Z
        I_r = I_s * Zm / (Zm + Zr)
        T = 3.0 * abs(I_r) ** 2 * dq.Rr / slip / (w_el / p)
    cos_phi = math.cos(math.atan2(Z.imag, Z.real))
    return T, abs(I_s), cos_phi, 3.0 * U_phase * abs(I_s) * cos_phi


def _phasor_breakdown(dq: DqParameters, p: int, U_phase: float, w_el: float):
    """Maximum motoring torque and the slip where it occurs (exact, Thevenin)."""
    Zs = dq.Rs + 1j * w_el * dq.Ls_sigma
    Zm = 1j * w_el * dq.Lm
    V_th = abs(U_phase * Zm / (Zs + Zm))
    Z_th = Zs * Zm / (Zs + Zm)
    R, X = Z_th.real, Z_th.imag + w_el * dq.Lr_sigma
    Z = math.hypot(R, X)
    return 3.0 * V_th**2 / (2.0 * (w_el / p) * (R + Z)), dq.Rr / Z


# --------------------------------------------------------------------------
# the motor
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class InductionMotor:
    """A three-phase squirrel-cage induction motor, from its catalogue data.

    Default: MTF3 series motor (brand listed as WAT), 0.75 kW, 4 poles,
    frame 80M, IE3, aluminium, 230/400 V 50 Hz, catalogue code
    "MTF3 0,75 1500 4 80M B3 W", from the manufacturer's technical table as
    reproduced on a distributor's product page (mecha.odoo.com, "motor
    electric trifazat 0,75 kW 1500 rpm 80M B3 IE3 WAT aluminiu"):

        rated power 0.75 kW, rated speed 1445 1/min, 1.7 A at 400 V,
        rated torque 5.0 N m, I_start/I_n 6.7, T_start/T_n 2.8,
        T_breakdown/T_n 3.4, efficiency 82.5 % (4/4 load), cos phi 0.77,
        J = 0.00261 kg m2.

    Values of this kind come from the manufacturer's catalogue or the
    motor's data sheet: the rated point is measured per IEC 60034-2-1 and
    guaranteed within the tolerances of IEC 60034-1 (slip +-20 %, +-30 %
    below 1 kW; breakdown torque -10 %; locked-rotor torque -15 %/+25 %;
    efficiency -15 % of 1 - eta), the rotor inertia comes from the design.
    Check: sqrt(3) 400 V 1.7 A 0.77 = 907 W = 750 W / 0.827. A datasheet
    gives no winding resistances; the dq model's are fitted (below). A 0.37
    or 0.55 kW motor in frame 71 (rated speed about 1370-1400 1/min) is an
    equally common choice: pass its values.

    Kloss's formula (no stator resistance)
        T(s) = 2 Tb / (s/sb + sb/s) = 2 Tb s sb / (s^2 + sb^2),
        s = (w_sync - w) / w_sync,  w_sync = 2 pi f / p,
        sb = sn (kb + sqrt(kb^2 - 1)),  kb = Tb/Tn,  Tn = Pn / wn,
    passes exactly through the rated point (sn, Tn) and the breakdown point
    (sb, Tb). It underestimates the starting torque of small motors (here
    2 kb / (1/sb + sb) = 1.56 Tn at standstill against the datasheet's 2.8 Tn):
    their rotor bars are deliberately resistive at high slip, which no
    constant-parameter model (Kloss or dq) represents. ``starting_ratio`` is
    kept for reference and not used.

    Starter (``start``):
        "dol"             direct on line: U = Un, f = fn from t = 0;
        "voltage_ramp"    soft starter: U/Un rises linearly from ``u_start`` to
                          1 in ``ramp_time``; torque scales with (U/Un)^2,
                          sb and w_sync unchanged (fundamental only);
        "frequency_ramp"  inverter with V/f control: f/fn rises linearly from
                          ``f_start`` to 1 in ``ramp_time``, U/Un = f/fn; the
                          synchronous speed scales with f and the torque is
                          Kloss's in the slip speed w_sync(f) - w, with the
                          same breakdown torque Tb at the same slip speed
                          sb w_sync,n (stator resistance neglected: no
                          low-frequency boost is modelled).
    Before t = 0 the motor is switched off.

    dq model: Rs is set by attributing ``stator_copper_share`` of the rated
    losses other than the rotor copper loss (Pn/eta - Pn - sn Tn w_sync) to
    stator copper (3 In^2 Rs); Ls_sigma = Lr_sigma (the IEC/IEEE split when
    unknown); Rr, the leakage and Lm are then solved so that the steady-state
    dq curve has exactly T(sn) = Tn, maximum torque Tb and cos phi(sn) =
    ``power_factor``. With Rs = 0 the dq steady state is exactly Kloss's
    curve; Rs > 0 (needed: it damps the switch-on transient) tilts it. With
    the default share 0.25 (Rs = 3.76 ohm) the steady dq torque stays within
    2.7 % of Tb of the Kloss curve for 0 < s <= sb and within 7.9 % of Tb up
    to standstill (more starting torque: 1.82 Tn). A physically typical
    share for this size, 0.5 (Rs = 7.5 ohm), gives 5.5 % / 16.7 %. See
    `dq_kloss_deviation`. Pass ``dq=DqParameters(...)`` to use measured values.
    """

    rated_power: float = 750.0  # Pn [W]
    rated_speed: float = 1445.0  # nn [1/min]
    rated_voltage: float = 400.0  # Un, line-to-line rms [V]
    rated_frequency: float = 50.0  # fn [Hz]
    pole_pairs: int = 2  # p [1] (4 poles)
    rated_current: float = 1.7  # In, line rms at Un [A]
    power_factor: float = 0.77  # cos phi at the rated point [1]
    efficiency: float = 0.825  # eta at the rated point [1]
    breakdown_ratio: float = 3.4  # kb = Tb/Tn [1]
    starting_ratio: float = 2.8  # Ts/Tn, datasheet; not used by Kloss [1]
    J_rotor: float = 0.00261  # rotor inertia [kg m2]
    start: str = "dol"  # one of START_MODES
    ramp_time: float = 2.5  # duration of a voltage or frequency ramp [s]
    u_start: float = 0.3  # U/Un at t = 0 of a voltage ramp [1]
    f_start: float = 0.0  # f/fn at t = 0 of a frequency ramp [1]
    stator_copper_share: float = 0.25  # sets Rs of the fitted dq model [1]
    dq: DqParameters | None = None  # None: fitted to the Kloss curve

    def __post_init__(self):
        for name, unit in (("rated_power", "W"), ("rated_speed", "1/min"), ("rated_voltage", "V"),
                           ("rated_frequency", "Hz"), ("rated_current", "A"), ("J_rotor", "kg m2"),
                           ("ramp_time", "s"), ("starting_ratio", "1")):
            object.__setattr__(self, name, _positive(name, getattr(self, name), unit))
        p = self.pole_pairs
        if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or p < 1:
            raise ParameterError(f"pole_pairs must be a positive integer (2 for a 4-pole motor), "
                                 f"got pole_pairs = {p!r}")
        object.__setattr__(self, "pole_pairs", int(p))
        object.__setattr__(self, "power_factor", _fraction("power_factor", self.power_factor, lo_open=True))
        object.__setattr__(self, "efficiency", _fraction("efficiency", self.efficiency, lo_open=True))
        object.__setattr__(self, "u_start", _fraction("u_start", self.u_start))
        object.__setattr__(self, "f_start", _fraction("f_start", self.f_start, hi_open=True))
        object.__setattr__(self, "stator_copper_share",
                           _fraction("stator_copper_share", self.stator_copper_share, hi_open=True))
        kb = _number("breakdown_ratio", self.breakdown_ratio, "1")
        if not kb > 1.0:
            raise ParameterError(f"breakdown_ratio Tb/Tn must be larger than 1 (Kloss's formula has no "
                                 f"rated point otherwise), got breakdown_ratio = {self.breakdown_ratio!r}")
        object.__setattr__(self, "breakdown_ratio", kb)
        n_sync = 60.0 * self.rated_frequency / p
        if not self.rated_speed < n_sync:
            raise ParameterError(
                f"rated_speed must be below the synchronous speed 60 f / p = {n_sync:g} 1/min "
                f"(a motor runs with positive slip), got rated_speed = {self.rated_speed!r} 1/min "
                f"with rated_frequency = {self.rated_frequency:g} Hz, pole_pairs = {p}")
        if self.start not in START_MODES:
            raise ParameterError(f"start must be one of {START_MODES}, got start = {self.start!r}")
        # the rated electrical input from the nameplate must match Pn / eta
        p_in = math.sqrt(3.0) * self.rated_voltage * self.rated_current * self.power_factor
        ratio = self.rated_power / (self.efficiency * p_in)
        if not 0.85 <= ratio <= 1.15:
            raise ParameterError(
                f"the rated values are inconsistent: Pn / eta = {self.rated_power / self.efficiency:.4g} W "
                f"but sqrt(3) Un In cos phi = {p_in:.4g} W (expected within 15 %); check units: "
                f"rated_power = {self.rated_power!r} W, rated_voltage = {self.rated_voltage!r} V, "
                f"rated_current = {self.rated_current!r} A")
        if self.dq is None:
            object.__setattr__(self, "dq", self._fit_dq())
        elif not isinstance(self.dq, DqParameters):
            raise ParameterError(f"dq must be a DqParameters or None, got dq = {self.dq!r}")

    # rated quantities -------------------------------------------------------
    @property
    def synchronous_speed(self) -> float:
        """Mechanical synchronous speed at the rated frequency, 2 pi fn / p [rad/s]."""
        return 2.0 * math.pi * self.rated_frequency / self.pole_pairs

    @property
    def rated_angular_speed(self) -> float:
        """Rated speed wn [rad/s]."""
        return self.rated_speed * RPM

    @property
    def rated_slip(self) -> float:
        """sn = (w_sync - wn) / w_sync [1]."""
        return 1.0 - self.rated_angular_speed / self.synchronous_speed

    @property
    def rated_torque(self) -> float:
        """Tn = Pn / wn [N m]."""
        return self.rated_power / self.rated_angular_speed

    @property
    def breakdown_torque(self) -> float:
        """Tb = kb Tn [N m]."""
        return self.breakdown_ratio * self.rated_torque

    @property
    def breakdown_slip(self) -> float:
        """sb = sn (kb + sqrt(kb^2 - 1)) [1], Kloss's breakdown slip."""
        kb = self.breakdown_ratio
        return self.rated_slip * (kb + math.sqrt(kb * kb - 1.0))

    @property
    def phase_voltage_peak(self) -> float:
        """Peak phase voltage of the star equivalent, sqrt(2/3) Un [V] (the dq
        model's voltage vector length, amplitude-invariant Park transform)."""
        return math.sqrt(2.0 / 3.0) * self.rated_voltage

    # Kloss ------------------------------------------------------------------
    def kloss_torque(self, slip):
        """Kloss torque at rated voltage and frequency [N m]; slip scalar or array.
        Negative slip (above synchronous speed) gives the generator branch."""
        s = np.asarray(slip, dtype=float)
        sb, Tb = self.breakdown_slip, self.breakdown_torque
        T = 2.0 * Tb * s * sb / (s * s + sb * sb)
        return float(T) if T.ndim == 0 else T

    def supply(self, t: float):
        """(U/Un, f/fn) of the starter at time t [1, 1]."""
        if t < 0.0:
            return 0.0, 1.0
        x = min(t / self.ramp_time, 1.0)
        if self.start == "dol":
            return 1.0, 1.0
        if self.start == "voltage_ramp":
            return self.u_start + (1.0 - self.u_start) * x, 1.0
        f = self.f_start + (1.0 - self.f_start) * x
        return f, f

    def synchronous_speed_at(self, t: float) -> float:
        """Mechanical synchronous speed of the supply at time t [rad/s]."""
        return self.supply(t)[1] * self.synchronous_speed

    def torque(self, w_motor: float, t: float) -> float:
        """Quasi-static (Kloss) air-gap torque at motor speed w_motor [rad/s] and
        time t, starter included [N m].

            T = (U/Un / (f/fn))^2 * 2 Tb dw dwb / (dw^2 + dwb^2),
            dw = (f/fn) w_sync - w_motor,  dwb = sb w_sync
        which is Kloss's formula at f = fn and the V/f law below it."""
        u, f = self.supply(t)
        flux = u / f if f > 0.0 else 1.0  # V/f: U and f vanish together, flux stays
        dw = f * self.synchronous_speed - w_motor
        dwb = self.breakdown_slip * self.synchronous_speed
        return flux * flux * 2.0 * self.breakdown_torque * dw * dwb / (dw * dw + dwb * dwb)

    # dq model ---------------------------------------------------------------
    def _fit_dq(self) -> DqParameters:
        p, w = self.pole_pairs, 2.0 * math.pi * self.rated_frequency
        U = self.rated_voltage / math.sqrt(3.0)
        sn, Tn, Tb = self.rated_slip, self.rated_torque, self.breakdown_torque
        p_loss = self.rated_power / self.efficiency - self.rated_power
        p_cu_rotor = sn * Tn * self.synchronous_speed
        Rs = self.stator_copper_share * max(p_loss - p_cu_rotor, 0.0) / (3.0 * self.rated_current**2)

        def residual(x):
            Rr, Lsig, Lm = np.exp(x)
            dq = DqParameters(Rs, Rr, Lsig, Lsig, Lm)
            T, _, cos_phi, _ = _phasor_steady_state(dq, p, U, w, sn)
            T_max, _ = _phasor_breakdown(dq, p, U, w)
            return [T / Tn - 1.0, T_max / Tb - 1.0, cos_phi / self.power_factor - 1.0]

        # start from the exact Rs = 0 solution (Gamma circuit = Kloss)
        X = 3.0 * U * U / (2.0 * self.synchronous_speed * Tb)
        x0 = np.log([self.breakdown_slip * X, X / (2.0 * w),
                     U / (self.rated_current * math.sqrt(max(1.0 - self.power_factor**2, 1e-6))) / w])
        from scipy.optimize import least_squares

        sol = least_squares(residual, x0, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if not sol.success or np.max(np.abs(sol.fun)) > 1e-9:
            raise ParameterError(
                f"no dq parameters reproduce the rated point and breakdown torque with "
                f"stator_copper_share = {self.stator_copper_share!r} and power_factor = "
                f"{self.power_factor!r} (residuals {np.round(sol.fun, 6).tolist()}); "
                f"lower stator_copper_share or pass dq=DqParameters(...)")
        Rr, Lsig, Lm = np.exp(sol.x)
        return DqParameters(Rs, float(Rr), float(Lsig), float(Lsig), float(Lm))

    def dq_steady_state(self, slip: float, u: float = 1.0, f: float = 1.0):
        """Steady state of the dq model at the given slip (relative to the supply
        frequency f/fn) and voltage U/Un: dict with torque [N m], current
        [A rms], power_factor, P_el [W] (phasor solution, no integration)."""
        T, I, c, P = _phasor_steady_state(self.dq, self.pole_pairs, u * self.rated_voltage / math.sqrt(3.0),
                                          2.0 * math.pi * self.rated_frequency * f, float(slip))
        return {"torque": T, "current": I, "power_factor": c, "P_el": P}

    def dq_kloss_deviation(self, s_max: float | None = None, n: int = 2001) -> float:
        """max |T_dq(s) - T_kloss(s)| / Tb over 0 < s <= s_max (default: breakdown
        slip sb), steady state at rated supply [1]."""
        s_max = self.breakdown_slip if s_max is None else float(s_max)
        ss = np.linspace(s_max / n, s_max, n)
        T_dq = np.array([self.dq_steady_state(s)["torque"] for s in ss])
        return float(np.max(np.abs(T_dq - self.kloss_torque(ss))) / self.breakdown_torque)

    def dq_currents(self, x):
        """Stator and rotor current vectors (isd, isq, ird, irq) [A peak] from the
        flux linkages x = (psi_sd, psi_sq, psi_rd, psi_rq) [V s]."""
        d = self.dq
        det = d.Ls * d.Lr - d.Lm * d.Lm
        psd, psq, prd, prq = x[0], x[1], x[2], x[3]
        return ((d.Lr * psd - d.Lm * prd) / det, (d.Lr * psq - d.Lm * prq) / det,
                (d.Ls * prd - d.Lm * psd) / det, (d.Ls * prq - d.Lm * psq) / det)

    def dq_rhs(self, t: float, x, w_motor: float):
        """d/dt of the flux linkages x = (psi_sd, psi_sq, psi_rd, psi_rq) [V s] in the
        frame turning with the supply (electrical angular speed w = 2 pi f(t)),
        the voltage vector on the d axis, at rotor speed w_motor [rad/s]:

            psi_s' = u_s - Rs i_s - j w psi_s
            psi_r' =     - Rr i_r - j (w - p w_motor) psi_r
        """
        u, f = self.supply(t)
        w = 2.0 * math.pi * self.rated_frequency * f
        wr = w - self.pole_pairs * w_motor
        isd, isq, ird, irq = self.dq_currents(x)
        Rs, Rr = self.dq.Rs, self.dq.Rr
        return (u * self.phase_voltage_peak - Rs * isd + w * x[1], -Rs * isq - w * x[0],
                -Rr * ird + wr * x[3], -Rr * irq - wr * x[2])

    def dq_torque(self, x) -> float:
        """Electromagnetic torque (3/2) p (psi_sd isq - psi_sq isd) [N m]."""
        isd, isq, _, _ = self.dq_currents(x)
        return 1.5 * self.pole_pairs * (x[0] * isq - x[1] * isd)

    def dq_outputs(self, t: float, x):
        """(torque [N m], stator current [A rms], electrical input power [W])."""
        isd, isq, _, _ = self.dq_currents(x)
        u, _ = self.supply(t)
        T = 1.5 * self.pole_pairs * (x[0] * isq - x[1] * isd)
        return T, math.hypot(isd, isq) / math.sqrt(2.0), 1.5 * u * self.phase_voltage_peak * isd

    def dq_losses_and_energy(self, x):
        """(copper losses [W], magnetic energy [J]) at the fluxes x."""
        isd, isq, ird, irq = self.dq_currents(x)
        p_cu = 1.5 * (self.dq.Rs * (isd * isd + isq * isq) + self.dq.Rr * (ird * ird + irq * irq))
        w_mag = 0.75 * (isd * x[0] + isq * x[1] + ird * x[2] + irq * x[3])
        return p_cu, w_mag

    def with_(self, **changes) -> "InductionMotor":
        """A copy with some values changed (validated, dq refitted unless given)."""
        values = {k: getattr(self, k) for k in self.__dataclass_fields__}
        if "dq" not in changes:
            values["dq"] = None
        values.update(changes)
        return InductionMotor(**values)


# --------------------------------------------------------------------------
# platform kinematics
# --------------------------------------------------------------------------
def platform_state(l: float, psi: float, psi_dot: float, psi_ddot: float):
    """(x1O, y1O, vx, vy, ax, ay) of the platform point O on a crank of length
    l [m] at angle psi [rad], psi' [rad/s], psi'' [rad/s2]; exact derivatives:

        x = l cos psi,  vx = -l psi' sin psi,  ax = -l (psi'' sin psi + psi'^2 cos psi)
        y = l sin psi,  vy =  l psi' cos psi,  ay =  l (psi'' cos psi - psi'^2 sin psi)
    """
    c, s = math.cos(psi), math.sin(psi)
    return (l * c, l * s, -l * s * psi_dot, l * c * psi_dot,
            -l * (s * psi_ddot + c * psi_dot * psi_dot), l * (c * psi_ddot - s * psi_dot * psi_dot))


# --------------------------------------------------------------------------
# the drive: motor + gear + crank + platform
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class CrankDrive:
    """Induction motor -> ideal gear (ratio i = w_motor / psi') -> crank shaft
    -> translating platform of mass m_platform on cranks of length l.

        J_total psi'' = i T_motor + M_reaction
        J_total = J_crank + m_platform l^2 + i^2 J_rotor   [kg m2, crank shaft]

    J_rotor is the motor's (anything else on the motor shaft - coupling,
    brake, gear input - belongs in it too); J_crank holds the cranks and the
    gear's output side. The ball is not part of J_total: it acts through
    M_reaction. Defaults: i = 24 (rated 1445 1/min gives 60.2 1/min at the
    crank, the paper's n0 = 60 1/min; 62.5 1/min at synchronous speed), l =
    0.5 m (the paper). m_platform = 30 kg and J_crank = 0.2 kg m2 are
    assumptions (the paper gives neither): a 4 mm steel shell of R = 0.25 m
    alone weighs about 24.5 kg.

    model: "kloss" (quasi-static torque, state (psi, psi')) or "dq" (state
    (psi, psi', psi_sd, psi_sq, psi_rd, psi_rq), fluxes in V s).
    """

    motor: InductionMotor = field(default_factory=InductionMotor)
    i: float = 24.0  # gear ratio w_motor / psi' [1]
    J_crank: float = 0.2  # crank shaft, cranks, gear output [kg m2]
    m_platform: float = 30.0  # translating platform with the chamber [kg]
    l: float = 0.5  # crank length [m]
    model: str = "kloss"

    def __post_init__(self):
        if not isinstance(self.motor, InductionMotor):
            raise ParameterError(f"motor must be an InductionMotor, got motor = {self.motor!r}")
        object.__setattr__(self, "i", _positive("i", self.i, "1"))
        object.__setattr__(self, "J_crank", _non_negative("J_crank", self.J_crank, "kg m2"))
        object.__setattr__(self, "m_platform", _non_negative("m_platform", self.m_platform, "kg"))
        object.__setattr__(self, "l", _positive("l", self.l, "m"))
        if self.model not in DRIVE_MODELS:
            raise ParameterError(f"model must be one of {DRIVE_MODELS}, got model = {self.model!r}")

    @property
    def J_total(self) -> float:
        """J_crank + m_platform l^2 + i^2 J_rotor, referred to the crank shaft [kg m2]."""
        return self.J_crank + self.m_platform * self.l**2 + self.i**2 * self.motor.J_rotor

    @property
    def n_states(self) -> int:
        return 2 if self.model == "kloss" else 6

    def initial_state(self, psi: float = 0.0, psi_dot: float = 0.0, fluxes=None) -> np.ndarray:
        """State vector at rest (or at the given angle, speed and fluxes [V s])."""
        y = np.zeros(self.n_states)
        y[0], y[1] = psi, psi_dot
        if self.model == "dq" and fluxes is not None:
            y[2:6] = fluxes
        return y

    def motor_speed(self, y) -> float:
        """w_motor = i psi' [rad/s]."""
        return self.i * y[1]

    def motor_torque(self, y, t: float) -> float:
        """Air-gap torque of the motor [N m], at the motor shaft."""
        if self.model == "kloss":
            return self.motor.torque(self.i * y[1], t)
        return self.motor.dq_torque(y[2:6])

    def psi_ddot(self, y, t: float, M_reaction: float) -> float:
        """psi'' = (i T_motor + M_reaction) / J_total [rad/s2]."""
        return (self.i * self.motor_torque(y, t) + M_reaction) / self.J_total

    def rhs(self, t: float, y, M_reaction: float) -> np.ndarray:
        """dy/dt at time t with the load torque M_reaction on the crank shaft."""
        dy = np.empty(self.n_states)
        dy[0] = y[1]
        dy[1] = self.psi_ddot(y, t, M_reaction)
        if self.model == "dq":
            dy[2:6] = self.motor.dq_rhs(t, y[2:6], self.i * y[1])
        return dy

    def platform(self, y, t: float, M_reaction: float):
        """(x1O, y1O, vx, vy, ax, ay) of the platform point O."""
        return platform_state(self.l, y[0], y[1], self.psi_ddot(y, t, M_reaction))

    def kinetic_energy(self, y) -> float:
        """1/2 J_total psi'^2 [J] (rotor, gear, cranks and platform)."""
        return 0.5 * self.J_total * y[1] ** 2

    def outputs(self, y, t: float, M_reaction: float) -> dict:
        """Drive outputs: psi, psi_dot, psi_ddot, w_motor, slip, T_motor, and for
        the dq model I_motor [A rms] and P_el [W] (NaN for Kloss)."""
        w_m = self.i * y[1]
        if self.model == "kloss":
            T, I, P = self.motor.torque(w_m, t), math.nan, math.nan
        else:
            T, I, P = self.motor.dq_outputs(t, y[2:6])
        ws = self.motor.synchronous_speed_at(t)
        return {"psi": y[0], "psi_dot": y[1], "psi_ddot": (self.i * T + M_reaction) / self.J_total,
                "w_motor": w_m, "slip": (ws - w_m) / ws if ws > 0.0 else math.nan,
                "T_motor": T, "I_motor": I, "P_el": P}


# --------------------------------------------------------------------------
# monolithic run-up (for tests and quick studies)
# --------------------------------------------------------------------------
@dataclass
class RunupResult:
    """A run-up trajectory. Arrays over ``t``: psi, psi_dot, w_motor, T_motor,
    M_reaction, W_motor (integral of T_motor w_motor dt, the motor's mechanical
    work [J]), W_load (integral of -M_reaction psi' dt, work done on the load
    [J]), E_kin (1/2 J_total psi'^2 [J]); for the dq model also I_motor [A rms],
    P_el [W], W_el (integral of P_el dt [J]), W_cu (copper losses [J]) and
    W_mag (magnetic energy [J]). ``sol`` is solve_ivp's dense output."""

    t: np.ndarray
    y: np.ndarray
    data: dict
    drive: CrankDrive
    sol: object
    success: bool
    message: str

    def __getitem__(self, key):
        return self.data[key]

    def time_to_speed(self, psi_dot: float) -> float:
        """First time the crank speed reaches psi_dot [rad/s] (dense output, root
        found to 1e-12 s); NaN if it never does."""
        v = self.y[1] - psi_dot
        k = np.flatnonzero(v >= 0.0)
        if k.size == 0:
            return math.nan
        j = int(k[0])
        if j == 0:
            return float(self.t[0])
        from scipy.optimize import brentq

        return brentq(lambda tt: self.sol(tt)[1] - psi_dot, self.t[j - 1], self.t[j], xtol=1e-12, rtol=1e-14)


def simulate_runup(drive: CrankDrive, t_end: float, load_torque: float | Callable = 0.0, y0=None,
                   rtol: float = 1e-9, atol: float = 1e-10, max_step: float = math.inf,
                   method: str = "DOP853", n_out: int = 2001) -> RunupResult:
    """Integrate the drive from y0 (default: at rest, fluxes zero) to t_end [s].

    load_torque: M_reaction on the crank shaft [N m], a number or a callable
    ``load_torque(t, psi, psi_dot)``; a resisting load is negative for
    psi' > 0. The work integrals are integrated with the state, so the energy
    balance W_motor = E_kin(t) - E_kin(0) + W_load holds to the integrator's
    accuracy. Use method="Radau" or "LSODA" for long dq runs.
    """
    t_end = _positive("t_end", t_end, "s")
    load = load_torque if callable(load_torque) else (lambda t, psi, psi_dot, c=float(load_torque): c)
    n = drive.n_states
    dq = drive.model == "dq"
    n_q = 4 if dq else 2  # quadratures: W_motor, W_load (+ W_el, W_cu)
    y_start = drive.initial_state() if y0 is None else np.asarray(y0, dtype=float)
    if y_start.shape != (n,):
        raise ParameterError(f"y0 must have {n} entries for model {drive.model!r}, got shape {y_start.shape}")

    def f(t, z):
        y = z[:n]
        M = load(t, y[0], y[1])
        dz = np.empty(n + n_q)
        dz[:n] = drive.rhs(t, y, M)
        w_m = drive.i * y[1]
        if dq:
            T, _, P = drive.motor.dq_outputs(t, y[2:6])
            dz[n + 2] = P
            dz[n + 3] = drive.motor.dq_losses_and_energy(y[2:6])[0]
        else:
            T = drive.motor.torque(w_m, t)
        dz[n] = T * w_m
        dz[n + 1] = -M * y[1]
        return dz

    z0 = np.concatenate([y_start, np.zeros(n_q)])
    t_eval = np.linspace(0.0, t_end, n_out)
    from scipy.integrate import solve_ivp

    res = solve_ivp(f, (0.0, t_end), z0, method=method, rtol=rtol, atol=atol, max_step=max_step,
                    t_eval=t_eval, dense_output=True)
    t, z = res.t, res.y
    y = z[:n]
    data = {"psi": y[0], "psi_dot": y[1], "w_motor": drive.i * y[1],
            "M_reaction": np.array([load(tt, a, b) for tt, a, b in zip(t, y[0], y[1])]),
            "W_motor": z[n], "W_load": z[n + 1], "E_kin": 0.5 * drive.J_total * y[1] ** 2}
    if dq:
        outs = np.array([drive.motor.dq_outputs(tt, y[2:6, k]) for k, tt in enumerate(t)])
        data.update(T_motor=outs[:, 0], I_motor=outs[:, 1], P_el=outs[:, 2], W_el=z[n + 2], W_cu=z[n + 3],
                    W_mag=np.array([drive.motor.dq_losses_and_energy(y[2:6, k])[1] for k in range(len(t))]))
    else:
        data["T_motor"] = np.array([drive.motor.torque(drive.i * b, tt) for tt, b in zip(t, y[1])])
    return RunupResult(t=t, y=y, data=data, drive=drive, sol=res.sol, success=bool(res.success),
                       message=str(res.message))
