"""Checkers, determinism, reward sums, energy, bad input and robustness of every environment."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from tests.envs.conftest import DYNAMIC, ROBOTS, TASKS, combos, make
from wheelgym.registration import env_id


def test_every_robot_registered():
    for robot in ROBOTS:
        assert env_id(robot) in gym.registry
        assert gym.registry[env_id(robot)].max_episode_steps == 500
    assert "ThreeWheel" in ROBOTS and "SkidSteer" in ROBOTS


@pytest.mark.parametrize("robot,task,mode", combos())
def test_checkers_without_warnings(robot, task, mode):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # (navigate on -v0 says by design that -v1 exists: tests/test_registration.py)
        warnings.filterwarnings("ignore", message=".*-v0 is out of date",
                                category=DeprecationWarning)
        env = make(robot, task=task, action_mode=mode)
        check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(make(robot, task=task, action_mode=mode), warn=True)
        env.close()


def _rollout(env, seed, n, actions_seed=1):
    rng = np.random.default_rng(actions_seed)
    obs, info = env.reset(seed=seed)
    out = [(obs, 0.0, info)]
    for _ in range(n):
        obs, r, te, tr, info = env.step(rng.uniform(-1.2, 1.2, env.action_space.shape))
        out.append((obs, r, info))
        if te or tr:
            obs, info = env.reset()
            out.append((obs, 0.0, info))
    return out


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and np.array_equal(a, b)
    return type(a) is type(b) and (a == b or (a != a and b != b))


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("task", TASKS)
def test_same_seed_same_bits_and_seeds_differ(robot, task):
    from wheelgym.envs.robots import get_spec

    # randomize=True where the robot has something to draw (else it is refused: see below)
    kw = {"task": task, "randomize": bool(get_spec(robot).default_randomize), "obs_noise": 0.01}
    a = _rollout(make(robot, **kw), 3, 60)
    b = _rollout(make(robot, **kw), 3, 60)
    assert len(a) == len(b)
    for (oa, ra, ia), (ob, rb, ib) in zip(a, b, strict=True):
        assert _same(oa, ob) and ra == rb and _same(ia, ib)
    c = _rollout(make(robot, **kw), 4, 60)
    assert not np.array_equal(a[0][0], c[0][0])


@pytest.mark.parametrize("robot,task,mode", combos())
def test_reward_terms_sum_and_obs_in_space(robot, task, mode):
    env = make(robot, task=task, action_mode=mode)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    for _ in range(40):
        obs, r, te, tr, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        assert obs.dtype == np.float32 and env.observation_space.contains(obs)
        assert math.isclose(sum(info["reward_terms"].values()), r, rel_tol=0, abs_tol=1e-12)
        for key in ("pose", "twist", "motor_torque", "joint_velocity", "tracking_error",
                    "energy", "internal_force", "saturated", "is_success"):
            assert key in info
        if te or tr:
            env.reset()


def _energy_reference(model, x0, torques, dt, n_fine):
    """Independent motor work: RK4 on the state augmented with E' = motor_power(x, tau)."""
    from wheelgym.integrators import rk4

    def f(z, u):
        x = z[..., :-1]
        dz = np.empty_like(z)
        dz[..., :-1] = model.derivative(x, u)
        dz[..., -1] = model.motor_power(x, u)
        return dz

    z = np.append(x0, 0.0)
    for u in torques:
        z = rk4(f, z, u, dt, n_fine)
    return z[-1]


@pytest.mark.parametrize("robot", DYNAMIC)
def test_energy_is_integral_of_torque_times_joint_rate(robot):
    env = make(robot, task="goal")
    core = env.unwrapped.core
    env.reset(seed=5)
    x0 = core.X[0].copy()
    rng = np.random.default_rng(2)
    torques = []
    for _ in range(20):
        env.step(rng.uniform(-0.6, 0.6, env.action_space.shape))
        torques.append(core.U[0].copy())
    e_env = env.unwrapped.core.energy[0]
    e_ref = _energy_reference(core.model, x0, torques, core.dt, 4 * core.n_sub)
    assert abs(e_env) > 1.0
    assert abs(e_env - e_ref) < 1e-4 * abs(e_ref)


