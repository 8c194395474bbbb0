"""Compiled pieces of the caster AGV (docs/physics/caster-robots.md), for every layer's kernels.

The model (:class:`wheelgym.models.CasterAGV`), the environments' step kernel and the
controllers inline these functions. They read the packed parameter array ``p`` of
:meth:`CasterAGVParams.pack` through the ``P_*`` indices below; ``(gc0, gc1, hc0, hc1)`` are
the caster's ``g_c``, ``h_c`` of :func:`gh`, ``(v, w)`` the body twist.

| name                  | what                                                       |
|-----------------------|------------------------------------------------------------|
| ``gh``                | caster ``g_c``, ``h_c`` (TW-1 without the vy column)       |
| ``loads``             | static normal loads ``(N_L, N_R, N_c)``                    |
| ``mass``              | ``(m00, m01, m11)`` of ``M(sigma)``                        |
| ``bias``              | ``c(sigma, u)``                                            |
| ``friction``          | ``Q_f(sigma, u)``                                          |
| ``friction_jac_rest`` | ``dQ_f/du`` at rest                                        |
| ``deriv_one``         | the state derivative of one state into ``out``             |
| ``power_t``           | motor power ``tau . omega`` (ideal motors)                 |
| ``*_dc``              | the same with DC motors (models/motor.py); ``power_t_dc``  |
|                       | the electrical ``V . i``; ``dc_kernels()`` their kernels   |
| ``k_motor``           | joint rate, applied torque, current, voltage per motor     |
| ``KERNELS``           | the model's batch kernels (integrators.model_kernels)      |

The formulas are those of the model module's docstring (:mod:`wheelgym.models.caster_agv`).
"""

from __future__ import annotations

import functools
import math

from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import llvm_inline, model_kernels
from wheelgym.models import friction as _friction_module
from wheelgym.models import motor as _motor_module
from wheelgym.models.friction import sgn_s
from wheelgym.models.motor import M_R, MOTOR_NP, dc_applied, dc_current, dc_power, ideal_applied

# kernels here inline integrators.rk4_inplace, friction.sgn_s and the DC motor law of
# models/motor.py
_numba_cache.guard(__file__, _integrators.__file__, _friction_module.__file__,
                   _motor_module.__file__)

__all__ = [
    "P_MB", "P_IB", "P_XG", "P_MW", "P_IWY", "P_IWZ", "P_R", "P_C", "P_AX", "P_AY", "P_D",
    "P_RC", "P_MC", "P_ICY", "P_ICZ", "P_MUR", "P_MUP", "P_RHO", "P_BD", "P_BC", "P_KS", "P_G",
    "P_TMAX", "P_KW", "P_KC", "P_KCZ", "P_MT", "P_INVR", "P_INVRC", "P_INVD", "P_M11",
    "P_MBXG", "P_GMBXG", "P_GMC", "P_GDRV", "P_INVC", "P_BDR2", "P_BCR2", "P_MOTOR", "P_MBLK",
    "NP", "NX", "NU", "gh", "loads", "mass", "bias", "friction", "friction_jac_rest",
    "deriv_one", "power_t", "deriv_one_dc", "power_t_dc", "dc_kernels", "k_motor",
    "k_sigma_pieces", "k_twist_pieces", "KERNELS",
]

#: Indices into the packed parameter array (CasterAGVParams.pack; P_KW .. P_BCR2 derived);
#: P_MOTOR the motor mode code (models/motor.py MODES: 0 ideal, 1 dc, 2 dc_voltage), P_MBLK
#: the block of the two (equal) drive motors (motor.pack_motor).
(P_MB, P_IB, P_XG, P_MW, P_IWY, P_IWZ, P_R, P_C, P_AX, P_AY, P_D, P_RC, P_MC, P_ICY, P_ICZ,
 P_MUR, P_MUP, P_RHO, P_BD, P_BC, P_KS, P_G, P_TMAX, P_KW, P_KC, P_KCZ, P_MT, P_INVR,
 P_INVRC, P_INVD, P_M11, P_MBXG, P_GMBXG, P_GMC, P_GDRV, P_INVC, P_BDR2, P_BCR2,
 P_MOTOR) = range(39)
P_MBLK = 39
NP = P_MBLK + MOTOR_NP  # length of the packed array
NX = 9  # state size
NU = 2  # input size


