"""pygame drawing shared by every wheelgym environment (``rgb_array`` and ``human``).

The frame is ``SIZE x SIZE`` pixels (``rgb_array`` returns ``(SIZE, SIZE, 3)`` uint8). It shows
the platform footprint, each wheel at its steering angle, an arrow per motor proportional to
its torque (drive torques along the wheel, steering torques across it), the trail, the goal
pose or the reference path, obstacles and range rays (navigate), and a readout of time, speed,
yaw rate and motor energy. Headless use needs no display: without ``DISPLAY`` the SDL dummy
video driver is selected before pygame starts.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from wheelgym.tasks.view import BatchView, RobotConstants

if TYPE_CHECKING:  # pragma: no cover
    from wheelgym.tasks.tasks import Task

__all__ = ["Renderer", "RenderView", "SIZE"]

#: Frame width and height (pixels).
SIZE = 600
_TRAIL = 600

_BG = (248, 248, 245)
_GRID = (225, 225, 220)
_BODY = (120, 150, 190)
_EDGE = (30, 40, 60)
_WHEEL = (40, 40, 40)
_TRAIL_C = (240, 150, 40)
_GOAL = (40, 170, 80)
_REF = (70, 110, 230)
_OBST = (110, 110, 110)
_RAY = (235, 120, 120)
_DRIVE = (210, 30, 30)
_STEER = (150, 40, 200)
_TEXT = (20, 20, 20)


class RobotDrawing(RobotConstants, Protocol):
    """The robot's constants and geometry the renderer reads (the envs' robot spec has them)."""

    @property
    def n_motor(self) -> int:
        """Motors (0 for kinematic robots)."""

    @property
    def n_steer_motor(self) -> int:
        """The last ``n_steer_motor`` motors steer wheels 0, 1, ...; the others drive them."""

    @property
    def geometry(self) -> Callable[[Any], dict]:
        """``geometry(params)``: footprint polygon, wheel radius and width."""

    @property
    def wheels(self) -> Callable[[np.ndarray, Any], np.ndarray]:
        """``wheels(x, params)``: each wheel's body-frame position and angle ``(k, 3)``."""


class RenderView(BatchView, Protocol):
    """The batch as the renderer sees it: the task's view plus the task itself, the state and
    the per-step buffers it draws (the environments' core implements it). The core's state
    buffer ``X`` changes identity every step, so the renderer reads it when it draws."""

    #: Task name and object (goal or reference, obstacles, range readings).
    task_name: str
    task: Task
    #: State ``(N, nx)``, motor torques ``(N, m)``, input upper bounds ``(N, m)``.
    X: np.ndarray
    U: np.ndarray
    HI: np.ndarray
    #: Body twist ``(N, 3)``, motor work ``(N,)`` (J), tracking error ``(N,)`` (m).
    twist: np.ndarray
    energy: np.ndarray
    err: np.ndarray
    #: Control steps since each row's reset ``(N,)``.
    steps: np.ndarray
    #: Each row's parameters (the drawn ones under randomisation).
    params_rows: Sequence[Any]

    @property
    def spec(self) -> RobotDrawing:
        """The robot's constants and geometry."""


def _headless() -> None:
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")


