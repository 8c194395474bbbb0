"""The one compiled body of an environment's physics step, shared by every robot.

Each robot module binds its model's per-state derivative ``_deriv_one`` and two small per-state
helpers (joint rates, features) into a cached kernel ``k_env_step`` that inlines
:func:`env_step_body`, the same way the models bind ``rk4_inplace`` (a derivative passed at run
time cannot be cached and costs a call per stage). Every row of the batch is independent and
uses its own parameter row ``P[i]``, so a batch of N robots gives each robot the bits of N = 1.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["env_step_body", "rk4_work"]


@njit(cache=True, inline="always")
def _power(jrate, x, u, p, jr):  # pragma: no cover - compiled
    jrate(x, p, jr)
    s = 0.0
    for j in range(u.shape[0]):
        s += u[j] * jr[j]
    return s


@njit(cache=True, inline="always")
def rk4_work(f, jrate, x, u, p, h, work, jr):  # pragma: no cover - compiled
    """One RK4 step of ``x`` (the arithmetic of ``integrators.rk4_inplace``, so the same bits)
    that also integrates the motor power ``u . jrate`` with the same stages: the work is RK4 of
    the state augmented with ``E' = u . qdot`` (exact to the integrator's order)."""
    m = x.shape[0]
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    tmp = work[4]
    half = 0.5 * h
    sixth = h / 6.0
    f(x, u, p, k1)
    e1 = _power(jrate, x, u, p, jr)
    for j in range(m):
        tmp[j] = x[j] + half * k1[j]
    f(tmp, u, p, k2)
    e2 = _power(jrate, tmp, u, p, jr)
    for j in range(m):
        tmp[j] = x[j] + half * k2[j]
    f(tmp, u, p, k3)
    e3 = _power(jrate, tmp, u, p, jr)
    for j in range(m):
        tmp[j] = x[j] + h * k3[j]
    f(tmp, u, p, k4)
    e4 = _power(jrate, tmp, u, p, jr)
    for j in range(m):
        x[j] += sixth * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    return sixth * (e1 + 2.0 * e2 + 2.0 * e3 + e4)


@njit(cache=True, inline="always")
def env_step_body(f, jrate, feats, X, A, LO, HI, P, h, n, Xo, U, jv, energy, eff,
                  pose, twist, feat, xf, sat, ok):  # pragma: no cover - compiled
    """Scale actions, integrate one control period, accumulate motor work, extract features.

    Args:
        f: per-state derivative ``f(x, u, p, out)`` of the model.
        jrate: ``jrate(x, p, out)`` joint (motor) rates in input order (rad/s); power is
            ``u . jrate`` (W). Robots without motors write zeros.
        feats: ``feats(x, u, p, pose, twist, feat) -> float`` writes the pose (x, y, yaw), the
            body twist (vx, vy, wz), the robot's extra observation features, and returns the
            internal-force measure (0 where it does not apply).
        X: states ``(N, n_x)`` (read only).
        A: normalised commands ``(N, m)``; clipped to [-1, 1] (``sat`` marks a clip).
        LO, HI: physical input bounds per row ``(N, m)``; ``u = mid + a * half``.
        P: packed parameters per row ``(N, n_p)``.
        h, n: substep (s) and substep count.
        Xo: new states (written).  U: physical inputs (written).  jv: joint rates at the end.
        energy: cumulative motor work per row (J, RK4 of ``E' = u . qdot`` on the same stages).
        eff: mean squared normalised command, ``sum a_j^2 / m``.
        pose, twist, feat, xf: outputs of ``feats`` at the new state.
        sat, ok: clip flag; False where the new state is not finite (``Xo`` then holds ``X``).

    Returns:
        False when an action entry is not finite (nothing is written then).
    """
    N = X.shape[0]
    m = A.shape[1]
    nx = X.shape[1]
    for i in range(N):
        for j in range(m):
            if not np.isfinite(A[i, j]):
                return False
    work = np.empty((5, nx))
    for i in range(N):
        s = False
        e = 0.0
        for j in range(m):
            a = A[i, j]
            if a > 1.0:
                a = 1.0
                s = True
            elif a < -1.0:
                a = -1.0
                s = True
            e += a * a
            U[i, j] = 0.5 * (HI[i, j] + LO[i, j]) + 0.5 * a * (HI[i, j] - LO[i, j])
        sat[i] = s
        eff[i] = e / m if m > 0 else 0.0
        x = Xo[i]
        for k in range(nx):
            x[k] = X[i, k]
        u = U[i]
        p = P[i]
        jr = jv[i]
        acc = 0.0
        for _ in range(n):
            acc += rk4_work(f, jrate, x, u, p, h, work, jr)
        jrate(x, p, jr)
        good = np.isfinite(acc)
        for k in range(nx):
            if not np.isfinite(x[k]):
                good = False
        if not good:
            for k in range(nx):
                x[k] = X[i, k]
            jrate(x, p, jr)
        else:
            energy[i] += acc
        ok[i] = good
        xf[i] = feats(x, u, p, pose[i], twist[i], feat[i])
    return True
