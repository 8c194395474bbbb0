"""Hindsight relabelling for tasks whose success ends the episode.

SB3's ``HerReplayBuffer`` relabels a transition's desired goal and recomputes its reward with
the env's ``compute_reward``, but keeps the transition's stored ``done``. That suits tasks that
never end on success (Gymnasium-Robotics' Fetch tasks); on wheelgym's goal and navigate tasks
success terminates, so a relabelled transition that reaches its new goal stays non-terminal
(the critic bootstraps past it and collects the success bonus again on every later step near
the goal: about ``10 / (1 - gamma)`` instead of 10), and a transition that ended on the
episode's own goal stays terminal for a goal it did not reach.

:class:`TerminatingHerReplayBuffer` sets the ``done`` of each relabelled transition to the
env's ``compute_terminated(next achieved goal, new goal, info)``: success within the
tolerances, or an end that does not depend on the goal (overspeed, numerical failure,
collision); a time-limit truncation is never terminal. Real transitions keep their ``done``.
Named in a config as ``replay_buffer_class: TerminatingHerReplayBuffer`` (with
``copy_info_dict: true``, which ``compute_terminated`` needs as ``compute_reward`` does).

It builds the relabelled batch itself, for wheelgym's envs: the step infos' keys that the
env's ``compute_reward`` and ``compute_terminated`` read (``tasks.HER_INFO_KEYS``) are also
stored as arrays when a transition is added, and a batch indexes them and passes them to both,
where SB3's buffer deep-copies every stored info dict of the batch first (a quarter of a 64x64
SAC+HER training's time here); the rewards are the same bits.

``relabel_observation=True`` (a ``replay_buffer_kwargs`` key) also rewrites the goal's entries
of each relabelled transition's ``observation`` (the goal in the body frame: ``goal_x_b``,
``goal_y_b``, ``cos_dyaw``, ``sin_dyaw``) with the env's ``relabel_observation``, so the policy
sees the relabelled goal as the plain env's observation shows its goal; SB3's buffer relabels
``desired_goal`` only, which is why its users need ``goal_free_observation=True``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3 import HerReplayBuffer
from stable_baselines3.common.type_aliases import DictReplayBufferSamples
from stable_baselines3.common.vec_env import VecNormalize

from wheelgym.tasks.tasks import HER_INFO_KEYS, her_info_arrays

__all__ = ["TerminatingHerReplayBuffer"]


class TerminatingHerReplayBuffer(HerReplayBuffer):
    """``HerReplayBuffer`` whose relabelled transitions end where the env says they end
    (module docstring). Arguments: those of ``HerReplayBuffer``; ``copy_info_dict`` must be
    True; ``relabel_observation``: also recompute the observation's goal entries for the
    relabelled goal (the env must keep them: ``goal_free_observation=False``).

    Raises:
        ValueError: ``copy_info_dict`` is False, or ``relabel_observation`` with an env whose
            observation cannot be relabelled (the env's message says why).
    """

    def __init__(self, *args: Any, relabel_observation: bool = False, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if not self.copy_info_dict:
            raise ValueError("TerminatingHerReplayBuffer needs replay_buffer_kwargs "
                             "copy_info_dict=True (compute_terminated reads the step info)")
        self.relabel_observation = bool(relabel_observation)
        #: ``HER_INFO_KEYS`` of each stored transition, ``(buffer_size, n_envs, ...)`` arrays
        #: allocated at the first ``add`` with the dtypes of its infos' values
        self.her_info: dict[str, np.ndarray] | None = None
        if self.relabel_observation and self.env is not None:  # the env's error, now
            o = np.zeros((1, *self.obs_shape["observation"]), dtype=np.float32)
            g = np.zeros((1, *self.obs_shape["desired_goal"]), dtype=np.float32)
            self.env.env_method("relabel_observation", o, g, g, indices=[0])

    def add(self, obs: dict[str, np.ndarray], next_obs: dict[str, np.ndarray],
            action: np.ndarray, reward: np.ndarray, done: np.ndarray,
            infos: list[dict[str, Any]]) -> None:
        """SB3's ``add``, and the infos' ``HER_INFO_KEYS`` into :attr:`her_info` at the same
        position (an info without them raises the ``ValueError`` that says what to set)."""
        pos, dim = self.pos, int(np.prod(self.obs_shape["desired_goal"]))
        vals = her_info_arrays(infos, (self.n_envs,), dim)
        if self.her_info is None:
            self.her_info = {k: np.zeros((self.buffer_size, *v.shape), dtype=v.dtype)
                             for k, v in zip(HER_INFO_KEYS, vals, strict=True)}
        for k, v in zip(HER_INFO_KEYS, vals, strict=True):
            self.her_info[k][pos] = v
        super().add(obs, next_obs, action, reward, done, infos)

    def _get_virtual_samples(self, batch_indices: np.ndarray, env_indices: np.ndarray,
                             env: VecNormalize | None = None) -> DictReplayBufferSamples:
        """The transitions at ``(batch_indices, env_indices)`` with relabelled goals, the env's
        rewards and ends for them (``env``: the ``VecNormalize`` whose statistics apply)."""
        assert self.env is not None
        obs = {k: v[batch_indices, env_indices] for k, v in self.observations.items()}
        nxt = {k: v[batch_indices, env_indices] for k, v in self.next_observations.items()}
        goals = self._sample_goals(batch_indices, env_indices)
        obs["desired_goal"] = nxt["desired_goal"] = goals
        assert self.her_info is not None  # (a batch is drawn from added transitions)
        info = {k: v[batch_indices, env_indices] for k, v in self.her_info.items()}
        # r_t depends on s_{t+1}: the next achieved goal against the relabelled goal
        achieved = nxt["achieved_goal"]
        reward = self.env.env_method("compute_reward", achieved, goals, info, indices=[0])[0]
        ended = self.env.env_method("compute_terminated", achieved, goals, info, indices=[0])[0]
        reward = np.asarray(reward).astype(np.float32).reshape(-1, 1)
        if self.relabel_observation:  # each observation seen from its own pose
            for o in (obs, nxt):
                o["observation"] = self.env.env_method(
                    "relabel_observation", o["observation"], o["achieved_goal"], goals,
                    indices=[0])[0]
        obs, nxt = self._normalize_obs(obs, env), self._normalize_obs(nxt, env)
        return DictReplayBufferSamples(
            observations={k: self.to_torch(v) for k, v in obs.items()},
            actions=self.to_torch(self.actions[batch_indices, env_indices]),
            next_observations={k: self.to_torch(v) for k, v in nxt.items()},
            dones=self.to_torch(np.asarray(ended, dtype=np.float32).reshape(-1, 1)),
            rewards=self.to_torch(self._normalize_reward(reward, env)),
        )
