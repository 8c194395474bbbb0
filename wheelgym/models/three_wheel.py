"""Three-wheel redundantly actuated robot with off-centred steerable wheels (physics.md section 2).

A platform carries three caster modules (wheel 1 rear-left, 2 rear-right, 3 front). Each module
has a steering motor at its vertical axis ``A_i`` and a drive motor on the wheel axle, so six
motors drive three degrees of freedom (force redundancy, three-wheel paper section 4).

State ``x = (x, y, yaw, vx, vy, wz, psi_1, psi_2, psi_3, theta_1, theta_2, theta_3)`` (TW-5);
input ``tau = (drive_1, drive_2, drive_3, steer_1, steer_2, steer_3)`` (N·m, motor order).

Dynamics in the body twist ``u = (vx, vy, wz)`` (physics.md TW-3, three-wheel paper (26)):

    M(psi) udot + c(psi, u) = J(psi)^T tau + Q_f(psi, u)

The compiled kernel evaluates the closed form of TW-3. :func:`noc_terms` derives the same
``M`` and ``c`` the long way, with the natural orthogonal complement of the paper (17)-(29):
twist-shaping matrix ``T`` of the seven bodies, ``T^T M_bodies T`` and
``T^T (M_bodies Tdot + W M_bodies T) u``; the tests check that both agree to 1e-12.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np
from numba import njit, prange

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import (
    DERIV1_SIG,
    LANES,
    STEP1_SIG,
    all_finite,
    check_one,
    check_step_args,
    finite_status,
    rk4_inplace,
    rk4_rows,
)
from wheelgym.integrators import fma as _fma
from wheelgym.models import friction as _friction
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

# kernels here inline integrators.rk4_inplace and integrators.rk4_block
_numba_cache.guard(__file__, _integrators.__file__, _friction.__file__)

__all__ = ["ThreeWheelParams", "ThreeWheel", "noc_terms", "RK4_REAL_STABILITY_LIMIT"]

#: RK4's stability region reaches ``lambda dt = -2.785`` on the negative real axis.
RK4_REAL_STABILITY_LIMIT = 2.785

# Layout of the packed parameter vector read by the kernels (from _KW on: derived values).
(_MB, _IB, _MW, _IWY, _IWZ, _R, _D, _A1X, _A1Y, _A2X, _A2Y, _A3X, _A3Y, _MUR, _MUP, _RHO,
 _BD, _BS, _KS, _G, _TDM, _TSM, _KW, _KZ, _MT, _INVD, _INVR, _M0) = range(28)
# _M0 .. _M0 + 5: the constant part M_0 of M (upper triangle), see ThreeWheelParams.pack
_NP = _M0 + 6  # length of the packed vector


def _cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


@dataclasses.dataclass(frozen=True)
class ThreeWheelParams(Params):
    """Three-wheel robot parameters (physics.md section 2; defaults: a research AGV of ~25 kg).

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

    @property
    def axes_array(self) -> np.ndarray:
        """Steering-axis positions ``a_i`` in B, shape ``(3, 2)`` (m)."""
        return np.asarray(self.axes, dtype=np.float64).reshape(3, 2)

    def pack(self) -> np.ndarray:
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
             1.0 / self.d, 1.0 / self.r, *m0],
            dtype=np.float64,
        )


# ---------------------------------------------------------------------------- fast libm pieces
# The derivative makes 8 sin/cos and 6 arctan calls: friction.sincos and friction.atan (libm's
# values to 2 ulp, branch-free so that the block kernels vectorise). Sums of products are
# written with explicit fused multiply-adds (``_fma``, integrators.fma): one instruction and
# one rounding each, the same in the vectorised blocks and the one-row kernels.
_sincos = _friction.sincos
_atan = _friction.atan
_TWO_OVER_PI = _friction.TWO_OVER_PI


@njit(cache=True, inline="always")
def _sgn_s(s, k_s):  # pragma: no cover - compiled
    """``sgn_s(s) = (2/pi) arctan(k_s s)`` (physics.md section 0), as friction.sgn_s."""
    return _TWO_OVER_PI * _atan(k_s * s)


