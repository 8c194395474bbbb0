"""Arena with walls and random obstacles, a pymunk space of them, and range sensing.

An obstacle layout is a :class:`World`: circles ``(x, y, radius)`` and segments
``(x0, y0, x1, y1)`` (the four walls, then four per box). Two range sensors read the same
layout and agree to round-off (tests/world):

* :func:`pymunk_ranges`: ``Space.segment_query_first`` per ray on a pymunk space built from the
  world (:func:`build_space`), rebuilt at every reset so a seed replays exactly;
* :func:`k_ranges`: the analytic ray-versus-circle and ray-versus-segment intersection,
  compiled and batched over robots (about 25x faster; the default).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pymunk
from numba import njit

__all__ = ["Arena", "World", "build_space", "k_ranges", "k_clearance", "pymunk_ranges"]


@dataclasses.dataclass
class World:
    """One obstacle layout (m): ``circles (C, 3)``, ``segments (S, 4)``, ``start``, ``goal``."""

    circles: np.ndarray
    segments: np.ndarray
    start: np.ndarray
    goal: np.ndarray


@dataclasses.dataclass(frozen=True)
class Arena:
    """Random arena generator.

    | field          | default      | unit | meaning                                       |
    |----------------|--------------|------|-----------------------------------------------|
    | half_size      | 4.0          | m    | walls at x, y = +-half_size                   |
    | n_circles      | (3, 6)       | -    | number of circular obstacles (inclusive range)|
    | circle_radius  | (0.15, 0.4)  | m    | their radii                                   |
    | n_boxes        | (1, 3)       | -    | number of rotated rectangular obstacles       |
    | box_half       | (0.15, 0.5)  | m    | box half-sides                                |
    | min_goal_dist  | 3.0          | m    | start-to-goal distance at least               |
    | clearance      | 0.3          | m    | free margin around start and goal beyond the robot |
    """

    half_size: float = 4.0
    n_circles: tuple[int, int] = (3, 6)
    circle_radius: tuple[float, float] = (0.15, 0.4)
    n_boxes: tuple[int, int] = (1, 3)
    box_half: tuple[float, float] = (0.15, 0.5)
    min_goal_dist: float = 3.0
    clearance: float = 0.3

    @property
    def max_circles(self) -> int:
        return self.n_circles[1]

    @property
    def max_segments(self) -> int:
        return 4 + 4 * self.n_boxes[1]

    def walls(self) -> np.ndarray:
        L = self.half_size
        return np.array([[-L, -L, L, -L], [L, -L, L, L], [L, L, -L, L], [-L, L, -L, -L]])

    def generate(self, rng: np.random.Generator, robot_radius: float) -> World:
        """Draw start, goal and obstacles from ``rng`` (only ``rng``: a seed replays exactly)."""
        L = self.half_size
        margin = robot_radius + self.clearance
        lim = L - margin
        start = np.array([rng.uniform(-lim, lim), rng.uniform(-lim, lim),
                          rng.uniform(-math.pi, math.pi)])
        goal = start.copy()
        for _ in range(200):
            goal[:2] = rng.uniform(-lim, lim, 2)
            if math.hypot(goal[0] - start[0], goal[1] - start[1]) >= self.min_goal_dist:
                break
        goal[2] = rng.uniform(-math.pi, math.pi)
        keep = np.stack([start[:2], goal[:2]])

        def free(cx: float, cy: float, r: float) -> bool:
            return bool(np.all(np.hypot(keep[:, 0] - cx, keep[:, 1] - cy) > r + margin))

        circles = []
        for _ in range(int(rng.integers(self.n_circles[0], self.n_circles[1] + 1))):
            for _ in range(50):
                r = rng.uniform(*self.circle_radius)
                cx, cy = rng.uniform(-L + r, L - r, 2)
                if free(cx, cy, r):
                    circles.append((cx, cy, r))
                    break
        segs = [tuple(w) for w in self.walls()]
        for _ in range(int(rng.integers(self.n_boxes[0], self.n_boxes[1] + 1))):
            for _ in range(50):
                hx, hy = rng.uniform(*self.box_half, 2)
                ang = rng.uniform(-math.pi, math.pi)
                bound = math.hypot(hx, hy)
                cx, cy = rng.uniform(-L + bound, L - bound, 2)
                if free(cx, cy, bound):
                    c, s = math.cos(ang), math.sin(ang)
                    pts = [(cx + c * px - s * py, cy + s * px + c * py)
                           for px, py in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))]
                    for k in range(4):
                        segs.append(pts[k] + pts[(k + 1) % 4])
                    break
        return World(np.array(circles, dtype=np.float64).reshape(-1, 3),
                     np.array(segs, dtype=np.float64).reshape(-1, 4), start, goal)


def build_space(world: World) -> pymunk.Space:
    """A static pymunk space holding the world's circles and segments."""
    space = pymunk.Space()
    body = space.static_body
    shapes = [pymunk.Circle(body, float(r), (float(x), float(y))) for x, y, r in world.circles]
    shapes += [pymunk.Segment(body, (float(a), float(b)), (float(c), float(d)), 0.0)
               for a, b, c, d in world.segments]
    space.add(*shapes)
    return space


