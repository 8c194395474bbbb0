"""skrl on the native vector env: ``wrap_env`` picks its Gymnasium wrapper, same-step autoreset
counts every episode end, NEXT_STEP warns, and skrl's own PPO trains (docs/topics/clients.md)."""

from __future__ import annotations

import gymnasium as gym
import pytest

from tests.clients.conftest import require

require("skrl", "skrl")
torch = require("torch", "torch")

from skrl.envs.wrappers.torch import wrap_env  # noqa: E402

import wheelgym  # noqa: E402, F401

ID = "wheelgym/ThreeWheel-v0"


def make(mode: str, n: int = 8, **kw):
    return gym.make_vec(ID, num_envs=n, vectorization_mode="vector_entry_point",
                        autoreset_mode=mode, max_episode_steps=50, **kw)


def count_ends(env, steps: int) -> int:
    env.reset()
    a = torch.zeros((env.num_envs, *env.action_space.shape))  # at rest: only time limits end
    ends = 0
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(a)
        ends += int((term | trunc).sum())
    return ends


def test_wrap_env_auto_detects_and_counts_every_episode_end():
    env = wrap_env(make("SameStep"))  # wrapper="auto": skrl reads the class's direct bases
    assert type(env).__name__ == "GymnasiumWrapper" and env.num_envs == 8
    assert env.observation_space.shape == (13,) and env.action_space.shape == (6,)
    assert count_ends(env, 200) == 8 * 200 // 50  # 32: every 50-step episode ends


def test_goal_conditioned_dict_observations_are_flattened():
    env = wrap_env(make("SameStep", task="goal", goal_conditioned=True))
    obs, _ = env.reset()
    assert obs.shape == (8, 13 + 4 + 4) and obs.dtype == torch.float32  # one float32 Dict
    obs, rew, *_ = env.step(torch.zeros((8, 6)))
    assert obs.shape == (8, 21) and rew.shape == (8, 1)


def test_next_step_warns():
    env = wrap_env(make("NextStep"))
    with pytest.warns(UserWarning, match="autoreset_mode='SameStep'"):
        env.reset()
    # what the warning is about: the autoreset steps are taken as transitions (24, not 32)
    assert count_ends(env, 200) < 32


def test_skrl_ppo_trains_on_the_native_env(tmp_path):
    from skrl.agents.torch.base import ExperimentCfg
    from skrl.agents.torch.ppo import PPO, PPO_CFG
    from skrl.memories.torch import RandomMemory
    from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
    from skrl.trainers.torch import SequentialTrainer

    class Policy(GaussianMixin, Model):
        def __init__(self, observation_space, action_space, device):
            Model.__init__(self, observation_space=observation_space,
                           action_space=action_space, device=device)
            GaussianMixin.__init__(self, clip_actions=True)
            self.net = torch.nn.Sequential(torch.nn.Linear(self.num_observations, 32),
                                           torch.nn.Tanh(),
                                           torch.nn.Linear(32, self.num_actions))
            self.log_std = torch.nn.Parameter(torch.full((self.num_actions,), -0.5))

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {"log_std": self.log_std}

    class Value(DeterministicMixin, Model):
        def __init__(self, observation_space, action_space, device):
            Model.__init__(self, observation_space=observation_space,
                           action_space=action_space, device=device)
            DeterministicMixin.__init__(self)
            self.net = torch.nn.Sequential(torch.nn.Linear(self.num_observations, 32),
                                           torch.nn.Tanh(), torch.nn.Linear(32, 1))

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {}

    torch.manual_seed(0)
    env = wrap_env(make("SameStep", task="goal", action_mode="velocity"))
    models = {"policy": Policy(env.observation_space, env.action_space, "cpu"),
              "value": Value(env.observation_space, env.action_space, "cpu")}
    memory = RandomMemory(memory_size=32, num_envs=env.num_envs, device="cpu")
    agent = PPO(models=models, memory=memory, observation_space=env.observation_space,
                action_space=env.action_space, device="cpu",
                cfg=PPO_CFG(rollouts=32, learning_epochs=2, mini_batches=2,
                            experiment=ExperimentCfg(directory=str(tmp_path), write_interval=0,
                                                     checkpoint_interval=0)))
    before = [p.detach().clone() for p in models["policy"].parameters()]
    trainer = SequentialTrainer(env=env, agents=agent,
                                cfg={"timesteps": 320, "headless": True,
                                     "disable_progressbar": True,
                                     "close_environment_at_exit": False})
    trainer.train()  # 320 steps x 8 sub-envs = 2,560 env steps, 10 PPO updates
    after = list(models["policy"].parameters())
    assert any(not torch.equal(b, a) for b, a in zip(before, after, strict=True))
    assert all(torch.isfinite(p).all() for p in after)
    env.close()