# ---------------------------------------------------------------------------- compiled pieces
# Every piece is written once, as an inline per-module contribution (``_*_i``) plus the
# platform's share; ``_mass``, ``_bias``, ``_friction``, ``_jt_tau`` sum them for the public
# methods, and ``_deriv_one`` sums all of them in one pass over the modules (same formulas,
# one loop, the trig of each steering angle evaluated once).
# g = (g0, g1, g2), h = (h0, h1, h2) of TW-1; gu = g.u, hu = h.u.


@njit(cache=True, inline="always")
def _trig(psi1, psi2, psi3):  # pragma: no cover - compiled
    s1, c1 = _sincos(psi1)
    s2, c2 = _sincos(psi2)
    s3, c3 = _sincos(psi3)
    return (c1, s1, c2, s2, c3, s3)


@njit(cache=True, inline="always")
def _gh(cs, i, p):  # pragma: no cover - compiled
    """``g_i`` and ``h_i`` of physics.md TW-1 (caster-singularity paper (8)-(11))."""
    c = cs[2 * i]
    s = cs[2 * i + 1]
    ax = p[_A1X + 2 * i]
    ay = p[_A1Y + 2 * i]
    return (c, s, _fma(ax, s, -(ay * c))), (-s, c, _fma(ax, c, ay * s))


@njit(cache=True, inline="always")
def _loads(cs, p):  # pragma: no cover - compiled
    """Static normal loads ``N_i`` (TW-4): barycentric weights of the CoM in the wheel-centre
    triangle, ``N_1 = m g [p_2, p_3] / ([p_2, p_3] + [p_3, p_1] + [p_1, p_2])`` and cyclic,
    which solves ``sum N_i = m g`` and zero moments about the CoM."""
    d = p[_D]
    x1 = _fma(-d, cs[0], p[_A1X])
    y1 = _fma(-d, cs[1], p[_A1Y])
    x2 = _fma(-d, cs[2], p[_A2X])
    y2 = _fma(-d, cs[3], p[_A2Y])
    x3 = _fma(-d, cs[4], p[_A3X])
    y3 = _fma(-d, cs[5], p[_A3Y])
    c23 = _fma(x2, y3, -(y2 * x3))
    c31 = _fma(x3, y1, -(y3 * x1))
    c12 = _fma(x1, y2, -(y1 * x2))
    w = p[_MT] * p[_G] / (c23 + c31 + c12)
    return w * c23, w * c31, w * c12


@njit(cache=True, inline="always")
def _mass_i(g, p):  # pragma: no cover - compiled
    """Module share ``(k_w - k_z) g g^T`` of ``M - M_0`` (TW-3), upper triangle; the rest of
    ``k_w g g^T + k_z h h^T`` is constant (see ThreeWheelParams.pack)."""
    k = p[_KW] - p[_KZ]
    return (k * g[0] * g[0], k * g[0] * g[1], k * g[0] * g[2], k * g[1] * g[1],
            k * g[1] * g[2], k * g[2] * g[2])


# Every generalized force of module i lies in span{g_i, h_i, e_3} (the rows of J are g_i / r
# and h_i / d - e_3), so the pieces below return its coefficients (a, b, c) on
# (g_i, h_i, e_3) and ``_assemble`` turns them into the 3-vector a g_i + b h_i + c e_3.


@njit(cache=True, inline="always")
def _dot3(a, vx, vy, wz):  # pragma: no cover - compiled
    """``a . (vx, vy, wz)`` (``g_i . u``, ``h_i . u`` of TW-1), fused."""
    return _fma(a[2], wz, _fma(a[1], vy, a[0] * vx))


@njit(cache=True, inline="always")
def _assemble(g, h, a, b, c):  # pragma: no cover - compiled
    return _fma(a, g[0], b * h[0]), _fma(a, g[1], b * h[1]), _fma(a, g[2], _fma(b, h[2], c))


@njit(cache=True, inline="always")
def _bias_i(gu, hu, wz, p):  # pragma: no cover - compiled
    """Module share ``psidot_i (k_w (h.u) g - k_z (g.u) h)`` of c (TW-3), as (a, b, c)."""
    psid = _fma(hu, p[_INVD], -wz)  # TW-1 steering rate
    return psid * p[_KW] * hu, -psid * p[_KZ] * gu, 0.0


