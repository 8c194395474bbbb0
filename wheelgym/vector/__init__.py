"""Native batched vector environments (one process, N robots) and the Stable-Baselines3 adapter.

``gym.make_vec("wheelgym/<Robot>-v0", num_envs=N, vectorization_mode="vector_entry_point",
**env_kwargs)`` returns a :class:`WheelVectorEnv`; :func:`make_sb3_vec_env` returns the same
batch as an SB3 ``VecEnv`` (:class:`SB3VecEnv`), :func:`make_tianshou_vec_env` as a Tianshou
``BaseVectorEnv`` (:class:`TianshouVectorEnv`). The adapters import their library (and torch)
only when first used. TorchRL, skrl and RLlib take the native env as it is
(``docs/topics/clients.md``).
"""

from __future__ import annotations

from typing import Any

from wheelgym.vector.env import (
    AckermannVectorEnv,
    BicycleVectorEnv,
    CasterAGVVectorEnv,
    DiffDriveVectorEnv,
    SkidSteerVectorEnv,
    ThreeWheelVectorEnv,
    UnicycleVectorEnv,
    WheelVectorEnv,
)

__all__ = [
    "WheelVectorEnv",
    "ThreeWheelVectorEnv",
    "SkidSteerVectorEnv",
    "CasterAGVVectorEnv",
    "DiffDriveVectorEnv",
    "UnicycleVectorEnv",
    "BicycleVectorEnv",
    "AckermannVectorEnv",
    "SB3VecEnv",
    "make_sb3_vec_env",
    "TianshouVectorEnv",
    "make_tianshou_vec_env",
]

#: Adapters imported on first use (each imports its library): name -> module.
_LAZY = {"SB3VecEnv": "sb3", "make_sb3_vec_env": "sb3",
         "TianshouVectorEnv": "tianshou", "make_tianshou_vec_env": "tianshou"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"wheelgym.vector.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'wheelgym.vector' has no attribute {name!r}")
