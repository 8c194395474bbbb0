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
   * track, car-like: speed and steering angle directly (:class:`_CarTrackSearch`). Where
     the reference over the next 1.5 s (the 30 steps the task previews) turns no tighter
     than the car can (``|w_r| <= 0.97 |v_r| tan(psi_max) / l``; Ackermann: and its steering
     angle ``atan(l w_r / v_r)`` changes within the rate limit, and the car's steering is
     within 0.05 rad of it) and the rear axle is within 2 cm and 0.1 rad of it: the
     rear-wheel feedback of :func:`~wheelgym.kinematics.car_tracking.rear_wheel_steering`
     (curvature feed-forward ``w_r / v_r``) about the reference of the current step, with
     the speed ``v_r cos(e_th) - k_s e_s`` (the reference runs on a clock: feedback on the
     along-track error), reversing where that is negative. Elsewhere (the figure-eight's
     lobes turn at radii down to 0.2 m, the cars' least is 0.87 m; a start with the
     Ackermann's steering off the reference's): a receding-horizon search over 30-step plans
     of speed and steering angle (600 fixed random piecewise-constant plans, the last plan
     moved on a step, local refinements of the best; each simulated on the car's model with
     its steering-rate limit), which starts the plan of least summed squared distance to the
     reference, forwards or backwards (the Bicycle backs and fills through the lobes);
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

Everything is batched over the core's rows with elementwise NumPy (the car-like search: per
row, its plans simulated by a compiled loop, :mod:`wheelgym.kinematics.car_rollout`, its argmin
exact, so a batch equals its single robots).

The model the baseline believes in (``model``, ``docs/topics/robustness.md``): ``"nominal"``
(the default: the parameters the environment was built with, ``core.base_params``, whatever
``randomize`` or ``perturbation`` draw for the plant: the computed torque's mass, inertia and
friction, SkidSteer's ``x_icr``, the torque limits and DC motor constants that turn torques
into actions, the kinematic robots' wheel radius and track) or ``"true"`` (each row's drawn
plant parameters, ``core.params_rows`` and ``core.P``: privileged, an upper reference). On a
nominal plant the two give the same actions bit for bit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wheelgym.envs.core import WheelCore
from wheelgym.kinematics.car_rollout import plan_costs

# the compiled element-wise functions, not NumPy's: a batch must equal each of its robots bit
# for bit on any CPU (NumPy's own loops depend on the CPU and the array's layout)
from wheelgym.models import elementwise as ew

__all__ = ["baseline", "BaselinePolicy", "voltage_for_torque", "BASELINE_MODELS"]

