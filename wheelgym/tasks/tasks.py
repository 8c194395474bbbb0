"""The environments' tasks: start states, goals or references, observations, rewards, ends.

A task works on a whole batch of robots (rows), seen through a
:class:`~wheelgym.tasks.view.BatchView` (the environments' core implements it), with one
compiled kernel per step (``wheelgym.tasks.kernels``); ``reset_rows`` draws row i's episode only
from ``rngs[i]``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from wheelgym.integrators import entry_point
from wheelgym.kinematics.car_tracking import min_turning_radius
from wheelgym.kinematics.references import (
    Circle,
    FigureEight,
    QuinticCircle,
    Reference,
    evaluate_batch,
)
from wheelgym.tasks.kernels import k_add1, k_goal, k_goal_par, k_goal_reset, k_track
from wheelgym.tasks.view import BatchView, RobotConstants

__all__ = ["Task", "GoalTask", "TrackTask", "NavigateTask", "TASKS", "POS_CLIP", "HER_INFO_KEYS",
           "GOAL_POS_BOUND", "her_info_arrays", "NAVIGATE_V1_WEIGHTS", "navigate_v1_bound"]

#: Bound of positions in the observation (m).
POS_CLIP = 12.0
_TWO_PI = math.pi - -math.pi  # the scale numpy's uniform(-pi, pi) uses
#: Step index standing for "no last step" (the track reference moves on forever).
_NO_END = np.iinfo(np.int64).max // 4


def _pose_option(key: str, value: Any, n: int) -> np.ndarray:
    """A pose option ``(x, y, yaw)``, one for all rows or ``(n, 3)``, as ``(n, 3)``."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"options[{key!r}] must be a pose (x, y, yaw) of numbers, "
                        f"got {value!r}") from None
    if a.shape == (3,):
        a = np.broadcast_to(a, (n, 3))
    elif a.shape != (n, 3):
        raise ValueError(f"options[{key!r}] must be a pose (x, y, yaw) of shape (3,), or one "
                         f"per sub-env of shape ({n}, 3); got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"options[{key!r}] must be finite, got {value!r}")
    return a


def _per_row(key: str, value: Any, n: int, one, what: str) -> list[Any]:
    """A scalar-like option (``one(v)`` validates and converts one value), one for all rows
    or a sequence of ``n``, as a list of ``n``."""
    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) != n:
            raise ValueError(f"options[{key!r}] as a sequence must hold one {what} per "
                             f"sub-env ({n}), got {len(value)}")
        return [one(v) for v in value]
    return [one(value)] * n


def internal_force_scale(core: BatchView) -> float:
    """The internal-force reward term's scale (N·m): the norm of the nominal robot's torque
    limits ``|tau_max|``, the largest ``|P tau|`` a torque within the limits can have (the
    projection ``P`` of TW-6 does not lengthen a vector). The term is ``|P tau| / |tau_max|``,
    in [0, 1] whatever the motors, so one weight serves any parameter set."""
    tau_max = getattr(core.base_params, "tau_max", None)
    if tau_max is None:
        return 1.0
    return float(np.sqrt(np.sum(np.square(np.asarray(tau_max, dtype=np.float64)))))


class Task:
    """Base class: term names, default weights, observation layout and bounds."""

    name: ClassVar[str] = ""
    #: All term columns of the kernel, in order.
    columns: ClassVar[tuple[str, ...]] = ()
    default_weights: ClassVar[dict[str, float]] = {}

    def __init__(self, core: BatchView, weights: Mapping[str, float] | None) -> None:
        self.core = core
        names = self.term_names(core.spec)
        self.term_index = np.array([self.columns.index(k) for k in names])
        self.names = names
        self.weights = {k: float(self.default_weights[k]) for k in names}
        self.W = np.zeros(len(self.columns))
        self.set_weights(weights)

    def set_weights(self, weights: Mapping[str, float] | None) -> None:
        """Change the weights of the named terms (the others keep theirs) from the next
        evaluation on. ``ValueError`` names an unknown key and lists the valid ones;
        ``TypeError``/``ValueError`` for a weight that is not a finite real number. Nothing
        changes when a key or weight is bad."""
        if weights is not None and not isinstance(weights, Mapping):
            raise TypeError(f"reward_weights must be a dict, got {weights!r}")
        w = dict(self.weights)
        for k, v in dict(weights or {}).items():
            if k not in self.names:
                raise ValueError(
                    f"unknown reward_weights key {k!r} for task {self.name!r} on "
                    f"{self.core.spec.name}; valid keys: {list(self.names)}"
                )
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise TypeError(f"reward_weights[{k!r}] must be a real number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise ValueError(f"reward_weights[{k!r}] must be finite, got {v!r}")
            w[k] = v
        self.weights = w
        # in place: the kernels read this array at every evaluation
        self.W[:] = [w.get(c, 0.0) for c in self.columns]
        if "internal_force" in w:  # the term is |P tau| / |tau_max| (0..1), see below
            self.W[self.columns.index("internal_force")] /= internal_force_scale(self.core)

    def term_names(self, spec: RobotConstants) -> tuple[str, ...]:
        return tuple(c for c in self.columns if c != "internal_force"
                     or spec.has_internal_force)

    def _tail_bounds(self) -> tuple[list[float], list[str]]:
        spec = self.core.spec
        v, w = self.core.vclip, self.core.wclip
        return [v, v, w, *spec.feat_high], ["vx", "vy", "wz", *spec.feat_names]

    def obs_layout(self) -> tuple[list[str], np.ndarray]:
        raise NotImplementedError

    #: Keys of ``reset(options=...)`` (the env docstring's "Reset Options" table).
    option_keys: ClassVar[tuple[str, ...]] = ()

    def parse_options(self, options: Mapping[str, Any] | None) -> dict[str, Any]:
        """Validate ``options`` (``ValueError`` naming unknown keys and the valid ones) and
        return each given one per row (entry i for row i; ``None`` values are left out)."""
        if options is None:
            return {}
        if not isinstance(options, Mapping):
            raise TypeError(f"options must be a dict, got {type(options).__name__}")
        unknown = [k for k in options if k not in self.option_keys]
        if unknown:
            raise ValueError(f"unknown reset option(s) {unknown} for task {self.name!r}; "
                             f"valid options: {list(self.option_keys)}")
        n = self.core.num
        out: dict[str, Any] = {}
        for k, v in options.items():
            if v is not None:
                out[k] = self._parse_option(k, v, n)
        return out

    def _parse_option(self, key: str, value: Any, n: int) -> Any:
        return _pose_option(key, value, n)  # start, goal

    def reset_rows(self, idx: Sequence[int], rngs, options: dict[str, Any]) -> np.ndarray:
        """Draw the episodes of rows ``idx`` (row i from ``rngs[i]``), apply the parsed
        ``options`` and return the start poses ``(len(idx), 3)``."""
        raise NotImplementedError

    #: Attributes rebuilt after a copy (compiled callables).
    _derived: ClassVar[tuple[str, ...]] = ()

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._derived}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    def evaluate(self, rows: np.ndarray | None = None) -> None:
        """Observation, reward terms, end and success of ``rows`` (all when None) from the
        core's blocks; other rows are not touched."""
        raise NotImplementedError

    def evaluate_all(self) -> Callable[[], None]:
        """``evaluate()`` (every row) as a callable without arguments; a task whose kernel
        reads only its own and the core's buffers (never reassigned, only written in place)
        binds its compiled entry point to them (the single env's step, ``WheelCore._step``)."""
        return self.evaluate


