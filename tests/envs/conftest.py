"""Shared helpers of the environment tests."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np

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


def assert_vector_equals_single_across_autoresets(**kw) -> None:
    """A 3-row SkidSteer goal-torque ``WheelVectorEnv`` (episodes of 6 steps, so rows
    autoreset) and three single envs with the same keywords ``kw`` give the same
    observations and rewards, bit for bit, over 15 seeded steps."""
    from wheelgym.vector import WheelVectorEnv

    kw = dict(task="goal", action_mode="torque", max_episode_steps=6, **kw)
    ve = WheelVectorEnv(3, robot="SkidSteer", **kw)
    single = [gym.make("wheelgym/SkidSteer-v0", **kw) for _ in range(3)]
    vo, _ = ve.reset(seed=[1, 2, 3])
    so = [e.reset(seed=s)[0] for e, s in zip(single, [1, 2, 3], strict=True)]
    assert np.array_equal(vo, np.array(so))
    rng = np.random.default_rng(4)
    for t in range(15):
        A = rng.uniform(-1, 1, (3, 4))
        vo, vr, *_ = ve.step(A)
        for i, e in enumerate(single):
            if t % 7 == 6:  # next-step autoreset: the single env resets from its generator
                o, _ = e.reset()
            else:
                o, r, *_ = e.step(A[i])
                assert vr[i] == r
            assert np.array_equal(vo[i], o), (t, i)