def test_internal_force_matches_null_space_projector():
    from wheelgym.control import internal_force

    env = make("ThreeWheel")
    core = env.unwrapped.core
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(5):
        _, _, _, _, info = env.step(rng.uniform(-1, 1, 6))
    # the projector acts at the end-of-step steering angles, as the kernel does
    J = core.model.jacobian(core.X[0, 6:9])
    ref = np.linalg.norm(internal_force(J, info["motor_torque"]))
    assert info["internal_force"] == pytest.approx(ref, rel=1e-9)


@pytest.mark.parametrize("robot", ROBOTS)
def test_bad_actions(robot):
    env = make(robot)
    env.reset(seed=0)
    n = env.action_space.shape[0]
    for bad in (np.zeros(n + 1), np.zeros((1, n)), np.array([np.nan] + [0.0] * (n - 1)),
                np.full(n, np.inf)):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)
    # outside [-1, 1] is clipped: the same as the bound; both are saturated, inside is not
    e1, e2, e3 = make(robot), make(robot), make(robot)
    for e in (e1, e2, e3):
        e.reset(seed=0)
    o1, r1, *_, i1 = e1.step(np.full(n, 5.0))
    o2, r2, *_, i2 = e2.step(np.ones(n))
    *_, i3 = e3.step(np.zeros(n))
    assert np.array_equal(o1, o2) and i1["saturated"] and i2["saturated"]
    assert not i3["saturated"]


@pytest.mark.filterwarnings("ignore:.*render_mode")
@pytest.mark.parametrize("kw,match", [
    ({"task": "fly"}, "valid tasks"),
    ({"action_mode": "jump"}, "valid modes"),
    ({"reward_weights": {"speed": 1.0}}, "valid keys"),
    ({"randomize": {"colour": 0.1}}, "valid keys"),
    ({"randomize": {"mass": (-1.0, 2.0)}}, "mass"),
    ({"ctrl_dt": 0.05, "sim_dt": 0.003}, "multiple"),
    ({"ctrl_dt": -1.0}, "ctrl_dt"),
    ({"obs_noise": -0.1}, "obs_noise"),
    ({"render_mode": "ascii"}, "render_mode"),
    ({"params": {"wings": 2}}, "valid names"),
])
def test_bad_keywords(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        make("SkidSteer", **kw)


@pytest.mark.parametrize("robot", DYNAMIC)
def test_extreme_torques_and_parameters_never_nan(robot):
    from wheelgym.envs.robots import get_spec

    spec = get_spec(robot)
    for side in (0, 1):
        rnd = {k: (v[side], v[side]) for k, v in spec.default_randomize.items()}
        env = make(robot, task="navigate", randomize=rnd)
        rng = np.random.default_rng(side)
        obs, info = env.reset(seed=side)
        for _ in range(200):
            a = np.sign(rng.uniform(-1, 1, env.action_space.shape)) * 3.0
            obs, r, te, tr, info = env.step(a)
            assert np.all(np.isfinite(obs)) and math.isfinite(r)
            assert all(np.all(np.isfinite(np.asarray(v))) for k, v in info.items()
                       if k != "reward_terms")
            if te or tr:
                obs, info = env.reset()


def test_non_finite_state_ends_with_numerical_failure():
    env = make("SkidSteer")
    env.reset(seed=0)
    env.unwrapped.core.X[0, 3] = 1e306  # the next step overflows
    obs, r, te, tr, info = env.step(np.ones(4))
    assert info["numerical_failure"] and te
    assert np.all(np.isfinite(obs)) and math.isfinite(r)
    assert env.observation_space.contains(obs)


def test_reset_info_has_drawn_parameters():
    env = make("ThreeWheel", randomize={"mass": 0.2, "caster_trail": (0.9, 1.1)})
    _, info = env.reset(seed=3)
    assert set(info["params"]) == {"m_b", "m_w", "d"}
    assert 0.9 * 0.04 <= info["params"]["d"] <= 1.1 * 0.04
    assert env.unwrapped.core.params_rows[0].d == info["params"]["d"]


def test_make_time_and_dt():
    env = make("SkidSteer", ctrl_dt=0.1)
    assert env.unwrapped.dt == 0.1
    assert env.unwrapped.core.n_sub == round(0.1 / env.unwrapped.core.model.default_sim_dt)


@pytest.mark.parametrize("robot", ["Bicycle", "Ackermann"])
def test_randomize_true_with_nothing_to_draw_is_refused(robot):
    with pytest.raises(ValueError, match="no parameters to randomise"):
        make(robot, randomize=True)