@njit(cache=True, inline="always")
def _friction_i(gu, hu, wz, n_i, p):  # pragma: no cover - compiled
    """Module share of Q_f (TW-4) as (a, b, c): rolling resistance ``-mu_r N_i sgn_s(g.u) g``,
    pivot scrub ``-mu_p N_i sgn_s(rho h.u / d) h / d``, viscous joints
    ``-J_i^T B J_i u = -b_drive thetadot (g / r) - b_steer psidot (h / d - e_3)``."""
    invd = p[_INVD]
    invr = p[_INVR]
    ks = p[_KS]
    thd = gu * invr  # TW-1 drive rate
    psid = _fma(hu, invd, -wz)  # TW-1 steering rate
    roll = p[_MUR] * n_i * _sgn_s(gu, ks)
    scrub = p[_MUP] * n_i * _sgn_s(p[_RHO] * hu * invd, ks) * invd
    visc_s = p[_BS] * psid
    return -roll - p[_BD] * thd * invr, -scrub - visc_s * invd, visc_s


@njit(cache=True, inline="always")
def _jt_tau_i(tau_drive, tau_steer, p):  # pragma: no cover - compiled
    """Module share of ``J^T tau`` as (a, b, c): ``tau_d g / r + tau_s (h / d - e_3)``."""
    return tau_drive * p[_INVR], tau_steer * p[_INVD], -tau_steer


@njit(cache=True, inline="always")
def _jrows_i(g, h, p):  # pragma: no cover - compiled
    """Module i's two rows of J (TW-1): drive ``g_i / r``, steer ``h_i / d - e_3``."""
    invr = p[_INVR]
    invd = p[_INVD]
    return ((g[0] * invr, g[1] * invr, g[2] * invr),
            (h[0] * invd, h[1] * invd, h[2] * invd - 1.0))


@njit(cache=True, inline="always")
def _mass(cs, p):  # pragma: no cover - compiled
    """Upper triangle (m00, m01, m02, m11, m12, m22) of M(psi), physics.md TW-3."""
    m = (p[_M0], p[_M0 + 1], p[_M0 + 2], p[_M0 + 3], p[_M0 + 4], p[_M0 + 5])  # M_0
    for i in range(3):
        g, h = _gh(cs, i, p)
        a = _mass_i(g, p)
        m = (m[0] + a[0], m[1] + a[1], m[2] + a[2], m[3] + a[3], m[4] + a[4], m[5] + a[5])
    return m


@njit(cache=True, inline="always")
def _bias(cs, vx, vy, wz, p):  # pragma: no cover - compiled
    """Coriolis/centripetal term c(psi, u) of physics.md TW-3 (three-wheel paper (26))."""
    c0 = -p[_MB] * wz * vy  # platform m_b (-wz vy, wz vx, 0)
    c1 = p[_MB] * wz * vx
    c2 = 0.0
    for i in range(3):
        g, h = _gh(cs, i, p)
        gu = _dot3(g, vx, vy, wz)
        hu = _dot3(h, vx, vy, wz)
        ba, bb, bc = _bias_i(gu, hu, wz, p)
        b = _assemble(g, h, ba, bb, bc)
        c0 += b[0]
        c1 += b[1]
        c2 += b[2]
    return c0, c1, c2


@njit(cache=True, inline="always")
def _friction(cs, vx, vy, wz, p):  # pragma: no cover - compiled
    """Generalized friction Q_f(psi, u) of physics.md TW-4."""
    n = _loads(cs, p)
    q0 = 0.0
    q1 = 0.0
    q2 = 0.0
    for i in range(3):
        g, h = _gh(cs, i, p)
        gu = _dot3(g, vx, vy, wz)
        hu = _dot3(h, vx, vy, wz)
        fa, fb, fc = _friction_i(gu, hu, wz, n[i], p)
        f = _assemble(g, h, fa, fb, fc)
        q0 += f[0]
        q1 += f[1]
        q2 += f[2]
    return q0, q1, q2


