"""Gymnasium registration of every robot; light enough for ``import wheelgym``.

Registration imports neither numba nor the models: the environment class, the model and its
compiled kernels load at the first ``gym.make``. The native vector environments
(:mod:`wheelgym.vector`) are each id's ``vector_entry_point``.
"""

from __future__ import annotations

import warnings

import gymnasium as gym

__all__ = ["register_envs", "env_id", "available_robots", "ENV_CLASSES", "DEFAULT_HORIZON",
           "VERSIONS"]

#: Default episode length (control steps) of every registered id.
DEFAULT_HORIZON = 500

#: Robot name -> env class name in :mod:`wheelgym.envs` (ids are ``wheelgym/<name>-v0``).
ENV_CLASSES = {
    "ThreeWheel": "ThreeWheelEnv",
    "SkidSteer": "SkidSteerEnv",
    "CasterAGV": "CasterAGVEnv",
    "DiffDrive": "DiffDriveEnv",
    "Unicycle": "UnicycleEnv",
    "Bicycle": "BicycleEnv",
    "Ackermann": "AckermannEnv",
}


#: Registered versions: ``-v0`` and ``-v1`` (navigate's v1 reward and observation; goal and
#: track are the same in both; docs/topics/planning.md has the version history).
VERSIONS = (0, 1)


def env_id(robot: str, version: int = 0) -> str:
    """``"wheelgym/<robot>-v<version>"``."""
    if robot not in ENV_CLASSES:
        raise ValueError(f"unknown robot {robot!r}; valid robots: {list(ENV_CLASSES)}")
    if isinstance(version, bool) or version not in VERSIONS:
        raise ValueError(f"version must be one of {list(VERSIONS)}, got {version!r}")
    return f"wheelgym/{robot}-v{version}"


def available_robots() -> list[str]:
    """Every robot, in table order."""
    return list(ENV_CLASSES)


#: Gymnasium's "-v0 is out of date" notice on every ``-v0`` make: -v1 changes navigate only,
#: so for goal and track it would tell users to move for nothing. The navigate task's -v0 says
#: so itself (:class:`wheelgym.tasks.NavigateTask`).
_OUT_OF_DATE = r".*wheelgym/[A-Za-z]+-v0 is out of date"


def register_envs() -> None:
    """Register ``wheelgym/<Robot>-v0`` and ``-v1`` for every robot (idempotent)."""
    warnings.filterwarnings("ignore", message=_OUT_OF_DATE, category=DeprecationWarning)
    for robot, env_class in ENV_CLASSES.items():
        for version in VERSIONS:
            eid = env_id(robot, version)
            if eid in gym.registry:
                continue
            gym.register(
                id=eid,
                entry_point=f"wheelgym.envs:{env_class}",
                vector_entry_point=f"wheelgym.vector:{env_class.replace('Env', 'VectorEnv')}",
                max_episode_steps=DEFAULT_HORIZON,
                kwargs={"version": version} if version else {},
            )
