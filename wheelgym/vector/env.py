"""Native batched Gymnasium vector environments: N robots in one :class:`WheelCore`.

:class:`WheelVectorEnv` steps all N sub-environments with the same compiled model, controller,
task and reward kernels as :class:`~wheelgym.envs.wheel_env.WheelEnv` (which is the core at
N = 1), so sub-environment ``i`` is bit for bit the single environment: reset with seed
``s + i`` and fed the same actions it returns the same observations, rewards, terminations,
truncations and infos (``tests/vector``).

Semantics (Gymnasium 1.x):

autoreset
    ``metadata["autoreset_mode"]``; default ``AutoresetMode.NEXT_STEP`` (Gymnasium's default:
    the step after an episode ends resets that sub-env, ignores its action and returns reward 0
    and ``terminated = truncated = False``). ``SAME_STEP`` resets within the ending step and puts
    ``final_obs`` and ``final_info`` in ``info`` (the SB3 adapter uses it); ``DISABLED`` leaves
    resets to ``reset(options={"reset_mask": mask})``.
time limit
    ``max_episode_steps`` (the id's 500 through ``gym.make_vec``) counted per sub-env; reaching
    it sets ``truncated`` (as ``TimeLimit`` does, also when ``terminated``). ``None``: no limit.
seeding
    ``reset(seed=s)`` seeds sub-env i with ``s + i``; ``seed=[s_0, s_1, ...]`` one each;
    ``None`` keeps each sub-env's generator (a fresh random one the first time). Autoresets
    continue the generator, as a single environment's ``reset()`` does.
info
    Gymnasium's vector format: each key of the single env's info as an array with leading axis
    N plus a bool mask ``_key``; nested dicts (``reward_terms``, and reset's ``params`` and
    ``task``) nest the same way. Step keys cover every sub-env; reset-only keys are masked to
    the sub-envs that reset. The same values ``SyncVectorEnv`` of single envs would build;
    each step's arrays are new (keep or change them freely), the float entries column views of
    one copy of the core's buffers (not C-contiguous: ``np.ascontiguousarray`` if needed).
    Two keywords give clients that want the same flat keys at every reset and step (TorchRL's
    info reader) such an info: ``reward_terms="flat"`` puts each term at the top level as
    ``reward_<term>`` (``"none"`` leaves them out; default ``"nested"``), ``reset_info=False``
    leaves out the reset-only ``params`` and ``task``.
actions
    ``(N, action_dim)`` real numbers; entries outside [-1, 1] are clipped; a wrong shape or a
    non-finite entry (in a sub-env that steps) raises ``ValueError``, a dtype other than float
    or int (strings, complex, bool) ``TypeError``. A sub-env that terminated is reset on the
    next step (``NEXT_STEP``) instead of stepping, so no terminal bonus is paid twice.
render
    ``render_mode="rgb_array"``: ``render()`` returns sub-env 0's frame ``(600, 600, 3)`` uint8,
    or a grid of the first ``render_envs`` sub-envs.

The keyword arguments are those of the single environment (see :class:`wheelgym.envs.WheelEnv`)
plus ``num_envs``, ``max_episode_steps``, ``autoreset_mode``, ``render_envs``,
``reward_terms`` and ``reset_info``. ``gym.make_vec`` passes them to the native env as plain
keywords (Gymnasium refuses ``vector_kwargs`` for a ``vector_entry_point``; with
``vectorization_mode="sync"`` or ``"async"`` its ``vector_kwargs`` go to ``SyncVectorEnv``).
Clients (TorchRL, skrl, Tianshou, RLlib): ``docs/topics/clients.md``.
"""

from __future__ import annotations

import inspect
import math
import sys
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from gymnasium import logger, spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from wheelgym.envs.config import EnvConfig, check_bool, signature_with
from wheelgym.envs.core import DEFAULT_HORIZON, WheelCore
from wheelgym.envs.wheel_env import (
    goal_free_columns,
    goal_space,
    observation_names,
    relabel_observation,
)
from wheelgym.vector._kernels import k_info_copy, k_step_ends, k_zero_rows