@njit(cache=True, inline="always")
def _friction_jac_rest(cs, p):  # pragma: no cover - compiled
    """Upper triangle of ``dQ_f/du`` at ``u = 0`` (symmetric, negative semi-definite):
    ``-sum_i [mu_r N_i s' g g^T + mu_p N_i s' (rho / d^2) h h^T + J_i^T B_i J_i]`` with
    ``s' = 2 k_s / pi``, the slope of sgn_s at 0 (TW-4 differentiated)."""
    n = _loads(cs, p)
    invd = p[_INVD]
    k = 2.0 * p[_KS] / math.pi
    e = np.zeros(6)
    for i in range(3):
        g, h = _gh(cs, i, p)
        jd, js = _jrows_i(g, h, p)
        kg = p[_MUR] * n[i] * k
        kh = p[_MUP] * n[i] * k * p[_RHO] * invd * invd
        idx = 0
        for a in range(3):
            for b in range(a, 3):
                e[idx] -= (kg * g[a] * g[b] + kh * h[a] * h[b] + p[_BD] * jd[a] * jd[b]
                           + p[_BS] * js[a] * js[b])
                idx += 1
    return e[0], e[1], e[2], e[3], e[4], e[5]


@njit(cache=True, inline="always")
def _solve3(m, f0, f1, f2):  # pragma: no cover - compiled
    """Solve the symmetric 3x3 system ``M a = f`` by cofactors (M is positive definite)."""
    m00, m01, m02, m11, m12, m22 = m
    a00 = _fma(m11, m22, -(m12 * m12))
    a01 = _fma(m02, m12, -(m01 * m22))
    a02 = _fma(m01, m12, -(m02 * m11))
    a11 = _fma(m00, m22, -(m02 * m02))
    a12 = _fma(m01, m02, -(m00 * m12))
    a22 = _fma(m00, m11, -(m01 * m01))
    inv_det = 1.0 / _fma(m02, a02, _fma(m01, a01, m00 * a00))
    return (_fma(a02, f2, _fma(a01, f1, a00 * f0)) * inv_det,
            _fma(a12, f2, _fma(a11, f1, a01 * f0)) * inv_det,
            _fma(a22, f2, _fma(a12, f1, a02 * f0)) * inv_det)


@njit(cache=True, inline="always")
def _module_terms(cs, i, n_i, vx, vy, wz, tau_drive, tau_steer, p, m, f):
    """Add module i's shares of M and of ``J^T tau + Q_f - c`` to ``m`` and ``f``; also return
    its TW-1 joint rates ``(psidot_i, thetadot_i)``."""  # pragma: no cover - compiled
    g, h = _gh(cs, i, p)
    gu = _dot3(g, vx, vy, wz)
    hu = _dot3(h, vx, vy, wz)
    a = _mass_i(g, p)
    tb = _bias_i(gu, hu, wz, p)
    tq = _friction_i(gu, hu, wz, n_i, p)
    tt = _jt_tau_i(tau_drive, tau_steer, p)
    df = _assemble(g, h, tt[0] + tq[0] - tb[0], tt[1] + tq[1] - tb[1], tt[2] + tq[2] - tb[2])
    return ((m[0] + a[0], m[1] + a[1], m[2] + a[2], m[3] + a[3], m[4] + a[4], m[5] + a[5]),
            (f[0] + df[0], f[1] + df[1], f[2] + df[2]),
            _fma(hu, p[_INVD], -wz),
            gu * p[_INVR])


@njit(cache=True, inline="always")
def _deriv_t(x, u, p):  # pragma: no cover - compiled
    """The state derivative as a 12-tuple. ``x``, ``u``, ``p`` are arrays or tuples read by
    constant index only, so the block kernels (tuples, no branches) vectorise."""
    yaw = x[2]
    vx = x[3]
    vy = x[4]
    wz = x[5]
    cs = _trig(x[6], x[7], x[8])
    sy, cy = _sincos(yaw)
    n = _loads(cs, p)
    # TW-3: M udot = J^T tau + Q_f - c; the platform's share, then each module's
    m = (p[_M0], p[_M0 + 1], p[_M0 + 2], p[_M0 + 3], p[_M0 + 4], p[_M0 + 5])
    f = (p[_MB] * wz * vy, -p[_MB] * wz * vx, 0.0)
    m, f, psid1, thd1 = _module_terms(cs, 0, n[0], vx, vy, wz, u[0], u[3], p, m, f)
    m, f, psid2, thd2 = _module_terms(cs, 1, n[1], vx, vy, wz, u[1], u[4], p, m, f)
    m, f, psid3, thd3 = _module_terms(cs, 2, n[2], vx, vy, wz, u[2], u[5], p, m, f)
    a0, a1, a2 = _solve3(m, f[0], f[1], f[2])
    # physics.md section 0 (three-wheel paper (15)-(16)), TW-3 and the TW-1 joint rates
    return (_fma(cy, vx, -(sy * vy)), _fma(sy, vx, cy * vy), wz, a0, a1, a2,
            psid1, psid2, psid3, thd1, thd2, thd3)


