"""The single Gymnasium environment: :class:`WheelEnv` is a :class:`WheelCore` at N = 1."""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from wheelgym.envs.config import EnvConfig, signature_with
from wheelgym.envs.core import WheelCore

__all__ = ["WheelEnv", "goal_space", "observation_names"]

_F32 = np.dtype(np.float32)
_F64 = np.dtype(np.float64)
_ZERO = np.float64(0.0)

_DOC = """
## Observation Space

float32 ``Box`` with finite bounds; angles enter as cos/sin; positions are in the robot's body
frame B (x forward, y left, docs/physics/conventions.md) and clipped to +-12 m; speeds to twice the
sanity limits. ``env.unwrapped.observation_names`` names every entry in order (with
``goal_conditioned``, those of the Dict's ``observation`` key). Layout by task (the robot's
features, listed above, come after the twist):

| task     | entries (in order)                                                   | unit        |
|----------|----------------------------------------------------------------------|-------------|
| goal     | goal_x_b, goal_y_b                                                   | m           |
|          | cos_dyaw, sin_dyaw (goal yaw minus yaw)                              | -           |
|          | vx, vy, wz (body twist); robot features                              | m/s, rad/s  |
| track    | ref_x_b, ref_y_b (reference position now)                            | m           |
|          | cos_dyaw, sin_dyaw; ref_vx, ref_vy, ref_wz (reference twist)         | -, m/s, rad/s|
|          | preview_{10,20,30}_{x,y}_b (reference 0.5, 1.0, 1.5 s ahead)         | m           |
|          | vx, vy, wz; robot features                                           | m/s, rad/s  |
| navigate | as goal, then range_0..range_15 (rays at yaw + 2 pi k / 16, 0-3 m)   | m           |
| (-v1)    | then goal_dist, cos_bearing, sin_bearing (+ waypoint_x_b, _y_b)      | m, -        |
| (hint)   | cars: + plan_offset, plan_heading, plan_curvature, plan_direction,   | m, rad, 1/m,|
|          | plan_remaining (the planning baseline's tracking frame)              | -, m        |
| any      | ``obs_history=k``: then prev_obs_1_<entry> .. prev_obs_k_<entry>      | as the entry|
| any      | ``action_history=k``: then prev_action_1_0 .. prev_action_k_{n-1}     | action units|

## Rewards

Named terms, each weighted (``reward_weights`` overrides; unknown keys raise listing the valid
ones; ``set_reward_weights`` changes them between steps); ``info["reward_terms"]`` holds the
weighted terms and they add up to the reward.

| term           | task            | value (before the weight)                       | weight |
|----------------|-----------------|--------------------------------------------------|--------|
| progress       | goal, navigate  | decrease of the distance to the goal this step (m)| 1.0   |
| heading        | goal (navigate) | -abs(dyaw) / pi                                  | 0.02 (0) |
| position       | track           | -distance to the reference (m)                   | 1.0    |
| heading        | track           | -abs(dyaw) / pi                                  | 0.1    |
| effort         | all             | -mean((tau / tau_max)^2) (normalised commands)   | 0.01   |
| internal_force | all (ThreeWheel)| -norm(P tau) / norm(tau_max): the torques'     | 0.2    |
|                |                 | null-space part over the torque limits (0..1)    |        |
| success        | goal, navigate  | +1 on success                                    | 10     |
| overspeed      | all             | -1 beyond the speed limits or on numerical failure | 10   |
| collision      | navigate        | -1 when the footprint circle touches an obstacle | 10     |
| proximity      | navigate        | -clip(1 - gap / 0.5 m, 0, 1); gap: footprint to  | 0      |
|                |                 | the nearest obstacle (exact, not the rays)       |        |
| lost           | track           | -1 when more than 1 m from the reference         | 10     |
| saturation     | all             | -1 when an action is at (or beyond) its bound or | 0      |
|                |                 | a controller torque was clipped (``saturated``)  |        |

## Starting State

Row i of every draw comes from ``np_random`` (seeded by ``reset(seed=...)``), in a fixed order:
the randomised parameters, then the task. goal: start at rest within 1 m of the origin with a
random heading, goal 1-3 m away with a random heading. track: a random reference (circle of
radius 0.8-2 m, figure-eight of size 1-2 m, or the three-wheel paper's quintic circle), random
speed, phase, rotation and offset; the robot starts at rest on its first pose. navigate: an
8 m x 8 m walled arena with 3-6 circles and 1-3 boxes, start and goal (>= 3 m apart) clear of
them, the pymunk space rebuilt at each reset.

## Reset Options

``reset(seed=..., options={...})`` replaces drawn values for that episode (evaluation sets,
replays). The draws from ``np_random`` are made all the same, so the generator advances as
without options; unknown keys raise ``ValueError`` listing the valid ones.

| key         | tasks          | value                                                          |
|-------------|----------------|----------------------------------------------------------------|
| start       | all            | start pose (x, y, yaw) (m, m, rad); the robot starts at rest   |
| goal        | goal, navigate | goal pose (x, y, yaw) (navigate ignores the yaw)               |
| reference   | track          | a ``wheelgym.tasks`` ``Reference`` (``Circle``, ``FigureEight``, |
|             |                | ``QuinticCircle``, ``Line``, ``PointToPoint``...), followed from |
|             |                | its t = 0 as placed (no random rotation or offset); the robot   |
|             |                | starts on its first pose unless ``start`` is given              |
| layout_seed | navigate       | int >= 0: the obstacle layout (and start, goal) drawn from a    |
|             |                | generator seeded with it (the layout ``reset(seed=s)`` draws     |
|             |                | without ``randomize``); ``start``/``goal`` override its poses    |

navigate refuses a ``start`` or ``goal`` whose footprint circle is not inside the walls and
clear of the obstacles (``ValueError``). In the vector env an option applies to the sub-envs
being reset: one value for all of them, or an array (a list for ``reference`` and
``layout_seed``) with a leading axis of ``num_envs`` whose entry i goes to sub-env i (the
entries of sub-envs not reset are ignored); ``reset_mask`` selects the sub-envs. Options act
on that reset only (autoresets draw as usual).

## Episode End

Terminated on success (goal: within 0.1 m and 0.2 rad; navigate: within 0.25 m), overspeed
(with the default ideal motors nothing caps the speed but this sanity limit; ``motor="dc"``
and the voltage mode add the back-EMF, which caps it near the motors' no-load speed), lost (track),
collision (navigate), or a diverged integration (``info["numerical_failure"] = True``: the
state turned non-finite or a twist entry exceeded 1e3 m/s or rad/s,
``robots.body.SPEED_BOUND``; the state, the observation and the reward then stay at the last
good state's, with the overspeed penalty). Truncated after ``max_episode_steps`` = 500
control steps (25 s at the default ``ctrl_dt``). The track reference never runs out: it is
evaluated in windows as the episode goes on (any ``max_episode_steps``, ``None`` included); the
circle and figure-eight keep lapping, the quintic circle rests at its end pose after its 20-40 s.

Stepping on after a terminated step without ``reset()`` is outside Gymnasium's contract; as
Gymnasium's own environments do (CartPole), the env warns once, keeps integrating, and returns
reward 0 (every ``reward_terms`` entry 0) with ``terminated=True`` until ``reset()``, so no
terminal bonus or penalty is paid twice. The vector env resets a terminated sub-env on its next
step instead (``NEXT_STEP`` autoreset), so it never pays one twice either.

## Arguments

Keyword arguments only; they are the fields of ``wheelgym.envs.config.EnvConfig``, validated
there once (the vector env takes the same).

| argument       | default           | meaning                                                 |
|----------------|-------------------|---------------------------------------------------------|
| task           | "goal"            | "goal", "track" or "navigate"                           |
| action_mode    | the robot's first | "torque" or "velocity"; kinematic robots: input modes;  |
|                |                   | ThreeWheel, SkidSteer, CasterAGV also "voltage" (DC     |
|                |                   | motors' terminal voltages: a_k V_s, implies motor="dc") |
| params         | None              | dict of overrides (field names of the robot's Params)   |
| ctrl_dt        | model default     | control period (s), 0.05; at most 1 s                   |
| sim_dt         | model default     | RK4 substep (s); divides ctrl_dt in at most 10000 steps |
|                |                   | and is inside RK4's stability region for the parameters |
| randomize      | None              | dict group -> range, or True for the robot's defaults   |
| obs_noise      | 0.0               | std of Gaussian noise on each entry (a number >= 0)     |
| reward_weights | task defaults     | dict term -> weight (finite real numbers)               |
| render_mode    | None              | "rgb_array" (600 x 600 x 3) or "human"                  |
| range_backend  | "analytic"        | navigate's rays: "analytic" (compiled) or "pymunk"      |
| arena          | None              | navigate's world: None (random obstacles each reset), a |
|                |                   | shipped map ("warehouse", "office", "maze") or the path |
|                |                   | of a ROS map_server YAML or a YAML of shapes            |
| horizon        | 500               | track: steps of the reference the single env evaluates  |
|                |                   | at a reset (at most 4096; it moves on by windows past)  |
| goal_conditioned | False           | goal, navigate: ``Dict`` observation and                |
|                |                   | ``compute_reward`` for HER ("Goal-conditioned")         |
| goal_free_observation | False      | with goal_conditioned: ``observation`` without the      |
|                |                   | goal's entries, as HER needs ("Goal-conditioned")       |
| action_delay   | 0                 | control steps (0-50) before an action acts; the first k |
|                |                   | steps of an episode apply the zero action (velocity     |
|                |                   | mode: the twist command is delayed)                     |
| actuator_lag   | 0.0               | time constant T (s) of a first-order lag on the applied |
|                |                   | torques (voltage mode: voltages; kinematic robots:      |
|                |                   | inputs); 0 = off; discrete at the control step:         |
|                |                   | u += (1 - exp(-ctrl_dt / T)) (u_cmd - u), held over the |
|                |                   | step's substeps                                         |
| motor          | None: "ideal"     | dynamic robots' motors: "ideal" (the joint gets the     |
|                | ("dc" in voltage  | commanded torque) or "dc" (DC motor with back-EMF and   |
|                | mode)             | current/voltage limits inside each RK4 stage,           |
|                |                   | ``wheelgym.models.motor``; parameters in ``params``);   |
|                |                   | "voltage" mode needs "dc" ("ideal" raises ValueError)   |
| version        | 0 (-v1 ids: 1)    | the id's version: 1 gives navigate's v1 reward and      |
|                |                   | observation (docs/topics/planning.md); goal, track same |
| waypoint_hint  | False             | navigate v1: the planner's next waypoint in the obs     |
| controller_model | "nominal"       | velocity mode: the twist controller's model, "nominal"  |
|                |                   | (the built parameters, whatever randomize/perturbation  |
|                |                   | draw) or "true" (each episode's drawn parameters);      |
|                |                   | docs/topics/robustness.md                               |
| perturbation   | None              | a ``Perturbation``, a dict of its fields or a level     |
|                |                   | ("easy", "medium", "hard"): parameter scales, delay,    |
|                |                   | lag, noise, dropped/stuck actions and observations      |
|                |                   | (``wheelgym.envs.perturbation``); a dict with "level":  |
|                |                   | that level with the dict's other fields replaced        |
| action_history | 0                 | the last k (0-8) actions sent, clipped to [-1, 1],      |
|                |                   | appended to the observation newest first (entries       |
|                |                   | ``prev_action_t_j``), zeros at a reset; not touched by  |
|                |                   | obs_noise or perturbation faults. With action_delay or  |
|                |                   | a perturbation's delay, k >= the delay makes the state  |
|                |                   | Markov again (the actions still to act are observed)    |
| obs_history    | 0                 | the task's entries of the last k (0-8) steps, as        |
|                |                   | observed (noise and faults included), newest first,     |
|                |                   | after the task's entries (``prev_obs_t_<entry>``); a    |
|                |                   | reset repeats its first observation (a frame stack)     |

Action modes of the dynamic robots (the robot classes' "Action Space" give the scales):

| action_mode | action a (entries in [-1, 1])      | physical input                          |
|-------------|------------------------------------|-----------------------------------------|
| torque      | one per motor                      | torque command a_k tau_max_k (N·m)      |
| velocity    | the body twist (twist_dim entries) | tracked by ``TwistController``          |
| voltage     | one per motor; needs (and implies) | terminal voltage a_k V_s (V); the DC    |
|             | ``motor="dc"``                     | law (back-EMF, winding resistance,      |
|             |                                    | current limit, gear) makes the torque   |
|             |                                    | in every RK4 stage (the model's         |
|             |                                    | "dc_voltage")                           |

``randomize`` groups (each robot supports those its parameters have): "mass", "inertia",
"friction", "x_icr", "wheel_radius", "caster_trail", "torque_limit", "motor" (``motor="dc"``
only: torque constants, winding resistances and the supply voltage; in voltage mode a drawn
``V_s`` also rescales that row's action, ``+-1 = +-V_s``). A value is a relative
factor range ``(low, high)`` (or a fraction f meaning ``(1 - f, 1 + f)``) multiplying every
parameter of the group; ``x_icr`` takes an absolute range (m). ``reset`` returns the draws in
``info["params"]``. The velocity mode's controller keeps the nominal parameters, and so
does the scale of the Unicycle's action: in ``WheelSpeedHeadingRate`` it drives at the drawn
radius times the wheel speed; in ``VehicleSpeedHeadingRate`` the radius acts only through the
wheel-speed limit, and a range too narrow to reach it raises ``ValueError``.
Every robot also takes the group "action_delay": an int range ``(low, high)`` of delays
(control steps, inclusive) drawn uniformly per episode from ``np_random`` after the parameter
groups; it replaces ``action_delay`` (each row's delay: ``core.delays``). The delay buffer and
the lag filter start from the zero action at each reset.

The parameters at every corner of the ranges (each group at its low or its high end) must be
valid and stable at ``sim_dt``, else the constructor raises ``ValueError`` naming the
``randomize`` entry. ``params`` must lie within the physical bounds of the parameter
dataclasses (``wheelgym.models._base``: lengths 1e-3-1e2 m, masses 1e-3-1e5 kg, ...).

Actions outside [-1, 1] are clipped; an action at or beyond +-1 sets ``info["saturated"]``
(SB3 clips to the box before ``step``, so a full-torque or full-speed command counts as well as
one beyond); a wrong shape or a non-finite
entry raises ``ValueError``, an array that is not of real numbers (strings, complex, bool)
``TypeError``; invalid keyword values raise ``ValueError``/``TypeError`` naming the argument
and listing the valid choices or range.

## Info (every step)

| key               | unit       | meaning                                                      |
|-------------------|------------|--------------------------------------------------------------|
| pose              | m, m, rad  | (x, y, yaw) in W (yaw unwrapped)                             |
| twist             | m/s, rad/s | (vx, vy, wz) in B                                            |
| motor_torque      | N·m        | commanded motor torques after clipping (empty: kinematic);   |
|                   |            | ``motor="dc"``: the command, before the motor's envelope;    |
|                   | (V)        | voltage mode: the commanded terminal voltages (V)            |
| joint_velocity    | rad/s      | motor joint rates at the end of the step (empty: kinematic)  |
| tracking_error    | m          | distance to the goal or to the reference                     |
| energy            | J          | cumulative motor work, RK4 integral of tau . qdot;           |
|                   |            | ``motor="dc"`` (and voltage mode): of the electrical power   |
|                   |            | sum V i                                                      |
| electrical_power  | W          | mean power the motors drew over the step: its ``energy``     |
|                   |            | increment / ctrl_dt (ideal motors: mean of tau . qdot); 0    |
|                   |            | at a reset                                                   |
| internal_force    | N·m        | norm of the torques' null-space part (ThreeWheel; else 0);   |
|                   | (V)        | voltage mode: of the commanded voltages' (V)                 |
| saturated         | bool       | an action at or beyond its bound, or a controller torque     |
|                   |            | clipped                                                      |
| is_success        | bool       | goal reached; track: within 5 cm of the reference            |
| numerical_failure | bool       | the integration diverged (the episode ends; Episode End)     |
| reward_terms      | dict       | weighted reward terms                                        |

Reset info adds ``params`` (drawn values) and ``task`` (goal pose or reference kind).
With ``goal_conditioned=True`` the step and reset infos add ``prev_achieved_goal``,
``reward_goal_free``, ``success_allowed`` and ``terminated_goal_free`` ("Goal-conditioned").

## Goal-conditioned

``goal_conditioned=True`` (goal and navigate) makes the observation a ``Dict`` in
Gymnasium-Robotics' convention, so SB3's ``HerReplayBuffer`` works unchanged:

| key           | dtype   | entries                                                        |
|---------------|---------|----------------------------------------------------------------|
| observation   | float32 | the observation above (goal in the body frame included; with   |
|               |         | ``goal_free_observation=True`` without the goal's entries)     |
| achieved_goal | float32 | goal: x, y, cos yaw, sin yaw of the robot (W; not clipped,     |
|               |         | not noised); navigate: x, y                                    |
| desired_goal  | float32 | the goal's, in the same form                                   |

All three are float32, as SB3's buffers and Gymnasium-Robotics users expect of one Dict space
(the goals are the float64 state rounded: within 0.25 um at 4 m, 0.5 mm at the +-1e4 m
bound).
(cos, sin) keeps the goal space continuous, so the Euclidean distance between goals is
meaningful; positions lie within +-1e4 m (``tasks.GOAL_POS_BOUND``).
``compute_reward(achieved_goal, desired_goal, info)`` is the step reward for any desired goal,
batched over leading axes (``info``: one step info, or a list/array of them, or a vector
info): progress from ``info["prev_achieved_goal"]`` (the achieved goal before the step),
heading (goal only) and success (``info["success_allowed"]``: no failure or collision) are
recomputed; the goal-independent terms come summed in ``info["reward_goal_free"]`` (effort,
internal_force, overspeed, collision; navigate: heading too, which compares with the env's goal
yaw). With the observed (float32) goals it equals the step reward to their rounding (within
1e-5 at the default weights; ``info["prev_achieved_goal"]`` is float64). These terms are not
functions of the goals, so SB3's ``HerReplayBuffer`` needs
``replay_buffer_kwargs=dict(..., copy_info_dict=True)``; without the info keys
``compute_reward`` raises a ``ValueError`` saying so.
For HER pass ``goal_free_observation=True``: ``HerReplayBuffer`` relabels ``desired_goal`` and
the reward, never ``observation``, so with the goal's entries there a relabelled transition
shows the policy one goal and pays it for another. The option leaves out the task's
``goal_entries`` (``goal_x_b``, ``goal_y_b``, ``cos_dyaw``, ``sin_dyaw``; navigate also
``goal_dist``, ``cos_bearing``, ``sin_bearing``; their copies in the observation history too),
with their bounds, so the goal reaches the policy only as ``desired_goal`` and
``achieved_goal``, in the world frame (``observation_names`` lists the entries kept). The
default keeps them (the plain env's observation). It cannot be combined with navigate's
``waypoint_hint``, a plan to the env's own goal.
``compute_terminated``: success within the tolerances or ``info["terminated_goal_free"]``
(overspeed, numerical failure, collision); ``compute_truncated``: False. Steps after the end
(reward 0, see Episode End) are outside this. Success ends the episode, which SB3's
``HerReplayBuffer`` does not know: it keeps each relabelled transition's stored ``done``, so
a relabelled goal reached mid-episode does not end its transition (the critic bootstraps on
and collects the success bonus again on the next steps near that goal) and a transition that
ended on its episode's goal stays ended for a goal it did not reach.
``wheelgym.agents.her.TerminatingHerReplayBuffer`` (the same arguments) takes each relabelled
transition's end from ``compute_terminated``; both ``configs/*-her.yml`` use it.
``relabel_observation(observation, achieved_goal, desired_goal)`` (goal task, batched) is the
``observation`` key with the goal's entries recomputed for another goal from the robot's pose
(``achieved_goal``): what the robot would have observed with that goal. With
``replay_buffer_kwargs=dict(..., relabel_observation=True)`` the terminating buffer rewrites
every relabelled observation so, and the policy keeps the goal in its body frame
(``goal_free_observation=False``; ``configs/Bicycle-goal-VehicleSpeedSteeringAngle-her.yml``).
It raises a ``ValueError`` where the observation holds entries it cannot recompute:
observation history, noise, dropped or stuck entries, and navigate's (whose goal space has no
yaw and whose bearing entries follow the plan).

## Copies

``copy.deepcopy(env)`` and ``pickle`` copy an episode in progress exactly: the copy and the
original, fed the same actions, return the same bits (planning over copies, checkpoints). A
renderer is not copied (a copy opens its own on ``render()``).

## Version History

* v0: initial version.
"""


