"""RLlib (new API stack) on the native vector env through ``vector_entry_point`` with
Gymnasium's default NEXT_STEP autoreset: its env runner's episodes, and RLlib's own PPO
(docs/topics/clients.md)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.clients.conftest import require

require("ray.rllib", "RLlib")
require("torch", "torch")

from ray.rllib.algorithms.ppo import PPOConfig  # noqa: E402

# "wheelgym:" imports wheelgym (registering the ids) wherever RLlib makes the env
ID = "wheelgym:wheelgym/ThreeWheel-v0"
T = 20


def config(n: int, **env_config) -> PPOConfig:
    return (PPOConfig()
            .environment(ID, env_config={"max_episode_steps": T, **env_config})
            .env_runners(num_env_runners=0, num_envs_per_env_runner=n,
                         gym_env_vectorize_mode="vector_entry_point")
            .debugging(seed=0))


def test_env_runner_episodes_on_the_native_env():
    from ray.rllib.env.single_agent_env_runner import SingleAgentEnvRunner

    from wheelgym.vector import ThreeWheelVectorEnv

    runner = SingleAgentEnvRunner(config=config(4))
    assert isinstance(runner.env.unwrapped, ThreeWheelVectorEnv)  # one native batch
    episodes = runner.sample(num_timesteps=200, random_actions=True)
    assert 200 <= sum(len(e) for e in episodes) < 204  # (stops after a whole batch step)
    done = [e for e in episodes if e.is_done]
    assert len(done) >= 4
    # NEXT_STEP's reset steps are not transitions: no episode is longer than the limit, and
    # the truncated ones are exactly as long
    assert all(len(e) <= T for e in episodes)
    assert all(len(e) == T for e in done if e.is_truncated)
    info = done[0].get_infos(-1)  # the single env's info, nested reward terms included
    assert np.isfinite(info["tracking_error"]) and "progress" in info["reward_terms"]
    runner.stop()


def test_goal_conditioned_through_flatten_observations():
    from ray.rllib.connectors.env_to_module import FlattenObservations
    from ray.rllib.env.single_agent_env_runner import SingleAgentEnvRunner

    cfg = config(4, task="goal", goal_conditioned=True).env_runners(
        env_to_module_connector=lambda env, spaces=None, device=None: FlattenObservations())
    runner = SingleAgentEnvRunner(config=cfg)
    episodes = runner.sample(num_timesteps=100, random_actions=True)
    assert 100 <= sum(len(e) for e in episodes) < 104
    obs = episodes[0].get_observations(0)  # flattened: 13 + 4 + 4 float32
    assert obs.shape == (21,) and obs.dtype == np.float32
    runner.stop()


@pytest.mark.slow  # Ray start-up and PPO's learner: ~45 s on a shared machine
def test_rllib_ppo_trains_on_the_native_env():
    algo = (config(8, task="goal", action_mode="velocity", max_episode_steps=100)
            .env_runners(rollout_fragment_length=128)
            .training(train_batch_size_per_learner=1024, minibatch_size=256, num_epochs=2)
            .rl_module(model_config={"fcnet_hiddens": [32]})
            .build_algo())
    try:
        for _ in range(3):  # 3 x 1,024 env steps
            result = algo.train()
        runners = result["env_runners"]
        assert runners["num_env_steps_sampled_lifetime"] == 3072
        # (episode_len_max reads 101 for episodes that span two train() calls, with Gymnasium's
        # SyncVectorEnv of single envs too: RLlib's metric, not the env)
        assert np.isfinite(runners["episode_return_mean"])
        learner = result["learners"]["default_policy"]
        assert np.isfinite(learner["total_loss"])
    finally:
        algo.stop()
