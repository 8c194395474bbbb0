"""The environments' tasks: start states, goals or references, observations, rewards, ends.

A task works on the whole batch of a :class:`~wheelgym.envs.core.WheelCore` (rows are robots)
through one compiled kernel per step (``wheelgym.tasks._kernels``); ``reset_rows`` draws row i's
episode only from ``rngs[i]``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from wheelgym.tasks._kernels import k_goal, k_track
from wheelgym.tasks.references import Circle, FigureEight, QuinticCircle

if TYPE_CHECKING:  # pragma: no cover
    from wheelgym.envs.core import WheelCore

__all__ = ["Task", "GoalTask", "TrackTask", "NavigateTask", "TASKS", "POS_CLIP"]

#: Bound of positions in the observation (m).
POS_CLIP = 12.0


class Task:
    """Base class: term names, default weights, observation layout and bounds."""

    name: ClassVar[str] = ""
    #: All term columns of the kernel, in order.
    columns: ClassVar[tuple[str, ...]] = ()
    default_weights: ClassVar[dict[str, float]] = {}

    def __init__(self, core: WheelCore, weights: Mapping[str, float] | None) -> None:
        self.core = core
        spec = core.spec
        names = self.term_names(spec)
        w = dict(self.default_weights)
        for k, v in dict(weights or {}).items():
            if k not in names:
                raise ValueError(
                    f"unknown reward_weights key {k!r} for task {self.name!r} on {spec.name}; "
                    f"valid keys: {list(names)}"
                )
            v = float(v)
            if not math.isfinite(v):
                raise ValueError(f"reward_weights[{k!r}] must be finite, got {v!r}")
            w[k] = v
        self.weights = {k: w[k] for k in names}
        self.W = np.array([self.weights.get(c, 0.0) for c in self.columns])
        self.term_index = np.array([self.columns.index(k) for k in names])
        self.names = names

    def term_names(self, spec) -> tuple[str, ...]:
        return tuple(c for c in self.columns if c != "internal_force"
                     or spec.has_internal_force)

    def _tail_bounds(self) -> tuple[list[float], list[str]]:
        spec = self.core.spec
        v, w = self.core.vclip, self.core.wclip
        return [v, v, w, *spec.feat_high], ["vx", "vy", "wz", *spec.feat_names]

    def obs_layout(self) -> tuple[list[str], np.ndarray]:
        raise NotImplementedError

    def reset_rows(self, idx: Sequence[int], rngs, options: dict | None) -> np.ndarray:
        raise NotImplementedError

    def evaluate(self) -> None:
        raise NotImplementedError

    def commit(self, rows: np.ndarray | None = None) -> None:
        """Advance the task's own state after a step (``rows``: those that were reset)."""


class GoalTask(Task):
    """Reach a goal pose; see :class:`wheelgym.envs.WheelEnv` for the tables."""

    name = "goal"
    columns = ("progress", "heading", "effort", "internal_force", "success", "overspeed",
               "collision")
    default_weights = {"progress": 1.0, "heading": 0.02, "effort": 0.01, "internal_force": 0.01,
                       "success": 10.0, "overspeed": 10.0, "collision": 10.0}
    #: Position (m) and heading (rad) tolerances of success.
    tol_pos: float = 0.1
    tol_yaw: float = 0.2
    #: Start-to-goal distance range (m).
    goal_dist: tuple[float, float] = (1.0, 3.0)
    n_rays = 0

    def __init__(self, core: WheelCore, weights: Mapping[str, float] | None) -> None:
        super().__init__(core, weights)
        N = core.num
        self.goal = np.zeros((N, 3))
        self.prev = np.zeros(N)
        self.ranges = np.zeros((N, self.n_rays))
        self.cfg = np.array([self.tol_pos, self.tol_yaw, core.spec.v_max, core.spec.w_max,
                             POS_CLIP, core.vclip, core.wclip])

    def term_names(self, spec) -> tuple[str, ...]:
        return tuple(n for n in super().term_names(spec) if n != "collision")

    def obs_layout(self) -> tuple[list[str], np.ndarray]:
        tail, tnames = self._tail_bounds()
        names = ["goal_x_b", "goal_y_b", "cos_dyaw", "sin_dyaw", *tnames]
        high = [POS_CLIP, POS_CLIP, 1.0, 1.0, *tail]
        return names, np.array(high)

    def reset_rows(self, idx, rngs, options):
        poses = np.zeros((len(idx), 3))
        for n, i in enumerate(idx):
            rng = rngs[i]
            start = np.array([*rng.uniform(-1.0, 1.0, 2), rng.uniform(-math.pi, math.pi)])
            d = rng.uniform(*self.goal_dist)
            a = rng.uniform(-math.pi, math.pi)
            self.goal[i] = (start[0] + d * math.cos(a), start[1] + d * math.sin(a),
                            rng.uniform(-math.pi, math.pi))
            poses[n] = start
            self.prev[i] = d
        return poses

    def evaluate(self) -> None:
        c = self.core
        k_goal(c.B, c.F, c.m, self.goal, self.prev, self.ranges, self.cfg, c.fclip, self.W,
               c.obs, c.terms)

    def target_pose(self) -> np.ndarray:
        return self.goal


