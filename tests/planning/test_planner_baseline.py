"""The planning baseline drives navigate episodes to their goals (a few seeds per robot kind)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym
from wheelgym.planning import grid_from_world
from wheelgym.registration import env_id


def _episodes(robot, arena, seeds, **kw):
    env = gym.make(env_id(robot), task="navigate", arena=arena)
    pol = wheelgym.baseline(env, planner="auto", **kw)
    wins = []
    for s in seeds:
        obs, _ = env.reset(seed=s)
        for _ in range(500):
            obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
            if term or trunc:
                break
        wins.append(bool(info["is_success"]))
    return wins, pol.navigator


@pytest.mark.parametrize("robot,arena", [("ThreeWheel", "maze"), ("DiffDrive", None),
                                         ("Bicycle", None)])
def test_planner_reaches_the_goals(robot, arena):
    wins, nav = _episodes(robot, arena, range(3))
    assert all(wins), wins
    st = nav.stats()
    assert st["plans"] >= 3 and st["failures"] == 0 and st["plan_ms_mean"] > 0


@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer"])
def test_velocity_mode_commands_stay_inside_the_twist_range(robot):
    """Cruise 1.5 m/s against a 1 m/s command range would clip on most steps (and bend a
    holonomic robot's direction): in the velocity mode the twist is scaled into TWIST_MARGIN
    of ``twist_max``, so no command reaches its bound."""
    from wheelgym.planning.navigator import TWIST_MARGIN

    env = gym.make(env_id(robot), task="navigate", action_mode="velocity", arena="office")
    pol = wheelgym.baseline(env, planner="auto")
    obs, _ = env.reset(seed=1)
    peak, clipped = 0.0, 0
    for _ in range(500):
        a = pol.predict(obs)[0]
        peak = max(peak, float(np.max(np.abs(a))))
        obs, _, term, trunc, info = env.step(a)
        clipped += bool(env.unwrapped.core._clipped[0])
        if term or trunc:
            break
    assert info["is_success"]
    assert 0.9 * TWIST_MARGIN < peak <= TWIST_MARGIN + 1e-6  # cruising inside (float32 actions)
    assert clipped == 0
    # the torque mode's twist is no command with a range: no cap
    tq = wheelgym.baseline(gym.make(env_id(robot), task="navigate"), planner="auto")
    assert tq.navigator.twist_cap is None


def test_vector_env_rows_plan_independently():
    env = gym.make_vec(env_id("Unicycle"), num_envs=3, task="navigate",
                       vectorization_mode="vector_entry_point")
    pol = wheelgym.baseline(env, planner="auto")
    obs, _ = env.reset(seed=0)
    done = np.zeros(3, bool)
    for _ in range(500):
        obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
        done |= term & info["is_success"]
        if done.all():
            break
    assert done.all()


def test_planner_choice_is_checked():
    env = gym.make(env_id("Bicycle"), task="navigate")
    with pytest.raises(ValueError, match="astar"):
        wheelgym.baseline(env, planner="astar")
    with pytest.raises(ValueError, match="planner must be one of"):
        wheelgym.baseline(env, planner="rrt")
    with pytest.raises(ValueError, match="navigate"):
        wheelgym.baseline(gym.make(env_id("ThreeWheel"), task="goal"), planner="auto")
    with pytest.raises(ValueError, match="hybrid"):
        wheelgym.baseline(gym.make(env_id("ThreeWheel"), task="navigate"), planner="hybrid")


@pytest.mark.parametrize("robot", ["DiffDrive", "Bicycle"])
def test_planner_replans_when_the_robot_strays(robot):
    env = gym.make(env_id(robot), task="navigate")
    pol = wheelgym.baseline(env, planner="auto")
    obs, _ = env.reset(seed=4)
    for _ in range(10):
        obs, *_ = env.step(pol.predict(obs)[0])
    nav, core = pol.navigator, env.unwrapped.core
    plans = nav.plans
    # push the robot sideways, off its path (to a free place), then one step of action 0
    grid = grid_from_world(core.task.worlds[0], core.task.arena, core.spec.radius)
    pose = core.X[0, :3].copy()
    for side in (0.6, -0.6, 0.9, -0.9):
        p = pose[:2] + side * np.array([-np.sin(pose[2]), np.cos(pose[2])])
        if grid.gap[grid.cell_of(p)] > 0.1:
            break
    core.X[0, :2] = p
    obs, *_ = env.step(np.zeros(env.action_space.shape))
    for _ in range(3):
        obs, _, term, trunc, _ = env.step(pol.predict(obs)[0])
    assert nav.plans > plans and nav.replans >= 1
    for _ in range(500):
        obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
        if term or trunc:
            break
    assert info["is_success"]
