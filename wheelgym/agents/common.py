"""Construction shared by training, evaluation, benchmarking and tuning.

The Stable-Baselines3 algorithm class and its keyword arguments from a config
(:func:`algo_class`, :func:`algo_kwargs`, :func:`build_model`), the environments
(:func:`make_single_env` for evaluation, :func:`make_train_env` for training, both after
:func:`ensure_registered`) and the ``VecNormalize`` wrapper (:func:`wrap_normalize`).

Stable-Baselines3 and torch are imported inside the functions that need them.
"""

from __future__ import annotations

import signal
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from wheelgym.agents.config import ACTIVATIONS, TrainConfig

__all__ = [
    "algo_class",
    "algo_kwargs",
    "build_model",
    "ensure_registered",
    "make_single_env",
    "make_train_env",
    "wrap_normalize",
]


def algo_class(algo: str) -> type:
    """The SB3 class for an algorithm name (``ppo``, ``sac``, ``td3``, ``a2c``)."""
    import stable_baselines3 as sb3

    table = {"ppo": sb3.PPO, "sac": sb3.SAC, "td3": sb3.TD3, "a2c": sb3.A2C}
    if algo not in table:
        raise ValueError(f"algo must be one of {sorted(table)}, got {algo!r}")
    return table[algo]


def ensure_registered(env_id: str) -> None:
    """Register wheelgym's ids if needed; ``ValueError`` naming the known ids if ``env_id``
    is still unknown."""
    import wheelgym  # noqa: F401  (registers the ids where the package does so on import)

    register = getattr(wheelgym, "register_envs", None)
    if env_id not in gym.registry and register is not None:
        register()
    if env_id not in gym.registry:
        known = sorted(k for k in gym.registry if k.startswith("wheelgym/"))
        raise ValueError(f"env id {env_id!r} is not registered; wheelgym ids: {known}")


def make_single_env(config: TrainConfig, render_mode: str | None = None) -> gym.Env:
    """``gym.make(config.env_id, **config.env_kwargs)``; a bad keyword becomes ``ValueError``."""
    ensure_registered(config.env_id)
    kwargs = dict(config.env_kwargs)
    if render_mode is not None:
        kwargs["render_mode"] = render_mode
    try:
        return gym.make(config.env_id, **kwargs)
    except TypeError as e:
        raise ValueError(f"{config.source}: env_kwargs {config.env_kwargs}: {e}") from e


def make_train_env(config: TrainConfig, n_envs: int | None = None, seed: int | None = None):
    """The training ``VecEnv``: ``n_envs`` copies with episode statistics (incl. success).

    ``vec_env``: ``dummy`` (SB3 ``DummyVecEnv``), ``subproc`` (``SubprocVecEnv``) or ``native``
    (wheelgym's batched vector env through its SB3 adapter, where available). The envs take
    :attr:`~wheelgym.agents.config.TrainConfig.training_env_kwargs` (``env_kwargs`` with
    ``train_env_kwargs``); ``ValueError`` if those give another observation or action space
    than the task's env (:func:`make_single_env`), on which the agent is evaluated.
    """
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    n = config.n_envs if n_envs is None else n_envs
    seed = config.seed if seed is None else seed
    ensure_registered(config.env_id)
    if config.vec_env == "native":
        try:
            from wheelgym.vector import make_sb3_vec_env
        except ImportError as e:
            raise ValueError(
                f"{config.source}: vec_env 'native' needs wheelgym.vector.make_sb3_vec_env: {e}"
            ) from None
        try:
            venv = make_sb3_vec_env(config.env_id, num_envs=n, seed=seed,
                                    **config.training_env_kwargs)
        except TypeError as e:
            raise ValueError(f"{config.source}: env_kwargs {config.training_env_kwargs}: {e}"
                             ) from e
        venv.action_space.seed(seed)
    else:
        env_id, kwargs = config.env_id, config.training_env_kwargs
        subproc = config.vec_env == "subproc"

        def factory(rank: int) -> Callable[[], gym.Env]:
            def _init() -> gym.Env:
                import wheelgym  # noqa: F401  (subprocess workers register the ids)

                if subproc:  # the worker: Ctrl-C is the main process's to handle (it saves)
                    signal.signal(signal.SIGINT, signal.SIG_IGN)

                env = gym.make(env_id, **kwargs)
                env.action_space.seed(seed + rank)
                return env

            return _init

        cls = SubprocVecEnv if subproc else DummyVecEnv
        try:
            venv = cls([factory(i) for i in range(n)])
        except TypeError as e:
            raise ValueError(f"{config.source}: env_kwargs {kwargs}: {e}") from e
        venv.seed(seed)
    if config.train_env_kwargs:
        _check_same_spaces(config, venv)
    # SB3 logs rollout/success_rate itself from info["is_success"] at episode ends.
    return VecMonitor(venv)