class NavigateTask(GoalTask):
    """Reach a goal position in an arena with obstacles, sensing them with range rays."""

    name = "navigate"
    default_weights = {**GoalTask.default_weights, "heading": 0.0}
    tol_pos = 0.25
    tol_yaw = math.inf
    n_rays = 16
    max_range = 3.0

    def __init__(self, core: WheelCore, weights: Mapping[str, float] | None,
                 range_backend: str = "analytic") -> None:
        from wheelgym.world import Arena

        super().__init__(core, weights)
        if range_backend not in ("analytic", "pymunk"):
            raise ValueError(
                f"range_backend must be one of ['analytic', 'pymunk'], got {range_backend!r}"
            )
        self.backend = range_backend
        self.arena = Arena()
        N = core.num
        self.circles = np.zeros((N, self.arena.max_circles, 3))
        self.nc = np.zeros(N, dtype=np.int64)
        self.segs = np.zeros((N, self.arena.max_segments, 4))
        self.ns = np.zeros(N, dtype=np.int64)
        self.clear = np.zeros(N)
        self.spaces: list[Any] = [None] * N
        self.worlds: list[Any] = [None] * N

    def term_names(self, spec) -> tuple[str, ...]:
        return Task.term_names(self, spec)

    def obs_layout(self):
        names, high = super().obs_layout()
        names += [f"range_{k}" for k in range(self.n_rays)]
        return names, np.concatenate([high, np.full(self.n_rays, self.max_range)])

    def obs_low(self) -> np.ndarray:
        _, high = self.obs_layout()
        low = -high
        low[-self.n_rays:] = 0.0
        return low

    def reset_rows(self, idx, rngs, options):
        from wheelgym.world import build_space

        poses = np.zeros((len(idx), 3))
        for n, i in enumerate(idx):
            w = self.arena.generate(rngs[i], self.core.spec.radius)
            self.worlds[i] = w
            self.nc[i] = len(w.circles)
            self.circles[i, : self.nc[i]] = w.circles
            self.ns[i] = len(w.segments)
            self.segs[i, : self.ns[i]] = w.segments
            self.goal[i] = w.goal
            self.prev[i] = math.hypot(*(w.goal[:2] - w.start[:2]))
            if self.backend == "pymunk":
                self.spaces[i] = build_space(w)
            poses[n] = w.start
        return poses

    def sense(self) -> None:
        """Range readings and collision flags at the current poses."""
        from wheelgym.world import k_clearance, k_ranges, pymunk_ranges

        c = self.core
        if self.backend == "analytic":
            k_ranges(c.pose, self.circles, self.nc, self.segs, self.ns, self.max_range,
                     self.ranges)
        else:
            for i in range(c.num):
                pymunk_ranges(self.spaces[i], c.pose[i], self.n_rays, self.max_range,
                              self.ranges[i])
        k_clearance(c.pose, self.circles, self.nc, self.segs, self.ns, self.clear)
        np.less(self.clear, c.spec.radius, out=c.coll)

    def evaluate(self) -> None:
        self.sense()
        super().evaluate()