@njit(cache=True)
def _deriv_one(x, u, p, out):  # pragma: no cover - compiled
    d = _deriv_t(x, u, p)
    for j in range(12):
        out[j] = d[j]


@njit(cache=True, inline="always")
def _power_t(x, k, u, p):  # pragma: no cover - compiled
    """Motor power ``tau . qdot`` (W) at a state whose derivative is ``k``: the derivative
    holds the TW-1 joint rates (TW-5 order), ``k[9 + i]`` drive and ``k[6 + i]`` steering;
    motor order [drive_1..3, steer_1..3]."""
    return _fma(u[5], k[8], _fma(u[4], k[7], _fma(u[3], k[6], _fma(
        u[2], k[11], _fma(u[1], k[10], u[0] * k[9])))))


@njit(cache=True)
def _k_deriv(X, U, p, out):  # pragma: no cover - compiled
    for i in range(X.shape[0]):
        _deriv_one(X[i], U[i], p, out[i])


@njit(DERIV1_SIG, cache=True)
def _k_deriv1(x, u, p, out):  # pragma: no cover - compiled
    """Derivative of one state into ``out``; a ``STATUS_*`` code of wheelgym.integrators."""
    status = check_one(x, u, 12, 6)
    if status == 0:
        _deriv_one(x, u, p, out)
    return status


@njit(STEP1_SIG, cache=True)
def _k_step1(x, u, p, dt, n):  # pragma: no cover - compiled
    """Advance one state ``x`` in place; a ``STATUS_*`` code of wheelgym.integrators."""
    status = check_one(x, u, 12, 6)
    if status == 0:
        status = check_step_args(dt, n)
    if status != 0:
        return status
    work = np.empty((5, 12))
    rk4_inplace(_deriv_one, x, u, p, dt / n, n, work)
    return finite_status(x)


@njit(cache=True, error_model="numpy")
def _k_block(X, U, P, h, n, out, work, b0):  # pragma: no cover - compiled
    """Rows ``b0 .. b0 + LANES`` as one vectorised block (``integrators.rk4_rows``): ``out``
    the new states, ``work`` the motor work (J); ``U`` is read in its first 6 columns, ``P``
    has one row (shared) or one per row. The models' batch steps and the environments' step
    kernels all call this one compiled function. NumPy's error model: no exception branch
    inside the vectorised loops (a division by zero gives inf/NaN, which the callers'
    finiteness checks catch)."""
    rk4_rows(_deriv_t, _power_t, X, U, P, h, n, out, work, b0, 12, 6, _NP)


@njit(cache=True)
def _k_step(X, U, p, h, n, out):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(U)):
        return False
    P = p.reshape((1, p.shape[0]))
    work = np.empty(X.shape[0])
    for b0 in range(0, X.shape[0], LANES):
        _k_block(X, U, P, h, n, out, work, b0)
    return True


