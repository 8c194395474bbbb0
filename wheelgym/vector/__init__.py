"""Native batched vector environments (one process, N robots) and the Stable-Baselines3 adapter.

``gym.make_vec("wheelgym/<Robot>-v0", num_envs=N, vectorization_mode="vector_entry_point",
**env_kwargs)`` returns a :class:`WheelVectorEnv`; :func:`make_sb3_vec_env` returns the same
batch as an SB3 ``VecEnv`` (:class:`SB3VecEnv`). The SB3 pieces import Stable-Baselines3 (and
torch) only when first used.
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
]

_LAZY = {"SB3VecEnv", "make_sb3_vec_env"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from wheelgym.vector import sb3

        return getattr(sb3, name)
    raise AttributeError(f"module 'wheelgym.vector' has no attribute {name!r}")