@functools.cache
def _info_builder(vectors: tuple[str, ...], numbers: tuple[tuple[str, int], ...],
                  core_numbers: tuple[str, ...], flags: tuple[tuple[str, int, bool], ...],
                  terms: tuple[tuple[str, int], ...]) -> Callable[..., dict[str, Any]]:
    """``build(vec, b, core, f, t)``: the step info as one dict display, ~0.6 us faster than
    filling it key by key (a sixth of a kinematic robot's step). ``vec``: the vectors' row
    views (copied), ``b``: row 0 of the float block (``numbers``: name, column), ``core``: the
    ``(N,)`` arrays of ``core_numbers``, ``f``: row 0 of the flag block as a list (``flags``:
    name, column, negate), ``t``: row 0 of the reward terms (``terms``: name, column). Keys in
    that order, ``reward_terms`` last."""
    items = [f"{n!r}: v{k}.copy()" for k, n in enumerate(vectors)]
    items += [f"{n!r}: b[{col}]" for n, col in numbers]
    items += [f"{n!r}: c{k}[0]" for k, n in enumerate(core_numbers)]
    items += [f"{n!r}: f[{col}] != {neg}" for n, col, neg in flags]
    rt = ", ".join(f"{n!r}: t[{col}]" for n, col in terms)
    unpack = "".join(f"    {', '.join(f'{p}{k}' for k in range(len(seq)))}, = {src}\n"
                     for p, seq, src in (("v", vectors, "vec"), ("c", core_numbers, "core"))
                     if seq)
    src = (f"def build(vec, b, core, f, t):\n{unpack}    return {{"
           + ", ".join(items) + f", 'reward_terms': {{{rt}}}}}\n")
    scope: dict[str, Any] = {}
    exec(src, scope)
    return scope["build"]


