"""Compiled bookkeeping of the native vector environments (wheelgym.vector.env).

The vector layer around the physics was some thirty NumPy calls a step (time limits,
autoreset masks, info copies), each a few microseconds when it runs right after the physics
kernel (cold caches: an info build measured 29 us alone and ~100 us in a running env). These
kernels do the same work in three calls a step. Row i reads and writes only row i.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def k_zero_rows(a, rows, out):  # pragma: no cover - compiled
    """``out = a`` with the rows where ``rows`` is True set to 0 (actions of the sub-envs that
    reset instead of stepping: ignored, so they may be anything)."""
    for i in range(a.shape[0]):
        if rows[i]:
            for j in range(a.shape[1]):
                out[i, j] = 0.0
        else:
            for j in range(a.shape[1]):
                out[i, j] = a[i, j]


@njit(cache=True)
def k_step_ends(reward, term, elapsed, max_steps, rr, any_rr, R, TT, done,
                idx):  # pragma: no cover - compiled
    """After the core's step: ``elapsed += 1``; rewards ``R``, terminations ``TT[0]`` and
    truncations ``TT[1]`` (``elapsed >= max_steps``; ``max_steps < 1``: no limit); the
    autoreset rows ``rr`` (when ``any_rr``) get 0, False, False. ``done = term | trunc``.

    Writes the rows to reset into ``idx``: the autoreset rows when ``any_rr`` (next-step
    autoreset), else the done rows (same-step autoreset). Returns how many."""
    n = 0
    for i in range(reward.shape[0]):
        e = elapsed[i] + 1
        elapsed[i] = e
        r = reward[i]
        t = term[i]
        tr = max_steps >= 1 and e >= max_steps
        if any_rr and rr[i]:
            r = 0.0
            t = False
            tr = False
            idx[n] = i
            n += 1
        R[i] = r
        TT[0, i] = t
        TT[1, i] = tr
        d = t or tr
        done[i] = d
        if d and not any_rr:
            idx[n] = i
            n += 1
    return n


@njit(cache=True)
def k_info_copy(B, F, terms, tidx, rows, f_sat, f_succ, f_ok, Bo, Fo, To):  # pragma: no cover
    """One copy of what the info of a step reports: ``Bo = B``; ``Fo`` rows saturated,
    success and numerical failure (``not F[:, f_ok]``); ``To[j] = terms[:, tidx[j]]``, 0 in the
    ``rows`` (indices) that were just reset."""
    for i in range(B.shape[0]):
        for j in range(B.shape[1]):
            Bo[i, j] = B[i, j]
        Fo[0, i] = F[i, f_sat]
        Fo[1, i] = F[i, f_succ]
        Fo[2, i] = not F[i, f_ok]
        for j in range(tidx.shape[0]):
            To[j, i] = terms[i, tidx[j]]
    for i in rows:
        for j in range(tidx.shape[0]):
            To[j, i] = 0.0
