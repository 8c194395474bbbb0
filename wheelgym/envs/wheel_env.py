"""The single Gymnasium environment: :class:`WheelEnv` is a :class:`WheelCore` at N = 1."""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from wheelgym.envs.core import DEFAULT_HORIZON, WheelCore

__all__ = ["WheelEnv"]

_DOC = """
## Arguments (all robots)

| argument | default | meaning |
|------------------|------------------------|---------------------------------------------------------------|
| task | "goal" | "goal", "track" or "navigate" |
| action_mode | first of the robot's | "torque", "velocity" (dynamic); input modes (kinematic)|
| params | None | dict of parameter overrides (names of the robot's Params) |
| ctrl_dt, sim_dt | model defaults | control period and RK4 substep (s); must divide |
| randomize | None | dict group -> range, or True for the defaults (below) |
| obs_noise | 0.0 | std of Gaussian noise added to each observation entry |
| reward_weights | task defaults | dict term -> weight; unknown keys raise listing valid ones |
| render_mode | None | "rgb_array" or "human" |
| range_backend | "analytic" | navigate's range sensor: "analytic" (compiled) or "pymunk" |

`randomize` groups (each robot supports those its parameters have): "mass", "inertia",
"friction", "x_icr", "wheel_radius", "caster_trail", "torque_limit". A value is a relative
factor range ``(low, high)`` (or a fraction f meaning ``(1 - f, 1 + f)``) multiplying the
parameters of the group, except ``x_icr`` which takes an absolute range in metres. Draws
come from ``np_random`` at each reset, in a fixed order; ``reset`` returns them in
``info["params"]``.

## Tasks, observations and rewards

Observations are float32 with finite bounds; angles enter as cos/sin; positions are in the
robot's body frame B (x forward, y left) and clipped to +-12 m; speeds to twice the
sanity limits. Every observation ends with the body twist and the robot's features:

| entries            | unit           | meaning                                               |
|--------------------|----------------|-------------------------------------------------------|
| vx, vy, wz         | m/s, m/s, rad/s| body twist (physics.md section 0)                     |
| robot features     | see robot      | e.g. cos/sin of ThreeWheel's steering angles          |

**goal** (success: within 0.1 m and 0.2 rad of a goal 1-3 m from a random start; terminates):
obs = [goal_x_b, goal_y_b (m), cos_dyaw, sin_dyaw, twist, features].
Reward terms: progress = w (d_prev - d) (distance decrease, m), heading = -w |dyaw| / pi,
effort = -w mean((tau/tau_max)^2), internal_force = -w |tau_null| (N·m, ThreeWheel only),
success = +w on success, overspeed = -w when the speed limit is exceeded (terminates).
Defaults w = 1, 0.02, 0.01, 0.01, 10, 10.

**track** (reference: circle, figure-eight or the paper's quintic circle, random size, speed,
phase and placement; the robot starts on it): obs = [ref_x_b, ref_y_b (m), cos_dyaw,
sin_dyaw, ref_vx, ref_vy (m/s), ref_wz (rad/s), preview points at +0.5, 1.0, 1.5 s in B (m),
twist, features]. Terms: position = -w |e| (m), heading = -w |dyaw| / pi, effort,
internal_force, overspeed, lost = -w when |e| > 1 m (terminates). Defaults 1, 0.1, 0.01,
0.01, 10, 10. ``is_success`` holds while |e| < 5 cm.

**navigate** (8 m x 8 m arena, 3-6 circles and 1-3 boxes, goal >= 3 m away, success within
0.25 m): obs = goal's + 16 range readings (m, 0-3, rays at yaw + 2 pi k / 16). Terms as goal
(heading weight 0) plus collision = -w (robot circle touches an obstacle; terminates).

Every term is in ``info["reward_terms"]`` (weighted) and they add up to the reward.

## Episode end

Terminated on success (goal, navigate), overspeed (|v| > v_max or |wz| > w_max: the models
have no motor back-EMF, so speed would grow without bound), lost (track), collision
(navigate), or a non-finite state (``info["numerical_failure"] = True``; the observation
then shows the last finite state). Truncated after ``max_episode_steps`` = 500 (25 s).

## Info (every step)

| key              | unit      | meaning                                                       |
|------------------|-----------|---------------------------------------------------------------|
| pose             | m, m, rad | (x, y, yaw) in W (yaw unwrapped)                              |
| twist            | m/s, rad/s| (vx, vy, wz) in B                                             |
| motor_torque     | N·m       | applied motor torques (after clipping); empty for kinematic   |
| joint_velocity   | rad/s     | motor joint rates at the end of the step                      |
| tracking_error   | m         | distance to the goal (goal, navigate) or the reference (track)|
| energy           | J         | cumulative motor work, integral of tau . qdot                 |
| internal_force   | N·m       | norm of the torques' null-space component (ThreeWheel; else 0)|
| saturated        | bool      | an action or controller torque was clipped                    |
| is_success       | bool      | see the tasks                                                 |
| reward_terms     | dict      | weighted reward terms                                         |
| numerical_failure| bool      | the state turned non-finite (the episode ends)                |

Reset info: ``params`` (drawn parameter values), ``task`` details.

## Bad input

An action of the wrong shape or with a non-finite entry raises ``ValueError``; entries outside
[-1, 1] are clipped (``saturated`` is set). Invalid keyword values raise ``ValueError`` or
``TypeError`` naming the argument and listing the valid choices.
"""