def goal_columns(core: WheelCore) -> list[int]:
    """The columns of the task's ``goal_entries`` among the task's observation entries, in the
    order of ``goal_entries`` (those the observation has)."""
    names = list(core.obs_names[:core.task_obs_dim])
    return [names.index(n) for n in core.task.goal_entries if n in names]


def goal_free_columns(core: WheelCore) -> np.ndarray:
    """The observation columns that do not depend on the desired goal (``goal_free_observation``):
    every entry but the task's ``goal_entries``, and their copies in the observation history
    (block ``t`` of the core's layout repeats the ``task_obs_dim`` task entries)."""
    D = core.task_obs_dim
    drop = {t * D + j for t in range(core.n_obs_history + 1) for j in goal_columns(core)}
    return np.array([i for i in range(len(core.obs_names)) if i not in drop], dtype=np.int64)


def relabel_observation(core: WheelCore, columns: np.ndarray | None, observation: np.ndarray,
                        achieved_goal: np.ndarray, desired_goal: np.ndarray) -> np.ndarray:
    """``observation`` (the Dict observation's ``observation`` key, batched over leading axes)
    with its goal entries recomputed for ``desired_goal`` from the robot's ``achieved_goal``
    (``GoalTask.goal_observation``), a new float32 array: what the env would have observed had
    its goal been ``desired_goal`` ("Goal-conditioned"). ``columns``: ``goal_free_columns`` or
    None.

    Raises:
        ValueError: the observation holds no goal entries (``goal_free_observation``), or other
            entries depend on the goal or on past poses (observation history, noise, dropped or
            stuck entries), or the task's goal entries are not functions of its goal space
            (navigate)."""
    if columns is not None:
        raise ValueError("relabel_observation needs the goal's entries in the observation "
                         "(goal_free_observation=False); a goal-free observation needs none")
    p = core.perturbation
    reasons = [r for r, on in (
        ("obs_history", core.n_obs_history > 0),
        ("obs_noise", core.obs_noise > 0 or (p is not None and p.obs_noise > 0)),
        ("perturbation obs_dropped", p is not None and p.obs_dropped[0] > 0),
        ("perturbation obs_stuck", p is not None and p.obs_stuck[0] > 0)) if on]
    if reasons:
        raise ValueError(f"relabel_observation cannot recompute the goal's entries with "
                         f"{', '.join(reasons)} (they hold past poses or drawn errors); use "
                         "goal_free_observation=True")
    goal = core.task.goal_observation(achieved_goal, desired_goal)
    out = np.array(observation, dtype=np.float32)
    if out.shape[:-1] != goal.shape[:-1] or out.shape[-1] != len(core.obs_names):
        raise ValueError(f"observation must have shape (..., {len(core.obs_names)}) with the "
                         f"goals' leading shape {goal.shape[:-1]}, got {out.shape}")
    out[..., goal_columns(core)] = goal
    return out


