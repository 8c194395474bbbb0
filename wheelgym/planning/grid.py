"""Occupancy grids for planning: a world's free space for a robot's circular footprint.

A :class:`OccupancyGrid` is an axis-aligned grid of square cells over the arena (or map)
bounds. Cell ``(i, j)`` (row ``i`` along y from the bottom, column ``j`` along x) has its centre
at ``origin + ((j + 1/2) res, (i + 1/2) res)``. Each cell holds the *gap*: the distance (m)
from its centre to the nearest obstacle surface minus the robot's radius (negative inside an
obstacle or beyond the bounds), so "the robot's circle centred here touches nothing" is
``gap >= 0`` and the grid inflated by the footprint plus a margin ``m`` is ``gap >= m``.

Two ways in:

* :func:`grid_from_world`: exact, from a :class:`~wheelgym.world.World`'s circles and segments
  (the random arena: the four walls, then four segments per box; a map:
  :class:`~wheelgym.world.MapArena`, whose ``inside`` test says which centres are solid);
* :func:`inflate` / :meth:`OccupancyGrid.from_cells`: from a boolean grid of solid cells (a
  hand-made or image map), with the gap of a free cell its centre's distance to the nearest
  solid cell's centre minus half a cell, less the radius: the cells blocked by an inflation of
  ``r`` are those nearer than ``r + res / 2`` to a solid centre.

Units: metres throughout; ``res`` m per cell.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from numba import njit

from wheelgym.world import k_surface_dist

__all__ = ["OccupancyGrid", "grid_from_world", "inflate"]


@njit(cache=True)
def _k_cell_gap(solid, res, radius, reach, out):  # pragma: no cover - compiled
    """Gap of every cell of a solid-cell grid (module docstring), searched within ``reach``
    cells (farther: the gap is capped at ``reach * res - radius``)."""
    H, W = solid.shape
    for i in range(H):
        for j in range(W):
            if solid[i, j]:
                out[i, j] = -radius - 0.5 * res
                continue
            best = reach * res
            for di in range(-reach, reach + 1):
                ii = i + di
                for dj in range(-reach, reach + 1):
                    jj = j + dj
                    outside = ii < 0 or ii >= H or jj < 0 or jj >= W
                    if outside or solid[ii, jj]:
                        d = math.sqrt(di * di + dj * dj) * res - 0.5 * res
                        if d < best:
                            best = d
            out[i, j] = best - radius


@dataclasses.dataclass
class OccupancyGrid:
    """A grid of gaps (module docstring).

    | field  | unit | meaning                                                          |
    |--------|------|------------------------------------------------------------------|
    | gap    | m    | (H, W) centre-to-surface distance minus the robot radius         |
    | res    | m    | cell side                                                         |
    | origin | m    | (2,) lower-left corner of cell (0, 0)                             |
    | radius | m    | the robot radius the gaps are measured for                       |
    """

    gap: np.ndarray
    res: float
    origin: np.ndarray
    radius: float

    @classmethod
    def from_cells(cls, solid: np.ndarray, res: float, origin: Any = (0.0, 0.0),
                   radius: float = 0.0) -> OccupancyGrid:
        """The grid of a boolean solid-cell map (row 0 at the bottom; outside is solid)."""
        solid = np.ascontiguousarray(np.asarray(solid, dtype=np.bool_))
        if solid.ndim != 2 or solid.size == 0:
            raise ValueError(f"solid must be a non-empty 2-D bool grid, got shape {solid.shape}")
        res, radius = _positive("res", res), _nonneg("radius", radius)
        reach = int(math.ceil((radius + 1.0) / res)) + 1
        gap = np.empty(solid.shape)
        _k_cell_gap(solid, res, radius, reach, gap)
        return cls(gap, res, np.asarray(origin, dtype=np.float64), radius)

    @property
    def shape(self) -> tuple[int, int]:
        return self.gap.shape  # type: ignore[return-value]

    def free(self, margin: float = 0.0) -> np.ndarray:
        """(H, W) bool: cells where the footprint plus ``margin`` (m) touches nothing."""
        return self.gap >= margin

    def centres(self) -> np.ndarray:
        """World position (m) of every cell centre, ``(H, W, 2)``."""
        H, W = self.gap.shape
        jj, ii = np.meshgrid(np.arange(W), np.arange(H))
        return np.stack([self.origin[0] + (jj + 0.5) * self.res,
                         self.origin[1] + (ii + 0.5) * self.res], axis=-1)

    def cell_of(self, xy: Any) -> tuple[int, int]:
        """Row and column of the cell holding the point ``xy`` (clipped onto the grid)."""
        H, W = self.gap.shape
        j = int(math.floor((float(xy[0]) - self.origin[0]) / self.res))
        i = int(math.floor((float(xy[1]) - self.origin[1]) / self.res))
        return min(max(i, 0), H - 1), min(max(j, 0), W - 1)

    def centre_of(self, i: int, j: int) -> np.ndarray:
        return np.array([self.origin[0] + (j + 0.5) * self.res,
                         self.origin[1] + (i + 0.5) * self.res])


def inflate(solid: np.ndarray, res: float, radius: float) -> np.ndarray:
    """Cells (bool, True: blocked) a robot of ``radius`` (m) cannot centre on: the solid cells
    and every cell whose centre lies nearer than ``radius + res / 2`` to a solid cell's centre
    (outside the grid counts solid)."""
    return ~OccupancyGrid.from_cells(solid, res, (0.0, 0.0), radius).free(0.0)


def grid_from_world(world: Any, arena: Any, radius: float, res: float = 0.05
                    ) -> OccupancyGrid:
    """The exact grid of one layout: ``world`` (:class:`~wheelgym.world.World`) in ``arena``
    (its :class:`~wheelgym.world.Arena` or :class:`~wheelgym.world.MapArena`), for a robot of
    ``radius`` (m), ``res`` m cells over the arena's bounds."""
    res, radius = _positive("res", res), _nonneg("radius", radius)
    if hasattr(arena, "bounds"):  # a map
        x0, y0, x1, y1 = (float(v) for v in arena.bounds)
    else:
        L = float(arena.half_size)
        x0, y0, x1, y1 = -L, -L, L, L
    W = max(1, int(math.ceil((x1 - x0) / res - 1e-9)))
    H = max(1, int(math.ceil((y1 - y0) / res - 1e-9)))
    grid = OccupancyGrid(np.empty((H, W)), res, np.array([x0, y0]), radius)
    pts = np.ascontiguousarray(grid.centres().reshape(-1, 2))
    gap = np.empty(len(pts))
    circles = np.ascontiguousarray(np.asarray(world.circles, dtype=np.float64).reshape(-1, 3))
    segs = np.ascontiguousarray(np.asarray(world.segments, dtype=np.float64).reshape(-1, 4))
    k_surface_dist(pts, circles, segs, gap)
    gap -= radius
    if hasattr(arena, "inside"):
        solid = arena.inside(pts)
    else:  # the walls, then four segments per box (wheelgym.world.Arena.generate)
        solid = ~((pts[:, 0] > x0) & (pts[:, 0] < x1) & (pts[:, 1] > y0) & (pts[:, 1] < y1))
        boxes = segs[4:].reshape(-1, 4, 4)
        for box in boxes:
            _k_in_convex(pts, np.ascontiguousarray(box[:, :2]), solid)
    gap[solid] = -np.abs(gap[solid]) - radius
    grid.gap = gap.reshape(H, W)
    return grid


@njit(cache=True)
def _k_in_convex(pts, corners, inside):  # pragma: no cover - compiled
    """Set ``inside[i]`` where ``pts[i]`` lies inside the convex polygon of ``corners (k, 2)``
    (either orientation): every edge's cross product with the point has one sign."""
    k = corners.shape[0]
    for i in range(pts.shape[0]):
        pos = True
        neg = True
        for e in range(k):
            ax = corners[e, 0]
            ay = corners[e, 1]
            bx = corners[(e + 1) % k, 0]
            by = corners[(e + 1) % k, 1]
            cross = (bx - ax) * (pts[i, 1] - ay) - (by - ay) * (pts[i, 0] - ax)
            pos = pos and cross > 0
            neg = neg and cross < 0
        if pos or neg:
            inside[i] = True


def _positive(name: str, v: Any) -> float:
    x = float(v)
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name} must be a positive number of metres, got {v!r}")
    return x


def _nonneg(name: str, v: Any) -> float:
    x = float(v)
    if not (math.isfinite(x) and x >= 0):
        raise ValueError(f"{name} must be a number of metres >= 0, got {v!r}")
    return x
