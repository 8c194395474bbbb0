"""TerminatingHerReplayBuffer: relabelled transitions end where ``compute_terminated`` says.

Checked against the env, not the buffer's own arithmetic: every virtual transition of a sampled
batch is rebuilt from the raw buffer (next achieved goal, the relabelled goal as the sample
shows it, the stored info) and asked of the single env's ``compute_terminated``; a transition
whose relabelled goal is its own next achieved goal must be terminal (success), which SB3's
``HerReplayBuffer`` leaves as stored."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import gymnasium as gym  # noqa: E402
import torch as th  # noqa: E402
from stable_baselines3 import SAC, HerReplayBuffer  # noqa: E402

from tests.vector.conftest import env_id  # noqa: E402
from wheelgym.agents.her import TerminatingHerReplayBuffer  # noqa: E402
from wheelgym.vector import make_sb3_vec_env  # noqa: E402

KW = {"task": "goal", "action_mode": "velocity", "goal_conditioned": True,
      "goal_free_observation": True, "max_episode_steps": 40}


def _filled(buffer_class: type) -> SAC:
    venv = make_sb3_vec_env(env_id("ThreeWheel"), num_envs=2, seed=0, **KW)
    model = SAC("MultiInputPolicy", venv, learning_starts=400, batch_size=64, seed=0,
                policy_kwargs={"net_arch": [8]}, replay_buffer_class=buffer_class,
                replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future",
                                      "copy_info_dict": True})
    model.learn(400)  # collection only (learning starts at 400)
    return model


def _virtual_dones(model: SAC, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The virtual half of one batch: the dones the buffer gives, and those the single env's
    compute_terminated gives for the same transitions and relabelled goals."""
    buf = model.replay_buffer
    n = 256
    valid = np.flatnonzero(buf.ep_length > 0)
    rng = np.random.default_rng(seed)  # the transitions; SB3 draws the goals (seeded by SAC)
    b, e = np.unravel_index(rng.choice(valid, n), buf.ep_length.shape)
    data = buf._get_virtual_samples(b, e)
    goals = data.observations["desired_goal"].numpy().astype(np.float64)
    achieved = buf.next_observations["achieved_goal"][b, e]
    env = gym.make(env_id("ThreeWheel"), **KW).unwrapped
    want = np.array([env.compute_terminated(achieved[k], goals[k], buf.infos[b[k], e[k]])
                     for k in range(n)], dtype=np.float32)
    return data.dones.numpy().reshape(-1), want


def test_relabelled_transitions_end_where_the_env_says():
    model = _filled(TerminatingHerReplayBuffer)
    got, want = _virtual_dones(model, seed=1)
    np.testing.assert_array_equal(got, want)
    assert 0 < want.sum() < len(want)  # some relabelled goals reached, most not
    # and training runs on it
    model.learn(200, reset_num_timesteps=False)
    assert model.num_timesteps >= 600


def test_the_batch_is_sb3s_but_the_ends():
    """The same goals drawn (SB3 draws them from NumPy's global generator): observations,
    actions and rewards equal SB3's own relabelled batch bit for bit; the ends differ where a
    relabelled goal was reached."""
    model = _filled(TerminatingHerReplayBuffer)
    buf = model.replay_buffer
    valid = np.flatnonzero(buf.ep_length > 0)
    b, e = np.unravel_index(np.random.default_rng(2).choice(valid, 256), buf.ep_length.shape)
    state = np.random.get_state()  # noqa: NPY002  (SB3's goal draws use the global generator)
    ours = buf._get_virtual_samples(b, e)
    np.random.set_state(state)  # noqa: NPY002
    sb3 = HerReplayBuffer._get_virtual_samples(buf, b, e)
    for key in ours.observations:
        assert th.equal(ours.observations[key], sb3.observations[key]), key
        assert th.equal(ours.next_observations[key], sb3.next_observations[key]), key
    assert th.equal(ours.actions, sb3.actions) and th.equal(ours.rewards, sb3.rewards)
    assert ours.dones.sum() > 0 and not th.equal(ours.dones, sb3.dones)


