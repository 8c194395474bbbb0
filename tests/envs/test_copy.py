"""Copies of an episode in progress (``copy.deepcopy``, ``pickle``) continue bit for bit."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

from tests.envs.conftest import ROBOTS, TASKS, make

COPIERS = {"deepcopy": copy.deepcopy, "pickle": lambda e: pickle.loads(pickle.dumps(e))}


def _same_step(a, b) -> None:
    oa, ra, ta, tra, ia = a
    ob, rb, tb, trb, ib = b
    assert np.array_equal(oa, ob)
    assert ra == rb and ta == tb and tra == trb
    for k in ("pose", "twist", "motor_torque", "joint_velocity"):
        assert np.array_equal(ia[k], ib[k]), k
    for k in ("tracking_error", "energy", "internal_force", "saturated", "is_success"):
        assert ia[k] == ib[k], k
    assert ia["reward_terms"] == ib["reward_terms"]


@pytest.mark.parametrize("how", list(COPIERS))
@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("robot", ROBOTS)
def test_copy_stays_bit_equal_for_50_steps(robot, task, how):
    env = make(robot, task=task)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    shape = env.action_space.shape
    for _ in range(3):
        env.step(rng.uniform(-1, 1, shape).astype(np.float32))
    twin = COPIERS[how](env)
    for _ in range(50):
        a = rng.uniform(-1, 1, shape).astype(np.float32)
        sa, sb = env.step(a), twin.step(a)
        _same_step(sa, sb)
        # the copy's reward is its own terms' sum (its views alias its own blocks)
        assert sb[1] == pytest.approx(sum(sb[4]["reward_terms"].values()), abs=1e-12)
        if sa[2] or sa[3]:
            env.reset(seed=5)
            twin.reset(seed=5)
    env.close()


@pytest.mark.parametrize("how", list(COPIERS))
def test_copy_is_independent_and_keeps_the_generator(how):
    env = make("ThreeWheel", task="navigate", obs_noise=0.01, randomize=True)
    env.reset(seed=1)
    twin = COPIERS[how](env)
    a = np.zeros(env.action_space.shape, dtype=np.float32)
    before = twin.unwrapped.core.pose.copy()
    for _ in range(5):
        env.step(a + 0.5)
    assert np.array_equal(twin.unwrapped.core.pose, before)  # the original's steps do not leak
    # the copied generator continues the original's stream: the next resets agree
    env2 = COPIERS[how](twin)
    oa, _ = twin.reset()
    ob, _ = env2.reset()
    assert np.array_equal(oa, ob)


def test_copy_pymunk_backend_and_rendering_env():
    env = make("SkidSteer", task="navigate", range_backend="pymunk", render_mode="rgb_array")
    env.reset(seed=2)
    env.render()
    a = np.full(env.action_space.shape, 0.4, dtype=np.float32)
    env.step(a)
    twin = pickle.loads(pickle.dumps(env))
    assert twin.unwrapped._renderer is None
    for _ in range(20):
        out = env.step(a)
        _same_step(out, twin.step(a))
        if out[2] or out[3]:
            env.reset(seed=4)
            twin.reset(seed=4)
    assert twin.render().shape == (600, 600, 3)


@pytest.mark.parametrize("task", TASKS)
def test_copy_vector_env(task):
    venv = gym.make_vec("wheelgym/DiffDrive-v0", num_envs=12, task=task, max_episode_steps=20)
    venv.reset(seed=0)
    rng = np.random.default_rng(1)
    for _ in range(4):
        venv.step(rng.uniform(-1, 1, venv.action_space.shape))
    twin = pickle.loads(pickle.dumps(venv))
    for _ in range(40):
        a = rng.uniform(-1, 1, venv.action_space.shape)
        oa, ra, ta, tra, _ = venv.step(a)
        ob, rb, tb, trb, _ = twin.step(a)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb)
        assert np.array_equal(ta, tb) and np.array_equal(tra, trb)
