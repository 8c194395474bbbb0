"""Compiled path searches on an :class:`~wheelgym.planning.grid.OccupancyGrid`'s gaps.

* :func:`astar`: A* on the 8-connected grid of cells whose gap is at least a margin (no corner
  cutting: a diagonal move needs both cells it passes between free). A move between
  neighbouring cells ``a`` and ``b`` costs its length (``res`` or ``sqrt(2) res``) times
  ``(w_a + w_b) / 2``, with the cell weight ``w = 1 + soft max(0, pref - gap) / pref >= 1``
  (paths keep ``pref`` of gap where they can). The octile distance is the heuristic: it never
  exceeds the true cost (the weights are at least 1) and is consistent, so the first time the
  goal is popped its cost is the least (tests/planning check it against exhaustive searches).
* :func:`cost_to_go`: Dijkstra from one cell over the same moves (the car planner's heuristic).
* :func:`shortcut`: line-of-sight smoothing of a cell path: from each kept point, the farthest
  later point whose straight segment keeps at least the smaller of ``pref`` and the least gap of
  the cells it replaces (and never below the margin).
* :func:`hybrid_astar`: a kinematically feasible plan for a car (Bicycle, Ackermann): hybrid
  A* (Dolgov et al. 2008, "Practical search techniques in path planning for autonomous
  driving") over the Reeds-Shepp primitives: arcs of radius ``R`` turning left or right and
  straights, each ``ds`` long, driven forwards or backwards
  (:mod:`wheelgym.kinematics.reeds_shepp`'s ``L``, ``S``, ``R``). States are pruned on cells
  of ``cell`` m and ``n_th`` heading bins; a motion costs its length (backwards times
  ``rev_cost``) plus ``switch_cost`` at each cusp and the soft gap cost; the heuristic is
  :func:`cost_to_go` of the centre cell. Every sample of a motion (at most ``res`` apart)
  keeps the margin. The search ends at the first motion that passes within ``tol`` of the
  goal position (navigate's goals have no heading).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["astar", "cost_to_go", "shortcut", "segment_gap", "hybrid_astar", "cell_weights",
           "KINDS"]

#: Primitive kinds of :func:`hybrid_astar`'s plans (index: the kernel's kind code).
KINDS = ("L", "S", "R")
_SQ2 = math.sqrt(2.0)


# ------------------------------------------------------------------------------ binary heap
@njit(cache=True, inline="always")
def _push(hk, hv, n, key, val):  # pragma: no cover - compiled
    i = n
    hk[i] = key
    hv[i] = val
    while i > 0:
        p = (i - 1) >> 1
        if hk[p] <= hk[i]:
            break
        hk[p], hk[i] = hk[i], hk[p]
        hv[p], hv[i] = hv[i], hv[p]
        i = p
    return n + 1


@njit(cache=True, inline="always")
def _pop(hk, hv, n):  # pragma: no cover - compiled
    """Remove the least key; returns its value and the new size."""
    val = hv[0]
    n -= 1
    hk[0] = hk[n]
    hv[0] = hv[n]
    i = 0
    while True:
        a = 2 * i + 1
        if a >= n:
            break
        b = a + 1
        c = b if b < n and hk[b] < hk[a] else a
        if hk[i] <= hk[c]:
            break
        hk[c], hk[i] = hk[i], hk[c]
        hv[c], hv[i] = hv[i], hv[c]
        i = c
    return val, n


# ------------------------------------------------------------------------------ grid searches
@njit(cache=True)
def _k_astar(free, w, si, sj, gi, gj, res, path):  # pragma: no cover - compiled
    """A* from cell (si, sj) to (gi, gj); writes the flat cell indices goal-last into ``path``
    and returns ``(n, cost)`` (n = 0: no path)."""
    H, W = free.shape
    N = H * W
    g = np.full(N, np.inf)
    parent = np.full(N, -1, dtype=np.int64)
    closed = np.zeros(N, dtype=np.bool_)
    cap = 8 * N + 8
    hk = np.empty(cap)
    hv = np.empty(cap, dtype=np.int64)
    s = si * W + sj
    t = gi * W + gj
    g[s] = 0.0
    n = _push(hk, hv, 0, 0.0, s)
    found = False
    while n > 0:
        u, n = _pop(hk, hv, n)
        if closed[u]:
            continue
        closed[u] = True
        if u == t:
            found = True
            break
        ui = u // W
        uj = u - ui * W
        for di in range(-1, 2):
            for dj in range(-1, 2):
                if di == 0 and dj == 0:
                    continue
                vi = ui + di
                vj = uj + dj
                if vi < 0 or vi >= H or vj < 0 or vj >= W or not free[vi, vj]:
                    continue
                if di != 0 and dj != 0 and not (free[ui, vj] and free[vi, uj]):
                    continue
                v = vi * W + vj
                if closed[v]:
                    continue
                step = res * (_SQ2 if di != 0 and dj != 0 else 1.0)
                c = g[u] + step * 0.5 * (w[ui, uj] + w[vi, vj])
                if c < g[v]:
                    g[v] = c
                    parent[v] = u
                    ai = abs(vi - gi)
                    aj = abs(vj - gj)
                    h = res * (max(ai, aj) + (_SQ2 - 1.0) * min(ai, aj))
                    n = _push(hk, hv, n, c + h, v)
    if not found:
        return 0, np.inf
    k = 0
    u = t
    while u != -1:
        path[k] = u
        k += 1
        u = parent[u]
    path[:k] = path[:k][::-1].copy()
    return k, g[t]


@njit(cache=True)
def _k_dijkstra(free, w, si, sj, res, dist):  # pragma: no cover - compiled
    H, W = free.shape
    N = H * W
    dist[:] = np.inf
    closed = np.zeros(N, dtype=np.bool_)
    hk = np.empty(8 * N + 8)
    hv = np.empty(8 * N + 8, dtype=np.int64)
    s = si * W + sj
    dist[s] = 0.0
    n = _push(hk, hv, 0, 0.0, s)
    while n > 0:
        u, n = _pop(hk, hv, n)
        if closed[u]:
            continue
        closed[u] = True
        ui = u // W
        uj = u - ui * W
        for di in range(-1, 2):
            for dj in range(-1, 2):
                if di == 0 and dj == 0:
                    continue
                vi = ui + di
                vj = uj + dj
                if vi < 0 or vi >= H or vj < 0 or vj >= W or not free[vi, vj]:
                    continue
                if di != 0 and dj != 0 and not (free[ui, vj] and free[vi, uj]):
                    continue
                v = vi * W + vj
                step = res * (_SQ2 if di != 0 and dj != 0 else 1.0)
                c = dist[u] + step * 0.5 * (w[ui, uj] + w[vi, vj])
                if c < dist[v]:
                    dist[v] = c
                    n = _push(hk, hv, n, c, v)


def cell_weights(gap: np.ndarray, pref: float, soft: float) -> np.ndarray:
    """The cells' move-cost weights ``1 + soft max(0, pref - gap) / pref`` (module docstring)."""
    if pref <= 0 or soft == 0:
        return np.ones_like(gap)
    return 1.0 + soft * np.clip(pref - gap, 0.0, None) / pref


