"""Compiled pieces of the three-wheel robot (docs/physics/three-wheel.md), for every layer's
kernels.

The model (:class:`wheelgym.models.ThreeWheel`), the environments' step kernel and the
controllers all inline these functions, so they share one set of formulas and bits. Every
function reads the packed parameter array ``p`` of :meth:`ThreeWheelParams.pack` through the
``P_*`` indices below; ``cs`` is the 6-tuple of :func:`trig`, ``g``/``h`` the 3-tuples of
:func:`gh` (TW-1), ``(vx, vy, wz)`` the body twist.

| name                | what                                                          |
|---------------------|---------------------------------------------------------------|
| ``trig``            | ``(cos psi_1, sin psi_1, ...)`` (friction.sincos)             |
| ``gh``              | ``g_i``, ``h_i`` of TW-1                                      |
| ``jacobian_rows``   | module i's drive and steer rows of J (TW-1)                   |
| ``loads``           | static normal loads ``N_i`` (TW-4)                            |
| ``mass``            | upper triangle of ``M(psi)`` (TW-3)                           |
| ``bias``            | ``c(psi, u)`` (TW-3)                                          |
| ``friction``        | ``Q_f(psi, u)`` (TW-4)                                        |
| ``friction_jac_rest`` | ``dQ_f/du`` at rest, upper triangle                         |
| ``solve3``, ``dot3`` | symmetric 3x3 solve by cofactors, fused 3-vector dot        |
| ``deriv_block``     | the state derivative as a 12-tuple, branch-free (blocks)      |
| ``deriv_one``       | the same into an array ``out`` (one state)                    |
| ``power_t``         | motor power ``tau . qdot`` from a stage's derivative          |
| ``*_dc``            | the same with DC motors (models/motor.py); ``power_t_dc`` the |
|                     | electrical power ``V . i``; ``dc_kernels()`` their kernels    |
| ``joint_rates``     | the six joint rates in motor order (TW-1)                     |
| ``k_motor``         | joint rate, applied torque, current, voltage of each motor    |
| ``KERNELS``         | the model's batch kernels (integrators.model_kernels);        |
|                     | ``k_block`` its vectorised block step                         |

Sums of products are written with explicit fused multiply-adds (``integrators.fma``): one
instruction and one rounding each, the same in the vectorised blocks and the one-row kernels.
The derivative makes 8 sin/cos and 6 arctan calls: ``friction.sincos`` and ``friction.atan``
(libm's values to 2 ulp, branch-free so that the block kernels vectorise).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import fma, llvm_inline, model_kernels
from wheelgym.models import friction as _friction_module
from wheelgym.models import motor as _motor_module
from wheelgym.models.friction import atan, sgn_s, sincos
from wheelgym.models.motor import M_R, MOTOR_NP, dc_applied, dc_current, dc_power, ideal_applied

# kernels here inline integrators.rk4_inplace, integrators.rk4_block, friction.sincos/atan and
# the DC motor law of models/motor.py
_numba_cache.guard(__file__, _integrators.__file__, _friction_module.__file__,
                   _motor_module.__file__)

__all__ = [
    "P_MB", "P_IB", "P_MW", "P_IWY", "P_IWZ", "P_R", "P_D", "P_A1X", "P_A1Y", "P_A2X", "P_A2Y",
    "P_A3X", "P_A3Y", "P_MUR", "P_MUP", "P_RHO", "P_BD", "P_BS", "P_KS", "P_G", "P_TDM",
    "P_TSM", "P_KW", "P_KZ", "P_MT", "P_INVD", "P_INVR", "P_M0", "P_MOTOR", "P_MDRV",
    "P_MSTR", "NP", "NX", "NU", "joint_rates", "k_motor",
    "sincos", "atan", "sgn_s", "trig", "gh", "loads", "dot3", "jacobian_rows", "mass", "bias",
    "friction", "friction_jac_rest", "solve3", "deriv_block", "deriv_one", "power_t",
    "deriv_block_dc", "deriv_one_dc", "power_t_dc", "dc_kernels",
    "k_psi_pieces", "k_twist_pieces", "KERNELS", "k_block",
]

#: Indices into the packed parameter array (ThreeWheelParams.pack; from P_KW on: derived).
(P_MB, P_IB, P_MW, P_IWY, P_IWZ, P_R, P_D, P_A1X, P_A1Y, P_A2X, P_A2Y, P_A3X, P_A3Y, P_MUR,
 P_MUP, P_RHO, P_BD, P_BS, P_KS, P_G, P_TDM, P_TSM, P_KW, P_KZ, P_MT, P_INVD, P_INVR,
 P_M0) = range(28)
#: P_M0 .. P_M0 + 5: the constant part M_0 of M (upper triangle), see ThreeWheelParams.pack
#: P_MOTOR: the motor mode code (models/motor.py MODES: 0 ideal, 1 dc, 2 dc_voltage);
#: P_MDRV, P_MSTR: the drive and steering motors' blocks (motor.pack_motor, offsets motor.M_*)
P_MOTOR = P_M0 + 6
P_MDRV = P_MOTOR + 1
P_MSTR = P_MDRV + MOTOR_NP
NP = P_MSTR + MOTOR_NP  # length of the packed array
NX = 12  # state size
NU = 6  # input size


# ---------------------------------------------------------------------------- compiled pieces
# Every piece is written once, as an inline per-module contribution (``_*_i``) plus the
# platform's share; ``mass``, ``bias``, ``friction``, ``_jt_tau`` sum them for the public
# methods, and ``deriv_one`` sums all of them in one pass over the modules (same formulas,
# one loop, the trig of each steering angle evaluated once).
# g = (g0, g1, g2), h = (h0, h1, h2) of TW-1; gu = g.u, hu = h.u.


@llvm_inline
def trig(psi1, psi2, psi3):  # pragma: no cover - compiled
    s1, c1 = sincos(psi1)
    s2, c2 = sincos(psi2)
    s3, c3 = sincos(psi3)
    return (c1, s1, c2, s2, c3, s3)


@llvm_inline
def gh(cs, i, p):  # pragma: no cover - compiled
    """``g_i`` and ``h_i`` of docs/physics/three-wheel.md TW-1
    (caster-singularity paper (8)-(11))."""
    c = cs[2 * i]
    s = cs[2 * i + 1]
    ax = p[P_A1X + 2 * i]
    ay = p[P_A1Y + 2 * i]
    return (c, s, fma(ax, s, -(ay * c))), (-s, c, fma(ax, c, ay * s))


@llvm_inline
def loads(cs, p):  # pragma: no cover - compiled
    """Static normal loads ``N_i`` (TW-4): barycentric weights of the CoM in the wheel-centre
    triangle, ``N_1 = m g [p_2, p_3] / ([p_2, p_3] + [p_3, p_1] + [p_1, p_2])`` and cyclic,
    which solves ``sum N_i = m g`` and zero moments about the CoM."""
    d = p[P_D]
    x1 = fma(-d, cs[0], p[P_A1X])
    y1 = fma(-d, cs[1], p[P_A1Y])
    x2 = fma(-d, cs[2], p[P_A2X])
    y2 = fma(-d, cs[3], p[P_A2Y])
    x3 = fma(-d, cs[4], p[P_A3X])
    y3 = fma(-d, cs[5], p[P_A3Y])
    c23 = fma(x2, y3, -(y2 * x3))
    c31 = fma(x3, y1, -(y3 * x1))
    c12 = fma(x1, y2, -(y1 * x2))
    w = p[P_MT] * p[P_G] / (c23 + c31 + c12)
    return w * c23, w * c31, w * c12


@llvm_inline
def _mass_i(g, p):  # pragma: no cover - compiled
    """Module share ``(k_w - k_z) g g^T`` of ``M - M_0`` (TW-3), upper triangle; the rest of
    ``k_w g g^T + k_z h h^T`` is constant (see ThreeWheelParams.pack)."""
    k = p[P_KW] - p[P_KZ]
    return (k * g[0] * g[0], k * g[0] * g[1], k * g[0] * g[2], k * g[1] * g[1],
            k * g[1] * g[2], k * g[2] * g[2])


# Every generalized force of module i lies in span{g_i, h_i, e_3} (the rows of J are g_i / r
# and h_i / d - e_3), so the pieces below return its coefficients (a, b, c) on
# (g_i, h_i, e_3) and ``_assemble`` turns them into the 3-vector a g_i + b h_i + c e_3.


@llvm_inline
def dot3(a, vx, vy, wz):  # pragma: no cover - compiled
    """``a . (vx, vy, wz)`` (``g_i . u``, ``h_i . u`` of TW-1), fused."""
    return fma(a[2], wz, fma(a[1], vy, a[0] * vx))


@llvm_inline
def _assemble(g, h, a, b, c):  # pragma: no cover - compiled
    return fma(a, g[0], b * h[0]), fma(a, g[1], b * h[1]), fma(a, g[2], fma(b, h[2], c))


@llvm_inline
def _bias_i(gu, hu, wz, p):  # pragma: no cover - compiled
    """Module share ``psidot_i (k_w (h.u) g - k_z (g.u) h)`` of c (TW-3), as (a, b, c)."""
    psid = fma(hu, p[P_INVD], -wz)  # TW-1 steering rate
    return psid * p[P_KW] * hu, -psid * p[P_KZ] * gu, 0.0


@llvm_inline
def _friction_i(gu, hu, wz, n_i, p):  # pragma: no cover - compiled
    """Module share of Q_f (TW-4) as (a, b, c): rolling resistance ``-mu_r N_i sgn_s(g.u) g``,
    pivot scrub ``-mu_p N_i sgn_s(rho h.u / d) h / d``, viscous joints
    ``-J_i^T B J_i u = -b_drive thetadot (g / r) - b_steer psidot (h / d - e_3)``."""
    invd = p[P_INVD]
    invr = p[P_INVR]
    ks = p[P_KS]
    thd = gu * invr  # TW-1 drive rate
    psid = fma(hu, invd, -wz)  # TW-1 steering rate
    roll = p[P_MUR] * n_i * sgn_s(gu, ks)
    scrub = p[P_MUP] * n_i * sgn_s(p[P_RHO] * hu * invd, ks) * invd
    visc_s = p[P_BS] * psid
    return -roll - p[P_BD] * thd * invr, -scrub - visc_s * invd, visc_s


@llvm_inline
def _jt_tau_i(tau_drive, tau_steer, p):  # pragma: no cover - compiled
    """Module share of ``J^T tau`` as (a, b, c): ``tau_d g / r + tau_s (h / d - e_3)``."""
    return tau_drive * p[P_INVR], tau_steer * p[P_INVD], -tau_steer


@llvm_inline
def jacobian_rows(g, h, p):  # pragma: no cover - compiled
    """Module i's two rows of J (TW-1): drive ``g_i / r``, steer ``h_i / d - e_3``."""
    invr = p[P_INVR]
    invd = p[P_INVD]
    return ((g[0] * invr, g[1] * invr, g[2] * invr),
            (h[0] * invd, h[1] * invd, h[2] * invd - 1.0))


