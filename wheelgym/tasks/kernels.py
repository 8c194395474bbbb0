"""Compiled per-step task kernels: observation assembly, reward terms, termination.

Pure functions of the batch: row i reads only row i, so a batch of N gives each row the bits of
N = 1. Term columns (the tasks name a subset; unused columns have weight 0):

* goal/navigate: 0 progress, 1 heading, 2 effort, 3 internal_force, 4 success, 5 overspeed,
  6 collision, 7 proximity, 8 saturation;
* track: 0 position, 1 heading, 2 effort, 3 internal_force, 4 overspeed, 5 lost, 6 saturation.
"""

from __future__ import annotations

import math

from numba import njit, prange

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.models import friction as _friction
from wheelgym.models.friction import sincos

# the kernels inline friction.sincos (and its integrators.fma)
_numba_cache.guard(__file__, _friction.__file__, _integrators.__file__)


@njit(cache=True, inline="always")
def _clip(a, lim):  # pragma: no cover - compiled
    return min(max(a, -lim), lim)

@njit(cache=True, inline="always")
def _target_obs(b, o, tx, ty, tyaw, pclip, ob):  # pragma: no cover - compiled
    """The target pose ``(tx, ty, tyaw)`` seen from the robot (pose at ``b[o + 2 ..]``) into
    ``ob[0:4]``: position in the body frame (clipped to ``pclip``), cos and sin of the yaw
    error (from one sincos of the error; the wrapped error by one atan2). Returns the
    distance, the wrapped yaw error, and sin, cos of the robot's yaw."""
    s, c = sincos(b[o + 4])
    dx = tx - b[o + 2]
    dy = ty - b[o + 3]
    sy, cy = sincos(tyaw - b[o + 4])
    ob[0] = _clip(c * dx + s * dy, pclip)
    ob[1] = _clip(-s * dx + c * dy, pclip)
    ob[2] = cy
    ob[3] = sy
    return _norm2(dx, dy), math.atan2(sy, cy), s, c


@njit(cache=True, inline="always")
def _norm2(x, y):  # pragma: no cover - compiled
    """``sqrt(x^2 + y^2)`` (poses and twists are far from overflow: no hypot needed)."""
    return math.sqrt(x * x + y * y)

# Block layouts (wheelgym.envs.robots.body.layout): pose at 2m+2, twist at 2m+5, eff 2m+1,
# xf 2m+8, reward 2m+9, err 2m+10, feat from 2m+11; flags F: 0 sat, 1 ok, 2 term, 3 succ,
# 4 collision. cfg (goal): tol_p, tol_y, vmax, wmax, pclip, vclip, wclip, radius, d_safe;
# cfg (track): vmax, wmax, lost, tol_p, pclip, vclip, wclip.


@njit(cache=True, inline="always")
def _common_tail(b, o, j, nf, fclip, vclip, wclip, obs_i):  # pragma: no cover - compiled
    obs_i[j] = _clip(b[o + 5], vclip)
    obs_i[j + 1] = _clip(b[o + 6], vclip)
    obs_i[j + 2] = _clip(b[o + 7], wclip)
    j += 3
    for k in range(nf):
        obs_i[j] = _clip(b[o + 11 + k], fclip[k])
        j += 1
    return j


@njit(cache=True, inline="always")
def _overspeed(ok, b, o, vmax, wmax):  # pragma: no cover - compiled
    return (not ok) or _norm2(b[o + 5], b[o + 6]) > vmax or abs(b[o + 7]) > wmax


@njit(cache=True, inline="always")
def _goal_row(i, B, F, m, goal, prev_dist, ranges, clear, cfg, fclip, W, obs,
              terms):  # pragma: no cover - compiled
    """Row i of :func:`k_goal`."""
    o = 2 * m  # energy column; pose at o + 2
    nf = B.shape[1] - (2 * m + 11)
    tol_p, tol_y, vmax, wmax, pclip, vclip, wclip = (cfg[0], cfg[1], cfg[2], cfg[3], cfg[4],
                                                      cfg[5], cfg[6])
    b = B[i]
    ob = obs[i]
    d, ey, _, _ = _target_obs(b, o, goal[i, 0], goal[i, 1], goal[i, 2], pclip, ob)
    j = _common_tail(b, o, 4, nf, fclip, vclip, wclip, ob)
    for k in range(ranges.shape[1]):
        ob[j + k] = ranges[i, k]
    ok = F[i, 1]
    over = _overspeed(ok, b, o, vmax, wmax)
    hit = F[i, 4]
    win = ok and (not hit) and d < tol_p and abs(ey) < tol_y
    t = terms[i]
    t[0] = W[0] * (prev_dist[i] - d)
    t[1] = -W[1] * abs(ey) / math.pi
    t[2] = -W[2] * b[o + 1]
    t[3] = -W[3] * b[o + 8]
    t[4] = W[4] if win else 0.0
    t[5] = -W[5] if over else 0.0
    t[6] = -W[6] if hit else 0.0
    if W[7] != 0.0:  # proximity: the footprint's gap to the nearest obstacle below d_safe
        t[7] = -W[7] * min(max(1.0 - (clear[i] - cfg[7]) / cfg[8], 0.0), 1.0)
    else:
        t[7] = 0.0
    t[8] = -W[8] if F[i, 0] else 0.0  # an action or a controller torque was clipped
    r = 0.0
    for k in range(t.shape[0]):
        r += t[k]
    b[o + 9] = r
    F[i, 2] = win or over or hit
    F[i, 3] = win
    b[o + 10] = d
    prev_dist[i] = d  # the next step's progress is measured from here


