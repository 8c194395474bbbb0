"""Three-wheel redundantly actuated robot with off-centred steerable wheels
(docs/physics/three-wheel.md).

A platform carries three caster modules (wheel 1 rear-left, 2 rear-right, 3 front). Each module
has a steering motor at its vertical axis ``A_i`` and a drive motor on the wheel axle, so six
motors drive three degrees of freedom (force redundancy, three-wheel paper section 4).

State ``x = (x, y, yaw, vx, vy, wz, psi_1, psi_2, psi_3, theta_1, theta_2, theta_3)`` (TW-5);
input ``tau = (drive_1, drive_2, drive_3, steer_1, steer_2, steer_3)`` (N·m, motor order).

Dynamics in the body twist ``u = (vx, vy, wz)`` (docs/physics/three-wheel.md TW-3,
three-wheel paper (26)):

    M(psi) udot + c(psi, u) = J(psi)^T tau + Q_f(psi, u)

The compiled kernels (:mod:`wheelgym.models.kernels.three_wheel`) evaluate the closed form of
TW-3. :func:`wheelgym.models.noc_reference.noc_terms` derives the same ``M`` and ``c`` the long
way, with the natural orthogonal complement of the paper (17)-(29); the tests check that both
agree to 1e-12.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from wheelgym.integrators import kernel_array
from wheelgym.models._base import (
    COEFFICIENT,
    DAMPING,
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
from wheelgym.models.kernels import three_wheel as _kern
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

__all__ = ["ThreeWheelParams", "ThreeWheel", "RK4_REAL_STABILITY_LIMIT"]

#: RK4's stability region reaches ``lambda dt = -2.785`` on the negative real axis.
RK4_REAL_STABILITY_LIMIT = 2.785


def _cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


@dataclasses.dataclass(frozen=True)
class ThreeWheelParams(Params):
    """Three-wheel robot parameters (docs/physics/three-wheel.md; defaults: a research AGV
    of ~25 kg).

    | name          | default | unit      | meaning                                      |
    |---------------|---------|-----------|----------------------------------------------|
    | m_b           | 20.0    | kg        | platform mass                                |
    | I_b           | 1.0     | kg m²     | platform yaw inertia about its CoM           |
    | m_w           | 1.0     | kg        | module mass (at the wheel centre)            |
    | I_wy          | 0.0028  | kg m²     | wheel spin inertia                           |
    | I_wz          | 0.005   | kg m²     | module yaw inertia about the wheel centre    |
    | r             | 0.075   | m         | wheel radius                                 |
    | d             | 0.04    | m         | caster trail, steering axis to wheel centre  |
    | axes          | see below | m       | steering-axis positions a_i in B, (3, 2)     |
    | mu_r          | 0.015   | -         | rolling-resistance coefficient               |
    | mu_p          | 0.008   | m         | pivot (scrub) friction length                |
    | rho           | 0.015   | m         | contact-patch radius (scrub slip speed)      |
    | b_drive       | 0.01    | N·m·s/rad | viscous drive-joint friction                 |
    | b_steer       | 0.01    | N·m·s/rad | viscous steering-joint friction              |
    | k_s           | 100.0   | s/m       | arctan smoothing of the friction sign        |
    | g             | 9.81    | m/s²      | gravity                                      |
    | tau_drive_max | 6.0     | N·m       | drive-motor torque limit                     |
    | tau_steer_max | 3.0     | N·m       | steering-motor torque limit                  |
    | motor         | "ideal" | -         | "ideal", "dc" or "dc_voltage" (models/motor.py) |
    | V_s           | 24.0    | V         | supply voltage of all six motors             |
    | gear_ratio_drive | 20.0 | -         | drive gearbox ratio n                        |
    | gear_efficiency_drive | 0.85 | -    | drive gearbox efficiency eta                 |
    | k_t_drive     | 0.05    | N·m/A     | drive torque constant (= k_e, V·s/rad)       |
    | R_w_drive     | 1.2     | ohm       | drive winding resistance                     |
    | I_max_drive   | 10.0    | A         | drive current limit                          |
    | gear_ratio_steer | 30.0 | -         | steering gearbox ratio n                     |
    | gear_efficiency_steer | 0.8 | -     | steering gearbox efficiency eta              |
    | k_t_steer     | 0.03    | N·m/A     | steering torque constant (= k_e, V·s/rad)    |
    | R_w_steer     | 2.0     | ohm       | steering winding resistance                  |
    | I_max_steer   | 5.0     | A         | steering current limit                       |

    DC motors (``motor="dc"``, the law of :mod:`wheelgym.models.motor`): the drive motors'
    stall torque is ``n eta k_t min(V_s / R_w, I_max) = 20 * 0.85 * 0.05 * min(20, 10) =
    8.5 N·m`` (>= ``tau_drive_max``), falling linearly above the corner speed
    ``(V_s - I_max R_w) / (k_e n) = 12 rad/s`` (0.9 m/s of wheel speed) to zero at the
    no-load joint speed ``V_s / (k_e n) = 24 rad/s`` (1.8 m/s, below the env's 2.0 m/s
    overspeed limit: docs/topics/motors.md); the steering motors' stall
    torque is ``30 * 0.8 * 0.03 * min(12, 5) = 3.6 N·m`` (>= ``tau_steer_max``), corner
    15.6 rad/s, no-load 26.7 rad/s. With ``motor="ideal"`` these fields are unused.
    ``axes`` defaults to ``((-0.20, 0.20), (-0.20, -0.20), (0.25, 0.0))``: wheel 1
    rear-left, 2 rear-right, 3 front.

    The body origin is the platform's centre of mass; it must lie strictly inside the triangle
    of the wheel centres ``p_i = a_i - d e_i`` at ``psi = 0`` (else some static normal load of
    TW-4 is negative), and the three steering axes must not be collinear.
    """

    m_b: float = 20.0
    I_b: float = 1.0
    m_w: float = 1.0
    I_wy: float = 0.0028
    I_wz: float = 0.005
    r: float = 0.075
    d: float = 0.04
    axes: tuple[tuple[float, float], ...] = ((-0.20, 0.20), (-0.20, -0.20), (0.25, 0.0))
    mu_r: float = 0.015
    mu_p: float = 0.008
    rho: float = 0.015
    b_drive: float = 0.01
    b_steer: float = 0.01
    k_s: float = 100.0
    g: float = 9.81
    tau_drive_max: float = 6.0
    tau_steer_max: float = 3.0
    motor: str = "ideal"
    V_s: float = 24.0
    gear_ratio_drive: float = 20.0
    gear_efficiency_drive: float = 0.85
    k_t_drive: float = 0.05
    R_w_drive: float = 1.2
    I_max_drive: float = 10.0
    gear_ratio_steer: float = 30.0
    gear_efficiency_steer: float = 0.8
    k_t_steer: float = 0.03
    R_w_steer: float = 2.0
    I_max_steer: float = 5.0

    _choices: ClassVar[dict[str, tuple[str, ...]]] = {"motor": tuple(MODES)}
    _positive: ClassVar[tuple[str, ...]] = (
        "m_b", "I_b", "m_w", "I_wy", "I_wz", "r", "d", "rho", "k_s", "g",
        "tau_drive_max", "tau_steer_max",
    )
    _nonnegative: ClassVar[tuple[str, ...]] = ("mu_r", "mu_p", "b_drive", "b_steer")
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "m_b": MASS, "m_w": MASS, "I_b": INERTIA, "I_wy": INERTIA, "I_wz": INERTIA,
        "r": LENGTH, "d": LENGTH, "axes": SIGNED_LENGTH, "mu_r": COEFFICIENT,
        "mu_p": (0.0, LENGTH[1], "m"), "rho": LENGTH, "b_drive": DAMPING, "b_steer": DAMPING,
        "k_s": SMOOTHING, "g": GRAVITY, "tau_drive_max": TORQUE, "tau_steer_max": TORQUE,
        "V_s": VOLTAGE, "gear_ratio_drive": GEAR_RATIO, "gear_efficiency_drive": EFFICIENCY,
        "k_t_drive": TORQUE_CONSTANT, "R_w_drive": RESISTANCE, "I_max_drive": CURRENT,
        "gear_ratio_steer": GEAR_RATIO, "gear_efficiency_steer": EFFICIENCY,
        "k_t_steer": TORQUE_CONSTANT, "R_w_steer": RESISTANCE, "I_max_steer": CURRENT,
    }

    def _check(self) -> None:
        a = np.asarray(self.axes, dtype=np.float64)
        if a.shape != (3, 2):
            raise ValueError(
                f"ThreeWheelParams.axes must be three (x, y) pairs, shape (3, 2), got shape "
                f"{a.shape}"
            )
        scale = max(float(np.max(np.abs(a))), self.d)
        area2 = _cross2(a[1] - a[0], a[2] - a[0])
        if abs(area2) <= 1e-9 * scale * scale:
            raise ValueError(
                f"ThreeWheelParams.axes are collinear (twice the triangle area is {area2:.3g} "
                "m²); the three steering axes must span a triangle"
            )
        p = a - self.d * np.array([1.0, 0.0])  # wheel centres at psi = 0 (TW-1)
        c23, c31, c12 = _cross2(p[1], p[2]), _cross2(p[2], p[0]), _cross2(p[0], p[1])
        tot = c23 + c31 + c12
        if abs(tot) <= 1e-9 * scale * scale:
            raise ValueError("ThreeWheelParams.axes: the wheel centres at psi = 0 are collinear")
        fractions = (c23 / tot, c31 / tot, c12 / tot)
        if min(fractions) <= 0.0:
            raise ValueError(
                "ThreeWheelParams.axes: the centre of mass (body origin) must lie strictly "
                "inside the triangle of the wheel centres a_i - d e_i at psi = 0, else a "
                f"normal load of TW-4 is <= 0; the load fractions are {fractions}"
            )

    # Derived quantities -------------------------------------------------------------
    @property
    def k_w(self) -> float:
        """Rolling inertia per module ``m_w + I_wy / r^2`` (kg), TW-3."""
        return self.m_w + self.I_wy / self.r**2

    @property
    def k_z(self) -> float:
        """Pivot inertia per module ``I_wz / d^2`` (kg), TW-3."""
        return self.I_wz / self.d**2

    @property
    def m_total(self) -> float:
        """Total mass ``m_b + 3 m_w`` (kg)."""
        return self.m_b + 3.0 * self.m_w

    @property
    def tau_max(self) -> np.ndarray:
        """Torque limits in motor order ``[drive_1..3, steer_1..3]`` (N·m)."""
        return np.array([self.tau_drive_max] * 3 + [self.tau_steer_max] * 3)

    def motor_table(self) -> dict[str, np.ndarray]:
        """DC-motor parameters per motor in motor order ``[drive_1..3, steer_1..3]``
        (keys :data:`wheelgym.models.motor.TABLE_KEYS`)."""
        def rows(drive: float, steer: float) -> np.ndarray:
            return np.array([drive] * 3 + [steer] * 3, dtype=np.float64)
        return {
            "gear_ratio": rows(self.gear_ratio_drive, self.gear_ratio_steer),
            "gear_efficiency": rows(self.gear_efficiency_drive, self.gear_efficiency_steer),
            "k_t": rows(self.k_t_drive, self.k_t_steer),
            "R_w": rows(self.R_w_drive, self.R_w_steer),
            "V_s": rows(self.V_s, self.V_s),
            "I_max": rows(self.I_max_drive, self.I_max_steer),
        }

    @property
    def axes_array(self) -> np.ndarray:
        """Steering-axis positions ``a_i`` in B, shape ``(3, 2)`` (m)."""
        return np.asarray(self.axes, dtype=np.float64).reshape(3, 2)

    def pack(self) -> np.ndarray:
        """The packed array in the layout of the ``P_*`` indices of
        :mod:`wheelgym.models.kernels.three_wheel`."""
        a = self.axes_array
        # M(psi) = M_0 + (k_w - k_z) sum_i g_i g_i^T: since g_i g_i^T + h_i h_i^T does not
        # depend on psi_i (it is [[1, 0, -ay], [0, 1, ax], [-ay, ax, ax^2 + ay^2]]), the k_z
        # part of TW-3's M is constant and goes into M_0 with the platform.
        kz = self.k_z
        m0 = [self.m_b + 3.0 * kz, 0.0, -kz * float(np.sum(a[:, 1])),
              self.m_b + 3.0 * kz, kz * float(np.sum(a[:, 0])),
              self.I_b + kz * float(np.sum(a * a))]
        return np.array(
            [self.m_b, self.I_b, self.m_w, self.I_wy, self.I_wz, self.r, self.d,
             a[0, 0], a[0, 1], a[1, 0], a[1, 1], a[2, 0], a[2, 1],
             self.mu_r, self.mu_p, self.rho, self.b_drive, self.b_steer, self.k_s, self.g,
             self.tau_drive_max, self.tau_steer_max, self.k_w, self.k_z, self.m_total,
             1.0 / self.d, 1.0 / self.r, *m0, mode_code(self.motor),
             *pack_motor(self.gear_ratio_drive, self.gear_efficiency_drive, self.k_t_drive,
                         self.R_w_drive, self.V_s, self.I_max_drive),
             *pack_motor(self.gear_ratio_steer, self.gear_efficiency_steer, self.k_t_steer,
                         self.R_w_steer, self.V_s, self.I_max_steer)],
            dtype=np.float64,
        )


# ---------------------------------------------------------------------------- the model
class ThreeWheel(MotorMixin, Model):
    """Three-wheel redundantly actuated robot with steerable off-centred wheels
    (docs/physics/three-wheel.md).

    | index | state   | unit  |   | index | input   | unit |
    |-------|---------|-------|---|-------|---------|------|
    | 0     | x       | m     |   | 0     | drive_1 (rear-left)  | N·m |
    | 1     | y       | m     |   | 1     | drive_2 (rear-right) | N·m |
    | 2     | yaw     | rad   |   | 2     | drive_3 (front)      | N·m |
    | 3     | vx      | m/s   |   | 3     | steer_1 | N·m  |
    | 4     | vy      | m/s   |   | 4     | steer_2 | N·m  |
    | 5     | wz      | rad/s |   | 5     | steer_3 | N·m  |
    | 6-8   | psi_1..3   | rad |  |       |         |      |
    | 9-11  | theta_1..3 | rad |  |       |         |      |

    Stability of the default ``sim_dt = 0.002 s``: the stiffest mode is the friction at rest,
    the largest ``|lambda|`` of ``M^-1 dQ_f/du`` at ``u = 0`` (dominated by the pivot scrub,
    ``mu_p N_i (2 k_s / pi) rho / d^2`` along ``h_i``). At the defaults it is 50.4 1/s, the
    maximum over all steering angles (:meth:`stiffness`; 47.6 1/s at ``psi = 0``), so
    ``|lambda| sim_dt = 0.10``, 27x inside RK4's real stability limit ``|lambda| dt < 2.785``
    (the largest stable step is about 55 ms).

    The casters add a speed-dependent mode: linearising TW-1 about a trailing caster gives
    ``d(psi_i)/dt = -(g_i.u / d) dpsi_i``, a decay at ``|v| / d`` (75 1/s at 3 m/s, so
    ``|lambda| sim_dt = 0.15``). Rolling backwards the same mode grows: a pushed caster flips
    over, and any perturbation (including integration error) is amplified at that rate while
    it does. Validation manoeuvres therefore drive forward (:meth:`validation_manoeuvre`).

    Cost (2-core machine, one core): about 0.17 us per derivative, 0.68 us per RK4 substep on
    one state (1.7 us for ``step`` with one substep); a batch steps in vectorised blocks of
    ``integrators.LANES`` robots at about 0.14 us per robot-substep
    (``kernels.three_wheel.k_block``, 4.2x).
    """

    state_names = ("x", "y", "yaw", "vx", "vy", "wz", "psi_1", "psi_2", "psi_3",
                   "theta_1", "theta_2", "theta_3")
    input_names = ("drive_1", "drive_2", "drive_3", "steer_1", "steer_2", "steer_3")
    params_type = ThreeWheelParams
    default_sim_dt = 0.002

    _k_deriv = _kern.KERNELS.deriv
    _k_step = _kern.KERNELS.step
    _k_step_par = _kern.KERNELS.step_par
    _k_step1 = _kern.KERNELS.step1
    _k_deriv1 = _kern.KERNELS.deriv1
    _k_motor = _kern.k_motor
    _kern_module = _kern

    friction_params = ("mu_r", "mu_p", "b_drive", "b_steer")

    params: ThreeWheelParams

    # batching helpers ---------------------------------------------------------------
    def _finite(self, a: Any, width: int, name: str) -> np.ndarray:
        arr = self._as_batch(a, width, name)
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} passed to {type(self).__name__} is not finite")
        return arr

    def _psi_pieces(self, psi) -> tuple[np.ndarray, ...]:
        P = self._finite(psi, 3, "psi")
        lead = P.shape[:-1]
        P2 = np.ascontiguousarray(P.reshape(-1, 3))
        n = P2.shape[0]
        jac = np.empty((n, 6, 3))
        mass = np.empty((n, 3, 3))
        loads = np.empty((n, 3))
        centers = np.empty((n, 3, 2))
        fjac = np.empty((n, 3, 3))
        _kern.k_psi_pieces(P2, self._p, jac, mass, loads, centers, fjac)
        return (jac.reshape(lead + (6, 3)), mass.reshape(lead + (3, 3)),
                loads.reshape(lead + (3,)), centers.reshape(lead + (3, 2)),
                fjac.reshape(lead + (3, 3)))

    def _twist_pieces(self, psi, u) -> tuple[np.ndarray, np.ndarray]:
        P = self._finite(psi, 3, "psi")
        V = self._finite(u, 3, "u")
        lead = np.broadcast_shapes(P.shape[:-1], V.shape[:-1])
        P2 = kernel_array(np.broadcast_to(P, lead + (3,)).reshape(-1, 3))
        V2 = kernel_array(np.broadcast_to(V, lead + (3,)).reshape(-1, 3))
        bias = np.empty_like(P2)
        fric = np.empty_like(P2)
        _kern.k_twist_pieces(P2, V2, self._p, bias, fric)
        return bias.reshape(lead + (3,)), fric.reshape(lead + (3,))

    def _state(self, x) -> np.ndarray:
        return self._finite(x, self.state_dim, "x")

    # validation hooks (wheelgym.validate) ----------------------------------------------
    @property
    def input_high(self) -> np.ndarray:
        """Torque limits in motor order (N·m)."""
        return self.params.tau_max

    def validation_state(self) -> np.ndarray:
        """Moving start for the validation runs: 0.5 m/s forward, turning at 0.2 rad/s, casters
        trailing (psi = 0)."""
        x = np.zeros(self.state_dim)
        x[3] = 0.5
        x[5] = 0.2
        return x

    def validation_manoeuvre(self, t: float) -> np.ndarray:
        """Torques (N·m) at time ``t`` of a 5 s forward manoeuvre: accelerate, turn left, turn
        right, brake, with small steering torques.

        It stays in forward motion on purpose: reversing makes pushed casters flip over, an
        unstable motion that amplifies any perturbation at a rate of about ``|v| / d`` (tens of
        1/s), so a step-refinement comparison there measures that instability, not RK4.
        """
        if t < 1.5:
            drive = (0.8, 0.8, 0.8)
        elif t < 3.0:
            drive = (0.2, 1.0, 0.6)
        elif t < 4.0:
            drive = (1.0, 0.2, 0.6)
        else:
            drive = (-0.6, -0.6, -0.6)
        steer = (0.1 * math.sin(2.0 * t), 0.1 * math.sin(2.0 * t + 1.0), 0.1 * math.sin(3.0 * t))
        return np.array(drive + steer)

    # TW-1 -----------------------------------------------------------------------------
    def jacobian(self, psi) -> np.ndarray:
        """Joint Jacobian ``J(psi)`` of TW-1, ``qdot = J u``; shape ``(..., 6, 3)``.

        Rows in motor order: ``g_i / r`` (drive i, rad/s per unit twist) then
        ``h_i / d - e_3`` (steer i).
        """
        return self._psi_pieces(psi)[0]

    def joint_velocity(self, x) -> np.ndarray:
        """Joint rates ``qdot = J(psi) u`` in motor order (rad/s), shape ``(..., 6)``."""
        X = self._state(x)
        return np.einsum("...ij,...j->...i", self.jacobian(X[..., 6:9]), X[..., 3:6])

    def body_twist(self, x) -> np.ndarray:
        """Body twist ``u = (vx, vy, wz)`` (m/s, m/s, rad/s), shape ``(..., 3)``."""
        return self._state(x)[..., 3:6].copy()

    def wheel_centers(self, psi) -> np.ndarray:
        """Wheel centres ``p_i = a_i - d e_i`` in B (m), shape ``(..., 3, 2)`` (TW-1)."""
        return self._psi_pieces(psi)[3]

    # TW-3, TW-4 -----------------------------------------------------------------------
    def mass_matrix(self, psi) -> np.ndarray:
        """Generalized inertia ``M(psi)`` of TW-3 (kg, kg m, kg m²), shape ``(..., 3, 3)``."""
        return self._psi_pieces(psi)[1]

    def bias(self, psi, u) -> np.ndarray:
        """Coriolis/centripetal term ``c(psi, u)`` of TW-3 (N, N, N·m), shape ``(..., 3)``."""
        return self._twist_pieces(psi, u)[0]

    def friction(self, psi, u) -> np.ndarray:
        """Generalized friction ``Q_f(psi, u)`` of TW-4 (N, N, N·m), shape ``(..., 3)``."""
        return self._twist_pieces(psi, u)[1]

    def dynamics_terms(self, psi, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(J, M, c, Q_f)`` of TW-1, TW-3 and TW-4 in one call (for controllers).

        Shapes ``(..., 6, 3)``, ``(..., 3, 3)``, ``(..., 3)``, ``(..., 3)``; ``psi`` and the
        twist ``u`` broadcast against each other.
        """
        c, q = self._twist_pieces(psi, u)
        P = np.broadcast_to(np.asarray(psi, dtype=np.float64), c.shape)
        jac, mass = self._psi_pieces(P)[:2]
        return jac, mass, c, q

    def normal_loads(self, psi) -> np.ndarray:
        """Static normal loads ``N_i`` (N) of TW-4 at steering angles ``psi``, ``(..., 3)``."""
        return self._psi_pieces(psi)[2]

    # Energy ---------------------------------------------------------------------------
    def kinetic_energy(self, x) -> np.ndarray:
        """``T = u^T M(psi) u / 2`` (J), shape ``(...)``."""
        X = self._state(x)
        u = X[..., 3:6]
        return 0.5 * np.einsum("...i,...ij,...j->...", u, self.mass_matrix(X[..., 6:9]), u)

    def motor_power(self, x, u) -> np.ndarray:
        """Mechanical power of the six motors at the joints ``tau . qdot`` (W), shape ``(...)``;
        ``tau`` the applied torques (the command for ideal motors, :meth:`applied_torque`)."""
        U = self.applied_torque(x, u) if self.dc else self._as_batch(u, self.input_dim, "u")
        return np.sum(U * self.joint_velocity(x), axis=-1)

    def friction_power(self, x) -> np.ndarray:
        """Power of the friction forces ``u . Q_f`` (W, <= 0), shape ``(...)``."""
        X = self._state(x)
        return np.sum(X[..., 3:6] * self.friction(X[..., 6:9], X[..., 3:6]), axis=-1)

    def friction_jacobian_at_rest(self, psi) -> np.ndarray:
        """``dQ_f/du`` at ``u = 0`` (N·s/m ...), shape ``(..., 3, 3)``: symmetric, <= 0."""
        return self._psi_pieces(psi)[4]

    def stiffness(self, psi=None) -> float:
        """Largest ``|lambda|`` of ``M^-1 dQ_f/du`` at rest (1/s), see the class docstring.

        Args:
            psi: steering angles ``(..., 3)`` to evaluate at; ``None`` takes the maximum over
                a grid of 12 angles per module (1728 configurations).

        RK4 is stable for real eigenvalues with ``|lambda| sim_dt < 2.785``
        (:data:`RK4_REAL_STABILITY_LIMIT`).
        """
        if psi is None:
            g = np.linspace(-np.pi, np.pi, 12, endpoint=False)
            psi = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
        _, mass, _, _, fjac = self._psi_pieces(psi)
        lam = np.linalg.eigvals(np.linalg.solve(mass, fjac))
        return float(np.max(np.abs(lam)))

