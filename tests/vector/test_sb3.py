"""The Stable-Baselines3 adapter: DummyVecEnv-equivalent output, SB3 wrappers, training."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.vector.conftest import assert_same, env_id

pytest.importorskip("stable_baselines3")
import torch  # noqa: E402
from stable_baselines3 import PPO, SAC  # noqa: E402
from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402
from stable_baselines3.common.vec_env import (  # noqa: E402
    DummyVecEnv,
    VecMonitor,
    VecNormalize,
)

from wheelgym.vector import SB3VecEnv, ThreeWheelVectorEnv, make_sb3_vec_env  # noqa: E402


@pytest.mark.parametrize("robot,task,mode", [
    ("ThreeWheel", "goal", "torque"),
    ("SkidSteer", "navigate", "velocity"),
    ("DiffDrive", "track", "WheelSpeeds"),
])
def test_matches_dummy_vec_env(robot, task, mode):
    """With ``info_keys="all"`` the adapter returns what ``DummyVecEnv`` of single envs
    returns (obs, float32 rewards, dones, per-env infos with ``terminal_observation`` and
    ``TimeLimit.truncated``, ``reset_infos``), bit for bit, across autoresets."""
    n = 4
    kw = dict(task=task, action_mode=mode, max_episode_steps=7, randomize=True, obs_noise=0.01)
    mine = make_sb3_vec_env(env_id(robot), n, seed=5, info_keys="all", **kw)
    ref = DummyVecEnv([lambda: gym.make(env_id(robot), **kw) for _ in range(n)])
    ref.seed(5)
    assert_same(mine.reset(), ref.reset(), "reset")
    assert_same(mine.reset_infos, ref.reset_infos, "reset_infos")
    rng = np.random.default_rng(1)
    dones = 0
    for t in range(24):
        a = np.sign(rng.uniform(-1, 1, (n, *mine.action_space.shape))).astype(np.float32)
        out = mine.step(a)
        assert_same(out, ref.step(a), f"step {t}")
        assert_same(mine.reset_infos, ref.reset_infos, f"reset_infos {t}")
        dones += int(out[2].sum())
    assert dones >= n * 3


def test_default_infos_monitor_and_normalize():
    n, T = 8, 5
    venv = make_sb3_vec_env("wheelgym/ThreeWheel-v0", n, seed=0, max_episode_steps=T)
    assert isinstance(venv, SB3VecEnv) and venv.num_envs == n
    env = VecNormalize(VecMonitor(venv, info_keywords=("is_success",)), norm_reward=True)
    obs = env.reset()
    assert obs.shape == (n, 13) and obs.dtype == np.float32
    a = np.zeros((n, 6), dtype=np.float32)
    for _t in range(T):
        obs, rew, done, infos = env.step(a)
        assert rew.dtype == np.float32 and done.dtype == np.bool_ and len(infos) == n
        assert all("TimeLimit.truncated" in i for i in infos)
    assert done.all()
    for i in infos:
        assert i["TimeLimit.truncated"] is True and i["is_success"] is False
        ep = i["episode"]
        assert ep["l"] == T and np.isfinite(ep["r"])
        term = i["terminal_observation"]  # normalised by VecNormalize like obs
        assert term.shape == (13,) and np.all(np.isfinite(term))
        assert not np.array_equal(term, obs[0])
    assert env.unwrapped is venv
    assert venv.get_attr("task") == ["goal"] * n
    with pytest.warns(UserWarning, match="render_mode"):
        assert venv.env_method("render", indices=[0, 1]) == [None, None]
    venv.set_attr("max_episode_steps", 9)
    assert venv.venv.max_episode_steps == 9
    with pytest.raises(ValueError, match="indices"):
        venv.set_attr("max_episode_steps", 3, indices=[0])
    assert venv.env_is_wrapped(gym.Wrapper) == [False] * n
    env.close()


def test_adapter_rejects_next_step_and_bad_arguments():
    with pytest.raises(ValueError, match="SAME_STEP"):
        SB3VecEnv(ThreeWheelVectorEnv(num_envs=2))
    with pytest.raises(TypeError, match="WheelVectorEnv"):
        SB3VecEnv(gym.make("wheelgym/ThreeWheel-v0"))
    with pytest.raises(ValueError, match="autoreset_mode"):
        make_sb3_vec_env("wheelgym/ThreeWheel-v0", 2, autoreset_mode="NextStep")
    with pytest.raises(ValueError, match="info_keys"):
        make_sb3_vec_env("wheelgym/ThreeWheel-v0", 2, info_keys="some")
    with pytest.raises(TypeError, match="normalize"):
        make_sb3_vec_env("wheelgym/ThreeWheel-v0", 2, normalize="yes")


def test_render_through_adapter():
    venv = make_sb3_vec_env("wheelgym/SkidSteer-v0", 4, seed=0, render_mode="rgb_array")
    venv.reset()
    img = venv.render()
    assert img.shape == (600, 600, 3) and img.dtype == np.uint8
    venv.close()


class _Episodes(BaseCallback):
    def __init__(self) -> None:
        super().__init__()
        self.returns: list[float] = []

    def _on_step(self) -> bool:
        self.returns += [i["episode"]["r"] for i in self.locals["infos"] if "episode" in i]
        return True


def test_ppo_learns_goal_velocity():
    """PPO on 64 SkidSteer robots (goal, velocity mode) in one process: the mean return of
    the last 64 episodes beats the first 64 by a wide margin after 12k steps (about 3 s)."""
    torch.set_num_threads(1)
    venv = make_sb3_vec_env("wheelgym/SkidSteer-v0", 64, seed=0, monitor=True, task="goal",
                            action_mode="velocity", max_episode_steps=50)
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=256, n_epochs=4, learning_rate=1e-3,
                gamma=0.95, seed=0)
    cb = _Episodes()
    model.learn(12_288, callback=cb)
    first, last = np.mean(cb.returns[:64]), np.mean(cb.returns[-64:])
    assert len(cb.returns) >= 192
    assert last > first + 0.3, (first, last)


def test_sac_runs_on_64_robots():
    """SAC trains on the batch: the replay buffer receives 64 transitions per step, with the
    terminal observations of ended episodes (not the reset ones)."""
    torch.set_num_threads(1)
    venv = make_sb3_vec_env("wheelgym/ThreeWheel-v0", 64, seed=0, task="goal",
                            action_mode="velocity", max_episode_steps=4, normalize=True)
    model = SAC("MlpPolicy", venv, learning_starts=128, batch_size=64, seed=0,
                policy_kwargs={"net_arch": [32, 32]})
    model.learn(640)
    buf = model.replay_buffer
    assert buf.pos == 10 and buf.n_envs == 64
    # steps 4, 8 ended every episode: next_obs there is the (normalised) terminal observation
    assert np.all(buf.timeouts[3]) and not np.any(buf.timeouts[2])
    assert not np.allclose(buf.next_observations[3], buf.observations[4])


def test_info_keys_subset_gives_last_step_values_at_episode_end():
    venv = make_sb3_vec_env("wheelgym/ThreeWheel-v0", 3, seed=0, info_keys=("energy", "pose"),
                            max_episode_steps=3)
    venv.reset()
    a = np.full((3, 6), 0.3, dtype=np.float32)
    energies = []
    for _ in range(3):
        _, _, done, infos = venv.step(a)
        assert all(set(i) >= {"energy", "pose", "TimeLimit.truncated"} for i in infos)
        energies.append(infos[0]["energy"])
    assert done.all() and "terminal_observation" in infos[0]
    assert 0.0 < energies[0] < energies[1] < energies[2]  # the ending step's, not the reset's
    assert venv.reset_infos[0]["energy"] == 0.0 and "params" in venv.reset_infos[0]
