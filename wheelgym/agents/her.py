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
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3 import HerReplayBuffer
from stable_baselines3.common.type_aliases import DictReplayBufferSamples

__all__ = ["TerminatingHerReplayBuffer"]


class TerminatingHerReplayBuffer(HerReplayBuffer):
    """``HerReplayBuffer`` whose relabelled transitions end where the env says they end
    (module docstring). Arguments: those of ``HerReplayBuffer``; ``copy_info_dict`` must be
    True.

    Raises:
        ValueError: ``copy_info_dict`` is False.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if not self.copy_info_dict:
            raise ValueError("TerminatingHerReplayBuffer needs replay_buffer_kwargs "
                             "copy_info_dict=True (compute_terminated reads the step info)")
        self._goals: np.ndarray | None = None

    def _sample_goals(self, batch_indices: np.ndarray, env_indices: np.ndarray) -> np.ndarray:
        goals = super()._sample_goals(batch_indices, env_indices)
        self._goals = goals  # the raw relabelled goals of the batch being built
        return goals

    def _get_virtual_samples(self, batch_indices: np.ndarray, env_indices: np.ndarray,
                             env: Any = None) -> DictReplayBufferSamples:
        data = super()._get_virtual_samples(batch_indices, env_indices, env)
        assert self._goals is not None and self.env is not None
        achieved = self.next_observations["achieved_goal"][batch_indices, env_indices]
        infos = self.infos[batch_indices, env_indices]  # read only: no copy
        ended = self.env.env_method("compute_terminated", achieved, self._goals, infos,
                                    indices=[0])[0]
        self._goals = None
        dones = self.to_torch(np.asarray(ended, dtype=np.float32).reshape(-1, 1))
        return data._replace(dones=dones)