@llvm_inline
def mass(cs, p):  # pragma: no cover - compiled
    """Upper triangle (m00, m01, m02, m11, m12, m22) of M(psi), docs/physics/three-wheel.md TW-3."""
    m = (p[P_M0], p[P_M0 + 1], p[P_M0 + 2], p[P_M0 + 3], p[P_M0 + 4], p[P_M0 + 5])  # M_0
    for i in range(3):
        g, h = gh(cs, i, p)
        a = _mass_i(g, p)
        m = (m[0] + a[0], m[1] + a[1], m[2] + a[2], m[3] + a[3], m[4] + a[4], m[5] + a[5])
    return m


@llvm_inline
def bias(cs, vx, vy, wz, p):  # pragma: no cover - compiled
    """Coriolis/centripetal term c(psi, u) of docs/physics/three-wheel.md TW-3
    (three-wheel paper (26))."""
    c0 = -p[P_MB] * wz * vy  # platform m_b (-wz vy, wz vx, 0)
    c1 = p[P_MB] * wz * vx
    c2 = 0.0
    for i in range(3):
        g, h = gh(cs, i, p)
        gu = dot3(g, vx, vy, wz)
        hu = dot3(h, vx, vy, wz)
        ba, bb, bc = _bias_i(gu, hu, wz, p)
        b = _assemble(g, h, ba, bb, bc)
        c0 += b[0]
        c1 += b[1]
        c2 += b[2]
    return c0, c1, c2


