"""The environments' keyword arguments as one validated value: :class:`EnvConfig`.

``WheelEnv(**kwargs)``, ``gym.make(id, **kwargs)``, ``gym.make_vec(id, num_envs, **kwargs)`` and
``WheelCore(robot, num, **kwargs)`` all build one :class:`EnvConfig` from their keywords and
pass it down; every keyword is checked here, once (a bad value raises ``ValueError`` or
``TypeError`` naming the keyword and the valid choices or range). What needs the built model
(parameter values, RK4 stability, the ``randomize`` extremes) is checked by
:class:`~wheelgym.envs.core.WheelCore` on the model it builds.

Adding a keyword: one field below (with its default and a line in the docstring) and one check
in :meth:`EnvConfig.__post_init__`; the env classes take it through ``**kwargs`` (their
signatures are built from the fields, :func:`signature_with`) and the core reads it from
``core.config``. Document it in the "Arguments" table of ``wheel_env.py``.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from wheelgym.envs.actuator import MAX_ACTION_DELAY
from wheelgym.envs.perturbation import Perturbation, parse_perturbation
from wheelgym.envs.robots import RANDOMIZE_GROUPS, RobotSpec, get_spec
from wheelgym.integrators import n_substeps
from wheelgym.registration import DEFAULT_HORIZON, VERSIONS
from wheelgym.tasks.tasks import TASKS

__all__ = ["EnvConfig", "RENDER_MODES", "MAX_CTRL_DT", "MAX_SUBSTEPS", "MOTORS",
           "CONTROLLER_MODELS", "MAX_ACTION_HISTORY", "signature_with"]

#: Render modes of the single environment (the vector env offers ``rgb_array`` only).
RENDER_MODES = ("human", "rgb_array")
#: Longest control period (s): a controller acting less than once a second leaves the robot
#: open loop for seconds (the tasks' tolerances and speed limits assume ~0.05 s), and one step
#: would integrate that whole stretch.
MAX_CTRL_DT = 1.0
#: Most RK4 substeps per control step (``ctrl_dt / sim_dt``): a substep costs about 1 us on
#: one robot, so this caps one step near 10 ms (the default is 25-40 substeps; 1e-9 s took
#: 25 s a step).
MAX_SUBSTEPS = 10_000
#: Motor models of the ``motor`` keyword (``wheelgym.models.motor``).
MOTORS = ("ideal", "dc")
#: Models the velocity mode's twist controller may believe in (``controller_model``).
CONTROLLER_MODELS = ("nominal", "true")
#: Most past actions ``action_history`` may append to the observation (twice the `hard`
#: perturbation level's 4-step delay).
MAX_ACTION_HISTORY = 8
#: Most past observations ``obs_history`` may append (the same bound).
MAX_OBS_HISTORY = 8
#: Range backends of the navigate task's range sensor.
RANGE_BACKENDS = ("analytic", "pymunk")


def _check_dt(name: str, value: Any, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TypeError(f"{name} must be a positive number of seconds, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and 0 < v <= high):
        raise ValueError(f"{name} must be a positive finite number of seconds"
                         + (f" <= {high:g}" if high < math.inf else "") + f", got {value!r}")
    return v


def check_bool(name: str, value: Any) -> bool:
    """``value`` as a bool (a NumPy bool too); ``TypeError`` naming ``name`` otherwise."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {value!r}")
    return bool(value)


