"""The three-wheel paper's natural orthogonal complement, written out (a reference derivation).

:func:`noc_terms` builds the twist-shaping matrix ``T`` of the robot's seven bodies and the
products ``T^T M_bodies T`` and ``T^T (M_bodies Tdot + W M_bodies T) u`` of the paper
(17)-(29) in NumPy. Nothing in the package runs it: the compiled kernels evaluate the closed
form of docs/physics/three-wheel.md TW-3 (:mod:`wheelgym.models.kernels.three_wheel`), and the
tests check that
both agree to 1e-12.
"""

from __future__ import annotations

import numpy as np

from wheelgym.models.three_wheel import ThreeWheelParams

__all__ = ["noc_terms"]


def noc_terms(
    params: ThreeWheelParams,
    psi: np.ndarray,
    u: np.ndarray,
    yaw: float = 0.0,
    wheel_diametral_inertia: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """``M`` and ``c`` of TW-3 by the natural orthogonal complement (three-wheel paper (17)-(29)).

    Reference derivation in NumPy (not used by the compiled kernel, which evaluates the closed
    form of docs/physics/three-wheel.md TW-3; the tests check both agree to 1e-12).

    Seven rigid bodies, each with a 6-vector twist ``t = (omega, v)`` at its centre of mass in
    the world frame (paper (17)-(18)): 0 the platform (mass ``m_b``, yaw inertia ``I_b``),
    1-3 the steering links (mass ``m_w`` at the wheel centre, yaw inertia ``I_wz - I_d``),
    4-6 the wheels (spin inertia ``I_wy`` about the axle ``n_i``, diametral inertia ``I_d``
    about ``e_i`` and the vertical, no mass of their own). The stacked 42-vector of twists is
    (paper (27)) ``t = T_a u + T_b qdot`` with ``qdot = J u`` the joint rates of TW-1 in
    motor order, so (paper (28)) ``T = T_a + T_b J`` and (paper (29), with ``J`` in place of
    the paper's ``J_b^-1 J_a``) ``Tdot = Tdot_a + Tdot_b J + T_b Jdot``. Then (paper (24)-(26))

        M = T^T M_bodies T,      c = T^T (M_bodies Tdot + W M_bodies T) u,

    ``W = diag(Omega_k, 0)`` the cross-product matrices of the body angular velocities.

    Reduction to the closed form of TW-3: with no skid, each wheel centre moves with speed
    ``g_i . u`` along ``e_i``, each module turns at ``h_i . u / d`` about the vertical and each
    wheel spins at ``g_i . u / r``, so the kinetic energy is
    ``(m_b |v|^2 + I_b wz^2)/2 + sum_i (k_w (g_i.u)^2 + k_z (h_i.u)^2)/2`` and
    ``T^T M T = diag(m_b, m_b, I_b) + sum k_w g g^T + k_z h h^T``. In ``T^T M Tdot u`` the
    rotation of ``e_i`` (normal to the path) drops out and only ``d(g_i.u)/dt = psidot_i h_i.u``
    and ``d(h_i.u)/dt = -psidot_i g_i.u`` survive, plus ``m_b wz (-vy, vx)`` of the platform;
    the ``W M T u`` terms are gyroscopic moments of the wheels along ``e_i`` (horizontal),
    orthogonal to every column of ``T`` (which only turns bodies about ``n_i`` and the
    vertical), so they vanish, whatever ``I_d`` is.

    Args:
        params: the robot.
        psi: steering angles (3,) (rad).
        u: body twist (vx, vy, wz) (m/s, m/s, rad/s).
        yaw: platform heading (rad); ``M`` and ``c`` do not depend on it.
        wheel_diametral_inertia: ``I_d`` (kg m², ``0 <= I_d <= I_wz``) moved from the steering
            link to the wheel; ``M`` and ``c`` do not depend on it either.

    Returns:
        ``(M, c, parts)`` with ``parts`` holding ``T`` (42, 3), ``Tdot``, ``M_bodies``
        (42, 42) and ``W`` (42, 42).
    """
    p = params
    psi = np.asarray(psi, dtype=np.float64).reshape(3)
    u = np.asarray(u, dtype=np.float64).reshape(3)
    i_d = float(wheel_diametral_inertia)
    if not 0.0 <= i_d <= p.I_wz:
        raise ValueError(f"wheel_diametral_inertia must be in [0, I_wz={p.I_wz}], got {i_d}")
    a = p.axes_array
    vx, vy, wz = u
    kz = np.array([0.0, 0.0, 1.0])

    # TW-1 joint rates and their Jacobian, with Jdot (dg/dpsi = h, dh/dpsi = -g).
    c, s = np.cos(psi), np.sin(psi)
    g = np.stack([c, s, a[:, 0] * s - a[:, 1] * c], axis=1)
    h = np.stack([-s, c, a[:, 0] * c + a[:, 1] * s], axis=1)
    J = np.vstack([g / p.r, h / p.d - kz])
    qdot = J @ u
    psid = qdot[3:]
    Jdot = np.vstack([(psid[:, None] * h) / p.r, -(psid[:, None] * g) / p.d])

    angles = np.concatenate([[yaw], yaw + psi])  # platform heading, module headings phi_i
    rates = np.concatenate([[wz], wz + psid])

    def build(E, N, const: float) -> tuple[np.ndarray, np.ndarray]:
        """T_a (42x3), T_b (42x6) from unit vectors E(k), N(k) of angle k (0: yaw, 1-3: phi_i).

        Called with the vectors themselves and ``const = 1`` this gives ``T_a, T_b``; called
        with their time derivatives and ``const = 0`` (constant entries) ``Tdot_a, Tdot_b``.
        """
        Ta = np.zeros((42, 3))
        Tb = np.zeros((42, 6))
        # platform: omega = wz k, v = vx E(yaw) + vy N(yaw)
        Ta[2, 2] = const
        Ta[3:6, 0] = E(0)
        Ta[3:6, 1] = N(0)
        for i in range(3):
            # wheel-centre velocity: v_b + wz k x R a_i - d (wz + psidot_i) N(phi_i)
            v_a = [E(0), N(0), -a[i, 1] * E(0) + a[i, 0] * N(0) - p.d * N(1 + i)]
            v_b = -p.d * N(1 + i)  # coefficient of psidot_i
            for body in (1 + i, 4 + i):  # steering link i, wheel i
                r0 = 6 * body
                Ta[r0 + 2, 2] = const  # omega_z = wz + psidot_i
                Tb[r0 + 2, 3 + i] = const
                for col in range(3):
                    Ta[r0 + 3:r0 + 6, col] = v_a[col]
                Tb[r0 + 3:r0 + 6, 3 + i] = v_b
            Tb[6 * (4 + i):6 * (4 + i) + 3, i] = N(1 + i)  # wheel spin thetadot_i about n_i
        return Ta, Tb

    def unit_e(k: int) -> np.ndarray:
        return np.array([np.cos(angles[k]), np.sin(angles[k]), 0.0])

    def unit_n(k: int) -> np.ndarray:
        return np.array([-np.sin(angles[k]), np.cos(angles[k]), 0.0])

    Ta, Tb = build(unit_e, unit_n, 1.0)
    # d/dt E(angle) = rate N(angle), d/dt N(angle) = -rate E(angle)
    Tad, Tbd = build(lambda k: rates[k] * unit_n(k), lambda k: -rates[k] * unit_e(k), 0.0)
    T = Ta + Tb @ J  # paper (28)
    Tdot = Tad + Tbd @ J + Tb @ Jdot  # paper (29)

    # Body inertia (paper (18)-(20)): diag(I_k, m_k 1), world frame.
    Mb = np.zeros((42, 42))
    Mb[0:3, 0:3] = p.I_b * np.eye(3)  # platform (only the yaw entry acts)
    Mb[3:6, 3:6] = p.m_b * np.eye(3)
    for i in range(3):
        r0 = 6 * (1 + i)
        Mb[r0:r0 + 3, r0:r0 + 3] = (p.I_wz - i_d) * np.outer(kz, kz)
        Mb[r0 + 3:r0 + 6, r0 + 3:r0 + 6] = p.m_w * np.eye(3)
        e3, n3 = unit_e(1 + i), unit_n(1 + i)
        r0 = 6 * (4 + i)
        Mb[r0:r0 + 3, r0:r0 + 3] = (p.I_wy * np.outer(n3, n3)
                                    + i_d * (np.outer(e3, e3) + np.outer(kz, kz)))
    t = T @ u
    W = np.zeros((42, 42))
    for k in range(7):
        w = t[6 * k:6 * k + 3]
        W[6 * k:6 * k + 3, 6 * k:6 * k + 3] = np.array(
            [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
        )
    M = T.T @ Mb @ T  # paper (26): generalized inertia
    cor = T.T @ (Mb @ Tdot + W @ Mb @ T) @ u  # paper (26): -C u
    return M, cor, {"T": T, "Tdot": Tdot, "M_bodies": Mb, "W": W}