@llvm_inline
def friction(cs, vx, vy, wz, p):  # pragma: no cover - compiled
    """Generalized friction Q_f(psi, u) of docs/physics/three-wheel.md TW-4."""
    n = loads(cs, p)
    q0 = 0.0
    q1 = 0.0
    q2 = 0.0
    for i in range(3):
        g, h = gh(cs, i, p)
        gu = dot3(g, vx, vy, wz)
        hu = dot3(h, vx, vy, wz)
        fa, fb, fc = _friction_i(gu, hu, wz, n[i], p)
        f = _assemble(g, h, fa, fb, fc)
        q0 += f[0]
        q1 += f[1]
        q2 += f[2]
    return q0, q1, q2


@llvm_inline
def friction_jac_rest(cs, p):  # pragma: no cover - compiled
    """Upper triangle of ``dQ_f/du`` at ``u = 0`` (symmetric, negative semi-definite):
    ``-sum_i [mu_r N_i s' g g^T + mu_p N_i s' (rho / d^2) h h^T + J_i^T B_i J_i]`` with
    ``s' = 2 k_s / pi``, the slope of sgn_s at 0 (TW-4 differentiated)."""
    n = loads(cs, p)
    invd = p[P_INVD]
    k = 2.0 * p[P_KS] / math.pi
    e = np.zeros(6)
    for i in range(3):
        g, h = gh(cs, i, p)
        jd, js = jacobian_rows(g, h, p)
        kg = p[P_MUR] * n[i] * k
        kh = p[P_MUP] * n[i] * k * p[P_RHO] * invd * invd
        idx = 0
        for a in range(3):
            for b in range(a, 3):
                e[idx] -= (kg * g[a] * g[b] + kh * h[a] * h[b] + p[P_BD] * jd[a] * jd[b]
                           + p[P_BS] * js[a] * js[b])
                idx += 1
    return e[0], e[1], e[2], e[3], e[4], e[5]