__all__ = [
    "WheelVectorEnv",
    "info_row",
    "adapter_base",
    "REWARD_TERMS",
    "ThreeWheelVectorEnv",
    "SkidSteerVectorEnv",
    "CasterAGVVectorEnv",
    "DiffDriveVectorEnv",
    "UnicycleVectorEnv",
    "BicycleVectorEnv",
    "AckermannVectorEnv",
]

_MODES = {m.value: m for m in AutoresetMode}
#: ``reward_terms`` choices: the terms as a nested dict, at the top level, or left out.
REWARD_TERMS = ("nested", "flat", "none")


def _autoreset_mode(value: Any) -> AutoresetMode:
    if isinstance(value, AutoresetMode):
        return value
    if isinstance(value, str) and value in _MODES:
        return _MODES[value]
    raise ValueError(
        f"autoreset_mode must be one of {list(AutoresetMode)} (or their values "
        f"{list(_MODES)}), got {value!r}"
    )


def info_row(info: dict[str, Any], i: int, skip: Sequence[str] = ()) -> dict[str, Any]:
    """Row ``i`` of a Gymnasium vector info as the single environment's info dict (keys whose
    ``_key`` mask is False in row ``i`` and keys in ``skip`` left out; numbers as NumPy
    scalars, flags as Python bools, vectors as copies)."""
    out: dict[str, Any] = {}
    for k, v in info.items():
        if k.startswith("_") or k in skip:
            continue
        mask = info.get("_" + k)
        if mask is not None and not mask[i]:
            continue
        if isinstance(v, dict):
            out[k] = info_row(v, i)
        elif v.dtype == object:
            out[k] = v[i]
        elif v.dtype == np.bool_ and v.ndim == 1:
            out[k] = bool(v[i])
        elif v.ndim == 1:
            out[k] = v[i]
        else:
            out[k] = v[i].copy()
    return out


def adapter_base(venv: Any, mode: AutoresetMode, client: str, info_keys: Sequence[str] | str
                 ) -> tuple[WheelVectorEnv, tuple[str, ...] | str]:
    """The checks every client adapter over the native vector env makes (``vector/sb3.py``,
    ``vector/tianshou.py``): the unwrapped :class:`WheelVectorEnv` of ``venv``, which must run
    the autoreset ``mode`` the ``client`` expects, and ``info_keys`` as ``"all"`` or a tuple."""
    base = getattr(venv, "unwrapped", venv)
    if not isinstance(base, WheelVectorEnv):
        raise TypeError(f"venv must be a wheelgym WheelVectorEnv, got {type(venv).__name__}")
    got = venv.metadata.get("autoreset_mode")
    if got is not mode:
        raise ValueError(f"{client}: make the env with autoreset_mode=AutoresetMode."
                         f"{mode.name} (got {got!r})")
    if isinstance(info_keys, str):
        if info_keys != "all":
            raise ValueError(f"info_keys must be 'all' or a tuple of info keys, "
                             f"got {info_keys!r}")
        return base, info_keys
    return base, tuple(info_keys)


