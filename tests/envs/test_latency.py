"""Action latency (``action_delay``) and actuator bandwidth (``actuator_lag``)."""

from __future__ import annotations

import copy
import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from tests.envs.conftest import DYNAMIC, ROBOTS, make, modes
from tests.vector.test_vector_env import NEXT, make_pair, rollout_equal
from wheelgym.envs.actuator import MAX_ACTION_DELAY
from wheelgym.envs.core import WheelCore

KEYS = ("pose", "twist", "motor_torque", "joint_velocity", "energy", "saturated")


def _same(a, b) -> None:
    oa, ra, ta, tra, ia = a
    ob, rb, tb, trb, ib = b
    assert np.array_equal(oa, ob)
    assert ra == rb and ta == tb and tra == trb
    for k in KEYS:
        assert np.array_equal(ia[k], ib[k]), k


@pytest.mark.parametrize("k", [1, 3])
@pytest.mark.parametrize("robot,mode", [(r, m) for r in ROBOTS for m in modes(r)])
def test_delay_equals_shifted_trajectory(robot, mode, k):
    """With ``action_delay=k`` the trajectory is the undelayed one fed k zero actions and then
    the same actions, bit for bit."""
    env = make(robot, action_mode=mode, action_delay=k, max_episode_steps=None)
    ref = make(robot, action_mode=mode, max_episode_steps=None)
    shape = env.action_space.shape
    rng = np.random.default_rng(4)
    acts = rng.uniform(-1.2, 1.2, (30, *shape)).astype(np.float32)
    shifted = np.concatenate([np.zeros((k, *shape), np.float32), acts[:-k]])
    oa, _ = env.reset(seed=2)
    ob, _ = ref.reset(seed=2)
    assert np.array_equal(oa, ob)
    for t in range(len(acts)):
        sa, sb = env.step(acts[t]), ref.step(shifted[t])
        _same(sa, sb)
        if sa[2]:
            break
    # a reset empties the buffer: the next k steps apply zero again
    env.reset(seed=5)
    ref.reset(seed=5)
    for t in range(k + 3):
        _same(env.step(acts[t]), ref.step(shifted[t]))


@pytest.mark.parametrize("robot", ROBOTS)
def test_first_k_steps_apply_zero(robot):
    """From a rest start the robot stays at rest for the first k steps (zero inputs); where
    the zero action is not a zero input (asymmetric bounds) it moves as under zero actions."""
    k = 4
    env = make(robot, action_delay=k)
    env.reset(seed=1)
    core = env.unwrapped.core
    if not np.array_equal(core.LO, -core.HI):
        ref = make(robot)
        ref.reset(seed=1)
        zero = np.zeros(env.action_space.shape, np.float32)
        for _ in range(k):
            _same(env.step(zero + 0.8), ref.step(zero))
        return
    pose0 = core.pose.copy()
    a = np.full(env.action_space.shape, 0.8, np.float32)
    for _ in range(k):
        _, _, _, _, info = env.step(a)
        assert np.all(info["motor_torque"] == 0.0)
        assert np.array_equal(info["pose"], pose0[0])
        assert np.all(info["twist"] == 0.0)
    _, _, _, _, info = env.step(a)
    assert np.any(info["twist"] != 0.0)


@pytest.mark.parametrize("robot", DYNAMIC)
def test_lag_step_response_is_analytic(robot):
    """A step command's applied torque is ``u (1 - exp(-t / T))`` at the control steps."""
    T = 0.2
    env = make(robot, action_mode="torque", actuator_lag=T, max_episode_steps=None)
    env.reset(seed=0)
    core = env.unwrapped.core
    m = core.m
    lo, hi = core.LH[0, :m], core.LH[0, m:]
    a = np.linspace(-0.9, 0.7, env.action_space.shape[0]).astype(np.float32)
    for n in range(1, 21):
        _, _, term, _, info = env.step(a)
        f = 1.0 - math.exp(-n * core.dt / T)
        want = 0.5 * (hi + lo) + 0.5 * (a.astype(np.float64) * f) * (hi - lo)
        np.testing.assert_allclose(info["motor_torque"], want[:len(info["motor_torque"])],
                                   rtol=1e-12, atol=1e-12)
        if term:
            break
    # a reset zeroes the filter: the first step applies alpha u again
    env.reset(seed=1)
    _, _, _, _, info = env.step(a)
    f = 1.0 - math.exp(-core.dt / T)
    np.testing.assert_allclose(info["motor_torque"], (0.5 * (hi + lo) + 0.5 * a * f * (hi - lo))
                               [:len(info["motor_torque"])], rtol=1e-6)


