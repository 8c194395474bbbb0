"""Compiled pieces of the skid-steer robot (docs/physics/skid-steer.md), for every layer's kernels.

The model (:class:`wheelgym.models.SkidSteer`), the environments' step kernel and the
controllers inline these functions. They read the packed parameter array ``p`` of
:meth:`SkidSteerParams.pack` through the ``P_*`` indices below.

| name          | what                                                                  |
|---------------|-----------------------------------------------------------------------|
| ``loads``     | ``(N_rear, N_front)`` of SS-2                                         |
| ``resist``    | ``Rbar`` of SS-2/SS-3 and the friction power                          |
| ``deriv_block`` | the state derivative as a 5-tuple, branch-free (blocks)             |
| ``deriv_one`` | the same into an array ``out`` (one state)                            |
| ``power_t``   | motor power ``tau . omega`` (SS-1, SS-3)                              |
| ``*_dc``      | the same with DC motors (models/motor.py); ``power_t_dc`` the         |
|               | electrical ``V . i``; ``dc_kernels()`` their batch kernels            |
| ``wheel_rates`` | ``(omega_L, omega_R)`` of SS-1                                      |
| ``k_motor``   | joint rate, applied torque, current, voltage of each motor            |
| ``KERNELS``   | the model's batch kernels (integrators.model_kernels); ``k_block``    |
|               | its vectorised block step                                             |
"""

from __future__ import annotations

import functools

from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import llvm_inline, model_kernels
from wheelgym.models import friction as _friction_module
from wheelgym.models import motor as _motor_module
from wheelgym.models.friction import sgn_s, sincos
from wheelgym.models.motor import M_R, MOTOR_NP, dc_applied, dc_current, dc_power, ideal_applied

# kernels here inline integrators.rk4_inplace, integrators.rk4_block, friction.sgn_s and the
# DC motor law of models/motor.py
_numba_cache.guard(__file__, _integrators.__file__, _friction_module.__file__,
                   _motor_module.__file__)

__all__ = [
    "P_M", "P_I", "P_A", "P_B", "P_C", "P_R", "P_XICR", "P_MUS", "P_MUL", "P_KS", "P_G",
    "P_TMAX", "P_INVR", "P_MOTOR", "P_MBLK", "NP", "NX", "NU", "loads", "resist",
    "deriv_block", "deriv_one", "power_t", "deriv_block_dc", "deriv_one_dc", "power_t_dc",
    "dc_kernels", "wheel_rates", "k_motor", "k_resist", "KERNELS",
    "k_block",
]

#: Indices into the packed parameter array (SkidSteerParams.pack): the parameters, then
#: P_INVR = 1 / r, P_MOTOR the motor mode code (models/motor.py MODES: 0 ideal, 1 dc,
#: 2 dc_voltage) and P_MBLK the block of the four (equal) motors (motor.pack_motor).
P_M, P_I, P_A, P_B, P_C, P_R, P_XICR, P_MUS, P_MUL, P_KS, P_G, P_TMAX, P_INVR, P_MOTOR = range(14)
P_MBLK = 14
NP = P_MBLK + MOTOR_NP  # length of the packed array
NX = 5  # state size
NU = 4  # input size


# ---------------------------------------------------------------------------- compiled pieces
@llvm_inline
def loads(p):  # pragma: no cover - compiled
    """(N_rear, N_front) of SS-2."""
    s = 2.0 * (p[P_A] + p[P_B])
    return p[P_B] * p[P_M] * p[P_G] / s, p[P_A] * p[P_M] * p[P_G] / s


