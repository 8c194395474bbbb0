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

from wheelgym.integrators import rk4_inplace

__all__ = ["env_step_body"]


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
        energy: cumulative motor work per row (J, accumulated by the trapezoid rule on substeps).
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
        jrate(x, p, jr)
        pw0 = 0.0
        for j in range(m):
            pw0 += u[j] * jr[j]
        acc = 0.0
        for _ in range(n):
            rk4_inplace(f, x, u, p, h, 1, work)
            jrate(x, p, jr)
            pw1 = 0.0
            for j in range(m):
                pw1 += u[j] * jr[j]
            acc += 0.5 * h * (pw0 + pw1)
            pw0 = pw1
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
