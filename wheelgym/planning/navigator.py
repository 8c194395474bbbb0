"""The planning baseline's commands on the navigate task: plan on the map, then track the plan.

:class:`PlanningNavigator` works on a batch of robots (a navigate core, read through the
attributes of :class:`~wheelgym.tasks.view.BatchView` and the navigate task's ``worlds``,
``arena`` and ``goal``); ``wheelgym.baseline(env, planner=...)`` wraps it into the baseline
policy, which turns its commands into actions. Per row:

1. **Grid.** The layout's :func:`~wheelgym.planning.grid.grid_from_world` for the robot's
   footprint radius (random arenas: rebuilt at each reset; a map: built once per robot radius).
2. **Plan** at the episode's start (``steps == 0``) or when the goal changes.

   * Robots that turn in place (ThreeWheel, SkidSteer, CasterAGV, DiffDrive, Unicycle):
     :func:`~wheelgym.planning.search.astar` on the cells with at least ``margin`` of gap
     (soft cost below ``pref``), then :func:`~wheelgym.planning.search.shortcut`, then the
     polyline resampled every ``step`` m and its points in narrow places moved toward the
     middle (:func:`centre`).
   * Cars (Bicycle, Ackermann): :func:`~wheelgym.planning.search.hybrid_astar` with the
     turning radius of :class:`~wheelgym.kinematics.car_tracking.CarTracker` (1.25 ``R_min``),
     heuristic :func:`~wheelgym.planning.search.cost_to_go`; the plan is a Reeds-Shepp path of
     its primitives (``path_from_segments``).

   When no path keeps ``margin``, the search is repeated with half of it, then none; when
   none exists at all the robot stands still (the failure is counted).
3. **Track.** Turn-in-place robots: a carrot ``lookahead`` m along the path from the nearest
   point (searched forwards from the last one); holonomic robots drive at the carrot,
   the others turn toward it (in place beyond 0.6 rad; 0.25 rad where the gap is below
   0.15 m) and drive with ``v cos^2(alpha)``. The carrot moves nearer while the straight line
   to it has less gap than the robot has now (no corner cutting). Speed ``v_cap``, slowed
   within 0.5 m of the path's end, where the gap is below 0.15 m (times ``gap / 0.15``,
   at least 0.3) and, where the gap is below 0.25 m, into bends (times ``cos(bend / 2)``, at
   least 0.4, ``bend`` the path's turn over the next metre). Cars: ``CarTracker`` (rear-wheel
   feedback forwards and backwards, stopping on each cusp) along the plan. In the velocity
   action mode the twist is scaled into ``TWIST_MARGIN`` of the command's range (a command at
   its bound clips, and counts as saturated; the scaling keeps a holonomic robot's direction).
4. **Re-plan** when the robot strays more than ``stray`` m from the path, or makes no progress
   along it for ``stuck_steps`` control steps (cars: ``CarTracker``'s own replans, which call
   the planner again from where the car is).

Planning time (wall clock of each search, grid included) is kept in :attr:`plan_times`.

Units: m, rad, s; commands are body twists ``(vx, vy, wz)`` (m/s, rad/s) for the robots that
turn in place and the car model's inputs for the cars.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numba import njit

from wheelgym.kinematics.car_tracking import CarTracker, TrackFrame
from wheelgym.kinematics.reeds_shepp import ReedsSheppPath, path_from_segments
from wheelgym.planning.grid import OccupancyGrid, grid_from_world
from wheelgym.planning.search import (
    astar,
    cell_weights,
    cost_to_go,
    hybrid_astar,
    segment_gap,
    shortcut,
)

__all__ = ["PlanningNavigator", "WaypointHint", "plan_path", "plan_car", "plan_car_or_stand",
           "car_tracker", "resample", "centre", "PLANNERS", "CAR_SPEED"]

#: ``planner=`` choices: ``"astar"`` (grid A* + smoothing; the robots that turn in place),
#: ``"hybrid"`` (hybrid A* over Reeds-Shepp primitives; the cars), ``"auto"`` (the robot's).
PLANNERS = ("auto", "astar", "hybrid")

#: the cars' cruise speed (m/s) in the planning baseline (cut to the car's speed range)
CAR_SPEED = 1.5

#: velocity mode: the share of the twist command's range (``twist_max``) the commands keep to,
#: so that cruising is not a command at its bound (which clips, and counts as saturated)
TWIST_MARGIN = 0.97


def car_tracker(model: Any, planner: Any, car_speed: float = CAR_SPEED) -> CarTracker:
    """The planning baseline's tracker for a car ``model``, planning with ``planner(pose)``
    (one construction for the baseline and the cars' waypoint hint)."""
    return CarTracker.from_model(model, cruise_speed=car_speed, planner=planner)


def _nearest_free(free: np.ndarray, cell: tuple[int, int]) -> tuple[int, int] | None:
    """The free cell nearest to ``cell`` (itself when free), within 20 cells."""
    i, j = cell
    if free[i, j]:
        return cell
    H, W = free.shape
    for r in range(1, 21):
        i0, i1, j0, j1 = max(i - r, 0), min(i + r + 1, H), max(j - r, 0), min(j + r + 1, W)
        ii, jj = np.nonzero(free[i0:i1, j0:j1])
        if len(ii):
            d = (ii + i0 - i) ** 2 + (jj + j0 - j) ** 2
            k = int(np.argmin(d))
            return int(ii[k] + i0), int(jj[k] + j0)
    return None


def plan_path(grid: OccupancyGrid, start_xy: Any, goal_xy: Any, *, margin: float = 0.08,
              pref: float = 0.35, soft: float = 2.0, step: float = 0.05) -> np.ndarray | None:
    """A* + smoothing from ``start_xy`` to ``goal_xy`` (m) on ``grid``: the path resampled
    every ``step`` m, ``(n, 2)``, from the start to the goal; ``None`` when no path exists."""
    sxy = np.asarray(start_xy, dtype=np.float64)[:2]
    gxy = np.asarray(goal_xy, dtype=np.float64)[:2]
    w = cell_weights(grid.gap, pref, soft)
    for m in (margin, 0.5 * margin, 0.0):
        free = grid.free(m)
        s = _nearest_free(free, grid.cell_of(sxy))
        g = _nearest_free(free, grid.cell_of(gxy))
        if s is None or g is None:
            continue
        cells, cost = astar(free, s, g, grid.res, w)
        if not len(cells):
            continue
        pts = grid.origin + (cells[:, ::-1] + 0.5) * grid.res
        pts = np.vstack([sxy, pts[1:-1], gxy]) if len(pts) > 2 else np.vstack([sxy, gxy])
        pts = shortcut(pts, grid.gap, grid.res, grid.origin, m, pref)
        return centre(grid, resample(pts, step), pref)
    return None


def centre(grid: OccupancyGrid, path: np.ndarray, pref: float, iters: int = 30,
           step: float = 0.01) -> np.ndarray:
    """Move the points of ``path`` whose gap is below ``pref`` up the gap's gradient, across
    the path (``iters`` moves of ``step`` m at most, the ends kept), so that narrow passages
    are crossed in their middle; a move that would lower a point's gap is not made."""
    if len(path) < 3:
        return path
    gy, gx = np.gradient(grid.gap, grid.res)
    H, W = grid.gap.shape
    p = path.copy()

    def look(a: np.ndarray, q: np.ndarray) -> np.ndarray:  # (np.clip costs more here)
        j = np.floor((q[:, 0] - grid.origin[0]) / grid.res).astype(np.int64)
        i = np.floor((q[:, 1] - grid.origin[1]) / grid.res).astype(np.int64)
        return a[np.minimum(np.maximum(i, 0), H - 1), np.minimum(np.maximum(j, 0), W - 1)]

    for _ in range(iters):
        inner = p[1:-1]
        gap = look(grid.gap, inner)
        t = p[2:] - p[:-2]  # the path's direction at each inner point
        t /= np.maximum(np.hypot(t[:, 0], t[:, 1]), 1e-12)[:, None]
        g = np.stack([look(gx, inner), look(gy, inner)], axis=1)
        g -= np.sum(g * t, axis=1)[:, None] * t  # across the path only
        n = np.hypot(g[:, 0], g[:, 1])
        move = (gap < pref) & (n > 1e-9)
        cand = inner + step * g / np.maximum(n, 1e-12)[:, None]
        ok = move & (look(grid.gap, cand) >= gap)
        inner[ok] = cand[ok]
    return p


def resample(pts: np.ndarray, step: float) -> np.ndarray:
    """The polyline ``pts (n, 2)`` with points at most ``step`` m apart (its corners kept)."""
    out = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        k = max(1, int(math.ceil(float(np.hypot(*(b - a))) / step)))
        u = np.arange(1, k + 1)[:, None] / k
        out.append(a + u * (b - a))
    return np.vstack(out)


def plan_car(grid: OccupancyGrid, start: Any, goal_xy: Any, turn_radius: float, *,
             margin: float = 0.06, pref: float = 0.3, tol: float = 0.15,
             max_nodes: int = 200_000) -> tuple[ReedsSheppPath | None, int]:
    """Hybrid A* from the pose ``start`` to ``goal_xy`` (m): ``(path, nodes)``; the path is
    ``None`` when no plan exists."""
    st = np.asarray(start, dtype=np.float64)[:3]
    gxy = np.asarray(goal_xy, dtype=np.float64)[:2]
    used = 0
    for m in (margin, 0.0):
        # the start may sit closer to a surface than the margin (after a stray): allow its gap
        i, j = grid.cell_of(st)
        m_eff = max(0.0, min(m, float(grid.gap[i, j]) - 1e-3))
        free = grid.free(m_eff)
        g = _nearest_free(free, grid.cell_of(gxy))
        if g is None:
            continue
        h = cost_to_go(free, g, grid.res)
        segs, n = hybrid_astar(grid.gap, grid.res, grid.origin, h, st, gxy, turn_radius,
                               tol=tol, margin=m_eff, pref=pref, max_nodes=max_nodes)
        used += n
        if segs:
            return path_from_segments(segs, turn_radius, st), used
    return None, used


def plan_car_or_stand(grid: OccupancyGrid, pose: Any, goal_xy: Any, turn_radius: float
                      ) -> tuple[ReedsSheppPath, bool]:
    """:func:`plan_car`'s plan, or an empty path at ``pose`` (the car stands) when none
    exists: ``(path, found)``; the plan the planning baseline and the cars' hint both follow."""
    path, _ = plan_car(grid, pose, goal_xy, turn_radius)
    if path is None:
        return path_from_segments([], turn_radius, pose), False
    return path, True


class PlanningNavigator:
    """Plans and tracking commands for every row of a navigate core (module docstring).

    Args:
        core: the environment's core (task ``navigate``).
        planner: one of :data:`PLANNERS`.
        v_cap: cruise speed (m/s) of the turn-in-place robots (cut to the robot's
            ``speed_range``); ``w_cap`` their yaw-rate cap (rad/s); ``car_speed`` the cars'
            cruise speed (m/s). In the velocity action mode the velocity is then scaled into
            :data:`TWIST_MARGIN` of the twist command's range (``twist_max``) and ``w_cap``
            cut to that share of its yaw-rate range.
        lookahead: carrot distance (m); ``stray``: off-path distance (m) that re-plans;
            ``stuck_steps``: control steps without progress along the path that re-plan.
        res: grid cell (m).
    """

    def __init__(self, core: Any, planner: str = "auto", *, v_cap: float = 1.5,
                 w_cap: float = 3.0,
                 car_speed: float = CAR_SPEED, lookahead: float = 0.5, stray: float = 0.3,
                 stuck_steps: int = 60, res: float = 0.05) -> None:
        if planner not in PLANNERS:
            raise ValueError(f"planner must be one of {list(PLANNERS)}, got {planner!r}")
        if getattr(core, "task_name", None) != "navigate":
            raise ValueError(f"planner={planner!r} plans on a navigate task's map, got task "
                             f"{getattr(core, 'task_name', None)!r}")
        self.core = core
        spec = core.spec
        self.car = not spec.turns_in_place
        if self.car and planner == "astar":
            raise ValueError(f"planner='astar' plans for robots that turn in place; "
                             f"{spec.name} is car-like: use 'hybrid' or 'auto'")
        if not self.car and planner == "hybrid":
            raise ValueError(f"planner='hybrid' plans for the car-like robots (Bicycle, "
                             f"Ackermann); {spec.name} turns in place: use 'astar' or 'auto'")
        self.kind = "hybrid" if self.car else "astar"
        self.holonomic = spec.holonomic
        self.radius = float(spec.radius)
        self.x_icr = float(getattr(core.base_params, "x_icr", 0.0))
        # within the robot's speed range where it has one (the kinematic robots)
        hi = getattr(core.base_params, "speed_range", (math.inf, math.inf))[1]
        self.v_cap = min(float(v_cap), float(hi))
        self.w_cap, self.car_speed = float(w_cap), float(car_speed)
        #: velocity mode: the body velocity's largest commands (vx, vy), TWIST_MARGIN of the
        #: twist command's range (the yaw rate's is ``w_cap``); None in the other modes
        self.twist_cap: np.ndarray | None = None
        if spec.tracks_twist(core.action_mode):
            tmax = spec.twist_max
            vy = tmax[1] if len(tmax) == 3 else math.inf
            self.twist_cap = TWIST_MARGIN * np.array([tmax[0], vy], dtype=float)
            self.w_cap = min(self.w_cap, TWIST_MARGIN * float(tmax[-1]))
        self.lookahead, self.stray, self.stuck_steps = float(lookahead), float(stray), \
            int(stuck_steps)
        self.res = float(res)
        #: the plans' least gap (m) between the footprint and the nearest surface
        self.margin = 0.08
        N = core.num
        self.paths: list[np.ndarray | None] = [None] * N
        self.idx = np.zeros(N, dtype=np.int64)
        #: plans of each row's current episode (1 + its re-plans)
        self.row_plans = np.zeros(N, dtype=np.int64)
        self.best_idx = np.zeros(N, dtype=np.int64)
        self.since = np.zeros(N, dtype=np.int64)
        self._goal = np.full((N, 2), np.nan)
        self._fresh = np.zeros(N, dtype=bool)
        self._seen: list[Any] = [None] * N  # each row's layout when last asked
        self._world: list[Any] = [None] * N
        self._grids: list[OccupancyGrid | None] = [None] * N
        self._map_grid: OccupancyGrid | None = None
        self.cars: list[CarTracker] | None = None
        if self.car:
            self.cars = [car_tracker(core.model, lambda pose, i=i: self._car_plan(i, pose),
                                     self.car_speed) for i in range(N)]
        #: wall-clock seconds of every plan (grid included), and the counts
        self.plan_times: list[float] = []
        self.plans = 0
        self.replans = 0
        self.failures = 0

    # ------------------------------------------------------------------ grids and plans
    def _grid(self, i: int) -> OccupancyGrid:
        task = self.core.task
        w = task.worlds[i]
        if hasattr(task.arena, "bounds"):  # a map: one static geometry
            if self._map_grid is None:
                self._map_grid = grid_from_world(w, task.arena, self.radius, self.res)
            return self._map_grid
        if self._world[i] is not w or self._grids[i] is None:
            self._grids[i] = grid_from_world(w, task.arena, self.radius, self.res)
            self._world[i] = w
        return self._grids[i]

    def _car_plan(self, i: int, pose: np.ndarray) -> ReedsSheppPath:
        t0 = time.perf_counter()
        grid = self._grid(i)
        assert self.cars is not None
        path, found = plan_car_or_stand(grid, pose, self._goal[i], self.cars[i].radius)
        self.plan_times.append(time.perf_counter() - t0)
        self.plans += 1
        self.replans += int(self.row_plans[i] > 0)  # the tracker's replans of this episode
        self.row_plans[i] += 1
        self.failures += int(not found)
        return path

    def _plan_row(self, i: int) -> None:
        c = self.core
        t0 = time.perf_counter()
        grid = self._grid(i)
        p = self._point(c.pose[i:i + 1])[0]
        path = plan_path(grid, p, self._goal[i], margin=self.margin)
        self.plan_times.append(time.perf_counter() - t0)
        self.plans += 1
        self.row_plans[i] += 1
        if path is None:
            self.failures += 1
        self.paths[i] = path
        self.idx[i] = 0
        self.best_idx[i] = 0
        self.since[i] = 0

    def _point(self, pose: np.ndarray) -> np.ndarray:
        """The tracked point: the pose, SkidSteer's ICR point ``x_icr`` ahead."""
        if self.holonomic or self.x_icr == 0.0:
            return pose[:, :2].copy()
        return pose[:, :2] + self.x_icr * np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])], 1)

    def _new_episodes(self) -> np.ndarray:
        c = self.core
        goal = c.task.goal[:, :2]
        start = c.steps == 0
        # a new episode (planned once, however often it is asked at step 0) or a new goal
        new = (start & ~self._fresh) | ~np.all(goal == self._goal, axis=1)
        worlds = c.task.worlds
        new |= np.array([w is not v for w, v in zip(worlds, self._seen, strict=True)])
        self._seen = list(worlds)
        self._fresh = start
        for i in np.flatnonzero(new):
            self._goal[i] = goal[i]
            self.row_plans[i] = 0
        return np.flatnonzero(new)

    # ------------------------------------------------------------------ commands
    def twist(self) -> np.ndarray:
        """Body-twist commands ``(N, 3)`` (m/s, m/s, rad/s) of the turn-in-place robots."""
        c = self.core
        for i in self._new_episodes():
            self._plan_row(int(i))
        N = c.num
        cmd = np.zeros((N, 3))
        p = self._point(c.pose)
        yaw = c.pose[:, 2]
        look = max(1, int(round(self.lookahead / 0.05)))
        for i in range(N):
            path = self.paths[i]
            if path is None:
                continue
            n = len(path)
            j0 = int(self.idx[i])
            win = path[j0:min(n, j0 + 40)]
            d2 = np.sum((win - p[i]) ** 2, axis=1)
            j = j0 + int(np.argmin(d2))
            off = math.sqrt(float(d2[j - j0]))
            self.idx[i] = j
            if j > self.best_idx[i]:
                self.best_idx[i] = j
                self.since[i] = 0
            else:
                self.since[i] += 1
            if off > self.stray or self.since[i] > self.stuck_steps:
                self.replans += 1
                self._plan_row(i)
                path = self.paths[i]
                if path is None:
                    continue
                n, j = len(path), 0
            # the carrot: ``lookahead`` on, nearer where the straight line to it would cut
            # a corner closer to a surface than the robot is now (or the margin)
            grid = self._grid(i)
            gi, gj = grid.cell_of(p[i])
            here = float(grid.gap[gi, gj])
            need = min(self.margin, here)
            ahead = look
            while ahead > 1:
                target = path[min(n - 1, j + ahead)]
                if segment_gap(grid.gap, grid.res, grid.origin, p[i], target) >= need:
                    break
                ahead //= 2
            target = path[min(n - 1, j + ahead)]
            left = (n - 1 - j) * 0.05
            # the path's turn over the next metre: slower into corners
            a0, a1 = path[min(n - 1, j + 1)] - path[j], path[min(n - 1, j + 20)] - \
                path[min(n - 1, j + 19)]
            bend = abs(math.atan2(a0[0] * a1[1] - a0[1] * a1[0], a0[0] * a1[0] + a0[1] * a1[1]))
            # slower near the goal and where the gap is small
            v = min(self.v_cap, 0.3 + 1.5 * left) * min(max(here / 0.15, 0.3), 1.0) \
                * (max(0.4, math.cos(0.5 * bend)) if here < 0.25 else 1.0)
            dx, dy = target[0] - p[i, 0], target[1] - p[i, 1]
            cy, sy = math.cos(yaw[i]), math.sin(yaw[i])
            ex, ey = cy * dx + sy * dy, -sy * dx + cy * dy
            dist = math.hypot(ex, ey)
            alpha = math.atan2(ey, ex)
            if self.holonomic:
                if dist > 1e-9:
                    cmd[i, 0], cmd[i, 1] = v * ex / dist, v * ey / dist
                cmd[i, 2] = min(max(2.0 * alpha, -self.w_cap), self.w_cap)
            else:
                # turn in place beyond 0.6 rad of heading error (0.25 rad in narrow passages)
                turn = 0.6 if here > 0.15 else 0.25
                cmd[i, 0] = 0.0 if abs(alpha) > turn else v * math.cos(alpha) ** 2
                cmd[i, 2] = min(max(3.0 * alpha, -self.w_cap), self.w_cap)
        if self.twist_cap is not None:  # the velocity: scaled into range (its direction kept)
            over = np.max(np.abs(cmd[:, :2]) / self.twist_cap, axis=1)
            cmd[:, :2] /= np.maximum(over, 1.0)[:, None]
        return cmd

    def car_inputs(self) -> np.ndarray:
        """The cars' model inputs ``(N, m)`` in their input mode (``CarTracker.action``)."""
        c = self.core
        assert self.cars is not None
        for i in self._new_episodes():
            self.cars[i].reset(c.X[i], (*self._goal[i], 0.0))  # (plans through _car_plan)
        u = np.empty((c.num, c.m))
        for i, car in enumerate(self.cars):
            u[i] = car.action(c.X[i], c.dt)
        return u

    def waypoints(self, i: int) -> np.ndarray | None:
        """Row ``i``'s current plan as points ``(n, 2)`` (m), or ``None`` (for drawing)."""
        if self.cars is not None:
            car = self.cars[i]
            if car.path is None:
                return None
            from wheelgym.kinematics.reeds_shepp import sample

            return sample(car.path, car.path.start, 0.05).poses[:, :2]
        return self.paths[i]

    def stats(self) -> dict[str, float]:
        """Plans, replans, failures and planning time (mean and max, ms)."""
        t = np.asarray(self.plan_times) * 1e3
        return {"plans": self.plans, "replans": self.replans, "failures": self.failures,
                "plan_ms_mean": float(t.mean()) if len(t) else 0.0,
                "plan_ms_max": float(t.max()) if len(t) else 0.0}