@llvm_inline
def solve3(m, f0, f1, f2):  # pragma: no cover - compiled
    """Solve the symmetric 3x3 system ``M a = f`` by cofactors (M is positive definite)."""
    m00, m01, m02, m11, m12, m22 = m
    a00 = fma(m11, m22, -(m12 * m12))
    a01 = fma(m02, m12, -(m01 * m22))
    a02 = fma(m01, m12, -(m02 * m11))
    a11 = fma(m00, m22, -(m02 * m02))
    a12 = fma(m01, m02, -(m00 * m12))
    a22 = fma(m00, m11, -(m01 * m01))
    inv_det = 1.0 / fma(m02, a02, fma(m01, a01, m00 * a00))
    return (fma(a02, f2, fma(a01, f1, a00 * f0)) * inv_det,
            fma(a12, f2, fma(a11, f1, a01 * f0)) * inv_det,
            fma(a22, f2, fma(a12, f1, a02 * f0)) * inv_det)


@njit(cache=True, inline="always")
def _module_terms(cs, i, n_i, vx, vy, wz, tau_drive, tau_steer, p, m, f, applied):
    """Add module i's shares of M and of ``J^T tau + Q_f - c`` to ``m`` and ``f``; also return
    its TW-1 joint rates ``(psidot_i, thetadot_i)``. The motors apply the torque
    ``applied(command, rate, mode, p, block)`` at these rates (models/motor.py:
    ``ideal_applied``, the command itself, or ``dc_applied``, the DC motor's envelope)."""
    # pragma: no cover - compiled
    g, h = gh(cs, i, p)
    gu = dot3(g, vx, vy, wz)
    hu = dot3(h, vx, vy, wz)
    psid = fma(hu, p[P_INVD], -wz)  # TW-1 steering rate
    thd = gu * p[P_INVR]  # TW-1 drive rate
    mode = p[P_MOTOR]
    a = _mass_i(g, p)
    tb = _bias_i(gu, hu, wz, p)
    tq = _friction_i(gu, hu, wz, n_i, p)
    tt = _jt_tau_i(applied(tau_drive, thd, mode, p, P_MDRV),
                   applied(tau_steer, psid, mode, p, P_MSTR), p)
    df = _assemble(g, h, tt[0] + tq[0] - tb[0], tt[1] + tq[1] - tb[1], tt[2] + tq[2] - tb[2])
    return ((m[0] + a[0], m[1] + a[1], m[2] + a[2], m[3] + a[3], m[4] + a[4], m[5] + a[5]),
            (f[0] + df[0], f[1] + df[1], f[2] + df[2]),
            psid,
            thd)


