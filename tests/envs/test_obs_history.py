"""``obs_history=k``: the task's entries of the last k steps, appended to the observation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401  (registers the ids)
from tests.envs.conftest import assert_vector_equals_single_across_autoresets
from wheelgym.envs.config import MAX_OBS_HISTORY

CASES = [("DiffDrive", "v0", dict(task="goal", action_mode="WheelSpeeds")),
         ("SkidSteer", "v0", dict(task="goal", action_mode="torque", perturbation="medium",
                                  action_history=2)),
         ("ThreeWheel", "v0", dict(task="track", action_mode="torque", obs_noise=0.05))]


@pytest.mark.parametrize("robot,version,kw", CASES)
def test_history_is_the_observed_entries_of_the_steps_before(robot, version, kw):
    """The task's entries (and the action history) are those of the env without obs history,
    bit for bit (the same draws); the appended entries are the task entries observed 1..k
    steps before, newest first, and a reset's first observation before the first step."""
    k = 3
    e0 = gym.make(f"wheelgym/{robot}-{version}", **kw)
    e1 = gym.make(f"wheelgym/{robot}-{version}", obs_history=k, **kw)
    o0, _ = e0.reset(seed=7)
    o1, _ = e1.reset(seed=7)
    D = e0.unwrapped.core.task_obs_dim
    assert e1.observation_space.shape == (o0.shape[0] + k * D,)
    names = e1.unwrapped.core.obs_names
    assert names[D] == f"prev_obs_1_{names[0]}"
    assert names[D + k * D - 1] == f"prev_obs_{k}_{names[D - 1]}"
    np.testing.assert_array_equal(e1.observation_space.high[D:D + D], e0.observation_space.high[:D])

    def split(o):
        return o[:D], o[D:D + k * D], o[D + k * D:]

    seen = [o0[:D]]
    a1, h1, t1 = split(o1)
    assert np.array_equal(a1, o0[:D]) and np.array_equal(t1, o0[D:])
    np.testing.assert_array_equal(h1, np.tile(o0[:D], k))  # the first stands for the steps before
    rng = np.random.default_rng(0)
    for _ in range(40):
        a = rng.uniform(-1, 1, e0.action_space.shape).astype(np.float32)
        s0, s1 = e0.step(a), e1.step(a)
        cur, hist, t = split(s1[0])
        assert np.array_equal(cur, s0[0][:D]) and np.array_equal(t, s0[0][D:]) and s1[1] == s0[1]
        past = seen[:k] + [seen[-1]] * (k - len(seen[:k]))
        np.testing.assert_array_equal(hist, np.concatenate(past))
        assert e1.observation_space.contains(s1[0])
        seen.insert(0, s0[0][:D])
        if s0[2] or s0[3]:
            break
    o1, _ = e1.reset(seed=8)
    np.testing.assert_array_equal(o1[D:D + k * D], np.tile(o1[:D], k))


def test_vector_env_equals_single_env_across_autoresets():
    assert_vector_equals_single_across_autoresets(perturbation="hard", obs_history=2,
                                                  action_history=1)


@pytest.mark.parametrize("bad,err", [(-1, ValueError), (MAX_OBS_HISTORY + 1, ValueError),
                                     (True, TypeError), (2.0, TypeError)])
def test_bad_values_name_the_keyword(bad, err):
    with pytest.raises(err, match="obs_history"):
        gym.make("wheelgym/DiffDrive-v0", obs_history=bad)
