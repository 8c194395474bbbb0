"""Follow a Reeds-Shepp path with a car-like robot (bicycle or Ackermann), forwards and back.

:class:`CarTracker` plans a :func:`~wheelgym.kinematics.reeds_shepp.reeds_shepp_path` path to the
goal with a turning radius ``radius_factor`` times the model's minimum
``R_min = l / tan(psi_max)`` (the margin is the feedback's steering authority), splits it at the
cusps into runs of one driving direction, and follows each run with the rear-wheel feedback law
(Samson; Paden et al. 2016, "A survey of motion planning and control techniques for
self-driving urban vehicles", eq. (13) written per unit arc length)::

    kappa_cmd = kappa_r cos(theta_e) / (1 - kappa_r e) - k_theta theta_e
                - k_e e sin(theta_e) / theta_e

with ``e`` the signed lateral offset of the rear axle from the run (left positive) and
``theta_e`` the heading error. The models' reference point is the rear axle and
``yawdot = v tan(psi) / l``, so the rear axle moves like a unicycle whose curvature is
``tan(psi) / l`` per metre of *signed* travel. A backward run is followed as a forward one by a
virtual car facing ``yaw + pi`` (its lateral offset is ``-e``, its path curvature per metre
driven ``direction * kappa``), and the steering angle is ``psi = atan(l kappa_cmd direction)``.
Linearised, ``e'' + k_theta e' + k_e e = 0`` in arc length: ``k_e = w^2``, ``k_theta = 2 zeta w``.

The speed is the cruise speed, slowed near the end of each run
(``|v| = min(v_cruise, max(v_min, k_v d), d / dt)``, ``d`` the arc length left) so that the
robot stops on each cusp and on the goal; at a cusp the robot stops and (Ackermann) turns its
steering to the next run's angle before moving. It replans from where it is when it drifts off
the run (``|e| > replan_offset`` or ``|theta_e| > replan_heading``) and when it stops at the end
of the path outside ``tol_pos`` / ``tol_yaw`` of the goal.

Units:

| quantity              | unit  | note                                                   |
|-----------------------|-------|--------------------------------------------------------|
| pose ``(x, y, yaw)``  | m, m, rad | rear axle; Ackermann states add the steering ``psi`` (rad) |
| ``v``                 | m/s   | signed speed                                           |
| ``delta``             | rad   | steering angle (the bicycle's ``psi`` input)          |
| ``psidot``            | rad/s | steering rate (Ackermann input)                        |
| ``w``                 | rad/s | heading rate (bicycle ``VehicleSpeedHeadingRate`` input) |
| ``k_e``, ``k_theta``  | 1/m^2, 1/m | feedback gains per unit arc length                 |
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from wheelgym.kinematics.reeds_shepp import ReedsSheppPath, Segment, reeds_shepp_path, sample
from wheelgym.models.elementwise import wrap_angle

__all__ = ["CarLimits", "CarCommand", "CarTracker", "TrackFrame", "rear_wheel_steering",
           "min_turning_radius"]

_MODES = ("VehicleSpeedSteeringAngle", "VehicleSpeedHeadingRate", "VehicleSpeedSteeringRate")


def min_turning_radius(params: Any) -> float:
    """Smallest turning radius (m) of a robot with parameters ``params``: ``l / tan(psi_max)``
    for the car-like robots (``wheelbase`` and ``max_steering_angle``: the rear axle's circle at
    full lock), 0 for robots that turn in place."""
    if not hasattr(params, "max_steering_angle"):
        return 0.0
    return float(params.wheelbase) / math.tan(float(params.max_steering_angle))


def rear_wheel_steering(e: float, theta_e: float, kappa_ref: float, direction: int,
                        wheelbase: float, k_e: float, k_theta: float) -> float:
    """Steering angle (rad, not yet clipped) of the rear-wheel feedback law (module docstring).

    Args:
        e: lateral offset (m) of the rear axle, left of the path's tangent positive.
        theta_e: heading error ``yaw - yaw_ref`` (rad, wrapped).
        kappa_ref: path curvature ``d yaw / d s`` per signed metre (1/m).
        direction: ``+1`` driving forwards, ``-1`` backwards.
        wheelbase: ``l`` (m).
        k_e: lateral gain (1/m^2); ``k_theta``: heading gain (1/m).
    """
    # the virtual car facing yaw + pi when reversing: offset -e, curvature direction * kappa
    ev, kv = direction * e, direction * kappa_ref
    den = max(1.0 - kv * ev, 0.2)  # 1 - kappa e: distance to the centre of curvature
    sinc = math.sin(theta_e) / theta_e if abs(theta_e) > 1e-9 else 1.0
    kappa = kv * math.cos(theta_e) / den - k_theta * theta_e - k_e * ev * sinc
    return math.atan(wheelbase * kappa * direction)  # tan(psi) / l = kappa * direction


@dataclasses.dataclass(frozen=True)
class CarLimits:
    """What the tracker must respect about the car.

    | name               | unit  | meaning                                                |
    |--------------------|-------|--------------------------------------------------------|
    | wheelbase          | m     | axle distance ``l``                                    |
    | max_steering_angle | rad   | ``abs(psi)`` limit                                     |
    | speed_range        | m/s   | ``(low, high)`` with ``low < 0 < high`` (it reverses)  |
    | max_steering_rate  | rad/s | ``abs(psidot)`` limit; ``None`` when the angle is commanded |
    """

    wheelbase: float
    max_steering_angle: float
    speed_range: tuple[float, float]
    max_steering_rate: float | None = None

    def __post_init__(self) -> None:
        if not (self.wheelbase > 0 and 0 < self.max_steering_angle < math.pi / 2):
            raise ValueError(f"bad wheelbase or steering limit in {self!r}")
        lo, hi = self.speed_range
        if not lo < 0 < hi:
            raise ValueError(f"speed_range must allow both directions, got {self.speed_range!r}")
        if self.max_steering_rate is not None and not self.max_steering_rate > 0:
            raise ValueError(f"max_steering_rate must be positive, got {self.max_steering_rate!r}")

    @property
    def min_radius(self) -> float:
        """Smallest turning radius ``l / tan(psi_max)`` (m)."""
        return min_turning_radius(self)


class CarCommand(NamedTuple):
    """One tracking command.

    Attributes:
        v: signed speed (m/s), inside the speed range.
        delta: steering angle wanted (rad), inside the steering limit.
        psidot: steering rate (rad/s) turning the current angle toward ``delta`` within the rate
            limit (``(delta - psi) / dt`` without one).
        done: the robot stands on the goal (within ``tol_pos`` and ``tol_yaw``).
    """

    v: float
    delta: float
    psidot: float
    done: bool


class TrackFrame(NamedTuple):
    """Where the car stands against the run it follows: the inputs of the feedback law at the
    last :meth:`CarTracker.command` (all zero, ``ahead`` the goal, when no run is followed).

    | field     | unit | meaning                                                        |
    |-----------|------|----------------------------------------------------------------|
    | offset    | m    | ``e``: the rear axle left of the run's tangent (positive)      |
    | heading   | rad  | ``theta_e = yaw - yaw_ref``, wrapped                           |
    | curvature | 1/m  | ``kappa_ref`` per signed metre, as the law reads it            |
    | direction | -    | ``+1`` forwards, ``-1`` backwards, ``0`` no run                |
    | remaining | m    | arc length left to the run's end (the next cusp or the goal)   |
    | ahead     | m, m | world point ``lookahead`` m on along the run (not past its end) |
    """

    offset: float
    heading: float
    curvature: float
    direction: int
    remaining: float
    ahead: tuple[float, float]


class _Run(NamedTuple):
    """Samples of one direction of travel (between cusps)."""

    xy: np.ndarray  # (n, 2)
    yaw: np.ndarray  # (n,)
    kappa: np.ndarray  # (n,) curvature per signed metre
    s: np.ndarray  # (n,) arc length from the run's start
    direction: int


class CarTracker:
    """Plan a Reeds-Shepp path to a goal pose and follow it (module docstring for the laws).

    Args:
        limits: the car's :class:`CarLimits`.
        input_mode: the model's input mode for :meth:`action`:
            ``VehicleSpeedSteeringAngle`` ``(v, psi)``, ``VehicleSpeedHeadingRate`` ``(v, w)``
            or ``VehicleSpeedSteeringRate`` ``(v, psidot)`` (needs ``max_steering_rate``).
        radius_factor: plan radius over ``limits.min_radius`` (> 1: steering margin).
        cruise_speed: largest ``|v|`` (m/s), also cut to the speed range.
        k_e: lateral gain (1/m^2); ``k_theta``: heading gain (1/m).
        k_v: slow-down gain (1/s) near a cusp or the goal; ``v_min``: creeping speed (m/s).
        step: sample spacing of the path (m).
        replan_offset: lateral offset (m) that triggers a replan; ``replan_heading`` (rad).
        tol_pos: goal position tolerance (m) at the end of the path; ``tol_yaw`` (rad).
        steer_tol: steering error (rad) allowed before moving off at a cusp (Ackermann).
        max_replans: replans allowed per goal.
        planner: ``planner(pose) -> ReedsSheppPath`` from the rear-axle pose ``(x, y, yaw)``
            to wherever the caller's goal lies (an obstacle-aware plan, e.g.
            ``wheelgym.planning``'s hybrid A*); the plan's end pose becomes the goal of
            :meth:`reset`'s and the replans' tolerance checks. Default: the Reeds-Shepp path
            straight to the goal pose.
    """

    def __init__(
        self,
        limits: CarLimits,
        input_mode: str = "VehicleSpeedSteeringAngle",
        *,
        radius_factor: float = 1.25,
        cruise_speed: float = 0.8,
        k_e: float = 4.0,
        k_theta: float = 4.0,
        k_v: float = 1.5,
        v_min: float = 0.05,
        step: float = 0.02,
        replan_offset: float = 0.15,
        replan_heading: float = 0.5,
        tol_pos: float = 0.05,
        tol_yaw: float = 0.1,
        steer_tol: float = 0.05,
        max_replans: int = 10,
        planner: Callable[[np.ndarray], ReedsSheppPath] | None = None,
    ) -> None:
        if input_mode not in _MODES:
            raise ValueError(f"input_mode must be one of {_MODES}, got {input_mode!r}")
        if input_mode == "VehicleSpeedSteeringRate" and limits.max_steering_rate is None:
            raise ValueError("VehicleSpeedSteeringRate needs limits.max_steering_rate")
        if not radius_factor >= 1.0:
            raise ValueError(f"radius_factor must be >= 1, got {radius_factor!r}")
        self.limits = limits
        self.input_mode = input_mode
        self.radius = radius_factor * limits.min_radius
        lo, hi = limits.speed_range
        self.v_fwd = min(cruise_speed, hi)
        self.v_back = min(cruise_speed, -lo)
        self.k_e, self.k_theta, self.k_v, self.v_min = k_e, k_theta, k_v, v_min
        self.step = step
        self.replan_offset, self.replan_heading = replan_offset, replan_heading
        self.tol_pos, self.tol_yaw = tol_pos, tol_yaw
        self.steer_tol = steer_tol
        self.max_replans = max_replans
        self.planner = planner
        self.path: ReedsSheppPath | None = None
        self.goal: tuple[float, float, float] | None = None
        self.replans = 0
        self._runs: list[_Run] = []
        self._run = 0
        self._i = 0
        self._moving = False
        self._delta = 0.0  # last steering command (the state of a bicycle has none)
        #: the feedback law's inputs at the last command (:class:`TrackFrame`)
        self.frame = self._idle_frame()
        #: the arc length (m) ``frame.ahead`` lies on from the nearest sample
        self.lookahead = 1.0

    @classmethod
    def from_model(cls, model: Any, **kwargs: Any) -> CarTracker:
        """A tracker for a :class:`~wheelgym.models.Bicycle` or
        :class:`~wheelgym.models.Ackermann` (its parameters and input mode)."""
        p = model.params
        rate = getattr(p, "max_steering_rate", None) if model.state_dim > 3 else None
        limits = CarLimits(p.wheelbase, p.max_steering_angle, tuple(p.speed_range), rate)
        return cls(limits, model.input_mode, **kwargs)

    # ------------------------------------------------------------------ planning
    def reset(self, state: Any, goal: Any) -> ReedsSheppPath:
        """Plan from ``state`` to ``goal`` ``(x, y, yaw)`` and start following; the plan."""
        g = np.asarray(goal, dtype=np.float64).reshape(-1)
        self.goal = (float(g[0]), float(g[1]), float(g[2]))
        self.replans = 0
        state = np.asarray(state, dtype=np.float64).reshape(-1)
        self._delta = float(state[3]) if state.shape[0] > 3 else 0.0
        return self._plan(state)

    def _plan(self, state: np.ndarray) -> ReedsSheppPath:
        assert self.goal is not None
        if self.planner is not None:
            path = self.planner(state[:3])
            self.goal = tuple(float(v) for v in path.goal)
        else:
            path = reeds_shepp_path(state[:3], self.goal, self.radius)
        self.path = path
        self._runs = self._split(path)
        self._run, self._i, self._moving = 0, 0, False
        return path

    def _split(self, path: ReedsSheppPath) -> list[_Run]:
        """Sample each run (maximal sequence of segments of one direction) separately."""
        runs: list[_Run] = []
        pose: Any = path.start
        group: list[Segment] = []
        for seg in (*path.segments, None):
            if group and (seg is None or seg.direction != group[-1].direction):
                sub = ReedsSheppPath(tuple(group), path.radius, pose, pose)
                smp = sample(sub, pose, self.step)
                runs.append(_Run(smp.poses[:, :2].copy(), smp.poses[:, 2].copy(),
                                 smp.curvature.copy(), smp.s.copy(), group[0].direction))
                pose = tuple(smp.poses[-1])
                group = []
            if seg is not None:
                group.append(seg)
        return runs

    # ------------------------------------------------------------------ control
    def command(self, state: Any, dt: float = 0.05) -> CarCommand:
        """The command for the current ``state`` (``(x, y, yaw)``, Ackermann ``(x, y, yaw,
        psi)``), held for ``dt`` seconds."""
        if self.goal is None:
            raise RuntimeError("call reset(state, goal) before command()")
        x = np.asarray(state, dtype=np.float64).reshape(-1)
        psi = float(x[3]) if x.shape[0] > 3 else self._delta
        self.frame = self._idle_frame()  # until a run is followed below
        for _ in range(len(self._runs) + 2):  # finished runs are skipped within one call
            if self._run >= len(self._runs):
                if self._at_goal(x) or self.replans >= self.max_replans:
                    return self._out(0.0, psi, psi, dt, True)
                self.replans += 1
                self._plan(x)
                continue
            out = self._follow(x, psi, dt)
            if out is not None:
                return out
        return self._out(0.0, psi, psi, dt, self._at_goal(x))

    def action(self, state: Any, dt: float = 0.05) -> np.ndarray:
        """:meth:`command` as the model's input vector in ``input_mode`` (see the class)."""
        c = self.command(state, dt)
        if self.input_mode == "VehicleSpeedSteeringAngle":
            return np.array([c.v, c.delta])
        if self.input_mode == "VehicleSpeedHeadingRate":
            return np.array([c.v, c.v * math.tan(c.delta) / self.limits.wheelbase])
        return np.array([c.v, c.psidot])

    def _idle_frame(self) -> TrackFrame:
        g = self.goal if self.goal is not None else (0.0, 0.0)
        return TrackFrame(0.0, 0.0, 0.0, 0, 0.0, (float(g[0]), float(g[1])))

    def _at_goal(self, x: np.ndarray) -> bool:
        g = self.goal
        assert g is not None
        return (math.hypot(x[0] - g[0], x[1] - g[1]) <= self.tol_pos
                and abs(wrap_angle(x[2] - g[2])) <= self.tol_yaw)

    def _out(self, v: float, delta: float, psi: float, dt: float, done: bool) -> CarCommand:
        lim = self.limits
        delta = min(max(delta, -lim.max_steering_angle), lim.max_steering_angle)
        rate = (delta - psi) / dt
        if lim.max_steering_rate is not None:
            rate = min(max(rate, -lim.max_steering_rate), lim.max_steering_rate)
        self._delta = delta if lim.max_steering_rate is None else psi + rate * dt
        lo, hi = lim.speed_range
        return CarCommand(min(max(v, lo), hi), delta, rate, done)

    def _follow(self, x: np.ndarray, psi: float, dt: float) -> CarCommand | None:
        """Track the current run; ``None`` when it has just ended (the caller moves on)."""
        run = self._runs[self._run]
        n = run.s.shape[0]
        # nearest sample ahead of the last one (within 0.5 m: the index only moves forward)
        j1 = min(n, self._i + max(2, int(0.5 / self.step)))
        d2 = (run.xy[self._i:j1, 0] - x[0]) ** 2 + (run.xy[self._i:j1, 1] - x[1]) ** 2
        i = self._i + int(np.argmin(d2))
        self._i = i
        yr = float(run.yaw[i])
        dx, dy = x[0] - run.xy[i, 0], x[1] - run.xy[i, 1]
        c, s = math.cos(yr), math.sin(yr)
        sign = run.direction
        along = sign * (c * dx + s * dy)  # ahead of the sample in the driving direction
        e = -s * dx + c * dy  # lateral offset, left of the path's tangent
        th = wrap_angle(x[2] - yr)  # heading error (the same for the virtual car facing yaw + pi)
        remaining = float(run.s[-1] - run.s[i]) - along
        if remaining <= 1e-3 or (i == n - 1 and along >= 0.0):
            self._run += 1
            self._i = 0
            self._moving = False
            return None
        if abs(e) > self.replan_offset or abs(th) > self.replan_heading:
            if self.replans < self.max_replans:
                self.replans += 1
                self._plan(x)
                return self._follow(x, psi, dt) if self._runs else None
        # curvature feed-forward; with a steering-rate limit, read it ahead by half the
        # distance covered in 0.3 s, so the lagging steering turns around the segment joints
        lim = self.limits
        speed = self.v_fwd if sign > 0 else self.v_back
        ahead = int(0.5 * speed * 0.3 / self.step) if lim.max_steering_rate is not None else 0
        k_ref = float(run.kappa[min(n - 1, i + ahead)])
        k = min(n - 1, i + int(round(self.lookahead / self.step)))
        self.frame = TrackFrame(e, th, k_ref, sign, remaining,
                                (float(run.xy[k, 0]), float(run.xy[k, 1])))
        delta = rear_wheel_steering(e, th, k_ref, sign, lim.wheelbase, self.k_e, self.k_theta)
        delta = min(max(delta, -lim.max_steering_angle), lim.max_steering_angle)
        # at the start of a run, stand until the steering has turned (Ackermann)
        if not self._moving:
            if lim.max_steering_rate is not None and abs(delta - psi) > self.steer_tol:
                return self._out(0.0, delta, psi, dt, False)
            self._moving = True
        v = min(speed, max(self.v_min, self.k_v * remaining), remaining / dt)
        if lim.max_steering_rate is not None:  # slow while the steering lags far behind
            v *= max(0.3, 1.0 - abs(delta - psi) / lim.max_steering_angle)
        return self._out(sign * v, delta, psi, dt, False)
