"""Re-export of :mod:`wheelgym.registration` (kept for ``wheelgym.envs.registration.env_id``)."""

from wheelgym.registration import (
    DEFAULT_HORIZON,
    ENV_CLASSES,
    available_robots,
    env_id,
    register_envs,
)

__all__ = ["register_envs", "env_id", "available_robots", "ENV_CLASSES", "DEFAULT_HORIZON"]