@llvm_inline
def resist(vx, wz, p):  # pragma: no cover - compiled
    """Rbar = (sum F_si, -x_icr sum F_li + M_r) of SS-2/SS-3 and the friction power (W, <= 0).

    Grouped as in the skid-steer notes: the two wheels of a side share ``v_ix`` (``v_L``,
    ``v_R``), the two wheels of an axle share ``v_iy`` (``v_F``, ``v_B``), so four smoothed
    signs serve eight forces, and ``M_r`` is the notes' side/axle sum. With equal side
    torques and ``wz = 0`` the two sides' forces are bitwise equal and ``M_r`` is exactly 0.
    """
    a, b, c, xicr, ks = p[P_A], p[P_B], p[P_C], p[P_XICR], p[P_KS]
    n_rear, n_front = loads(p)
    vy = -xicr * wz  # SS-1 ICR constraint vy + x_icr wz = 0
    # SS-1 contact velocities v_ix = vx - wz y_i, v_iy = vy + wz x_i (y_i = +-c, x_i = -a, b)
    v_l = vx - wz * c  # wheels 1, 2 (left)
    v_r = vx + wz * c  # wheels 3, 4 (right)
    v_f = vy + wz * b  # wheels 2, 3 (front)
    v_b = vy - wz * a  # wheels 1, 4 (rear)
    # SS-2: F_si = mu_s N_i sgn_s(v_ix), F_li = mu_l N_i sgn_s(v_iy)
    s_l = p[P_MUS] * sgn_s(v_l, ks)
    s_r = p[P_MUS] * sgn_s(v_r, ks)
    l_f = p[P_MUL] * sgn_s(v_f, ks)
    l_b = p[P_MUL] * sgn_s(v_b, ks)
    fs_left = n_rear * s_l + n_front * s_l  # F_s1 + F_s2
    fs_right = n_front * s_r + n_rear * s_r  # F_s3 + F_s4
    fl_front = n_front * l_f + n_front * l_f  # F_l2 + F_l3
    fl_rear = n_rear * l_b + n_rear * l_b  # F_l1 + F_l4
    sum_fs = fs_left + fs_right
    sum_fl = fl_front + fl_rear
    # SS-2 M_r = sum x_i F_li - y_i F_si (skid-steer notes: -a(F_l1+F_l4) + b(F_l2+F_l3)
    #   + c(-(F_s1+F_s2) + (F_s3+F_s4)))
    m_r = b * fl_front - a * fl_rear + c * (fs_right - fs_left)
    power = -(fs_left * v_l + fs_right * v_r + fl_front * v_f + fl_rear * v_b)
    return sum_fs, -xicr * sum_fl + m_r, power  # SS-3 Rbar


@llvm_inline
def wheel_rates(vx, wz, p):  # pragma: no cover - compiled
    """``(omega_L, omega_R) = ((vx - c wz) / r, (vx + c wz) / r)`` (SS-1), rad/s."""
    return (vx - p[P_C] * wz) * p[P_INVR], (vx + p[P_C] * wz) * p[P_INVR]


@njit(cache=True, inline="always")
def _deriv(x, u, p, applied):  # pragma: no cover - compiled
    """The state derivative as a 5-tuple with the motor law ``applied`` (models/motor.py:
    ``ideal_applied`` or ``dc_applied``). ``x``, ``u``, ``p`` are arrays or tuples read by
    constant index only, so the block kernels (tuples, no branches) vectorise."""
    yaw, vx, wz = x[2], x[3], x[4]
    m, xicr = p[P_M], p[P_XICR]
    vy = -xicr * wz  # SS-1
    sy, cy = sincos(yaw)
    r0, r1, _ = resist(vx, wz, p)
    # the torques the motors apply at the SS-1 wheel rates (models/motor.py; ideal: u itself)
    w_l, w_r = wheel_rates(vx, wz, p)
    mode = p[P_MOTOR]
    tau_l = applied(u[0], w_l, mode, p, P_MBLK) + applied(u[1], w_l, mode, p, P_MBLK)
    tau_r = applied(u[2], w_r, mode, p, P_MBLK) + applied(u[3], w_r, mode, p, P_MBLK)
    # SS-3: Mbar etadot = Bbar (tau_L, tau_R) - Cbar eta - Rbar,
    #   Cbar eta = m x_icr (wz wz, -wz vx), Bbar = (1/r) [[1, 1], [-c, c]]
    f0 = (tau_l + tau_r) / p[P_R] - m * xicr * wz * wz - r0
    f1 = p[P_C] * (tau_r - tau_l) / p[P_R] + m * xicr * wz * vx - r1
    # docs/physics/conventions.md (three-wheel paper (15)-(16)), then SS-3
    return (cy * vx - sy * vy, sy * vx + cy * vy, wz, f0 / m, f1 / (m * xicr * xicr + p[P_I]))


@llvm_inline
def deriv_block(x, u, p):  # pragma: no cover - compiled
    """The state derivative as a 5-tuple with ideal motors (the wheels get ``u``)."""
    return _deriv(x, u, p, ideal_applied)


