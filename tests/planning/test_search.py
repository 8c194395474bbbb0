"""A* against exhaustive searches; hybrid A* car plans are feasible and collision-free."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest

from wheelgym.kinematics.car_tracking import min_turning_radius
from wheelgym.kinematics.reeds_shepp import sample
from wheelgym.models import BicycleParams
from wheelgym.planning import astar, cost_to_go, grid_from_world, plan_car, plan_path
from wheelgym.planning.search import cell_weights
from wheelgym.world import Arena, World

SQ2 = math.sqrt(2.0)
MOVES = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]


def _moves(free, u):
    H, W = free.shape
    i, j = u
    for di, dj in MOVES:
        v = (i + di, j + dj)
        if not (0 <= v[0] < H and 0 <= v[1] < W) or not free[v]:
            continue
        if di and dj and not (free[i, j + dj] and free[i + di, j]):
            continue  # no corner cutting
        yield v, (SQ2 if di and dj else 1.0)


def _edge(w, u, v, step):
    return step * 0.5 * (w[u] + w[v])


def _dijkstra(free, w, s, t):
    """Reference: plain Dijkstra with Python's heapq (no heuristic)."""
    dist = {s: 0.0}
    pq = [(0.0, s)]
    done = set()
    while pq:
        d, u = heapq.heappop(pq)
        if u in done:
            continue
        done.add(u)
        if u == t:
            return d
        for v, step in _moves(free, u):
            c = d + _edge(w, u, v, step)
            if c < dist.get(v, math.inf):
                dist[v] = c
                heapq.heappush(pq, (c, v))
    return math.inf


def _exhaustive(free, w, s, t):
    """Reference: the least cost over every simple path (depth-first enumeration)."""
    best = [math.inf]

    def go(u, cost, seen):
        if cost >= best[0]:
            return
        if u == t:
            best[0] = cost
            return
        for v, step in _moves(free, u):
            if v not in seen:
                seen.add(v)
                go(v, cost + _edge(w, u, v, step), seen)
                seen.remove(v)

    go(s, 0.0, {s})
    return best[0]


def _check_path(free, w, cells, cost, s, t):
    assert tuple(cells[0]) == s and tuple(cells[-1]) == t
    total = 0.0
    for a, b in zip(cells[:-1], cells[1:], strict=True):
        a, b = tuple(a), tuple(b)
        steps = dict(_moves(free, a))
        assert b in steps, f"{a} -> {b} is not a legal move"
        total += _edge(w, a, b, steps[b])
    assert total == pytest.approx(cost, abs=1e-9)


def _random_case(rng, H, W, p, weighted):
    free = rng.random((H, W)) > p
    cells = np.argwhere(free)
    if len(cells) < 2:
        return None
    s, t = (tuple(int(v) for v in cells[k]) for k in rng.choice(len(cells), 2, replace=False))
    w = 1.0 + 2.0 * rng.random((H, W)) if weighted else np.ones((H, W))
    return free, w, s, t


@pytest.mark.parametrize("weighted", [False, True])
def test_astar_is_optimal_against_dijkstra(weighted):
    rng = np.random.default_rng(11)
    checked = unreachable = 0
    for _ in range(60):
        case = _random_case(rng, 12, 15, 0.3, weighted)
        if case is None:
            continue
        free, w, s, t = case
        cells, cost = astar(free, s, t, 1.0, w)
        ref = _dijkstra(free, w, s, t)
        if math.isinf(ref):
            assert len(cells) == 0 and math.isinf(cost)
            unreachable += 1
            continue
        assert cost == pytest.approx(ref, abs=1e-9)
        _check_path(free, w, cells, cost, s, t)
        checked += 1
    assert checked > 30 and unreachable > 0  # both kinds of case were met


@pytest.mark.parametrize("weighted", [False, True])
def test_astar_is_optimal_against_all_paths_on_small_grids(weighted):
    rng = np.random.default_rng(5)
    n = 0
    for _ in range(40):
        case = _random_case(rng, 4, 4, 0.25, weighted)
        if case is None:
            continue
        free, w, s, t = case
        cells, cost = astar(free, s, t, 1.0, w)
        ref = _exhaustive(free, w, s, t)
        assert cost == pytest.approx(ref, abs=1e-9) or (math.isinf(ref) and math.isinf(cost))
        if len(cells):
            _check_path(free, w, cells, cost, s, t)
            n += 1
    assert n > 20


def test_cost_to_go_equals_astar_costs():
    rng = np.random.default_rng(2)
    free, w, s, t = _random_case(rng, 10, 10, 0.2, True)
    h = cost_to_go(free, t, 0.5, w)
    for c in np.argwhere(free)[:25]:
        _, cost = astar(free, tuple(c), t, 0.5, w)
        assert h[tuple(c)] == pytest.approx(cost, abs=1e-9) or (math.isinf(cost)
                                                                and math.isinf(h[tuple(c)]))