@njit(cache=True, inline="always")
def _deriv(x, u, p, applied):  # pragma: no cover - compiled
    """The state derivative as a 12-tuple with the motor law ``applied`` (see
    :func:`_module_terms`). ``x``, ``u``, ``p`` are arrays or tuples read by constant index
    only, so the block kernels (tuples, no branches) vectorise."""
    yaw = x[2]
    vx = x[3]
    vy = x[4]
    wz = x[5]
    cs = trig(x[6], x[7], x[8])
    sy, cy = sincos(yaw)
    n = loads(cs, p)
    # TW-3: M udot = J^T tau + Q_f - c; the platform's share, then each module's
    m = (p[P_M0], p[P_M0 + 1], p[P_M0 + 2], p[P_M0 + 3], p[P_M0 + 4], p[P_M0 + 5])
    f = (p[P_MB] * wz * vy, -p[P_MB] * wz * vx, 0.0)
    m, f, psid1, thd1 = _module_terms(cs, 0, n[0], vx, vy, wz, u[0], u[3], p, m, f, applied)
    m, f, psid2, thd2 = _module_terms(cs, 1, n[1], vx, vy, wz, u[1], u[4], p, m, f, applied)
    m, f, psid3, thd3 = _module_terms(cs, 2, n[2], vx, vy, wz, u[2], u[5], p, m, f, applied)
    a0, a1, a2 = solve3(m, f[0], f[1], f[2])
    # docs/physics/conventions.md (three-wheel paper (15)-(16)), TW-3 and the TW-1 joint rates
    return (fma(cy, vx, -(sy * vy)), fma(sy, vx, cy * vy), wz, a0, a1, a2,
            psid1, psid2, psid3, thd1, thd2, thd3)


@llvm_inline
def deriv_block(x, u, p):  # pragma: no cover - compiled
    """The state derivative as a 12-tuple with ideal motors (the joints get ``u``)."""
    return _deriv(x, u, p, ideal_applied)


@llvm_inline
def deriv_block_dc(x, u, p):  # pragma: no cover - compiled
    """The state derivative as a 12-tuple with DC motors (models/motor.py)."""
    return _deriv(x, u, p, dc_applied)


@njit(cache=True)
def deriv_one(x, u, p, out):  # pragma: no cover - compiled
    d = deriv_block(x, u, p)
    for j in range(12):
        out[j] = d[j]


@njit(cache=True)
def deriv_one_dc(x, u, p, out):  # pragma: no cover - compiled
    d = deriv_block_dc(x, u, p)
    for j in range(12):
        out[j] = d[j]


@llvm_inline
def power_t(x, k, u, p):  # pragma: no cover - compiled
    """Motor power ``tau . qdot`` (W) of ideal motors at a state whose derivative is ``k``: the
    derivative holds the TW-1 joint rates (TW-5 order), ``k[9 + i]`` drive and ``k[6 + i]``
    steering; motor order [drive_1..3, steer_1..3]."""
    return fma(u[5], k[8], fma(u[4], k[7], fma(u[3], k[6], fma(
        u[2], k[11], fma(u[1], k[10], u[0] * k[9])))))


@llvm_inline
def power_t_dc(x, k, u, p):  # pragma: no cover - compiled
    """Power the DC motors draw (W): the electrical power ``sum V i`` (models/motor.py) at the
    joint rates of ``k`` (as :func:`power_t`), which the environments' energy integral then
    accumulates; :func:`power_t` where the mode code is ideal."""
    mech = power_t(x, k, u, p)
    mode = p[P_MOTOR]
    el = (dc_power(u[0], k[9], mode, p, P_MDRV) + dc_power(u[1], k[10], mode, p, P_MDRV)
          + dc_power(u[2], k[11], mode, p, P_MDRV) + dc_power(u[3], k[6], mode, p, P_MSTR)
          + dc_power(u[4], k[7], mode, p, P_MSTR) + dc_power(u[5], k[8], mode, p, P_MSTR))
    return mech if mode == 0.0 else el


@llvm_inline
def joint_rates(x, p):  # pragma: no cover - compiled
    """The six joint rates (rad/s) in motor order, the bits of :func:`deriv_block`'s."""
    cs = trig(x[6], x[7], x[8])
    vx = x[3]
    vy = x[4]
    wz = x[5]
    g, h = gh(cs, 0, p)
    d1, s1 = dot3(g, vx, vy, wz) * p[P_INVR], fma(dot3(h, vx, vy, wz), p[P_INVD], -wz)
    g, h = gh(cs, 1, p)
    d2, s2 = dot3(g, vx, vy, wz) * p[P_INVR], fma(dot3(h, vx, vy, wz), p[P_INVD], -wz)
    g, h = gh(cs, 2, p)
    d3, s3 = dot3(g, vx, vy, wz) * p[P_INVR], fma(dot3(h, vx, vy, wz), p[P_INVD], -wz)
    return d1, d2, d3, s1, s2, s3


