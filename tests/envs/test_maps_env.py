"""navigate on a map from a file (``arena=``): the shipped maps in the single and vector env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import wheelgym
from wheelgym.world import MAPS, load_map


@pytest.mark.parametrize("name", sorted(MAPS))
def test_shipped_map_env_passes_the_checker_and_starts_free(name):
    env = gym.make("wheelgym/ThreeWheel-v0", task="navigate", arena=name)
    check_env(env.unwrapped, skip_render_check=True)
    arena = load_map(name)
    for seed in range(5):
        _, info = env.reset(seed=seed)
        task = env.unwrapped.core.task
        assert np.array_equal(task.segs[0, : task.ns[0]], arena.segments)
        for pose in (info["pose"], task.goal[0]):
            assert arena.is_free(pose[None, :2], env.unwrapped.core.spec.radius)[0]


def test_map_ranges_equal_pymunk_and_vector_equals_single():
    kw = {"task": "navigate", "arena": "warehouse"}
    a = gym.make("wheelgym/SkidSteer-v0", **kw)
    p = gym.make("wheelgym/SkidSteer-v0", range_backend="pymunk", **kw)
    oa, _ = a.reset(seed=3)
    op, _ = p.reset(seed=3)
    np.testing.assert_allclose(oa, op, rtol=0, atol=1e-9)
    venv = gym.make_vec("wheelgym/SkidSteer-v0", num_envs=2, **kw)
    ov, _ = venv.reset(seed=3)
    assert np.array_equal(ov[0], oa)
    pol = wheelgym.baseline(a)
    for _ in range(40):
        act = pol.predict(oa)[0]
        oa, _, ta, _, _ = a.step(act)
        op, _, tp, _, _ = p.step(act)
        np.testing.assert_allclose(oa, op, rtol=0, atol=1e-9)
        if ta:
            break


def test_arena_errors():
    with pytest.raises(ValueError, match="task='navigate'"):
        gym.make("wheelgym/DiffDrive-v0", task="goal", arena="maze")
    with pytest.raises(ValueError, match="unknown map 'nowhere'"):
        gym.make("wheelgym/DiffDrive-v0", task="navigate", arena="nowhere")
    with pytest.raises(TypeError, match="arena"):
        gym.make("wheelgym/DiffDrive-v0", task="navigate", arena=3)
    env = gym.make("wheelgym/DiffDrive-v0", task="navigate", arena="office")
    with pytest.raises(ValueError, match="not free"):
        env.reset(seed=0, options={"start": (-100.0, 0.0, 0.0)})


def test_map_is_drawn():
    env = gym.make("wheelgym/DiffDrive-v0", task="navigate", arena="maze",
                   render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (600, 600, 3)
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 5