def test_sb3s_buffer_keeps_the_stored_dones():
    """Why the class exists: the same batch from SB3's buffer misses those ends."""
    got, want = _virtual_dones(_filled(HerReplayBuffer), seed=1)
    assert want.sum() > 0 and not np.array_equal(got, want)


def test_needs_copy_info_dict():
    venv = make_sb3_vec_env(env_id("ThreeWheel"), num_envs=2, seed=0, **KW)
    with pytest.raises(ValueError, match="copy_info_dict=True"):
        SAC("MultiInputPolicy", venv, replay_buffer_class=TerminatingHerReplayBuffer,
            replay_buffer_kwargs={"copy_info_dict": False})


def test_trains_on_a_single_env_too():
    """SB3 wraps a single env in its DummyVecEnv, whose env_method reaches compute_terminated
    through Gymnasium's wrappers."""
    env = gym.make(env_id("ThreeWheel"), **KW)
    model = SAC("MultiInputPolicy", env, learning_starts=100, batch_size=32, seed=0,
                policy_kwargs={"net_arch": [8]}, replay_buffer_class=TerminatingHerReplayBuffer,
                replay_buffer_kwargs={"copy_info_dict": True})
    model.learn(200)
    assert model.num_timesteps == 200


def _goal_seen(obs: dict[str, np.ndarray]) -> np.ndarray:
    """The goal (x, y, cos yaw, sin yaw) that the observation's body-frame entries show, put
    back into the world frame from the achieved goal (pose): the inverse rotation."""
    a, o = obs["achieved_goal"].astype(np.float64), obs["observation"].astype(np.float64)
    ca, sa = a[:, 2], a[:, 3]
    xb, yb, cd, sd = o[:, 0], o[:, 1], o[:, 2], o[:, 3]
    return np.stack([a[:, 0] + ca * xb - sa * yb, a[:, 1] + sa * xb + ca * yb,
                     ca * cd - sa * sd, sa * cd + ca * sd], axis=1)


@pytest.mark.parametrize("relabel", [True, False])
def test_relabel_observation_shows_the_relabelled_goal(relabel):
    """With relabel_observation the goal in the body frame of every relabelled observation and
    next observation is the relabelled desired goal (an inverse rotation, not the buffer's
    formula); without it (SB3's behaviour) it is still the episode's goal."""
    kw = {**KW, "goal_free_observation": False}
    venv = make_sb3_vec_env(env_id("ThreeWheel"), num_envs=2, seed=0, **kw)
    model = SAC("MultiInputPolicy", venv, learning_starts=400, batch_size=64, seed=0,
                policy_kwargs={"net_arch": [8]}, replay_buffer_class=TerminatingHerReplayBuffer,
                replay_buffer_kwargs={"n_sampled_goal": 4, "copy_info_dict": True,
                                      "relabel_observation": relabel})
    model.learn(400)
    buf = model.replay_buffer
    b, e = np.unravel_index(np.random.default_rng(4).choice(np.flatnonzero(buf.ep_length > 0),
                                                            256), buf.ep_length.shape)
    data = buf._get_virtual_samples(b, e)
    for side in (data.observations, data.next_observations):
        o = {k: v.numpy() for k, v in side.items()}
        err = np.abs(_goal_seen(o) - o["desired_goal"]).max(axis=1)
        if relabel:
            assert err.max() < 1e-4
        else:  # the stored observation shows the episode's goal, not the relabelled one
            assert (err > 1e-2).mean() > 0.9
    model.learn(200, reset_num_timesteps=False)  # and it trains


def test_relabel_observation_refuses_a_goal_free_observation():
    venv = make_sb3_vec_env(env_id("ThreeWheel"), num_envs=2, seed=0, **KW)
    with pytest.raises(ValueError, match="goal_free_observation=False"):
        SAC("MultiInputPolicy", venv, replay_buffer_class=TerminatingHerReplayBuffer,
            replay_buffer_kwargs={"copy_info_dict": True, "relabel_observation": True})