class GoalTask(Task):
    """Reach a goal pose; see :class:`wheelgym.envs.WheelEnv` for the tables."""

    name = "goal"
    columns = ("progress", "heading", "effort", "internal_force", "success", "overspeed",
               "collision", "proximity", "saturation")
    default_weights = {"progress": 1.0, "heading": 0.02, "effort": 0.01, "internal_force": 0.2,
                       "success": 10.0, "overspeed": 10.0, "collision": 10.0, "proximity": 0.0,
                       "saturation": 0.0}
    #: Observation entries that are functions of the desired goal (left out of a
    #: ``goal_free_observation``).
    goal_entries: tuple[str, ...] = ("goal_x_b", "goal_y_b", "cos_dyaw", "sin_dyaw")
    #: Position (m) and heading (rad) tolerances of success.
    tol_pos: float = 0.1
    tol_yaw: float = 0.2
    #: Start-to-goal distance range (m).
    goal_dist: tuple[float, float] = (1.0, 3.0)
    n_rays = 0
    #: Gap (m) between the footprint and the nearest obstacle below which the ``proximity``
    #: term (navigate) grows linearly from 0 to 1 at contact.
    d_safe: float = 0.5

    def __init__(self, core: BatchView, weights: Mapping[str, float] | None) -> None:
        super().__init__(core, weights)
        N = core.num
        self.goal = np.zeros((N, 3))
        self.prev = np.zeros(N)
        self.ranges = np.zeros((N, self.n_rays))
        #: distance from each robot's centre to the nearest obstacle (m; navigate's sensing)
        self.clear = np.zeros(N)
        self.cfg = np.array([self.tol_pos, self.tol_yaw, core.spec.v_max, core.spec.w_max,
                             POS_CLIP, core.vclip, core.wclip, core.spec.radius, self.d_safe])
        # the whole batch over numba's threads where the core uses them (same bits per row)
        self._threaded = core.threaded
        self._k_all = k_goal_par if core.threaded else k_goal

    option_keys = ("start", "goal")
    _derived = ("_k_all",)

    def __setstate__(self, state: dict[str, Any]) -> None:
        super().__setstate__(state)
        self._k_all = k_goal_par if self._threaded else k_goal

    def term_names(self, spec) -> tuple[str, ...]:
        return tuple(n for n in super().term_names(spec) if n not in ("collision", "proximity"))

    def obs_layout(self) -> tuple[list[str], np.ndarray]:
        tail, tnames = self._tail_bounds()
        names = ["goal_x_b", "goal_y_b", "cos_dyaw", "sin_dyaw", *tnames]
        high = [POS_CLIP, POS_CLIP, 1.0, 1.0, *tail]
        return names, np.array(high)

    def reset_rows(self, idx, rngs, options):
        # six uniform draws per row in one call each (k_goal_reset says what they become)
        rows = np.asarray(idx, dtype=np.int64)
        U = np.empty((rows.size, 6))
        for n, i in enumerate(rows.tolist()):
            rngs[i].random(out=U[n])
        poses = np.empty((rows.size, 3))
        k_goal_reset(rows, U, float(self.goal_dist[0]), float(self.goal_dist[1]), _TWO_PI,
                     self.goal, self.prev, poses)
        if options:  # replace the drawn start or goal
            start, goal = options.get("start"), options.get("goal")
            for n, i in enumerate(rows.tolist()):
                if start is not None:
                    poses[n] = start[i]
                if goal is not None:
                    self.goal[i] = goal[i]
                self.prev[i] = math.hypot(self.goal[i, 0] - poses[n, 0],
                                          self.goal[i, 1] - poses[n, 1])
        return poses

    def _kernel_args(self, rows: np.ndarray) -> tuple[Any, ...]:
        """The goal kernel's arguments for ``rows``."""
        c = self.core
        return (rows, c.B, c.F, c.m, self.goal, self.prev, self.ranges, self.clear, self.cfg,
                c.fclip, self.W, c.obs, c.terms)

    def evaluate(self, rows: np.ndarray | None = None) -> None:
        if rows is None:
            self._k_all(*self._kernel_args(self.core.all_rows))
        else:
            k_goal(*self._kernel_args(rows))

    def evaluate_all(self) -> Callable[[], None]:
        if type(self).evaluate is not GoalTask.evaluate:  # (navigate senses first)
            return self.evaluate
        args = self._kernel_args(self.core.all_rows)
        return functools.partial(entry_point(self._k_all, *args), *args)

    def target_pose(self) -> np.ndarray:
        return self.goal

    # -------------------------------------------------- goal-conditioned (HER) observations
    #: The goal spaces hold the yaw as (cos, sin) after (x, y) (navigate: position only).
    goal_yaw: ClassVar[bool] = True
    #: Reward term columns that depend on the goal (the others are summed into
    #: ``info["reward_goal_free"]``): progress, heading (goal only), success.
    _goal_cols: ClassVar[tuple[int, ...]] = (0, 1, 4)

    @property
    def goal_dim(self) -> int:
        """Length of ``achieved_goal`` and ``desired_goal``: 4 (x, y, cos yaw, sin yaw) or 2."""
        return 4 if self.goal_yaw else 2

    def goal_high(self) -> np.ndarray:
        """Bounds of the goal spaces: the true (unclipped) position within
        :data:`GOAL_POS_BOUND` m; cos and sin in [-1, 1]."""
        return np.array([GOAL_POS_BOUND, GOAL_POS_BOUND, 1.0, 1.0][:self.goal_dim])

    def _as_goal(self, pose: np.ndarray) -> np.ndarray:
        out = np.empty((pose.shape[0], self.goal_dim))
        out[:, :2] = pose[:, :2]
        if self.goal_yaw:
            out[:, 2] = np.cos(pose[:, 2])
            out[:, 3] = np.sin(pose[:, 2])
        return out

    def achieved_goal(self) -> np.ndarray:
        """Every row's pose in the goal space ``(N, goal_dim)`` float64 (a new array)."""
        return self._as_goal(self.core.pose)

    def desired_goal(self) -> np.ndarray:
        """Every row's goal in the goal space ``(N, goal_dim)`` float64 (a new array)."""
        return self._as_goal(self.goal)

    def goal_info(self, prev_achieved: np.ndarray, reset: np.ndarray | None = None
                  ) -> dict[str, np.ndarray]:
        """The step info that :meth:`compute_reward` needs, per row (new arrays):
        ``prev_achieved_goal`` (the achieved goal before the step), ``reward_goal_free`` (the
        weighted terms that do not depend on the goal), ``success_allowed`` (no numerical
        failure, no collision) and ``terminated_goal_free`` (overspeed, failure or collision).
        Rows ``reset`` (just reset) get their reset values: the current achieved goal, 0 and
        False."""
        c = self.core
        free = [k for k in range(len(self.columns)) if k not in self._goal_cols]
        gfree = np.zeros(c.num)
        for k in free:  # the kernel's order of summation
            gfree += c.terms[:, k]
        vmax, wmax = self.cfg[2], self.cfg[3]
        tw = c.twist
        over = ~c.ok | (np.sqrt(tw[:, 0] * tw[:, 0] + tw[:, 1] * tw[:, 1]) > vmax) \
            | (np.abs(tw[:, 2]) > wmax)
        prev = np.array(prev_achieved, dtype=np.float64)
        tfree = over | c.coll
        if reset is not None and len(reset):
            prev[reset] = self.achieved_goal()[reset]
            gfree[reset] = 0.0
            tfree[reset] = False
        return {"prev_achieved_goal": prev, "reward_goal_free": gfree,
                "success_allowed": c.ok & ~c.coll, "terminated_goal_free": tfree}

    def _goal_terms(self, achieved: np.ndarray, desired: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance, |yaw error| (0 without yaw) and the tolerance test, as the kernel."""
        dx = desired[..., 0] - achieved[..., 0]
        dy = desired[..., 1] - achieved[..., 1]
        d = np.sqrt(dx * dx + dy * dy)
        if self.goal_yaw:  # yaw error: goal yaw minus yaw, wrapped by atan2
            ca, sa, cg, sg = achieved[..., 2], achieved[..., 3], desired[..., 2], desired[..., 3]
            ey = np.abs(np.arctan2(sg * ca - cg * sa, cg * ca + sg * sa))
        else:
            ey = np.zeros_like(d)
        return d, ey, (d < self.tol_pos) & (ey < self.tol_yaw)

    def goal_observation(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The observation's goal entries (:attr:`goal_entries`: ``goal_x_b``, ``goal_y_b``,
        ``cos_dyaw``, ``sin_dyaw``) for the robot at ``achieved`` and the goal ``desired``
        (goal-space arrays, batched over leading axes), as the kernel's ``_target_obs``
        computes them from the pose: the goal's position in the body frame, clipped to
        ``POS_CLIP``, and cos and sin of goal yaw minus yaw. Float64 ``(..., 4)``.

        Raises:
            ValueError: the task's goal entries are not functions of its goal space (navigate:
                its goal space holds no yaw, and its bearing entries follow the plan)."""
        if type(self).goal_entries != GoalTask.goal_entries or not self.goal_yaw:
            raise ValueError(f"the {self.name} task's observation entries {self.goal_entries} "
                             "are not functions of its goal space (x, y"
                             f"{', cos yaw, sin yaw' if self.goal_yaw else ''}): only the goal "
                             "task's observation can be relabelled")
        achieved, desired = _goal_arrays(achieved, desired, self.goal_dim)
        ca, sa = achieved[..., 2], achieved[..., 3]
        cg, sg = desired[..., 2], desired[..., 3]
        dx = desired[..., 0] - achieved[..., 0]
        dy = desired[..., 1] - achieved[..., 1]
        out = np.empty(achieved.shape[:-1] + (4,))
        out[..., 0] = np.clip(ca * dx + sa * dy, -POS_CLIP, POS_CLIP)
        out[..., 1] = np.clip(-sa * dx + ca * dy, -POS_CLIP, POS_CLIP)
        out[..., 2] = cg * ca + sg * sa  # cos(goal yaw - yaw)
        out[..., 3] = sg * ca - cg * sa  # sin(goal yaw - yaw)
        return out

    def compute_reward(self, achieved: np.ndarray, desired: np.ndarray,
                       info: HerInfo) -> np.ndarray:
        """The step reward for any goals, batched over leading axes (Gymnasium-Robotics)."""
        achieved, desired = _goal_arrays(achieved, desired, self.goal_dim)
        prev, gfree, allowed, _ = her_info_arrays(info, achieved.shape[:-1], self.goal_dim)
        W = self.W
        d, ey, near = self._goal_terms(achieved, desired)
        pdx = desired[..., 0] - prev[..., 0]
        pdy = desired[..., 1] - prev[..., 1]
        r = W[0] * (np.sqrt(pdx * pdx + pdy * pdy) - d)
        if self.goal_yaw:
            r = r + -W[1] * ey / math.pi
        r = r + np.where(allowed & near, W[4], 0.0)
        return r + gfree

    def compute_terminated(self, achieved: np.ndarray, desired: np.ndarray,
                           info: HerInfo) -> np.ndarray:
        """Whether the step ends the episode for these goals: success within the tolerances,
        or an end that does not depend on the goal (overspeed, failure, collision)."""
        achieved, desired = _goal_arrays(achieved, desired, self.goal_dim)
        _, _, allowed, tfree = her_info_arrays(info, achieved.shape[:-1], self.goal_dim)
        return (allowed & self._goal_terms(achieved, desired)[2]) | tfree


#: ``compute_reward``'s ``info``: one step info dict, a batched (vector) info dict, or a
#: sequence / object array of step info dicts.
HerInfo = Any
#: Keys of the step info that ``compute_reward`` and ``compute_terminated`` read.
HER_INFO_KEYS = ("prev_achieved_goal", "reward_goal_free", "success_allowed",
                 "terminated_goal_free")
#: Bound of the goal spaces' positions (m).
GOAL_POS_BOUND = 1e4


def _goal_arrays(achieved: Any, desired: Any, dim: int) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(achieved, dtype=np.float64)
    g = np.asarray(desired, dtype=np.float64)
    if a.shape[-1:] != (dim,) or g.shape[-1:] != (dim,):
        raise ValueError(f"achieved_goal and desired_goal must end in an axis of {dim}, got "
                         f"shapes {a.shape} and {g.shape}")
    a, g = np.broadcast_arrays(a, g)
    return a, g


def _require_her_keys(info: Any) -> None:
    if not isinstance(info, Mapping) or any(k not in info for k in HER_INFO_KEYS):
        got = sorted(info) if isinstance(info, Mapping) else type(info).__name__
        raise ValueError(
            f"compute_reward needs the step info's {', '.join(HER_INFO_KEYS)} (progress and "
            f"the goal-free terms are not functions of the goals; got {got}): with SB3's "
            "HerReplayBuffer pass replay_buffer_kwargs=dict(..., copy_info_dict=True)")


def her_info_arrays(info: HerInfo, batch: tuple[int, ...], dim: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``info``'s :data:`HER_INFO_KEYS` as arrays of leading shape ``batch``.

    The reward cannot be computed from the goals alone: its progress term needs the achieved
    goal before the step and its effort, internal-force, overspeed and collision terms the
    step's physics. An info without the keys (SB3's ``HerReplayBuffer`` passes empty dicts
    unless ``copy_info_dict=True``) raises a ``ValueError`` saying what to set."""
    if isinstance(info, Mapping):
        _require_her_keys(info)
        vals = [np.asarray(info[k]) for k in HER_INFO_KEYS]
    else:
        rows = list(np.asarray(info, dtype=object).reshape(-1))
        if len(rows) != int(np.prod(batch, dtype=np.int64)):
            raise ValueError(f"info must hold one dict per goal ({int(np.prod(batch))}), got "
                             f"{len(rows)}")
        for r in rows:
            _require_her_keys(r)
        vals = [np.array([r[k] for r in rows]) for k in HER_INFO_KEYS]
    try:
        prev = vals[0].astype(np.float64).reshape(*batch, dim)
        return (prev, *(v.reshape(batch) for v in vals[1:]))
    except ValueError:
        raise ValueError(f"info's {list(HER_INFO_KEYS)} do not match the goals' batch shape "
                         f"{batch}") from None


#: navigate ``version=1`` (the ``-v1`` ids): default weights, in per-episode units
#: (:class:`NavigateTask`'s docstring): progress ``w_p`` over the arena's diagonal, the
#: per-step costs over the horizon, the ends as they are.
NAVIGATE_V1_WEIGHTS = {"progress": 10.0, "heading": 0.0, "effort": 1.0, "internal_force": 1.0,
                       "success": 20.0, "overspeed": 20.0, "collision": 20.0,
                       "proximity": 1.0, "saturation": 0.0}
#: The per-step cost columns (each term's value lies in [0, 1]).
_COST_TERMS = ("heading", "effort", "internal_force", "proximity", "saturation")


def navigate_v1_bound(weights: Mapping[str, float]) -> tuple[float, float]:
    """``(w_p + C, C)`` of a navigate -v1 weight set: the least failure penalty and the least
    success bonus for which no policy gains by ending early (:class:`NavigateTask`), with
    ``C`` the sum of the per-step cost weights."""
    c = sum(abs(float(weights.get(k, 0.0))) for k in _COST_TERMS)
    return abs(float(weights.get("progress", 0.0))) + c, c


class NavigateTask(GoalTask):
    """Reach a goal position in an arena with obstacles, sensing them with range rays.

    ``version=1`` (the ``-v1`` ids) changes the reward's units so that no policy gains by
    ending its episode early (crashing, overspeeding) or by standing still, and adds
    observation entries. Each weight is what its term can add up to over one episode:

    * progress: ``(w_p / D) (d_{t-1} - d_t)`` with ``D`` the diagonal of the arena's bounds
      (m), the farthest a robot inside the walls can be from its goal;
    * the per-step costs (heading, effort, internal_force, proximity, saturation; each term's
      value in [0, 1]): weight ``w_c / T`` per step, ``T`` the core's ``horizon`` (500, the
      ids' ``max_episode_steps``), so an episode of at most ``T`` steps pays at most
      ``C = sum w_c`` in all;
    * success ``+S``, overspeed and collision ``-P`` once, as in v0.

    The bound (derivation). Take any step ``k`` and any state. A failure at step ``k + 1``
    gets at most ``(w_p / D) d_k - P`` from there on (the last progress is at most
    ``(w_p / D) d_k``, the cost is not negative). Any continuation without a failure end (stand
    still, drive on, time out or succeed) gets at least ``(w_p / D) (d_k - d_end) - C >=
    (w_p / D) d_k - w_p - C`` (``d_end <= D``; the success bonus is not negative). So with
    ``P > w_p + C`` every continuation beats failing from the same state: no early-end gain.
    Standing still for a whole episode earns ``-C <= G_still <= 0``; reaching the goal from
    ``d_0`` earns at least ``(w_p / D)(d_0 - tol) - C + S``, more than any standing still when
    ``S > C``. The defaults (:data:`NAVIGATE_V1_WEIGHTS`): ``w_p = 10``, ``C = 3``,
    ``P = S = 20 > 13``; :func:`navigate_v1_bound` gives both limits of a weight set
    (tests/planning/test_navigate_v1.py checks the bound on constructed episodes).

    v1's observation appends, after the rays: the goal in polar body coordinates
    ``goal_dist`` (m, clipped to 12), ``cos_bearing``, ``sin_bearing``; with
    ``waypoint_hint=True`` also ``waypoint_x_b``, ``waypoint_y_b`` (m): the point 1 m along the
    planning baseline's plan (:class:`~wheelgym.planning.WaypointHint`: robots that turn in
    place a shortest grid path, re-planned when the robot strays from it by 0.5 m; cars the run
    of the hybrid-A* plan their tracker follows, up to its next cusp), and for cars the rest of
    the tracker's :class:`~wheelgym.kinematics.car_tracking.TrackFrame`: ``plan_offset`` (m),
    ``plan_heading`` (rad), ``plan_curvature`` (1/m), ``plan_direction`` (+1, -1, 0),
    ``plan_remaining`` (m, clipped to 12).
    """

    name = "navigate"
    goal_entries = (*GoalTask.goal_entries, "goal_dist", "cos_bearing", "sin_bearing")
    default_weights = {**GoalTask.default_weights, "heading": 0.0}
    tol_pos = 0.25
    tol_yaw = math.inf
    n_rays = 16
    max_range = 3.0
    goal_yaw = False
    _goal_cols = (0, 4)  # heading (weight 0 by default) compares with the env's goal yaw

    def __init__(self, core: BatchView, weights: Mapping[str, float] | None,
                 range_backend: str = "analytic", arena: str | None = None,
                 version: int = 0, waypoint_hint: bool = False) -> None:
        from wheelgym.world import Arena, load_map

        if version not in (0, 1):
            raise ValueError(f"version must be 0 or 1, got {version!r}")
        self.version = int(version)
        if self.version == 0:
            from gymnasium import logger

            robot = core.spec.name
            logger.deprecation(
                f"navigate on wheelgym/{robot}-v0: -v0 is out of date for this task (its "
                f"reward lets a policy gain by ending an episode early); use "
                f"wheelgym/{robot}-v1 (docs/topics/planning.md)")
        self.waypoint_hint = bool(waypoint_hint) and self.version == 1
        self._scale: np.ndarray | None = None  # v1's per-column weight scales (below)
        if self.version == 1:
            self.default_weights = NAVIGATE_V1_WEIGHTS
        super().__init__(core, weights)
        if range_backend not in ("analytic", "pymunk"):
            raise ValueError(
                f"range_backend must be one of ['analytic', 'pymunk'], got {range_backend!r}"
            )
        self.backend = range_backend
        #: the random arena (redrawn at each reset) or a map's static world (start and goal
        #: drawn in its reachable free space at each reset)
        self.arena = Arena() if arena is None else load_map(arena)
        N = core.num
        self.circles = np.zeros((N, max(1, self.arena.max_circles), 3))
        self.nc = np.zeros(N, dtype=np.int64)
        self.segs = np.zeros((N, self.arena.max_segments, 4))
        self.ns = np.zeros(N, dtype=np.int64)
        self.spaces: list[Any] = [None] * N
        self.worlds: list[Any] = [None] * N
        self.hint = None
        if self.version == 1:
            b = getattr(self.arena, "bounds", None)
            if b is None:
                L = float(self.arena.half_size)
                b = (-L, -L, L, L)
            #: v1: the arena's diagonal (m), the progress term's unit
            self.diagonal = float(math.hypot(b[2] - b[0], b[3] - b[1]))
            scale = np.ones(len(self.columns))
            scale[self.columns.index("progress")] = 1.0 / self.diagonal
            for k in _COST_TERMS:
                scale[self.columns.index(k)] = 1.0 / core.horizon
            self._scale = scale
            self.set_weights(None)  # the scales on the weights set above
            if self.waypoint_hint:
                from wheelgym.planning import WaypointHint

                car = None if core.spec.turns_in_place else core.model
                self.hint = WaypointHint(self.arena, core.spec.radius, N, car=car, dt=core.dt)
            self._polar = np.zeros((N, 3 + len(self._hint_layout()[0])))
            self._obs_end = len(self.obs_layout()[0])  # where v1's entries end in core.obs

    option_keys = ("start", "goal", "layout_seed")

    def set_weights(self, weights: Mapping[str, float] | None) -> None:
        super().set_weights(weights)
        if self._scale is not None:  # v1: the weights are per-episode totals (docstring)
            self.W *= self._scale

    def term_names(self, spec) -> tuple[str, ...]:
        return Task.term_names(self, spec)

    def _parse_option(self, key: str, value: Any, n: int) -> Any:
        if key != "layout_seed":
            return super()._parse_option(key, value, n)

        def seed(v: Any) -> int:
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) \
                    or v < 0:
                raise ValueError(f"options['layout_seed'] must be an int >= 0 (or one per "
                                 f"sub-env), got {v!r}")
            return int(v)

        return _per_row(key, value, n, seed, "int seed")

    def _check_clear(self, key: str, world: Any, pose: np.ndarray) -> None:
        """``ValueError`` unless the robot's circle at ``pose`` is free of the layout."""
        from wheelgym.world import k_clearance

        r = self.core.spec.radius
        if hasattr(self.arena, "is_free"):  # a map: inside its walls, clear of its obstacles
            if not self.arena.is_free(pose[None, :2], r)[0]:
                raise ValueError(
                    f"options[{key!r}] = {pose.tolist()} is not free: the robot's circle "
                    f"(radius {r} m) must lie in the map's free space "
                    f"({self.arena.path.name})")
            return
        clear = np.empty(1)
        k_clearance(pose[None, :2], world.circles[None], np.array([len(world.circles)]),
                    world.segments[None], np.array([len(world.segments)]), clear)
        lim = self.arena.half_size
        if not (clear[0] >= r and abs(pose[0]) < lim and abs(pose[1]) < lim):
            raise ValueError(f"options[{key!r}] = {pose.tolist()} is not free: the robot's "
                             f"circle (radius {r} m) must lie inside the walls (+-{lim} m) "
                             f"and clear of the obstacles (clearance {clear[0]:.3g} m)")

    def _extra_layout(self) -> tuple[list[str], list[float], list[float]]:
        """v1's entries after the rays: names, lows, highs."""
        if self.version == 0:
            return [], [], []
        names = ["goal_dist", "cos_bearing", "sin_bearing"]
        low, high = [0.0, -1.0, -1.0], [POS_CLIP, 1.0, 1.0]
        hn, hl, hh = self._hint_layout()
        return names + hn, low + hl, high + hh

    def _hint_layout(self) -> tuple[list[str], list[float], list[float]]:
        """The waypoint hint's entries: names, lows, highs (none without the hint)."""
        if not self.waypoint_hint:
            return [], [], []
        names = ["waypoint_x_b", "waypoint_y_b"]
        low, high = [-POS_CLIP, -POS_CLIP], [POS_CLIP, POS_CLIP]
        if self.hint.cars is not None:  # a car: its tracker's frame (WaypointHint)
            kappa = 1.0 / self.hint.cars[0].radius  # the plan's tightest turn
            names += ["plan_offset", "plan_heading", "plan_curvature", "plan_direction",
                      "plan_remaining"]
            low += [-POS_CLIP, -math.pi, -kappa, -1.0, 0.0]
            high += [POS_CLIP, math.pi, kappa, 1.0, POS_CLIP]
        return names, low, high

    def obs_layout(self):
        names, high = super().obs_layout()
        names += [f"range_{k}" for k in range(self.n_rays)]
        xn, _, xh = self._extra_layout()
        return names + xn, np.concatenate([high, np.full(self.n_rays, self.max_range), xh])

    def obs_low(self) -> np.ndarray:
        _, high = self.obs_layout()
        xn, xl, _ = self._extra_layout()
        low = -high
        end = len(low) - len(xn)
        low[end - self.n_rays:end] = 0.0
        low[end:] = xl
        return low

    def reset_rows(self, idx, rngs, options):
        from wheelgym.world import build_space

        poses = np.zeros((len(idx), 3))
        seeds, start, goal = (options.get(k) for k in ("layout_seed", "start", "goal"))
        radius = self.core.spec.radius
        for n, i in enumerate(idx):
            w = self.arena.generate(rngs[i], radius)
            if seeds is not None:  # the layout of that seed (rngs[i] advanced all the same)
                w = self.arena.generate(np.random.default_rng(seeds[i]), radius)
            if start is not None or goal is not None:
                w = dataclasses.replace(
                    w, start=w.start if start is None else np.array(start[i]),
                    goal=w.goal if goal is None else np.array(goal[i]))
                for key, pose in (("start", start), ("goal", goal)):
                    if pose is not None:
                        self._check_clear(key, w, pose[i])
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

    def sense(self, rows: np.ndarray | None = None) -> None:
        """Range readings and collision flags at the current poses of ``rows`` (all: None)."""
        from wheelgym.world import k_clearance, k_ranges, pymunk_ranges

        c = self.core
        if rows is None:
            if self.backend == "analytic":
                k_ranges(c.pose, self.circles, self.nc, self.segs, self.ns, self.max_range,
                         self.ranges)
            else:
                for i in range(c.num):
                    pymunk_ranges(self.spaces[i], c.pose[i], self.n_rays, self.max_range,
                                  self.ranges[i])
            k_clearance(c.pose, self.circles, self.nc, self.segs, self.ns, self.clear)
            np.less(self.clear, c.spec.radius, out=c.coll)
            return
        # a few rows (a partial reset): the same kernels on those rows' copies
        pose, circles, nc, segs, ns = (c.pose[rows], self.circles[rows], self.nc[rows],
                                       self.segs[rows], self.ns[rows])
        if self.backend == "analytic":
            ranges = np.empty((len(rows), self.n_rays))
            k_ranges(pose, circles, nc, segs, ns, self.max_range, ranges)
            self.ranges[rows] = ranges
        else:
            for i in rows:
                pymunk_ranges(self.spaces[i], c.pose[i], self.n_rays, self.max_range,
                              self.ranges[i])
        clear = np.empty(len(rows))
        k_clearance(pose, circles, nc, segs, ns, clear)
        self.clear[rows] = clear
        c.coll[rows] = clear < c.spec.radius

    def evaluate(self, rows: np.ndarray | None = None) -> None:
        self.sense(rows)
        super().evaluate(rows)
        if self.version == 1:
            self._extra_obs(self.core.all_rows if rows is None else rows)

    def _extra_obs(self, rows: np.ndarray) -> None:
        """v1's polar goal (and the waypoint hint) of ``rows``, after the kernel's entries."""
        c = self.core
        pose = c.pose[rows]
        out = self._polar[:len(rows)] if len(rows) <= len(self._polar) else \
            np.zeros((len(rows), self._polar.shape[1]))
        dx = self.goal[rows, 0] - pose[:, 0]
        dy = self.goal[rows, 1] - pose[:, 1]
        cy, sy = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        bx, by = cy * dx + sy * dy, -sy * dx + cy * dy
        d = np.sqrt(bx * bx + by * by)
        safe = np.where(d > 0.0, d, 1.0)
        out[:, 0] = np.minimum(d, POS_CLIP)
        out[:, 1] = np.where(d > 0.0, bx / safe, 1.0)
        out[:, 2] = np.where(d > 0.0, by / safe, 0.0)
        if self.hint is not None:
            if self.hint.cars is not None:
                way = np.empty((len(rows), 2))
                for n, i in enumerate(rows.tolist()):
                    # the tracker reads the whole model state (Ackermann: its steering)
                    f = self.hint.frame(i, self.worlds[i], c.X[i], self.goal[i],
                                        c.steps[i] == 0)
                    way[n] = f.ahead
                    out[n, 5] = np.clip(f.offset, -POS_CLIP, POS_CLIP)
                    out[n, 6:9] = f.heading, f.curvature, f.direction
                    out[n, 9] = min(f.remaining, POS_CLIP)
            else:
                way = self.hint.points(rows, [self.worlds[i] for i in rows.tolist()], pose,
                                       self.goal[rows], c.steps[rows] == 0)
            ex, ey = way[:, 0] - pose[:, 0], way[:, 1] - pose[:, 1]
            # (np.clip's own overhead is most of a single env's cost here)
            out[:, 3] = np.minimum(np.maximum(cy * ex + sy * ey, -POS_CLIP), POS_CLIP)
            out[:, 4] = np.minimum(np.maximum(-sy * ex + cy * ey, -POS_CLIP), POS_CLIP)
        end = self._obs_end  # the task's last entries (core.obs may hold more after them)
        c.obs[rows, end - out.shape[1]:end] = out


