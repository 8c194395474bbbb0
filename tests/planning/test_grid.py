"""The occupancy grids: inflation against a hand-made map, exact gaps of a hand-made world."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym.planning import OccupancyGrid, grid_from_world, inflate
from wheelgym.world import Arena, World, load_map

# a hand-made 9 x 11 map ('#' solid); row 0 of the drawing is the top, the grids' row 0 the
# bottom, so the drawings are flipped below
MAP = """
...........
...........
...........
.....#.....
...........
...........
........###
...........
...........
"""
# inflated by a radius of 1.6 cells (cell side 1): blocked where a solid centre (outside the
# map is solid) is nearer than 1.6 + 0.5 = 2.1 cells: offsets (0, 0), (1, 0), (1, 1), (2, 0)
INFLATED_16 = """
###########
###########
##..###..##
##.#####.##
##..###.###
##...#.####
##....#####
###########
###########
"""
# radius 0.6 cells: nearer than 1.1 cells (the 4-neighbours; diagonals are sqrt(2) away)
INFLATED_06 = """
###########
#.........#
#....#....#
#...###...#
#....#....#
#.......###
#......####
#.......###
###########
"""


def _grid(text: str) -> np.ndarray:
    rows = [r for r in text.strip().splitlines()]
    return np.array([[ch == "#" for ch in r] for r in rows])[::-1]


@pytest.mark.parametrize("radius,expected", [(1.6, INFLATED_16), (0.6, INFLATED_06)])
def test_inflation_of_a_hand_made_map(radius, expected):
    blocked = inflate(_grid(MAP), 1.0, radius)
    assert np.array_equal(blocked, _grid(expected)), "\n" + "\n".join(
        "".join("#" if b else "." for b in row) for row in blocked[::-1])


def test_inflation_matches_brute_force_at_other_resolutions():
    rng = np.random.default_rng(3)
    solid = rng.random((14, 17)) < 0.08
    res, r = 0.05, 0.12
    blocked = inflate(solid, res, r)
    H, W = solid.shape
    pad = np.ones((H + 2, W + 2), dtype=bool)  # outside the grid is solid
    pad[1:-1, 1:-1] = solid
    si, sj = np.nonzero(pad)
    for i in range(H):
        for j in range(W):
            d = np.hypot(si - (i + 1), sj - (j + 1)).min() * res
            assert blocked[i, j] == (d < r + 0.5 * res), (i, j, d)


def test_gaps_of_a_hand_made_world():
    # walls at +-2 m, a circle of 0.5 m at (1, 0), a 1 x 1 m box centred at (-1, -1)
    walls = Arena(half_size=2.0).walls()
    box = [(-1.5, -1.5, -0.5, -1.5), (-0.5, -1.5, -0.5, -0.5), (-0.5, -0.5, -1.5, -0.5),
           (-1.5, -0.5, -1.5, -1.5)]
    world = World(np.array([[1.0, 0.0, 0.5]]), np.vstack([walls, box]), np.zeros(3),
                  np.zeros(3))
    r = 0.3
    grid = grid_from_world(world, Arena(half_size=2.0), r, res=0.1)
    assert grid.shape == (40, 40)
    c = grid.centres()
    x, y = c[..., 0], c[..., 1]
    to_circle = np.hypot(x - 1.0, y) - 0.5
    to_walls = 2.0 - np.maximum(np.abs(x), np.abs(y))
    qx, qy = np.abs(x + 1.0) - 0.5, np.abs(y + 1.0) - 0.5  # box's signed distance
    to_box = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0)) + np.minimum(np.maximum(qx, qy), 0)
    free = (np.minimum(np.minimum(to_circle, to_walls), to_box) >= r)
    assert np.array_equal(grid.free(0.0), free)
    inside_box = (qx < 0) & (qy < 0)
    assert np.all(grid.gap[inside_box] < 0)  # far from the box's edges but inside it
    outside = np.abs(to_box) > 1e-9
    np.testing.assert_allclose(grid.gap[~inside_box & outside],
                               np.minimum(np.minimum(to_circle, to_walls), to_box)
                               [~inside_box & outside] - r, atol=1e-12)


@pytest.mark.parametrize("clockwise", [False, True])
def test_a_rotated_box_is_solid_inside(clockwise):
    # a 1 x 1 m box turned by 30 deg about (0.3, -0.2); its cells are those whose centre has
    # |u|, |v| < 0.5 m in the box's own frame
    c, s, cx, cy = math.cos(math.pi / 6), math.sin(math.pi / 6), 0.3, -0.2
    corners = [(cx + c * u - s * v, cy + s * u + c * v)
               for u, v in ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))]
    if clockwise:
        corners = corners[::-1]
    box = [(*a, *b) for a, b in zip(corners, corners[1:] + corners[:1], strict=True)]
    world = World(np.zeros((0, 3)), np.vstack([Arena(half_size=2.0).walls(), box]),
                  np.zeros(3), np.zeros(3))
    grid = grid_from_world(world, Arena(half_size=2.0), 0.0, res=0.05)
    p = grid.centres()
    u = c * (p[..., 0] - cx) + s * (p[..., 1] - cy)
    v = -s * (p[..., 0] - cx) + c * (p[..., 1] - cy)
    inside = (np.abs(u) < 0.5 - 1e-9) & (np.abs(v) < 0.5 - 1e-9)
    outside = (np.abs(u) > 0.5 + 1e-9) | (np.abs(v) > 0.5 + 1e-9)
    assert inside.sum() > 300  # about 400 cells of 5 cm
    assert np.all(grid.gap[inside] < 0)
    assert np.all(grid.gap[outside] > 0)


def test_map_grid_agrees_with_the_maps_free_test():
    arena = load_map("maze")
    r = 0.35
    grid = grid_from_world(arena.world(np.zeros(3), np.zeros(3)), arena, r, res=0.1)
    pts = grid.centres().reshape(-1, 2)
    np.testing.assert_array_equal(grid.free(0.0).ravel(), arena.is_free(pts, r))


def test_bad_arguments_name_themselves():
    with pytest.raises(ValueError, match="res"):
        OccupancyGrid.from_cells(np.zeros((3, 3), bool), 0.0)
    with pytest.raises(ValueError, match="radius"):
        inflate(np.zeros((3, 3), bool), 1.0, -1.0)
    with pytest.raises(ValueError, match="solid"):
        OccupancyGrid.from_cells(np.zeros((0, 3), bool), 1.0)
    assert math.isfinite(OccupancyGrid.from_cells(np.zeros((3, 3), bool), 1.0).gap.max())
