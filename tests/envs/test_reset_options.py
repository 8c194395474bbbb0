"""``reset(options=...)``: start, goal, reference and layout options, the same in ``gym.make``
and in each row of ``gym.make_vec``; unknown keys raise."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.envs.conftest import make
from wheelgym.tasks import Circle, Line
from wheelgym.tasks.tasks import NavigateTask

START = np.array([0.3, -0.2, 0.7])
GOAL = np.array([2.0, 1.5, -1.0])


@pytest.mark.parametrize("task", ["goal", "track", "navigate"])
def test_unknown_option_names_the_valid_ones(task):
    env = make("DiffDrive", task=task)
    with pytest.raises(ValueError, match="valid options") as e:
        env.reset(seed=0, options={"strat": START})
    assert "'start'" in str(e.value)
    venv = gym.make_vec("wheelgym/DiffDrive-v0", num_envs=2, task=task)
    with pytest.raises(ValueError, match="reset_mask"):
        venv.reset(seed=0, options={"strat": START})


def test_goal_start_and_goal_options():
    env = make("ThreeWheel", task="goal")
    _, info = env.reset(seed=4, options={"start": START, "goal": GOAL})
    assert np.array_equal(info["pose"], START)
    assert np.array_equal(info["task"]["goal"], GOAL)
    assert info["tracking_error"] == pytest.approx(np.hypot(*(GOAL - START)[:2]), rel=1e-12)
    # progress is measured from the given start: standing still earns no progress
    _, _, _, _, info = env.step(np.zeros(6, dtype=np.float32))
    assert abs(info["reward_terms"]["progress"]) < 1e-6
    # the generator advanced as without options: the next reset matches a plain sequence
    plain = make("ThreeWheel", task="goal")
    plain.reset(seed=4)
    plain.step(np.zeros(6, dtype=np.float32))
    assert np.array_equal(env.reset()[0], plain.reset()[0])


def test_goal_option_only_keeps_drawn_start():
    a, b = make("SkidSteer", task="goal"), make("SkidSteer", task="goal")
    _, ia = a.reset(seed=9)
    _, ib = b.reset(seed=9, options={"goal": GOAL})
    assert np.array_equal(ia["pose"], ib["pose"])
    assert np.array_equal(ib["task"]["goal"], GOAL)


@pytest.mark.parametrize("bad,exc", [({"start": (1.0, 2.0)}, ValueError),
                                     ({"start": (1.0, np.nan, 0.0)}, ValueError),
                                     ({"start": "here"}, TypeError),
                                     ({"goal": np.zeros((2, 3))}, ValueError)])
def test_bad_pose_options(bad, exc):
    with pytest.raises(exc, match="options"):
        make("DiffDrive", task="goal").reset(seed=0, options=bad)


def test_track_reference_and_start_options():
    ref = Circle(radius=1.5, speed=0.4)
    env = make("Unicycle", task="track")
    _, info = env.reset(seed=2, options={"reference": ref})
    assert info["task"]["reference"] == "Circle"
    pose0 = ref.initial_pose()
    assert np.allclose(info["pose"], pose0, atol=1e-12)
    core = env.unwrapped.core
    k = 40
    for _ in range(k):
        env.step(np.zeros(2, dtype=np.float32))
    pose, twist, _ = core.task.reference_at()
    want_pose, want_twist, _ = ref.evaluate(k * core.dt)
    assert np.allclose(pose[0], want_pose, atol=1e-12)
    assert np.allclose(twist[0], want_twist, atol=1e-12)
    _, info = env.reset(seed=2, options={"reference": Line(), "start": START})
    assert np.array_equal(info["pose"], START) and info["task"]["reference"] == "Line"
    with pytest.raises(TypeError, match="Reference"):
        env.reset(options={"reference": "circle"})


def test_navigate_layout_seed_and_poses():
    env = make("DiffDrive", task="navigate")
    task: NavigateTask = env.unwrapped.core.task
    env.reset(seed=123)
    drawn = task.worlds[0]
    env.reset(seed=7, options={"layout_seed": 123})  # the layout seed 123 draws
    w = task.worlds[0]
    assert np.array_equal(w.circles, drawn.circles) and np.array_equal(w.segments, drawn.segments)
    assert np.array_equal(w.start, drawn.start)
    # the same layout whatever the episode seed; start and goal override its poses
    env.reset(seed=8, options={"layout_seed": 123, "start": w.start, "goal": drawn.goal})
    assert np.array_equal(task.circles[0, : task.nc[0]], drawn.circles)
    assert np.array_equal(task.goal[0], drawn.goal)
    with pytest.raises(ValueError, match="not free"):
        c = drawn.circles[0]
        env.reset(options={"layout_seed": 123, "start": (c[0], c[1], 0.0)})
    with pytest.raises(ValueError, match="layout_seed"):
        env.reset(options={"layout_seed": -1})


def _single(robot, task, seed, options, **kw):
    env = make(robot, task=task, **kw)
    obs, info = env.reset(seed=seed, options=options)
    return obs, info


@pytest.mark.parametrize("task", ["goal", "track", "navigate"])
def test_vector_rows_match_single_env_with_options(task):
    n = 3
    starts = np.array([[0.1, 0.2, 0.3], [-0.5, 0.4, 1.0], [0.0, -0.3, -2.0]])
    per_row = {"goal": {"start": starts, "goal": GOAL},
               "track": {"start": starts, "reference": [Circle(), Line(), Circle(radius=2.0)]},
               "navigate": {"layout_seed": [5, 6, 7]}}[task]
    venv = gym.make_vec("wheelgym/DiffDrive-v0", num_envs=n, task=task)
    obs, info = venv.reset(seed=10, options=per_row)
    for i in range(n):
        opt = {k: (v if isinstance(v, np.ndarray) and v.ndim == 1 else v[i])
               for k, v in per_row.items()}
        o, inf = _single("DiffDrive", task, 10 + i, opt)
        assert np.array_equal(obs[i], o)
        assert np.array_equal(info["pose"][i], inf["pose"])
    # a partial reset applies the options to the rows reset only
    mask = np.array([False, True, False])
    before = venv.unwrapped.core.pose.copy()
    obs2, _ = venv.reset(options={"reset_mask": mask, **per_row})
    assert np.array_equal(venv.unwrapped.core.pose[[0, 2]], before[[0, 2]])
    if task != "navigate":
        assert np.array_equal(venv.unwrapped.core.pose[1], starts[1])


def test_vector_per_row_shape_errors():
    venv = gym.make_vec("wheelgym/DiffDrive-v0", num_envs=3, task="goal")
    with pytest.raises(ValueError, match=r"\(3, 3\)"):
        venv.reset(seed=0, options={"start": np.zeros((2, 3))})
    venv = gym.make_vec("wheelgym/DiffDrive-v0", num_envs=3, task="navigate")
    with pytest.raises(ValueError, match="one int seed per sub-env"):
        venv.reset(seed=0, options={"layout_seed": [1, 2]})


def test_no_options_draws_unchanged():
    a, b = make("ThreeWheel", task="track"), make("ThreeWheel", task="track")
    oa, _ = a.reset(seed=1)
    ob, _ = b.reset(seed=1, options={})
    oc, _ = b.reset(seed=1, options=None)
    assert np.array_equal(oa, ob) and np.array_equal(oa, oc)