def astar(free: np.ndarray, start: tuple[int, int], goal: tuple[int, int], res: float = 1.0,
          weights: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Least-cost 8-connected path from cell ``start`` to ``goal`` (row, column).

    Args:
        free: (H, W) bool, True where the robot may centre.
        start, goal: cells; both must be free.
        res: cell side (m): the move lengths.
        weights: (H, W) cell weights >= 1 (default 1: the shortest path).

    Returns:
        ``(cells (n, 2) int, cost)``; an empty array and ``inf`` when the goal is unreachable.
    """
    free = np.ascontiguousarray(np.asarray(free, dtype=np.bool_))
    H, W = free.shape
    w = np.ones((H, W)) if weights is None else np.ascontiguousarray(weights, dtype=np.float64)
    if w.shape != free.shape or np.any(w < 1.0):
        raise ValueError(f"weights must have the grid's shape {free.shape} and be >= 1")
    for name, (i, j) in (("start", start), ("goal", goal)):
        if not (0 <= i < H and 0 <= j < W) or not free[i, j]:
            raise ValueError(f"{name} cell {(i, j)} must be a free cell of the {H} x {W} grid")
    buf = np.empty(H * W, dtype=np.int64)
    n, cost = _k_astar(free, w, int(start[0]), int(start[1]), int(goal[0]), int(goal[1]),
                       float(res), buf)
    cells = np.stack([buf[:n] // W, buf[:n] % W], axis=1)
    return cells, float(cost)


def cost_to_go(free: np.ndarray, goal: tuple[int, int], res: float = 1.0,
               weights: np.ndarray | None = None) -> np.ndarray:
    """(H, W) least cost (m, weighted) from every cell to ``goal`` (inf: unreachable)."""
    free = np.ascontiguousarray(np.asarray(free, dtype=np.bool_))
    w = np.ones(free.shape) if weights is None else np.ascontiguousarray(weights,
                                                                          dtype=np.float64)
    dist = np.empty(free.size)
    _k_dijkstra(free, w, int(goal[0]), int(goal[1]), float(res), dist)
    return dist.reshape(free.shape)


@njit(cache=True, inline="always")
def _gap_at(gap, res, ox, oy, x, y):  # pragma: no cover - compiled
    H, W = gap.shape
    j = int(math.floor((x - ox) / res))
    i = int(math.floor((y - oy) / res))
    if i < 0 or i >= H or j < 0 or j >= W:
        return -np.inf
    return gap[i, j]


@njit(cache=True)
def _k_min_gap(gap, res, ox, oy, x0, y0, x1, y1):  # pragma: no cover - compiled
    L = math.hypot(x1 - x0, y1 - y0)
    n = max(1, int(math.ceil(L / (0.5 * res))))
    best = np.inf
    for k in range(n + 1):
        u = k / n
        v = _gap_at(gap, res, ox, oy, x0 + u * (x1 - x0), y0 + u * (y1 - y0))
        if v < best:
            best = v
    return best


@njit(cache=True)
def _k_shortcut(xy, gap, res, ox, oy, margin, pref, keep):  # pragma: no cover - compiled
    n = xy.shape[0]
    pg = np.empty(n)
    for k in range(n):
        pg[k] = _gap_at(gap, res, ox, oy, xy[k, 0], xy[k, 1])
    m = 0
    keep[m] = 0
    m += 1
    i = 0
    while i < n - 1:
        best = i + 1
        lo = pg[i]
        for j in range(i + 1, n):
            if pg[j] < lo:
                lo = pg[j]
            need = max(min(pref, lo), margin)
            if _k_min_gap(gap, res, ox, oy, xy[i, 0], xy[i, 1], xy[j, 0], xy[j, 1]) >= need:
                best = j
        keep[m] = best
        m += 1
        i = best
    return m


def segment_gap(gap: np.ndarray, res: float, origin: np.ndarray, a: np.ndarray,
                b: np.ndarray) -> float:
    """Least gap (m) of the cells along the straight segment from ``a`` to ``b`` (sampled every
    half cell; ``-inf`` off the grid)."""
    return float(_k_min_gap(gap, float(res), float(origin[0]), float(origin[1]), float(a[0]),
                            float(a[1]), float(b[0]), float(b[1])))


def shortcut(xy: np.ndarray, gap: np.ndarray, res: float, origin: np.ndarray, margin: float,
             pref: float) -> np.ndarray:
    """The points of ``xy (n, 2)`` kept by line-of-sight smoothing (module docstring)."""
    xy = np.ascontiguousarray(xy, dtype=np.float64)
    if len(xy) < 3:
        return xy.copy()
    keep = np.empty(len(xy), dtype=np.int64)
    m = _k_shortcut(xy, np.ascontiguousarray(gap), float(res), float(origin[0]),
                    float(origin[1]), float(margin), float(pref), keep)
    return xy[keep[:m]]


# ------------------------------------------------------------------------------ hybrid A*
@njit(cache=True, inline="always")
def _move(x, y, th, kappa, s):  # pragma: no cover - compiled
    """Pose after ``s`` signed metres at curvature ``kappa`` (exact arc or line)."""
    if kappa == 0.0:
        return x + s * math.cos(th), y + s * math.sin(th), th
    t2 = th + kappa * s
    return (x + (math.sin(t2) - math.sin(th)) / kappa,
            y - (math.cos(t2) - math.cos(th)) / kappa, t2)


@njit(cache=True)
def _k_hybrid(gap, res, ox, oy, hgrid, sx, sy, sth, gx, gy, tol, R, ds, n_th, cell, margin,
              pref, soft, rev_cost, switch_cost, max_nodes, out_kind, out_len
              ):  # pragma: no cover - compiled
    H, W = gap.shape
    nx = int(math.ceil(W * res / cell)) + 1
    ny = int(math.ceil(H * res / cell)) + 1
    closed = np.zeros((ny, nx, n_th), dtype=np.bool_)
    bestg = np.full((ny, nx, n_th), np.inf)
    X = np.empty(max_nodes)
    Y = np.empty(max_nodes)
    T = np.empty(max_nodes)
    G = np.empty(max_nodes)
    PAR = np.empty(max_nodes, dtype=np.int64)
    KIND = np.empty(max_nodes, dtype=np.int64)
    LEN = np.empty(max_nodes)
    hk = np.empty(6 * max_nodes + 6)
    hv = np.empty(6 * max_nodes + 6, dtype=np.int64)
    nsamp = max(2, int(math.ceil(ds / res)))
    X[0] = sx
    Y[0] = sy
    T[0] = sth
    G[0] = 0.0
    PAR[0] = -1
    KIND[0] = 1
    LEN[0] = 0.0
    nn = 1
    n = _push(hk, hv, 0, 0.0, 0)
    end = -1
    two_pi = 2.0 * math.pi
    while n > 0 and end < 0:
        u, n = _pop(hk, hv, n)
        cx = int(math.floor((X[u] - ox) / cell))
        cy = int(math.floor((Y[u] - oy) / cell))
        ct = int(math.floor((T[u] % two_pi) / two_pi * n_th + 0.5)) % n_th
        if cx < 0 or cx >= nx or cy < 0 or cy >= ny:
            continue
        if closed[cy, cx, ct]:
            continue
        closed[cy, cx, ct] = True
        for kind in range(3):
            kappa = (1.0 - kind) / R  # L: +1/R, S: 0, R: -1/R
            for di in range(2):
                d = 1.0 if di == 0 else -1.0
                ok = True
                lo = np.inf
                hit = -1
                x = X[u]
                y = Y[u]
                th = T[u]
                for k in range(1, nsamp + 1):
                    x, y, th = _move(X[u], Y[u], T[u], kappa, d * ds * k / nsamp)
                    v = _gap_at(gap, res, ox, oy, x, y)
                    if v < margin:
                        ok = False
                        break
                    if v < lo:
                        lo = v
                    if (x - gx) * (x - gx) + (y - gy) * (y - gy) <= tol * tol:
                        hit = k
                        break
                if not ok:
                    continue
                s = ds if hit < 0 else ds * hit / nsamp
                c = s * (1.0 if d > 0 else rev_cost)
                if u > 0 and LEN[u] * d < 0.0:
                    c += switch_cost
                if pref > 0.0 and lo < pref:
                    c += s * soft * (pref - lo) / pref
                gnew = G[u] + c
                if hit >= 0:
                    if nn >= max_nodes:
                        break
                    X[nn] = x
                    Y[nn] = y
                    T[nn] = th
                    G[nn] = gnew
                    PAR[nn] = u
                    KIND[nn] = kind
                    LEN[nn] = d * s
                    end = nn
                    nn += 1
                    break
                bx = int(math.floor((x - ox) / cell))
                by = int(math.floor((y - oy) / cell))
                bt = int(math.floor((th % two_pi) / two_pi * n_th + 0.5)) % n_th
                if bx < 0 or bx >= nx or by < 0 or by >= ny or closed[by, bx, bt]:
                    continue
                if gnew >= bestg[by, bx, bt]:
                    continue
                hi = int(math.floor((y - oy) / res))
                hj = int(math.floor((x - ox) / res))
                h = hgrid[min(max(hi, 0), H - 1), min(max(hj, 0), W - 1)]
                if not h < np.inf:
                    continue
                if nn >= max_nodes:
                    break
                bestg[by, bx, bt] = gnew
                X[nn] = x
                Y[nn] = y
                T[nn] = th
                G[nn] = gnew
                PAR[nn] = u
                KIND[nn] = kind
                LEN[nn] = d * s
                n = _push(hk, hv, n, gnew + h, nn)
                nn += 1
            if end >= 0:
                break
        if nn >= max_nodes:
            break
    if end < 0:
        return 0, nn
    m = 0
    u = end
    while PAR[u] != -1:
        out_kind[m] = KIND[u]
        out_len[m] = LEN[u]
        m += 1
        u = PAR[u]
    out_kind[:m] = out_kind[:m][::-1].copy()
    out_len[:m] = out_len[:m][::-1].copy()
    return m, nn


def hybrid_astar(gap: np.ndarray, res: float, origin: np.ndarray, hgrid: np.ndarray,
                 start: np.ndarray, goal_xy: np.ndarray, radius: float, *, tol: float = 0.15,
                 ds: float = 0.3, n_th: int = 72, cell: float = 0.15, margin: float = 0.05,
                 pref: float = 0.3, soft: float = 1.0, rev_cost: float = 1.5,
                 switch_cost: float = 1.0, max_nodes: int = 200_000
                 ) -> tuple[list[tuple[str, float]], int]:
    """A car's plan (module docstring): ``([(kind, signed length m), ...], nodes used)``,
    consecutive equal pieces merged; an empty list when no plan was found.

    Args:
        gap, res, origin: the grid (:class:`~wheelgym.planning.grid.OccupancyGrid`).
        hgrid: :func:`cost_to_go` to the goal's cell (the heuristic).
        start: pose ``(x, y, yaw)`` (m, m, rad) of the footprint's centre (rear axle).
        goal_xy: goal position (m).
        radius: turning radius ``R`` (m) of the arcs.
    """
    if not radius > 0:
        raise ValueError(f"radius must be positive (the car's turning radius), got {radius!r}")
    cap = 4096
    kinds = np.empty(cap, dtype=np.int64)
    lens = np.empty(cap)
    m, used = _k_hybrid(np.ascontiguousarray(gap), float(res), float(origin[0]),
                        float(origin[1]), np.ascontiguousarray(hgrid), float(start[0]),
                        float(start[1]), float(start[2]), float(goal_xy[0]), float(goal_xy[1]),
                        float(tol), float(radius), float(ds), int(n_th), float(cell),
                        float(margin), float(pref), float(soft), float(rev_cost),
                        float(switch_cost), int(max_nodes), kinds, lens)
    out: list[tuple[str, float]] = []
    for k in range(min(m, cap)):
        kind, length = KINDS[int(kinds[k])], float(lens[k])
        if out and out[-1][0] == kind and (out[-1][1] > 0) == (length > 0):
            out[-1] = (kind, out[-1][1] + length)
        else:
            out.append((kind, length))
    return out, int(used)
