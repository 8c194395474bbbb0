"""The analytic baseline as a policy: drives any wheelgym environment from privileged state.

``policy = wheelgym.baseline(env)`` (this module's :func:`baseline`) unwraps ``env`` to its
:class:`~wheelgym.envs.core.WheelCore` (a single environment, any wrapper stack, or a batched
core / vector env exposing ``core``) and returns a :class:`BaselinePolicy` with the
Stable-Baselines3 ``predict`` signature, so one evaluation loop scores a trained agent and the
baseline. It reads the core's true state, goal, reference and range readings (not the
observation), and outputs actions in the env's action space:

1. a body-twist command from the task:

   * goal, holonomic (ThreeWheel): ``v_B = k e_B`` (body-frame position error, capped at
     ``v_cap``), ``w = k_yaw e_yaw``;
   * goal, nonholonomic: drive the point without lateral velocity (SkidSteer: the ICR point
     ``(x_icr, 0)``, SS-1; the others: the axle centre) to the goal's, forwards or backwards,
     then turn in place to the goal heading;
   * goal, car-like (Bicycle, Ackermann: no turning in place): a Reeds-Shepp path to the goal
     pose, planned at each episode's start and followed forwards and backwards by
     :class:`~wheelgym.kinematics.car_tracking.CarTracker` (rear-axle feedback, replanning
     when off the path), which gives the model's inputs directly;
   * track: the reference twist fed forward plus feedback on the body-frame error
     (ThreeWheel: per axis; nonholonomic: Kanayama's law);
   * navigate: the goal attraction plus a repulsion from every range reading closer than
     ``d_safe`` (a potential field on the 16 rays), turned into a twist as above;

2. the twist becomes the action: ``velocity`` mode scales it by the command bounds; ``torque``
   mode passes it through :class:`~wheelgym.control.controllers.TwistController` (track on
   ThreeWheel/SkidSteer: :class:`~wheelgym.control.controllers.TrackingController` directly);
   ``voltage`` mode computes the same torques, clipped to the torque limits, and applies the
   terminal voltage that makes each DC motor deliver its torque at the joint speed at the
   start of the step (:func:`voltage_for_torque`; the voltage is held over the step while the
   speed changes, so the torque drifts from the command within a step);
   kinematic robots map it onto their input mode.

Everything is batched over the core's rows with elementwise NumPy.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wheelgym.envs.core import WheelCore

# the compiled element-wise functions, not NumPy's: a batch must equal each of its robots bit
# for bit on any CPU (NumPy's own loops depend on the CPU and the array's layout)
from wheelgym.models import elementwise as ew

__all__ = ["baseline", "BaselinePolicy", "voltage_for_torque"]


def _sq(a: np.ndarray) -> np.ndarray:
    return a * a


def voltage_for_torque(tau: np.ndarray, omega: np.ndarray, n: np.ndarray, eta: np.ndarray,
                       k_t: np.ndarray, R_w: np.ndarray) -> np.ndarray:
    """Terminal voltage (V) at which a DC motor applies the joint torque ``tau`` (N·m) at
    joint speed ``omega`` (rad/s), inside the drive's limits: the inverse of
    ``wheelgym.models.motor``'s law, ``V = R_w i + k_e n omega`` with the current
    ``i = tau / (n k_t eta)`` motoring (``tau omega >= 0``) and ``i = tau eta / (n k_t)``
    driven back (the gear loss's direction, as ``dc_current`` decides it). Where the result
    exceeds ``V_s`` or its current ``I_max``, the motor delivers less (NumPy; broadcasts)."""
    K = n * k_t  # N·m per A before the gear loss, V per joint rad/s of back-EMF
    # the factors of motor.pack_motor (M_I_FWD, M_I_BACK), so the bits match the kernels'
    i = tau * np.where(tau * omega >= 0.0, 1.0 / (K * eta), eta / K)
    return R_w * i + K * omega


def _find_core(env: Any) -> WheelCore:
    seen = 0
    e = env
    while seen < 50:
        if isinstance(e, WheelCore):
            return e
        core = getattr(e, "core", None)
        if isinstance(core, WheelCore):
            return core
        nxt = getattr(e, "unwrapped", None)
        if nxt is not None and nxt is not e:
            e = nxt
        elif hasattr(e, "env"):
            e = e.env
        else:
            break
        seen += 1
    raise TypeError(f"baseline needs a wheelgym environment (or its core), got {env!r}")


class BaselinePolicy:
    """Privileged analytic controller with ``predict(obs, state, episode_start, deterministic)``.

    Args:
        core: the environment's :class:`~wheelgym.envs.core.WheelCore`.
        v_cap: speed cap of the goal/navigate commands (m/s).
        w_cap: yaw-rate cap (rad/s).
    """

    def __init__(self, core: WheelCore, v_cap: float = 0.6, w_cap: float = 1.5) -> None:
        self.core = core
        spec = core.spec
        self.holonomic = spec.holonomic
        self.turns_in_place = spec.turns_in_place
        self.v_cap = float(v_cap)
        self.w_cap = float(w_cap)
        self.x_icr = float(getattr(core.base_params, "x_icr", 0.0))
        self._twist_ctl = None
        self._track_ctl = None
        #: voltage mode: the rows' Params and their motor tables (:meth:`_motor_rows`)
        self._mrows: tuple[list[Any], dict[str, np.ndarray]] | None = None
        #: car-like robots on ``goal``: one Reeds-Shepp tracker per row, replanned when the
        #: row starts an episode (its step counter is 0) or its goal changes
        self._cars: list[Any] | None = None
        if not self.turns_in_place and core.task_name == "goal":
            from wheelgym.kinematics.car_tracking import CarTracker

            self._cars = [CarTracker.from_model(core.model) for _ in range(core.num)]
            self._car_goal = np.full((core.num, 3), np.nan)
        if spec.baseline_controllers:
            from wheelgym.control.controllers import TrackingController, TwistController

            # the env's control period: the deadbeat twist loop and the friction look-ahead
            self._twist_ctl = TwistController(core.model, ctrl_dt=core.dt)
            self._track_ctl = TrackingController(core.model, ctrl_dt=core.dt)

    # ------------------------------------------------------------------ SB3 interface
    def predict(self, observation: Any = None, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, None]:
        """Actions for the core's current state: ``(action_dim,)`` for a single env (N = 1
        with a 1-D observation), else ``(N, action_dim)``."""
        a = self.actions()
        if isinstance(observation, dict):  # goal_conditioned: the Dict observation
            observation = observation.get("observation")
        single = observation is not None and np.ndim(observation) == 1
        return (a[0] if single else a).astype(np.float32), None

    def reset(self) -> None:
        """Forget the car-like robots' plans (they are replanned at the next call)."""
        if self._cars is not None:
            self._car_goal[:] = np.nan

    # ------------------------------------------------------------------ commands
    def actions(self) -> np.ndarray:
        c = self.core
        task = c.task_name
        if task == "track" and self._track_ctl is not None and \
                not c.spec.tracks_twist(c.action_mode):
            pose, tw, rate = c.task.reference_at()
            if not self.holonomic:  # the controller steers the ICR point: shift its reference
                pose = self._icr_reference(pose)
            tau, _ = self._track_ctl.torques(c.X, pose, tw, rate)
            return self._torque_action(tau)
        if self._cars is not None:
            return self._car_actions()
        if task == "track":
            cmd = self._track_twist()
        else:
            cmd = self._goal_twist()
        return self._to_action(cmd)

    def _car_actions(self) -> np.ndarray:
        """Bicycle/Ackermann on ``goal``: each row's Reeds-Shepp tracker, its input vector
        scaled onto the action range as :meth:`_kinematic_action` does."""
        c = self.core
        goal = c.task.goal
        u = np.empty((c.num, c.m))
        for i, car in enumerate(self._cars):
            if c.steps[i] == 0 or not np.array_equal(goal[i], self._car_goal[i]):
                car.reset(c.X[i], goal[i])
                self._car_goal[i] = goal[i]
            u[i] = car.action(c.X[i], c.dt)
        return self._scale(u)

    def _goal_twist(self) -> np.ndarray:
        c = self.core
        pose = c.pose
        goal = c.task.goal.copy()
        navigate = c.task_name == "navigate"
        x_off = 0.0 if self.holonomic else self.x_icr
        # tracked point P = position + x_off e(yaw) and the goal's
        px = pose[:, 0] + x_off * ew.cos(pose[:, 2])
        py = pose[:, 1] + x_off * ew.sin(pose[:, 2])
        gx = goal[:, 0] + x_off * ew.cos(goal[:, 2])
        gy = goal[:, 1] + x_off * ew.sin(goal[:, 2])
        dx, dy = gx - px, gy - py
        cy, sy = ew.cos(pose[:, 2]), ew.sin(pose[:, 2])
        ex = cy * dx + sy * dy  # goal in B
        ey = -sy * dx + cy * dy
        dist = ew.hypot(ex, ey)
        eyaw = ew.wrap_angle(goal[:, 2] - pose[:, 2])
        if navigate:  # potential field on the range ring (body-frame vector)
            ranges = c.task.ranges
            R = ranges.shape[1]
            ang = 2.0 * math.pi * np.arange(R) / R
            d_safe = c.spec.radius + 0.6
            push = np.clip(1.0 / np.maximum(ranges - c.spec.radius, 0.05) - 1.0 /
                           (d_safe - c.spec.radius), 0.0, None) * (ranges < d_safe)
            att = np.stack([ex, ey], axis=1) / np.maximum(dist, 1e-9)[:, None]
            att *= np.minimum(dist, 1.0)[:, None]
            vx_b = att[:, 0] - 0.25 * np.sum(push * ew.cos(ang), axis=1)
            vy_b = att[:, 1] - 0.25 * np.sum(push * ew.sin(ang), axis=1)
            ex, ey = vx_b, vy_b
            eyaw = np.zeros_like(eyaw)
        N = c.num
        cmd = np.zeros((N, 3))
        if self.holonomic:
            v = np.stack([1.5 * ex, 1.5 * ey], axis=1)
            n = np.linalg.norm(v, axis=1, keepdims=True)
            v *= np.minimum(1.0, self.v_cap / np.maximum(n, 1e-12))
            cmd[:, :2] = v
            cmd[:, 2] = np.clip(2.0 * eyaw, -self.w_cap, self.w_cap)
            if navigate:  # face the direction of travel, so the front rays look ahead
                cmd[:, 2] = np.clip(2.0 * ew.arctan2(ey, ex), -self.w_cap, self.w_cap)
            return cmd
        alpha = ew.arctan2(ey, ex)
        back = (np.abs(alpha) > 0.5 * math.pi) & (not navigate) & (dist < 1.5)
        alpha_d = np.where(back, ew.wrap_angle(alpha - math.pi), alpha)
        sgn = np.where(back, -1.0, 1.0)
        near = (dist < 0.05) & (not navigate) & self.turns_in_place
        v = sgn * np.clip(1.2 * dist * _sq(ew.cos(alpha_d)), 0.0, self.v_cap)
        v = np.where(np.abs(alpha_d) > 0.6, 0.0 if self.turns_in_place else v, v)
        w = np.clip(2.5 * alpha_d, -self.w_cap, self.w_cap)
        if navigate:
            v = np.clip(ew.hypot(ex, ey), 0.0, self.v_cap) * np.clip(ew.cos(alpha_d), 0.0, None)
        cmd[:, 0] = np.where(near, 0.0, v)
        cmd[:, 2] = np.where(near, np.clip(2.5 * eyaw, -self.w_cap, self.w_cap), w)
        return cmd

    def _track_twist(self) -> np.ndarray:
        c = self.core
        pose, tw, _ = c.task.reference_at()
        # aim at the reference one control step ahead (the twist acts over the next step)
        ref = c.task.reference_ahead(1)
        pose, tw = ref[:, :3], ref[:, 3:6]
        x_off = 0.0 if self.holonomic else self.x_icr
        if not self.holonomic:
            pose = self._icr_reference(pose)
        px = c.pose[:, 0] + x_off * ew.cos(c.pose[:, 2])
        py = c.pose[:, 1] + x_off * ew.sin(c.pose[:, 2])
        dx, dy = pose[:, 0] - px, pose[:, 1] - py
        cy, sy = ew.cos(c.pose[:, 2]), ew.sin(c.pose[:, 2])
        ex = cy * dx + sy * dy
        ey = -sy * dx + cy * dy
        eyaw = ew.wrap_angle(pose[:, 2] - c.pose[:, 2])
        cmd = np.zeros((c.num, 3))
        if self.holonomic:
            ce, se = ew.cos(eyaw), ew.sin(eyaw)
            cmd[:, 0] = ce * tw[:, 0] - se * tw[:, 1] + 4.0 * ex
            cmd[:, 1] = se * tw[:, 0] + ce * tw[:, 1] + 4.0 * ey
            cmd[:, 2] = tw[:, 2] + 4.0 * eyaw
            return cmd
        vr, wr = tw[:, 0], tw[:, 2]  # Kanayama's law
        cmd[:, 0] = vr * ew.cos(eyaw) + 3.0 * ex
        cmd[:, 2] = wr + vr * (25.0 * ey + 6.0 * ew.sin(eyaw))
        return cmd

    def _icr_reference(self, pose: np.ndarray) -> np.ndarray:
        """Reference of the tracked point: the CoM reference moved by ``x_icr`` along its
        heading, so that the CoM lands on the reference when the point does (SS-1)."""
        out = pose.copy()
        out[:, 0] += self.x_icr * ew.cos(pose[:, 2])
        out[:, 1] += self.x_icr * ew.sin(pose[:, 2])
        return out

    def _to_action(self, cmd: np.ndarray) -> np.ndarray:
        c = self.core
        spec = c.spec
        if spec.kinematic:
            return self._kinematic_action(cmd)
        twist = cmd if spec.twist_dim == 3 else cmd[:, [0, 2]]
        if spec.tracks_twist(c.action_mode):
            return np.clip(twist / np.asarray(spec.twist_max), -1.0, 1.0)
        if self._twist_ctl is not None:
            tau, _ = self._twist_ctl.torques(c.X, twist)
        else:  # CasterAGV: proportional twist loop through the wheel torques (no controller)
            p = c.params_rows[0]
            m = p.m_b + 2 * p.m_w + p.m_c
            f = m / c.dt * 0.5 * (twist[:, 0] - c.twist[:, 0])
            mz = (p.I_b + m * 0.1**2) / c.dt * 0.5 * (twist[:, 1] - c.twist[:, 2])
            cc = 0.5 * p.track_width
            tau = np.stack([p.r * (0.5 * f - 0.5 * mz / cc), p.r * (0.5 * f + 0.5 * mz / cc)],
                           axis=1)
        return self._torque_action(tau)

    def _torque_action(self, tau: np.ndarray) -> np.ndarray:
        """Motor torques ``tau (N, m)`` as the action: ``torque`` mode ``tau / tau_max``;
        ``voltage`` mode the voltage (:func:`voltage_for_torque`, of ``V_s``) that applies
        ``tau`` clipped to the torque limits at each motor's current joint speed."""
        c = self.core
        if not c.voltage:
            return np.clip(tau / c.HI, -1.0, 1.0)
        t = self._motor_rows()
        tau = np.clip(tau, -t["tau_max"], t["tau_max"])  # the torque mode's limits
        v = voltage_for_torque(tau, c.jv, t["gear_ratio"], t["gear_efficiency"], t["k_t"],
                               t["R_w"])
        return np.clip(v / c.HI, -1.0, 1.0)  # HI: each row's V_s

    def _motor_rows(self) -> dict[str, np.ndarray]:
        """Per-row motor tables ``(N, m)`` (``Params.motor_table()`` and the torque limits)
        of the core's rows' parameters, rebuilt when a reset draws new ones."""
        rows = self.core.params_rows
        cached = self._mrows
        if cached is not None and len(cached[0]) == len(rows) and all(
                a is b for a, b in zip(cached[0], rows, strict=True)):
            return cached[1]
        spec = self.core.spec
        tables: dict[int, dict[str, np.ndarray]] = {}  # one table per distinct Params object
        for p in rows:
            if id(p) not in tables:
                tab = p.motor_table()
                tab["tau_max"] = np.broadcast_to(spec.input_bounds(p, "torque")[1],
                                                 tab["V_s"].shape)
                tables[id(p)] = tab
        out = {k: np.stack([tables[id(p)][k] for p in rows]) for k in tables[id(rows[0])]}
        self._mrows = (list(rows), out)
        return out

    def _kinematic_action(self, cmd: np.ndarray) -> np.ndarray:
        c = self.core
        p = c.params_rows[0]
        v, w = cmd[:, 0], cmd[:, 2]
        mode = c.action_mode
        if mode == "WheelSpeeds":
            r, d = p.wheel_radius, p.track_width
            u = np.stack([(v - 0.5 * d * w) / r, (v + 0.5 * d * w) / r], axis=1)
        elif mode == "WheelSpeedHeadingRate":
            u = np.stack([v / p.wheel_radius, w], axis=1)
        elif mode == "VehicleSpeedSteeringAngle":
            vv = np.where(np.abs(v) < 0.05, 0.05, v)
            u = np.stack([vv, ew.arctan(w * p.wheelbase / vv)], axis=1)
        elif mode == "VehicleSpeedSteeringRate":
            vv = np.where(np.abs(v) < 0.05, 0.05, v)
            psi_d = ew.arctan(w * p.wheelbase / vv)
            u = np.stack([vv, 4.0 * (psi_d - c.X[:, 3])], axis=1)
        else:  # VehicleSpeedHeadingRate
            u = np.stack([v, w], axis=1)
        return self._scale(u)

    def _scale(self, u: np.ndarray) -> np.ndarray:
        """Physical inputs ``u`` onto the action range [-1, 1] (the rows' input bounds)."""
        c = self.core
        mid = 0.5 * (c.HI + c.LO)
        half = np.maximum(0.5 * (c.HI - c.LO), 1e-12)
        return np.clip((u - mid) / half, -1.0, 1.0)


def baseline(env: Any, **kwargs: Any) -> BaselinePolicy:
    """The analytic baseline policy for a wheelgym environment (see the module docstring)."""
    return BaselinePolicy(_find_core(env), **kwargs)