def observation_names(core: WheelCore, columns: np.ndarray | None = None) -> tuple[str, ...]:
    """The names of the observation's entries in order (the "Observation Space" table);
    ``columns``: those kept (``goal_free_columns``; None: all)."""
    names = tuple(core.obs_names)
    return names if columns is None else tuple(names[int(i)] for i in columns)


def goal_space(core: WheelCore, obs_space: spaces.Box,
               columns: np.ndarray | None = None) -> spaces.Dict:
    """The ``goal_conditioned`` observation space of ``core``'s task (one env); ``columns``:
    those of ``obs_space`` the ``observation`` key keeps (None: all)."""
    high = core.task.goal_high().astype(np.float32)
    if columns is not None:
        obs_space = spaces.Box(obs_space.low[columns], obs_space.high[columns],
                               dtype=np.float32)
    return spaces.Dict({"observation": obs_space,
                        "achieved_goal": spaces.Box(-high, high, dtype=np.float32),
                        "desired_goal": spaces.Box(-high, high, dtype=np.float32)})


class WheelEnv(gym.Env):
    """Base of the wheelgym environments (one robot, one task); see the robot subclasses."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 20}
    robot: str = ""

    def __init__(self, **kwargs: Any) -> None:
        """Keywords: the "Arguments" table (:class:`~wheelgym.envs.config.EnvConfig`'s
        fields), validated once by the config and passed down to the core."""
        config = EnvConfig.from_kwargs(type(self).__name__, self.robot, kwargs,
                                       tuple(self.metadata["render_modes"]))
        #: The validated keyword arguments.
        self.config = config
        self.core = WheelCore(config, 1)
        c = self.core
        self.render_mode = config.render_mode
        self.task = config.task
        self.action_mode = c.action_mode
        self.dt = c.dt
        self.action_space = spaces.Box(-1.0, 1.0, (c.action_dim,), np.float32)
        self.observation_space = spaces.Box(c.obs_low, c.obs_high, dtype=np.float32)
        self._gc = config.goal_conditioned
        #: ``goal_free_observation``: the observation columns kept (else None: all).
        self._columns = goal_free_columns(c) if config.goal_free_observation else None
        if self._gc:
            self.observation_space = goal_space(c, self.observation_space, self._columns)
            # only a goal-conditioned env has them (checkers detect a GoalEnv by them)
            self.compute_reward = self._compute_reward
            self.compute_terminated = self._compute_terminated
            self.compute_truncated = self._compute_truncated
            self.relabel_observation = self._relabel_observation
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / c.dt))}
        self._names = c.task.names
        #: The observation's entry names in order (``goal_conditioned``: those of the
        #: ``observation`` key, without the goal's with ``goal_free_observation``).
        self.observation_names: tuple[str, ...] = observation_names(c, self._columns)
        self._tidx = [int(k) for k in c.task.term_index]
        self._shape = (c.action_dim,)
        self._renderer = None
        self._started = False
        self._ended = False  # the episode terminated (steps pay 0 until reset())
        self._warned_ended = False
        self._bind()

    def _bind(self) -> None:
        """Row 0 of the action buffer and of the core's blocks as views, and the info keys
        on them, for ``step``; rebuilt after a copy (a copied view stops aliasing its
        block)."""
        c = self.core
        self._A0 = c.A[0]  # the actions go into the core's buffer (its direct calls)
        self._obs0 = c.obs[0]
        self._terms0 = c.terms[0]
        self._zero_terms = np.zeros_like(self._terms0)  # (a reset's reward terms)
        self._f0 = c.F[0]
        self._b0 = c.B[0]
        self._info_vec = tuple(v[0] for _, v in c.info_vectors)
        self._info_core = tuple(v for _, v in c.info_core)
        floats, flags = c.info_columns()
        self._info_build = _info_builder(
            tuple(n for n, _ in c.info_vectors),
            tuple((n, col) for n, col in floats if not isinstance(col, slice)),
            tuple(n for n, _ in c.info_core), flags,
            tuple(zip(self._names, self._tidx, strict=True)))

    # ------------------------------------------------------------------ copies
    def __getstate__(self) -> dict[str, Any]:
        """``copy.deepcopy`` and ``pickle`` copy the episode exactly (the core, the task, the
        generator); the renderer (a window, fonts) is left out and rebuilt on demand."""
        state = self.__dict__.copy()
        state["_renderer"] = None
        del state["_info_build"]  # (generated code: _bind builds it again)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind()

    # ------------------------------------------------------------------ reward weights
    @property
    def reward_weights(self) -> dict[str, float]:
        """The weight of each reward term now (a copy; see the "Rewards" table)."""
        return dict(self.core.task.weights)

    def set_reward_weights(self, weights: dict[str, float]) -> None:
        """Change the weights of the named reward terms from the next step on (the others
        keep theirs), e.g. a curriculum during training. Unknown keys raise ``ValueError``
        listing the valid ones; a weight that is not a finite number raises; nothing changes
        then."""
        self.core.task.set_weights(weights)

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode; ``options`` as in the "Reset Options" table (unknown keys raise
        ``ValueError`` listing the valid ones)."""
        super().reset(seed=seed)
        c = self.core
        row = c.reset(None, [self.np_random], options)[0]
        obs = self._goal_obs(row) if self._gc else row.copy()
        self._started = True
        self._ended = False
        info = self._info(True)
        if self._gc:
            info.update(self._goal_info(c.task.achieved_goal(), True))
        info["params"] = {k: np.float64(v) for k, v in c.drawn[0].items()}
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
        dt = a.dtype
        if dt is not _F32 and dt is not _F64 and dt.kind not in "fiu":
            raise TypeError(f"action must be an array of real numbers (float or int), got "
                            f"dtype {dt}")
        if a.shape != self._shape:
            raise ValueError(f"action must have shape {self._shape}, got {np.shape(action)}")
        self._A0[:] = a
        prev = self.core.task.achieved_goal() if self._gc else None
        c = self.core
        _, reward, term, _ = c._step(c.A, None)  # (A: float64 of the shape)
        info = self._info(False)
        if self._gc:
            info.update(self._goal_info(prev, False))
        if self._ended:  # beyond the end (class docstring): reward 0, still terminated
            if not self._warned_ended:
                gym.logger.warn(
                    "step() called after the episode terminated; call reset() first. Steps "
                    "until reset() return reward 0 and terminated=True")
                self._warned_ended = True
            info["reward_terms"] = dict.fromkeys(self._names, _ZERO)
            r, t = 0.0, True
        else:
            r, t = reward.item(0), term.item(0)
            self._ended = t
        if self.render_mode == "human":
            self.render()
        if self._gc:
            return self._goal_obs(self._obs0), r, t, False, info
        return self._obs0.copy(), r, t, False, info

    # ------------------------------------------------------------------ goal-conditioned
    def _goal_obs(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        """The Dict observation; ``obs`` is the core's row (copied here: the kept columns by
        their indexing, else whole)."""
        task = self.core.task
        obs = obs.copy() if self._columns is None else obs[self._columns]
        return {"observation": obs, "achieved_goal": task.achieved_goal()[0].astype(np.float32),
                "desired_goal": task.desired_goal()[0].astype(np.float32)}

    def _goal_info(self, prev: np.ndarray, at_reset: bool) -> dict[str, Any]:
        g = self.core.task.goal_info(prev, np.zeros(1, dtype=np.int64) if at_reset else None)
        return {"prev_achieved_goal": g["prev_achieved_goal"][0],
                "reward_goal_free": g["reward_goal_free"][0],
                "success_allowed": bool(g["success_allowed"][0]),
                "terminated_goal_free": bool(g["terminated_goal_free"][0])}

    def _goal_task(self):
        return self.core.task

    def _compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray,
                       info: Any) -> np.ndarray | float:
        """The step reward had the goal been ``desired_goal`` (``goal_conditioned``), batched
        over leading axes: ``info`` is one step's info, or a list or array of them (one per
        goal, as SB3's ``HerReplayBuffer`` passes). With the true goal it equals the step's
        reward (to rounding). See the "Goal-conditioned" section."""
        r = self._goal_task().compute_reward(achieved_goal, desired_goal, info)
        return float(r) if np.ndim(r) == 0 else r

    def _compute_terminated(self, achieved_goal: np.ndarray, desired_goal: np.ndarray,
                           info: Any) -> np.ndarray | bool:
        """Whether the step ends the episode for ``desired_goal`` (batched as
        :meth:`compute_reward`): success within the tolerances, or an end that does not
        depend on the goal (overspeed, numerical failure, collision)."""
        t = self._goal_task().compute_terminated(achieved_goal, desired_goal, info)
        return bool(t) if np.ndim(t) == 0 else t

    def _relabel_observation(self, observation: np.ndarray, achieved_goal: np.ndarray,
                             desired_goal: np.ndarray) -> np.ndarray:
        """The ``observation`` key with its goal entries recomputed for ``desired_goal``
        (batched over leading axes): what the robot at ``achieved_goal`` would have observed
        with that goal, for hindsight relabelling ("Goal-conditioned";
        :func:`relabel_observation` says when it raises)."""
        return relabel_observation(self.core, self._columns, observation, achieved_goal,
                                   desired_goal)

    def _compute_truncated(self, achieved_goal: np.ndarray, desired_goal: np.ndarray,
                          info: Any) -> np.ndarray | bool:
        """Always False (time limits belong to the wrappers), batched as
        :meth:`compute_reward`."""
        shape = np.shape(achieved_goal)[:-1]
        self._goal_task()
        return False if not shape else np.zeros(shape, dtype=np.bool_)

    def _info(self, at_reset: bool) -> dict[str, Any]:
        """The step info (``core.INFO_KEYS``, through the core's views of its blocks): vectors
        as copies, numbers as NumPy ``float64`` scalars (a dtype, as TorchRL's info reader needs),
        flags as Python bools (``SyncVectorEnv`` batches ``np.bool_`` into object arrays), the
        reward terms as a dict of ``float64`` (zeros at a reset); one dict display generated
        for the env's keys and columns (:func:`_info_builder`)."""
        return self._info_build(self._info_vec, self._b0, self._info_core, self._f0.tolist(),
                                self._zero_terms if at_reset else self._terms0)

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


WheelEnv.__init__.__signature__ = signature_with()  # type: ignore[attr-defined]