@pytest.mark.parametrize("robot", ROBOTS)
def test_zero_lag_and_delay_are_todays_env(robot):
    """``action_delay=0, actuator_lag=0`` is the default env, bit for bit (no extra work)."""
    env = make(robot, action_delay=0, actuator_lag=0.0)
    ref = make(robot)
    core = env.unwrapped.core
    assert not (core._delay or core._lag or core._act_fx)
    rng = np.random.default_rng(0)
    env.reset(seed=3)
    ref.reset(seed=3)
    for _ in range(20):
        a = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        sa, sb = env.step(a), ref.step(a)
        _same(sa, sb)
        if sa[2]:
            break


def test_randomized_delay_per_row():
    """Delays drawn per row at reset: rows differ, each the single env of the same seed."""
    n = 8
    vec = gym.make_vec("wheelgym/ThreeWheel-v0", num_envs=n,
                       vectorization_mode="vector_entry_point",
                       randomize={"action_delay": (0, 5)})
    vec.reset(seed=7)
    delays = vec.unwrapped.core.delays.copy()
    assert len(set(delays.tolist())) > 1 and delays.min() >= 0 and delays.max() <= 5
    for i in range(n):
        single = make("ThreeWheel", randomize={"action_delay": (0, 5)})
        single.reset(seed=7 + i)
        assert single.unwrapped.core.delays[0] == delays[i]
    vec, ref = make_pair("ThreeWheel", 4, NEXT, randomize={"action_delay": (0, 5), "mass": 0.1},
                         max_episode_steps=6)
    rollout_equal(vec, ref, 16)


@pytest.mark.parametrize("robot", ROBOTS)
def test_vector_matches_single(robot):
    for mode in modes(robot):
        vec, ref = make_pair(robot, 3, NEXT, action_mode=mode, action_delay=2,
                             actuator_lag=0.1, max_episode_steps=6)
        rollout_equal(vec, ref, 16)


@pytest.mark.parametrize("robot", ROBOTS)
def test_check_env_clean(robot):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for kw in ({"action_delay": 2, "actuator_lag": 0.1},
                   {"randomize": {"action_delay": (1, 3)}}):
            env = make(robot, **kw)
            check_env(env.unwrapped, skip_render_check=True)
            env.close()


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer", "DiffDrive"])
def test_copy_stays_bit_equal(robot, how):
    copier = copy.deepcopy if how == "deepcopy" else (lambda e: pickle.loads(pickle.dumps(e)))
    env = make(robot, action_delay=3, actuator_lag=0.15,
               randomize={"action_delay": (2, 4)}, max_episode_steps=None)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    shape = env.action_space.shape
    for _ in range(5):
        env.step(rng.uniform(-1, 1, shape).astype(np.float32))
    twin = copier(env)
    for _ in range(30):
        a = rng.uniform(-1, 1, shape).astype(np.float32)
        sa, sb = env.step(a), twin.step(a)
        _same(sa, sb)
        if sa[2]:
            break


@pytest.mark.parametrize("kw,exc", [
    ({"action_delay": -1}, ValueError), ({"action_delay": MAX_ACTION_DELAY + 1}, ValueError),
    ({"action_delay": 1.5}, TypeError), ({"action_delay": True}, TypeError),
    ({"action_delay": "2"}, TypeError),
    ({"actuator_lag": -0.1}, ValueError), ({"actuator_lag": float("nan")}, ValueError),
    ({"actuator_lag": "0.1"}, TypeError), ({"actuator_lag": True}, TypeError),
    ({"randomize": {"action_delay": (3, 1)}}, ValueError),
    ({"randomize": {"action_delay": (0, MAX_ACTION_DELAY + 1)}}, ValueError),
    ({"randomize": {"action_delay": (0.5, 2)}}, TypeError),
    ({"randomize": {"action_delay": 2}}, TypeError),
])
def test_bad_values_raise_naming_the_argument(kw, exc):
    name = "action_delay" if "action_delay" in str(kw) else "actuator_lag"
    with pytest.raises(exc, match=name):
        WheelCore("ThreeWheel", 1, **kw)


def test_nan_action_raises_and_keeps_the_buffer():
    core = WheelCore("ThreeWheel", 1, action_delay=2, actuator_lag=0.1)
    core.reset(None, [np.random.default_rng(0)])
    buf = core._dbuf.copy()
    with pytest.raises(ValueError, match="finite"):
        core.step(np.full((1, core.action_dim), np.nan))
    assert np.array_equal(core._dbuf, buf)
