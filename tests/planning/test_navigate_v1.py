"""navigate -v1: no policy gains by ending early or standing still; -v0 unchanged."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym
from wheelgym.registration import available_robots, env_id
from wheelgym.tasks.tasks import NAVIGATE_V1_WEIGHTS, navigate_v1_bound

# DiffDrive (kinematic: fast) at (3, y) facing the +x wall 1 m away, the goal 5 m behind it
START = (3.0, 0.0, 0.0)
GOAL = (-2.0, 0.0, 0.0)
LAYOUT = 4
FORWARD = np.array([1.0, 1.0])  # both wheels at full speed
STILL = np.zeros(2)
SPIN = np.array([1.0, -1.0])  # turning on the spot, saturated (the most effort per step)


def _env(version, **kw):
    return gym.make(env_id("DiffDrive", version), task="navigate", **kw)


def _run(env, actions, seed=0):
    """Return, steps, terminated, is_success and collision of one episode: ``actions(k)`` at
    step k (None: stop the episode there, as if truncated)."""
    env.reset(seed=seed, options={"start": START, "goal": GOAL, "layout_seed": LAYOUT})
    G, k = 0.0, 0
    while True:
        a = actions(k)
        if a is None:
            return G, k, False, False, False
        _, r, term, trunc, info = env.step(a)
        G += float(r)
        k += 1
        if term or trunc:
            return G, k, term, bool(info["is_success"]), bool(env.unwrapped.core.coll[0])


def _crash_step(env):
    G, k, term, _, hit = _run(env, lambda k: FORWARD)
    assert term and hit, "the constructed episode must end in a collision"
    return G, k


def test_default_weights_meet_the_bound():
    need_p, need_s = navigate_v1_bound(NAVIGATE_V1_WEIGHTS)
    assert min(NAVIGATE_V1_WEIGHTS["collision"], NAVIGATE_V1_WEIGHTS["overspeed"]) > need_p
    assert NAVIGATE_V1_WEIGHTS["success"] > need_s


@pytest.mark.parametrize("weights", [None, {"effort": 5.0, "proximity": 5.0, "saturation": 3.0,
                                            "collision": 24.5, "overspeed": 24.5}])
def test_crashing_never_pays_in_v1(weights):
    env = _env(1, reward_weights=weights)
    w = env.unwrapped.core.task.weights
    assert w["collision"] > navigate_v1_bound(w)[0]
    G_crash, k = _crash_step(env)
    # the same first k - 1 steps, then: stand still, spin saturated, or drive away from the
    # goal and back and forth, each until the 500-step truncation
    for after in (STILL, SPIN):
        G, n, term, _, _ = _run(env, lambda j, after=after: FORWARD if j < k - 1 else after)
        assert not term and n == 500
        assert G > G_crash, (after, G, G_crash)
    # reversing from the wall and away (the goal lies behind: this one gains progress) and
    # circling saturated far from it
    G, n, term, _, hit = _run(env, lambda j: FORWARD if j < k - 1 else
                              (-FORWARD if j < k + 4 else SPIN))
    assert not hit and G > G_crash


def test_v0_has_the_early_end_gain_that_v1_removes():
    # the construction detects an early-end gain: v0 with a per-step effort of 0.05 pays more
    # for 500 steps of spinning than for a crash
    env = _env(0, reward_weights={"effort": 0.05})
    G_crash, k = _crash_step(env)
    G_spin, _, _, _, _ = _run(env, lambda j: FORWARD if j < k - 1 else SPIN)
    assert G_spin < G_crash
    # v1 with the same total effort over an episode (0.05 * 500 = 25) and P above its bound
    w = {"effort": 25.0, "collision": 40.0}
    env = _env(1, reward_weights=w)
    assert env.unwrapped.core.task.weights["collision"] > navigate_v1_bound(
        env.unwrapped.core.task.weights)[0]
    G_crash, k = _crash_step(env)
    G_spin, _, _, _, _ = _run(env, lambda j: FORWARD if j < k - 1 else SPIN)
    assert G_spin > G_crash


def test_moving_to_the_goal_beats_standing_still():
    env = _env(1)
    G_still, n, term, _, _ = _run(env, lambda k: STILL)
    assert n == 500 and not term
    _, C = navigate_v1_bound(env.unwrapped.core.task.weights)
    assert -C <= G_still <= 0.0
    pol = wheelgym.baseline(env, planner="auto")
    env.reset(seed=0, options={"start": START, "goal": GOAL, "layout_seed": LAYOUT})
    G_move = 0.0
    for _ in range(500):
        _, r, term, trunc, info = env.step(pol.predict(np.zeros(1))[0])
        G_move += float(r)
        if term or trunc:
            break
    assert info["is_success"]
    assert G_move > G_still + env.unwrapped.core.task.weights["success"] - C


def test_v1_is_the_v0_kernel_with_per_episode_weights():
    v1 = _env(1)
    task = v1.unwrapped.core.task
    per_step = {k: float(task.W[task.columns.index(k)]) for k in task.names}
    # internal_force is scaled again by the torque limits inside set_weights (none here)
    v0 = _env(0, reward_weights=per_step)
    rng = np.random.default_rng(0)
    o0, _ = v0.reset(seed=3)
    o1, _ = v1.reset(seed=3)
    n0 = len(o0)
    assert np.array_equal(o0, o1[:n0]) and len(o1) == n0 + 3
    for _ in range(60):
        a = rng.uniform(-1, 1, 2)
        o0, r0, t0, _, i0 = v0.step(a)
        o1, r1, t1, _, i1 = v1.step(a)
        assert r0 == r1 and t0 == t1 and np.array_equal(o0, o1[:n0])
        if t0:
            break
    # the polar goal: distance and bearing of the body-frame goal the kernel writes first
    d = np.hypot(o1[0], o1[1])
    assert o1[n0] == pytest.approx(min(d, 12.0), rel=1e-6)
    assert o1[n0 + 1] == pytest.approx(o1[0] / d, abs=1e-6)
    assert o1[n0 + 2] == pytest.approx(o1[1] / d, abs=1e-6)


def test_waypoint_hint_points_along_the_shortest_path():
    env = _env(1, waypoint_hint=True)
    obs, _ = env.reset(seed=0, options={"start": START, "goal": GOAL, "layout_seed": LAYOUT})
    assert env.observation_space.contains(obs)
    names = env.unwrapped.core.obs_names
    wx, wy = obs[names.index("waypoint_x_b")], obs[names.index("waypoint_y_b")]
    assert np.hypot(wx, wy) == pytest.approx(1.0, abs=0.06)  # 1 m along the path
    assert wx < 0  # the goal lies behind the robot
    with pytest.raises(ValueError, match="waypoint_hint"):
        _env(0, waypoint_hint=True)
    with pytest.raises(ValueError, match="version"):
        gym.make(env_id("DiffDrive"), task="navigate", version=2)


@pytest.mark.parametrize("robot", available_robots())
def test_v1_ids_and_unchanged_goal_task(robot):
    assert env_id(robot, 1) in gym.registry
    a = gym.make(env_id(robot, 0), task="goal")
    b = gym.make(env_id(robot, 1), task="goal")
    oa, _ = a.reset(seed=1)
    ob, _ = b.reset(seed=1)
    assert np.array_equal(oa, ob)
    rng = np.random.default_rng(1)
    for _ in range(5):
        act = rng.uniform(-1, 1, a.action_space.shape)
        ra, rb = a.step(act), b.step(act)
        assert np.array_equal(ra[0], rb[0]) and ra[1] == rb[1]


def test_v1_compute_reward_matches_the_step_reward():
    env = _env(1, goal_conditioned=True)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(30):
        obs, r, term, _, info = env.step(rng.uniform(-1, 1, 2))
        # (the observed goals are float32: the state rounded, ~1e-7 m at these distances)
        assert env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"],
                                            info) == pytest.approx(r, abs=1e-5)
        if term:
            break


def _hint_on(segments):
    """A car's hint on a hand-made plan of ``(kind, signed length)`` pieces from the origin
    (the hint's tracker plans it instead of a hybrid A*)."""
    from wheelgym.kinematics.reeds_shepp import path_from_segments
    from wheelgym.models import Bicycle
    from wheelgym.planning import WaypointHint

    hint = WaypointHint(None, 0.2, 1, car=Bicycle())
    car = hint.cars[0]
    car.planner = lambda pose: path_from_segments(segments, car.radius, (0.0, 0.0, 0.0))
    world, goal = object(), np.array([9.0, 9.0])
    first = [True]

    def at(xy):
        f = hint.frame(0, world, np.array([*xy, 0.0]), goal, first[0])
        first[0] = False
        return f
    return at


def test_car_hint_stops_at_the_cusp_and_then_points_back():
    # forward 2 m along x to a cusp at (2, 0), then reversing 1 m to (1, 0)
    at = _hint_on([("S", 2.0), ("S", -1.0)])
    f = at((0.0, 0.0))
    assert f.ahead == pytest.approx((1.0, 0.0))  # 1 m ahead on the forward run
    assert (f.direction, f.remaining, f.offset, f.heading) == pytest.approx((1, 2.0, 0, 0))
    for x in (0.4, 0.8, 1.2):  # the tracker searches 0.5 m on from its last nearest sample
        at((x, 0.0))
    f = at((1.5, 0.05))
    assert f.ahead == pytest.approx((2.0, 0.0))  # not past the cusp
    assert (f.remaining, f.offset) == pytest.approx((0.5, 0.05), abs=0.011)
    # (1.6, 0) also lies on the reversing run: the tracker does not jump there before the cusp
    assert at((1.6, 0.0)).ahead == pytest.approx((2.0, 0.0))
    f = at((2.0, 0.0))  # at the cusp: 1 m back, behind the car, driving backwards
    assert f.ahead == pytest.approx((1.0, 0.0)) and f.direction == -1
    assert f.remaining == pytest.approx(1.0)


@pytest.mark.parametrize("robot, mode", [("Bicycle", "VehicleSpeedSteeringAngle"),
                                         ("Ackermann", "VehicleSpeedSteeringRate")])
def test_car_hint_is_the_planning_baselines_tracking_frame(robot, mode):
    """On the office map the hint's tracker replans when and where the planning baseline's
    does: its frame equals the baseline's at every step, and the baseline's steering is the
    feedback law of the observed frame (car_tracking.rear_wheel_steering)."""
    from wheelgym.kinematics.car_tracking import rear_wheel_steering

    env = gym.make(env_id(robot, 1), task="navigate", action_mode=mode, arena="office",
                   waypoint_hint=True)
    policy = wheelgym.baseline(env, planner="auto")
    names = env.unwrapped.core.obs_names
    k = names.index("plan_offset")
    assert names[k - 2:k + 5] == ["waypoint_x_b", "waypoint_y_b", "plan_offset", "plan_heading",
                                  "plan_curvature", "plan_direction", "plan_remaining"]
    steps = replans = 0
    rng = np.random.default_rng(0)
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        while True:
            assert env.observation_space.contains(obs)
            a = np.asarray(policy.predict(obs)[0])
            car, mine = policy.navigator.cars[0], env.unwrapped.core.task.hint.cars[0]
            assert mine.frame == car.frame
            e, th, kappa, d = (float(v) for v in obs[k:k + 4])
            if d != 0 and robot == "Bicycle":
                lim = car.limits
                want = rear_wheel_steering(e, th, kappa, int(d), lim.wheelbase, car.k_e,
                                           car.k_theta)
                want = min(max(want, -lim.max_steering_angle), lim.max_steering_angle)
                assert car._delta == pytest.approx(want, abs=1e-4)  # float32 observation
            if 30 <= steps % 100 < 50:  # off the plan for a while, as a learner drives
                a = np.clip(a + rng.normal(0.0, 1.0, 2), -1.0, 1.0)
            steps += 1
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                break
        replans += car.replans
    assert steps > 300
    assert replans > 0 or robot == "Ackermann"  # Bicycle's replans were matched too