def _masked(arr: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``arr`` with rows outside ``mask`` (a bool mask or row indices) zeroed (Gymnasium fills
    absent entries with 0)."""
    out = np.zeros_like(arr)
    out[mask] = arr[mask]
    return out


class WheelVectorEnv(VectorEnv):
    """N sub-environments of one robot and task stepped as one batch (module docstring).

    Args:
        num_envs: number of sub-environments N.
        max_episode_steps: per-sub-env time limit in control steps, or ``None``.
        autoreset_mode: an :class:`~gymnasium.vector.AutoresetMode` (or its value string).
        render_envs: how many sub-envs (the first ones) ``render()`` draws, tiled in a grid.
        reward_terms: ``"nested"`` (``info["reward_terms"]``, a dict with its ``_`` masks, as
            ``SyncVectorEnv`` builds it), ``"flat"`` (``info["reward_<term>"]`` at the top
            level) or ``"none"`` (left out).
        reset_info: ``False`` leaves the reset-only keys ``params`` and ``task`` out of the
            reset and step infos (every info then has the same keys).
        robot: robot name; set by the per-robot subclasses (``ThreeWheelVectorEnv``...).
        **kwargs: the single env's keywords (:class:`~wheelgym.envs.config.EnvConfig`: task,
            action_mode, params, ctrl_dt, sim_dt, randomize, obs_noise, reward_weights,
            range_backend, horizon; shared by all N) and ``render_mode`` (``None`` or
            ``"rgb_array"``).
    """

    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": ["rgb_array"],
        "render_fps": 20,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }
    robot: ClassVar[str] = ""

    def __init__(
        self,
        num_envs: int = 1,
        *,
        max_episode_steps: int | None = DEFAULT_HORIZON,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_envs: int = 1,
        reward_terms: str = "nested",
        reset_info: bool = True,
        robot: str | None = None,
        **kwargs: Any,
    ) -> None:
        robot = self.robot if robot is None else robot
        if not robot:
            raise ValueError("robot must be given (or use a per-robot class such as "
                             "ThreeWheelVectorEnv)")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) \
                or num_envs < 1:
            raise ValueError(f"num_envs must be a positive int, got {num_envs!r}")
        if max_episode_steps is not None and (
                isinstance(max_episode_steps, bool)
                or not isinstance(max_episode_steps, (int, np.integer)) or max_episode_steps < 1):
            raise ValueError(f"max_episode_steps must be None or a positive int, "
                             f"got {max_episode_steps!r}")
        config = EnvConfig.from_kwargs(type(self).__name__, robot, kwargs,
                                       tuple(self.metadata["render_modes"]))
        if isinstance(render_envs, bool) or not isinstance(render_envs, (int, np.integer)) \
                or not 1 <= render_envs <= num_envs:
            raise ValueError(f"render_envs must be an int in [1, num_envs={num_envs}], "
                             f"got {render_envs!r}")
        mode = _autoreset_mode(autoreset_mode)
        if not isinstance(reward_terms, str) or reward_terms not in REWARD_TERMS:
            raise ValueError(f"reward_terms must be one of {list(REWARD_TERMS)}, "
                             f"got {reward_terms!r}")
        reset_info = check_bool("reset_info", reset_info)
        #: The validated keyword arguments shared by the N sub-envs.
        self.config = config
        self.core = c = WheelCore(config, int(num_envs))
        self.num_envs = N = int(num_envs)
        self.task = config.task
        self.action_mode = c.action_mode
        self.dt = c.dt
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.autoreset_mode = mode
        self.render_mode = config.render_mode
        self.render_envs = int(render_envs)
        #: How the step info holds the reward terms (``REWARD_TERMS``).
        self.reward_terms = reward_terms
        #: Whether the infos carry the reset-only ``params`` and ``task``.
        self.reset_info = reset_info
        self._client_checked = False
        self.metadata = {**self.metadata, "autoreset_mode": mode,
                         "render_fps": int(round(1.0 / c.dt))}
        # the single environment's spaces, batched
        self.single_action_space = spaces.Box(-1.0, 1.0, (c.action_dim,), np.float32)
        self.single_observation_space = spaces.Box(c.obs_low, c.obs_high, dtype=np.float32)
        #: ``goal_conditioned``: Dict observations and ``compute_reward`` (the single env's
        #: "Goal-conditioned" section), batched.
        self.goal_conditioned = config.goal_conditioned
        #: ``goal_free_observation``: the observation columns kept (else None: all).
        self._columns = goal_free_columns(c) if config.goal_free_observation else None
        if self.goal_conditioned:
            self.single_observation_space = goal_space(c, self.single_observation_space,
                                                       self._columns)
        #: The single observation's entry names in order (the single env's
        #: ``observation_names``).
        self.observation_names: tuple[str, ...] = observation_names(c, self._columns)
        self._prev_ag: np.ndarray | None = None
        self.action_space = batch_space(self.single_action_space, N)
        self.observation_space = batch_space(self.single_observation_space, N)
        self._init_buffers(c, N)

    def _init_buffers(self, c: WheelCore, N: int) -> None:
        """The constructor's last part: where the step's info comes from in the core's
        blocks, the episode counters and flags, and the step's scratch arrays."""
        self._names = c.task.names
        self._flat_names = tuple(f"reward_{n}" for n in self._names)
        self._tidx = np.array([int(k) for k in c.task.term_index], dtype=np.int64)
        # the INFO_KEYS table on this core: the float entries' columns of the core's block B,
        # the flags' columns of F (and which are reported negated)
        self._bslices, flags = c.info_columns()
        # k_info_copy copies the flags as (F[a], F[b], not F[c])
        if tuple(neg for _, _, neg in flags) != (False, False, True):
            raise AssertionError("INFO_KEYS' flags must be two plain flags then a negated one "
                                 "(vector/_kernels.k_info_copy)")
        self._fnames = tuple(n for n, _, _ in flags)
        self._fcols = tuple(col for _, col, _ in flags)
        self._nkeys = len(self._bslices) + len(c.info_core) + len(flags) + 1  # + reward_terms
        self._has_goal = hasattr(c.task, "goal")
        self._has_kind = hasattr(c.task, "kind")
        self._rngs: list[np.random.Generator | None] = [None] * N
        self._elapsed = np.zeros(N, dtype=np.int64)
        self._max_steps = -1 if self.max_episode_steps is None else self.max_episode_steps
        self._started = np.zeros(N, dtype=np.bool_)
        self._ready = False  # every sub-env has been reset once
        self._autoreset = np.zeros(N, dtype=np.bool_)  # NEXT_STEP: rows to reset next step
        self._done = np.zeros(N, dtype=np.bool_)  # DISABLED: rows ended, not yet reset
        # scratch of the step: actions with the autoreset rows zeroed, the done rows (swapped
        # with _autoreset), the indices of the rows to reset
        self._abuf = np.zeros((N, c.action_dim))
        self._done_buf = np.zeros(N, dtype=np.bool_)
        self._idx_buf = np.zeros(N, dtype=np.int64)
        self._no_rows = np.zeros(0, dtype=np.int64)
        self._renderers: list[Any] | None = None

    # ------------------------------------------------------------------ seeding and reset
    def _seed_list(self, seed: int | Sequence[int | None] | None) -> list[int | None]:
        N = self.num_envs
        if seed is None:
            return [None] * N
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(N)]
        if isinstance(seed, Sequence) and not isinstance(seed, str):
            if len(seed) != N:
                raise ValueError(f"seed as a list must have num_envs={N} entries, got {len(seed)}")
            return list(seed)
        raise TypeError(f"seed must be None, an int or a list of num_envs ints, got {seed!r}")

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs (all, or those in ``options["reset_mask"]``).

        The other ``options`` are the single env's (its "Reset Options" table) and apply to
        the sub-envs reset: one value for all, or an array (a list for ``reference`` and
        ``layout_seed``) with a leading axis of ``num_envs`` (entry i for sub-env i; the
        entries of the others are ignored). Unknown keys raise ``ValueError``.

        Returns:
            ``obs (N, obs_dim) float32`` and the batched reset info.
        """
        if not self._client_checked:
            self._check_client()
        N = self.num_envs
        seeds = self._seed_list(seed)
        options = dict(options) if options else {}
        valid = ["reset_mask", *self.core.task.option_keys]
        unknown = [k for k in options if k not in valid]
        if unknown:
            raise ValueError(f"unknown reset option(s) {unknown} for task {self.task!r}; "
                             f"valid options: {valid}")
        mask = options.pop("reset_mask", None)
        if mask is None:
            mask = np.ones(N, dtype=np.bool_)
        else:
            mask = np.asarray(mask)
            if mask.shape != (N,) or mask.dtype != np.bool_:
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({N},), "
                                 f"got {mask.dtype} {mask.shape}")
            if not mask.any():
                raise ValueError("options['reset_mask'] must select at least one sub-env")
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            super().reset(seed=int(seed))
        rows = np.flatnonzero(mask)
        for i in rows:
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
            elif self._rngs[i] is None:
                self._rngs[i] = seeding.np_random()[0]
        self._reset_rows(rows, options or None)
        self._autoreset[rows] = False
        if self.goal_conditioned:
            self._prev_ag = self.core.task.achieved_goal()
        info = self._info(mask, rows)
        if not mask.all():
            info = self._mask_info(info, mask)
        return self._obs(), info

    def _check_client(self) -> None:
        """Warn once, at the first ``reset()``, when a client that expects same-step autoreset
        drives this env with ``NEXT_STEP``: skrl's Gymnasium wrapper (which ``wrap_env`` picks
        for this class) would learn from the autoreset steps' transitions."""
        self._client_checked = True
        if self.autoreset_mode is not AutoresetMode.NEXT_STEP:
            return
        frame = sys._getframe(2)
        for _ in range(8):  # the caller, through a few wrappers
            if frame is None:
                return
            if frame.f_globals.get("__name__", "").startswith("skrl."):
                logger.warn(
                    "skrl resets a wheelgym vector env with autoreset_mode=NEXT_STEP: skrl "
                    "expects same-step autoreset and would learn from the reset transitions; "
                    "make the env with autoreset_mode='SameStep' (docs/topics/clients.md)")
                return
            frame = frame.f_back

    # ------------------------------------------------------------------ goal-conditioned
    def _obs(self) -> np.ndarray | dict[str, np.ndarray]:
        """A copy of the batch's observation (a dict of them when ``goal_conditioned``)."""
        obs = self.core.obs
        if not self.goal_conditioned:
            return obs.copy()
        task = self.core.task
        obs = obs.copy() if self._columns is None else obs[:, self._columns]
        return {"observation": obs, "achieved_goal": task.achieved_goal().astype(np.float32),
                "desired_goal": task.desired_goal().astype(np.float32)}

    @property
    def reward_weights(self) -> dict[str, float]:
        """The weight of each reward term now, shared by all sub-envs (a copy)."""
        return dict(self.core.task.weights)

    def set_reward_weights(self, weights: dict[str, float]) -> None:
        """Change the named reward terms' weights of every sub-env from the next step on (the
        single env's :meth:`~wheelgym.envs.WheelEnv.set_reward_weights`)."""
        self.core.task.set_weights(weights)

    def _goal_task(self) -> Any:
        if not self.goal_conditioned:
            raise RuntimeError("compute_reward needs goal_conditioned=True")
        return self.core.task

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray,
                       info: Any) -> np.ndarray:
        """The step reward for ``desired_goal``, batched over leading axes (the single env's
        :meth:`~wheelgym.envs.WheelEnv.compute_reward`; ``info``: this env's batched info, or
        a list/array of single step infos)."""
        return self._goal_task().compute_reward(achieved_goal, desired_goal, info)

    def compute_terminated(self, achieved_goal: np.ndarray, desired_goal: np.ndarray,
                           info: Any) -> np.ndarray:
        """Success for ``desired_goal`` or a goal-independent end, batched."""
        return self._goal_task().compute_terminated(achieved_goal, desired_goal, info)

    def relabel_observation(self, observation: np.ndarray, achieved_goal: np.ndarray,
                            desired_goal: np.ndarray) -> np.ndarray:
        """The ``observation`` key with its goal entries recomputed for ``desired_goal``,
        batched (the single env's :meth:`~wheelgym.envs.WheelEnv.relabel_observation`)."""
        self._goal_task()
        return relabel_observation(self.core, self._columns, observation, achieved_goal,
                                   desired_goal)

    def compute_truncated(self, achieved_goal: np.ndarray, desired_goal: np.ndarray,
                          info: Any) -> np.ndarray:
        """All False, of the goals' batch shape."""
        self._goal_task()
        return np.zeros(np.shape(achieved_goal)[:-1], dtype=np.bool_)

    def _reset_rows(self, rows: np.ndarray, options: dict | None = None) -> None:
        self.core.reset(rows, self._rngs, options)
        self._elapsed[rows] = 0
        if not self._ready:
            self._started[rows] = True
            self._ready = np.count_nonzero(self._started) == self.num_envs
        if self.autoreset_mode is AutoresetMode.DISABLED:
            self._done[rows] = False
        if self._renderers is not None:
            for i, r in enumerate(self._renderers):
                if self._started[i] and i in rows:
                    r.reset()

    def __getstate__(self) -> dict[str, Any]:
        """``copy.deepcopy``/``pickle`` copy every sub-env's episode exactly; renderers are
        left out (rebuilt on demand)."""
        state = self.__dict__.copy()
        state["_renderers"] = None
        return state

    # ------------------------------------------------------------------ step
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray, dict[str, Any]]:
        """Step every sub-env with its row of ``actions`` ``(N, action_dim)``.

        Returns:
            ``obs (N, obs_dim) float32``, ``rewards (N,) float64``, ``terminations (N,) bool``,
            ``truncations (N,) bool`` and the batched info (module docstring).
        """
        c = self.core
        N = self.num_envs
        if not self._ready:
            raise RuntimeError("call reset() (on every sub-env) before step()")
        a = actions
        if type(a) is not np.ndarray or a.dtype != np.float64:  # (float64 arrays: fast)
            a = np.asarray(actions)
            if a.dtype.kind not in "fiu":
                raise TypeError(f"actions must be an array of real numbers (float or int), "
                                f"got dtype {a.dtype}")
            a = a.astype(np.float64, copy=False)
        if a.shape != c.A.shape:
            raise ValueError(f"actions must have shape {c.A.shape}, got {np.shape(actions)}")
        mode = self.autoreset_mode
        if mode is AutoresetMode.DISABLED and np.count_nonzero(self._done):
            raise RuntimeError(
                f"sub-envs {np.flatnonzero(self._done).tolist()} ended; with autoreset_mode "
                "DISABLED reset them with reset(options={'reset_mask': mask}) before step()")
        # NEXT_STEP: the rows that ended last step reset now instead of stepping (their
        # actions are ignored, so they may be anything)
        any_rr = mode is AutoresetMode.NEXT_STEP and np.count_nonzero(self._autoreset) > 0
        rr = self._autoreset
        active = None
        if any_rr:
            k_zero_rows(a, rr, self._abuf)
            a = self._abuf
            if c.step_draws:
                active = ~rr
        if self.goal_conditioned:
            self._prev_ag = c.task.achieved_goal()
        _, reward, term, _ = c.step(a, active)
        # time limits, the autoreset rows' zeros, the done rows and the rows to reset now,
        # in one pass (each step's arrays are new)
        R = np.empty(N)
        TT = np.empty((2, N), dtype=np.bool_)
        done = self._done_buf
        n_reset = k_step_ends(reward, term, self._elapsed, self._max_steps, rr, any_rr, R, TT,
                              done, self._idx_buf)
        term = TT[0]
        trunc = TT[1]
        if any_rr:
            rows = self._idx_buf[:n_reset].copy()
            self._reset_rows(rows)
            info = self._info(None, rows)
        elif mode is AutoresetMode.SAME_STEP and n_reset:
            rows = self._idx_buf[:n_reset].copy()
            ended = done.copy()
            step_info = self._info(None, None)
            final_obs = np.full(N, None, dtype=object)
            last = self._obs()
            for i in rows:
                final_obs[i] = ({k: v[i] for k, v in last.items()} if self.goal_conditioned
                                else last[i])
            final = {"final_obs": final_obs, "_final_obs": ended,
                     "final_info": self._mask_info(step_info, ended),
                     "_final_info": ended.copy()}
            self._reset_rows(rows)
            info = self._info(None, rows)
            info.update(final)
        else:
            info = self._info(None, None)
        if mode is AutoresetMode.NEXT_STEP:
            self._autoreset, self._done_buf = done, rr
        elif mode is AutoresetMode.DISABLED:
            self._done[:] = done
        return self._obs(), R, term, trunc, info

    # ------------------------------------------------------------------ info
    def _info(self, rows: np.ndarray | None, reset: np.ndarray | None) -> dict[str, Any]:
        """The single env's info keys for the sub-envs in the bool mask ``rows`` (all when
        None), values from the core's buffers (which hold the reset values for rows just
        reset); the sub-envs with indices ``reset`` get zero reward terms and the reset-only
        keys ``params`` and ``task``.

        Few allocations per step: one compiled copy of the core's float block (the float
        entries are column views of it), of the flags and of the reward terms; the masks are
        rows of one array. Each step's arrays are new (the caller may keep or change them) and
        no two entries overlap."""
        c = self.core
        N = self.num_envs
        nt = self._tidx.size
        nk = self._nkeys
        Bo = np.empty_like(c.B)
        Fo = np.empty((3, N), dtype=np.bool_)
        tv = np.empty((nt, N))
        k_info_copy(c.B, c.F, c.terms, self._tidx, self._no_rows if reset is None else reset,
                    *self._fcols, Bo, Fo, tv)
        if rows is None:
            masks = np.ones((nk + nt, N), dtype=np.bool_)
        else:
            masks = np.empty((nk + nt, N), dtype=np.bool_)
            masks[:] = rows
        # one mask row per key (INFO_KEYS order), then one per reward term
        info: dict[str, Any] = {}
        j = 0
        for k, sl in self._bslices:
            info[k] = Bo[:, sl]
            info["_" + k] = masks[j]
            j += 1
        for k, v in c.info_core:  # per-row numbers the core keeps outside its blocks
            info[k] = v.copy()
            info["_" + k] = masks[j]
            j += 1
        for f, k in enumerate(self._fnames):
            info[k] = Fo[f]
            info["_" + k] = masks[j]
            j += 1
        if self.reward_terms == "nested":
            terms: dict[str, Any] = {}
            for q, n in enumerate(self._names):
                terms[n] = tv[q]
                terms["_" + n] = masks[nk + q]
            info["reward_terms"] = terms
            info["_reward_terms"] = masks[j]
        elif self.reward_terms == "flat":
            for q, n in enumerate(self._flat_names):
                info[n] = tv[q]
                info["_" + n] = masks[nk + q]
        if self.goal_conditioned:
            g = c.task.goal_info(self._prev_ag, reset)
            for k, v in g.items():
                info[k] = v
                info["_" + k] = masks[j].copy()
        if reset is not None and reset.size and self.reset_info:
            info.update(self._reset_info(reset))
        return info

    def _reset_info(self, idx: np.ndarray) -> dict[str, Any]:
        """``params`` and ``task`` of the sub-envs with indices ``idx`` (just reset)."""
        c = self.core
        N = self.num_envs
        params: dict[str, Any] = {}
        if c.randomize:
            for i in idx:
                for k, v in c.drawn[i].items():
                    if k not in params:
                        params[k] = np.zeros(N)
                        params["_" + k] = np.zeros(N, dtype=np.bool_)
                    params[k][i] = v
                    params["_" + k][i] = True
        task = c.task
        name = np.empty(N, dtype=object)  # None-filled
        name[idx] = c.task_name
        tinfo: dict[str, Any] = {"name": name}
        if self._has_goal:
            tinfo["goal"] = _masked(task.goal, idx)
        if self._has_kind:
            ref = np.empty(N, dtype=object)
            for i in idx:
                ref[i] = task.kind[i]
            tinfo["reference"] = ref
        masks = np.zeros((len(tinfo) + 2, N), dtype=np.bool_)
        masks[:, idx] = True
        for j, k in enumerate(list(tinfo)):
            tinfo["_" + k] = masks[2 + j]
        return {"params": params, "_params": masks[0], "task": tinfo, "_task": masks[1]}

    def _mask_info(self, info: dict[str, Any], mask: np.ndarray) -> dict[str, Any]:
        """``info`` restricted to ``mask`` (entries outside zeroed, masks and-ed)."""
        out: dict[str, Any] = {}
        for k, v in info.items():
            if isinstance(v, dict):
                out[k] = self._mask_info(v, mask)
            elif k.startswith("_"):
                out[k] = v & mask
            elif v.dtype == object:
                out[k] = np.where(mask, v, None)
            else:
                out[k] = _masked(v, mask)
        return out

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        """Sub-env 0's frame, or a grid of the first ``render_envs`` (``rgb_array``)."""
        if self.render_mode is None:
            logger.warn("render() called without a render_mode; pass render_mode='rgb_array' "
                        "to gym.make_vec")
            return None
        if not self._ready:
            raise RuntimeError("call reset() before render()")
        if self._renderers is None:
            from wheelgym.render import Renderer

            self._renderers = [Renderer(self.core, "rgb_array", self.metadata["render_fps"])
                               for _ in range(self.render_envs)]
        frames = [r.render(i) for i, r in enumerate(self._renderers)]
        if len(frames) == 1:
            return frames[0]
        cols = math.ceil(math.sqrt(len(frames)))
        rows = math.ceil(len(frames) / cols)
        h, w, ch = frames[0].shape
        grid = np.full((rows * h, cols * w, ch), 255, dtype=np.uint8)
        for k, f in enumerate(frames):
            r, q = divmod(k, cols)
            grid[r * h:(r + 1) * h, q * w:(q + 1) * w] = f
        return grid

    def close_extras(self, **kwargs: Any) -> None:
        if self._renderers is not None:
            for r in self._renderers:
                r.close()
            self._renderers = None


