"""Tianshou on the native vector env through :class:`~wheelgym.vector.tianshou.TianshouVectorEnv`:
the same transitions as ``DummyVectorEnv`` of single envs, subsets of sub-envs, and Tianshou's
own PPO through its ``Collector`` and trainer (docs/topics/clients.md)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.clients.conftest import require

require("tianshou", "Tianshou")
torch = require("torch", "torch")

from tianshou.env import BaseVectorEnv, DummyVectorEnv  # noqa: E402

import wheelgym  # noqa: E402, F401
from tests.vector.conftest import assert_same  # noqa: E402
from wheelgym.vector import make_tianshou_vec_env  # noqa: E402

ID = "wheelgym/ThreeWheel-v0"
N, T = 3, 15


@pytest.mark.parametrize("goal_conditioned", [False, True], ids=["box", "goal_conditioned"])
def test_matches_dummy_vector_env_bit_for_bit(goal_conditioned):
    kw = {"task": "goal", "max_episode_steps": T, "goal_conditioned": goal_conditioned}
    mine = make_tianshou_vec_env(ID, N, **kw)
    ref = DummyVectorEnv([lambda: gym.make(ID, **kw) for _ in range(N)])
    assert isinstance(mine, BaseVectorEnv) and len(mine) == N
    assert mine.action_space == ref.action_space  # one single-env space per sub-env
    assert mine.observation_space == ref.observation_space
    assert mine.seed(7) == ref.seed(7)
    assert_same(mine.reset(), ref.reset(), "reset")
    rng = np.random.default_rng(0)
    ends = 0
    for t in range(60):
        a = rng.uniform(-1, 1, (N, 6))
        a[rng.random(N) < 0.3] = 1.0  # bang-bang now and then: overspeed ends
        out = mine.step(a)
        assert_same(out, ref.step(a), f"step {t}")
        done = np.flatnonzero(out[2] | out[3])
        ends += done.size
        if done.size:  # as the Collector does: reset the ended sub-envs
            assert_same(mine.reset(done), ref.reset(done), f"reset {t}")
    assert ends >= N * 3


def test_subsets_and_stale_sub_envs():
    env = make_tianshou_vec_env(ID, N, seed=0, max_episode_steps=T)
    env.reset()
    obs, rew, term, trunc, info = env.step(np.zeros((2, 6)), id=[2, 0])
    assert obs.shape == (2, 13) and [i["env_id"] for i in info] == [2, 0]
    with pytest.raises(RuntimeError, match=r"sub-envs \[1\] were left out"):
        env.step(np.zeros((N, 6)))
    env.reset(env_id=[1])  # reset: usable again
    env.step(np.zeros((N, 6)))
    with pytest.raises(ValueError, match="id must be"):
        env.step(np.zeros((1, 6)), id=[N])
    with pytest.raises(ValueError, match="one row per sub-env"):
        env.step(np.zeros((1, 6)), id=[0, 1])
    with pytest.raises(ValueError, match="autoreset_mode"):
        make_tianshou_vec_env(ID, N, autoreset_mode="SameStep")


def test_info_keys():
    full = make_tianshou_vec_env(ID, N, seed=0)
    few = make_tianshou_vec_env(ID, N, seed=0, info_keys=("is_success", "tracking_error"))
    none = make_tianshou_vec_env(ID, N, seed=0, info_keys=())
    for env in (full, few, none):
        env.reset()
    a = np.zeros((N, 6))
    (*out, info), (*out2, info2), (*out3, info3) = full.step(a), few.step(a), none.step(a)
    assert_same(out, out2)
    assert_same(out, out3)
    assert [set(i) for i in info2] == [{"is_success", "tracking_error", "env_id"}] * N
    assert [i["tracking_error"] for i in info2] == [i["tracking_error"] for i in info]
    assert list(info3) == [{"env_id": i} for i in range(N)]
    with pytest.raises(ValueError, match="info_keys"):
        make_tianshou_vec_env(ID, N, info_keys="some")


@pytest.mark.slow  # 3,072 env steps of PPO and its test episodes: ~60 s on a shared machine
def test_tianshou_ppo_trains_on_the_native_env():
    from tianshou.algorithm import PPO
    from tianshou.algorithm.modelfree.reinforce import ProbabilisticActorPolicy
    from tianshou.algorithm.optim import AdamOptimizerFactory
    from tianshou.data import Collector, VectorReplayBuffer
    from tianshou.trainer import OnPolicyTrainerParams
    from tianshou.utils.net.common import Net
    from tianshou.utils.net.continuous import ContinuousActorProbabilistic, ContinuousCritic
    from torch.distributions import Independent, Normal

    torch.manual_seed(0)
    kw = {"task": "goal", "action_mode": "velocity", "max_episode_steps": 100}
    train_envs = make_tianshou_vec_env(ID, 8, seed=0, **kw)
    test_envs = make_tianshou_vec_env(ID, 4, seed=100, **kw)
    space = gym.make(ID, **kw)
    obs_shape, act_shape = space.observation_space.shape, space.action_space.shape
    actor = ContinuousActorProbabilistic(
        preprocess_net=Net(state_shape=obs_shape, hidden_sizes=[32]), action_shape=act_shape,
        unbounded=True)
    critic = ContinuousCritic(preprocess_net=Net(state_shape=obs_shape, hidden_sizes=[32]))

    def dist(loc_scale):
        loc, scale = loc_scale
        return Independent(Normal(loc, scale), 1)

    policy = ProbabilisticActorPolicy(actor=actor, dist_fn=dist,
                                      action_space=space.action_space)
    algorithm = PPO(policy=policy, critic=critic, optim=AdamOptimizerFactory(lr=3e-4))
    train = Collector(algorithm, train_envs, VectorReplayBuffer(1024, len(train_envs)))
    test = Collector(algorithm, test_envs)  # n_episode collection: steps subsets
    before = [p.detach().clone() for p in actor.parameters()]
    result = algorithm.run_training(OnPolicyTrainerParams(
        training_collector=train, test_collector=test, max_epochs=1, epoch_num_steps=3072,
        collection_step_num_env_steps=1024, update_step_num_repetitions=2, batch_size=256,
        test_step_num_episodes=4, show_progress=False, verbose=False))
    assert train.collect_step >= 3072
    assert result.best_reward is not None and np.isfinite(result.best_reward)
    assert any(not torch.equal(b, a) for b, a in zip(before, actor.parameters(), strict=True))