#: The models the baseline may believe in (``BaselinePolicy(model=...)``).
BASELINE_MODELS = ("nominal", "true")


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
        elif hasattr(e, "venv"):  # SB3's VecEnv wrappers and the native env's SB3 adapter
            e = e.venv
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
        planner: navigate only: ``None`` (the potential field) or one of
            ``wheelgym.planning.PLANNERS`` (``"auto"``, ``"astar"``, ``"hybrid"``): plan on
            the map and track the plan (:class:`~wheelgym.planning.PlanningNavigator`;
            docs/topics/planning.md); ``planner_kwargs`` go to it.
        model: ``"nominal"`` (the env's built parameters) or ``"true"`` (each row's drawn
            plant parameters); module docstring.
        twist_gains: the gains of the twist loop that turns goal and navigate commands into
            torques (torque and voltage modes, ThreeWheel and SkidSteer): a
            :class:`~wheelgym.control.controllers.TwistGains` or a mapping of its fields
            (``k_v``, ``k_i``), or None (the deadbeat ``k_v = 1 / ctrl_dt`` without integral
            action). Given, SkidSteer's integral action ``k_i`` applies (its default
            ``0.3 / ctrl_dt²``; ``k_i: 0`` for none): one integrator per row, zeroed at the
            row's reset, advanced by each call of :meth:`actions` (once per env step).
            A loop for a delayed plant: ``docs/topics/robustness.md``.

    Raises:
        ValueError: ``model`` or ``twist_gains`` invalid, ``twist_gains`` for a robot without
            the twist controller, or integral action with ``model="true"``.
    """

    def __init__(self, core: WheelCore, v_cap: float = 0.6, w_cap: float = 1.5,
                 planner: str | None = None, planner_kwargs: dict[str, Any] | None = None,
                 model: str = "nominal", twist_gains: Any = None) -> None:
        if model not in BASELINE_MODELS:
            raise ValueError(f"model must be one of {list(BASELINE_MODELS)}, got {model!r}")
        #: ``"nominal"`` or ``"true"``: the parameters the baseline computes with.
        self.model = model
        self._true = model == "true"
        self.core = core
        # the nominal row's action bounds (torque limits, or V_s in the voltage mode)
        _, self._lo_nominal, self._hi_nominal = core.spec.row_params(
            core.model, core.base_params, core.action_mode)
        #: the planning baseline's navigator (``planner=...``), else None
        self.navigator = None
        if planner is not None:
            from wheelgym.planning import PlanningNavigator

            self.navigator = PlanningNavigator(core, planner, **(planner_kwargs or {}))
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
        #: car-like robots on ``track``: feedback, and a receding-horizon search where the
        #: reference is out of the car's reach (each row's last plan is its warm start)
        self._car_track: _CarTrackSearch | None = None
        if not self.turns_in_place and core.task_name == "track":
            self._car_track = _CarTrackSearch(core)
        if spec.baseline_controllers:
            from wheelgym.control.controllers import TrackingController, TwistController

            # the env's control period: the deadbeat twist loop and the friction look-ahead
            try:
                self._twist_ctl = TwistController(core.model, gains=twist_gains, ctrl_dt=core.dt)
            except TypeError as e:
                raise ValueError(f"twist_gains: {e}") from None
            self._track_ctl = TrackingController(core.model, ctrl_dt=core.dt)
        elif twist_gains is not None:
            raise ValueError(f"twist_gains: {spec.name} has no twist controller (ThreeWheel and "
                             "SkidSteer have)")
        #: the stateful twist loop (``twist_gains`` with integral action): one integrator a row
        self._integral = twist_gains is not None and self._twist_ctl.gains.k_i > 0.0
        if self._integral:
            if self._true:
                raise ValueError("twist_gains: the integral action (k_i > 0) is for "
                                 "model='nominal'; pass k_i: 0 with model='true'")
            self._twist_ctl.set_rows(core.num)

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
        """Forget the car-like robots' plans (they are replanned at the next call) and zero
        the twist loop's integrators (``twist_gains`` with integral action)."""
        if self._integral:
            self._twist_ctl.reset_rows(slice(None))
        if self._cars is not None:
            self._car_goal[:] = np.nan
        if self._car_track is not None:
            self._car_track.reset()

    # ------------------------------------------------------------------ commands
    def actions(self) -> np.ndarray:
        c = self.core
        task = c.task_name
        if self.navigator is not None:  # planner=...: the plan's twist or car inputs
            if self.navigator.car:
                return self._scale(self.navigator.car_inputs())
            return self._to_action(self.navigator.twist())
        if task == "track" and self._track_ctl is not None and \
                not c.spec.tracks_twist(c.action_mode):
            pose, tw, rate = c.task.reference_at()
            if not self.holonomic:  # the controller steers the ICR point: shift its reference
                pose = self._icr_reference(pose)
            if self._true:
                tau, _ = self._track_ctl.row_torques(c.X, pose, tw, rate, c.P,
                                                     self._tau_max_rows())
            else:
                tau, _ = self._track_ctl.torques(c.X, pose, tw, rate)
            return self._torque_action(tau)
        if self._cars is not None:
            return self._car_actions()
        if self._car_track is not None:
            return self._car_track_actions()
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

    def _car_track_actions(self) -> np.ndarray:
        """Bicycle/Ackermann on ``track``: speed and steering angle of :class:`_CarTrackSearch`
        as the model's input mode, scaled onto the action range."""
        c = self.core
        v, delta = self._car_track.inputs()
        mode = c.action_mode
        if mode == "VehicleSpeedSteeringAngle":
            u = np.stack([v, delta], axis=1)
        elif mode == "VehicleSpeedSteeringRate":  # turn to delta within the step
            u = np.stack([v, (delta - c.X[:, 3]) / c.dt], axis=1)
        else:  # VehicleSpeedHeadingRate
            u = np.stack([v, v * ew.sin(delta) / ew.cos(delta) / self._car_track.wheelbase],
                         axis=1)
        return self._scale(u)

    def _goal_twist(self) -> np.ndarray:
        c = self.core
        pose = c.pose
        goal = c.task.goal.copy()
        navigate = c.task_name == "navigate"
        x_off = 0.0 if self.holonomic else self._param("x_icr", self.x_icr)
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
        x_off = 0.0 if self.holonomic else self._param("x_icr", self.x_icr)
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
        x_icr = self._param("x_icr", self.x_icr)
        out[:, 0] += x_icr * ew.cos(pose[:, 2])
        out[:, 1] += x_icr * ew.sin(pose[:, 2])
        return out

    def _param(self, name: str, nominal: Any = None) -> Any:
        """Parameter ``name`` as the baseline believes it: the base value (``nominal``:
        given, else ``core.base_params``'), or with ``model="true"`` each row's ``(N,)``."""
        c = self.core
        if not self._true:
            return getattr(c.base_params, name) if nominal is None else nominal
        if not hasattr(c.base_params, name):  # (x_icr of the robots without one: 0)
            return nominal
        return np.array([float(getattr(p, name)) for p in c.params_rows])

    def _tau_max_rows(self) -> np.ndarray:
        """``model="true"``: each row's motor torque limits ``(N, m)`` (C-contiguous)."""
        c = self.core
        if c.voltage:
            return np.ascontiguousarray(self._motor_rows()["tau_max"])
        return np.ascontiguousarray(c.HI)

    def _to_action(self, cmd: np.ndarray) -> np.ndarray:
        c = self.core
        spec = c.spec
        if spec.kinematic:
            return self._kinematic_action(cmd)
        twist = cmd if spec.twist_dim == 3 else cmd[:, [0, 2]]
        if spec.tracks_twist(c.action_mode):
            return np.clip(twist / np.asarray(spec.twist_max), -1.0, 1.0)
        if self._twist_ctl is not None:
            if self._true:
                tau, _ = self._twist_ctl.row_torques(c.X, twist, c.P, self._tau_max_rows())
            elif self._integral:  # rows that have just been reset start a fresh integrator
                self._twist_ctl.reset_rows(np.flatnonzero(c.steps == 0))
                tau, _ = self._twist_ctl.step(c.X, twist)
            else:
                tau, _ = self._twist_ctl.torques(c.X, twist)
        else:  # CasterAGV: proportional twist loop through the wheel torques (no controller)
            P = self._param
            m = P("m_b") + 2 * P("m_w") + P("m_c")
            f = m / c.dt * 0.5 * (twist[:, 0] - c.twist[:, 0])
            mz = (P("I_b") + m * 0.1**2) / c.dt * 0.5 * (twist[:, 1] - c.twist[:, 2])
            cc = 0.5 * P("track_width")
            r = P("r")
            tau = np.stack([r * (0.5 * f - 0.5 * mz / cc), r * (0.5 * f + 0.5 * mz / cc)],
                           axis=1)
        return self._torque_action(tau)

    def _torque_action(self, tau: np.ndarray) -> np.ndarray:
        """Motor torques ``tau (N, m)`` as the action: ``torque`` mode ``tau / tau_max``;
        ``voltage`` mode the voltage (:func:`voltage_for_torque`, of ``V_s``) that applies
        ``tau`` clipped to the torque limits at each motor's current joint speed."""
        c = self.core
        hi = c.HI if self._true else self._hi_nominal  # the rows' or the nominal bounds
        if not c.voltage:
            return np.clip(tau / hi, -1.0, 1.0)
        t = self._motor_rows() if self._true else self._motor_nominal()
        tau = np.clip(tau, -t["tau_max"], t["tau_max"])  # the torque mode's limits
        v = voltage_for_torque(tau, c.jv, t["gear_ratio"], t["gear_efficiency"], t["k_t"],
                               t["R_w"])
        return np.clip(v / hi, -1.0, 1.0)  # hi: V_s

    def _motor_nominal(self) -> dict[str, np.ndarray]:
        """The motor table of ``core.base_params`` (as :meth:`_motor_rows`' rows)."""
        if getattr(self, "_mnom", None) is None:
            p = self.core.base_params
            tab = p.motor_table()
            tab["tau_max"] = np.broadcast_to(self.core.spec.input_bounds(p, "torque")[1],
                                             tab["V_s"].shape)
            self._mnom = tab
        return self._mnom

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
        P = self._param
        v, w = cmd[:, 0], cmd[:, 2]
        mode = c.action_mode
        if mode == "WheelSpeeds":
            r, d = P("wheel_radius"), P("track_width")
            u = np.stack([(v - 0.5 * d * w) / r, (v + 0.5 * d * w) / r], axis=1)
        elif mode == "WheelSpeedHeadingRate":
            u = np.stack([v / P("wheel_radius"), w], axis=1)
        elif mode == "VehicleSpeedSteeringAngle":
            vv = np.where(np.abs(v) < 0.05, 0.05, v)
            u = np.stack([vv, ew.arctan(w * P("wheelbase") / vv)], axis=1)
        elif mode == "VehicleSpeedSteeringRate":
            vv = np.where(np.abs(v) < 0.05, 0.05, v)
            psi_d = ew.arctan(w * P("wheelbase") / vv)
            u = np.stack([vv, 4.0 * (psi_d - c.X[:, 3])], axis=1)
        else:  # VehicleSpeedHeadingRate
            u = np.stack([v, w], axis=1)
        return self._scale(u)

    def _scale(self, u: np.ndarray) -> np.ndarray:
        """Physical inputs ``u`` onto the action range [-1, 1] (the rows' input bounds)."""
        c = self.core
        lo, hi = (c.LO, c.HI) if self._true else (self._lo_nominal, self._hi_nominal)
        mid = 0.5 * (hi + lo)
        half = np.maximum(0.5 * (hi - lo), 1e-12)
        return np.clip((u - mid) / half, -1.0, 1.0)