@njit(cache=True)
def k_goal(rows, B, F, m, goal, prev_dist, ranges, clear, cfg, fclip, W, obs,
           terms):  # pragma: no cover - compiled
    """Goal and navigate tasks: observation, the 9 term columns, reward, end, success, dist,
    for the rows listed in ``rows`` (the others are not touched).

    Also moves ``prev_dist`` on to the new distance (a row evaluated twice at the same pose
    gets the same bits again)."""
    for r in range(rows.shape[0]):
        _goal_row(rows[r], B, F, m, goal, prev_dist, ranges, clear, cfg, fclip, W, obs, terms)


@njit(cache=True, parallel=True)
def k_goal_par(rows, B, F, m, goal, prev_dist, ranges, clear, cfg, fclip, W, obs,
               terms):  # pragma: no cover - compiled
    """:func:`k_goal` with the rows spread over numba's threads (large batches; same bits)."""
    for r in prange(rows.shape[0]):
        _goal_row(rows[r], B, F, m, goal, prev_dist, ranges, clear, cfg, fclip, W, obs, terms)


@njit(cache=True)
def k_track(rows, B, F, m, ref, kstep, kbase, L, preview, cfg, fclip, W, obs,
            terms):  # pragma: no cover - compiled
    """Track task, for the rows listed in ``rows``. ``ref (N, n_window, 6)`` holds pose and body
    twist of row i's reference at control steps ``kbase[i] + j``; row i compares with step
    ``min(kstep[i], L - 1)`` and previews ``min(kstep[i] + preview[q], L - 1)`` (the reference
    holds its last point from step ``L - 1`` on)."""
    o = 2 * m
    nf = B.shape[1] - (2 * m + 11)
    vmax, wmax, lost, tol_p, pclip, vclip, wclip = (cfg[0], cfg[1], cfg[2], cfg[3], cfg[4],
                                                     cfg[5], cfg[6])
    for r in range(rows.shape[0]):
        i = rows[r]
        b = B[i]
        ob = obs[i]
        k = min(kstep[i], L - 1) - kbase[i]
        px = b[o + 2]
        py = b[o + 3]
        e, ey, s, c = _target_obs(b, o, ref[i, k, 0], ref[i, k, 1], ref[i, k, 2], pclip, ob)
        ob[4] = _clip(ref[i, k, 3], vclip)  # reference twist in its own frame
        ob[5] = _clip(ref[i, k, 4], vclip)
        ob[6] = _clip(ref[i, k, 5], wclip)
        j = 7
        for q in range(preview.shape[0]):
            kq = min(kstep[i] + preview[q], L - 1) - kbase[i]
            qx = ref[i, kq, 0] - px
            qy = ref[i, kq, 1] - py
            ob[j] = _clip(c * qx + s * qy, pclip)
            ob[j + 1] = _clip(-s * qx + c * qy, pclip)
            j += 2
        _common_tail(b, o, j, nf, fclip, vclip, wclip, ob)
        ok = F[i, 1]
        over = _overspeed(ok, b, o, vmax, wmax)
        gone = e > lost
        t = terms[i]
        t[0] = -W[0] * e
        t[1] = -W[1] * abs(ey) / math.pi
        t[2] = -W[2] * b[o + 1]
        t[3] = -W[3] * b[o + 8]
        t[4] = -W[4] if over else 0.0
        t[5] = -W[5] if gone else 0.0
        t[6] = -W[6] if F[i, 0] else 0.0  # an action or a controller torque was clipped
        r = 0.0
        for q in range(t.shape[0]):
            r += t[q]
        b[o + 9] = r
        F[i, 2] = over or gone
        F[i, 3] = ok and e < tol_p
        b[o + 10] = e


@njit(cache=True)
def k_goal_reset(rows, U, d_lo, d_hi, two_pi, goal, prev, poses):  # pragma: no cover
    """Goal task: start poses ``poses[r]`` and goals of ``rows[r]`` from the row's six uniforms
    ``U[r]`` (start x, y in [-1, 1], start yaw, goal distance in [d_lo, d_hi], goal direction,
    goal yaw; angles ``-pi + two_pi u``), with ``Generator.uniform``'s ``lo + (hi - lo) u``.
    ``prev`` gets the start-to-goal distance. libm's cos/sin, as Python's ``math``."""
    for r in range(rows.shape[0]):
        i = rows[r]
        x = -1.0 + 2.0 * U[r, 0]
        y = -1.0 + 2.0 * U[r, 1]
        d = d_lo + (d_hi - d_lo) * U[r, 3]
        a = -math.pi + two_pi * U[r, 4]
        poses[r, 0] = x
        poses[r, 1] = y
        poses[r, 2] = -math.pi + two_pi * U[r, 2]
        goal[i, 0] = x + d * math.cos(a)
        goal[i, 1] = y + d * math.sin(a)
        goal[i, 2] = -math.pi + two_pi * U[r, 5]
        prev[i] = d


@njit(cache=True)
def k_add1(a):  # pragma: no cover - compiled
    """``a += 1`` for an int array: 0.24 us a call where NumPy's in-place add takes 1.4 us
    (the single track env advances its step counter every step)."""
    for i in range(a.shape[0]):
        a[i] += 1


@njit(cache=True)
def k_noise(rows, obs, noise, low, high):  # pragma: no cover - compiled
    """``obs[rows[r]] += noise[r]`` clipped to the bounds, in place."""
    for r in range(rows.shape[0]):
        i = rows[r]
        for j in range(obs.shape[1]):
            v = obs[i, j] + noise[r, j]
            obs[i, j] = min(max(v, low[j]), high[j])
