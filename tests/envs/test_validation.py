"""Construction and step validation of the environments."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401
from wheelgym.envs.core import MAX_CTRL_DT, MAX_SUBSTEPS
from wheelgym.envs.robots.body import SPEED_BOUND
from wheelgym.models.three_wheel import ThreeWheelParams
from wheelgym.registration import env_id


def make(robot: str, **kw) -> gym.Env:
    return gym.make(env_id(robot), **kw)


def make_vec(robot: str, num_envs: int, **kw):
    return gym.make_vec(env_id(robot), num_envs=num_envs, **kw)


# ---------------------------------------------------------------- randomize ranges
@pytest.mark.parametrize(("robot", "randomize", "key"), [
    ("SkidSteer", {"x_icr": (-0.5, 0.1)}, "x_icr"),  # x_icr must lie in (-a, b)
    ("SkidSteer", {"mass": (0.5, 1.5), "x_icr": (-0.1, 0.3)}, "x_icr"),
    ("ThreeWheel", {"caster_trail": (0.01, 1.0)}, "caster_trail"),  # d below 1 mm
    ("CasterAGV", {"caster_trail": (1.0, 12.0)}, "caster_trail"),  # trail beyond the axis
])
def test_randomize_range_that_can_draw_invalid_parameters_is_refused(robot, randomize, key):
    with pytest.raises(ValueError, match=rf"randomize\['{key}'\]"):
        make(robot, randomize=randomize)


def test_randomize_valid_ranges_still_build_and_draw():
    env = make("SkidSteer", randomize={"x_icr": (-0.2, 0.2), "mass": 0.3})
    for seed in range(5):
        env.reset(seed=seed)


def test_randomize_unstable_extreme_is_refused():
    # ThreeWheel's trailing-caster mode v_max / d: at d = 2 mm stable at 2 ms, not at d = 1 mm
    make("ThreeWheel", params={"d": 0.002})
    with pytest.raises(ValueError, match=r"randomize\['caster_trail'\].*stability"):
        make("ThreeWheel", params={"d": 0.002}, randomize={"caster_trail": (0.5, 1.0)})


# ---------------------------------------------------------------- divergence
def test_unstable_parameters_refused_at_construction():
    with pytest.raises(ValueError, match="stability region.*sim_dt <"):
        make("ThreeWheel", action_mode="velocity", params={"d": 1.2e-3})
    make("ThreeWheel", action_mode="velocity", params={"d": 1.2e-3}, sim_dt=0.001)


def _unchecked_params(**changes) -> np.ndarray:
    """Packed ThreeWheel parameters that skip the dataclass validation (to reach the kernel
    with a set that diverges: the validation refuses it now)."""
    base = ThreeWheelParams()
    p = object.__new__(ThreeWheelParams)
    for f in dataclasses.fields(base):
        object.__setattr__(p, f.name, changes.get(f.name, getattr(base, f.name)))
    return p.pack()


def test_diverging_integration_is_caught_on_its_step():
    # d = 1e-5 m: the caster mode |v| / d puts RK4 far outside its stability region; before
    # the fix the diverged steps returned twists up to 1e16 and rewards of -1e4 (or NaN)
    env = make("ThreeWheel", action_mode="velocity")
    core = env.unwrapped.core
    P = _unchecked_params(d=1e-5)
    failures = 0
    for seed in range(6):
        env.reset(seed=seed)
        core.P[0] = P
        rng = np.random.default_rng(seed)
        for _ in range(50):
            obs, r, te, tr, info = env.step(rng.uniform(-1, 1, 3))
            assert np.all(np.isfinite(obs)) and env.observation_space.contains(obs)
            assert math.isfinite(r) and abs(r) < 30.0
            assert np.all(np.abs(info["twist"]) <= SPEED_BOUND)
            assert np.all(np.isfinite(core.X))
            if info["numerical_failure"]:
                assert te
                failures += 1
            if te or tr:
                break
    assert failures > 0


def test_diverging_rows_caught_in_the_block_kernel():
    # 16 rows step through the vectorised block kernel: the same check per row
    venv = make_vec("ThreeWheel", 16, action_mode="velocity")
    venv.reset(seed=0)
    core = venv.unwrapped.core
    core.P[::2] = _unchecked_params(d=1e-5)  # even rows diverge, odd rows are nominal
    rng = np.random.default_rng(0)
    seen = np.zeros(16, dtype=bool)
    for _ in range(20):
        obs, r, te, tr, info = venv.step(rng.uniform(-1, 1, (16, 3)))
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(r)) and np.all(np.abs(r) < 30)
        assert np.all(np.abs(info["twist"]) <= SPEED_BOUND)
        seen |= info["numerical_failure"]
    assert seen[::2].any() and not seen[1::2].any()


# ---------------------------------------------------------------- work per call
def test_substeps_per_control_step_bounded():
    with pytest.raises(ValueError, match=f"at most {MAX_SUBSTEPS}.*sim_dt"):
        make("ThreeWheel", sim_dt=1e-9)
    make("ThreeWheel", sim_dt=0.05 / MAX_SUBSTEPS)  # the limit itself is accepted


@pytest.mark.parametrize("ctrl_dt", [1e6, 2.0])
def test_ctrl_dt_bounded(ctrl_dt):
    with pytest.raises(ValueError, match=f"ctrl_dt.*<= {MAX_CTRL_DT:g}"):
        make("DiffDrive", ctrl_dt=ctrl_dt)


# ---------------------------------------------------------------- lax validation
BAD_ACTIONS = [np.array(["0.1", "0.2"]), np.array([0.1 + 1j, 0.2]), np.array([True, False]),
               ["0.1", "0.2"]]


@pytest.mark.parametrize("action", BAD_ACTIONS, ids=["str", "complex", "bool", "list-str"])
def test_single_env_refuses_non_real_actions(action):
    env = make("DiffDrive")
    env.reset(seed=0)
    with pytest.raises(TypeError, match="action must be an array of real numbers"):
        env.step(action)
    core = env.unwrapped.core
    with pytest.raises(TypeError, match="action must be an array of real numbers"):
        core.step(np.asarray(action).reshape(1, 2))
    env.step(np.array([0.1, 0.2], dtype=np.float32))  # real arrays still step
    env.step([1, 0])


@pytest.mark.parametrize("action", BAD_ACTIONS, ids=["str", "complex", "bool", "list-str"])
def test_vector_env_refuses_non_real_actions(action):
    venv = make_vec("DiffDrive", 2)
    venv.reset(seed=0)
    with pytest.raises(TypeError, match="actions must be an array of real numbers"):
        venv.step(np.stack([np.asarray(action)] * 2))
    venv.step(np.zeros((2, 2), dtype=np.float32))


@pytest.mark.parametrize("value", ["0.1", True, None, [0.1]])
def test_obs_noise_type_checked(value):
    with pytest.raises(TypeError, match="obs_noise"):
        make("DiffDrive", obs_noise=value)


def test_obs_noise_range_checked():
    with pytest.raises(ValueError, match="obs_noise.*>= 0"):
        make("DiffDrive", obs_noise=-0.1)


@pytest.mark.parametrize("value", ["1.0", True, None])
def test_reward_weights_type_checked(value):
    with pytest.raises(TypeError, match=r"reward_weights\['success'\]"):
        make("DiffDrive", reward_weights={"success": value})


# ---------------------------------------------------------------- terminal bonus
def _put_goal_under_robot(core, row: int = 0) -> None:
    core.task.goal[row] = core.X[row, :3]  # at rest on the goal: the next step succeeds


def test_single_env_step_after_termination_pays_nothing_more():
    env = make("DiffDrive")
    env.reset(seed=0)
    _put_goal_under_robot(env.unwrapped.core)
    _, r, te, _, info = env.step(np.zeros(2))
    assert te and info["is_success"] and info["reward_terms"]["success"] == 10.0
    with pytest.warns(UserWarning, match="after the episode terminated"):
        _, r2, te2, _, info2 = env.step(np.zeros(2))  # would pay the success bonus again
    assert r2 == 0.0 and te2 and set(info2["reward_terms"].values()) == {0.0}
    _, r3, te3, _, _ = env.step(np.zeros(2))  # warned once; still nothing paid
    assert r3 == 0.0 and te3
    env.reset(seed=1)
    _, r4, te4, _, info4 = env.step(np.zeros(2))
    assert not te4 and r4 == sum(info4["reward_terms"].values()) != 0.0


def test_vector_env_does_not_pay_the_terminal_bonus_twice():
    venv = make_vec("DiffDrive", 2)
    venv.reset(seed=0)
    _put_goal_under_robot(venv.unwrapped.core, 0)
    _, r, te, _, info = venv.step(np.zeros((2, 2)))
    assert te[0] and info["reward_terms"]["success"][0] == 10.0
    _, r2, te2, _, info2 = venv.step(np.zeros((2, 2)))  # row 0 resets (next-step autoreset)
    assert r2[0] == 0.0 and not te2[0] and info2["reward_terms"]["success"][0] == 0.0
