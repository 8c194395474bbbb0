"""Action latency and actuator bandwidth: the compiled per-row kernels of ``action_delay`` and
``actuator_lag`` (:class:`~wheelgym.envs.core.WheelCore` holds their state).

Delay: each row keeps a ring buffer ``buf (N, K + 1, action_dim)`` of its last normalised
actions (``K``: the largest delay of the batch) with one write position ``head`` shared by the
rows (they step together); row i reads the action pushed ``delays[i]`` steps ago. A reset
zeroes the row's buffer, so its first ``delays[i]`` steps read the zero action.

Lag: a first-order filter on the normalised inputs (the motor torques of the dynamic robots,
the inputs of the kinematic ones; both linear in the normalised value), discrete at the
control step: ``u += alpha (clip(u_cmd) - u)`` with ``alpha = 1 - exp(-ctrl_dt / T)``, held
over the step's substeps.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["MAX_ACTION_DELAY", "k_delay", "k_lag"]

#: Largest ``action_delay`` (control steps; 2.5 s at the default 0.05 s).
MAX_ACTION_DELAY = 50


@njit(cache=True)
def k_delay(a, buf, head, delays, out):  # pragma: no cover - compiled
    """Push ``a (N, d)`` into the rows' ring buffers and write into ``out`` each row's action
    of ``delays[i]`` steps ago. Returns False (writing nothing) when an entry is not finite."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not np.isfinite(a[i, j]):
                return False
    L = buf.shape[1]
    h = head[0] + 1
    if h >= L:
        h = 0
    head[0] = h
    for i in range(a.shape[0]):
        r = h - delays[i]
        if r < 0:
            r += L
        for j in range(a.shape[1]):
            buf[i, h, j] = a[i, j]
        for j in range(a.shape[1]):
            out[i, j] = buf[i, r, j]
    return True


@njit(cache=True)
def k_lag(A, U, alpha, sat):  # pragma: no cover - compiled
    """``U += alpha (clip(A, -1, 1) - U)`` per entry; ``sat[i]`` marks an entry of row i's
    command at or beyond +-1. Returns False (writing nothing) when an entry of ``A`` is not
    finite."""
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            if not np.isfinite(A[i, j]):
                return False
    for i in range(A.shape[0]):
        s = False
        for j in range(A.shape[1]):
            v = A[i, j]
            if v >= 1.0:  # at or beyond the bound: saturated (SB3 clips to the box first)
                v = 1.0
                s = True
            elif v <= -1.0:
                v = -1.0
                s = True
            U[i, j] += alpha * (v - U[i, j])
        sat[i] = s
    return True
