"""Analytic baseline controllers: inverse dynamics, computed torque, load distribution.

Two controllers per robot, both stateless in :meth:`torques` (batched over leading axes):

* :class:`TwistController` turns a commanded body twist into motor torques (the
  environments' velocity action mode).
* :class:`TrackingController` follows a reference trajectory (pose, twist, twist rate).

Both compute a desired acceleration, the generalized force it needs by inverse dynamics
(docs/physics/three-wheel.md TW-6: ``Q_d = M udot_d + c - Q_f``; docs/physics/skid-steer.md
SS-4: ``Bbar tau_LR = Mbar etadot_d + Cbar eta +
Rbar``), and the motor torques through a load distribution (:mod:`wheelgym.control.distribution`).
Torques over a limit are scaled down uniformly (every motor by the same factor, so the
generalized force keeps its direction) and reported as ``saturated``.

Sampling. The controllers are designed for torques computed once per control step and held
over it: the control period ``ctrl_dt`` is an argument of each controller (default the model's
``default_ctrl_dt``, docs/physics/conventions.md), the environment passing its own.

* twist loop ``udot_d = k_v (u_cmd - u)``: with the torque held, the twist error after one step
  is ``(1 - k_v ctrl_dt)`` times the error before, so the default ``k_v = 1 / ctrl_dt``
  (20 1/s at 0.05 s) is the deadbeat gain; the loop stays stable
  (``|1 - k_v ctrl_dt / g| < 1``) for any plant-to-model inertia ratio ``g < 2``.
* SkidSteer integral action (PI twist loop), per row, discrete at the control period: the
  integrator ``z`` (twist units: m/s, rad/s) steps ``z+ = clip(z + beta e, -z_max, z_max)`` with
  ``beta = k_i ctrl_dt^2`` and the loop asks ``udot_d = k_v e + z+ / ctrl_dt`` (friction then at
  ``u + udot_d ctrl_dt = u_cmd + z+`` when deadbeat: the integrator shifts the feed-forward's
  target). Error dynamics for a plant-to-model inertia ratio ``1/rho`` (torque-to-acceleration gain
  ``rho``): ``lambda^2 - (2 - rho (k_v ctrl_dt + beta)) lambda + 1 - rho k_v ctrl_dt = 0``; where
  the friction is steep (static plant, gain ``rho``): ``lambda = 1 - rho beta``. The default
  ``beta = 0.3`` (``k_i = 0.3 / ctrl_dt^2``, 120 1/s² at 0.05 s) keeps every pole within 0.85
  for ``rho`` in 0.5..1.6 (nominal: 0 and 0.7) and removes the steady error a friction or mass
  mismatch leaves (22% of the yaw rate at 20% mismatch without it). Anti-windup: ``|z|`` is
  clamped to ``z_max`` (the twist shift whose ``M z / ctrl_dt`` the four motors can deliver alone:
  ``4 tau_max / r`` force, ``4 tau_max c / r`` yaw moment), and while the torques saturate a
  component of ``z`` steps only towards zero (conditional integration). ``k_i = 0`` is the
  proportional loop, bit for bit. :meth:`TwistController.torques` is stateless (proportional);
  the integral acts through :meth:`TwistController.step` and the batch kernel with bound rows.
* friction is evaluated at the twist the step aims for (``u + udot_d ctrl_dt``), not at the
  current twist: where the arctan friction is steep (near zero slip) the plant settles within
  milliseconds to the twist at which friction balances the held torque, so that twist must be
  the target. Where the friction is saturated both choices agree.
* ThreeWheel pose loop (world frame, per axis) ``a_d = a_ref + k_d (v_ref - v) + k_p e``: the
  sampled closed loop of a double integrator with zero-order hold has spectral radius 0.80 per
  step at the defaults ``k_p = 36 1/s², k_d = 12 1/s`` (0.75-0.82 for inertia ratios 0.8-1.25).

The controller's model may have parameters other than the plant's (robustness tests use a
20% mismatch). The environments choose it with ``controller_model``: ``"nominal"`` (the
controller's ``model``: the robot's parameters the environment was built with) or ``"true"``
(each row's drawn plant parameters, through :meth:`TwistController.row_kernel` and
:meth:`TrackingController.row_kernel`; ``docs/topics/robustness.md``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.control import distribution as _distribution
from wheelgym.control.distribution import DISTRIBUTIONS, _distribute_one
from wheelgym.integrators import all_finite, kernel_array
from wheelgym.models import elementwise as _elementwise
from wheelgym.models import friction as _friction
from wheelgym.models.caster_agv import CasterAGV
from wheelgym.models.elementwise import wrap
from wheelgym.models.kernels import caster_agv as _ca
from wheelgym.models.kernels import skid_steer as _ss
from wheelgym.models.kernels import three_wheel as _tw
from wheelgym.models.skid_steer import SkidSteer
from wheelgym.models.three_wheel import ThreeWheel

_numba_cache.guard(__file__, _distribution.__file__, _tw.__file__, _ss.__file__, _ca.__file__,
             _friction.__file__, _integrators.__file__, _elementwise.__file__)

__all__ = [
    "TwistGains",
    "TrackingGains",
    "UnicycleTrackingGains",
    "TwistController",
    "TrackingController",
    "make_controller",
    "inverse_dynamics",
    "tracked_point",
]


# ---------------------------------------------------------------------------- gains
@dataclasses.dataclass(frozen=True)
class TwistGains:
    """Twist-loop gains (the control period is the controller's ``ctrl_dt`` argument).

    | name | default         | unit | meaning                                              |
    |------|-----------------|------|------------------------------------------------------|
    | k_v  | ``1 / ctrl_dt`` | 1/s  | twist-error gain (None: deadbeat at ``ctrl_dt``)      |
    | k_i  | see below       | 1/s² | integral gain, SkidSteer only (None: ``0.3 / ctrl_dt²``; |
    |      |                 |      | 0 off; ThreeWheel and CasterAGV: 0)                  |

    The sampled loop is stable for ``k_v ctrl_dt < 2`` and ``k_i ctrl_dt² < 1`` (checked by
    the controller; module docstring for the integral design).
    """

    k_v: float | None = None
    k_i: float | None = None

    def __post_init__(self) -> None:
        _check_gains(self)


@dataclasses.dataclass(frozen=True)
class TrackingGains:
    """Computed-torque pose/twist gains for holonomic tracking (ThreeWheel), per world axis.

    | name    | default | unit        | meaning                                          |
    |---------|---------|-------------|--------------------------------------------------|
    | k_p     | 36.0    | 1/s²        | position and heading error gain                  |
    | k_d     | 12.0    | 1/s         | velocity and yaw-rate error gain                 |
    """

    k_p: float = 36.0
    k_d: float = 12.0

    def __post_init__(self) -> None:
        _check_gains(self)


@dataclasses.dataclass(frozen=True)
class UnicycleTrackingGains:
    """Kanayama tracking law plus the twist loop (SkidSteer, nonholonomic).

    ``v_c = v_r cos e_yaw + k_x e_x``, ``w_c = w_r + v_r (k_y e_y + k_yaw sin e_yaw)``
    (errors in the robot frame), then ``etadot_d = d/dt (v_c, w_c) + k_v ((v_c, w_c) - eta)``.
    The lateral error obeys ``e_y'' + v_r k_yaw e_y' + v_r^2 k_y e_y = 0`` when linearised:
    the defaults give a natural frequency ``14.1 v_r`` rad/s with damping 0.99.

    Sampling: differentiating ``w_c`` feeds ``w`` back with gain ``k_v + |v_r| k_yaw`` in
    all, which must stay well below ``2 / ctrl_dt`` (with margin for a heavier or lighter
    plant). Where ``|v_r| k_yaw`` would exceed ``k_w_max - k_v``, ``k_yaw`` is lowered to
    fit and ``k_y`` with its square (same damping).

    | name    | default | unit  | meaning                                          |
    |---------|---------|-------|--------------------------------------------------|
    | k_x     | 4.0     | 1/s   | along-track error gain                           |
    | k_y     | 200.0   | 1/m²  | cross-track error gain                           |
    | k_yaw   | 28.0    | 1/m   | heading error gain                               |
    | k_v     | 10.0    | 1/s   | twist-loop gain                                  |
    | k_w_max | 24.0    | 1/s   | cap on the total yaw-rate gain ``k_v + |v_r| k_yaw`` |

    ``k_w_max < 2 / ctrl_dt`` is checked by the controller (its control period).
    """

    k_x: float = 4.0
    k_y: float = 200.0
    k_yaw: float = 28.0
    k_v: float = 10.0
    k_w_max: float = 24.0

    def __post_init__(self) -> None:
        _check_gains(self)
        if not self.k_v < self.k_w_max:
            raise ValueError(
                "UnicycleTrackingGains: need k_v < k_w_max, got "
                f"k_v={self.k_v}, k_w_max={self.k_w_max}"
            )


def _check_gains(g: Any) -> None:
    for f in dataclasses.fields(g):
        v = getattr(g, f.name)
        if v is None and f.default is None:  # a default derived from the control period
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
            raise TypeError(f"{type(g).__name__}.{f.name} must be a number, got {v!r}")
        if f.name == "k_i":  # an integral gain may be zero (off)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{type(g).__name__}.k_i must be >= 0 and finite, got {v!r}")
        elif not (math.isfinite(v) and v > 0):
            raise ValueError(f"{type(g).__name__}.{f.name} must be positive and finite, got {v!r}")


def _check_ctrl_dt(value: Any) -> float:
    """``value`` as a positive finite control period (s)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TypeError(f"ctrl_dt must be a positive number of seconds, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"ctrl_dt must be a positive finite number of seconds, got {value!r}")
    return v


def _make_gains(cls: type, gains: Any) -> Any:
    if gains is None:
        return cls()
    if isinstance(gains, cls):
        return gains
    if isinstance(gains, Mapping):
        valid = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(gains) - set(valid))
        if "ctrl_dt" in unknown:
            raise TypeError(f"ctrl_dt is not a {cls.__name__} field: pass it to the controller "
                            "(e.g. TwistController(model, ctrl_dt=0.02))")
        if unknown:
            raise TypeError(f"unknown {cls.__name__} field(s) {unknown}; valid names: {valid}")
        return cls(**gains)
    raise TypeError(
        f"gains must be a {cls.__name__}, a mapping or None, got {type(gains).__name__}"
    )


# ---------------------------------------------------------------------------- compiled pieces
@njit(cache=True, inline="always")
def _saturate(tau, tmax):  # pragma: no cover - compiled
    """Scale ``tau`` uniformly into the limits; True if it had to."""
    worst = 0.0
    for i in range(tau.shape[0]):
        v = abs(tau[i]) / tmax[i]
        if v > worst:
            worst = v
    if worst > 1.0:
        for i in range(tau.shape[0]):
            tau[i] /= worst
        return True
    return False


@njit(cache=True)
def _tw_force(x, ud0, ud1, ud2, uf0, uf1, uf2, p, J, Q):  # pragma: no cover - compiled
    """ThreeWheel inverse dynamics (TW-6): ``Q = M(psi) udot + c(psi, u) - Q_f(psi, u_f)``
    and the Jacobian ``J(psi)`` of TW-1 (rows in motor order)."""
    cs = _tw.trig(x[6], x[7], x[8])
    m00, m01, m02, m11, m12, m22 = _tw.mass(cs, p)
    c0, c1, c2 = _tw.bias(cs, x[3], x[4], x[5], p)
    f0, f1, f2 = _tw.friction(cs, uf0, uf1, uf2, p)
    Q[0] = m00 * ud0 + m01 * ud1 + m02 * ud2 + c0 - f0
    Q[1] = m01 * ud0 + m11 * ud1 + m12 * ud2 + c1 - f1
    Q[2] = m02 * ud0 + m12 * ud1 + m22 * ud2 + c2 - f2
    for i in range(3):
        g, h = _tw.gh(cs, i, p)
        jd, js = _tw.jacobian_rows(g, h, p)
        for j in range(3):
            J[i, j] = jd[j]
            J[3 + i, j] = js[j]


@njit(cache=True)
def _tw_twist_one(x, cmd, p, tmax, kv, dt, mode, tau):  # pragma: no cover - compiled
    J = np.empty((6, 3))
    Q = np.empty(3)
    e0 = cmd[0] - x[3]
    e1 = cmd[1] - x[4]
    e2 = cmd[2] - x[5]
    ud0, ud1, ud2 = kv * e0, kv * e1, kv * e2
    _tw_force(x, ud0, ud1, ud2, x[3] + ud0 * dt, x[4] + ud1 * dt, x[5] + ud2 * dt, p, J, Q)
    status = _distribute_one(J, Q, tmax, mode, tau)
    return _saturate(tau, tmax) or status < 0


@njit(cache=True)
def _tw_track_one(x, pose, tw, rate, p, tmax, kp, kd, dt, mode, tau):  # pragma: no cover
    """Computed torque with a world-frame PD on pose (module docstring)."""
    yaw = x[2]
    vx, vy, wz = x[3], x[4], x[5]
    cy, sy = math.cos(yaw), math.sin(yaw)
    cr, sr = math.cos(pose[2]), math.sin(pose[2])
    # world velocities of robot and reference (docs/physics/conventions.md)
    vwx = cy * vx - sy * vy
    vwy = sy * vx + cy * vy
    rwx = cr * tw[0] - sr * tw[1]
    rwy = sr * tw[0] + cr * tw[1]
    # reference world acceleration: R_ref (udot_lin + wz S u_lin), S = [[0, -1], [1, 0]]
    bx = rate[0] - tw[2] * tw[1]
    by = rate[1] + tw[2] * tw[0]
    awx = cr * bx - sr * by + kd * (rwx - vwx) + kp * (pose[0] - x[0])
    awy = sr * bx + cr * by + kd * (rwy - vwy) + kp * (pose[1] - x[1])
    alpha = rate[2] + kd * (tw[2] - wz) + kp * wrap(pose[2] - yaw)
    # back to the body twist rate: udot_lin = R^T a - wz S u_lin
    ud0 = cy * awx + sy * awy + wz * vy
    ud1 = -sy * awx + cy * awy - wz * vx
    ud2 = alpha
    J = np.empty((6, 3))
    Q = np.empty(3)
    _tw_force(x, ud0, ud1, ud2, vx + ud0 * dt, vy + ud1 * dt, wz + ud2 * dt, p, J, Q)
    status = _distribute_one(J, Q, tmax, mode, tau)
    return _saturate(tau, tmax) or status < 0


@njit(cache=True)
def _ss_sides(eta0, eta1, ed0, ed1, p, dt):  # pragma: no cover - compiled
    """SS-3 inverted: ``(tau_L, tau_R) = Bbar^-1 (Mbar etadot + Cbar eta + Rbar(eta_f))``."""
    m, xicr, c, r = p[_ss.P_M], p[_ss.P_XICR], p[_ss.P_C], p[_ss.P_R]
    r0, r1, _ = _ss.resist(eta0 + ed0 * dt, eta1 + ed1 * dt, p)
    f0 = m * ed0 + m * xicr * eta1 * eta1 + r0  # Cbar eta = m x_icr (wz^2, -wz vx)
    f1 = (m * xicr * xicr + p[_ss.P_I]) * ed1 - m * xicr * eta1 * eta0 + r1
    # Bbar = (1/r) [[1, 1], [-c, c]]  ->  tau_L + tau_R = r f0, tau_R - tau_L = r f1 / c
    s = r * f0
    dlt = r * f1 / c
    return 0.5 * (s - dlt), 0.5 * (s + dlt)


@njit(cache=True, inline="always")
def _ss_split(tl, tr, frac, tau):  # pragma: no cover - compiled
    """SS-4: ``frac`` = share of the rear wheel on each side (0.5: min-norm halves)."""
    tau[0] = frac[0] * tl
    tau[1] = (1.0 - frac[0]) * tl
    tau[2] = (1.0 - frac[1]) * tr
    tau[3] = frac[1] * tr


@njit(cache=True)
def _ss_twist_one(x, cmd, p, tmax, frac, kv, dt, tau):  # pragma: no cover - compiled
    ed0 = kv * (cmd[0] - x[3])
    ed1 = kv * (cmd[1] - x[4])
    tl, tr = _ss_sides(x[3], x[4], ed0, ed1, p, dt)
    _ss_split(tl, tr, frac, tau)
    return _saturate(tau, tmax)


@njit(cache=True)
def _ss_twist_pi(x, cmd, p, tmax, frac, kv, beta, zmax, dt, z, tau):  # pragma: no cover
    """PI twist loop (module docstring); the integrator ``z (2,)`` is updated in place."""
    e0 = cmd[0] - x[3]
    e1 = cmd[1] - x[4]
    z0 = min(max(z[0] + beta * e0, -zmax[0]), zmax[0])
    z1 = min(max(z[1] + beta * e1, -zmax[1]), zmax[1])
    tl, tr = _ss_sides(x[3], x[4], kv * e0 + z0 / dt, kv * e1 + z1 / dt, p, dt)
    _ss_split(tl, tr, frac, tau)
    sat = _saturate(tau, tmax)
    if sat:  # conditional integration: while saturated, a component only steps towards zero
        y0 = z[0] if e0 * z[0] >= 0.0 else (0.0 if z0 * z[0] < 0.0 else z0)
        y1 = z[1] if e1 * z[1] >= 0.0 else (0.0 if z1 * z[1] < 0.0 else z1)
        if y0 != z0 or y1 != z1:
            z0, z1 = y0, y1
            tl, tr = _ss_sides(x[3], x[4], kv * e0 + z0 / dt, kv * e1 + z1 / dt, p, dt)
            _ss_split(tl, tr, frac, tau)
            sat = _saturate(tau, tmax)
    z[0] = z0
    z[1] = z1
    return sat


@njit(cache=True, inline="always")
def _unicycle_law(px, py, yaw, v, w, pose, tw, rate, gains):  # pragma: no cover - compiled
    """Kanayama's law for a point moving like a unicycle (forward speed v, yaw rate w),
    differentiated for the feedforward; returns the desired ``(vdot, wdot)``."""
    kx, ky, kth, kv, kwmax = gains[0], gains[1], gains[2], gains[3], gains[4]
    cy, sy = math.cos(yaw), math.sin(yaw)
    dx, dy = pose[0] - px, pose[1] - py
    ex = cy * dx + sy * dy
    ey = -sy * dx + cy * dy
    eth = wrap(pose[2] - yaw)
    vr, wr = tw[0], tw[2]
    vrd, wrd = rate[0], rate[2]
    if abs(vr) * kth > kwmax - kv:  # keep the sampled yaw-rate loop stable (class docstring)
        k_new = (kwmax - kv) / abs(vr)
        ky = ky * (k_new / kth) ** 2
        kth = k_new
    st, ct = math.sin(eth), math.cos(eth)
    vc = vr * ct + kx * ex
    wc = wr + vr * (ky * ey + kth * st)
    # error rates of a unicycle (v, w) tracking (vr, wr)
    exd = w * ey - v + vr * ct
    eyd = -w * ex + vr * st
    ethd = wr - w
    vcd = vrd * ct - vr * st * ethd + kx * exd
    wcd = wrd + vrd * (ky * ey + kth * st) + vr * (ky * eyd + kth * ct * ethd)
    return vcd + kv * (vc - v), wcd + kv * (wc - w)


@njit(cache=True)
def _ss_track_one(x, pose, tw, rate, p, tmax, frac, gains, dt, tau):  # pragma: no cover
    """Kanayama's law on the ICR point P (no lateral slip), backstepped into computed torque."""
    xicr = p[_ss.P_XICR]
    yaw = x[2]
    px = x[0] + xicr * math.cos(yaw)  # P = CoM + R (x_icr, 0): moves like a unicycle (SS-1)
    py = x[1] + xicr * math.sin(yaw)
    ed0, ed1 = _unicycle_law(px, py, yaw, x[3], x[4], pose, tw, rate, gains)
    tl, tr = _ss_sides(x[3], x[4], ed0, ed1, p, dt)
    _ss_split(tl, tr, frac, tau)
    return _saturate(tau, tmax)


@njit(cache=True)
def _ca_sides(x, ed0, ed1, p, dt, tau):  # pragma: no cover - compiled
    """CasterAGV inverse dynamics: ``Q = M(sigma) udot + c(sigma, u) - Q_f(sigma, u_f)`` and
    ``(tau_L, tau_R)`` from ``Q = ((tau_L + tau_R), c (tau_R - tau_L)) / r`` (no redundancy)."""
    v, w = x[3], x[4]
    cs = math.cos(x[5])
    sn = math.sin(x[5])
    gc0, gc1, hc0, hc1 = _ca.gh(cs, sn, p)
    n_l, n_r, n_c = _ca.loads(cs, sn, p)
    m00, m01, m11 = _ca.mass(gc0, gc1, hc0, hc1, p)
    b0, b1 = _ca.bias(gc0, gc1, hc0, hc1, v, w, p)
    q0, q1 = _ca.friction(gc0, gc1, hc0, hc1, v + ed0 * dt, w + ed1 * dt, n_l, n_r, n_c, p)
    f0 = m00 * ed0 + m01 * ed1 + b0 - q0
    f1 = m01 * ed0 + m11 * ed1 + b1 - q1
    r = p[_ca.P_R]
    c = p[_ca.P_C]
    tau[0] = 0.5 * r * (f0 - f1 / c)
    tau[1] = 0.5 * r * (f0 + f1 / c)


@njit(cache=True)
def _ca_twist_one(x, cmd, p, tmax, kv, dt, tau):  # pragma: no cover - compiled
    _ca_sides(x, kv * (cmd[0] - x[3]), kv * (cmd[1] - x[4]), p, dt, tau)
    return _saturate(tau, tmax)


@njit(cache=True)
def _ca_track_one(x, pose, tw, rate, p, tmax, gains, dt, tau):  # pragma: no cover - compiled
    """Kanayama's law on the axle midpoint (the body origin, ``vy = 0``), computed torque."""
    ed0, ed1 = _unicycle_law(x[0], x[1], x[2], x[3], x[4], pose, tw, rate, gains)
    _ca_sides(x, ed0, ed1, p, dt, tau)
    return _saturate(tau, tmax)


# Batch kernels (also the single-state path, with a batch of one). Each returns False, before
# computing anything, when an input is not finite.
@njit(cache=True)
def _k_tw_twist(X, C, p, tmax, kv, dt, mode, out, sat):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(C)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _tw_twist_one(X[n], C[n], p, tmax, kv, dt, mode, out[n])
    return True


@njit(cache=True)
def _k_tw_track(X, P, T, R, p, tmax, kp, kd, dt, mode, out, sat):  # pragma: no cover
    if not (all_finite(X) and all_finite(P) and all_finite(T) and all_finite(R)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _tw_track_one(X[n], P[n], T[n], R[n], p, tmax, kp, kd, dt, mode, out[n])
    return True


@njit(cache=True)
def _k_ss_twist(X, C, p, tmax, frac, kv, dt, beta, zmax, Z, out, sat):  # pragma: no cover
    """``Z (n, 2)``: the rows' integrators (PI loop when ``beta > 0`` and Z has X's rows;
    else the proportional loop, Z untouched)."""
    if not (all_finite(X) and all_finite(C)):
        return False
    if beta > 0.0 and Z.shape[0] == X.shape[0]:
        for n in range(X.shape[0]):
            sat[n] = _ss_twist_pi(X[n], C[n], p, tmax, frac, kv, beta, zmax, dt, Z[n], out[n])
    else:
        for n in range(X.shape[0]):
            sat[n] = _ss_twist_one(X[n], C[n], p, tmax, frac, kv, dt, out[n])
    return True


@njit(cache=True)
def _k_ss_track(X, P, T, R, p, tmax, frac, gains, dt, out, sat):  # pragma: no cover
    if not (all_finite(X) and all_finite(P) and all_finite(T) and all_finite(R)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _ss_track_one(X[n], P[n], T[n], R[n], p, tmax, frac, gains, dt, out[n])
    return True


@njit(cache=True)
def _k_ca_twist(X, C, p, tmax, kv, dt, out, sat):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(C)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _ca_twist_one(X[n], C[n], p, tmax, kv, dt, out[n])
    return True


@njit(cache=True)
def _k_ca_track(X, P, T, R, p, tmax, gains, dt, out, sat):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(P) and all_finite(T) and all_finite(R)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _ca_track_one(X[n], P[n], T[n], R[n], p, tmax, gains, dt, out[n])
    return True


# Row-parameter batch kernels: the same per-state pieces with each row's own packed parameters
# ``P (n, n_p)`` and torque limits ``T (n, m)`` (the ``"true"`` controller model: the plant's
# parameters row by row, ``docs/topics/robustness.md``); compiled on first use.
@njit(cache=True)
def _k_tw_twist_rows(X, C, P, T, kv, dt, mode, out, sat):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(C)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _tw_twist_one(X[n], C[n], P[n], T[n], kv, dt, mode, out[n])
    return True


@njit(cache=True)
def _k_tw_track_rows(X, Pz, Tw, R, P, T, kp, kd, dt, mode, out, sat):  # pragma: no cover
    if not (all_finite(X) and all_finite(Pz) and all_finite(Tw) and all_finite(R)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _tw_track_one(X[n], Pz[n], Tw[n], R[n], P[n], T[n], kp, kd, dt, mode, out[n])
    return True


@njit(cache=True)
def _k_ss_twist_rows(X, C, P, T, frac, kv, dt, beta, zmax, Z, out, sat):  # pragma: no cover
    if not (all_finite(X) and all_finite(C)):
        return False
    if beta > 0.0 and Z.shape[0] == X.shape[0]:
        for n in range(X.shape[0]):
            sat[n] = _ss_twist_pi(X[n], C[n], P[n], T[n], frac, kv, beta, zmax, dt, Z[n],
                                  out[n])
    else:
        for n in range(X.shape[0]):
            sat[n] = _ss_twist_one(X[n], C[n], P[n], T[n], frac, kv, dt, out[n])
    return True


@njit(cache=True)
def _k_ss_track_rows(X, Pz, Tw, R, P, T, frac, gains, dt, out, sat):  # pragma: no cover
    if not (all_finite(X) and all_finite(Pz) and all_finite(Tw) and all_finite(R)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _ss_track_one(X[n], Pz[n], Tw[n], R[n], P[n], T[n], frac, gains, dt, out[n])
    return True


@njit(cache=True)
def _k_ca_twist_rows(X, C, P, T, kv, dt, out, sat):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(C)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _ca_twist_one(X[n], C[n], P[n], T[n], kv, dt, out[n])
    return True


@njit(cache=True)
def _k_ca_track_rows(X, Pz, Tw, R, P, T, gains, dt, out, sat):  # pragma: no cover - compiled
    if not (all_finite(X) and all_finite(Pz) and all_finite(Tw) and all_finite(R)):
        return False
    for n in range(X.shape[0]):
        sat[n] = _ca_track_one(X[n], Pz[n], Tw[n], R[n], P[n], T[n], gains, dt, out[n])
    return True


def _check_rows(P: Any, T: Any, n: int, n_p: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """``P (n, n_p)`` and ``T (n, m)`` as C-contiguous float64 arrays (``ValueError``)."""
    P, T = kernel_array(P), kernel_array(T)
    if P.shape != (n, n_p):
        raise ValueError(f"params must have shape ({n}, {n_p}) (one packed row per state), "
                         f"got {P.shape}")
    if T.shape != (n, m):
        raise ValueError(f"tau_max must have shape ({n}, {m}), got {T.shape}")
    if not (np.all(np.isfinite(P)) and np.all(T > 0) and np.all(np.isfinite(T))):
        raise ValueError("params must be finite and tau_max positive and finite")
    return P, T


@njit(cache=True)
def _k_tw_inverse(X, UD, UF, p, J, Q):  # pragma: no cover - compiled
    for n in range(X.shape[0]):
        _tw_force(X[n], UD[n, 0], UD[n, 1], UD[n, 2], UF[n, 0], UF[n, 1], UF[n, 2], p, J[n],
                  Q[n])


def _is_vec(a: Any, n: int) -> bool:
    """A C-contiguous, writable float64 array of shape (n,) (eligible for the single-state
    fast path; :func:`wheelgym.integrators.kernel_array` says why writable)."""
    return (type(a) is np.ndarray and a.shape == (n,) and a.dtype == np.float64
            and a.flags.c_contiguous and a.flags.writeable)


# ---------------------------------------------------------------------------- helpers
_SUPPORTED = (ThreeWheel, SkidSteer, CasterAGV)


def _check_model(model: Any) -> None:
    if not isinstance(model, _SUPPORTED):
        raise TypeError(
            "model must be one of "
            f"{[c.__name__ for c in _SUPPORTED]}, got {type(model).__name__}"
        )


def _batch(a: Any, width: int, name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != width:
        raise ValueError(f"{name} must have shape (..., {width}), got {arr.shape}")
    return arr


def _flat(arrays: list[np.ndarray]) -> tuple[list[np.ndarray], tuple[int, ...]]:
    lead = np.broadcast_shapes(*(a.shape[:-1] for a in arrays))
    out = [kernel_array(np.broadcast_to(a, lead + a.shape[-1:]).reshape(-1, a.shape[-1]))
           for a in arrays]
    return out, lead


def inverse_dynamics(model: ThreeWheel, x: Any, udot: Any, u_friction: Any = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Required generalized force ``Q_d = M(psi) udot + c(psi, u) - Q_f(psi, u_f)`` (TW-6).

    Args:
        model: a :class:`~wheelgym.models.ThreeWheel`.
        x: state ``(..., 12)``; ``psi`` and the twist ``u`` are read from it.
        udot: desired body twist rate ``(..., 3)`` (m/s², m/s², rad/s²).
        u_friction: twist at which to evaluate friction (default: the state's twist).

    Returns:
        ``(Q_d, J)``: ``(..., 3)`` (N, N, N·m) and the TW-1 Jacobian ``(..., 6, 3)``; motor
        torques follow from :func:`~wheelgym.control.distribution.distribute` ``(J, Q_d)``.
    """
    if not isinstance(model, ThreeWheel):
        raise TypeError(f"model must be a ThreeWheel, got {type(model).__name__}")
    X = _batch(x, 12, "x")
    UD = _batch(udot, 3, "udot")
    UF = X[..., 3:6] if u_friction is None else _batch(u_friction, 3, "u_friction")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(UD)) and np.all(np.isfinite(UF))):
        raise ValueError("x, udot and u_friction must be finite")
    (X2, UD2, UF2), lead = _flat([X, UD, UF])
    J = np.empty((X2.shape[0], 6, 3))
    Q = np.empty((X2.shape[0], 3))
    _k_tw_inverse(X2, UD2, UF2, model.packed, J, Q)
    return Q.reshape(lead + (3,)), J.reshape(lead + (6, 3))


def tracked_point(model: Any, x: Any) -> np.ndarray:
    """World position ``(..., 2)`` of the point a :class:`TrackingController` steers onto the path.

    ThreeWheel: the centre of mass. SkidSteer: the point ``P`` at ``(x_icr, 0)`` in B, the one
    body point without lateral velocity (SS-1: ``vy + x_icr wz = 0``), which moves like a
    unicycle; the centre of mass cannot keep its velocity along its heading while turning.
    CasterAGV: its body origin, the axle midpoint (``vy = 0`` there).
    """
    _check_model(model)
    X = _batch(x, model.state_dim, "x")
    if isinstance(model, SkidSteer):
        xi = model.params.x_icr
        return np.stack([X[..., 0] + xi * np.cos(X[..., 2]), X[..., 1] + xi * np.sin(X[..., 2])],
                        axis=-1)
    return X[..., :2].copy()


# ---------------------------------------------------------------------------- controllers
class _Controller:
    """Shared parts: model checks, distribution mode, limits, SB3-style ``predict``."""

    _gains_type: type = TwistGains

    def __init__(self, model: Any, gains: Any = None, distribution: str = "min_norm", *,
                 ctrl_dt: float | None = None) -> None:
        _check_model(model)
        self.model = model
        #: Control period (s): the torques are held over it (friction look-ahead, sampled gains).
        self.ctrl_dt = _check_ctrl_dt(model.default_ctrl_dt if ctrl_dt is None else ctrl_dt)
        self.gains = self._resolve_gains(_make_gains(self._gains_for(model), gains))
        self._p = model.packed
        if isinstance(model, ThreeWheel):
            if distribution not in DISTRIBUTIONS:
                raise ValueError(
                    f"distribution must be one of {DISTRIBUTIONS} for ThreeWheel, "
                    f"got {distribution!r}"
                )
            self._mode = DISTRIBUTIONS.index(distribution)
            self._tmax = np.ascontiguousarray(model.params.tau_max, dtype=np.float64)
        elif isinstance(model, CasterAGV):
            if distribution != "min_norm":
                raise ValueError(
                    "distribution must be one of ('min_norm',) for CasterAGV (two motors, two "
                    f"degrees of freedom: no redundancy), got {distribution!r}"
                )
            self._mode = 0
            self._tmax = np.full(2, float(model.params.tau_max))
        else:
            valid = ("min_norm", "loads")
            if distribution not in valid:
                raise ValueError(
                    f"distribution must be one of {valid} for SkidSteer (SS-4: equal halves or "
                    f"in proportion to the normal loads), got {distribution!r}"
                )
            self._mode = valid.index(distribution)
            n = model.params.normal_loads  # [RL, FL, FR, RR]
            rear = 0.5 if distribution == "min_norm" else n[0] / (n[0] + n[1])
            rear_r = 0.5 if distribution == "min_norm" else n[3] / (n[2] + n[3])
            self._frac = np.array([rear, rear_r])
            self._tmax = np.full(4, float(model.params.tau_max))
        self.distribution = distribution
        self._tw = isinstance(model, ThreeWheel)
        self._ca = isinstance(model, CasterAGV)
        self._t: np.ndarray | float = 0.0

    def _gains_for(self, model: Any) -> type:
        return self._gains_type

    def _resolve_gains(self, gains: Any) -> Any:
        """The gains with their period-derived defaults filled in, checked against
        :attr:`ctrl_dt`."""
        return gains

    def batch_kernel(self) -> tuple[Any, tuple[Any, ...]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def __getstate__(self) -> dict[str, Any]:
        """State for ``copy`` and ``pickle``, without the compiled kernel (rebuilt)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_kernel", "_args")}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._kernel, self._args = self.batch_kernel()

    @property
    def tau_max(self) -> np.ndarray:
        """Motor torque limits (N·m), motor order."""
        return self._tmax.copy()

    def reset(self) -> None:
        """Forget the time counter of :meth:`predict` (``torques`` keeps no state)."""
        self._t = 0.0

    def act(self, state: Any, reference: Any) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError


class TwistController(_Controller):
    """Commanded body twist -> motor torques (computed torque, then load distribution).

    Twist command: ``(vx, vy, wz)`` for ThreeWheel, ``(vx, wz)`` for SkidSteer and
    CasterAGV (its ``(v, w)`` of the axle midpoint). See the module docstring for the
    sampled-loop design (deadbeat ``k_v = 1/ctrl_dt``).

    Args:
        model: the controller's model (its parameters may differ from the plant's).
        gains: :class:`TwistGains`, a mapping of its fields, or None (``k_v = 1 / ctrl_dt``).
        distribution: ThreeWheel: ``"min_norm"`` (default), ``"weighted"`` or
            ``"within_limits"``; SkidSteer: ``"min_norm"`` (equal halves) or ``"loads"``;
            CasterAGV: ``"min_norm"`` (two motors for two degrees of freedom: the torques are
            unique).
        ctrl_dt: control period (s) the torques are held over; default the model's
            ``default_ctrl_dt``. An environment passes its own.
        rows: number of independent integrators (SkidSteer integral action, one per batch row)
            that :meth:`batch_kernel` and :meth:`step` use; 0: none yet (:meth:`step` sizes
            them to its batch).

    ``gains.k_v`` and ``gains.k_i`` hold the gains in use. :meth:`torques` is stateless (the
    proportional loop with its feed-forward); :meth:`step` and the batch kernel add the integral
    action (SkidSteer, ``k_i > 0``) and advance the per-row integrators, which
    :meth:`reset_rows` and :meth:`reset` zero.
    """

    def __init__(self, model: Any, gains: Any = None, distribution: str = "min_norm", *,
                 ctrl_dt: float | None = None, rows: int = 0) -> None:
        super().__init__(model, gains, distribution, ctrl_dt=ctrl_dt)
        if isinstance(model, SkidSteer):  # z_max: module docstring (anti-windup)
            p = model.params
            force = float(np.sum(self._tmax)) / p.r
            self._zmax = np.array([self.ctrl_dt * force / p.m,
                                   self.ctrl_dt * force * p.c / (p.m * p.x_icr**2 + p.I)])
        else:
            self._zmax = np.zeros(2)
        self._z0 = np.zeros((0, 2))  # no integrator: the stateless torques()
        self.set_rows(rows)

    def _resolve_gains(self, gains: TwistGains) -> TwistGains:
        k_v = 1.0 / self.ctrl_dt if gains.k_v is None else float(gains.k_v)
        if k_v * self.ctrl_dt >= 2.0:
            raise ValueError(
                f"TwistGains: k_v * ctrl_dt = {k_v * self.ctrl_dt:.3g} must be < 2 for a "
                "stable sampled loop (1 is deadbeat)"
            )
        ss = isinstance(self.model, SkidSteer)
        k_i = (0.3 / self.ctrl_dt**2 if ss else 0.0) if gains.k_i is None else float(gains.k_i)
        if k_i > 0 and not ss:
            raise ValueError(f"TwistGains: integral action (k_i > 0) is for SkidSteer only, "
                             f"got k_i={k_i} for {type(self.model).__name__}")
        if k_i * self.ctrl_dt**2 >= 1.0:
            raise ValueError(f"TwistGains: k_i * ctrl_dt**2 = {k_i * self.ctrl_dt**2:.3g} must "
                             "be < 1 (module docstring; default 0.3)")
        return dataclasses.replace(gains, k_v=k_v, k_i=k_i)

    def set_rows(self, rows: int) -> None:
        """Bind ``rows`` fresh (zero) integrators; rebuilds :meth:`batch_kernel`'s arguments
        (callers holding the old ones must fetch them again)."""
        if isinstance(rows, bool) or not isinstance(rows, (int, np.integer)) or rows < 0:
            raise ValueError(f"rows must be an int >= 0, got {rows!r}")
        #: Per-row integrators ``(rows, 2)`` (twist units; module docstring).
        self.integrator = np.zeros((int(rows), 2))
        self._kernel, self._args = self._make_kernel(self._z0)

    def reset_rows(self, idx: Any) -> None:
        """Zero the integrators of rows ``idx`` (an environment's reset of those rows)."""
        if self.integrator.shape[0]:
            self.integrator[idx] = 0.0

    def reset(self) -> None:
        """Zero every integrator and the time counter of :meth:`predict`."""
        super().reset()
        self.integrator[:] = 0.0

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._kernel, self._args = self._make_kernel(self._z0)

    def _make_kernel(self, Z: np.ndarray) -> tuple[Any, tuple[Any, ...]]:
        k_v, dt = self.gains.k_v, self.ctrl_dt
        if self._tw:
            return _k_tw_twist, (self._p, self._tmax, k_v, dt, self._mode)
        if self._ca:
            return _k_ca_twist, (self._p, self._tmax, k_v, dt)
        beta = self.gains.k_i * dt * dt
        return _k_ss_twist, (self._p, self._tmax, self._frac, k_v, dt, beta, self._zmax, Z)

    def batch_kernel(self) -> tuple[Any, tuple[Any, ...]]:
        """The compiled batch kernel and its trailing arguments: ``kernel(X, C, *args, out,
        sat)`` writes the torques ``out (n, m)`` and ``sat (n,)`` of states ``X (n, nx)`` and
        commands ``C (n, k)`` (C-contiguous float64) and returns False if an input is not
        finite. :meth:`step` without its per-call checks, for callers that step a batch
        (the environments' velocity mode): with :attr:`integrator` bound to ``n`` rows
        (``rows``, :meth:`set_rows`) the SkidSteer kernel advances them (integral action); with
        none it is :meth:`torques`."""
        return self._make_kernel(self.integrator)

    def row_kernel(self, params: np.ndarray, tau_max: np.ndarray
                   ) -> tuple[Any, tuple[Any, ...]]:
        """:meth:`batch_kernel` with each row's own model: ``kernel(X, C, *args, out, sat)``
        reads row n's packed parameters ``params[n]`` (the layout of ``model.packed``) and
        torque limits ``tau_max[n]`` (both C-contiguous float64, bound by reference: the
        caller may change their values between calls). The ``"true"`` controller model of
        the environments (``docs/topics/robustness.md``): the plant's parameters row by row.
        The SkidSteer anti-windup bound ``z_max`` stays the controller model's."""
        k_v, dt = self.gains.k_v, self.ctrl_dt
        if self._tw:
            return _k_tw_twist_rows, (params, tau_max, k_v, dt, self._mode)
        if self._ca:
            return _k_ca_twist_rows, (params, tau_max, k_v, dt)
        beta = self.gains.k_i * dt * dt
        return _k_ss_twist_rows, (params, tau_max, self._frac, k_v, dt, beta, self._zmax,
                                  self.integrator)

    def row_torques(self, x: Any, twist_cmd: Any, params: Any, tau_max: Any
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Stateless :meth:`torques` of a batch ``x (n, nx)``, ``twist_cmd (n, k)`` with each
        row's own packed parameters ``params (n, n_p)`` and torque limits ``tau_max (n, m)``
        (:meth:`row_kernel`)."""
        X = kernel_array(_batch(x, self.model.state_dim, "x"))
        C = kernel_array(_batch(twist_cmd, self.command_dim, "twist_cmd"))
        if X.ndim != 2 or C.shape[0] != X.shape[0]:
            raise ValueError(f"x and twist_cmd must be batches (n, ...) of one n, got "
                             f"{X.shape} and {C.shape}")
        n = X.shape[0]
        P, T = _check_rows(params, tau_max, n, self._p.size, self.model.input_dim)
        out = np.empty((n, self.model.input_dim))
        sat = np.empty(n, dtype=np.bool_)
        kernel, args = self._row_kernel_stateless(P, T)
        if not kernel(X, C, *args, out, sat):
            raise ValueError("x and twist_cmd must be finite")
        return out, sat

    def _row_kernel_stateless(self, P: np.ndarray, T: np.ndarray
                              ) -> tuple[Any, tuple[Any, ...]]:
        kernel, args = self.row_kernel(P, T)
        if not (self._tw or self._ca):  # the proportional loop: no integrator rows
            args = args[:-1] + (self._z0,)
        return kernel, args

    @property
    def command_dim(self) -> int:
        return 3 if isinstance(self.model, ThreeWheel) else 2

    def torques(self, x: Any, twist_cmd: Any) -> tuple[np.ndarray, np.ndarray]:
        """Motor torques for state(s) ``x`` ``(..., n)`` and commands ``(..., k)``.

        Returns:
            ``(tau, saturated)``: ``(..., m)`` N·m within the limits, and ``(...,)`` bool.
        """
        nx, k = self.model.state_dim, self.command_dim
        if _is_vec(x, nx) and _is_vec(twist_cmd, k):  # one state: a batch of one, no copies
            X2, C2, lead = x.reshape(1, nx), twist_cmd.reshape(1, k), ()
        else:
            X = _batch(x, nx, "x")
            C = _batch(twist_cmd, k, "twist_cmd")
            (X2, C2), lead = _flat([X, C])
        n = X2.shape[0]
        out = np.empty((n, self.model.input_dim))
        sat = np.empty(n, dtype=np.bool_)
        if not self._kernel(X2, C2, *self._args, out, sat):
            raise ValueError("x and twist_cmd must be finite")
        if lead == ():
            return out[0], sat[0]
        return out.reshape(lead + (self.model.input_dim,)), sat.reshape(lead)

    def step(self, x: Any, twist_cmd: Any) -> tuple[np.ndarray, np.ndarray]:
        """One control step of the stateful loop: as :meth:`torques`, plus the integral
        action (SkidSteer, ``k_i > 0``), advancing one integrator per row of the flattened
        batch (a batch of another size than :attr:`integrator` starts fresh ones)."""
        nx, k = self.model.state_dim, self.command_dim
        X = _batch(x, nx, "x")
        C = _batch(twist_cmd, k, "twist_cmd")
        (X2, C2), lead = _flat([X, C])
        n = X2.shape[0]
        if self.integrator.shape[0] != n:
            self.set_rows(n)
        out = np.empty((n, self.model.input_dim))
        sat = np.empty(n, dtype=np.bool_)
        kernel, args = self.batch_kernel()
        if not kernel(X2, C2, *args, out, sat):
            raise ValueError("x and twist_cmd must be finite")
        return out.reshape(lead + (self.model.input_dim,)), sat.reshape(lead)

    def act(self, state: Any, reference: Any) -> np.ndarray:
        """Torques for ``state`` and a twist command ``reference``."""
        return self.torques(state, reference)[0]

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, None]:
        """SB3-style: ``observation`` is ``concat(model state, twist command)``."""
        obs = np.asarray(observation, dtype=np.float64)
        n = self.model.state_dim
        return self.act(obs[..., :n], obs[..., n:]), None


class TrackingController(_Controller):
    """Trajectory tracking by computed torque.

    * ThreeWheel (holonomic): feedforward from the reference twist and its rate plus a
      world-frame PD on pose and twist (:class:`TrackingGains`), inverse dynamics (TW-6), then
      load distribution.
    * SkidSteer (nonholonomic): Kanayama's law on the ICR point (:func:`tracked_point`), its
      time derivative fed forward, a twist loop, computed torque through SS-3, then the
      per-side split (SS-4) (:class:`UnicycleTrackingGains`). The reference must have a
      tangent heading (``vy = 0``) and describes that point's motion.
    * CasterAGV (nonholonomic): the same law on the axle midpoint, computed torque through
      its ``M(sigma) udot + c - Q_f``, solved exactly for the two drive torques.

    Args:
        model: the controller's model.
        gains: the gains dataclass for the model, a mapping, or None.
        distribution: as for :class:`TwistController`.
        trajectory: optional :class:`~wheelgym.kinematics.references.Reference` used by
            :meth:`predict` (evaluated at ``k * ctrl_dt`` on the k-th call since reset).
        ctrl_dt: control period (s) the torques are held over; default the model's
            ``default_ctrl_dt``.
    """

    def __init__(self, model: Any, gains: Any = None, distribution: str = "min_norm",
                 trajectory: Any = None, *, ctrl_dt: float | None = None) -> None:
        super().__init__(model, gains, distribution, ctrl_dt=ctrl_dt)
        if trajectory is not None and not hasattr(trajectory, "evaluate"):
            raise TypeError("trajectory must have an evaluate(t) method (a Reference)")
        self.trajectory = trajectory
        if not self._tw:
            g = self.gains
            self._gv = np.array([g.k_x, g.k_y, g.k_yaw, g.k_v, g.k_w_max])
        self._kernel, self._args = self.batch_kernel()

    def _gains_for(self, model: Any) -> type:
        return TrackingGains if isinstance(model, ThreeWheel) else UnicycleTrackingGains

    def _resolve_gains(self, gains: Any) -> Any:
        if isinstance(gains, UnicycleTrackingGains) and not gains.k_w_max < 2.0 / self.ctrl_dt:
            raise ValueError(
                "UnicycleTrackingGains: need k_w_max < 2 / ctrl_dt, got "
                f"k_w_max={gains.k_w_max}, ctrl_dt={self.ctrl_dt}"
            )
        return gains

    def batch_kernel(self) -> tuple[Any, tuple[Any, ...]]:
        """The compiled batch kernel and its trailing arguments: ``kernel(X, P, T, R, *args,
        out, sat)`` writes the torques ``out (n, m)`` and ``sat (n,)`` of states ``X`` and
        reference poses, twists and twist rates ``P, T, R (n, 3)`` (C-contiguous float64);
        False if an input is not finite."""
        g, dt = self.gains, self.ctrl_dt
        if self._tw:
            return _k_tw_track, (self._p, self._tmax, g.k_p, g.k_d, dt, self._mode)
        if self._ca:
            return _k_ca_track, (self._p, self._tmax, self._gv, dt)
        return _k_ss_track, (self._p, self._tmax, self._frac, self._gv, dt)

    def row_kernel(self, params: np.ndarray, tau_max: np.ndarray
                   ) -> tuple[Any, tuple[Any, ...]]:
        """:meth:`batch_kernel` with each row's own packed parameters ``params (n, n_p)`` and
        torque limits ``tau_max (n, m)`` (as :meth:`TwistController.row_kernel`)."""
        g, dt = self.gains, self.ctrl_dt
        if self._tw:
            return _k_tw_track_rows, (params, tau_max, g.k_p, g.k_d, dt, self._mode)
        if self._ca:
            return _k_ca_track_rows, (params, tau_max, self._gv, dt)
        return _k_ss_track_rows, (params, tau_max, self._frac, self._gv, dt)

    def row_torques(self, x: Any, ref_pose: Any, ref_twist: Any, ref_twist_rate: Any,
                    params: Any, tau_max: Any) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`torques` of a batch ``(n, ...)`` with each row's own packed parameters
        ``params (n, n_p)`` and torque limits ``tau_max (n, m)``."""
        X = kernel_array(_batch(x, self.model.state_dim, "x"))
        refs = [kernel_array(_batch(a, 3, name)) for a, name in
                ((ref_pose, "ref_pose"), (ref_twist, "ref_twist"),
                 (ref_twist_rate, "ref_twist_rate"))]
        if X.ndim != 2 or any(r.shape != (X.shape[0], 3) for r in refs):
            raise ValueError("x and the reference must be batches (n, ...) of one n")
        n = X.shape[0]
        P, T = _check_rows(params, tau_max, n, self._p.size, self.model.input_dim)
        out = np.empty((n, self.model.input_dim))
        sat = np.empty(n, dtype=np.bool_)
        kernel, args = self.row_kernel(P, T)
        if not kernel(X, *refs, *args, out, sat):
            raise ValueError("x and the reference must be finite")
        return out, sat

    def torques(self, x: Any, ref_pose: Any, ref_twist: Any, ref_twist_rate: Any
                ) -> tuple[np.ndarray, np.ndarray]:
        """Motor torques ``(..., m)`` and ``saturated`` ``(...,)`` for state(s) ``x``.

        ``ref_pose`` ``(..., 3)`` world (x, y, yaw); ``ref_twist`` and ``ref_twist_rate``
        ``(..., 3)`` in the reference's body frame (as :meth:`Reference.evaluate` returns).
        """
        nx = self.model.state_dim
        if (_is_vec(x, nx) and _is_vec(ref_pose, 3) and _is_vec(ref_twist, 3)
                and _is_vec(ref_twist_rate, 3)):  # one state: a batch of one, no copies
            X2, P2, T2, R2 = (x.reshape(1, nx), ref_pose.reshape(1, 3), ref_twist.reshape(1, 3),
                              ref_twist_rate.reshape(1, 3))
            lead: tuple[int, ...] = ()
        else:
            X = _batch(x, nx, "x")
            P = _batch(ref_pose, 3, "ref_pose")
            T = _batch(ref_twist, 3, "ref_twist")
            R = _batch(ref_twist_rate, 3, "ref_twist_rate")
            (X2, P2, T2, R2), lead = _flat([X, P, T, R])
        n = X2.shape[0]
        out = np.empty((n, self.model.input_dim))
        sat = np.empty(n, dtype=np.bool_)
        if not self._kernel(X2, P2, T2, R2, *self._args, out, sat):
            raise ValueError("x and the reference must be finite")
        if lead == ():
            return out[0], sat[0]
        return out.reshape(lead + (self.model.input_dim,)), sat.reshape(lead)

    def act(self, state: Any, reference: Any) -> np.ndarray:
        """Torques for ``state`` and ``reference = (pose, twist, twist_rate)``."""
        if not (isinstance(reference, (tuple, list)) and len(reference) == 3):
            raise TypeError("reference must be a (pose, twist, twist_rate) tuple")
        return self.torques(state, *reference)[0]

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, None]:
        """SB3-style: ``observation`` is the raw model state; needs ``trajectory``.

        Keeps a time counter per leading index (``episode_start`` True resets it).
        """
        if self.trajectory is None:
            raise ValueError("predict needs a trajectory (pass trajectory=... to the constructor)")
        obs = _batch(observation, self.model.state_dim, "observation")
        lead = obs.shape[:-1]
        t = np.broadcast_to(np.asarray(self._t, dtype=np.float64), lead).copy()
        if episode_start is not None:
            t = np.where(np.asarray(episode_start, dtype=bool), 0.0, t)
        tau = self.act(obs, self.trajectory.evaluate(t))
        self._t = t + self.ctrl_dt
        return tau, None


def make_controller(model: Any, kind: str = "twist", **kwargs: Any) -> _Controller:
    """Build a controller: ``kind`` ``"twist"`` (:class:`TwistController`) or ``"tracking"``
    (:class:`TrackingController`); keyword arguments go to the constructor."""
    kinds = {"twist": TwistController, "tracking": TrackingController}
    if kind not in kinds:
        raise ValueError(f"kind must be one of {sorted(kinds)}, got {kind!r}")
    return kinds[kind](model, **kwargs)