def _check_same_spaces(config: TrainConfig, venv: Any) -> None:
    task = make_single_env(config)
    try:
        for what in ("observation_space", "action_space"):
            if getattr(task, what) != getattr(venv, what):
                venv.close()
                raise ValueError(
                    f"{config.source}: train_env_kwargs {config.train_env_kwargs} change the "
                    f"{what.replace('_', ' ')} ({getattr(venv, what)}) from the task's "
                    f"({getattr(task, what)}): the agent is evaluated on env_kwargs")
    finally:
        task.close()


def wrap_normalize(venv, config: TrainConfig):
    """``venv`` in a ``VecNormalize`` with the config's options, or as is (``normalize`` off)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if config.normalize is None:
        return venv
    kwargs = dict(config.normalize)
    kwargs.setdefault("gamma", config.hyperparams.get("gamma", 0.99))  # as the RL Zoo does
    return VecNormalize(venv, **kwargs)


def _linear(initial: float) -> Callable[[float], float]:
    def schedule(progress_remaining: float) -> float:
        return progress_remaining * initial

    return schedule


def algo_kwargs(config: TrainConfig, n_actions: int | None = None) -> dict[str, Any]:
    """The config's plain hyperparameters turned into SB3 keyword arguments."""
    import torch

    kw = {k: v for k, v in config.hyperparams.items()}
    for key in ("learning_rate", "clip_range", "clip_range_vf"):
        v = kw.get(key)
        if isinstance(v, str):  # "lin_<x>", validated by the loader
            kw[key] = _linear(float(v.split("_", 1)[1]))
    if isinstance(kw.get("replay_buffer_class"), str):  # by name (config.REPLAY_BUFFERS)
        import stable_baselines3 as sb3
        from stable_baselines3.common import buffers

        from wheelgym.agents import her

        name = kw["replay_buffer_class"]
        kw["replay_buffer_class"] = (getattr(her, name, None) or getattr(sb3, name, None)
                                     or getattr(buffers, name))
    if isinstance(kw.get("train_freq"), list):
        kw["train_freq"] = tuple(kw["train_freq"])
    pk = dict(kw.get("policy_kwargs", {}))
    if "activation_fn" in pk:
        pk["activation_fn"] = getattr(torch.nn, ACTIVATIONS[pk["activation_fn"]])
    if pk:
        kw["policy_kwargs"] = pk
    if config.noise is not None:
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

        noise_type, std = config.noise
        cls = NormalActionNoise if noise_type == "normal" else OrnsteinUhlenbeckActionNoise
        assert n_actions is not None
        kw["action_noise"] = cls(mean=np.zeros(n_actions), sigma=std * np.ones(n_actions))
    return kw


def build_model(config: TrainConfig, venv, tensorboard_log: str | None = None, verbose: int = 0):
    """Construct the SB3 algorithm on ``venv``; SB3's own objections become ``ValueError``."""
    cls = algo_class(config.algo)
    n_actions = int(np.prod(venv.action_space.shape)) if venv.action_space.shape else None
    kwargs = algo_kwargs(config, n_actions)
    policy = kwargs.pop("policy")
    if config.mean_bound is not None:  # MlpPolicy with the squashed mean (checked by the loader)
        from wheelgym.agents.bounded_policy import BoundedMeanPolicy

        policy = BoundedMeanPolicy  # policy_kwargs.mean_bound is its keyword argument
    try:
        return cls(
            policy,
            venv,
            seed=config.seed,
            device=config.device,
            tensorboard_log=tensorboard_log,
            verbose=verbose,
            **kwargs,
        )
    except (AssertionError, TypeError, ValueError) as e:
        raise ValueError(f"{config.source}: cannot build {config.algo}: {e}") from e