class Renderer:
    """Draws row ``i`` of a batch of robots (a :class:`RenderView`: the envs' core)."""

    def __init__(self, core: RenderView, mode: str, fps: int = 20) -> None:
        _headless()
        import pygame

        self.pg = pygame
        self.core = core
        self.mode = mode
        self.fps = fps
        pygame.font.init()  # no pygame.init(): the audio driver is not wanted
        if mode == "human":
            pygame.display.init()
        self.font = pygame.font.Font(None, 20)
        if mode == "human":
            self.window = pygame.display.set_mode((SIZE, SIZE))
            pygame.display.set_caption(f"wheelgym {core.spec.name} {core.task_name}")
            self.clock = pygame.time.Clock()
        self.surface = pygame.Surface((SIZE, SIZE))
        self.trail: list[tuple[float, float]] = []
        self.center = np.zeros(2)
        self.scale = 60.0
        self._view_set = False
        self._path_key: tuple[int, int] | None = None
        self._path = np.zeros((0, 2))

    def reset(self) -> None:
        self.trail = []
        self._view_set = False

    def _set_view(self, i: int) -> None:
        c = self.core
        task = c.task
        if c.task_name == "navigate":  # the whole arena (a map's bounds, or the random one's)
            self.center = np.array(getattr(task.arena, "center", (0.0, 0.0)), dtype=float)
            half = task.arena.half_size + 0.3
        else:
            pts = [c.pose[i, :2]]
            if c.task_name == "track":
                pts.append(self._ref_path(i))
            else:
                pts.append(task.goal[i, :2])
            pts = np.vstack([np.atleast_2d(p) for p in pts])
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            self.center = 0.5 * (lo + hi)
            half = max(2.0, 0.5 * float(np.max(hi - lo)) + 1.0)
        self.scale = SIZE / (2.0 * half)
        self._view_set = True

    def _ref_path(self, i: int) -> np.ndarray:
        """Row i's reference path every 4 steps, evaluated once per episode."""
        obj = self.core.task.objs[i]
        if self._path_key != (i, id(obj)):
            self._path = self.core.task.path(i, stride=4)
            self._path_key = (i, id(obj))
        return self._path

    def _px(self, x: float, y: float) -> tuple[int, int]:
        return (int(round(SIZE / 2 + (x - self.center[0]) * self.scale)),
                int(round(SIZE / 2 - (y - self.center[1]) * self.scale)))

    def render(self, i: int = 0) -> Any:
        pg = self.pg
        c = self.core
        if not self._view_set:
            self._set_view(i)
        s = self.surface
        s.fill(_BG)
        # grid every metre
        half = SIZE / (2 * self.scale)
        for gx in range(int(math.floor(self.center[0] - half)), int(self.center[0] + half) + 1):
            pg.draw.line(s, _GRID, self._px(gx, self.center[1] - half),
                         self._px(gx, self.center[1] + half))
        for gy in range(int(math.floor(self.center[1] - half)), int(self.center[1] + half) + 1):
            pg.draw.line(s, _GRID, self._px(self.center[0] - half, gy),
                         self._px(self.center[0] + half, gy))
        x, y, yaw = (float(v) for v in c.pose[i])
        task = c.task
        if c.task_name == "navigate":
            for poly in getattr(task.arena, "polygons", ()):  # a map's solid areas
                pg.draw.polygon(s, _OBST, [self._px(px, py) for px, py in poly])
            for k in range(task.nc[i]):
                cx, cy, r = task.circles[i, k]
                pg.draw.circle(s, _OBST, self._px(cx, cy), max(1, int(r * self.scale)))
            for k in range(task.ns[i]):
                a, b, e, f = task.segs[i, k]
                pg.draw.line(s, _EDGE, self._px(a, b), self._px(e, f), 3)
            for k in range(task.n_rays):
                ang = yaw + 2.0 * math.pi * k / task.n_rays
                d = float(task.ranges[i, k])
                pg.draw.line(s, _RAY, self._px(x, y),
                             self._px(x + d * math.cos(ang), y + d * math.sin(ang)), 1)
        if c.task_name == "track":
            path = [self._px(px, py) for px, py in self._ref_path(i)]
            pg.draw.lines(s, _REF, False, path, 2)
            rp = task.reference_at()[0][i]
            self._pose_marker(rp, _REF)
        else:
            self._pose_marker(task.goal[i], _GOAL)
            pg.draw.circle(s, _GOAL, self._px(*task.goal[i, :2]),
                           max(2, int(task.tol_pos * self.scale)), 1)
        # trail
        self.trail.append((x, y))
        del self.trail[:-_TRAIL]
        if len(self.trail) > 1:
            pg.draw.lines(s, _TRAIL_C, False, [self._px(*p) for p in self.trail], 2)
        self._robot(i, x, y, yaw)
        self._readout(i)
        if self.mode == "human":
            pg.event.pump()
            self.window.blit(s, (0, 0))
            pg.display.flip()
            self.clock.tick(self.fps)
            return None
        return np.transpose(pg.surfarray.array3d(s), (1, 0, 2)).copy()

    def _pose_marker(self, pose: np.ndarray, color) -> None:
        pg = self.pg
        px, py, pyaw = (float(v) for v in pose)
        pg.draw.circle(self.surface, color, self._px(px, py), 5)
        pg.draw.line(self.surface, color, self._px(px, py),
                     self._px(px + 0.3 * math.cos(pyaw), py + 0.3 * math.sin(pyaw)), 3)

    def _world(self, x, y, yaw, bx, by):
        c, s = math.cos(yaw), math.sin(yaw)
        return self._px(x + c * bx - s * by, y + s * bx + c * by)

    def _robot(self, i: int, x: float, y: float, yaw: float) -> None:
        pg = self.pg
        c = self.core
        params = c.params_rows[i]
        geom = c.spec.geometry(params)
        poly = [self._world(x, y, yaw, bx, by) for bx, by in geom["footprint"]]
        pg.draw.polygon(self.surface, _BODY, poly)
        pg.draw.polygon(self.surface, _EDGE, poly, 2)
        pg.draw.line(self.surface, _EDGE, self._world(x, y, yaw, 0.0, 0.0),
                     self._world(x, y, yaw, 0.25, 0.0), 3)
        wheels = c.spec.wheels(c.X[i], params)
        r = max(float(geom["wheel_radius"]), 0.03)
        w = max(float(geom["wheel_width"]), 0.02) / 2
        tau = c.U[i]
        tmax = np.maximum(np.abs(c.HI[i]), 1e-9)
        ns = c.spec.n_steer_motor
        nd = c.spec.n_motor - ns  # drive motors: wheels 0..nd-1; steer motors nd + k: wheel k
        for k, (bx, by, ang) in enumerate(wheels):
            ca, sa = math.cos(ang), math.sin(ang)
            corners = [(bx + ca * px - sa * py, by + sa * px + ca * py)
                       for px, py in ((r, w), (-r, w), (-r, -w), (r, -w))]
            pg.draw.polygon(self.surface, _WHEEL, [self._world(x, y, yaw, *q) for q in corners])
            if k < nd:
                f = float(tau[k] / tmax[k]) * 0.35
                pg.draw.line(self.surface, _DRIVE, self._world(x, y, yaw, bx, by),
                             self._world(x, y, yaw, bx + f * ca, by + f * sa), 3)
            if k < ns:
                f = float(tau[nd + k] / tmax[nd + k]) * 0.25
                pg.draw.line(self.surface, _STEER, self._world(x, y, yaw, bx, by),
                             self._world(x, y, yaw, bx - f * sa, by + f * ca), 2)

    def _readout(self, i: int) -> None:
        c = self.core
        v = math.hypot(c.twist[i, 0], c.twist[i, 1])
        lines = [f"{c.spec.name}  {c.task_name}  t = {c.steps[i] * c.dt:5.2f} s",
                 f"speed {v:4.2f} m/s   yaw rate {c.twist[i, 2]:+5.2f} rad/s",
                 f"energy {c.energy[i]:7.1f} J   error {c.err[i]:5.2f} m"]
        for k, line in enumerate(lines):
            self.surface.blit(self.font.render(line, True, _TEXT), (8, 6 + 18 * k))

    def close(self) -> None:
        if self.mode == "human":
            self.pg.display.quit()