def test_astar_refuses_bad_cells():
    free = np.ones((3, 3), bool)
    free[1, 1] = False
    with pytest.raises(ValueError, match="start"):
        astar(free, (1, 1), (0, 0))
    with pytest.raises(ValueError, match="goal"):
        astar(free, (0, 0), (5, 0))
    with pytest.raises(ValueError, match="weights"):
        astar(free, (0, 0), (2, 2), 1.0, np.zeros((3, 3)))


def _box(x0, y0, x1, y1):
    """The four segments of an axis-aligned box (as ``Arena.generate`` writes a box)."""
    return [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]


def _wall_world():
    """4 m walls, a wall from the bottom to y = 1 at x = 0: the goal is behind it."""
    arena = Arena(half_size=4.0)
    segs = np.vstack([arena.walls(), _box(-0.1, -4.0, 0.1, 1.0)])
    return arena, World(np.zeros((0, 3)), segs, np.zeros(3), np.zeros(3))


def test_point_path_goes_around_the_wall_and_keeps_the_margin():
    arena, world = _wall_world()
    grid = grid_from_world(world, arena, 0.35)
    path = plan_path(grid, (-2.0, -2.0), (2.0, -2.0), margin=0.08)
    assert path is not None
    assert np.hypot(*(path[0] - (-2.0, -2.0))) < 1e-12
    assert np.hypot(*(path[-1] - (2.0, -2.0))) < 1e-12
    assert path[:, 1].max() > 1.0 + 0.35  # over the wall's end
    i = np.floor((path[:, 1] - grid.origin[1]) / grid.res).astype(int)
    j = np.floor((path[:, 0] - grid.origin[0]) / grid.res).astype(int)
    assert grid.gap[i, j].min() >= 0.08 - 1e-9
    assert np.max(np.hypot(*np.diff(path, axis=0).T)) <= 0.05 + 1e-9
    # the smoothed path is not longer than the A* cell path it came from
    free = grid.free(0.08)
    cells, cost = astar(free, grid.cell_of((-2.0, -2.0)), grid.cell_of((2.0, -2.0)), grid.res,
                        cell_weights(grid.gap, 0.35, 2.0))
    assert np.sum(np.hypot(*np.diff(path, axis=0).T)) <= cost + 2 * grid.res


@pytest.mark.parametrize("start", [(-2.0, -2.0, 0.0), (-2.0, -2.0, -math.pi / 2),
                                   (-2.0, 2.5, math.pi)])
def test_car_plan_is_feasible(start):
    arena, world = _wall_world()
    grid = grid_from_world(world, arena, 0.35)
    r_min = min_turning_radius(BicycleParams())
    R = 1.25 * r_min
    goal = np.array([2.0, -2.0])
    path, nodes = plan_car(grid, start, goal, R, margin=0.06, tol=0.15)
    assert path is not None and nodes > 0
    smp = sample(path, path.start, 0.02)
    # curvature: arcs of radius R >= R_min, straights; no piece tighter than the car can
    kappa = np.abs(smp.curvature)
    assert np.all((kappa < 1e-12) | np.isclose(kappa, 1.0 / R))
    assert kappa.max() <= 1.0 / r_min
    # the path is continuous (consecutive samples <= the step apart) and collision-free
    assert np.max(np.hypot(*np.diff(smp.poses[:, :2], axis=0).T)) <= 0.02 + 1e-9
    i = np.floor((smp.poses[:, 1] - grid.origin[1]) / grid.res).astype(int)
    j = np.floor((smp.poses[:, 0] - grid.origin[0]) / grid.res).astype(int)
    assert grid.gap[i, j].min() >= 0.06 - 1e-9
    # heading continuity along each piece: yaw changes as kappa * signed step
    dyaw = np.angle(np.exp(1j * np.diff(smp.poses[:, 2])))
    ds = np.diff(smp.s) * smp.direction[1:]
    np.testing.assert_allclose(dyaw, smp.curvature[1:] * ds, atol=1e-9)
    # cusps: the direction changes along the samples, as the path counts them
    d = smp.direction[1:]
    assert path.cusps == int(np.sum(d[1:] != d[:-1]))
    assert np.hypot(*(np.array(path.end_pose()[:2]) - goal)) <= 0.15 + 1e-9


def test_car_plan_backs_out_of_a_dead_end():
    # a 1.4 m wide dead end (walls at y = +-0.7 m from x = -4 to 1), the car facing its end
    arena = Arena(half_size=4.0)
    segs = np.vstack([arena.walls(), _box(-4.0, 0.7, 1.0, 0.8), _box(-4.0, -0.8, 1.0, -0.7)])
    world = World(np.zeros((0, 3)), segs, np.zeros(3), np.zeros(3))
    grid = grid_from_world(world, arena, 0.35)
    R = 1.25 * min_turning_radius(BicycleParams())
    path, _ = plan_car(grid, (-2.5, 0.0, math.pi), np.array([-1.0, 3.0]), R)
    assert path is not None
    assert path.segments[0].length < 0  # it must reverse out first
    assert path.cusps >= 1
