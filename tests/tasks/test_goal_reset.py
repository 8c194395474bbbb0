"""The goal task's start poses and goals: exactly the documented uniform draws."""

from __future__ import annotations

import math

import numpy as np

from wheelgym.envs.core import WheelCore


def test_goal_reset_equals_generator_uniform_draws() -> None:
    """Each reset row consumes six uniforms from its own generator: start x, y in [-1, 1],
    start yaw in [-pi, pi), goal distance in ``goal_dist``, goal direction and goal yaw in
    [-pi, pi). The task's compiled arithmetic must give ``Generator.uniform``'s values, bit
    for bit, and put the goal at that distance and direction from the start."""
    N = 40
    core = WheelCore("DiffDrive", N, task="goal")
    rngs = [np.random.default_rng(100 + i) for i in range(N)]
    rows = np.array([3, 7, 8, 21, 39])
    core.reset(None, rngs)
    poses = core.task.reset_rows(rows, rngs, None)
    d_lo, d_hi = core.task.goal_dist
    for n, i in enumerate(rows):
        g = np.random.default_rng(100 + i)
        g.random(6)  # the full reset above
        x, y = g.uniform(-1.0, 1.0), g.uniform(-1.0, 1.0)
        yaw = g.uniform(-math.pi, math.pi)
        d = g.uniform(d_lo, d_hi)
        a = g.uniform(-math.pi, math.pi)
        gyaw = g.uniform(-math.pi, math.pi)
        assert poses[n].tolist() == [x, y, yaw]
        assert core.task.goal[i].tolist() == [x + d * math.cos(a), y + d * math.sin(a), gyaw]
        assert core.task.prev[i] == d
        assert math.isclose(math.hypot(*(core.task.goal[i, :2] - poses[n, :2])), d,
                            rel_tol=1e-14)
        # the generator moved on by exactly six draws
        assert rngs[i].random() == g.random()
