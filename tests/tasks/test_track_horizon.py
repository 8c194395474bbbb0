"""The track reference never runs out (any time limit), and ``horizon`` bounds the memory."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym
from wheelgym.envs import DiffDriveEnv, WheelCore
from wheelgym.tasks import Circle, FigureEight
from wheelgym.tasks.tasks import TrackTask


def _placed(ref, k, dt: float) -> np.ndarray:
    return ref.evaluate(np.asarray(k) * dt)[0]


@pytest.mark.parametrize("n", [1, 4, 16])  # the single env's table, a small batch, windows
def test_reference_moves_past_the_default_horizon(n):
    # the core never ends an episode: the reference is read for 1200 steps (the time limit
    # belongs to the wrappers, and any limit, None included, must see it move on)
    ref = FigureEight(size=1.5, period=20.0)
    core = WheelCore("DiffDrive", n, task="track")
    core.reset(None, [np.random.default_rng(i) for i in range(n)], {"reference": ref})
    a = np.zeros((n, 2))
    seen = []
    for k in range(1, 1201):
        core.step(a)
        if k in (500, 501, 531, 532, 533, 600, 999, 1200):
            pose = core.task.reference_at()[0]
            np.testing.assert_allclose(pose, np.broadcast_to(_placed(ref, k, core.dt),
                                                             pose.shape), atol=1e-9)
            ahead = core.task.reference_ahead(31)[:, :3]
            np.testing.assert_allclose(ahead, np.broadcast_to(_placed(ref, k + 31, core.dt),
                                                              ahead.shape), atol=1e-9)
            # the observation's previews (0.5, 1.0, 1.5 s ahead) move on as well
            seen.append(core.obs[0, 7:13].copy())
    assert not np.allclose(seen[-2], seen[-1])
    assert core.task.ref.shape[1] == (532 if n <= TrackTask.whole_up_to else 64)


def test_gym_make_long_time_limit_follows_the_moving_reference():
    env = gym.make("wheelgym/DiffDrive-v0", task="track", action_mode="VehicleSpeedHeadingRate",
                   max_episode_steps=1000)
    ref = Circle(radius=1.2, speed=0.3)
    obs, _ = env.reset(seed=3, options={"reference": ref})
    policy = wheelgym.baseline(env)
    core = env.unwrapped.core
    for k in range(1, 1001):
        act, _ = policy.predict(obs, deterministic=True)
        obs, _, term, trunc, info = env.step(act)
        assert not term, f"lost at step {k}"
        if k == 900:
            np.testing.assert_allclose(core.task.reference_at()[0][0], _placed(ref, k, core.dt),
                                       atol=1e-9)
    assert trunc
    assert info["tracking_error"] < 0.1  # still on the (moving) reference at step 1000


def test_huge_horizon_is_bounded():
    env = DiffDriveEnv(task="track", horizon=20_000_000)
    task = env.core.task
    assert task.nw == TrackTask.max_table + task.ahead + 1
    assert task.ref.nbytes + task.ref_rate.nbytes < 2**20  # not gigabytes
    ref = DiffDriveEnv(task="track")  # the same values as the default table
    oa, _ = env.reset(seed=5)
    ob, _ = ref.reset(seed=5)
    assert np.array_equal(oa, ob)
    a = np.full(2, 0.2, dtype=np.float32)
    for _ in range(20):
        assert np.array_equal(env.step(a)[0], ref.step(a)[0])


def test_long_episodes_single_table_equals_batch_windows():
    n = 10  # windows of 64 steps a row, against the single env's table moved on at 501
    batch = WheelCore("Unicycle", n, task="track")
    singles = [WheelCore("Unicycle", 1, task="track") for _ in range(n)]
    batch.reset(None, [np.random.default_rng(40 + i) for i in range(n)])
    for i, s in enumerate(singles):
        s.reset(None, [np.random.default_rng(40 + i)])
    rng = np.random.default_rng(0)
    for _ in range(700):
        a = rng.uniform(-1, 1, (n, 2))
        obs = batch.step(a)[0]
        for i, s in enumerate(singles):
            assert np.array_equal(s.step(a[i:i + 1])[0][0], obs[i])