@njit(cache=True, parallel=True)
def _k_step_par(X, U, p, h, n, out):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(U)):
        return False
    P = p.reshape((1, p.shape[0]))
    work = np.empty(X.shape[0])
    for b in prange((X.shape[0] + LANES - 1) // LANES):
        _k_block(X, U, P, h, n, out, work, b * LANES)
    return True


@njit(cache=True, inline="always")
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
def _k_psi_pieces(PSI, p, jac, mass, loads, centers, fjac):  # pragma: no cover - compiled
    """Fill J (N,6,3), M (N,3,3), N_i (N,3), wheel centres (N,3,2), dQ_f/du at rest (N,3,3)."""
    d = p[_D]
    for k in range(PSI.shape[0]):
        cs = _trig(PSI[k, 0], PSI[k, 1], PSI[k, 2])
        for i in range(3):
            g, h = _gh(cs, i, p)
            jd, js = _jrows_i(g, h, p)
            for j in range(3):
                jac[k, i, j] = jd[j]
                jac[k, 3 + i, j] = js[j]
            centers[k, i, 0] = p[_A1X + 2 * i] - d * cs[2 * i]  # p_i = a_i - d e_i
            centers[k, i, 1] = p[_A1Y + 2 * i] - d * cs[2 * i + 1]
        _put_sym3(mass[k], _mass(cs, p))
        _put_sym3(fjac[k], _friction_jac_rest(cs, p))
        n1, n2, n3 = _loads(cs, p)
        loads[k, 0] = n1
        loads[k, 1] = n2
        loads[k, 2] = n3


@njit(cache=True)
def _k_twist_pieces(PSI, V, p, bias, fric):  # pragma: no cover - compiled
    """Fill c(psi, u) (N,3) and Q_f(psi, u) (N,3)."""
    for k in range(PSI.shape[0]):
        cs = _trig(PSI[k, 0], PSI[k, 1], PSI[k, 2])
        bias[k, 0], bias[k, 1], bias[k, 2] = _bias(cs, V[k, 0], V[k, 1], V[k, 2], p)
        fric[k, 0], fric[k, 1], fric[k, 2] = _friction(cs, V[k, 0], V[k, 1], V[k, 2], p)


# ---------------------------------------------------------------------------- the model
class ThreeWheel(Model):
    """Three-wheel redundantly actuated robot with steerable off-centred wheels (physics.md 2).

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
    ``integrators.LANES`` robots at about 0.14 us per robot-substep (``_k_block``, 4.2x).
    """

    state_names = ("x", "y", "yaw", "vx", "vy", "wz", "psi_1", "psi_2", "psi_3",
                   "theta_1", "theta_2", "theta_3")
    input_names = ("drive_1", "drive_2", "drive_3", "steer_1", "steer_2", "steer_3")
    params_type = ThreeWheelParams
    default_sim_dt = 0.002
    default_ctrl_dt = 0.05

    _k_deriv = _k_deriv
    _k_step = _k_step
    _k_step_par = _k_step_par
    _k_step1 = _k_step1
    _k_deriv1 = _k_deriv1

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
        _k_psi_pieces(P2, self._p, jac, mass, loads, centers, fjac)
        return (jac.reshape(lead + (6, 3)), mass.reshape(lead + (3, 3)),
                loads.reshape(lead + (3,)), centers.reshape(lead + (3, 2)),
                fjac.reshape(lead + (3, 3)))

    def _twist_pieces(self, psi, u) -> tuple[np.ndarray, np.ndarray]:
        P = self._finite(psi, 3, "psi")
        V = self._finite(u, 3, "u")
        lead = np.broadcast_shapes(P.shape[:-1], V.shape[:-1])
        P2 = np.ascontiguousarray(np.broadcast_to(P, lead + (3,)).reshape(-1, 3))
        V2 = np.ascontiguousarray(np.broadcast_to(V, lead + (3,)).reshape(-1, 3))
        bias = np.empty_like(P2)
        fric = np.empty_like(P2)
        _k_twist_pieces(P2, V2, self._p, bias, fric)
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
        """Mechanical power of the six motors ``tau . qdot`` (W), shape ``(...)``."""
        U = self._as_batch(u, self.input_dim, "u")
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


# ---------------------------------------------------------------------------- NOC derivation
def noc_terms(
    params: ThreeWheelParams,
    psi: np.ndarray,
    u: np.ndarray,
    yaw: float = 0.0,
    wheel_diametral_inertia: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """``M`` and ``c`` of TW-3 by the natural orthogonal complement (three-wheel paper (17)-(29)).

    Reference derivation in NumPy (not used by the compiled kernel, which evaluates the closed
    form of physics.md TW-3; the tests check both agree to 1e-12).

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
