"""``observation_names``: one name per observation entry, in order, single and vector env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.vector.conftest import env_id


@pytest.mark.parametrize("robot,task,kw", [
    ("ThreeWheel", "goal", {}),
    ("SkidSteer", "track", {"obs_history": 2}),
    ("DiffDrive", "navigate", {"action_history": 1}),
    ("Ackermann", "goal", {}),
])
def test_one_name_per_entry(robot, task, kw):
    env = gym.make(env_id(robot), task=task, **kw)
    names = env.unwrapped.observation_names
    assert len(names) == env.observation_space.shape[0] == len(set(names))
    assert all(isinstance(n, str) and n for n in names)
    if kw.get("obs_history"):
        assert names.index("prev_obs_1_vx") > names.index("vx")
    if kw.get("action_history"):
        assert names[-2:] == ("prev_action_1_0", "prev_action_1_1")
    venv = gym.make_vec(env_id(robot), num_envs=2, task=task, **kw)
    assert venv.observation_names == names


def test_goal_conditioned_names_follow_the_observation_key():
    """With goal_free_observation the names leave out the goal's entries, in the order of the
    Dict's 'observation' key (checked on values: the kept names pick the same bits out of the
    plain observation)."""
    kw = {"task": "goal", "action_mode": "velocity", "goal_conditioned": True}
    full = gym.make(env_id("ThreeWheel"), **kw)
    free = gym.make(env_id("ThreeWheel"), goal_free_observation=True, **kw)
    fn, gn = full.unwrapped.observation_names, free.unwrapped.observation_names
    assert fn[:4] == ("goal_x_b", "goal_y_b", "cos_dyaw", "sin_dyaw")
    assert gn == fn[4:]
    assert len(gn) == free.observation_space["observation"].shape[0]
    o_full, _ = full.reset(seed=1)
    o_free, _ = free.reset(seed=1)
    np.testing.assert_array_equal(o_free["observation"],
                                  o_full["observation"][[fn.index(n) for n in gn]])
    venv = gym.make_vec(env_id("ThreeWheel"), num_envs=2, goal_free_observation=True, **kw)
    assert venv.observation_names == gn
