"""The track task's moving reference windows against the references evaluated directly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym.envs.core import WheelCore
from wheelgym.tasks.tasks import TrackTask


def _direct(task: TrackTask, i: int, step: int) -> np.ndarray:
    """Row i's placed reference pose and twist at ``step``, from its object alone."""
    k = min(step, task.L - 1)
    pose, twist, _ = task.objs[i].evaluate(np.array([task.t0[i] + k * task.core.dt]))
    c, s, ox, oy, th = task.place[i]
    x = c * pose[0, 0] - s * pose[0, 1] + ox
    y = s * pose[0, 0] + c * pose[0, 1] + oy
    return np.array([x, y, pose[0, 2] + th, *twist[0]])


@pytest.mark.parametrize("horizon", [500, 40])
def test_windows_follow_the_reference_past_the_horizon(horizon):
    N = TrackTask.whole_up_to + 3  # a batch: moving windows
    core = WheelCore("DiffDrive", N, task="track", horizon=horizon)
    rngs = [np.random.default_rng(100 + i) for i in range(N)]
    core.reset(None, rngs)
    task = core.task
    assert isinstance(task, TrackTask)
    assert task.ref.shape == (N, min(TrackTask.window, task.span), 6)
    moved = 0
    a = np.zeros((N, core.action_dim))
    for t in range(130):
        if t == 17:  # desynchronise: rows 1 and 3 start again
            core.reset(np.array([1, 3]), rngs)
        kb = task.kbase.copy()
        core.step(a)
        moved += int(np.sum(task.kbase != kb))
        for i in range(N):
            k = int(task.kstep[i])
            pose, twist, _ = (v[i] for v in task.reference_at())
            np.testing.assert_allclose(np.r_[pose, twist], _direct(task, i, k), rtol=0,
                                       atol=1e-12)
            for q in (1, task.ahead):
                np.testing.assert_allclose(task.reference_ahead(q)[i], _direct(task, i, k + q),
                                           rtol=0, atol=1e-12)
            # the observation's preview points (float32) are the reference's, in the body frame
            px, py, yaw = core.pose[i]
            cy, sy = math.cos(yaw), math.sin(yaw)
            for n, q in enumerate(task.preview_steps):
                r = _direct(task, i, k + int(q))
                bx = cy * (r[0] - px) + sy * (r[1] - py)
                by = -sy * (r[0] - px) + cy * (r[1] - py)
                np.testing.assert_allclose(core.obs[i, 7 + 2 * n: 9 + 2 * n], [bx, by],
                                           rtol=0, atol=1e-5)
    # each window moves on every window - ahead steps (a short horizon only makes them short)
    assert moved >= (2 * N if horizon == 500 else N)
    if horizon == 40:  # past the horizon the reference moves on (it never runs out)
        assert np.all(task.kstep > task.span)
        assert not np.any(np.all(task.reference_ahead(task.ahead) == task.reference_ahead(0),
                                 axis=1))


def test_memory_per_row_is_fixed_in_batches():
    n = TrackTask.whole_up_to + 1
    short = WheelCore("DiffDrive", n, task="track", horizon=100).task
    long = WheelCore("DiffDrive", n, task="track", horizon=100_000).task
    assert short.ref.nbytes == long.ref.nbytes == n * TrackTask.window * 6 * 8
    single = WheelCore("DiffDrive", 1, task="track", horizon=100).task
    assert single.ref.shape == (1, single.span, 6)  # the single env: horizon + previews


def test_reference_ahead_rejects_offsets_outside_the_window():
    task = WheelCore("DiffDrive", 1, task="track").task
    task.core.reset(None, [np.random.default_rng(0)])
    with pytest.raises(ValueError, match="ahead"):
        task.reference_ahead(task.ahead + 1)
    with pytest.raises(ValueError, match="ahead"):
        task.reference_ahead(-1)


def test_path_is_the_reference_from_step_zero():
    core = WheelCore("ThreeWheel", 2, task="track")
    core.reset(None, [np.random.default_rng(3), np.random.default_rng(4)])
    task = core.task
    path = task.path(1, stride=7)
    assert path.shape == (len(range(0, task.span, 7)), 2)
    for n, k in enumerate(range(0, task.span, 7)):
        np.testing.assert_allclose(path[n], _direct(task, 1, k)[:2], rtol=0, atol=1e-12)


def _tightest_radius(ref, kind: str) -> float:
    """Smallest radius of curvature ``|v| / |w|`` (m) of ``ref`` over one lap (the quintic
    circle over its moving part), sampled every 1/4000 of it."""
    t = np.linspace(0.0, ref.duration, 4001)
    _, twist, _ = ref.evaluate(t)
    v, w = np.hypot(twist[:, 0], twist[:, 1]), np.abs(twist[:, 2])
    if kind == "quintic_circle":  # it starts and ends at rest (0 / 0)
        keep = v > 1e-3 * v.max()
        v, w = v[keep], w[keep]
    return float(np.min(v / np.maximum(w, 1e-12)))


def _drawn(robot: str, n: int) -> list[tuple[str, float]]:
    core = WheelCore(robot, n, task="track")
    core.reset(None, [np.random.default_rng(s) for s in range(n)])
    return [(core.task.kind[i], _tightest_radius(core.task.objs[i], core.task.kind[i]))
            for i in range(n)]


@pytest.mark.parametrize("robot", ["Bicycle", "Ackermann"])
def test_car_references_stay_within_the_turning_radius(robot):
    """Sampled curvature of every drawn reference (not the ``0.2088 A`` the task scales
    by): no turn tighter than ``min_radius_factor * l / tan(psi_max)`` (0.5 m / tan 30 deg =
    0.866 m), and the tightest eight close to it (scaled up just enough)."""
    r_min = 0.5 / math.tan(math.radians(30.0))
    limit = TrackTask.min_radius_factor * r_min
    drawn = _drawn(robot, 60)
    assert {k for k, _ in drawn} == set(TrackTask.references)
    assert min(r for _, r in drawn) >= limit * (1 - 1e-4)
    eights = [r for k, r in drawn if k == "figure_eight"]
    assert min(eights) < 1.1 * limit


def test_robots_that_turn_in_place_keep_tight_references():
    """DiffDrive's drawn eights turn at 0.21-0.42 m (``0.2088 A``, ``A`` in 1-2 m): unscaled."""
    eights = [r for k, r in _drawn("DiffDrive", 60) if k == "figure_eight"]
    assert eights and 0.2087 <= min(eights) and max(eights) <= 0.4176
    assert min(eights) < 0.25
