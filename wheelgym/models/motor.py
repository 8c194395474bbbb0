"""DC motor actuators of the dynamic robots: the torque-speed envelope and the electrical power.

Each motor of ThreeWheel, SkidSteer and CasterAGV is either **ideal** (``motor="ideal"``, the
default: the joint receives the commanded torque, the motor draws exactly the mechanical power
``tau omega``) or a **DC motor** with a gearbox behind a current-controlled drive
(``motor="dc"``), or the same DC motor commanded by its terminal voltage
(``motor="dc_voltage"``). The law is applied inside the derivative, so inside every RK4 stage
(the envelope depends on the joint speed, which changes within a control step).

Per motor (standard permanent-magnet DC motor equations, SI units, ``k_e = k_t``):

| symbol | parameter field   | unit  | meaning                                            |
|--------|-------------------|-------|----------------------------------------------------|
| n      | gear_ratio        | -     | motor turns per joint turn (``omega_m = n omega``) |
| eta    | gear_efficiency   | -     | gearbox efficiency in (0, 1]                       |
| k_t    | k_t               | N·m/A | torque constant, = back-EMF constant k_e in V·s/rad |
| R_w    | R_w               | ohm   | winding resistance                                 |
| V_s    | V_s               | V     | supply voltage (the drive's output is in ±V_s)     |
| I_max  | I_max             | A     | the drive's current limit                          |

Electrical side: ``V = R_w i + e`` with the back-EMF ``e = k_e n omega``; motor torque
``tau_m = k_t i``; electrical power ``P_el = V i = R_w i² + k_t i n omega`` (copper loss plus
the mechanical power at the motor shaft ``tau_m omega_m``).

Drive (``motor="dc"``): the torque command ``tau_c`` (N·m at the joint, what the environment's
action scales to) becomes the current that would produce it, ``i_c = tau_c / (n k_t eta_d)``;
the drive limits it to ``|i| <= I_max`` and can only apply a voltage in ``[-V_s, V_s]``, so

    i = clip(clip(i_c, -I_max, I_max), (-V_s - e) / R_w, (V_s - e) / R_w)

(the voltage limit is the outer, hard one: beyond the no-load speed even ``+V_s`` drives a
braking current). With ``motor="dc_voltage"`` the input is the terminal voltage ``V_c`` (V)
instead: ``i_c = (clip(V_c, -V_s, V_s) - e) / R_w``, then the same clips (the current limiter
lowers the voltage magnitude). Within the limits the drive delivers the commanded torque
exactly, so ``motor="dc"`` differs from ``"ideal"`` only where the envelope binds.

Gear efficiency (the simple choice made here): the gearbox loses the fraction ``1 - eta`` of
the power flowing through it, in either direction. Motoring (``i omega >= 0``) the joint gets
``tau = eta n k_t i``; driven back (``i omega < 0``: braking, regeneration) ``tau = n k_t i /
eta`` (the gear friction helps the brake, and the motor receives ``eta`` of the joint power).
The gear loss ``(1 - eta)`` times the through-flowing power is never negative, so no energy is
created; the price is a jump of the torque per ampere when the joint speed changes sign under
load (a real gearbox's friction does the same). ``eta_d`` in ``i_c`` above is ``eta``
motoring and ``1 / eta`` driven back (decided by the sign of ``tau_c omega``).

The torque-speed envelope at joint speed ``omega >= 0`` (mirror for ``omega < 0``):

    tau_hi(omega) = n eta k_t min(I_max, (V_s - k_e n omega) / R_w)     (motoring)
    tau_lo(omega) = n k_t max(-I_max, (-V_s - k_e n omega) / R_w) / eta (braking)

falling linearly to zero at the no-load joint speed ``omega_0 = V_s / (k_e n)``; the stall
torque is ``n eta k_t min(V_s / R_w, I_max)``.

The packed parameter array of a model holds ``P_MOTOR`` (the mode code, :data:`MODES`) and one
block of :data:`MOTOR_NP` derived values per motor group (:func:`pack_motor`, indices
``M_*`` relative to the block). The compiled :func:`dc_current` / :func:`dc_torque` are
written without branches (selects), so the vectorised block kernels stay vectorised; in
``"ideal"`` mode the derivative selects the commanded torque itself, the same bits as before
the motor model existed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from wheelgym.integrators import llvm_inline

__all__ = [
    "MODES", "MOTOR_IDEAL", "MOTOR_DC", "MOTOR_DC_VOLTAGE", "MOTOR_NP", "M_K", "M_ETA",
    "M_INV_ETA", "M_R", "M_INV_R", "M_VS", "M_IMAX", "M_I_FWD", "M_I_BACK", "GEAR_RATIO",
    "EFFICIENCY", "TORQUE_CONSTANT", "RESISTANCE", "VOLTAGE", "CURRENT", "mode_code",
    "pack_motor", "dc_current", "dc_torque", "ideal_applied", "dc_applied", "dc_power", "envelope",
    "motor_figures", "TABLE_KEYS", "MotorMixin",
]

#: Motor mode codes (``P_MOTOR`` of the packed arrays).
MOTOR_IDEAL = 0.0
MOTOR_DC = 1.0
MOTOR_DC_VOLTAGE = 2.0
#: ``motor`` parameter value -> code.
MODES: Mapping[str, float] = {"ideal": MOTOR_IDEAL, "dc": MOTOR_DC,
                              "dc_voltage": MOTOR_DC_VOLTAGE}

# Physical bounds of the motor parameters (``Params._bounds`` entries).
#: Gear ratio (motor turns per joint turn).
GEAR_RATIO = (1.0, 1e4, "-")
#: Gearbox efficiency.
EFFICIENCY = (0.05, 1.0, "-")
#: Torque constant (N·m/A) = back-EMF constant (V·s/rad).
TORQUE_CONSTANT = (1e-4, 1e2, "N·m/A")
#: Winding resistance (ohm).
RESISTANCE = (1e-4, 1e4, "ohm")
#: Supply voltage (V).
VOLTAGE = (0.1, 1e4, "V")
#: Current limit (A).
CURRENT = (1e-3, 1e4, "A")

#: Offsets inside a motor block of the packed array (:func:`pack_motor`).
(M_K, M_ETA, M_INV_ETA, M_R, M_INV_R, M_VS, M_IMAX, M_I_FWD, M_I_BACK) = range(9)
#: Length of one motor block.
MOTOR_NP = 9


def mode_code(motor: str) -> float:
    """The ``P_MOTOR`` code of a ``motor`` parameter value (``ValueError`` if unknown)."""
    try:
        return MODES[motor]
    except KeyError:
        raise ValueError(f"motor must be one of {list(MODES)}, got {motor!r}") from None


def pack_motor(n: float, eta: float, k_t: float, R_w: float, V_s: float,
               I_max: float) -> list[float]:
    """The derived block of one motor group: ``K = n k_t`` (joint N·m per A before the gear
    loss, and V per joint rad/s of back-EMF), ``eta``, ``1/eta``, ``R_w``, ``1/R_w``, ``V_s``,
    ``I_max``, and the current per commanded joint torque motoring ``1/(K eta)`` and driven
    back ``eta/K`` (offsets ``M_*``)."""
    K = n * k_t
    return [K, eta, 1.0 / eta, R_w, 1.0 / R_w, V_s, I_max, 1.0 / (K * eta), eta / K]


@llvm_inline
def dc_current(u, omega, mode, p, o):  # pragma: no cover - compiled
    """Motor current ``i`` (A) and back-EMF ``e`` (V) of the motor block at ``p[o:]`` for the
    input ``u`` (joint torque command, N·m, or terminal voltage, V, when ``mode`` is
    ``MOTOR_DC_VOLTAGE``) at joint speed ``omega`` (rad/s); module docstring."""
    e = p[o + M_K] * omega  # back-EMF k_e n omega
    vs = p[o + M_VS]
    inv_r = p[o + M_INV_R]
    imax = p[o + M_IMAX]
    # torque command -> current, through the gear efficiency of the power's direction
    i_t = u * (p[o + M_I_FWD] if u * omega >= 0.0 else p[o + M_I_BACK])
    i_v = (min(max(u, -vs), vs) - e) * inv_r  # voltage command
    i = i_v if mode == MOTOR_DC_VOLTAGE else i_t
    i = min(max(i, -imax), imax)  # the drive's current limit
    return min(max(i, (-vs - e) * inv_r), (vs - e) * inv_r), e  # the supply voltage


@llvm_inline
def dc_torque(i, omega, p, o):  # pragma: no cover - compiled
    """Joint torque (N·m) of current ``i`` at joint speed ``omega``: ``eta n k_t i`` motoring,
    ``n k_t i / eta`` driven back (module docstring)."""
    return p[o + M_K] * i * (p[o + M_ETA] if i * omega >= 0.0 else p[o + M_INV_ETA])


@llvm_inline
def ideal_applied(u, omega, mode, p, o):  # pragma: no cover - compiled
    """The ideal motor: the joint gets the command ``u`` (the derivative of the ideal-motor
    kernels, which compute exactly the bits of the model before the motor law)."""
    return u


@llvm_inline
def dc_applied(u, omega, mode, p, o):  # pragma: no cover - compiled
    """The joint torque the motor applies: ``u`` itself in ideal mode (``mode == 0``, the same
    bits), else the DC motor's torque for the input ``u`` at joint speed ``omega``."""
    i, _ = dc_current(u, omega, mode, p, o)
    t = dc_torque(i, omega, p, o)
    return t if mode != MOTOR_IDEAL else u


