"""Shared helpers of the environment tests."""

from __future__ import annotations

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


def make(robot: str, **kw) -> gym.Env:
    return gym.make(env_id(robot), **kw)