# ---------------------------------------------------------------------------- compiled pieces
@llvm_inline
def gh(cs, sn, p):  # pragma: no cover - compiled
    """Caster ``g_c``, ``h_c`` (docs/physics/three-wheel.md TW-1 with the vy column dropped)."""
    ax = p[P_AX]
    ay = p[P_AY]
    return cs, ax * sn - ay * cs, -sn, ax * cs + ay * sn


@llvm_inline
def loads(cs, sn, p):  # pragma: no cover - compiled
    """Static normal loads ``(N_L, N_R, N_c)`` (N): total weight at the total centre of mass,
    force and moment balance over the contacts ``(0, c)``, ``(0, -c)``, ``p = a - d e``.

    Moments about the axle line give ``N_c p_x = g (m_b x_G + m_c p_x)``, about the x axis
    ``c (N_L - N_R) + N_c p_y = g m_c p_y``; with ``t = g m_b x_G / p_x`` these read
    ``N_c = t + g m_c`` and ``N_L - N_R = -t p_y / c``."""
    px = p[P_AX] - p[P_D] * cs
    py = p[P_AY] - p[P_D] * sn
    t = p[P_GMBXG] / px
    rest = p[P_GDRV] - t  # N_L + N_R
    diff = -t * py * p[P_INVC]  # N_L - N_R
    return 0.5 * (rest + diff), 0.5 * (rest - diff), t + p[P_GMC]


@llvm_inline
def mass(gc0, gc1, hc0, hc1, p):  # pragma: no cover - compiled
    """``(m00, m01, m11)`` of M(sigma) (module docstring)."""
    c = p[P_C]
    kw = p[P_KW]
    kc = p[P_KC]
    kz = p[P_KCZ]
    return (p[P_MB] + 2.0 * kw + kc * gc0 * gc0 + kz * hc0 * hc0,
            kc * gc0 * gc1 + kz * hc0 * hc1,
            p[P_M11] + 2.0 * kw * c * c + kc * gc1 * gc1 + kz * hc1 * hc1)


@llvm_inline
def bias(gc0, gc1, hc0, hc1, v, w, p):  # pragma: no cover - compiled
    """Coriolis/centripetal term ``c(sigma, u)`` (module docstring,
    docs/physics/three-wheel.md TW-3)."""
    gu = gc0 * v + gc1 * w
    hu = hc0 * v + hc1 * w
    sd = hu * p[P_INVD] - w  # TW-1 swivel rate
    a = sd * p[P_KC] * hu
    b = sd * p[P_KCZ] * gu
    return -p[P_MBXG] * w * w + a * gc0 - b * hc0, p[P_MBXG] * w * v + a * gc1 - b * hc1


@llvm_inline
def friction(gc0, gc1, hc0, hc1, v, w, n_l, n_r, n_c, p):  # pragma: no cover - compiled
    """Generalized friction ``Q_f(sigma, u)`` (module docstring,
    docs/physics/three-wheel.md TW-4)."""
    c = p[P_C]
    ks = p[P_KS]
    invd = p[P_INVD]
    ul = v - c * w  # g_L . u
    ur = v + c * w  # g_R . u
    fl = p[P_MUR] * n_l * sgn_s(ul, ks) + p[P_BDR2] * ul
    fr = p[P_MUR] * n_r * sgn_s(ur, ks) + p[P_BDR2] * ur
    piv = p[P_MUP] * (n_l + n_r) * sgn_s(p[P_RHO] * w, ks)  # drive-wheel pivot scrub
    gu = gc0 * v + gc1 * w
    hu = hc0 * v + hc1 * w
    pivot = hu * invd  # caster wheel rate about the vertical, w + sigmadot
    fa = p[P_MUR] * n_c * sgn_s(gu, ks) + p[P_BCR2] * gu
    fb = p[P_MUP] * n_c * sgn_s(p[P_RHO] * pivot, ks) * invd
    fs = p[P_BC] * (pivot - w)  # swivel joint, b_caster sigmadot
    q0 = -(fl + fr) - fa * gc0 - (fb + fs * invd) * hc0
    q1 = c * (fl - fr) - piv - fa * gc1 - (fb + fs * invd) * hc1 + fs
    return q0, q1


