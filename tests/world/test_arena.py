"""Arena generation and the two range sensors (pymunk segment queries vs analytic rays)."""

from __future__ import annotations

import math

import numpy as np
import pymunk

from wheelgym.world import Arena, build_space, k_clearance, k_ranges, pymunk_ranges


def _pack(w, arena):
    C = np.zeros((1, arena.max_circles, 3))
    S = np.zeros((1, arena.max_segments, 4))
    C[0, : len(w.circles)] = w.circles
    S[0, : len(w.segments)] = w.segments
    return C, np.array([len(w.circles)]), S, np.array([len(w.segments)])


def test_generation_is_reproducible_and_keeps_start_and_goal_clear():
    arena = Arena()
    for seed in range(10):
        a = arena.generate(np.random.default_rng(seed), 0.4)
        b = arena.generate(np.random.default_rng(seed), 0.4)
        assert np.array_equal(a.circles, b.circles) and np.array_equal(a.segments, b.segments)
        assert math.hypot(*(a.goal[:2] - a.start[:2])) >= arena.min_goal_dist
        C, nc, S, ns = _pack(a, arena)
        for p in (a.start, a.goal):
            out = np.zeros(1)
            k_clearance(p[None], C, nc, S, ns, out)
            assert out[0] > 0.4


def test_analytic_rays_equal_pymunk_segment_queries():
    arena = Arena()
    rng = np.random.default_rng(0)
    worst = 0.0
    for seed in range(8):
        w = arena.generate(np.random.default_rng(seed), 0.4)
        space = build_space(w)
        C, nc, S, ns = _pack(w, arena)
        for _ in range(20):
            pose = np.array([*rng.uniform(-3.8, 3.8, 2), rng.uniform(-math.pi, math.pi)])
            ref = np.zeros(16)
            pymunk_ranges(space, pose, 16, 3.0, ref)
            out = np.zeros((1, 16))
            k_ranges(pose[None], C, nc, S, ns, 3.0, out)
            inside = np.zeros(1)
            k_clearance(pose[None], C, nc, S, ns, inside)
            if inside[0] <= 0.0:  # pymunk reports a start inside a circle differently
                continue
            worst = max(worst, float(np.max(np.abs(out[0] - ref))))
    assert worst < 1e-9


def test_clearance_matches_pymunk_point_query():
    arena = Arena()
    w = arena.generate(np.random.default_rng(3), 0.4)
    space = build_space(w)
    C, nc, S, ns = _pack(w, arena)
    rng = np.random.default_rng(1)
    for _ in range(50):
        p = rng.uniform(-3.9, 3.9, 2)
        out = np.zeros(1)
        k_clearance(np.array([[p[0], p[1], 0.0]]), C, nc, S, ns, out)
        q = space.point_query_nearest((float(p[0]), float(p[1])), 10.0, pymunk.ShapeFilter())
        assert abs(q.distance - out[0]) < 1e-9


def test_navigate_env_with_pymunk_backend_matches_analytic():
    import gymnasium as gym

    import wheelgym  # noqa: F401

    ea = gym.make("wheelgym/SkidSteer-v0", task="navigate")
    ep = gym.make("wheelgym/SkidSteer-v0", task="navigate", range_backend="pymunk")
    oa, _ = ea.reset(seed=4)
    op, _ = ep.reset(seed=4)
    np.testing.assert_allclose(oa, op, atol=1e-5)
    for _ in range(20):
        a = np.array([0.3, 0.3, 0.2, 0.2])
        oa, _, ta, *_ = ea.step(a)
        op, _, tp, *_ = ep.step(a)
        np.testing.assert_allclose(oa, op, atol=1e-5)
        assert ta == tp
        if ta:
            break
