"""Four-wheel skid-steer robot, Kozlowski-Pazderski model (docs/physics/skid-steer.md).

State ``x = (x, y, yaw, vx, wz)`` (m, m, rad, m/s, rad/s); input ``u = (tau_1, tau_2, tau_3,
tau_4)`` (N·m), wheels 1 rear-left, 2 front-left, 3 front-right, 4 rear-right. The lateral
body velocity follows from the ICR constraint ``vy = -x_icr wz`` (SS-1), so it is not a state.

Dynamics (SS-3): ``Mbar etadot + Cbar eta + Rbar = Bbar (tau_L, tau_R)`` with
``eta = (vx, wz)``, ``tau_L = tau_1 + tau_2``, ``tau_R = tau_3 + tau_4``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import numpy as np

from wheelgym.models._base import (
    COEFFICIENT,
    GRAVITY,
    INERTIA,
    LENGTH,
    MASS,
    SIGNED_LENGTH,
    SMOOTHING,
    TORQUE,
    Model,
    Params,
)
from wheelgym.models.kernels import skid_steer as _kern
from wheelgym.models.motor import (
    CURRENT,
    EFFICIENCY,
    GEAR_RATIO,
    MODES,
    RESISTANCE,
    TORQUE_CONSTANT,
    VOLTAGE,
    MotorMixin,
    mode_code,
    pack_motor,
)

__all__ = ["SkidSteerParams", "SkidSteer"]


@dataclasses.dataclass(frozen=True)
class SkidSteerParams(Params):
    """Skid-steer parameters (docs/physics/skid-steer.md; defaults: a Clearpath Husky-like robot).

    | name     | default | unit  | meaning                                                  |
    |----------|---------|-------|----------------------------------------------------------|
    | m        | 56.6    | kg    | total mass                                               |
    | I        | 3.6     | kg m² | yaw inertia about the centre of mass                     |
    | a        | 0.286   | m     | centre of mass to rear axle                              |
    | b        | 0.226   | m     | centre of mass to front axle                             |
    | c        | 0.2854  | m     | half track                                               |
    | r        | 0.1651  | m     | wheel radius                                             |
    | x_icr    | -0.03   | m     | ICR x coordinate in B (``vy = -x_icr wz``), in (-a, b)   |
    | mu_s     | 0.03    | -     | longitudinal rolling-resistance coefficient              |
    | mu_l     | 0.6     | -     | lateral sliding-friction coefficient                     |
    | k_s      | 100.0   | s/m   | arctan smoothing of the friction sign                    |
    | g        | 9.81    | m/s²  | gravity                                                  |
    | tau_max  | 30.0    | N·m   | torque limit of each motor                               |
    | motor    | "ideal" | -     | "ideal", "dc" or "dc_voltage" (models/motor.py)          |
    | gear_ratio | 40.0  | -     | gearbox ratio n (four equal motors)                      |
    | gear_efficiency | 0.8 | -  | gearbox efficiency eta                                   |
    | k_t      | 0.05    | N·m/A | torque constant (= k_e, V·s/rad)                         |
    | R_w      | 0.3     | ohm   | winding resistance                                       |
    | V_s      | 24.0    | V     | supply voltage                                           |
    | I_max    | 20.0    | A     | current limit of each drive                              |

    DC motors (``motor="dc"``, :mod:`wheelgym.models.motor`): stall torque
    ``n eta k_t min(V_s / R_w, I_max) = 40 * 0.8 * 0.05 * min(80, 20) = 32 N·m``
    (>= ``tau_max``), falling linearly above the corner speed ``(V_s - I_max R_w) / (k_e n)
    = 9 rad/s`` (1.49 m/s) to zero at the no-load joint speed ``V_s / (k_e n) = 12 rad/s``
    (1.98 m/s of wheel speed). With ``motor="ideal"`` these fields are unused.
    """

    m: float = 56.6
    I: float = 3.6
    a: float = 0.286
    b: float = 0.226
    c: float = 0.2854
    r: float = 0.1651
    x_icr: float = -0.03
    mu_s: float = 0.03
    mu_l: float = 0.6
    k_s: float = 100.0
    g: float = 9.81
    tau_max: float = 30.0
    motor: str = "ideal"
    gear_ratio: float = 40.0
    gear_efficiency: float = 0.8
    k_t: float = 0.05
    R_w: float = 0.3
    V_s: float = 24.0
    I_max: float = 20.0

    _choices: ClassVar[dict[str, tuple[str, ...]]] = {"motor": tuple(MODES)}
    _positive: ClassVar[tuple[str, ...]] = ("m", "I", "a", "b", "c", "r", "k_s", "g", "tau_max")
    _nonnegative: ClassVar[tuple[str, ...]] = ("mu_s", "mu_l")
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "m": MASS, "I": INERTIA, "a": LENGTH, "b": LENGTH, "c": LENGTH, "r": LENGTH,
        "x_icr": SIGNED_LENGTH, "mu_s": COEFFICIENT, "mu_l": COEFFICIENT, "k_s": SMOOTHING,
        "g": GRAVITY, "tau_max": TORQUE, "gear_ratio": GEAR_RATIO,
        "gear_efficiency": EFFICIENCY, "k_t": TORQUE_CONSTANT, "R_w": RESISTANCE,
        "V_s": VOLTAGE, "I_max": CURRENT,
    }

    def _check(self) -> None:
        if not -self.a < self.x_icr < self.b:
            raise ValueError(
                f"SkidSteerParams.x_icr must lie between the axles, in (-a, b) = "
                f"({-self.a}, {self.b}), got {self.x_icr}"
            )

    def pack(self) -> np.ndarray:
        """The packed array in the layout of the ``P_*`` indices of
        :mod:`wheelgym.models.kernels.skid_steer`."""
        return np.array(
            [self.m, self.I, self.a, self.b, self.c, self.r, self.x_icr, self.mu_s, self.mu_l,
             self.k_s, self.g, self.tau_max, 1.0 / self.r, mode_code(self.motor),
             *pack_motor(self.gear_ratio, self.gear_efficiency, self.k_t, self.R_w, self.V_s,
                         self.I_max)],
            dtype=np.float64,
        )

    def motor_table(self) -> dict[str, np.ndarray]:
        """DC-motor parameters per motor (four equal motors; keys
        :data:`wheelgym.models.motor.TABLE_KEYS`)."""
        return {k: np.full(4, float(getattr(self, k))) for k in
                ("gear_ratio", "gear_efficiency", "k_t", "R_w", "V_s", "I_max")}

    # Derived quantities -------------------------------------------------------------
    @property
    def wheel_positions(self) -> np.ndarray:
        """Wheel contact points ``(x_i, y_i)`` in B, wheels 1..4 (docs/physics/skid-steer.md)."""
        return np.array([[-self.a, self.c], [self.b, self.c], [self.b, -self.c],
                         [-self.a, -self.c]])

    @property
    def normal_loads(self) -> np.ndarray:
        """Static normal loads ``N_i`` (N), wheels 1..4 (SS-2)."""
        n_rear = self.b * self.m * self.g / (2.0 * (self.a + self.b))
        n_front = self.a * self.m * self.g / (2.0 * (self.a + self.b))
        return np.array([n_rear, n_front, n_front, n_rear])


# ---------------------------------------------------------------------------- the model
class SkidSteer(MotorMixin, Model):
    """Four-wheel skid-steer robot (Kozlowski-Pazderski, docs/physics/skid-steer.md).

    | index | state | unit  |   | index | input | unit |
    |-------|-------|-------|---|-------|-------|------|
    | 0     | x     | m     |   | 0     | tau_1 (rear-left)   | N·m |
    | 1     | y     | m     |   | 1     | tau_2 (front-left)  | N·m |
    | 2     | yaw   | rad   |   | 2     | tau_3 (front-right) | N·m |
    | 3     | vx    | m/s   |   | 3     | tau_4 (rear-right)  | N·m |
    | 4     | wz    | rad/s |   |       |       |      |

    Default ``sim_dt = 0.00125 s`` (40 substeps per 0.05 s control step). The stiffest mode
    is the yaw rate near ``v_iy = 0``, where ``dRbar_2/dwz = (2 k_s/pi) (mu_l sum N_i
    (x_i - x_icr)^2 + mu_s sum N_i y_i^2)`` over ``m x_icr^2 + I`` gives about 405 1/s at the
    defaults (:meth:`stiffness`); RK4's real stability limit is ``|lambda| dt < 2.785``, so
    0.002 s (0.81) would be stable, but its error over the 5 s validation manoeuvre is
    1.3e-6 of the state scale (bound 1e-6), against 3.6e-8 at 0.00125 s: the arctan friction
    bends sharply (over 1 cm/s of slip speed) each time a contact velocity changes sign.
    """

    state_names = ("x", "y", "yaw", "vx", "wz")
    input_names = ("tau_1", "tau_2", "tau_3", "tau_4")
    params_type = SkidSteerParams
    default_sim_dt = 0.00125

    friction_params = ("mu_s", "mu_l")

    _k_deriv = _kern.KERNELS.deriv
    _k_step = _kern.KERNELS.step
    _k_step_par = _kern.KERNELS.step_par
    _k_step1 = _kern.KERNELS.step1
    _k_deriv1 = _kern.KERNELS.deriv1
    _k_motor = _kern.k_motor
    _kern_module = _kern

    params: SkidSteerParams

    # SS-3 pieces ------------------------------------------------------------------
    def mbar(self) -> np.ndarray:
        """``Mbar = [[m, 0], [0, m x_icr^2 + I]]`` (SS-3)."""
        p = self.params
        return np.array([[p.m, 0.0], [0.0, p.m * p.x_icr**2 + p.I]])

    def cbar(self, x: np.ndarray) -> np.ndarray:
        """``Cbar(eta) = m x_icr [[0, wz], [-wz, 0]]`` (SS-3); shape ``(..., 2, 2)``."""
        wz = np.asarray(x, dtype=np.float64)[..., 4]
        k = self.params.m * self.params.x_icr * wz
        out = np.zeros(wz.shape + (2, 2))
        out[..., 0, 1] = k
        out[..., 1, 0] = -k
        return out

    def bbar(self) -> np.ndarray:
        """``Bbar = (1/r) [[1, 1], [-c, c]]`` acting on ``(tau_L, tau_R)`` (SS-3)."""
        p = self.params
        return np.array([[1.0, 1.0], [-p.c, p.c]]) / p.r

    def rbar(self, x: np.ndarray) -> np.ndarray:
        """Resistance ``Rbar(eta)`` of SS-2/SS-3, shape ``(..., 2)``."""
        return self._resist(x)[..., :2]

    @property
    def input_high(self) -> np.ndarray:
        """Upper torque limit of each motor (N·m); the lower limit is its negative."""
        return np.full(4, self.params.tau_max)

    def normal_loads(self) -> np.ndarray:
        """Static wheel loads ``N_i`` (N), wheels 1..4 (SS-2)."""
        return self.params.normal_loads

    def _resist(self, x: np.ndarray) -> np.ndarray:
        X = self._as_batch(x, self.state_dim, "x")
        E = np.ascontiguousarray(X[..., 3:5].reshape(-1, 2))
        out = np.empty((E.shape[0], 3))
        _kern.k_resist(E, self._p, out)
        return out.reshape(X.shape[:-1] + (3,))

    # Kinematics ---------------------------------------------------------------------
    def wheel_speeds(self, x: np.ndarray) -> np.ndarray:
        """``(omega_L, omega_R) = ((vx - c wz)/r, (vx + c wz)/r)`` (SS-1), rad/s."""
        X = self._as_batch(x, self.state_dim, "x")
        p = self.params
        return np.stack([(X[..., 3] - p.c * X[..., 4]) / p.r,
                         (X[..., 3] + p.c * X[..., 4]) / p.r], axis=-1)

    def joint_velocity(self, x: np.ndarray) -> np.ndarray:
        """Wheel rates in motor order (rad/s): ``(omega_L, omega_L, omega_R, omega_R)``."""
        w = self.wheel_speeds(x)
        return w[..., [0, 0, 1, 1]]

    def body_twist(self, x: np.ndarray) -> np.ndarray:
        """``(vx, vy, wz)`` in B with ``vy = -x_icr wz`` (SS-1)."""
        X = self._as_batch(x, self.state_dim, "x")
        return np.stack([X[..., 3], -self.params.x_icr * X[..., 4], X[..., 4]], axis=-1)

    # Energy ---------------------------------------------------------------------------
    def kinetic_energy(self, x: np.ndarray) -> np.ndarray:
        """``T = m (vx^2 + vy^2)/2 + I wz^2/2`` (J)."""
        X = self._as_batch(x, self.state_dim, "x")
        p = self.params
        return 0.5 * p.m * X[..., 3] ** 2 + 0.5 * (p.m * p.x_icr**2 + p.I) * X[..., 4] ** 2

    def motor_power(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Mechanical power of the motors at the joints, ``sum tau_k omega_k`` (W); ``tau`` the
        applied torques (the command for ideal motors, :meth:`applied_torque`)."""
        U = self.applied_torque(x, u) if self.dc else self._as_batch(u, self.input_dim, "u")
        return np.sum(U * self.joint_velocity(x), axis=-1)

    def friction_power(self, x: np.ndarray) -> np.ndarray:
        """Power of the friction forces, ``-sum (F_si v_ix + F_li v_iy)`` (W, <= 0)."""
        return self._resist(x)[..., 2]

    def stiffness(self) -> float:
        """Largest friction eigenvalue magnitude (1/s) at zero velocity (see class docstring).

        RK4 is stable for real eigenvalues with ``|lambda| sim_dt < 2.785``.
        """
        p = self.params
        pos = p.wheel_positions
        n = p.normal_loads
        k = 2.0 * p.k_s / math.pi
        lat = k * p.mu_l * np.sum(n * (pos[:, 0] - p.x_icr) ** 2)
        lon_w = k * p.mu_s * np.sum(n * pos[:, 1] ** 2)
        lam_w = (lat + lon_w) / (p.m * p.x_icr**2 + p.I)
        lam_v = k * p.mu_s * np.sum(n) / p.m
        return float(max(lam_w, lam_v))