def pymunk_ranges(space: pymunk.Space, pose: np.ndarray, n_rays: int, max_range: float,
                  out: np.ndarray) -> None:
    """Range readings (m) of a ring of ``n_rays`` rays from ``pose`` via segment queries.

    Ray k points at ``yaw + 2 pi k / n_rays``; no hit reads ``max_range``.
    """
    x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
    filt = pymunk.ShapeFilter()
    for k in range(n_rays):
        a = yaw + 2.0 * math.pi * k / n_rays
        end = (x + max_range * math.cos(a), y + max_range * math.sin(a))
        hit = space.segment_query_first((x, y), end, 0.0, filt)
        out[k] = max_range if hit is None else hit.alpha * max_range


@njit(cache=True)
def k_ranges(pose, circles, nc, segs, ns, max_range, out):  # pragma: no cover - compiled
    """Analytic ring of range readings for a batch: ``out (N, R)`` (m), rays as in pymunk."""
    N = pose.shape[0]
    R = out.shape[1]
    for i in range(N):
        px = pose[i, 0]
        py = pose[i, 1]
        for k in range(R):
            a = pose[i, 2] + 2.0 * math.pi * k / R
            dx = math.cos(a)
            dy = math.sin(a)
            best = max_range
            for j in range(nc[i]):  # |p + t d - c|^2 = r^2, smallest t >= 0
                ox = px - circles[i, j, 0]
                oy = py - circles[i, j, 1]
                b = ox * dx + oy * dy
                c = ox * ox + oy * oy - circles[i, j, 2] ** 2
                disc = b * b - c
                if disc >= 0.0:
                    sq = math.sqrt(disc)
                    t = -b - sq
                    if t < 0.0:
                        t = 0.0 if c <= 0.0 else -b + sq
                    if 0.0 <= t < best:
                        best = t
            for j in range(ns[i]):  # p + t d = s0 + u (s1 - s0), t >= 0, u in [0, 1]
                sx = segs[i, j, 0]
                sy = segs[i, j, 1]
                ex = segs[i, j, 2] - sx
                ey = segs[i, j, 3] - sy
                den = dx * ey - dy * ex
                if den != 0.0:
                    wx = sx - px
                    wy = sy - py
                    t = (wx * ey - wy * ex) / den
                    u = (wx * dy - wy * dx) / den
                    if 0.0 <= u <= 1.0 and 0.0 <= t < best:
                        best = t
            out[i, k] = best


@njit(cache=True)
def k_clearance(pose, circles, nc, segs, ns, out):  # pragma: no cover - compiled
    """Distance (m) from each robot centre to the nearest obstacle surface, ``out (N,)``."""
    for i in range(pose.shape[0]):
        px = pose[i, 0]
        py = pose[i, 1]
        best = np.inf
        for j in range(nc[i]):
            d = math.hypot(px - circles[i, j, 0], py - circles[i, j, 1]) - circles[i, j, 2]
            if d < best:
                best = d
        for j in range(ns[i]):
            sx = segs[i, j, 0]
            sy = segs[i, j, 1]
            ex = segs[i, j, 2] - sx
            ey = segs[i, j, 3] - sy
            ll = ex * ex + ey * ey
            u = ((px - sx) * ex + (py - sy) * ey) / ll if ll > 0.0 else 0.0
            u = min(max(u, 0.0), 1.0)
            d = math.hypot(px - sx - u * ex, py - sy - u * ey)
            if d < best:
                best = d
        out[i] = best
