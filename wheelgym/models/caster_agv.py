"""Differential-drive AGV with a passive trailing caster (docs/physics/caster-robots.md).

Two driven conventional wheels on a common axle and one passive off-centred caster wheel: the
2-DOF robot of the caster-singularity paper (its second robot) and of the three-wheel paper's
reference [10] (Angeles and Saha). The caster's swivel angle ``sigma`` is a state.

Frames. The body origin is the **axle midpoint** (not the centre of mass as in
docs/physics/conventions.md): there the no-skid constraint of the driven wheels reads
``vy = 0``, so the body
twist is ``u = (v, w)`` (forward speed, yaw rate) and ``(vx, vy, wz) = (v, 0, w)``. The
platform's centre of mass sits at ``(x_G, 0)`` in B. Wheels: L at ``(0, +c)``, R at
``(0, -c)`` (``c`` half the track width), caster steering axis at ``a = (a_x, a_y)``, caster
wheel centre ``p = a - d e(sigma)``, ``e = (cos sigma, sin sigma)``
(docs/physics/three-wheel.md TW-1).

Kinematics (docs/physics/three-wheel.md TW-1 with the ``vy`` column dropped;
caster-singularity paper (8)-(11)):

    g_L = (1, -c),  g_R = (1, c)                      thetadot_L,R = g_L,R . u / r
    g_c = (cos s, a_x sin s - a_y cos s)              thetadot_c   = g_c . u / r_c
    h_c = (-sin s, a_x cos s + a_y sin s)             sigmadot     = h_c . u / d - w

Dynamics (natural orthogonal complement as docs/physics/three-wheel.md TW-3;
the twist-shaping map from
``u`` to the TW-3 body twist is the constant ``(v, w) -> (v, 0, w)``, so its transpose
removes the lateral constraint force and adds no ``Tdot`` term):

    M(s) = [[m_b, 0], [0, I_b + m_b x_G^2 + 2 I_wz]] + k_w (g_L g_L^T + g_R g_R^T)
           + k_c g_c g_c^T + k_cz h_c h_c^T
    c(s, u) = m_b x_G (-w^2, w v) + sigmadot (k_c (h_c . u) g_c - k_cz (g_c . u) h_c)
    M udot + c = (g_L tau_L + g_R tau_R) / r + Q_f

with ``k_w = m_w + I_wy / r^2``, ``k_c = m_c + I_cy / r_c^2``, ``k_cz = I_cz / d^2``. The
first term of ``c`` is the platform's centripetal force at its offset centre of mass; the
driven wheels sit on the axle (``x = 0``) and add none.

Friction (docs/physics/three-wheel.md TW-4 applied to every wheel):

    Q_f = - sum_{j=L,R} (mu_r N_j sgn_s(g_j . u) + b_drive g_j . u / r^2) g_j
          - (mu_p (N_L + N_R) sgn_s(rho w)) e_w                     (drive-wheel pivot scrub)
          - (mu_r N_c sgn_s(g_c . u) + b_caster g_c . u / r_c^2) g_c
          - mu_p N_c sgn_s(rho h_c . u / d) h_c / d                  (caster pivot scrub)
          - b_caster sigmadot (h_c / d - e_w)                        (caster swivel joint)

with ``e_w = (0, 1)``; ``N_j`` the static distribution of the total weight over the three
contact points (the caster's depends on ``sigma``, its module mass sitting at ``p``).
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
from wheelgym.models.kernels import caster_agv as _kern
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

__all__ = ["CasterAGVParams", "CasterAGV"]


@dataclasses.dataclass(frozen=True)
class CasterAGVParams(Params):
    """Caster-AGV parameters (docs/physics/caster-robots.md; defaults: a ~23 kg
    differential-drive AGV).

    | name        | default       | unit      | meaning                                        |
    |-------------|---------------|-----------|------------------------------------------------|
    | m_b         | 20.0          | kg        | platform mass (without wheels and caster)      |
    | I_b         | 0.8           | kg m²     | platform yaw inertia about its centre of mass  |
    | x_G         | 0.05          | m         | platform CoM ahead of the axle midpoint        |
    | m_w         | 1.0           | kg        | mass of each driven wheel (at its centre)      |
    | I_wy        | 0.0028        | kg m²     | driven-wheel spin inertia                      |
    | I_wz        | 0.0015        | kg m²     | driven-wheel inertia about a vertical diameter |
    | r           | 0.075         | m         | driven-wheel radius                            |
    | track_width | 0.40          | m         | distance between the driven wheels (``2 c``)   |
    | caster_axis | (0.30, 0.0)   | m         | caster steering axis ``a`` in B (front caster) |
    | d           | 0.03          | m         | caster trail, axis to wheel centre             |
    | r_c         | 0.04          | m         | caster-wheel radius                            |
    | m_c         | 0.5           | kg        | caster module mass (at the wheel centre)       |
    | I_cy        | 0.0004        | kg m²     | caster-wheel spin inertia                      |
    | I_cz        | 0.0006        | kg m²     | caster module yaw inertia about the wheel centre |
    | mu_r        | 0.015         | -         | rolling-resistance coefficient (all wheels)    |
    | mu_p        | 0.008         | m         | pivot (scrub) friction length (all wheels)     |
    | rho         | 0.015         | m         | contact-patch radius (scrub slip speed)        |
    | b_drive     | 0.01          | N·m·s/rad | viscous friction of the driven axles           |
    | b_caster    | 0.001         | N·m·s/rad | viscous friction of the caster axle and swivel |
    | k_s         | 100.0         | s/m       | arctan smoothing of the friction sign          |
    | g           | 9.81          | m/s²      | gravity                                        |
    | tau_max     | 6.0           | N·m       | torque limit of each drive motor               |
    | motor       | "ideal"       | -         | "ideal", "dc" or "dc_voltage" (models/motor.py) |
    | gear_ratio  | 20.0          | -         | drive gearbox ratio n (two equal motors)       |
    | gear_efficiency | 0.85      | -         | drive gearbox efficiency eta                   |
    | k_t         | 0.05          | N·m/A     | torque constant (= k_e, V·s/rad)               |
    | R_w         | 1.2           | ohm       | winding resistance                             |
    | V_s         | 24.0          | V         | supply voltage                                 |
    | I_max       | 10.0          | A         | current limit of each drive                    |

    DC motors (``motor="dc"``, :mod:`wheelgym.models.motor`; ThreeWheel's drive motor):
    stall torque ``20 * 0.85 * 0.05 * min(20, 10) = 8.5 N·m`` (>= ``tau_max``), corner speed
    12 rad/s (0.9 m/s), no-load joint speed ``V_s / (k_e n) = 24 rad/s`` (1.8 m/s, below the
    env's 2.0 m/s overspeed limit: docs/topics/motors.md). With
    ``motor="ideal"`` these fields are unused.

    The caster axis must lie off the axle, farther from it than the trail (``|a_x| > d``), and
    the centre of mass must stay strictly inside the support triangle for every swivel angle
    (all three static normal loads positive); both are checked.

    Directional stability: the driven axle is the only point that takes lateral load (a
    trailing caster takes almost none), so driving forward is yaw-stable only with the centre
    of mass ahead of the axle (``x_G > 0``: the centripetal term ``-m_b x_G w v`` then damps
    ``w``), as in a shopping cart with front casters. Hence the front caster by default;
    reversing at speed with equal torques, or ``x_G < 0``, is yaw-unstable (real physics, not a
    numerical effect).
    """

    m_b: float = 20.0
    I_b: float = 0.8
    x_G: float = 0.05
    m_w: float = 1.0
    I_wy: float = 0.0028
    I_wz: float = 0.0015
    r: float = 0.075
    track_width: float = 0.40
    caster_axis: tuple[float, float] = (0.30, 0.0)
    d: float = 0.03
    r_c: float = 0.04
    m_c: float = 0.5
    I_cy: float = 0.0004
    I_cz: float = 0.0006
    mu_r: float = 0.015
    mu_p: float = 0.008
    rho: float = 0.015
    b_drive: float = 0.01
    b_caster: float = 0.001
    k_s: float = 100.0
    g: float = 9.81
    tau_max: float = 6.0
    motor: str = "ideal"
    gear_ratio: float = 20.0
    gear_efficiency: float = 0.85
    k_t: float = 0.05
    R_w: float = 1.2
    V_s: float = 24.0
    I_max: float = 10.0

    _choices: ClassVar[dict[str, tuple[str, ...]]] = {"motor": tuple(MODES)}
    _positive: ClassVar[tuple[str, ...]] = (
        "m_b", "I_b", "m_w", "I_wy", "I_wz", "r", "track_width", "d", "r_c", "m_c", "I_cy",
        "I_cz", "rho", "k_s", "g", "tau_max",
    )
    _nonnegative: ClassVar[tuple[str, ...]] = ("mu_r", "mu_p", "b_drive", "b_caster")
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "m_b": MASS, "m_w": MASS, "m_c": MASS, "I_b": INERTIA, "I_wy": INERTIA,
        "I_wz": INERTIA, "I_cy": INERTIA, "I_cz": INERTIA, "x_G": SIGNED_LENGTH, "r": LENGTH,
        "track_width": LENGTH, "caster_axis": SIGNED_LENGTH, "d": LENGTH, "r_c": LENGTH,
        "mu_r": COEFFICIENT, "mu_p": (0.0, LENGTH[1], "m"), "rho": LENGTH,
        "b_drive": DAMPING, "b_caster": DAMPING, "k_s": SMOOTHING, "g": GRAVITY,
        "tau_max": TORQUE, "gear_ratio": GEAR_RATIO, "gear_efficiency": EFFICIENCY,
        "k_t": TORQUE_CONSTANT, "R_w": RESISTANCE, "V_s": VOLTAGE, "I_max": CURRENT,
    }

    def _check(self) -> None:
        a = np.asarray(self.caster_axis, dtype=np.float64)
        if a.shape != (2,):
            raise ValueError(
                f"CasterAGVParams.caster_axis must be an (x, y) pair, got {self.caster_axis!r}"
            )
        if not abs(a[0]) > self.d:
            raise ValueError(
                f"CasterAGVParams.caster_axis x ({a[0]}) must be farther from the axle than "
                f"the trail d ({self.d}): |a_x| > d, else the caster contact can reach the axle"
            )
        sig = np.linspace(-np.pi, np.pi, 73)
        loads = _loads_numpy(self, sig)
        if not np.all(loads > 0.0):
            raise ValueError(
                "CasterAGVParams: the centre of mass leaves the support triangle for some "
                f"swivel angle (smallest static normal load {loads.min():.3g} N); move x_G "
                "toward the caster or the caster axis away from the axle"
            )

    @property
    def c(self) -> float:
        """Half track (m)."""
        return 0.5 * self.track_width

    @property
    def m_total(self) -> float:
        """Total mass ``m_b + 2 m_w + m_c`` (kg)."""
        return self.m_b + 2.0 * self.m_w + self.m_c

    def pack(self) -> np.ndarray:
        """The packed array in the layout of the ``P_*`` indices of
        :mod:`wheelgym.models.kernels.caster_agv`."""
        a = np.asarray(self.caster_axis, dtype=np.float64)
        kw = self.m_w + self.I_wy / self.r**2
        return np.array(
            [self.m_b, self.I_b, self.x_G, self.m_w, self.I_wy, self.I_wz, self.r, self.c,
             a[0], a[1], self.d, self.r_c, self.m_c, self.I_cy, self.I_cz, self.mu_r,
             self.mu_p, self.rho, self.b_drive, self.b_caster, self.k_s, self.g, self.tau_max,
             kw, self.m_c + self.I_cy / self.r_c**2, self.I_cz / self.d**2, self.m_total,
             1.0 / self.r, 1.0 / self.r_c, 1.0 / self.d,
             self.I_b + self.m_b * self.x_G**2 + 2.0 * self.I_wz, self.m_b * self.x_G,
             self.g * self.m_b * self.x_G, self.g * self.m_c, self.g * (self.m_b + 2 * self.m_w),
             1.0 / self.c, self.b_drive / self.r**2, self.b_caster / self.r_c**2,
             mode_code(self.motor),
             *pack_motor(self.gear_ratio, self.gear_efficiency, self.k_t, self.R_w, self.V_s,
                         self.I_max)],
            dtype=np.float64,
        )

    def motor_table(self) -> dict[str, np.ndarray]:
        """DC-motor parameters per motor ``(tau_L, tau_R)`` (keys
        :data:`wheelgym.models.motor.TABLE_KEYS`)."""
        return {k: np.full(2, float(getattr(self, k))) for k in
                ("gear_ratio", "gear_efficiency", "k_t", "R_w", "V_s", "I_max")}


def _loads_numpy(p: CasterAGVParams, sig: np.ndarray) -> np.ndarray:
    """Parameter check only (before packing): the compiled ``loads`` for angles ``sig``."""
    out = np.empty((len(sig), 3))
    pk = p.pack()
    for k, s in enumerate(sig):
        out[k] = _kern.loads(math.cos(s), math.sin(s), pk)
    return out


# ---------------------------------------------------------------------------- the model
class CasterAGV(MotorMixin, Model):
    """Differential-drive AGV with a passive trailing caster (docs/physics/caster-robots.md).

    | index | state   | unit  | meaning                          |   | index | input | unit |
    |-------|---------|-------|----------------------------------|---|-------|-------|------|
    | 0     | x       | m     | axle midpoint in W               |   | 0     | tau_L | N·m  |
    | 1     | y       | m     |                                  |   | 1     | tau_R | N·m  |
    | 2     | yaw     | rad   |                                  |   |       |       |      |
    | 3     | v       | m/s   | forward speed of the axle midpoint |  |       |       |      |
    | 4     | w       | rad/s | yaw rate                         |   |       |       |      |
    | 5     | sigma   | rad   | caster swivel angle from body x  |   |       |       |      |
    | 6     | theta_L | rad   | left wheel angle                 |   |       |       |      |
    | 7     | theta_R | rad   | right wheel angle                |   |       |       |      |
    | 8     | theta_c | rad   | caster wheel angle               |   |       |       |      |

    ``sigma = 0`` points the caster's rolling direction along body x, its wheel trailing
    behind the swivel axis; driving forward, that is the stable alignment.

    Joints of the singularity analysis (:attr:`joint_names`, rows of :meth:`jacobian`):
    ``drive_L``, ``drive_R``, ``caster_drive`` (caster wheel spin), ``caster_steer`` (swivel).

    Stability of the default ``sim_dt = 0.002 s``: the stiffest mode is the friction at rest,
    the largest ``|lambda|`` of ``M^-1 dQ_f/du`` at ``u = 0`` (:meth:`stiffness`); at the
    defaults it is about 39 1/s over all swivel angles (the rolling resistance along ``g``),
    so ``|lambda| sim_dt`` is about 0.08, far inside RK4's real stability limit 2.785.
    """

    state_names = ("x", "y", "yaw", "v", "w", "sigma", "theta_L", "theta_R", "theta_c")
    input_names = ("tau_L", "tau_R")
    joint_names: ClassVar[tuple[str, ...]] = ("drive_L", "drive_R", "caster_drive",
                                              "caster_steer")
    params_type = CasterAGVParams
    default_sim_dt = 0.002

    _k_deriv = _kern.KERNELS.deriv
    _k_step = _kern.KERNELS.step
    _k_step_par = _kern.KERNELS.step_par
    _k_step1 = _kern.KERNELS.step1
    _k_deriv1 = _kern.KERNELS.deriv1
    _k_motor = _kern.k_motor
    _kern_module = _kern
    friction_params = ("mu_r", "mu_p", "b_drive", "b_caster")

    params: CasterAGVParams

    # batching helpers ---------------------------------------------------------------
    def _sigma(self, sigma: Any) -> np.ndarray:
        s = np.asarray(sigma, dtype=np.float64)
        if not np.all(np.isfinite(s)):
            raise ValueError("sigma must be finite")
        return s

    def _sigma_pieces(self, sigma: Any) -> tuple[np.ndarray, ...]:
        s = self._sigma(sigma)
        lead = s.shape
        S = np.ascontiguousarray(s.reshape(-1))
        n = S.shape[0]
        jac = np.empty((n, 4, 2))
        mass = np.empty((n, 2, 2))
        loads = np.empty((n, 3))
        centers = np.empty((n, 3, 2))
        fjac = np.empty((n, 2, 2))
        _kern.k_sigma_pieces(S, self._p, jac, mass, loads, centers, fjac)
        return (jac.reshape(lead + (4, 2)), mass.reshape(lead + (2, 2)),
                loads.reshape(lead + (3,)), centers.reshape(lead + (3, 2)),
                fjac.reshape(lead + (2, 2)))

    def _twist_pieces(self, sigma: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
        s = self._sigma(sigma)
        V = self._as_batch(u, 2, "u")
        lead = np.broadcast_shapes(s.shape, V.shape[:-1])
        S = kernel_array(np.broadcast_to(s, lead).reshape(-1))
        V2 = kernel_array(np.broadcast_to(V, lead + (2,)).reshape(-1, 2))
        bias = np.empty_like(V2)
        fric = np.empty_like(V2)
        _kern.k_twist_pieces(S, V2, self._p, bias, fric)
        return bias.reshape(lead + (2,)), fric.reshape(lead + (2,))

    def _state(self, x: Any) -> np.ndarray:
        return self._as_batch(x, self.state_dim, "x")

    # Kinematics -------------------------------------------------------------------------
    def jacobian(self, sigma: Any) -> np.ndarray:
        """Joint Jacobian ``qdot = J(sigma) u``, ``u = (v, w)``; shape ``(..., 4, 2)``.

        Rows (:attr:`joint_names`): ``g_L / r``, ``g_R / r``, ``g_c / r_c``, ``h_c / d - e_w``.
        """
        return self._sigma_pieces(sigma)[0]

    def joint_velocity(self, x: Any) -> np.ndarray:
        """Joint rates ``(thetadot_L, thetadot_R, thetadot_c, sigmadot)`` (rad/s), ``(..., 4)``."""
        X = self._state(x)
        return np.einsum("...ij,...j->...i", self.jacobian(X[..., 5]), X[..., 3:5])

    def body_twist(self, x: Any) -> np.ndarray:
        """Body twist ``(vx, vy, wz) = (v, 0, w)`` at the axle midpoint, shape ``(..., 3)``."""
        X = self._state(x)
        out = np.zeros(X.shape[:-1] + (3,))
        out[..., 0] = X[..., 3]
        out[..., 2] = X[..., 4]
        return out

    def wheel_centers(self, sigma: Any) -> np.ndarray:
        """Wheel centres in B (m): L, R, caster ``a - d e``; shape ``(..., 3, 2)``."""
        return self._sigma_pieces(sigma)[3]

    # Dynamics -----------------------------------------------------------------------------
    def mass_matrix(self, sigma: Any) -> np.ndarray:
        """Generalized inertia ``M(sigma)`` (kg, kg m, kg m²), shape ``(..., 2, 2)``."""
        return self._sigma_pieces(sigma)[1]

    def bias(self, sigma: Any, u: Any) -> np.ndarray:
        """Coriolis/centripetal term ``c(sigma, u)`` (N, N·m), shape ``(..., 2)``."""
        return self._twist_pieces(sigma, u)[0]

    def friction(self, sigma: Any, u: Any) -> np.ndarray:
        """Generalized friction ``Q_f(sigma, u)`` (N, N·m), shape ``(..., 2)``."""
        return self._twist_pieces(sigma, u)[1]

    def normal_loads(self, sigma: Any) -> np.ndarray:
        """Static normal loads ``(N_L, N_R, N_c)`` (N), shape ``(..., 3)``."""
        return self._sigma_pieces(sigma)[2]

    def input_matrix(self) -> np.ndarray:
        """``B`` with ``Q_motor = B (tau_L, tau_R)``: columns ``g_L / r``, ``g_R / r``."""
        p = self.params
        return np.array([[1.0, 1.0], [-p.c, p.c]]) / p.r

    # Energy -------------------------------------------------------------------------------
    def kinetic_energy(self, x: Any) -> np.ndarray:
        """``T = u^T M(sigma) u / 2`` (J), shape ``(...)``."""
        X = self._state(x)
        u = X[..., 3:5]
        return 0.5 * np.einsum("...i,...ij,...j->...", u, self.mass_matrix(X[..., 5]), u)

    def motor_power(self, x: Any, u: Any) -> np.ndarray:
        """Mechanical power of the two motors at the joints ``tau_L thetadot_L + tau_R
        thetadot_R`` (W); ``tau`` the applied torques (the command for ideal motors,
        :meth:`applied_torque`)."""
        U = self.applied_torque(x, u) if self.dc else self._as_batch(u, self.input_dim, "u")
        return np.sum(U * self.joint_velocity(x)[..., :2], axis=-1)

    def friction_power(self, x: Any) -> np.ndarray:
        """Power of the friction forces ``u . Q_f`` (W, <= 0), shape ``(...)``."""
        X = self._state(x)
        return np.sum(X[..., 3:5] * self.friction(X[..., 5], X[..., 3:5]), axis=-1)

    def friction_jacobian_at_rest(self, sigma: Any) -> np.ndarray:
        """``dQ_f/du`` at ``u = 0``, shape ``(..., 2, 2)``: symmetric, negative definite."""
        return self._sigma_pieces(sigma)[4]

    def stiffness(self, sigma: Any = None) -> float:
        """Largest ``|lambda|`` of ``M^-1 dQ_f/du`` at rest (1/s), see the class docstring.

        Args:
            sigma: swivel angles to evaluate at; ``None`` takes the maximum over 72 angles.
        """
        if sigma is None:
            sigma = np.linspace(-np.pi, np.pi, 72, endpoint=False)
        _, mass, _, _, fjac = self._sigma_pieces(sigma)
        lam = np.linalg.eigvals(np.linalg.solve(mass, fjac))
        return float(np.max(np.abs(lam)))
