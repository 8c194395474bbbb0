"""HER as SB3 documents it: ``SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
replay_buffer_kwargs=dict(n_sampled_goal=4, goal_selection_strategy="future"))``.

wheelgym's reward is not a function of the goals alone (its progress term needs the achieved
goal before the step, its effort, internal-force, overspeed and collision terms the step's
physics), so ``compute_reward`` needs the step info, which SB3 stores only with
``copy_info_dict=True``. Without it the env says so at the first call, in one line; with it the
documented recipe runs and relabels with the env's own reward."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.vector.conftest import env_id
from wheelgym.tasks.tasks import HER_INFO_KEYS

HER_KWARGS = {"n_sampled_goal": 4, "goal_selection_strategy": "future"}  # SB3's docs example


def _env(**kw) -> gym.Env:
    return gym.make(env_id("ThreeWheel"), task="goal", action_mode="velocity",
                    goal_conditioned=True, max_episode_steps=50, **kw)


def _says_what_to_set(e: BaseException) -> None:
    text = str(e)
    assert "\n" not in text
    assert "copy_info_dict=True" in text and "HerReplayBuffer" in text
    for key in HER_INFO_KEYS:
        assert key in text


@pytest.mark.parametrize("info", [[{}] * 4, np.array([{}] * 4, dtype=object), {}],
                         ids=["list", "object-array", "dict"])
def test_empty_infos_as_sb3_passes_them_say_what_to_set(info):
    """What ``HerReplayBuffer._get_virtual_samples`` passes without ``copy_info_dict``: one
    empty dict per goal."""
    env = _env()
    obs, _ = env.reset(seed=0)
    ag = np.repeat(obs["achieved_goal"][None], 4, axis=0)
    dg = np.repeat(obs["desired_goal"][None], 4, axis=0)
    if isinstance(info, dict):
        ag, dg = ag[0], dg[0]
    with pytest.raises(ValueError) as e:
        env.unwrapped.compute_reward(ag, dg, info)
    _says_what_to_set(e.value)
    with pytest.raises(ValueError) as e:
        env.unwrapped.compute_terminated(ag, dg, info)
    _says_what_to_set(e.value)
    env.close()


def test_partial_info_names_what_is_missing():
    env = _env()
    obs, _ = env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    del info["reward_goal_free"]
    with pytest.raises(ValueError, match="copy_info_dict=True") as e:
        env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], [info])
    assert "prev_achieved_goal" in str(e.value)
    env.close()


@pytest.mark.slow  # torch import and SAC's first updates: up to a minute on a busy machine
def test_sb3_her_as_documented():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import SAC, HerReplayBuffer

    # as documented: the first relabelled batch (at learning_starts) says what to set
    model = SAC("MultiInputPolicy", _env(), learning_starts=100, batch_size=32, seed=0,
                policy_kwargs={"net_arch": [16, 16]}, replay_buffer_class=HerReplayBuffer,
                replay_buffer_kwargs=HER_KWARGS)
    with pytest.raises(ValueError) as e:
        model.learn(300)
    _says_what_to_set(e.value)
    assert model.num_timesteps <= 101  # at the first call, not deep into training

    # with what it says: a few hundred steps, the relabelled rewards are the env's own
    env = _env()
    model = SAC("MultiInputPolicy", env, learning_starts=100, batch_size=32, seed=0,
                policy_kwargs={"net_arch": [16, 16]}, replay_buffer_class=HerReplayBuffer,
                replay_buffer_kwargs={**HER_KWARGS, "copy_info_dict": True})
    model.learn(300)
    buf = model.replay_buffer
    n = buf.pos
    assert n == 300
    ag = buf.next_observations["achieved_goal"][:n, 0]
    dg = buf.observations["desired_goal"][:n, 0]
    r = env.unwrapped.compute_reward(ag, dg, buf.infos[:n, 0])
    np.testing.assert_allclose(r, buf.rewards[:n, 0], rtol=0, atol=1e-5)  # float32 store
    batch = buf.sample(64)  # real and relabelled goals: finite rewards
    assert np.all(np.isfinite(batch.rewards.numpy()))
