"""TorchRL on wheelgym: the single env with an info reader, the native vector env with
SAME_STEP (flat info: its info reader and final observations) and DISABLED autoreset, and
TorchRL's own PPO (docs/topics/clients.md)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.clients.conftest import require

require("torchrl", "TorchRL")
torch = require("torch", "torch")

from torchrl.envs import GymWrapper, default_info_dict_reader  # noqa: E402
from torchrl.envs.utils import check_env_specs  # noqa: E402

import wheelgym  # noqa: E402, F401

ID = "wheelgym/ThreeWheel-v0"
N, T = 4, 20  # sub-envs, episode length


def native(mode: str, **kw):
    return gym.make_vec(ID, num_envs=N, vectorization_mode="vector_entry_point",
                        autoreset_mode=mode, max_episode_steps=T, **kw)


def zero_policy(td):
    return td.set("action", torch.zeros(td.batch_size + (6,)))


def test_single_env_with_an_info_reader():
    from torchrl.data import Unbounded

    env = GymWrapper(gym.make(ID, max_episode_steps=T))
    f64 = Unbounded((), dtype=torch.float64)
    env.set_info_dict_reader(default_info_dict_reader(["tracking_error", "energy"],
                                                      spec=[f64, f64.clone()]))
    check_env_specs(env)
    td = env.rollout(2 * T, policy=zero_policy, break_when_any_done=False)
    assert td["next", "tracking_error"].dtype == torch.float64  # a NumPy float64 in the info
    assert td["next", "tracking_error"].shape == (2 * T,)
    assert int(td["next", "truncated"].sum()) == 2


def test_native_same_step_flat_info_and_final_observations():
    vec = native("SameStep", reward_terms="flat", reset_info=False)
    env = GymWrapper(vec)  # registers its final-observation info reader
    check_env_specs(env)
    td = env.rollout(3 * T, policy=zero_policy, break_when_any_done=False)
    nxt = td["next"]
    assert td.batch_size == (N, 3 * T)
    assert nxt["tracking_error"].dtype == torch.float64
    assert nxt["is_success"].dtype == torch.bool
    assert nxt["reward_progress"].shape == (N, 3 * T)  # reward_terms="flat"
    # the weighted terms add up to the reward
    terms = sum(nxt[k] for k in nxt.keys() if isinstance(k, str) and k.startswith("reward_"))
    np.testing.assert_allclose(terms.numpy(), nxt["reward"][..., 0].numpy(), atol=1e-5)
    done = nxt["done"][..., 0]
    assert int(done.sum()) == N * 3  # every 20-step episode ended (at rest: time limits)
    # at an end, "next" holds the episode's last observation, the following step the reset one
    t = T - 1
    assert done[:, t].all()
    assert not torch.equal(nxt["observation"][:, t], td["observation"][:, t + 1])
    env.close()


def test_native_disabled_resets_through_reset_mask():
    env = GymWrapper(native("Disabled"))
    check_env_specs(env)
    td = env.rollout(3 * T, policy=zero_policy, break_when_any_done=False)
    assert int(td["next", "done"].sum()) == N * 3
    env.close()


def test_goal_conditioned_single_and_native_disabled():
    kw = {"task": "goal", "goal_conditioned": True}
    single = GymWrapper(gym.make(ID, max_episode_steps=T, **kw))
    check_env_specs(single)
    env = GymWrapper(native("Disabled", **kw))
    check_env_specs(env)
    td = env.rollout(2 * T, policy=zero_policy, break_when_any_done=False)
    for key in ("observation", "achieved_goal", "desired_goal"):
        assert td["next", key].dtype == torch.float32  # one dtype in the Dict space
    assert td["next", "achieved_goal"].shape == (N, 2 * T, 4)
    assert int(td["next", "done"].sum()) == N * 2


def test_next_step_is_refused_by_torchrl():
    with pytest.raises(RuntimeError, match="SAME_STEP or DISABLED"):
        GymWrapper(native("NextStep"))


@pytest.mark.slow  # 3,072 env steps of PPO: ~20 s on a shared machine
def test_torchrl_ppo_trains_on_the_native_env():
    from tensordict.nn import NormalParamExtractor, TensorDictModule
    from torchrl.collectors import Collector
    from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator
    from torchrl.objectives import ClipPPOLoss
    from torchrl.objectives.value import GAE

    torch.manual_seed(0)
    env = GymWrapper(gym.make_vec(ID, num_envs=8, vectorization_mode="vector_entry_point",
                                  autoreset_mode="SameStep", max_episode_steps=100,
                                  task="goal", action_mode="velocity",
                                  reward_terms="flat", reset_info=False))
    obs_dim, act_dim = 13, 3
    net = torch.nn.Sequential(torch.nn.Linear(obs_dim, 32), torch.nn.Tanh(),
                              torch.nn.Linear(32, 2 * act_dim), NormalParamExtractor())
    actor = ProbabilisticActor(
        TensorDictModule(net, in_keys=["observation"], out_keys=["loc", "scale"]),
        spec=env.action_spec, in_keys=["loc", "scale"], distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0}, return_log_prob=True)
    value = ValueOperator(torch.nn.Sequential(torch.nn.Linear(obs_dim, 32), torch.nn.Tanh(),
                                              torch.nn.Linear(32, 1)), in_keys=["observation"])
    collector = Collector(env, actor, frames_per_batch=1024, total_frames=3072)
    gae = GAE(gamma=0.99, lmbda=0.95, value_network=value, average_gae=True)
    loss = ClipPPOLoss(actor, value)
    opt = torch.optim.Adam(loss.parameters(), lr=3e-4)
    before = [p.detach().clone() for p in loss.parameters()]
    frames = 0
    for data in collector:  # 3 batches of 128 steps x 8 sub-envs
        frames += data.numel()
        with torch.no_grad():
            gae(data)
        flat = data.reshape(-1)
        for _ in range(2):
            for idx in torch.randperm(flat.numel()).split(256):
                out = loss(flat[idx])
                total = out["loss_objective"] + out["loss_critic"] + out["loss_entropy"]
                opt.zero_grad()
                total.backward()
                opt.step()
        assert torch.isfinite(total)
    collector.shutdown()
    assert frames == 3072
    assert any(not torch.equal(b, a) for b, a in zip(before, loss.parameters(), strict=True))