class TrackTask(Task):
    """Follow a reference trajectory (circle, figure-eight or the paper's quintic circle).

    Each row holds its reference object and a window of its control steps (pose, body twist,
    twist rate); the window moves on when a preview would leave it, and all due rows of one
    reference class are evaluated in one NumPy pass
    (:func:`~wheelgym.kinematics.references.evaluate_batch`), so memory per row is fixed whatever
    the episode length, and the reference never runs out (any ``max_episode_steps``, ``None``
    included): the circle and the figure-eight go on lapping, the quintic circle rests at its
    end pose after its ``duration`` (its rest-to-rest time law). A batch of more than
    ``whole_up_to`` robots keeps ``window`` steps a row (about 4.6 KB at 64); smaller batches
    (the single env) keep ``horizon + preview_steps[-1] + 2`` steps (the core's ``horizon``,
    at most ``max_table``), evaluated at the reset and then once per that many steps (a
    short window costs the single env ~4 us a step). All hold the same values
    (element-wise evaluation).

    The drawn references respect the robot's turning radius: for a car-like robot (Bicycle,
    Ackermann: ``R_min = l / tan(psi_max)``, 0.87 m by default) circle and quintic-circle radii
    and the figure-eight's size are scaled up (speeds unchanged) so that no reference turns
    tighter than :attr:`min_radius_factor` ``R_min``. The eight
    ``(A sin wt, A/2 sin 2wt)`` turns tightest at ``wt = 0.900`` rad and its symmetric points,
    radius ``0.2088 A``: unscaled (``A`` 1-2 m, radii 0.21-0.42 m) a car cannot follow it
    without backing and filling. Robots that turn in place draw the unscaled references.

    Reset options: ``reference`` (a :class:`~wheelgym.kinematics.references.Reference`, followed
    from its time 0 as placed, no random rotation or offset; it may be as tight as the user
    likes) and ``start`` (the robot's start pose instead of the reference's first pose).
    """

    name = "track"
    columns = ("position", "heading", "effort", "internal_force", "overspeed", "lost",
               "saturation")
    default_weights = {"position": 1.0, "heading": 0.1, "effort": 0.01, "internal_force": 0.2,
                       "overspeed": 10.0, "lost": 10.0, "saturation": 0.0}
    #: Preview offsets (control steps) of the reference points in the observation.
    preview_steps = np.array([10, 20, 30], dtype=np.int64)
    #: Distance (m) beyond which the robot is lost (the episode ends).
    lost_dist = 1.0
    #: A step counts as success (``is_success``) within this distance (m).
    tol_pos = 0.05
    references = ("circle", "figure_eight", "quintic_circle")
    #: Drawn references turn no tighter than this times the robot's smallest turning radius
    #: (the car planner's margin, :class:`~wheelgym.kinematics.CarTracker`'s ``radius_factor``:
    #: the rest of the steering range is the feedback's).
    min_radius_factor = 1.25
    #: Smallest radius (m) of each drawn reference kind at scale 1: circle and quintic-circle
    #: radii from 0.8 m, the figure-eight's ``0.20876 A`` (the lemniscate's smallest radius of
    #: curvature, found numerically; rounded down) with ``A`` from 1 m.
    _tightest = {"circle": 0.8, "figure_eight": 0.2087, "quintic_circle": 0.8}
    #: Control steps of the reference held per row in a batch.
    window = 64
    #: Batches of up to this many robots keep ``horizon`` steps (+ the previews) instead.
    whole_up_to = 8
    #: Most steps of that table (a larger ``horizon`` is capped: memory and reset work).
    max_table = 4096
    option_keys = ("start", "reference")

    def __init__(self, core: BatchView, weights: Mapping[str, float] | None) -> None:
        super().__init__(core, weights)
        N = core.num
        # steps ahead of the current one that are read: the previews and the baseline's k + 1
        self.ahead = int(self.preview_steps[-1]) + 1
        # the kernels' "last step" (they hold it after): none, the windows move on forever
        self.L = _NO_END
        #: Steps the render's path shows (the first table's span).
        self.span = min(core.horizon, self.max_table) + self.ahead + 1
        # window length (steps): a batch keeps ``window`` steps a row; a few robots (the
        # single env) keep ``span`` steps, evaluated at the reset (same values)
        self.nw = self.span if N <= self.whole_up_to else min(self.window, self.span)
        self.ref = np.zeros((N, self.nw, 6))
        self.ref_rate = np.zeros((N, self.nw, 3))
        self.kstep = np.zeros(N, dtype=np.int64)
        self.kbase = np.zeros(N, dtype=np.int64)  # step of window column 0, per row
        self.kind = [""] * N
        self.objs: list[Any] = [None] * N
        self.t0 = np.zeros(N)  # reference time at step 0 (s)
        self.place = np.zeros((N, 5))  # rigid placement: cos th, sin th, ox, oy, th
        self._slack = 0  # steps before any row's window must move on
        self.cfg = np.array([core.spec.v_max, core.spec.w_max, self.lost_dist, self.tol_pos,
                             POS_CLIP, core.vclip, core.wclip])
        # size factor of each drawn kind: 1 for robots that turn in place
        r = self.min_radius_factor * min_turning_radius(core.base_params)
        self.scale = {k: max(1.0, r / tight) for k, tight in self._tightest.items()}

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
        k = self.scale[kind]  # the turning-radius scale (1 unless a car)
        if kind == "circle":
            ref = Circle(radius=rng.uniform(0.8, 2.0) * k, speed=rng.uniform(0.4, 1.0) * vmax,
                         clockwise=cw)
            t0 = rng.uniform(0.0, ref.duration)
        elif kind == "figure_eight":
            size = rng.uniform(1.0, 2.0) * k
            # lap length of the eight is about 6.1 size; mean speed up to vmax
            ref = FigureEight(size=size, period=6.1 * size / (rng.uniform(0.4, 1.0) * vmax))
            t0 = rng.uniform(0.0, ref.duration)
        else:
            ref = QuinticCircle(radius=rng.uniform(0.8, 1.5) * k,
                                duration=rng.uniform(20.0, 40.0))
            t0 = 0.0
        return kind, ref, t0

    def _parse_option(self, key: str, value: Any, n: int) -> Any:
        if key != "reference":
            return super()._parse_option(key, value, n)

        def one(v: Any) -> Reference:
            if not isinstance(v, Reference):
                raise TypeError(f"options['reference'] must be a wheelgym.tasks.Reference "
                                f"(Circle, FigureEight, QuinticCircle, Line, PointToPoint...) "
                                f"or one per sub-env, got {type(v).__name__}")
            return v

        return _per_row(key, value, n, one, "Reference")

    def reset_rows(self, idx, rngs, options):
        given, start = options.get("reference"), options.get("start")
        for i in idx:
            rng = rngs[i]
            kind, ref, t0 = self._draw_reference(rng)
            # random rigid placement: rotate by th about the origin, then shift by (ox, oy)
            th = rng.uniform(-math.pi, math.pi)
            ox, oy = rng.uniform(-1.0, 1.0, 2)
            if given is not None:  # the given reference as placed (the draws made all the same)
                ref, kind, t0 = given[i], type(given[i]).__name__, 0.0
                th = ox = oy = 0.0
            self.place[i] = (math.cos(th), math.sin(th), ox, oy, th)
            self.objs[i] = ref
            self.kind[i] = kind
            self.t0[i] = t0
        idx = np.asarray(idx, dtype=np.int64)
        self.kstep[idx] = 0
        self.kbase[idx] = 0
        self._fill(idx)
        self._update_slack()
        poses = self.ref[idx, 0, :3].copy()
        if start is not None:
            poses[:] = start[idx]
        return poses

    def _fill(self, rows: np.ndarray) -> None:
        """Evaluate the windows of ``rows`` from their ``kbase`` on (one pass per class)."""
        j = np.arange(self.nw)
        groups: dict[type, list[int]] = {}
        for i in rows:
            groups.setdefault(type(self.objs[i]), []).append(int(i))
        for members in groups.values():
            r = np.array(members, dtype=np.int64)
            k = np.minimum(self.kbase[r, None] + j, self.L - 1)
            pose, twist, rate = evaluate_batch([self.objs[i] for i in members],
                                               k * self.core.dt + self.t0[r, None])
            c, s, ox, oy, th = (self.place[r, q, None] for q in range(5))
            out = self.ref[r]
            out[..., 0] = c * pose[..., 0] - s * pose[..., 1] + ox
            out[..., 1] = s * pose[..., 0] + c * pose[..., 1] + oy
            out[..., 2] = pose[..., 2] + th
            out[..., 3:6] = twist
            self.ref[r] = out
            self.ref_rate[r] = rate

    def _update_slack(self) -> None:
        # a row needs a new window once min(kstep + ahead, L - 1) passes its last column
        last = self.kbase + self.nw - 1
        slack = np.where(last >= self.L - 1, np.iinfo(np.int64).max,
                         last - (self.kstep + self.ahead))
        self._slack = int(slack.min())

    def _kernel_args(self, rows: np.ndarray) -> tuple[Any, ...]:
        """The track kernel's arguments for ``rows``."""
        c = self.core
        return (rows, c.B, c.F, c.m, self.ref, self.kstep, self.kbase, self.L,
                self.preview_steps, self.cfg, c.fclip, self.W, c.obs, c.terms)

    def evaluate(self, rows: np.ndarray | None = None) -> None:
        k_track(*self._kernel_args(self.core.all_rows if rows is None else rows))

    def evaluate_all(self) -> Callable[[], None]:
        if type(self).evaluate is not TrackTask.evaluate:
            return self.evaluate
        args = self._kernel_args(self.core.all_rows)
        return functools.partial(entry_point(k_track, *args), *args)

    def advance(self) -> None:
        """Move every row's reference index one control step on (before integrating), and the
        windows of the rows whose previews would leave theirs."""
        k_add1(self.kstep)
        self._slack -= 1
        if self._slack < 0:
            due = np.flatnonzero(np.minimum(self.kstep + self.ahead, self.L - 1)
                                 > self.kbase + self.nw - 1)
            self.kbase[due] = np.minimum(self.kstep[due], self.L - 1)
            self._fill(due)
            self._update_slack()

    def _column(self, ahead: int = 0) -> np.ndarray:
        """Window column of step ``min(kstep + ahead, L - 1)`` per row."""
        return np.minimum(self.kstep + ahead, self.L - 1) - self.kbase

    def reference_at(self, rows=slice(None)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Reference pose, twist and twist rate at each row's current step."""
        r = self.core.all_rows[rows]
        k = self._column()[rows]
        return self.ref[r, k, :3], self.ref[r, k, 3:6], self.ref_rate[r, k]

    def reference_ahead(self, ahead: int) -> np.ndarray:
        """Reference pose and twist ``(N, 6)`` ``ahead`` steps on (at most ``ahead`` =
        ``preview_steps[-1] + 1``, the span every window covers)."""
        if not 0 <= ahead <= self.ahead:
            raise ValueError(f"ahead must be in [0, {self.ahead}], got {ahead!r}")
        return self.ref[self.core.all_rows, self._column(ahead)]

    def path(self, i: int, stride: int = 1) -> np.ndarray:
        """Row ``i``'s reference path ``(n, 2)`` (m) from step 0 to ``span - 1`` or its
        current preview, whichever is later, every ``stride`` steps (for drawing; evaluated
        on demand)."""
        k = np.arange(0, max(self.span, int(self.kstep[i]) + self.ahead + 1), stride)
        pose = evaluate_batch([self.objs[i]], k[None] * self.core.dt + self.t0[i])[0][0]
        c, s, ox, oy, _ = self.place[i]
        return np.stack([c * pose[:, 0] - s * pose[:, 1] + ox,
                         s * pose[:, 0] + c * pose[:, 1] + oy], axis=-1)

    def target_pose(self) -> np.ndarray:
        return self.reference_at()[0]


TASKS: dict[str, type[Task]] = {"goal": GoalTask, "track": TrackTask, "navigate": NavigateTask}
