"""Shared helpers of the environment tests."""

from __future__ import annotations

import gymnasium as gym

import wheelgym  # noqa: F401
from wheelgym.envs.registration import env_id
from wheelgym.envs.robots import available_robots, get_spec

ROBOTS = available_robots()
DYNAMIC = [r for r in ROBOTS if get_spec(r).n_motor > 0]
TASKS = ("goal", "track", "navigate")


def velocity_available() -> bool:
    try:
        from wheelgym.control.controllers import TwistController  # noqa: F401
    except ImportError:
        return False
    return True


def modes(robot: str) -> tuple[str, ...]:
    spec = get_spec(robot)
    if spec.n_motor > 0 and not velocity_available():
        return ("torque",)
    return spec.action_modes


def combos() -> list[tuple[str, str, str]]:
    return [(r, t, m) for r in ROBOTS for t in TASKS for m in modes(r)]


def make(robot: str, **kw) -> gym.Env:
    return gym.make(env_id(robot), **kw)
