"""Gymnasium registration of every available robot (``register_envs`` runs on import)."""

from __future__ import annotations

import importlib.util

import gymnasium as gym

from wheelgym.envs.core import DEFAULT_HORIZON
from wheelgym.envs.robots import available_robots

__all__ = ["register_envs", "env_id", "ENV_CLASSES"]

#: Robot name -> (id name, env class name in wheelgym.envs).
ENV_CLASSES = {
    "ThreeWheel": ("ThreeWheel", "ThreeWheelEnv"),
    "SkidSteer": ("SkidSteer", "SkidSteerEnv"),
    "CasterAGV": ("CasterAGV", "CasterAGVEnv"),
    "DiffDrive": ("DiffDrive", "DiffDriveEnv"),
    "Unicycle": ("Unicycle", "UnicycleEnv"),
    "Bicycle": ("Bicycle", "BicycleEnv"),
    "Ackermann": ("Ackermann", "AckermannEnv"),
}


def env_id(robot: str) -> str:
    return f"wheelgym/{ENV_CLASSES[robot][0]}-v0"


def _vector_entry_point(robot: str) -> str | None:
    """Hook for the native vector environments (``wheelgym.vector``): when that package
    provides ``make_vector_env(robot, num_envs, **kwargs)``, ``gym.make_vec(...,
    vectorization_mode="vector_entry_point")`` uses it."""
    if importlib.util.find_spec("wheelgym.vector") is None:
        return None
    try:
        mod = importlib.import_module("wheelgym.vector")
    except ImportError:
        return None
    attr = f"{ENV_CLASSES[robot][1].replace('Env', 'VectorEnv')}"
    return f"wheelgym.vector:{attr}" if hasattr(mod, attr) else None


def register_envs() -> None:
    """Register ``wheelgym/<Robot>-v0`` for every robot whose model exists (idempotent)."""
    for robot in available_robots():
        eid = env_id(robot)
        if eid in gym.registry:
            continue
        gym.register(
            id=eid,
            entry_point=f"wheelgym.envs:{ENV_CLASSES[robot][1]}",
            vector_entry_point=_vector_entry_point(robot),
            max_episode_steps=DEFAULT_HORIZON,
        )
