"""The analytic baseline policy: goal success, track RMS error, navigate vs random."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401
from wheelgym.control.baseline import baseline


def _episode(env, pol, seed, rng=None):
    obs, info = env.reset(seed=seed)
    errs = []
    for _ in range(500):
        a = pol.predict(obs)[0] if rng is None else rng.uniform(-1, 1, env.action_space.shape)
        obs, r, te, tr, info = env.step(a)
        errs.append(info["tracking_error"])
        if te or tr:
            break
    return info, te, float(np.sqrt(np.mean(np.square(errs))))


ROBOT_MODES = [(r, m) for r in ("ThreeWheel", "SkidSteer") for m in ("torque", "velocity")]


def _goal_and_track(robot, mode, seeds, track_seeds):
    env = gym.make(f"wheelgym/{robot}-v0", task="goal", action_mode=mode)
    pol = baseline(env)
    wins = [_episode(env, pol, s)[0]["is_success"] for s in seeds]
    env = gym.make(f"wheelgym/{robot}-v0", task="track", action_mode=mode)
    pol = baseline(env)
    runs = [_episode(env, pol, s) for s in track_seeds]
    return np.mean(wins), [rms for _, _, rms in runs], [te for _, te, _ in runs]


@pytest.mark.parametrize("robot,mode", ROBOT_MODES)
def test_baseline_goal_and_track_small(robot, mode):
    win, rms, ended = _goal_and_track(robot, mode, range(100, 106), range(100, 103))
    assert win >= 5 / 6
    assert not any(ended) and np.sqrt(np.mean(np.square(rms))) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("robot,mode", ROBOT_MODES)
def test_baseline_goal_and_track_20_seeds(robot, mode):
    win, rms, ended = _goal_and_track(robot, mode, range(20), range(20))
    assert win >= 0.95
    assert not any(ended) and max(rms) < 0.05


@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer"])
def test_baseline_navigate_beats_random(robot):
    env = gym.make(f"wheelgym/{robot}-v0", task="navigate")
    pol = baseline(env)
    rng = np.random.default_rng(0)
    seeds = range(6)
    base = np.mean([_episode(env, pol, s)[0]["is_success"] for s in seeds])
    rand = np.mean([_episode(env, pol, s, rng)[0]["is_success"] for s in seeds])
    assert base >= 0.75 and base >= rand + 0.5


@pytest.mark.parametrize("robot", ["CasterAGV", "DiffDrive", "Unicycle"])
def test_baseline_drives_other_robots_to_goals(robot):
    env = gym.make(f"wheelgym/{robot}-v0", task="goal")
    pol = baseline(env)
    assert np.mean([_episode(env, pol, s)[0]["is_success"] for s in range(4)]) >= 0.75


def test_baseline_on_a_batched_core_matches_single():
    from wheelgym.envs.core import WheelCore

    core = WheelCore("ThreeWheel", 3, task="goal")
    rngs = [np.random.default_rng(s) for s in (0, 1, 2)]
    core.reset(None, rngs)
    pol = baseline(core)
    env = gym.make("wheelgym/ThreeWheel-v0", task="goal")
    single = baseline(env)
    obs, _ = env.reset(seed=1)  # np_random of seed 1 is default_rng(1), row 1's generator
    a_batch = pol.predict(core.obs)[0]
    assert a_batch.shape == (3, 6)
    np.testing.assert_array_equal(obs, core.obs[1])
    np.testing.assert_array_equal(single.predict(obs)[0], a_batch[1])


def test_baseline_rejects_non_wheelgym_env():
    with pytest.raises(TypeError, match="wheelgym"):
        baseline(gym.make("Pendulum-v1"))
