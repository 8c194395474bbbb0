"""``action_history=k``: the last k actions the policy sent, appended to the observation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401  (registers the ids)
from tests.envs.conftest import assert_vector_equals_single_across_autoresets
from wheelgym.envs.config import MAX_ACTION_HISTORY

CASES = [("DiffDrive", "v0", dict(task="goal", action_mode="WheelSpeeds")),
         ("SkidSteer", "v0", dict(task="track", action_mode="velocity", perturbation="medium")),
         ("ThreeWheel", "v0", dict(task="goal", action_mode="torque", obs_noise=0.05)),
         ("DiffDrive", "v1", dict(task="navigate", waypoint_hint=True))]


def _expected(past: list[np.ndarray], k: int, ad: int) -> np.ndarray:
    pad = [np.zeros(ad)] * max(0, k - len(past))
    return np.concatenate([*past[:k], *pad])


@pytest.mark.parametrize("robot,version,kw", CASES)
def test_history_is_the_sent_actions_and_leaves_the_task_entries_bit_equal(robot, version, kw):
    """The task's entries are those of the env without history, bit for bit (the same draws:
    observation noise and perturbation faults act on them alone), and the appended entries
    are the actions sent, clipped to [-1, 1], newest first, zeros before the first."""
    k = 3
    e0 = gym.make(f"wheelgym/{robot}-{version}", **kw)
    e1 = gym.make(f"wheelgym/{robot}-{version}", action_history=k, **kw)
    o0, _ = e0.reset(seed=7)
    o1, _ = e1.reset(seed=7)
    D, ad = o0.shape[0], e0.action_space.shape[0]
    assert e1.observation_space.shape == (D + k * ad,)
    assert e1.unwrapped.core.obs_names[D:D + 2] == ["prev_action_1_0", "prev_action_1_1"]
    assert np.array_equal(o1[:D], o0) and not o1[D:].any()
    rng = np.random.default_rng(0)
    past: list[np.ndarray] = []
    for _ in range(30):
        a = rng.uniform(-1.4, 1.4, ad).astype(np.float32)  # beyond the bounds too: clipped
        s0, s1 = e0.step(a), e1.step(a)
        past.insert(0, np.clip(a, -1.0, 1.0).astype(np.float64))
        assert np.array_equal(s1[0][:D], s0[0]) and s1[1] == s0[1]
        np.testing.assert_array_equal(s1[0][D:], _expected(past, k, ad).astype(np.float32))
        assert e1.observation_space.contains(s1[0])
        if s0[2] or s0[3]:
            break
    o1, _ = e1.reset()
    assert not o1[D:].any()  # a new episode starts with no action sent


def test_vector_env_equals_single_env_across_autoresets():
    assert_vector_equals_single_across_autoresets(perturbation="hard", action_history=2)


@pytest.mark.parametrize("bad,err", [(-1, ValueError), (MAX_ACTION_HISTORY + 1, ValueError),
                                     (True, TypeError), (1.5, TypeError)])
def test_bad_values_name_the_keyword(bad, err):
    with pytest.raises(err, match="action_history"):
        gym.make("wheelgym/DiffDrive-v0", action_history=bad)


def test_non_finite_action_raises_and_nothing_enters_the_history():
    env = gym.make("wheelgym/DiffDrive-v0", action_history=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0.0], dtype=np.float32))
