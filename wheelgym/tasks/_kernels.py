"""Compiled per-step task kernels: observation assembly, reward terms, termination.

Pure functions of the batch: row i reads only row i, so a batch of N gives each row the bits of
N = 1. Term columns (the tasks name a subset; unused columns have weight 0):

* goal/navigate: 0 progress, 1 heading, 2 effort, 3 internal_force, 4 success, 5 overspeed,
  6 collision;
* track: 0 position, 1 heading, 2 effort, 3 internal_force, 4 overspeed, 5 lost.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def _clip(a, lim):  # pragma: no cover - compiled
    return min(max(a, -lim), lim)

@njit(cache=True, inline="always")
def _wrap(a):  # pragma: no cover - compiled
    return math.atan2(math.sin(a), math.cos(a))

@njit(cache=True, inline="always")
def _common_tail(i, j, twist, feat, fclip, vclip, wclip, obs):  # pragma: no cover - compiled
    obs[i, j] = _clip(twist[i, 0], vclip)
    obs[i, j + 1] = _clip(twist[i, 1], vclip)
    obs[i, j + 2] = _clip(twist[i, 2], wclip)
    j += 3
    for k in range(feat.shape[1]):
        obs[i, j] = _clip(feat[i, k], fclip[k])
        j += 1
    return j

@njit(cache=True, inline="always")
def _overspeed(ok, twist, i, vmax, wmax):  # pragma: no cover - compiled
    return (not ok[i]) or math.hypot(twist[i, 0], twist[i, 1]) > vmax or abs(twist[i, 2]) > wmax

@njit(cache=True)
def k_goal(pose, twist, feat, eff, xf, ok, goal, prev_dist, ranges, coll, tol_p, tol_y, vmax,
           wmax, pclip, vclip, wclip, fclip, W, obs, terms, reward, term, succ,
           dist):  # pragma: no cover - compiled
    """Goal and navigate tasks: observation, the 7 term columns, termination, success."""
    N = pose.shape[0]
    for i in range(N):
        dx = goal[i, 0] - pose[i, 0]
        dy = goal[i, 1] - pose[i, 1]
        c = math.cos(pose[i, 2])
        s = math.sin(pose[i, 2])
        d = math.hypot(dx, dy)
        ey = _wrap(goal[i, 2] - pose[i, 2])
        obs[i, 0] = _clip(c * dx + s * dy, pclip)  # goal in B
        obs[i, 1] = _clip(-s * dx + c * dy, pclip)
        obs[i, 2] = math.cos(ey)
        obs[i, 3] = math.sin(ey)
        j = _common_tail(i, 4, twist, feat, fclip, vclip, wclip, obs)
        for k in range(ranges.shape[1]):
            obs[i, j + k] = ranges[i, k]
        over = _overspeed(ok, twist, i, vmax, wmax)
        hit = coll[i]
        win = ok[i] and (not hit) and d < tol_p and abs(ey) < tol_y
        terms[i, 0] = W[0] * (prev_dist[i] - d)
        terms[i, 1] = -W[1] * abs(ey) / math.pi
        terms[i, 2] = -W[2] * eff[i]
        terms[i, 3] = -W[3] * xf[i]
        terms[i, 4] = W[4] if win else 0.0
        terms[i, 5] = -W[5] if over else 0.0
        terms[i, 6] = -W[6] if hit else 0.0
        r = 0.0
        for k in range(terms.shape[1]):
            r += terms[i, k]
        reward[i] = r
        term[i] = win or over or hit
        succ[i] = win
        dist[i] = d

@njit(cache=True)
def k_track(pose, twist, feat, eff, xf, ok, ref, kstep, preview, vmax, wmax, lost, tol_p, pclip,
            vclip, wclip, fclip, W, obs, terms, reward, term, succ,
            err):  # pragma: no cover - compiled
    """Track task. ``ref (N, L, 6)`` holds pose and body twist of the reference per control step;
    row i compares with ``ref[i, kstep[i]]`` and previews ``ref[i, kstep[i] + preview[q]]``."""
    N = pose.shape[0]
    L = ref.shape[1]
    for i in range(N):
        k = min(kstep[i], L - 1)
        c = math.cos(pose[i, 2])
        s = math.sin(pose[i, 2])
        dx = ref[i, k, 0] - pose[i, 0]
        dy = ref[i, k, 1] - pose[i, 1]
        e = math.hypot(dx, dy)
        ey = _wrap(ref[i, k, 2] - pose[i, 2])
        obs[i, 0] = _clip(c * dx + s * dy, pclip)  # reference in B
        obs[i, 1] = _clip(-s * dx + c * dy, pclip)
        obs[i, 2] = math.cos(ey)
        obs[i, 3] = math.sin(ey)
        obs[i, 4] = _clip(ref[i, k, 3], vclip)  # reference twist in its own frame
        obs[i, 5] = _clip(ref[i, k, 4], vclip)
        obs[i, 6] = _clip(ref[i, k, 5], wclip)
        j = 7
        for q in range(preview.shape[0]):
            kq = min(k + preview[q], L - 1)
            qx = ref[i, kq, 0] - pose[i, 0]
            qy = ref[i, kq, 1] - pose[i, 1]
            obs[i, j] = _clip(c * qx + s * qy, pclip)
            obs[i, j + 1] = _clip(-s * qx + c * qy, pclip)
            j += 2
        _common_tail(i, j, twist, feat, fclip, vclip, wclip, obs)
        over = _overspeed(ok, twist, i, vmax, wmax)
        gone = e > lost
        terms[i, 0] = -W[0] * e
        terms[i, 1] = -W[1] * abs(ey) / math.pi
        terms[i, 2] = -W[2] * eff[i]
        terms[i, 3] = -W[3] * xf[i]
        terms[i, 4] = -W[4] if over else 0.0
        terms[i, 5] = -W[5] if gone else 0.0
        r = 0.0
        for q in range(terms.shape[1]):
            r += terms[i, q]
        reward[i] = r
        term[i] = over or gone
        succ[i] = ok[i] and e < tol_p
        err[i] = e

@njit(cache=True)
def k_noise(obs, noise, low, high):  # pragma: no cover - compiled
    """``obs += noise`` clipped to the bounds, in place."""
    for i in range(obs.shape[0]):
        for j in range(obs.shape[1]):
            v = obs[i, j] + noise[i, j]
            obs[i, j] = min(max(v, low[j]), high[j])

