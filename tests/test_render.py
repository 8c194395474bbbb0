"""Rendering: frame size, the robot is visible, frames change as the robot moves."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401
from wheelgym.render import _BODY, SIZE


@pytest.mark.parametrize("robot,task", [("ThreeWheel", "navigate"), ("SkidSteer", "track"),
                                        ("CasterAGV", "goal"), ("Ackermann", "goal")])
def test_rgb_array_frames(robot, task):
    env = gym.make(f"wheelgym/{robot}-v0", task=task, render_mode="rgb_array")
    env.reset(seed=0)
    f0 = env.render()
    assert f0.shape == (SIZE, SIZE, 3) and f0.dtype == np.uint8
    body = np.all(f0 == np.array(_BODY, dtype=np.uint8), axis=-1)
    assert body.sum() > 100  # the platform is drawn
    for _ in range(10):
        if env.step(np.full(env.action_space.shape, 0.6))[2]:
            break  # terminated (overspeed, lost): the frame of the last state
    f1 = env.render()
    moved = np.all(f1 == np.array(_BODY, dtype=np.uint8), axis=-1)
    assert moved.sum() > 100 and np.any(moved != body)
    env.close()


def test_human_mode_headless():
    env = gym.make("wheelgym/ThreeWheel-v0", render_mode="human")
    env.reset(seed=0)
    assert env.render() is None
    env.step(np.zeros(6))
    env.close()


def test_render_without_mode_warns():
    env = gym.make("wheelgym/ThreeWheel-v0")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.unwrapped.render() is None


def test_record_video(tmp_path):
    pytest.importorskip("moviepy")
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(gym.make("wheelgym/SkidSteer-v0", render_mode="rgb_array"),
                      str(tmp_path / "videos"), episode_trigger=lambda e: True, disable_logger=True)
    env.reset(seed=0)
    for _ in range(10):
        if env.step(np.full(4, 0.5))[2]:
            break
    env.close()
    assert list((tmp_path / "videos").glob("*.mp4"))