@llvm_inline
def dc_power(u, omega, mode, p, o):  # pragma: no cover - compiled
    """Electrical power ``V i = i (R_w i + e)`` (W) the motor draws for input ``u`` at joint
    speed ``omega`` (DC modes)."""
    i, e = dc_current(u, omega, mode, p, o)
    return i * (p[o + M_R] * i + e)


def envelope(omega: np.ndarray, n: np.ndarray, eta: np.ndarray, k_t: np.ndarray,
             R_w: np.ndarray, V_s: np.ndarray, I_max: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """``(tau_lo, tau_hi)`` (N·m): the joint torques a DC motor can apply at joint speed
    ``omega`` (rad/s), per the module docstring (NumPy; arguments broadcast)."""
    omega = np.asarray(omega, dtype=np.float64)
    e = k_t * n * omega
    lo_v = (-V_s - e) / R_w  # currents the supply voltage allows against the back-EMF
    hi_v = (V_s - e) / R_w
    i_hi = np.minimum(np.maximum(I_max, lo_v), hi_v)  # the current limit, then the voltage
    i_lo = np.minimum(np.maximum(-I_max, lo_v), hi_v)

    def torque(i: np.ndarray) -> np.ndarray:
        return n * k_t * i * np.where(i * omega >= 0.0, eta, 1.0 / eta)

    return torque(i_lo), torque(i_hi)


def motor_figures(n: float, eta: float, k_t: float, R_w: float, V_s: float,
                  I_max: float) -> dict[str, float]:
    """Stall torque (N·m), no-load joint speed (rad/s) and the corner speed where the current
    limit stops binding (rad/s) of one motor."""
    return {"stall_torque": n * eta * k_t * min(V_s / R_w, I_max),
            "no_load_speed": V_s / (k_t * n),
            "corner_speed": max(0.0, (V_s - I_max * R_w) / (k_t * n))}


#: Keys of ``Params.motor_table()``: per-motor arrays in motor (input) order.
TABLE_KEYS = ("gear_ratio", "gear_efficiency", "k_t", "R_w", "V_s", "I_max")


class MotorMixin:
    """DC-motor methods of the dynamic models (ThreeWheel, SkidSteer, CasterAGV).

    The model provides ``_k_motor(X, U, p, out)`` (its kernel module's ``k_motor``: per row
    and motor the joint rate, applied torque, current and voltage, ``out (N, 4, m)``) and its
    parameters ``motor`` and ``motor_table()`` (per-motor arrays, :data:`TABLE_KEYS`). Inputs
    are ``(..., n)`` states and ``(..., m)`` inputs as in :meth:`Model.step`.

    | method             | returns                                          | unit  |
    |--------------------|--------------------------------------------------|-------|
    | applied_torque     | joint torques the motors apply, ``(..., m)``     | N·m   |
    | motor_current      | currents ``(..., m)`` (0 for ideal motors)       | A     |
    | motor_voltage      | terminal voltages ``(..., m)`` (0 for ideal)     | V     |
    | electrical_power   | ``sum V i`` (DC) or ``tau . qdot`` (ideal)       | W     |
    | copper_loss        | ``sum R_w i²`` (0 for ideal motors)              | W     |
    | shaft_power        | ``sum k_t i n omega`` (DC) or ``tau . qdot``     | W     |
    | stall_torque       | ``n eta k_t min(V_s / R_w, I_max)`` per motor    | N·m   |
    | no_load_speed      | ``V_s / (k_e n)`` per motor (joint)              | rad/s |
    | torque_envelope    | ``(tau_lo, tau_hi)`` at joint speeds ``omega``   | N·m   |
    """

    params: Any
    _p: np.ndarray
    #: The kernel module (``dc_kernels()``: the model's batch kernels with the DC law).
    _kern_module: Any = None

    def _bind_kernels(self) -> None:
        """DC motors step with the kernels compiled with the motor law (the kernel module's
        ``dc_kernels()``, compiled on first use); ideal motors keep the class's kernels, the
        code (and bits and speed) of the model before the motor law."""
        if self.dc:
            k = self._kern_module.dc_kernels()
            self._kd, self._ks, self._ksp = k.deriv, k.step, k.step_par
            self._step1, self._deriv1 = k.step1, k.deriv1

    @property
    def dc(self) -> bool:
        """Whether the motors are DC motors (``motor`` not ``"ideal"``)."""
        return self.params.motor != "ideal"

    def motor_state(self, x: Any, u: Any) -> np.ndarray:
        """``(..., 4, m)``: joint rate (rad/s), applied torque (N·m), current (A) and terminal
        voltage (V) of each motor, from the compiled law the derivative uses."""
        X, U, lead = self._prepare(x, u)  # type: ignore[attr-defined]
        out = np.empty((X.shape[0], 4, U.shape[1]))
        type(self)._k_motor(X, U, self._p, out)  # type: ignore[attr-defined]
        return out.reshape(lead + out.shape[1:])

    def applied_torque(self, x: Any, u: Any) -> np.ndarray:
        """Joint torques the motors apply (N·m): ``u`` itself for ideal motors."""
        return self.motor_state(x, u)[..., 1, :]

    def motor_current(self, x: Any, u: Any) -> np.ndarray:
        """Motor currents (A); zeros for ideal motors."""
        s = self.motor_state(x, u)[..., 2, :]
        return s if self.dc else np.zeros_like(s)

    def motor_voltage(self, x: Any, u: Any) -> np.ndarray:
        """Terminal voltages ``V = R_w i + k_e n omega`` (V); zeros for ideal motors."""
        s = self.motor_state(x, u)[..., 3, :]
        return s if self.dc else np.zeros_like(s)

    def electrical_power(self, x: Any, u: Any) -> np.ndarray:
        """Power drawn from the supply ``sum V i`` (W; negative when regenerating). Ideal
        motors convert without loss: their mechanical power ``tau . qdot``."""
        if not self.dc:
            return self.motor_power(x, u)  # type: ignore[attr-defined]
        s = self.motor_state(x, u)
        return np.sum(s[..., 3, :] * s[..., 2, :], axis=-1)

    def copper_loss(self, x: Any, u: Any) -> np.ndarray:
        """Winding loss ``sum R_w i²`` (W); 0 for ideal motors."""
        s = self.motor_state(x, u)
        if not self.dc:
            return np.zeros(s.shape[:-2])
        return np.sum(self.params.motor_table()["R_w"] * s[..., 2, :] ** 2, axis=-1)

    def shaft_power(self, x: Any, u: Any) -> np.ndarray:
        """Mechanical power at the motor shafts ``sum k_t i n omega`` (W; the joint power
        before the gear loss); ideal motors: ``tau . qdot``."""
        if not self.dc:
            return self.motor_power(x, u)  # type: ignore[attr-defined]
        s = self.motor_state(x, u)
        t = self.params.motor_table()
        return np.sum(t["k_t"] * t["gear_ratio"] * s[..., 2, :] * s[..., 0, :], axis=-1)

    def stall_torque(self) -> np.ndarray:
        """``n eta k_t min(V_s / R_w, I_max)`` per motor (N·m), at zero joint speed."""
        t = self.params.motor_table()
        return t["gear_ratio"] * t["gear_efficiency"] * t["k_t"] * np.minimum(
            t["V_s"] / t["R_w"], t["I_max"])

    def no_load_speed(self) -> np.ndarray:
        """``V_s / (k_e n)`` per motor (rad/s at the joint), where the torque reaches 0."""
        t = self.params.motor_table()
        return t["V_s"] / (t["k_t"] * t["gear_ratio"])

    def torque_envelope(self, omega: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(tau_lo, tau_hi)`` (N·m) of each motor at joint speeds ``omega`` ``(..., m)``
        (rad/s), the DC motor's limits whatever ``motor`` is (:func:`envelope`)."""
        t = self.params.motor_table()
        return envelope(np.asarray(omega, dtype=np.float64), t["gear_ratio"],
                        t["gear_efficiency"], t["k_t"], t["R_w"], t["V_s"], t["I_max"])
