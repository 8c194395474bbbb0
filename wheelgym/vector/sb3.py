"""Stable-Baselines3 adapter: a :class:`WheelVectorEnv` presented as an SB3 ``VecEnv``.

PPO, SAC (any SB3 algorithm) then train on N robots stepped as one batch in one process, with
``VecNormalize``, ``VecMonitor`` and SB3's episode statistics::

    from wheelgym.vector import make_sb3_vec_env
    venv = make_sb3_vec_env("wheelgym/SkidSteer-v0", num_envs=64, seed=0, monitor=True,
                            task="goal", action_mode="velocity")
    model = stable_baselines3.PPO("MlpPolicy", venv).learn(100_000)

Per-sub-env ``infos`` follow SB3's ``DummyVecEnv``: every row has ``TimeLimit.truncated``
(truncated and not terminated); a row whose episode ended has ``terminal_observation`` and
``is_success`` of its last step, and its new episode's reset info is in ``reset_infos[i]``. With
``info_keys="all"`` every row carries the single environment's whole info (as ``DummyVecEnv``
of single environments gives it, bit for bit); a tuple of key names copies just those keys into
every row; the default ``()`` keeps only the keys above (cheapest).

With ``goal_conditioned=True`` the observations are dicts (``observation``, ``achieved_goal``,
``desired_goal``), every row's info carries the keys ``compute_reward`` reads
(``tasks.HER_INFO_KEYS``), and ``env_method("compute_reward", achieved, desired, infos,
indices=[0])`` answers through the batched env's vectorised ``compute_reward``, so SB3's
``HerReplayBuffer`` works on it unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvStepReturn

from wheelgym.tasks.tasks import HER_INFO_KEYS
from wheelgym.vector.env import WheelVectorEnv, adapter_base, info_row

__all__ = ["SB3VecEnv", "make_sb3_vec_env"]


_FINAL = ("final_obs", "final_info")


_row = info_row  # row i of a vector info as the single env's info dict


class SB3VecEnv(VecEnv):
    """SB3 ``VecEnv`` over a :class:`WheelVectorEnv` built with ``autoreset_mode=SAME_STEP``.

    Args:
        venv: the batched environment (``gym.make_vec(..., vectorization_mode=
            "vector_entry_point", autoreset_mode=AutoresetMode.SAME_STEP)``).
        info_keys: ``()`` (default), a tuple of info keys to copy into every row's dict, or
            ``"all"`` for the single environment's whole info (module docstring).

    The sub-environments share every attribute: ``get_attr``/``env_method`` answer from the
    batched env for each requested index; ``set_attr`` applies to all of them only.
    """

    def __init__(self, venv: WheelVectorEnv, info_keys: Sequence[str] | str = ()) -> None:
        base, info_keys = adapter_base(venv, AutoresetMode.SAME_STEP, "SB3 expects same-step "
                                       "autoreset", info_keys)
        if not isinstance(info_keys, str) and getattr(base, "goal_conditioned", False):
            info_keys += tuple(k for k in HER_INFO_KEYS if k not in info_keys)  # compute_reward
        self.venv = venv
        self.info_keys = info_keys
        self._actions: np.ndarray | None = None
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)

    # ------------------------------------------------------------------ VecEnv API
    def reset(self) -> np.ndarray:
        seeds = list(self._seeds)
        opts = self._options
        if any(o != opts[0] for o in opts):
            raise ValueError("SB3VecEnv passes one options dict to every sub-env; "
                             "set_options(...) with a single dict")
        obs, info = self.venv.reset(seed=seeds, options=dict(opts[0]) or None)
        self.reset_infos = [_row(info, i, _FINAL) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("call step_async(actions) before step_wait()")
        obs, rew, term, trunc, info = self.venv.step(self._actions)
        self._actions = None
        dones = term | trunc
        tl = trunc & ~term
        keys = self.info_keys
        if keys == "all":
            infos = [_row(info, i, _FINAL) for i in range(self.num_envs)]
        elif keys:
            sub = {k: info[k] for k in keys if k in info}
            sub.update({"_" + k: info["_" + k] for k in keys if k in info})
            infos = [_row(sub, i) for i in range(self.num_envs)]
        else:
            infos = [{} for _ in range(self.num_envs)]
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = bool(tl[i])
        if dones.any():
            final_obs = info["final_obs"]
            final = info["final_info"]
            succ = final["is_success"]
            for i in np.flatnonzero(dones):
                d = infos[i]
                if keys == "all":
                    d.clear()
                    d.update(_row(final, i))
                    d["TimeLimit.truncated"] = bool(tl[i])
                elif keys:
                    for k in keys:
                        if k in final:
                            d[k] = _row({k: final[k], "_" + k: final["_" + k]}, i)[k]
                d["is_success"] = bool(succ[i])
                d["terminal_observation"] = final_obs[i]
                self.reset_infos[i] = _row(info, i, _FINAL)
        return obs, rew.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        return [self.venv.render()]

    def render(self, mode: str | None = None) -> np.ndarray | None:
        """The batched env's frame (sub-env 0 or its grid); ``mode`` must match."""
        if mode is not None and mode != self.render_mode:
            return super().render(mode)
        return self.venv.render()

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        return list(self._get_indices(indices))

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        if sorted(self._indices(indices)) != list(range(self.num_envs)):
            raise ValueError("the sub-envs share their attributes: set_attr applies to all "
                             "indices (indices=None)")
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        idx = self._indices(indices)
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in idx]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper],
                       indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._indices(indices)]


def make_sb3_vec_env(
    env_id: str,
    num_envs: int = 64,
    seed: int | None = None,
    *,
    monitor: bool = False,
    normalize: bool | dict[str, Any] = False,
    info_keys: Sequence[str] | str = (),
    monitor_kwargs: dict[str, Any] | None = None,
    **env_kwargs: Any,
) -> VecEnv:
    """``num_envs`` robots of ``env_id`` as one SB3 ``VecEnv`` (:class:`SB3VecEnv`).

    Args:
        env_id: a registered wheelgym id, e.g. ``"wheelgym/ThreeWheel-v0"``.
        num_envs: number of sub-environments.
        seed: sub-env i is reset with ``seed + i`` at the first ``reset()`` (``None``: random).
        monitor: wrap in ``VecMonitor`` (episode returns, lengths and ``is_success``).
        normalize: wrap in ``VecNormalize`` (``True`` or its keyword arguments).
        info_keys: see :class:`SB3VecEnv`.
        monitor_kwargs: extra ``VecMonitor`` arguments.
        **env_kwargs: the environment's keyword arguments (``task``, ``action_mode``,
            ``max_episode_steps``...).
    """
    if "autoreset_mode" in env_kwargs:
        raise ValueError("make_sb3_vec_env sets autoreset_mode (SAME_STEP, as SB3 expects)")
    venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)
    env: VecEnv = SB3VecEnv(venv, info_keys=info_keys)
    if seed is not None:
        env.seed(seed)
        env.action_space.seed(seed)
    if monitor:
        kw = {"info_keywords": ("is_success",), **(monitor_kwargs or {})}
        env = VecMonitor(env, **kw)
    if normalize:
        if normalize is True:
            env = VecNormalize(env)
        elif isinstance(normalize, dict):
            env = VecNormalize(env, **normalize)
        else:
            raise TypeError(f"normalize must be a bool or a dict of VecNormalize arguments, "
                            f"got {normalize!r}")
    return env