class TrackTask(Task):
    """Follow a reference trajectory (circle, figure-eight or the paper's quintic circle)."""

    name = "track"
    columns = ("position", "heading", "effort", "internal_force", "overspeed", "lost")
    default_weights = {"position": 1.0, "heading": 0.1, "effort": 0.01, "internal_force": 0.01,
                       "overspeed": 10.0, "lost": 10.0}
    #: Preview offsets (control steps) of the reference points in the observation.
    preview_steps = np.array([10, 20, 30], dtype=np.int64)
    #: Distance (m) beyond which the robot is lost (the episode ends).
    lost_dist = 1.0
    #: A step counts as success (``is_success``) within this distance (m).
    tol_pos = 0.05
    references = ("circle", "figure_eight", "quintic_circle")

    def __init__(self, core: WheelCore, weights: Mapping[str, float] | None) -> None:
        super().__init__(core, weights)
        N = core.num
        self.L = core.horizon + int(self.preview_steps[-1]) + 2
        self.ref = np.zeros((N, self.L, 6))
        self.ref_rate = np.zeros((N, self.L, 3))
        self.kstep = np.zeros(N, dtype=np.int64)
        self.kind = [""] * N
        self.cfg = np.array([core.spec.v_max, core.spec.w_max, self.lost_dist, self.tol_pos,
                             POS_CLIP, core.vclip, core.wclip])

    def obs_layout(self):
        tail, tnames = self._tail_bounds()
        v, w = self.core.vclip, self.core.wclip
        names = ["ref_x_b", "ref_y_b", "cos_dyaw", "sin_dyaw", "ref_vx", "ref_vy", "ref_wz"]
        high = [POS_CLIP, POS_CLIP, 1.0, 1.0, v, v, w]
        for q in self.preview_steps:
            names += [f"preview_{q}_x_b", f"preview_{q}_y_b"]
            high += [POS_CLIP, POS_CLIP]
        return names + tnames, np.array(high + tail)

    def _draw_reference(self, rng: np.random.Generator):
        """A random reference (kind, object, time offset = random phase, s)."""
        vmax = 0.5 * self.core.spec.twist_max[0]
        kind = self.references[int(rng.integers(len(self.references)))]
        cw = bool(rng.integers(2))
        if kind == "circle":
            ref = Circle(radius=rng.uniform(0.8, 2.0), speed=rng.uniform(0.4, 1.0) * vmax,
                         clockwise=cw)
            t0 = rng.uniform(0.0, ref.duration)
        elif kind == "figure_eight":
            size = rng.uniform(1.0, 2.0)
            # lap length of the eight is about 6.1 size; mean speed up to vmax
            ref = FigureEight(size=size, period=6.1 * size / (rng.uniform(0.4, 1.0) * vmax))
            t0 = rng.uniform(0.0, ref.duration)
        else:
            ref = QuinticCircle(radius=rng.uniform(0.8, 1.5), duration=rng.uniform(20.0, 40.0))
            t0 = 0.0
        return kind, ref, t0

    def reset_rows(self, idx, rngs, options):
        dt = self.core.dt
        t = np.arange(self.L) * dt
        poses = np.zeros((len(idx), 3))
        for n, i in enumerate(idx):
            rng = rngs[i]
            kind, ref, t0 = self._draw_reference(rng)
            pose, twist, rate = ref.evaluate(t + t0)
            # random rigid placement: rotate by th about the origin, then shift by (ox, oy)
            th = rng.uniform(-math.pi, math.pi)
            ox, oy = rng.uniform(-1.0, 1.0, 2)
            c, s = math.cos(th), math.sin(th)
            out = self.ref[i]
            out[:, 0] = c * pose[:, 0] - s * pose[:, 1] + ox
            out[:, 1] = s * pose[:, 0] + c * pose[:, 1] + oy
            out[:, 2] = pose[:, 2] + th
            out[:, 3:6] = twist
            self.ref_rate[i] = rate
            self.kind[i] = kind
            self.kstep[i] = 0
            poses[n] = out[0, :3]
        return poses

    def evaluate(self) -> None:
        c = self.core
        k_track(c.B, c.F, c.m, self.ref, self.kstep, self.preview_steps, self.cfg, c.fclip,
                self.W, c.obs, c.terms)

    def advance(self) -> None:
        """Move every row's reference index one control step on (before integrating)."""
        self.kstep += 1

    def reference_at(self, rows=slice(None)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Reference pose, twist and twist rate at each row's current index."""
        k = np.minimum(self.kstep[rows], self.L - 1)
        r = np.arange(self.core.num)[rows]
        return self.ref[r, k, :3], self.ref[r, k, 3:6], self.ref_rate[r, k]

    def target_pose(self) -> np.ndarray:
        return self.reference_at()[0]


TASKS: dict[str, type[Task]] = {"goal": GoalTask, "track": TrackTask, "navigate": NavigateTask}