def _check_number(name: str, value: Any, low: float = -math.inf) -> float:
    """``value`` as a float: a real number (not bool, not a string), finite and >= ``low``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and v >= low):
        raise ValueError(f"{name} must be a finite number" + (f" >= {low:g}" if low > -math.inf
                                                               else "") + f", got {value!r}")
    return v


def _check_randomize(spec: RobotSpec, randomize: Any) -> dict[str, tuple[float, float]]:
    """``randomize`` as group -> (low, high) (``{}``: none); the checks that need only the
    spec (the core checks the ranges' extremes on the model)."""
    if randomize is None or randomize is False:
        return {}
    if randomize is True:
        out = dict(spec.default_randomize)
        if not out:  # nothing to draw: say so rather than silently randomise nothing
            raise ValueError(
                f"randomize=True: {spec.name} has no parameters to randomise (its model has "
                f"no randomize groups); pass randomize=None")
        return out
    if not isinstance(randomize, Mapping):
        raise TypeError(f"randomize must be a dict, True or None, got {randomize!r}")
    out = {}
    for k, v in randomize.items():
        if k == "action_delay":
            out[k] = _check_delay_range(v)
            continue
        if k not in spec.randomize:
            raise ValueError(
                f"unknown randomize key {k!r} for {spec.name}; valid keys: "
                f"{list(spec.randomize)} (all groups: {list(RANDOMIZE_GROUPS)})"
            )
        kinds = {kind for _, kind in spec.randomize[k]}
        if np.ndim(v) == 0:
            v = float(v)
            if "abs" in kinds:
                raise ValueError(f"randomize[{k!r}] needs an absolute (low, high) range")
            if not (math.isfinite(v) and 0 <= v < 1):
                raise ValueError(f"randomize[{k!r}] as a fraction must be in [0, 1), got {v}")
            v = (1.0 - v, 1.0 + v)
        lo, hi = (float(a) for a in v)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(f"randomize[{k!r}] must be a finite (low, high), got {v!r}")
        if "rel" in kinds and lo <= 0:
            raise ValueError(f"randomize[{k!r}] relative factors must be > 0, got {v!r}")
        out[k] = (lo, hi)
    return out


def _check_motor(spec: RobotSpec, motor: Any, mode: str, params: Mapping[str, Any],
                 randomize: Mapping[str, Any]) -> str:
    """The resolved ``motor``: one of :data:`MOTORS`, or None for the action mode's
    (``"dc"`` in ``action_mode="voltage"``, else ``"ideal"``). ``"dc"`` only on a robot with
    motors; the voltage mode needs the DC motors (``motor="ideal"`` with it raises); the motor
    mode is this keyword's, not a ``params`` entry; ``randomize["motor"]`` needs DC motors."""
    voltage = mode in spec.dc_action_modes
    if motor is None:
        motor = "dc" if voltage else "ideal"
    if not isinstance(motor, str) or motor not in MOTORS:
        hint = (" (the model's voltage input: pass action_mode='voltage')"
                if motor == "dc_voltage" else "")
        raise ValueError(f"motor must be one of {list(MOTORS)} or None (the action mode's), "
                         f"got {motor!r}{hint}")
    if motor != "ideal" and not spec.has_dc_motors:
        raise ValueError(f"motor={motor!r}: {spec.name} has no motor model (kinematic inputs); "
                         f"use motor='ideal'")
    if voltage and motor != "dc":
        raise ValueError(
            f"action_mode={mode!r} commands the DC motors' terminal voltages, which "
            f"motor={motor!r} does not have: pass motor='dc' (or leave motor unset, which "
            f"implies it), or an action_mode of {list(spec.action_modes)} for ideal motors")
    if "motor" in params:
        raise ValueError("params['motor']: choose the motor model with the motor= keyword")
    if "motor" in randomize and motor == "ideal":
        raise ValueError("randomize['motor'] draws DC motor parameters, which ideal motors do "
                         "not use (nothing would change); pass motor='dc'")
    return motor


def _check_delay(name: str, value: Any) -> int:
    """``value`` as an int in [0, :data:`MAX_ACTION_DELAY`] (control steps)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int number of control steps, got {value!r}")
    if not 0 <= value <= MAX_ACTION_DELAY:
        raise ValueError(f"{name} must be in [0, {MAX_ACTION_DELAY}] control steps, "
                         f"got {value!r}")
    return int(value)


def _check_history(name: str, k: Any, high: int, what: str) -> int:
    """An observation history's length: an int in [0, high] (``what``: what it appends)."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
        raise TypeError(f"{name} must be an int ({what} in the observation), got {k!r}")
    if not 0 <= k <= high:
        raise ValueError(f"{name} must be in [0, {high}], got {k}")
    return int(k)


def _check_delay_range(v: Any) -> tuple[int, int]:
    """``randomize["action_delay"]`` as ints ``(low, high)``, 0 <= low <= high <= max."""
    name = "randomize['action_delay']"
    if np.ndim(v) != 1 or len(v) != 2:
        raise TypeError(f"{name} must be an int range (low, high), got {v!r}")
    lo, hi = (_check_delay(name, x) for x in v)
    if lo > hi:
        raise ValueError(f"{name} must have low <= high, got {v!r}")
    return lo, hi


def _check_perturbation(spec: RobotSpec, pert: Perturbation, cfg: Any) -> None:
    """A perturbation's checks against the other keywords: its groups must be randomisation
    groups (of some robot), not also drawn by ``randomize``; its delay and lag exclusive with
    ``action_delay`` (and ``randomize['action_delay']``) and ``actuator_lag``."""
    bad = [g for g in pert.scales if g not in RANDOMIZE_GROUPS]
    if bad:
        raise ValueError(f"perturbation scales: unknown group(s) {bad}; valid groups: "
                         f"{list(RANDOMIZE_GROUPS)}")
    both = [g for g in pert.scales if g in cfg.randomize and g in spec.randomize]
    if both:
        raise ValueError(f"perturbation scales and randomize both draw {both}: set each group "
                         f"in one of them")
    if pert.action_delay != (0, 0) and (cfg.action_delay or "action_delay" in cfg.randomize):
        raise ValueError("perturbation action_delay and action_delay / "
                         "randomize['action_delay'] are both set: use one of them")
    if pert.actuator_lag > 0 and cfg.actuator_lag > 0:
        raise ValueError("perturbation actuator_lag and actuator_lag are both set: use one")


@dataclasses.dataclass(frozen=True)
class EnvConfig:
    """The keyword arguments of every wheelgym environment, validated and normalised.

    The fields hold the resolved values: ``action_mode`` the robot's default when not given,
    ``motor`` the action mode's when not given (``"dc"`` for ``"voltage"``, else ``"ideal"``),
    ``ctrl_dt`` and ``sim_dt`` the model's defaults (floats), ``randomize`` a dict group ->
    ``(low, high)`` (``{}``: none), ``params`` a dict. Building a config from another's fields
    gives an equal config. The meaning of each field is the "Arguments" table of
    :class:`~wheelgym.envs.wheel_env.WheelEnv`.

    Attributes:
        robot: robot name (``"ThreeWheel"``...; ``wheelgym.envs.robots``).
        task: ``"goal"``, ``"track"`` or ``"navigate"``.
        action_mode: one of the robot's action modes (``RobotSpec.all_action_modes``:
            ``"torque"``, ``"velocity"``, and ``"voltage"`` on the robots with DC motors).
        params: parameter overrides (field names of the robot's Params dataclass).
        ctrl_dt, sim_dt: control period and RK4 substep (s).
        randomize: group -> (low, high) ranges drawn at each reset.
        obs_noise: std of the Gaussian observation noise (>= 0).
        reward_weights: term -> weight overrides (the task checks the keys), or None.
        render_mode: None or one of ``render_modes``.
        range_backend: navigate's rays, ``"analytic"`` or ``"pymunk"``.
        arena: navigate's static world: None (random circles and boxes, redrawn each reset), a
            shipped map's name (``wheelgym.world.MAPS``) or a map file's path (ROS map_server
            YAML or a YAML of shapes; :func:`wheelgym.world.load_map`).
        horizon: track: reference steps evaluated at a reset by small batches; navigate
            ``version=1``: the episode length (control steps) its per-step costs are spread
            over (docs/topics/planning.md).
        goal_conditioned: goal and navigate: a ``Dict`` observation (``observation``,
            ``achieved_goal``, ``desired_goal``) and ``compute_reward`` for HER.
        goal_free_observation: with ``goal_conditioned``, the ``observation`` key without the
            entries that depend on the desired goal (the goal in the body frame, navigate's
            distance and bearing; in the observation history too), as HER needs: a relabelled
            goal reaches the policy only through ``desired_goal``. Not with navigate's
            ``waypoint_hint`` (the plan to the goal).
        action_delay: control steps between an action and its effect (0 to
            :data:`~wheelgym.envs.actuator.MAX_ACTION_DELAY`).
        actuator_lag: time constant (s) of the first-order lag on the applied inputs
            (>= 0; 0: off).
        motor: the dynamic robots' motors: ``"ideal"`` (the joints get the commanded torque)
            or ``"dc"`` (DC motors with back-EMF, current and voltage limits,
            ``wheelgym.models.motor``); one of :data:`MOTORS`. Given as None (the default)
            it resolves to the action mode's: ``"dc"`` with ``action_mode="voltage"`` (the
            action is the DC motors' terminal voltage; ``"ideal"`` with it raises), else
            ``"ideal"``.
        version: the registered id's version: 0 (``wheelgym/<Robot>-v0``) or 1 (``-v1``:
            navigate's v1 reward and observation, docs/topics/planning.md; goal and track are
            the same in both).
        waypoint_hint: navigate ``version=1``: the planner's next waypoint in the
            observation (an opt-in hint).
        controller_model: the model the velocity mode's twist controller computes its
            torques with: ``"nominal"`` (the parameters the env was built with, ``params``;
            the default) or ``"true"`` (each episode's drawn plant parameters, ``randomize``
            and ``perturbation``: privileged); one of :data:`CONTROLLER_MODELS`
            (``docs/topics/robustness.md``).
        perturbation: None, a :class:`~wheelgym.envs.perturbation.Perturbation`, a dict of
            its fields or a level name (``"easy"``, ``"medium"``, ``"hard"``); stored as a
            ``Perturbation`` (``wheelgym.envs.perturbation``).
        action_history: the last ``k`` actions the policy sent (0 to
            :data:`MAX_ACTION_HISTORY`; 0: none) appended to the observation, newest first.
        obs_history: the task's observation entries of the last ``k`` steps before this one,
            as the policy saw them (0 to :data:`MAX_OBS_HISTORY`; 0: none), newest first,
            after the task's entries and before the action history (a frame stack: with the
            action history, what a policy needs to tell how the plant answers its inputs).
        render_modes: the render modes the environment class offers (not compared).
    """

    robot: str
    task: str = "goal"
    action_mode: str | None = None
    params: Mapping[str, Any] | None = None
    ctrl_dt: float | None = None
    sim_dt: float | None = None
    randomize: Mapping[str, Any] | bool | None = None
    obs_noise: float = 0.0
    reward_weights: Mapping[str, float] | None = None
    render_mode: str | None = None
    range_backend: str = "analytic"
    arena: str | os.PathLike | None = None
    horizon: int = DEFAULT_HORIZON
    goal_conditioned: bool = False
    goal_free_observation: bool = False
    action_delay: int = 0
    actuator_lag: float = 0.0
    motor: str | None = None
    version: int = 0
    waypoint_hint: bool = False
    controller_model: str = "nominal"
    perturbation: Perturbation | Mapping[str, Any] | str | None = None
    action_history: int = 0
    obs_history: int = 0
    render_modes: tuple[str, ...] = dataclasses.field(default=RENDER_MODES, repr=False,
                                                      compare=False)

    def __post_init__(self) -> None:
        """Every keyword check, in this order (the first bad keyword raises)."""
        put = self._put
        if self.render_mode is not None and self.render_mode not in self.render_modes:
            raise ValueError(f"render_mode must be None or one of {list(self.render_modes)}, "
                             f"got {self.render_mode!r}")
        spec = self.spec
        if self.task not in TASKS:
            raise ValueError(f"unknown task {self.task!r}; valid tasks: {list(TASKS)}")
        mode = spec.action_modes[0] if self.action_mode is None else self.action_mode
        if mode not in spec.all_action_modes:
            raise ValueError(
                f"unknown action_mode {self.action_mode!r} for {spec.name}; valid modes: "
                f"{list(spec.all_action_modes)}"
            )
        put("action_mode", mode)
        if self.params is not None and not isinstance(self.params, Mapping):
            raise TypeError(f"params must be a dict of parameter overrides, got {self.params!r}")
        put("params", dict(self.params or {}))
        model_cls = spec.model_cls
        dt = _check_dt("ctrl_dt", model_cls.default_ctrl_dt if self.ctrl_dt is None
                       else self.ctrl_dt, MAX_CTRL_DT)
        sdt = _check_dt("sim_dt", model_cls.default_sim_dt if self.sim_dt is None
                        else self.sim_dt)
        if sdt > dt:
            raise ValueError(f"sim_dt ({sdt}) must not exceed ctrl_dt ({dt})")
        if dt / sdt > MAX_SUBSTEPS + 0.5:
            raise ValueError(
                f"ctrl_dt / sim_dt ({dt} / {sdt}) must be at most {MAX_SUBSTEPS} RK4 "
                f"substeps per control step (each costs about 1 us a robot); raise sim_dt"
            )
        put("ctrl_dt", dt)
        put("sim_dt", sdt)
        put("randomize", _check_randomize(spec, self.randomize))
        put("obs_noise", _check_number("obs_noise", self.obs_noise, 0.0))
        h = self.horizon
        if isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 1:
            raise ValueError(f"horizon must be a positive int, got {h!r}")
        put("horizon", int(h))
        put("action_delay", _check_delay("action_delay", self.action_delay))
        put("actuator_lag", _check_number("actuator_lag", self.actuator_lag, 0.0))
        put("motor", _check_motor(spec, self.motor, mode, self.params, self.randomize))
        if self.controller_model not in CONTROLLER_MODELS:
            raise ValueError(f"controller_model must be one of {list(CONTROLLER_MODELS)}, got "
                             f"{self.controller_model!r}")
        pert = parse_perturbation(self.perturbation)
        put("perturbation", pert)
        if pert is not None:
            _check_perturbation(spec, pert, self)
        self._check_task_keywords()

    def _check_task_keywords(self) -> None:
        """``__post_init__``'s second part: the keywords of the task and the observation."""
        put = self._put
        if self.reward_weights is not None and not isinstance(self.reward_weights, Mapping):
            raise TypeError(f"reward_weights must be a dict, got {self.reward_weights!r}")
        if self.task != "navigate" and self.range_backend != "analytic":
            raise ValueError("range_backend applies to task='navigate' only")
        if self.arena is not None:
            if not isinstance(self.arena, (str, os.PathLike)):
                raise TypeError(f"arena must be None, a shipped map's name or a map file's path, "
                                f"got {self.arena!r}")
            if self.task != "navigate":
                raise ValueError("arena applies to task='navigate' only")
            put("arena", os.fspath(self.arena))  # (the task loads it: one-line errors)
        # (navigate's sensor checks the backend's name, listing the valid ones)
        put("goal_conditioned", check_bool("goal_conditioned", self.goal_conditioned))
        if self.goal_conditioned and self.task not in ("goal", "navigate"):
            raise ValueError(f"goal_conditioned applies to task='goal' or 'navigate' only, "
                             f"got task={self.task!r}")
        put("goal_free_observation",
            check_bool("goal_free_observation", self.goal_free_observation))
        if self.goal_free_observation and not self.goal_conditioned:
            raise ValueError("goal_free_observation needs goal_conditioned=True (it shapes the "
                             "Dict observation's 'observation' key)")
        if isinstance(self.version, bool) or self.version not in VERSIONS:
            raise ValueError(f"version must be one of {list(VERSIONS)} (the id's -vN), got "
                             f"{self.version!r}")
        put("version", int(self.version))
        put("waypoint_hint", check_bool("waypoint_hint", self.waypoint_hint))
        if self.waypoint_hint and (self.task != "navigate" or self.version != 1):
            raise ValueError("waypoint_hint applies to task='navigate' of the -v1 ids "
                             "(version=1) only")
        if self.waypoint_hint and self.goal_free_observation:
            raise ValueError("goal_free_observation cannot be combined with waypoint_hint (the "
                             "hint is the plan to the env's goal); valid: one of them")
        put("action_history", _check_history("action_history", self.action_history,
                                             MAX_ACTION_HISTORY, "past actions"))
        put("obs_history", _check_history("obs_history", self.obs_history, MAX_OBS_HISTORY,
                                          "past observations"))

    def _put(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)  # the normalised value (frozen dataclass)

    # ------------------------------------------------------------------ derived
    @property
    def spec(self) -> RobotSpec:
        """The robot's :class:`~wheelgym.envs.robots.RobotSpec` (``ValueError`` for an unknown
        robot, listing the robots)."""
        return get_spec(self.robot)

    @property
    def n_substeps(self) -> int:
        """RK4 substeps per control step (``ctrl_dt / sim_dt`` rounded)."""
        return n_substeps(self.ctrl_dt, self.sim_dt)

    def task_kwargs(self) -> dict[str, Any]:
        """Keywords of the task's constructor beyond the core and the reward weights."""
        if self.task != "navigate":
            return {}
        kw: dict[str, Any] = {"range_backend": self.range_backend, "arena": self.arena}
        if self.version == 1:
            kw.update(version=1, waypoint_hint=self.waypoint_hint)
        return kw

    def replace(self, **changes: Any) -> EnvConfig:
        """A new config with ``changes`` (validated)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_kwargs(cls, owner: str, robot: str, kwargs: Mapping[str, Any],
                    render_modes: tuple[str, ...] = RENDER_MODES) -> EnvConfig:
        """The config of ``owner(**kwargs)``; an unknown keyword raises ``TypeError`` as
        Python does for a signature, listing the valid ones."""
        unknown = [k for k in kwargs if k not in KEYWORDS]
        if unknown:
            raise TypeError(f"{owner}() got an unexpected keyword argument {unknown[0]!r}; "
                            f"valid keywords: {list(KEYWORDS)}")
        return cls(robot, render_modes=render_modes, **kwargs)


#: The environments' keywords (the fields a user sets; ``robot`` comes from the class).
KEYWORDS: dict[str, dataclasses.Field] = {
    f.name: f for f in dataclasses.fields(EnvConfig) if f.name not in ("robot", "render_modes")
}


def signature_with(*extra: inspect.Parameter, keywords: tuple[str, ...] | None = None
                   ) -> inspect.Signature:
    """``(self, *extra, <the config's keywords>)`` as keyword parameters with their defaults
    and annotations (for ``help()`` and ``inspect.signature`` of the env classes)."""
    names = list(KEYWORDS) if keywords is None else list(keywords)
    params = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD), *extra]
    params += [inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, default=KEYWORDS[n].default,
                                 annotation=KEYWORDS[n].type) for n in names]
    return inspect.Signature(params)
