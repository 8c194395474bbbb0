"""Tianshou adapter: a :class:`WheelVectorEnv` as Tianshou's ``BaseVectorEnv``.

Tianshou's ``Collector`` drives a ``BaseVectorEnv``: ``len(env)`` sub-envs, ``reset(env_id)``
of the sub-envs whose episodes ended, ``step(action, id)`` of the ready ones, infos as an
object array of per-sub-env dicts. :class:`TianshouVectorEnv` answers that protocol from one
native batch (N robots stepped by one compiled call, no worker per env)::

    from wheelgym.vector.tianshou import make_tianshou_vec_env
    train_envs = make_tianshou_vec_env("wheelgym/SkidSteer-v0", num_envs=16, seed=0,
                                       task="goal", action_mode="velocity")
    collector = tianshou.data.Collector(algorithm, train_envs, buffer)

Semantics:

autoreset
    none: the batch is made with ``autoreset_mode=DISABLED`` and the ``Collector`` resets the
    sub-envs that ended (``reset(env_id=...)``), so a truncated step returns its true last
    observation.
``step(action, id)`` with a subset of the sub-envs
    The batch steps all its robots together. Sub-envs outside ``id`` are stepped with a zero
    action, their results dropped, and they are *stale* until reset: stepping a stale sub-env
    raises ``RuntimeError``. (Tianshou steps subsets only while collecting ``n_episode``
    episodes, when the left-out sub-envs have finished theirs, and resets every sub-env after
    that collection.) A stale sub-env whose discarded step ended its episode is reset before
    the next step, from its own generator.
seeding
    as ``DummyVectorEnv`` of single envs: ``seed(s)`` resets sub-env i with seed ``s + i``
    (``seed([s_0, ...])``: ``s_i``) and later resets continue its generator;
    ``reset(seed=s)`` passes ``s`` to each sub-env reset. With the same seeds and actions the
    adapter returns what ``DummyVectorEnv`` of single envs returns, bit for bit
    (``tests/clients/test_tianshou.py``).
info
    ``np.ndarray`` of dicts, one per requested sub-env: the single environment's info
    (:func:`~wheelgym.vector.env.info_row`), step infos with ``env_id`` too. Building N dicts
    a step costs more than the batch's step: ``info_keys=("is_success", ...)`` copies just
    those keys (``()``: none but ``env_id``), ``"all"`` (default) the whole info.
attributes
    ``action_space`` / ``observation_space`` (and the other keys Tianshou forwards) answer per
    sub-env from the batch: the single env's spaces, one per sub-env.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from tianshou.env import BaseVectorEnv

from wheelgym.vector.env import WheelVectorEnv, adapter_base, info_row

__all__ = ["TianshouVectorEnv", "make_tianshou_vec_env"]

#: Attributes answered per sub-env from the batch's single-env counterpart.
_SINGLE = {"action_space": "single_action_space", "observation_space": "single_observation_space"}


class TianshouVectorEnv(BaseVectorEnv):
    """Tianshou ``BaseVectorEnv`` over a :class:`WheelVectorEnv` made with
    ``autoreset_mode=DISABLED`` (module docstring).

    Args:
        venv: the batched environment (``gym.make_vec(..., vectorization_mode=
            "vector_entry_point", autoreset_mode="Disabled")``).
        info_keys: ``"all"`` (default: each row the single env's whole info), or a tuple of
            the info keys to copy into every row (``()``: none).
    """

    def __init__(self, venv: WheelVectorEnv,
                 info_keys: Sequence[str] | str = "all") -> None:  # (no workers: not super())
        base, info_keys = adapter_base(venv, AutoresetMode.DISABLED, "Tianshou resets the "
                                       "sub-envs itself", info_keys)
        N = venv.num_envs
        self.venv = venv
        self.info_keys = info_keys
        self._base = base
        # BaseVectorEnv's bookkeeping (synchronous: every sub-env ready)
        self._env_fns: list[Any] = []
        self.workers: list[Any] = []
        self.worker_class = type(None)
        self.env_num = N
        self.wait_num = N
        self.timeout = None
        self.is_async = False
        self.waiting_conn: list[Any] = []
        self.waiting_id: list[int] = []
        self.ready_id = list(range(N))
        self.is_closed = False
        self._started = False
        self._ended = np.zeros(N, dtype=np.bool_)  # the last step ended it, not yet reset
        self._stale = np.zeros(N, dtype=np.bool_)  # left out of a step, not yet reset
        self._zeros = np.zeros((N, *venv.single_action_space.shape))

    # ------------------------------------------------------------------ attributes
    def get_env_attr(self, key: str, id: int | list[int] | np.ndarray | None = None
                     ) -> list[Any]:
        """``key`` of each sub-env in ``id`` (all: ``None``), answered by the batch (the
        spaces: its ``single_*`` spaces)."""
        self._assert_is_not_closed()
        value = getattr(self._base, _SINGLE.get(key, key))
        return [value for _ in self._ids(id)]

    def set_env_attr(self, key: str, value: Any,
                     id: int | list[int] | np.ndarray | None = None) -> None:
        """Set ``key`` on the batch; the sub-envs share their attributes, so ``id`` must be
        ``None`` or every sub-env."""
        self._assert_is_not_closed()
        if sorted(int(i) for i in self._ids(id)) != list(range(self.env_num)):
            raise ValueError("the sub-envs share their attributes: set_env_attr applies to all "
                             "of them (id=None)")
        setattr(self._base, key, value)

    def _ids(self, id: int | Sequence[int] | np.ndarray | None) -> np.ndarray:
        if id is None:
            return np.arange(self.env_num)
        ids = np.atleast_1d(np.asarray(id))
        if ids.ndim != 1 or ids.dtype.kind not in "iu" or ids.size == 0 \
                or ids.min() < 0 or ids.max() >= self.env_num \
                or np.unique(ids).size != ids.size:
            raise ValueError(f"id must be None or distinct sub-env indices in "
                             f"[0, {self.env_num}), got {id!r}")
        return ids

    # ------------------------------------------------------------------ reset and step
    def seed(self, seed: int | list[int] | None = None) -> list[list[int | None]]:
        """Reset sub-env i with seed ``seed + i`` (or ``seed[i]``), as ``DummyVectorEnv``'s
        workers do; returns the seeds."""
        self._assert_is_not_closed()
        if seed is None:
            seeds: list[int | None] = [None] * self.env_num
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(self.env_num)]
        else:
            seeds = list(seed)
            if len(seeds) != self.env_num:
                raise ValueError(f"seed as a list must have {self.env_num} entries, "
                                 f"got {len(seeds)}")
        self._reset_rows(np.arange(self.env_num), seeds)
        return [[s] for s in seeds]  # one list per worker, as DummyVectorEnv returns

    def _obs_rows(self, obs: Any, ids: np.ndarray) -> np.ndarray:
        if isinstance(obs, dict):  # goal_conditioned: one dict per sub-env
            out = np.empty(ids.size, dtype=object)
            for k, i in enumerate(ids):
                out[k] = {key: v[i] for key, v in obs.items()}
            return out
        return obs[ids]

    def _infos(self, info: dict[str, Any], ids: np.ndarray, env_id: bool) -> np.ndarray:
        if self.info_keys == ():
            out = np.empty(ids.size, dtype=object)
            out[:] = [{"env_id": int(i)} if env_id else {} for i in ids]
            return out
        if self.info_keys != "all":
            keys = [k for k in self.info_keys if k in info]
            info = {**{k: info[k] for k in keys}, **{"_" + k: info["_" + k] for k in keys}}
        out = np.empty(ids.size, dtype=object)
        for k, i in enumerate(ids):
            row = info_row(info, int(i))
            if env_id:  # (step infos only, as BaseVectorEnv.step adds it)
                row["env_id"] = int(i)
            out[k] = row
        return out

    def reset(self, env_id: int | list[int] | np.ndarray | None = None,
              **kwargs: Any) -> tuple[np.ndarray, np.ndarray]:
        """Reset the sub-envs ``env_id`` (all: ``None``); ``kwargs``: ``seed`` and
        ``options`` (the single env's reset options, applied to those sub-envs)."""
        self._assert_is_not_closed()
        ids = self._ids(env_id)
        unknown = sorted(set(kwargs) - {"seed", "options"})
        if unknown:
            raise TypeError(f"unknown reset argument(s) {unknown}; valid: ['seed', 'options']")
        if not self._started and ids.size != self.env_num:
            raise RuntimeError("reset every sub-env (env_id=None) before resetting a subset")
        seed = kwargs.get("seed")
        if seed is not None and (isinstance(seed, bool)
                                 or not isinstance(seed, (int, np.integer))):
            raise TypeError(f"seed must be None or an int (passed to each sub-env reset, as "
                            f"DummyVectorEnv does; seed(...) seeds them one by one), got {seed!r}")
        obs, info = self._reset_rows(ids, [seed] * self.env_num, kwargs.get("options"))
        return self._obs_rows(obs, ids), self._infos(info, ids, False)

    def _reset_rows(self, ids: np.ndarray, seeds: list[int | None] | None = None,
                    options: dict | None = None) -> tuple[Any, dict]:
        opts = dict(options) if options else {}
        if ids.size != self.env_num:
            mask = np.zeros(self.env_num, dtype=np.bool_)
            mask[ids] = True
            opts["reset_mask"] = mask
        obs, info = self.venv.reset(seed=seeds or [None] * self.env_num, options=opts or None)
        self._started = True
        self._ended[ids] = False
        self._stale[ids] = False
        return obs, info

    def step(self, action: np.ndarray | Any | None,
             id: int | list[int] | np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Step the sub-envs ``id`` (all: ``None``) with ``action`` (one row per sub-env in
        ``id``); returns their ``obs``, ``rew``, ``terminated``, ``truncated`` and infos."""
        self._assert_is_not_closed()
        if action is None:
            raise ValueError("action must not be None (this env is synchronous)")
        if not self._started:
            raise RuntimeError("call reset() before step()")
        N = self.env_num
        ids = self._ids(id)
        a = np.asarray(action.detach().cpu().numpy() if hasattr(action, "detach") else action)
        if a.shape[:1] != (ids.size,):
            raise ValueError(f"action must have one row per sub-env in id ({ids.size}), "
                             f"got shape {a.shape}")
        every = ids.size == N  # (distinct indices: all of them)
        if every and (self._stale.any() or self._ended.any()) or not every and (
                self._stale[ids].any() or self._ended[ids].any()):
            stale = ids[self._stale[ids]]
            if stale.size:
                raise RuntimeError(
                    f"sub-envs {stale.tolist()} were left out of an earlier step (their robots "
                    "moved on); reset them (reset(env_id=...)) before stepping them")
            raise RuntimeError(f"sub-envs {ids[self._ended[ids]].tolist()} ended; reset them "
                               "before step()")
        if every and (id is None or np.array_equal(ids, np.arange(N))):
            out_ids, A, rows = None, a, slice(None)
        else:
            out_ids = np.setdiff1d(np.arange(N), ids)
            parked = out_ids[self._ended[out_ids]]
            if parked.size:  # left out and ended: reset (their results are dropped anyway)
                self._reset_rows(parked)
            A = self._zeros.copy()
            A[ids] = a
            rows = ids
        obs, rew, term, trunc, info = self.venv.step(A)
        np.logical_or(term, trunc, out=self._ended)
        if out_ids is not None:
            self._stale[out_ids] = True
        return (self._obs_rows(obs, ids) if out_ids is not None or isinstance(obs, dict)
                else obs, rew[rows], term[rows], trunc[rows], self._infos(info, ids, True))

    def render(self, **kwargs: Any) -> list[Any]:
        """The batch's frame (sub-env 0, or its grid of ``render_envs``), in a list."""
        self._assert_is_not_closed()
        return [self.venv.render()]

    def close(self) -> None:
        self._assert_is_not_closed()
        self.venv.close()
        self.is_closed = True


def make_tianshou_vec_env(env_id: str, num_envs: int = 16, seed: int | None = None, *,
                          info_keys: Sequence[str] | str = "all",
                          **env_kwargs: Any) -> TianshouVectorEnv:
    """``num_envs`` robots of ``env_id`` as one Tianshou ``BaseVectorEnv``.

    Args:
        env_id: a registered wheelgym id, e.g. ``"wheelgym/ThreeWheel-v0"``.
        num_envs: number of sub-environments.
        seed: ``seed(seed)``: sub-env i is reset with ``seed + i`` (``None``: random).
        info_keys: see :class:`TianshouVectorEnv`.
        **env_kwargs: the environment's keyword arguments (``task``, ``action_mode``,
            ``max_episode_steps``...; ``autoreset_mode`` is set here).
    """
    if "autoreset_mode" in env_kwargs:
        raise ValueError("make_tianshou_vec_env sets autoreset_mode (DISABLED: the Collector "
                         "resets the sub-envs)")
    venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.DISABLED, **env_kwargs)
    env = TianshouVectorEnv(venv, info_keys=info_keys)
    if seed is not None:
        env.seed(seed)
    return env