@llvm_inline
def friction_jac_rest(gc0, gc1, hc0, hc1, n_l, n_r, n_c, p):  # pragma: no cover - compiled
    """``(e00, e01, e11)`` of ``dQ_f/du`` at ``u = 0`` (symmetric, negative definite)."""
    k = 2.0 * p[P_KS] / math.pi  # slope of sgn_s at 0
    c = p[P_C]
    invd = p[P_INVD]
    kd = p[P_BD] * p[P_INVR] * p[P_INVR]
    kl = p[P_MUR] * n_l * k + kd
    kr = p[P_MUR] * n_r * k + kd
    kp = p[P_MUP] * (n_l + n_r) * k * p[P_RHO]
    kg = p[P_MUR] * n_c * k + p[P_BC] * p[P_INVRC] * p[P_INVRC]
    kh = p[P_MUP] * n_c * k * p[P_RHO] * invd * invd
    s0 = hc0 * invd
    s1 = hc1 * invd - 1.0
    bc = p[P_BC]
    e00 = kl + kr + kg * gc0 * gc0 + kh * hc0 * hc0 + bc * s0 * s0
    e01 = c * (kl - kr) + kg * gc0 * gc1 + kh * hc0 * hc1 + bc * s0 * s1
    e11 = c * c * (kl + kr) + kp + kg * gc1 * gc1 + kh * hc1 * hc1 + bc * s1 * s1
    return -e00, -e01, -e11


@njit(cache=True, inline="always")
def _deriv_one(x, u, p, out, applied):  # pragma: no cover - compiled
    """The state derivative into ``out`` with the motor law ``applied`` (models/motor.py:
    ``ideal_applied`` or ``dc_applied``)."""
    yaw = x[2]
    v = x[3]
    w = x[4]
    cs = math.cos(x[5])
    sn = math.sin(x[5])
    out[0] = math.cos(yaw) * v  # docs/physics/conventions.md with vy = 0
    out[1] = math.sin(yaw) * v
    out[2] = w
    gc0, gc1, hc0, hc1 = gh(cs, sn, p)
    c = p[P_C]
    out[5] = (hc0 * v + hc1 * w) * p[P_INVD] - w  # TW-1 swivel rate
    thl = (v - c * w) * p[P_INVR]  # thetadot_L
    thr = (v + c * w) * p[P_INVR]  # thetadot_R
    out[6] = thl
    out[7] = thr
    out[8] = (gc0 * v + gc1 * w) * p[P_INVRC]  # thetadot_c
    n_l, n_r, n_c = loads(cs, sn, p)
    m00, m01, m11 = mass(gc0, gc1, hc0, hc1, p)
    b0, b1 = bias(gc0, gc1, hc0, hc1, v, w, p)
    q0, q1 = friction(gc0, gc1, hc0, hc1, v, w, n_l, n_r, n_c, p)
    # the torques the motors apply at the wheel rates (models/motor.py; ideal: u itself)
    mode = p[P_MOTOR]
    tl = applied(u[0], thl, mode, p, P_MBLK)
    tr = applied(u[1], thr, mode, p, P_MBLK)
    # M udot = (g_L tau_L + g_R tau_R) / r + Q_f - c
    f0 = (tl + tr) * p[P_INVR] + q0 - b0
    f1 = c * (tr - tl) * p[P_INVR] + q1 - b1
    inv_det = 1.0 / (m00 * m11 - m01 * m01)
    out[3] = (m11 * f0 - m01 * f1) * inv_det
    out[4] = (m00 * f1 - m01 * f0) * inv_det


@njit(cache=True)
def deriv_one(x, u, p, out):  # pragma: no cover - compiled
    _deriv_one(x, u, p, out, ideal_applied)


@njit(cache=True)
def deriv_one_dc(x, u, p, out):  # pragma: no cover - compiled
    _deriv_one(x, u, p, out, dc_applied)


@llvm_inline
def power_t(x, k, u, p):  # pragma: no cover - compiled
    """Motor power ``tau_L thetadot_L + tau_R thetadot_R`` (W) of ideal motors at a stage whose
    derivative is ``k`` (``k[6]``, ``k[7]`` the drive rates; the environment's stage power)."""
    return u[0] * k[6] + u[1] * k[7]


@llvm_inline
def power_t_dc(x, k, u, p):  # pragma: no cover - compiled
    """Power the DC motors draw (W): the electrical ``sum V i`` (models/motor.py) at the
    drive rates of ``k``; :func:`power_t` where the mode code is ideal."""
    mode = p[P_MOTOR]
    el = dc_power(u[0], k[6], mode, p, P_MBLK) + dc_power(u[1], k[7], mode, p, P_MBLK)
    return power_t(x, k, u, p) if mode == 0.0 else el