@njit(cache=True)
def k_motor(X, U, p, out):  # pragma: no cover - compiled
    """Per row and motor: ``out[k, 0]`` joint rate (rad/s), ``out[k, 1]`` applied joint torque
    (N·m), ``out[k, 2]`` current (A) and ``out[k, 3]`` terminal voltage (V) of the DC motor
    law (models/motor.py; the current and voltage are those a DC motor would have, also in
    ideal mode, where the applied torque is the command). ``out`` is ``(N, 4, 6)``."""
    mode = p[P_MOTOR]
    for k in range(X.shape[0]):
        w = joint_rates(X[k], p)
        for j in range(6):
            o = P_MDRV if j < 3 else P_MSTR
            i, e = dc_current(U[k, j], w[j], mode, p, o)
            out[k, 0, j] = w[j]
            out[k, 1, j] = dc_applied(U[k, j], w[j], mode, p, o)
            out[k, 2, j] = i
            out[k, 3, j] = p[o + M_R] * i + e  # V = R_w i + e


@llvm_inline
def _put_sym3(out, upper):  # pragma: no cover - compiled
    """Write the symmetric 3x3 matrix whose upper triangle is
    ``upper = (a00, a01, a02, a11, a12, a22)`` into ``out``."""
    a00, a01, a02, a11, a12, a22 = upper
    out[0, 0] = a00
    out[0, 1] = a01
    out[1, 0] = a01
    out[0, 2] = a02
    out[2, 0] = a02
    out[1, 1] = a11
    out[1, 2] = a12
    out[2, 1] = a12
    out[2, 2] = a22


# Batched kernels of the pieces: PSI (N, 3), V (N, 3) body twists.
@njit(cache=True)
def k_psi_pieces(PSI, p, jac, mass_out, loads_out, centers, fjac):  # pragma: no cover - compiled
    """Fill J (N,6,3), M (N,3,3), N_i (N,3), wheel centres (N,3,2), dQ_f/du at rest (N,3,3)."""
    d = p[P_D]
    for k in range(PSI.shape[0]):
        cs = trig(PSI[k, 0], PSI[k, 1], PSI[k, 2])
        for i in range(3):
            g, h = gh(cs, i, p)
            jd, js = jacobian_rows(g, h, p)
            for j in range(3):
                jac[k, i, j] = jd[j]
                jac[k, 3 + i, j] = js[j]
            centers[k, i, 0] = p[P_A1X + 2 * i] - d * cs[2 * i]  # p_i = a_i - d e_i
            centers[k, i, 1] = p[P_A1Y + 2 * i] - d * cs[2 * i + 1]
        _put_sym3(mass_out[k], mass(cs, p))
        _put_sym3(fjac[k], friction_jac_rest(cs, p))
        n1, n2, n3 = loads(cs, p)
        loads_out[k, 0] = n1
        loads_out[k, 1] = n2
        loads_out[k, 2] = n3


@njit(cache=True)
def k_twist_pieces(PSI, V, p, bias_out, fric):  # pragma: no cover - compiled
    """Fill c(psi, u) (N,3) and Q_f(psi, u) (N,3)."""
    for k in range(PSI.shape[0]):
        cs = trig(PSI[k, 0], PSI[k, 1], PSI[k, 2])
        bias_out[k, 0], bias_out[k, 1], bias_out[k, 2] = bias(cs, V[k, 0], V[k, 1], V[k, 2], p)
        fric[k, 0], fric[k, 1], fric[k, 2] = friction(cs, V[k, 0], V[k, 1], V[k, 2], p)


# ---------------------------------------------------------------------------- batch kernels
#: The model's batch kernels: the generic bodies of wheelgym.integrators with this robot's
#: derivative (vectorised blocks of integrators.LANES robots), ideal motors.
KERNELS = model_kernels(__name__, __file__, deriv_one, NX, NU, deriv_block, power_t, NP)


@functools.cache
def dc_kernels() -> _integrators.ModelKernels:
    """The batch kernels with DC motors (``deriv_one_dc``, ``deriv_block_dc``, stage power
    ``power_t_dc``: the electrical power), named ``k_*_dc``; built on first use, so ideal-motor
    users never compile them. ``dc_kernels().block`` is the DC twin of :data:`k_block`."""
    return model_kernels(__name__, __file__, deriv_one_dc, NX, NU, deriv_block_dc, power_t_dc,
                         NP, suffix="_dc")
#: ``k_block(X, U, P, h, n, out, work, b0)``: one vectorised block with the motor work (J);
#: the model's batch steps and the environments' step kernel all call this one function.
k_block = KERNELS.block
