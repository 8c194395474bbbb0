"""Gymnasium registration of every available robot; light enough for ``import wheelgym``.

A robot is registered when its model's source file exists (checked without importing it, so
``import wheelgym`` does not load numba or the models); the environment class, the model and
its compiled kernels load at the first ``gym.make``. The native vector environments
(:mod:`wheelgym.vector`) are each id's ``vector_entry_point``.
"""

from __future__ import annotations

import os

import gymnasium as gym

__all__ = ["register_envs", "env_id", "available_robots", "ENV_CLASSES", "DEFAULT_HORIZON",
           "MODEL_FILES"]

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

#: Robot name -> its model's source file (relative to the package), which must exist.
MODEL_FILES = {
    "ThreeWheel": "models/three_wheel.py",
    "SkidSteer": "models/skid_steer.py",
    "CasterAGV": "models/caster_agv.py",
    "DiffDrive": "models/kinematic.py",
    "Unicycle": "models/kinematic.py",
    "Bicycle": "models/kinematic.py",
    "Ackermann": "models/kinematic.py",
}

_ROOT = os.path.dirname(os.path.abspath(__file__))


def env_id(robot: str) -> str:
    """``"wheelgym/<robot>-v0"``."""
    if robot not in ENV_CLASSES:
        raise ValueError(f"unknown robot {robot!r}; valid robots: {list(ENV_CLASSES)}")
    return f"wheelgym/{robot}-v0"


def available_robots() -> list[str]:
    """Robots whose model files exist, in table order."""
    return [r for r in ENV_CLASSES if os.path.exists(os.path.join(_ROOT, MODEL_FILES[r]))]


def _vector_entry_point(robot: str) -> str | None:
    """``wheelgym.vector:<Robot>VectorEnv`` when the vector package exists (not imported)."""
    if not os.path.exists(os.path.join(_ROOT, "vector", "__init__.py")):
        return None
    return f"wheelgym.vector:{ENV_CLASSES[robot].replace('Env', 'VectorEnv')}"


def register_envs() -> None:
    """Register ``wheelgym/<Robot>-v0`` for every available robot (idempotent)."""
    for robot in available_robots():
        eid = env_id(robot)
        if eid in gym.registry:
            continue
        gym.register(
            id=eid,
            entry_point=f"wheelgym.envs:{ENV_CLASSES[robot]}",
            vector_entry_point=_vector_entry_point(robot),
            max_episode_steps=DEFAULT_HORIZON,
        )