@njit(cache=True)
def _k_nearest(P, length, idx, rows, xy, window, stray2, strayed):  # pragma: no cover
    """:meth:`WaypointHint.points`' search: for each of ``rows``, the path point of ``P[i]``
    (its first ``length[i]``) nearest to ``xy[n]`` among the ``window`` from ``idx[i]`` on
    (the first of equals) becomes ``idx[i]``; ``strayed[n]``: its squared distance exceeds
    ``stray2``."""
    for n in range(rows.shape[0]):
        i = rows[n]
        best = np.inf
        near = idx[i]
        for j in range(idx[i], min(idx[i] + window, length[i])):
            dx = P[i, j, 0] - xy[n, 0]
            dy = P[i, j, 1] - xy[n, 1]
            d2 = dx * dx + dy * dy
            if d2 < best:
                best = d2
                near = j
        idx[i] = near
        strayed[n] = best > stray2


class WaypointHint:
    """The navigate -v1 observation's opt-in hint: where the planning baseline's plan goes.

    Robots that turn in place: the point ``ahead`` m along a shortest path (:func:`plan_path`
    on the layout's grid) from the robot to its goal, planned when the episode starts, when its
    layout or goal changes and when the robot is more than ``stray`` m from the path (between
    plans the nearest path point is searched forwards from the last one); without a path the
    goal itself.

    Cars (``car`` given): the planning baseline's own tracker (:func:`car_tracker`, the
    hybrid-A* plan of :func:`plan_car`, replanned when and where the baseline replans) is run
    on the robot's states, and the hint is its :class:`~wheelgym.kinematics.car_tracking.
    TrackFrame`: the point ``ahead`` m along the run it follows (not past the next cusp, so on
    a reversing run it lies behind the car), the car's lateral offset and heading error
    against that run, the run's curvature, its driving direction and the arc length left to
    its end, the inputs of the tracker's steering and speed laws. The baseline, driving the
    same states, computes its commands from the same frame.

    Args:
        arena: the task's :class:`~wheelgym.world.Arena` or :class:`~wheelgym.world.MapArena`.
        radius: the robot's footprint radius (m).
        num: rows.
        car: a car's model (Bicycle, Ackermann), ``None`` for robots that turn in place.
        dt: the control period (s) the cars' trackers command for.
    """

    #: path samples' spacing (m)
    STEP = 0.05

    def __init__(self, arena: Any, radius: float, num: int, *, ahead: float = 1.0,
                 stray: float = 0.5, res: float = 0.05, car: Any = None,
                 dt: float = 0.05) -> None:
        self.arena, self.radius, self.res = arena, float(radius), float(res)
        self.ahead, self.stray, self.dt = float(ahead), float(stray), float(dt)
        self.idx = np.zeros(num, dtype=np.int64)
        self._key: list[Any] = [None] * num
        self._world: list[Any] = [None] * num
        self._goal = np.zeros((num, 2))
        self._latest: tuple[Any, OccupancyGrid] | None = None
        # robots that turn in place: each row's path padded into one array (the batched
        # search of :meth:`points`) and its length (0: not planned yet)
        self._P = np.zeros((num, 64, 2))
        self._len = np.zeros(num, dtype=np.int64)
        #: cars: each row's tracker (the planning baseline's); robots that turn in place: None
        self.cars: list[CarTracker] | None = None
        if car is not None:
            self.cars = [car_tracker(car, lambda pose, i=i: self._car_plan(i, pose))
                         for i in range(num)]
            for tracker in self.cars:
                tracker.lookahead = self.ahead

    def _grid_of(self, world: Any) -> OccupancyGrid:
        """The grid of ``world``'s layout: a map has one; of random layouts the latest is kept,
        held with its layout (so that a new layout cannot take its identity)."""
        if hasattr(self.arena, "bounds"):  # a map: one geometry
            if self._latest is None:
                self._latest = (None, grid_from_world(world, self.arena, self.radius, self.res))
        elif self._latest is None or self._latest[0] is not world:
            self._latest = (world, grid_from_world(world, self.arena, self.radius, self.res))
        return self._latest[1]

    def _car_plan(self, i: int, pose: np.ndarray) -> ReedsSheppPath:
        assert self.cars is not None
        return plan_car_or_stand(self._grid_of(self._world[i]), pose, self._goal[i],
                                 self.cars[i].radius)[0]

    def frame(self, i: int, world: Any, state: np.ndarray, goal: np.ndarray,
              new_episode: bool) -> TrackFrame:
        """A car's hint at ``state`` (its model state; rear axle ``x, y, yaw`` first): the
        frame of row ``i``'s tracker after its command for this state (world frame)."""
        assert self.cars is not None
        car = self.cars[i]
        key = (id(world), float(goal[0]), float(goal[1]))
        if new_episode or key != self._key[i]:
            self._key[i], self._world[i] = key, world
            self._goal[i] = goal[:2]
            car.reset(state, (float(goal[0]), float(goal[1]), 0.0))
        car.command(state, self.dt)
        return car.frame

    def points(self, rows: np.ndarray, worlds: list[Any], pose: np.ndarray, goal: np.ndarray,
               new_episode: np.ndarray) -> np.ndarray:
        """The hints ``(k, 2)`` (m, world frame) of ``rows`` (robots that turn in place), at
        their ``pose (k, 3)``, in their layouts ``worlds`` with goals ``goal (k, >= 2)``;
        ``new_episode (k,)`` bool. A row is planned when its episode starts, its layout or goal
        changes or it has no path yet, then its nearest path point is searched among the
        :attr:`WINDOW` from its last one (all rows at once), and a row farther than ``stray``
        from it is planned again from where it stands; the hint is the path point ``ahead``
        m on."""
        rows = np.asarray(rows, dtype=np.int64)
        goal = np.asarray(goal, dtype=np.float64)[:, :2]
        need = self._needs_plan(rows, worlds, goal, new_episode)
        if need.any():
            for n in np.flatnonzero(need).tolist():
                self._plan(int(rows[n]), worlds[n], pose[n], goal[n])
        strayed = np.empty(len(rows), dtype=np.bool_)
        _k_nearest(self._P, self._len, self.idx, rows, np.ascontiguousarray(pose[:, :2]),
                   self.WINDOW, self.stray ** 2, strayed)
        if strayed.any():
            for n in np.flatnonzero(strayed).tolist():
                self._plan(int(rows[n]), worlds[n], pose[n], goal[n])  # from where it stands
        k = np.minimum(self._len[rows] - 1, self.idx[rows] + int(round(self.ahead / self.STEP)))
        return self._P[rows, k]

    #: path points searched for the nearest one, from the last nearest on
    WINDOW = 40

    def _needs_plan(self, rows: np.ndarray, worlds: list[Any], goal: np.ndarray,
                    new_episode: np.ndarray) -> np.ndarray:
        need = (goal != self._goal[rows]).any(axis=1)
        need |= new_episode
        for n, (i, world) in enumerate(zip(rows.tolist(), worlds, strict=True)):
            if self._world[i] is not world or self._len[i] == 0:
                need[n] = True
        return need

    def _plan(self, i: int, world: Any, pose: np.ndarray, goal: np.ndarray) -> np.ndarray:
        path = plan_path(self._grid_of(world), pose[:2], goal[:2])
        if path is None:
            path = np.asarray(goal[:2], dtype=np.float64)[None].copy()
        self.idx[i], self._world[i] = 0, world
        self._goal[i] = goal[:2]
        if len(path) > self._P.shape[1]:  # room for the longest path so far
            grown = np.zeros((len(self._P), max(len(path), 2 * self._P.shape[1]), 2))
            grown[:, :self._P.shape[1]] = self._P
            self._P = grown
        self._P[i, :len(path)] = path
        self._len[i] = len(path)
        return path