@njit(cache=True)
def k_motor(X, U, p, out):  # pragma: no cover - compiled
    """Per row and motor: ``out[k, 0]`` joint rate (rad/s), ``out[k, 1]`` applied joint torque
    (N·m), ``out[k, 2]`` current (A), ``out[k, 3]`` terminal voltage (V) (models/motor.py;
    current and voltage those of a DC motor, also in ideal mode). ``out`` is ``(N, 4, 2)``."""
    mode = p[P_MOTOR]
    c = p[P_C]
    for k in range(X.shape[0]):
        v = X[k, 3]
        w = X[k, 4]
        for j in range(2):
            wj = (v - c * w) * p[P_INVR] if j == 0 else (v + c * w) * p[P_INVR]
            i, e = dc_current(U[k, j], wj, mode, p, P_MBLK)
            out[k, 0, j] = wj
            out[k, 1, j] = dc_applied(U[k, j], wj, mode, p, P_MBLK)
            out[k, 2, j] = i
            out[k, 3, j] = p[P_MBLK + M_R] * i + e  # V = R_w i + e


@njit(cache=True)
def k_sigma_pieces(S, p, jac, mass_out, loads_out, centers, fjac):  # pragma: no cover - compiled
    """Fill J (N,4,2), M (N,2,2), N_j (N,3), wheel centres (N,3,2), dQ_f/du at rest (N,2,2)."""
    c = p[P_C]
    for k in range(S.shape[0]):
        cs = math.cos(S[k])
        sn = math.sin(S[k])
        gc0, gc1, hc0, hc1 = gh(cs, sn, p)
        jac[k, 0, 0] = p[P_INVR]
        jac[k, 0, 1] = -c * p[P_INVR]
        jac[k, 1, 0] = p[P_INVR]
        jac[k, 1, 1] = c * p[P_INVR]
        jac[k, 2, 0] = gc0 * p[P_INVRC]
        jac[k, 2, 1] = gc1 * p[P_INVRC]
        jac[k, 3, 0] = hc0 * p[P_INVD]
        jac[k, 3, 1] = hc1 * p[P_INVD] - 1.0
        m00, m01, m11 = mass(gc0, gc1, hc0, hc1, p)
        mass_out[k, 0, 0] = m00
        mass_out[k, 0, 1] = m01
        mass_out[k, 1, 0] = m01
        mass_out[k, 1, 1] = m11
        n_l, n_r, n_c = loads(cs, sn, p)
        loads_out[k, 0] = n_l
        loads_out[k, 1] = n_r
        loads_out[k, 2] = n_c
        centers[k, 0, 0] = 0.0
        centers[k, 0, 1] = c
        centers[k, 1, 0] = 0.0
        centers[k, 1, 1] = -c
        centers[k, 2, 0] = p[P_AX] - p[P_D] * cs
        centers[k, 2, 1] = p[P_AY] - p[P_D] * sn
        e00, e01, e11 = friction_jac_rest(gc0, gc1, hc0, hc1, n_l, n_r, n_c, p)
        fjac[k, 0, 0] = e00
        fjac[k, 0, 1] = e01
        fjac[k, 1, 0] = e01
        fjac[k, 1, 1] = e11


@njit(cache=True)
def k_twist_pieces(S, V, p, bias_out, fric):  # pragma: no cover - compiled
    """Fill c(sigma, u) (N,2) and Q_f(sigma, u) (N,2)."""
    for k in range(S.shape[0]):
        cs = math.cos(S[k])
        sn = math.sin(S[k])
        gc0, gc1, hc0, hc1 = gh(cs, sn, p)
        v = V[k, 0]
        w = V[k, 1]
        bias_out[k, 0], bias_out[k, 1] = bias(gc0, gc1, hc0, hc1, v, w, p)
        n_l, n_r, n_c = loads(cs, sn, p)
        fric[k, 0], fric[k, 1] = friction(gc0, gc1, hc0, hc1, v, w, n_l, n_r, n_c, p)


# ---------------------------------------------------------------------------- batch kernels
#: The model's batch kernels: the generic bodies of wheelgym.integrators with this robot's
#: derivative, a row at a time.
KERNELS = model_kernels(__name__, __file__, deriv_one, NX, NU)


@functools.cache
def dc_kernels() -> _integrators.ModelKernels:
    """The batch kernels with DC motors (``k_*_dc``), built on first use."""
    return model_kernels(__name__, __file__, deriv_one_dc, NX, NU, suffix="_dc")
