"""The one compiled body of an environment's physics step, shared by every robot.

Each robot module binds its model's per-state derivative ``_deriv_one`` and three small per-state
helpers (stage motor power, joint rates, features) into a cached kernel ``k_env_step`` that inlines
:func:`env_step_body` and ``integrators.rk4_power``, the same way the models bind
``rk4_inplace`` (a derivative passed at run time cannot be cached and costs a call per stage).
ThreeWheel and SkidSteer step 16 rows or more through their model's vectorised block kernel
(:func:`env_step_blocks`). Every row of the batch is independent and
uses its own parameter row ``P[i]``, so a batch of N robots gives each robot the bits of N = 1.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from wheelgym.integrators import LANES, all_finite, rk4_power

__all__ = ["env_step_body", "env_step_body_par", "env_step_row", "env_step_block",
           "env_step_blocks", "env_step_blocks_par", "PAR_MIN_ROWS", "SPEED_BOUND"]

#: Batch size from which the environments step with the threaded kernel ``k_env_step_par``
#: (below it the serial ``k_env_step``; the single env, N = 1, never starts numba's threads).
#: Chosen by measurement (benchmarks/vector.py): below ~256 rows the threads' launch
#: overhead (~10-20 us a call) eats the gain.
PAR_MIN_ROWS = 256

#: Divergence bound on every body-twist entry (m/s and rad/s): a step ending beyond it is a
#: numerical failure (state restored, ``F_OK`` False), like a non-finite one. It is 50x and
#: more above every robot's sanity limit (``RobotSpec.v_max``, ``w_max``: at most 10 m/s and
#: 20 rad/s), which ends an episode long before a real motion gets near it; RK4 outside its
#: stability region grows by orders of magnitude a substep, so it crosses the bound (or
#: overflows) on the step where it diverges.
SPEED_BOUND = 1.0e3


#: Column layout of the per-row float block ``B`` for ``m`` inputs (see :func:`layout`).
def layout(m: int, nf: int) -> dict[str, slice | int]:
    """Columns of the block ``B (N, 2 m + 11 + nf)``: ``U``, ``jv`` (m each), ``energy``,
    ``eff``, ``pose`` (3), ``twist`` (3), ``xf``, ``reward``, ``err``, ``feat`` (nf)."""
    return {"U": slice(0, m), "jv": slice(m, 2 * m), "energy": 2 * m, "eff": 2 * m + 1,
            "pose": slice(2 * m + 2, 2 * m + 5), "twist": slice(2 * m + 5, 2 * m + 8),
            "xf": 2 * m + 8, "reward": 2 * m + 9, "err": 2 * m + 10,
            "feat": slice(2 * m + 11, 2 * m + 11 + nf), "width": 2 * m + 11 + nf}


#: Columns of the per-row flag block ``F (N, 5)``.
F_SAT, F_OK, F_TERM, F_SUCC, F_COLL = range(5)


@njit(cache=True, inline="always")
def _scale_row(i, A, LH, B, F):  # pragma: no cover - compiled
    """Clip row i's actions to [-1, 1] (``F_SAT`` marks an entry at or beyond
    +-1); write ``U`` and ``eff``."""
    m = A.shape[1]
    s = False
    e = 0.0
    b = B[i]
    for j in range(m):
        a = A[i, j]
        if a >= 1.0:  # at or beyond the bound: saturated (SB3 clips to the box first)
            a = 1.0
            s = True
        elif a <= -1.0:
            a = -1.0
            s = True
        e += a * a
        b[j] = 0.5 * (LH[i, m + j] + LH[i, j]) + 0.5 * a * (LH[i, m + j] - LH[i, j])
    F[i, 0] = s
    b[2 * m + 1] = e / m if m > 0 else 0.0


@njit(cache=True, inline="always")
def _finish_row(jrate, feats, i, X, P, Xo, B, F, acc, m):  # pragma: no cover - compiled
    """After the substeps of row i (new state in ``Xo[i]``, motor work ``acc``): back to
    ``X[i]`` where not finite or where a twist entry exceeds :data:`SPEED_BOUND` (a diverged
    integration; ``F_OK`` False), else add the work; write the joint rates ``jv``, pose,
    twist, features and the internal-force measure."""
    o_e = 2 * m
    o_p = 2 * m + 2
    o_f = 2 * m + 11
    nb = B.shape[1]
    b = B[i]
    x = Xo[i]
    p = P[i]
    good = np.isfinite(acc)
    for k in range(x.shape[0]):
        if not np.isfinite(x[k]):
            good = False
    if not good:
        for k in range(x.shape[0]):
            x[k] = X[i, k]
    while True:  # twice at most: a twist beyond SPEED_BOUND is a diverged step too
        jrate(x, p, b[m:2 * m])
        b[o_p + 6] = feats(x, b[0:m], p, b[o_p:o_p + 3], b[o_p + 3:o_p + 6], b[o_f:nb])
        if good and not (abs(b[o_p + 3]) <= SPEED_BOUND and abs(b[o_p + 4]) <= SPEED_BOUND
                         and abs(b[o_p + 5]) <= SPEED_BOUND):
            good = False
            for k in range(x.shape[0]):
                x[k] = X[i, k]
        else:
            break
    if good:
        b[o_e] += acc
    F[i, 1] = good


@njit(cache=True, inline="always")
def env_step_row(f, kpower, jrate, feats, i, X, A, LH, P, h, n, Xo, B, F,
                 work):  # pragma: no cover - compiled
    """Row ``i`` of :func:`env_step_body` (``work``: ``(5, n_x)`` scratch of this row)."""
    _scale_row(i, A, LH, B, F)
    m = A.shape[1]
    x = Xo[i]
    for k in range(X.shape[1]):
        x[k] = X[i, k]
    acc = rk4_power(f, kpower, x, B[i, 0:m], P[i], h, n, work)
    _finish_row(jrate, feats, i, X, P, Xo, B, F, acc, m)


@njit(cache=True, inline="always")
def env_step_block(block, jrate, feats, b0, X, A, LH, P, h, n, Xo, B, F,
                   W):  # pragma: no cover - compiled
    """Rows ``b0 .. b0 + LANES`` of :func:`env_step_body` with the substeps in the model's
    compiled block kernel ``block(X, U, P, h, n, out, work, b0)`` (several robots per
    instruction, ``integrators.rk4_block``; the bits of :func:`env_step_row`). ``W`` is
    ``(N,)`` scratch for the motor work."""
    end = min(b0 + LANES, X.shape[0])
    for i in range(b0, end):
        _scale_row(i, A, LH, B, F)
    block(X, B, P, h, n, Xo, W, b0)  # the inputs U are B's first m columns
    for i in range(b0, end):
        _finish_row(jrate, feats, i, X, P, Xo, B, F, W[i], A.shape[1])


@njit(cache=True, inline="always")
def env_step_blocks(block, jrate, feats, X, A, LH, P, h, n, Xo, B,
                    F):  # pragma: no cover - compiled
    """:func:`env_step_body` through :func:`env_step_block`, block after block."""
    if not all_finite(A):
        return False
    W = np.empty(X.shape[0])
    for b0 in range(0, X.shape[0], LANES):
        env_step_block(block, jrate, feats, b0, X, A, LH, P, h, n, Xo, B, F, W)
    return True


@njit(cache=True, inline="always")
def env_step_blocks_par(rows, X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    """:func:`env_step_blocks` with the blocks spread over numba's threads (``prange``).

    ``rows(b0, X, A, LH, P, h, n, Xo, B, F, W)`` is the robot's compiled (not inlined) kernel
    around :func:`env_step_block` (the parfor passes would otherwise analyse the inlined
    model code, which numba's array analysis rejects for ThreeWheel's tuple helpers). Each
    block runs the same code, so every row's bits are the serial kernel's."""
    if not all_finite(A):
        return False
    W = np.empty(X.shape[0])
    for b in prange((X.shape[0] + LANES - 1) // LANES):
        rows(b * LANES, X, A, LH, P, h, n, Xo, B, F, W)
    return True


@njit(cache=True, inline="always")
def env_step_body(f, kpower, jrate, feats, X, A, LH, P, h, n, Xo, B,
                  F):  # pragma: no cover - compiled
    """Scale actions, integrate one control period, accumulate motor work, extract features.

    Arrays are few and packed because each array argument of a compiled call costs ~0.25 us.

    Args:
        f: per-state derivative ``f(x, u, p, out)`` of the model.
        kpower: ``kpower(x, k, u, p) -> float`` motor power ``u . qdot`` (W) at a stage state
            ``x`` with derivative ``k = f(x, u, p)`` (see ``integrators.rk4_power``); 0 without
            motors.
        jrate: ``jrate(x, p, out)`` joint (motor) rates in input order (rad/s), evaluated once
            at the end of the step for ``jv``. Robots without motors write zeros.
        feats: ``feats(x, u, p, pose, twist, feat) -> float`` writes the pose (x, y, yaw), the
            body twist (vx, vy, wz), the robot's extra observation features, and returns the
            internal-force measure (0 where it does not apply).
        X: states ``(N, n_x)`` (read only).
        A: normalised commands ``(N, m)``; clipped to [-1, 1] (``F[:, F_SAT]`` marks an entry at or
            beyond +-1).
        LH: physical input bounds per row ``(N, 2 m)``: low then high; ``u = mid + a * half``.
        P: packed parameters per row ``(N, n_p)``.
        h, n: substep (s) and substep count.
        Xo: new states (written; where not finite, ``X`` again and ``F[:, F_OK]`` False).
        B: float block (:func:`layout`): writes U, jv (at the end), eff (mean squared
            normalised command), pose, twist, xf, feat; adds the step's motor work to energy
            (RK4 of ``E' = u . qdot`` on the same stages).
        F: flag block; writes ``F_SAT`` and ``F_OK``.

    Returns:
        False when an action entry is not finite (nothing is written then).
    """
    if not all_finite(A):
        return False
    work = np.empty((5, X.shape[1]))
    for i in range(X.shape[0]):
        env_step_row(f, kpower, jrate, feats, i, X, A, LH, P, h, n, Xo, B, F, work)
    return True


@njit(cache=True, inline="always")
def env_step_body_par(row, X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    """:func:`env_step_body` with the rows spread over numba's threads (``prange``), for
    large batches; bound into a ``parallel=True`` kernel ``k_env_step_par``.

    ``row(i, X, A, LH, P, h, n, Xo, B, F, work)`` is the robot's compiled (not inlined) kernel
    around :func:`env_step_row`: the parfor passes would otherwise analyse the inlined model
    code, which numba's array analysis rejects for some models (ThreeWheel's tuple helpers).
    Each row runs the same row code on its own scratch, so every row's bits equal the serial
    kernel's. The finiteness check of the actions stays a serial pass first (nothing is
    written when it fails).
    """
    if not all_finite(A):
        return False
    for i in prange(X.shape[0]):
        work = np.empty((5, X.shape[1]))
        # int64: numba types the loop index int64 when it first types this function and
        # uint64 in the threaded loop body, and would compile ``row`` once for each
        row(np.int64(i), X, A, LH, P, h, n, Xo, B, F, work)
    return True


@njit(cache=True)
def k_twist_command(a, scale, cmd, clipped):  # pragma: no cover - compiled
    """Velocity mode: ``cmd = clip(a, -1, 1) * scale`` per row, ``clipped`` marks an entry at or
    beyond +-1.

    Returns False (writing nothing) when an entry of ``a`` is not finite.
    """
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not np.isfinite(a[i, j]):
                return False
    for i in range(a.shape[0]):
        c = False
        for j in range(a.shape[1]):
            v = a[i, j]
            if v >= 1.0:  # at or beyond the bound: saturated (SB3 clips to the box first)
                v = 1.0
                c = True
            elif v <= -1.0:
                v = -1.0
                c = True
            cmd[i, j] = v * scale[j]
        clipped[i] = c
    return True


@njit(cache=True)
def k_torque_ratio(tau, LH, A):  # pragma: no cover - compiled
    """``A = tau / high`` per row: the controller's torques as normalised commands."""
    m = tau.shape[1]
    for i in range(tau.shape[0]):
        for j in range(m):
            A[i, j] = tau[i, j] / LH[i, m + j]


@njit(cache=True)
def k_or_flags(F, csat, clipped):  # pragma: no cover - compiled
    """``F[:, 0] |= csat | clipped`` (saturation flag of the velocity mode)."""
    for i in range(F.shape[0]):
        F[i, 0] = F[i, 0] or csat[i] or clipped[i]