@llvm_inline
def deriv_block_dc(x, u, p):  # pragma: no cover - compiled
    """The state derivative as a 5-tuple with DC motors (models/motor.py)."""
    return _deriv(x, u, p, dc_applied)


@njit(cache=True)
def deriv_one(x, u, p, out):  # pragma: no cover - compiled
    d = deriv_block(x, u, p)
    for j in range(5):
        out[j] = d[j]


@njit(cache=True)
def deriv_one_dc(x, u, p, out):  # pragma: no cover - compiled
    d = deriv_block_dc(x, u, p)
    for j in range(5):
        out[j] = d[j]


@llvm_inline
def power_t(x, k, u, p):  # pragma: no cover - compiled
    """Motor power ``tau . omega`` (W) of ideal motors at state ``x``: the state holds no
    wheel angles, so
    from SS-1 ``tau_L omega_L + tau_R omega_R = ((tau_L + tau_R) vx + c (tau_R - tau_L) wz)
    / r`` (= Bbar (tau_L, tau_R) . eta of SS-3), one division."""
    tl = u[0] + u[1]
    tr = u[2] + u[3]
    return ((tl + tr) * x[3] + p[P_C] * (tr - tl) * x[4]) / p[P_R]


@llvm_inline
def power_t_dc(x, k, u, p):  # pragma: no cover - compiled
    """Power the DC motors draw (W): the electrical power ``sum V i`` (models/motor.py), which
    the environments' energy integral then accumulates; :func:`power_t` where the mode code
    is ideal."""
    mech = power_t(x, k, u, p)
    # DC motors: the electrical power sum V i (models/motor.py) at the SS-1 wheel rates
    w_l, w_r = wheel_rates(x[3], x[4], p)
    mode = p[P_MOTOR]
    el = (dc_power(u[0], w_l, mode, p, P_MBLK) + dc_power(u[1], w_l, mode, p, P_MBLK)
          + dc_power(u[2], w_r, mode, p, P_MBLK) + dc_power(u[3], w_r, mode, p, P_MBLK))
    return mech if mode == 0.0 else el


@njit(cache=True)
def k_motor(X, U, p, out):  # pragma: no cover - compiled
    """Per row and motor: ``out[k, 0]`` joint rate (rad/s), ``out[k, 1]`` applied joint torque
    (N·m), ``out[k, 2]`` current (A), ``out[k, 3]`` terminal voltage (V) (models/motor.py;
    current and voltage those of a DC motor, also in ideal mode). ``out`` is ``(N, 4, 4)``."""
    mode = p[P_MOTOR]
    for k in range(X.shape[0]):
        w_l, w_r = wheel_rates(X[k, 3], X[k, 4], p)
        for j in range(4):
            w = w_l if j < 2 else w_r
            i, e = dc_current(U[k, j], w, mode, p, P_MBLK)
            out[k, 0, j] = w
            out[k, 1, j] = dc_applied(U[k, j], w, mode, p, P_MBLK)
            out[k, 2, j] = i
            out[k, 3, j] = p[P_MBLK + M_R] * i + e  # V = R_w i + e


@njit(cache=True)
def k_resist(E, p, out):  # pragma: no cover - compiled
    for i in range(E.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = resist(E[i, 0], E[i, 1], p)


# ---------------------------------------------------------------------------- batch kernels
#: The model's batch kernels: the generic bodies of wheelgym.integrators with this robot's
#: derivative (vectorised blocks of integrators.LANES robots).
KERNELS = model_kernels(__name__, __file__, deriv_one, NX, NU, deriv_block, power_t, NP)


@functools.cache
def dc_kernels() -> _integrators.ModelKernels:
    """The batch kernels with DC motors (``k_*_dc``, stage power ``power_t_dc``), built on
    first use; ``dc_kernels().block`` is the DC twin of :data:`k_block`."""
    return model_kernels(__name__, __file__, deriv_one_dc, NX, NU, deriv_block_dc, power_t_dc,
                         NP, suffix="_dc")
#: ``k_block(X, U, P, h, n, out, work, b0)``: one vectorised block with the motor work (J),
#: as ThreeWheel's; ``U`` read in its first 4 columns.
k_block = KERNELS.block
