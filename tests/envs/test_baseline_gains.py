"""The baseline's twist-loop gains (``wheelgym.baseline(env, twist_gains=...)``): the default
loop when given its own gains, SkidSteer's integral action restarting with each episode, the
errors, and the loop tuned for the ``medium`` level's two-step delay (docs/topics/robustness.md)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import wheelgym
from wheelgym.agents.evaluate import run_episodes_vector

#: A loop for the two-step delay (docs/topics/robustness.md): k_v ctrl_dt = 0.6 (< 0.618, the
#: delayed sampled loop's limit), k_i ctrl_dt^2 = 0.05 at ctrl_dt = 0.05 s, w_cap 1 rad/s.
DELAYED = {"w_cap": 1.0, "twist_gains": {"k_v": 12.0, "k_i": 20.0}}


def _env(robot="SkidSteer", **kw):
    return gym.make(f"wheelgym/{robot}-v0", task="goal", action_mode="torque", **kw)


def _actions(env, policy, steps, seed):
    env.reset(seed=seed)
    out = []
    for _ in range(steps):
        a = policy.actions()[0].copy()
        out.append(a)
        env.step(a)
    return np.array(out)


@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer"])
def test_the_default_gains_given_explicitly_give_the_default_actions(robot):
    env = _env(robot)
    dt = env.unwrapped.dt
    plain = _actions(env, wheelgym.baseline(env), 30, seed=4)
    same = _actions(env, wheelgym.baseline(env, twist_gains={"k_v": 1.0 / dt, "k_i": 0.0}), 30,
                    seed=4)
    softer = _actions(env, wheelgym.baseline(env, twist_gains={"k_v": 0.5 / dt, "k_i": 0.0}),
                      30, seed=4)
    assert np.array_equal(plain, same)
    assert np.abs(softer - plain).max() > 1e-3


def test_the_integral_action_accumulates_and_restarts_with_each_episode():
    env = _env()
    pol = wheelgym.baseline(env, **DELAYED)
    env.reset(seed=1)
    env.step(pol.actions()[0])
    a1 = pol.actions()[0].copy()
    a1_again = pol.actions()[0].copy()  # the same state, the integrator one step further
    assert np.abs(a1_again - a1).max() > 1e-6
    _actions(env, pol, 40, seed=1)  # an episode's worth of integration
    env.reset(seed=2)  # steps == 0: the row's integrator starts afresh
    fresh = wheelgym.baseline(env, **DELAYED)
    assert np.array_equal(pol.actions(), fresh.actions())
    env.step(np.zeros(4))
    pol.actions()  # the integrator runs on ...
    assert not np.array_equal(pol.actions(), wheelgym.baseline(env, **DELAYED).actions())
    pol.reset()  # ... until reset() zeroes it: as a fresh policy
    assert np.array_equal(pol.actions(), wheelgym.baseline(env, **DELAYED).actions())


def test_twist_gains_errors_name_the_argument():
    with pytest.raises(ValueError, match="twist_gains: .*no twist controller"):
        wheelgym.baseline(gym.make("wheelgym/DiffDrive-v0", task="goal"),
                          twist_gains={"k_v": 10.0})
    with pytest.raises(ValueError, match="twist_gains: the integral action"):
        wheelgym.baseline(_env(), model="true", twist_gains={"k_v": 10.0})
    with pytest.raises(ValueError, match="twist_gains: unknown TwistGains field"):
        wheelgym.baseline(_env(), twist_gains={"k_p": 10.0})
    with pytest.raises(ValueError, match="k_v \\* ctrl_dt"):
        wheelgym.baseline(_env(), twist_gains={"k_v": 100.0})
    # no integral with the true model: allowed
    wheelgym.baseline(_env(), model="true", twist_gains={"k_v": 10.0, "k_i": 0.0})


def test_the_loop_for_a_delayed_plant_keeps_the_goal_at_medium():
    """At ``medium`` (two steps of action delay, the plant perturbed) the deadbeat loop spins
    past the overspeed limit or stalls on the nominal friction; the softer loop with integral
    action does neither as often (200 episodes: 88% -> 97.5%, docs/topics/robustness.md), and
    on the nominal robot both reach every goal."""
    seeds = list(range(200000, 200060))
    rates = {}
    for level in ("none", "medium"):
        for name, kw in (("deadbeat", {}), ("delayed", DELAYED)):
            venv = gym.make_vec("wheelgym/SkidSteer-v0", num_envs=len(seeds), task="goal",
                                action_mode="torque",
                                perturbation=None if level == "none" else level)
            eps = run_episodes_vector(venv, wheelgym.baseline(venv, **kw), seeds)
            rates[level, name] = np.mean([e.success for e in eps])
            venv.close()
    assert rates["none", "deadbeat"] == rates["none", "delayed"] == 1.0
    assert rates["medium", "delayed"] >= 0.95 > rates["medium", "deadbeat"] + 0.05, rates