class WheelEnv(gym.Env):
    """Base of the wheelgym environments (one robot, one task); see the robot subclasses."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 20}
    robot: str = ""

    def __init__(
        self,
        task: str = "goal",
        action_mode: str | None = None,
        params: Mapping[str, Any] | None = None,
        ctrl_dt: float | None = None,
        sim_dt: float | None = None,
        randomize: Mapping[str, Any] | bool | None = None,
        obs_noise: float = 0.0,
        reward_weights: Mapping[str, float] | None = None,
        render_mode: str | None = None,
        range_backend: str = "analytic",
        horizon: int = DEFAULT_HORIZON,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.core = WheelCore(
            self.robot, 1, task=task, action_mode=action_mode, params=params, ctrl_dt=ctrl_dt,
            sim_dt=sim_dt, randomize=randomize, obs_noise=obs_noise,
            reward_weights=reward_weights, horizon=horizon, range_backend=range_backend,
        )
        c = self.core
        self.render_mode = render_mode
        self.task = task
        self.action_mode = c.action_mode
        self.dt = c.dt
        self.action_space = spaces.Box(-1.0, 1.0, (c.action_dim,), np.float32)
        self.observation_space = spaces.Box(c.obs_low, c.obs_high, dtype=np.float32)
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / c.dt))}
        self._names = c.task.names
        self._tidx = [int(k) for k in c.task.term_index]
        self._nmotor = c.spec.n_motor
        self._A = np.zeros((1, c.action_dim))
        self._shape = (c.action_dim,)
        self._renderer = None
        self._started = False

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        c = self.core
        obs = c.reset(None, [self.np_random], options)[0].copy()
        self._started = True
        info = self._info(True)
        info["params"] = dict(c.drawn[0])
        info["task"] = self._task_info()
        if self._renderer is not None:
            self._renderer.reset()
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(action)
        if a.shape != self._shape:
            raise ValueError(f"action must have shape {self._shape}, got {np.shape(action)}")
        self._A[0] = a
        obs, reward, term, _ = self.core.step(self._A)
        info = self._info(False)
        if self.render_mode == "human":
            self.render()
        return obs[0].copy(), reward.item(0), term.item(0), False, info

    def _info(self, at_reset: bool) -> dict[str, Any]:
        c = self.core
        nm = self._nmotor
        t = c.terms[0].tolist()
        return {
            "pose": c.pose[0].copy(),
            "twist": c.twist[0].copy(),
            "motor_torque": c.U[0, :nm].copy(),
            "joint_velocity": c.jv[0, :nm].copy(),
            "tracking_error": c.err.item(0),
            "energy": c.energy.item(0),
            "internal_force": c.xf.item(0),
            "saturated": c.sat.item(0),
            "is_success": c.succ.item(0),
            "numerical_failure": not c.ok.item(0),
            "reward_terms": {n: (0.0 if at_reset else t[k])
                             for n, k in zip(self._names, self._tidx, strict=True)},
        }

    def _task_info(self) -> dict[str, Any]:
        c = self.core
        task = c.task
        out: dict[str, Any] = {"name": c.task_name}
        if hasattr(task, "goal"):
            out["goal"] = task.goal[0].copy()
        if hasattr(task, "kind"):
            out["reference"] = task.kind[0]
        return out

    # ------------------------------------------------------------------ rendering
    def render(self):
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or "
                "'human' to gym.make"
            )
            return None
        if self._renderer is None:
            if self.render_mode == "human" and not os.environ.get("DISPLAY") and \
                    not os.environ.get("WAYLAND_DISPLAY"):
                os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
            from wheelgym.render import Renderer

            self._renderer = Renderer(self.core, self.render_mode, self.metadata["render_fps"])
        return self._renderer.render(0)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