# The per-robot classes name ``VectorEnv`` among their direct bases (it is already in their MRO
# through WheelVectorEnv): skrl's ``wrap_env(env)`` picks its wrapper from the names of the
# env class's direct bases and knows ``gymnasium.*`` ones only.


class ThreeWheelVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.ThreeWheelEnv` (``gym.make_vec("wheelgym/ThreeWheel-v0",
    num_envs=N)``)."""

    robot = "ThreeWheel"


class SkidSteerVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.SkidSteerEnv`."""

    robot = "SkidSteer"


class CasterAGVVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.CasterAGVEnv`."""

    robot = "CasterAGV"


class DiffDriveVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.DiffDriveEnv`."""

    robot = "DiffDrive"


class UnicycleVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.UnicycleEnv`."""

    robot = "Unicycle"


class BicycleVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.BicycleEnv`."""

    robot = "Bicycle"


class AckermannVectorEnv(WheelVectorEnv, VectorEnv):
    """Batched :class:`~wheelgym.envs.AckermannEnv`."""

    robot = "Ackermann"


WheelVectorEnv.__init__.__signature__ = signature_with(  # type: ignore[attr-defined]
    inspect.Parameter("num_envs", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=1,
                      annotation="int"),
    *(p for n, p in inspect.signature(WheelVectorEnv.__init__).parameters.items()
      if p.kind is inspect.Parameter.KEYWORD_ONLY))