def _car_feedback(pose: np.ndarray, ref0: np.ndarray, ref1: np.ndarray, wheelbase: float,
                  psi_max: float) -> tuple[np.ndarray, ...]:
    """Rear-axle feedback on a time-parameterised reference (car-like ``track``).

    ``pose (n, 3)`` the rear axle, ``ref0``/``ref1 (n, 6)`` the reference pose and body twist
    at this control step and the next. The law of
    :func:`~wheelgym.kinematics.car_tracking.rear_wheel_steering` (curvature feed-forward
    ``kappa_r = w_r / v_r`` of the step's mean twist, feedback on the lateral offset ``e_n`` and
    heading error ``e_th`` per metre of signed travel) with a speed feedback on the
    along-track error ``e_s`` (the reference runs on a clock): ``v = v_r cos(e_th) -
    k_s e_s``, driving backwards (the virtual car facing ``yaw + pi``) when that is negative.

    Returns ``(v, delta, e_s, e_n, e_th)``: speed (m/s), steering angle (rad, within
    ``psi_max``), errors (m, m, rad; ahead, left and yaw of the reference positive).
    """
    k_e, k_th, k_s = _CAR_GAINS
    vr = 0.5 * (ref0[:, 3] + ref1[:, 3])
    wr = 0.5 * (ref0[:, 5] + ref1[:, 5])
    cr, sr = ew.cos(ref0[:, 2]), ew.sin(ref0[:, 2])
    dx, dy = pose[:, 0] - ref0[:, 0], pose[:, 1] - ref0[:, 1]
    es = cr * dx + sr * dy
    en = cr * dy - sr * dx
    eth = ew.wrap_angle(pose[:, 2] - ref0[:, 2])
    moving = np.abs(vr) > 1e-6
    kr = np.where(moving, wr / np.where(moving, vr, 1.0), 0.0)
    v = vr * ew.cos(eth) - k_s * es
    sgn = np.where(v < 0.0, -1.0, 1.0)
    ev, kv = sgn * en, sgn * kr  # the virtual car facing yaw + pi when reversing
    den = np.maximum(1.0 - kv * ev, 0.2)
    small = np.abs(eth) < 1e-9
    sinc = np.where(small, 1.0, ew.sin(eth) / np.where(small, 1.0, eth))
    kappa = kv * ew.cos(eth) / den - k_th * eth - k_e * ev * sinc
    # arctan2(y, 1): arctan without a division by zero at y = 0
    delta = np.clip(ew.arctan2(wheelbase * kappa * sgn, 1.0), -psi_max, psi_max)
    return v, delta, es, en, eth


