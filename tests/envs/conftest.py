"""Shared helpers of the environment tests."""

from __future__ import annotations

import warnings

import gymnasium as gym

import wheelgym  # noqa: F401
from wheelgym.envs.robots import available_robots, get_spec
from wheelgym.registration import env_id

ROBOTS = available_robots()
DYNAMIC = [r for r in ROBOTS if get_spec(r).n_motor > 0]
TASKS = ("goal", "track", "navigate")


def modes(robot: str) -> tuple[str, ...]:
    return get_spec(robot).action_modes


def combos() -> list[tuple[str, str, str]]:
    return [(r, t, m) for r in ROBOTS for t in TASKS for m in modes(r)]


def make(robot: str, version: int = 0, **kw) -> gym.Env:
    """``gym.make`` of the robot's ``-v<version>`` id. Making a ``-v0`` id, Gymnasium notes
    (a ``DeprecationWarning``) that ``-v1`` exists; the ``-v0`` ids are kept as they were, so
    the helper lets that one notice pass (tests that fail on any warning check the env)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
        return gym.make(env_id(robot, version), **kw)
