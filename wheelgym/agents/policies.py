"""Policies with the Stable-Baselines3 ``predict`` interface, so one loop scores them all.

``predict(obs, state=None, episode_start=None, deterministic=True) -> (action, state)`` is what
SB3 models, :class:`AgentPolicy`, :class:`RandomPolicy` and ``wheelgym.baseline(env)``
share.
"""

from __future__ import annotations

import copy
import pickle
from pathlib import Path
from typing import Any

import gymnasium as gym

from wheelgym.agents.common import algo_class
from wheelgym.envs.baseline import baseline

__all__ = ["AgentPolicy", "RandomPolicy", "make_baseline", "load_agent"]


class RandomPolicy:
    """Uniform random actions from a copy of the action space, seeded per episode.

    ``reset(seed)`` reseeds it, so the random row of a table replays exactly for a seed.
    """

    name = "random"

    def __init__(self, action_space: gym.spaces.Space, seed: int | None = None) -> None:
        self.action_space = copy.deepcopy(action_space)
        self.action_space.seed(seed)

    def reset(self, seed: int | None = None) -> None:
        self.action_space.seed(seed)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        return self.action_space.sample(), state


class AgentPolicy:
    """A trained SB3 model plus the observation normalisation it was trained with.

    ``obs_norm`` is the run's ``VecNormalize`` (or ``None``); only its frozen observation
    statistics are used (``normalize_obs`` does not update them).
    """

    def __init__(self, model: Any, obs_norm: Any | None = None, name: str = "agent") -> None:
        self.model = model
        self.obs_norm = obs_norm
        self.name = name

    def reset(self, seed: int | None = None) -> None:
        """Stateless (MLP policies); present for the common interface."""

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        if self.obs_norm is not None and self.obs_norm.norm_obs:
            obs = self.obs_norm.normalize_obs(obs)
        return self.model.predict(
            obs, state=state, episode_start=episode_start, deterministic=deterministic
        )


def load_vecnormalize(path: str | Path) -> Any | None:
    """Load saved ``VecNormalize`` statistics (without an attached env), or ``None``."""
    path = Path(path)
    if not path.is_file():
        return None
    try:
        with path.open("rb") as f:
            vn = pickle.load(f)  # noqa: S301 - our own run folder, as SB3's VecNormalize.load does
    except Exception as e:
        raise ValueError(f"{path}: cannot load VecNormalize statistics: "
                         f"{type(e).__name__}: {e}") from None
    vn.training = False
    vn.norm_reward = False
    return vn


def load_agent(model_path: str | Path, algo: str, vecnorm_path: str | Path | None = None,
               device: str = "cpu") -> AgentPolicy:
    """Load ``model.zip`` (and the statistics next to it) as an :class:`AgentPolicy`.

    For acting only: an off-policy model gets SB3's default replay buffer in place of the one
    it trained with (``HerReplayBuffer`` cannot be built without the env), so HER runs load
    as the others do."""
    custom = ({"replay_buffer_class": None, "replay_buffer_kwargs": {}}
              if algo in ("sac", "td3") else None)
    try:
        model = algo_class(algo).load(str(model_path), device=device, custom_objects=custom)
    except Exception as e:
        raise ValueError(f"{model_path}: cannot load the {algo.upper()} model: "
                         f"{type(e).__name__}: {e}") from None
    obs_norm = load_vecnormalize(vecnorm_path) if vecnorm_path is not None else None
    return AgentPolicy(model, obs_norm, name=f"agent ({algo.upper()})")


def make_baseline(env: gym.Env) -> Any:
    """``wheelgym.baseline(env)``: the analytic controller as a policy.

    Raises ``ValueError`` when the env has no baseline (e.g. a non-wheelgym env).
    """
    try:
        policy = baseline(env)
    except (TypeError, ValueError, AttributeError) as e:
        raise ValueError(f"no analytic baseline for {env.spec.id if env.spec else env}: {e}") from e
    if not hasattr(policy, "name"):
        try:
            policy.name = "baseline"
        except AttributeError:
            pass
    return policy