#: Car-like ``track``: rear-axle feedback gains ``k_e`` (1/m^2), ``k_th`` (1/m) and the speed
#: feedback ``k_s`` (1/s) on the along-track error.
_CAR_GAINS = (4.0, 4.0, 1.0)


class _CarTrackSearch:
    """Car-like ``track`` (Bicycle, Ackermann): feedback where the reference is within reach,
    a receding-horizon search where it is not (module docstring).

    Each control step, per row: while the reference over the next ``H`` steps turns no tighter than
    ``feasible`` times the car's minimum radius allows (Ackermann: and its steering angle changes no
    faster than ``feasible`` times the rate limit) and the robot is within ``near`` of it, the
    rear-axle feedback (:func:`_car_feedback`) drives. Elsewhere ``H``-step plans of speed and
    steering angle are simulated (:func:`~wheelgym.kinematics.car_rollout.plan_costs`, compiled) and
    the one with the least summed squared distance to the reference positions is started: a fixed
    table of ``samples`` random plans (``pieces`` piecewise-constant pieces, speeds uniform in
    ``speeds``, steering angles among ``steer_levels`` times ``psi_max``; one table for every row),
    the last plan moved on a step (else the feedback command held), and the best so far with each
    piece's speed or steering moved by ``+-step`` (a second pass at half the step). Element-wise per
    row (the argmin is exact), so a batch equals its single robots.

    Args:
        core: the environment's core (a car-like robot on ``track``).
    """

    H = 30  # horizon (control steps); reference_ahead reaches 31
    pieces = 8
    samples = 600
    speeds = (-1.0, 2.0)  # m/s, cut to the model's speed range
    steer_levels = (-1.0, -0.5, 0.0, 0.5, 1.0)
    step = (0.4, 0.25)  # m/s, rad
    feasible = 0.97
    near = (0.02, 0.1)  # m, rad
    chunk = 16  # rows searched together (memory)

    def __init__(self, core: WheelCore) -> None:
        self.core = core
        p = core.params_rows[0]
        self.wheelbase = float(p.wheelbase)
        self.psi_max = float(p.max_steering_angle)
        self.rate = float(p.max_steering_rate) if core.X.shape[1] > 3 else None
        lo, hi = (float(s) for s in p.speed_range)
        self.v_range = (lo, hi)
        H, P = self.H, self.pieces
        self.cuts = np.linspace(0, H, P + 1).astype(np.int64)
        rng = np.random.default_rng(0)
        v = rng.uniform(max(self.speeds[0], lo), min(self.speeds[1], hi), (self.samples, P))
        d = rng.choice(np.asarray(self.steer_levels) * self.psi_max, (self.samples, P))
        reps = np.diff(self.cuts)
        self.table_v = np.ascontiguousarray(np.repeat(v, reps, axis=1).T)  # (H, samples)
        self.table_d = np.ascontiguousarray(np.repeat(d, reps, axis=1).T)
        # (H, 4 P): step k lies in the piece that candidate 4 p + m moves
        piece = np.searchsorted(self.cuts, np.arange(H), side="right") - 1
        self.moved = piece[:, None] == np.repeat(np.arange(P), 4)[None, :]
        self.plan_v = np.zeros((core.num, H))
        self.plan_d = np.zeros((core.num, H))
        self.warm = np.zeros(core.num, dtype=bool)

    def reset(self) -> None:
        self.warm[:] = False

    def inputs(self) -> tuple[np.ndarray, np.ndarray]:
        """Speed (m/s) and steering angle (rad) ``(N,)`` for the core's current state."""
        c = self.core
        H, L = self.H, self.wheelbase
        refs = np.stack([c.task.reference_ahead(k) for k in range(H + 1)], axis=1)
        pose = c.pose
        psi = c.X[:, 3] if self.rate is not None else np.zeros(c.num)
        v, delta, es, en, eth = _car_feedback(pose, refs[:, 0], refs[:, 1], L, self.psi_max)
        self.warm &= c.steps != 0  # a new episode forgets its row's plan
        vr, wr = refs[:, :, 3], refs[:, :, 5]
        k_max = float(ew.sin(self.psi_max) / ew.cos(self.psi_max)) / L  # 1/m, least radius
        fb = np.all(np.abs(wr) <= self.feasible * k_max * np.abs(vr), axis=1)
        if self.rate is not None:  # the reference's steering angle and its rate
            d_ref = ew.arctan2(L * wr * np.where(vr < 0.0, -1.0, 1.0), np.abs(vr))
            fb &= np.all(np.abs(d_ref[:, 1:] - d_ref[:, :-1])
                         <= self.feasible * self.rate * c.dt, axis=1)
            fb &= np.abs(psi - d_ref[:, 0]) <= 0.05
        fb &= (es * es + en * en <= self.near[0] ** 2) & (np.abs(eth) <= self.near[1])
        self.warm[fb] = False
        rows = np.flatnonzero(~fb)
        for s in range(0, rows.size, self.chunk):
            r = rows[s:s + self.chunk]
            start = np.stack([pose[r, 0], pose[r, 1], pose[r, 2], psi[r]], axis=1)
            v[r], delta[r] = self._search(r, start, refs[r, 1:, :2], v[r], delta[r])
        return v, delta

    def _search(self, r: np.ndarray, start: np.ndarray, ref_xy: np.ndarray, v_fb: np.ndarray,
                d_fb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n, H, S = r.size, self.H, self.samples
        lo, hi = self.v_range
        warm = self.warm[r, None]
        shift_v = np.concatenate([self.plan_v[r, 1:], self.plan_v[r, -1:]], axis=1)
        shift_d = np.concatenate([self.plan_d[r, 1:], self.plan_d[r, -1:]], axis=1)
        best_v = np.where(warm, shift_v, v_fb[:, None])
        best_d = np.where(warm, shift_d, d_fb[:, None])
        dv, dd = self.step
        rows = np.arange(n)
        for it in range(2):
            # the row's own plans: the best so far, (first pass) the feedback command held, and
            # the best with one piece's speed or steering moved by +-step (clipped to range)
            sv = np.tile([dv, -dv, 0.0, 0.0], self.pieces)
            sd = np.tile([0.0, 0.0, dd, -dd], self.pieces)
            bv, bd = best_v[:, :, None], best_d[:, :, None]
            cv = [bv, np.broadcast_to(v_fb[:, None, None], (n, H, 1))] if it == 0 else [bv]
            cd = [bd, np.broadcast_to(d_fb[:, None, None], (n, H, 1))] if it == 0 else [bd]
            cv.append(np.where(self.moved, np.clip(bv + sv, lo, hi), bv))
            cd.append(np.where(self.moved, np.clip(bd + sd, -self.psi_max, self.psi_max), bd))
            V, D = np.concatenate(cv, axis=2), np.concatenate(cd, axis=2)
            shared = (self.table_v, self.table_d) if it == 0 else None
            cost = plan_costs(start, V, D, ref_xy, self.core.dt, self.wheelbase, self.rate,
                              shared=shared)
            if it == 0:  # candidate order: best, table, the rest (argmin keeps the first)
                cost = np.concatenate([cost[:, S:S + 1], cost[:, :S], cost[:, S + 1:]], axis=1)
                j = np.argmin(cost, axis=1)
                own = np.where(j > S, j - S, 0)
                table = (j >= 1) & (j <= S)
                tj = np.clip(j - 1, 0, S - 1)
                best_v = np.where(table[:, None], self.table_v[:, tj].T, V[rows, :, own])
                best_d = np.where(table[:, None], self.table_d[:, tj].T, D[rows, :, own])
            else:
                j = np.argmin(cost, axis=1)
                best_v, best_d = V[rows, :, j], D[rows, :, j]
            dv, dd = 0.5 * dv, 0.5 * dd
        self.plan_v[r], self.plan_d[r] = best_v, best_d
        self.warm[r] = True
        return best_v[:, 0], best_d[:, 0]


def baseline(env: Any, **kwargs: Any) -> BaselinePolicy:
    """The analytic baseline policy for a wheelgym environment (see the module docstring)."""
    return BaselinePolicy(_find_core(env), **kwargs)
