"""The shaping terms: internal force normalised by the torque limits, navigate's proximity."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401


def test_internal_force_term_is_the_fraction_of_the_largest_torque():
    env = gym.make("wheelgym/ThreeWheel-v0", task="goal", action_mode="torque",
                   reward_weights={"internal_force": 0.7})
    env.reset(seed=3)
    # |tau_max| of the default motors by hand: three drives at 6 N·m, three steers at 3 N·m
    scale = math.sqrt(3 * 6.0**2 + 3 * 3.0**2)
    rng = np.random.default_rng(0)
    seen = 0.0
    for _ in range(20):
        _, _, term, trunc, info = env.step(rng.uniform(-1, 1, 6).astype(np.float32))
        xf = info["internal_force"]
        assert 0.0 <= xf <= scale
        assert info["reward_terms"]["internal_force"] == pytest.approx(-0.7 * xf / scale,
                                                                        rel=1e-12)
        seen = max(seen, xf)
        if term or trunc:
            env.reset()
    assert seen > 0.5  # random torques do fight: the check above was not on zeros


def _clearance(world, p: np.ndarray) -> float:
    """Distance from ``p`` to the nearest circle surface or wall/box segment (NumPy)."""
    best = math.inf
    for cx, cy, r in world.circles:
        best = min(best, math.hypot(p[0] - cx, p[1] - cy) - r)
    for x0, y0, x1, y1 in world.segments:
        d = np.array([x1 - x0, y1 - y0])
        t = np.clip(np.dot(p - (x0, y0), d) / np.dot(d, d), 0.0, 1.0)
        best = min(best, float(np.hypot(*(p - (np.array([x0, y0]) + t * d)))))
    return best


@pytest.mark.parametrize("gap", [0.05, 0.2, 0.45, 0.8])
def test_proximity_term_from_the_footprint_gap(gap):
    env = gym.make("wheelgym/DiffDrive-v0", task="navigate",
                   reward_weights={"proximity": 0.3})
    task = env.unwrapped.core.task
    radius = env.unwrapped.core.spec.radius
    # a start pose facing away from the lower wall at the wanted gap, where the wall is the
    # nearest obstacle, in the first layout that has one (the check below uses the true
    # clearance after the step all the same)
    y = -task.arena.half_size + radius + gap
    for seed in range(50):
        env.reset(seed=seed)
        world = task.worlds[0]
        xs = [x for x in np.linspace(-3.0, 3.0, 61) if _clearance(world, np.array([x, y]))
              == pytest.approx(radius + gap, abs=1e-12)]
        if xs:
            break
    assert xs, "no layout with a spot along the wall where the wall is the nearest obstacle"
    start = np.array([xs[len(xs) // 2], y, math.pi / 2])
    env.reset(seed=seed, options={"start": start})
    _, _, _, _, info = env.step(np.zeros(2, dtype=np.float32))
    pose = info["pose"][:2]
    g = _clearance(task.worlds[0], pose) - radius
    expect = -0.3 * min(max(1.0 - g / task.d_safe, 0.0), 1.0)
    assert info["reward_terms"]["proximity"] == pytest.approx(expect, abs=1e-9)
    assert (expect < 0) == (gap < task.d_safe)


def test_goal_task_has_no_proximity_term():
    env = gym.make("wheelgym/ThreeWheel-v0", task="goal")
    env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert "proximity" not in info["reward_terms"]
    with pytest.raises(ValueError, match="proximity"):
        gym.make("wheelgym/ThreeWheel-v0", task="goal", reward_weights={"proximity": 1.0})


@pytest.mark.parametrize("robot, task", [("SkidSteer", "track"), ("ThreeWheel", "goal"),
                                         ("CasterAGV", "navigate")])
def test_saturation_term_follows_the_flag(robot, task):
    env = gym.make(f"wheelgym/{robot}-v0", task=task, action_mode="velocity",
                   reward_weights={"saturation": 0.5})
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    flags = []
    for _ in range(40):
        # half the steps within bounds, half far beyond (clipped: the flag is up)
        a = rng.uniform(-1, 1, env.action_space.shape) * rng.choice([0.5, 4.0])
        _, r, term, trunc, info = env.step(a.astype(np.float32))
        flags.append(bool(info["saturated"]))
        assert info["reward_terms"]["saturation"] == (-0.5 if info["saturated"] else 0.0)
        assert sum(info["reward_terms"].values()) == pytest.approx(r, abs=1e-12)
        if term or trunc:
            env.reset()
    assert any(flags) and not all(flags)  # both branches were seen


@pytest.mark.parametrize("vector", [False, True])
def test_set_reward_weights_takes_effect_on_the_next_step(vector):
    kw = dict(task="goal", action_mode="torque")
    env = (gym.make_vec("wheelgym/ThreeWheel-v0", num_envs=2,
                        vectorization_mode="vector_entry_point", **kw)
           if vector else gym.make("wheelgym/ThreeWheel-v0", **kw))
    u = env.unwrapped if not vector else env
    env.reset(seed=5)
    a = np.tile(np.array([0.4, -0.3, 0.2, 0.1, -0.2, 0.3], dtype=np.float32),
                (2, 1) if vector else (1,))
    env.step(a)
    u.set_reward_weights({"internal_force": 2.0, "effort": 0.0})
    assert u.reward_weights["internal_force"] == 2.0 and u.reward_weights["progress"] == 1.0
    _, r, _, _, info = env.step(a)
    terms = {k: v for k, v in info["reward_terms"].items() if not k.startswith("_")}  # masks
    xf = np.asarray(info["internal_force"])
    scale = math.sqrt(3 * 6.0**2 + 3 * 3.0**2)  # |tau_max| of the default motors
    np.testing.assert_allclose(terms["internal_force"], -2.0 * xf / scale, rtol=1e-12)
    np.testing.assert_array_equal(terms["effort"], 0.0)
    np.testing.assert_allclose(sum(terms.values()), r, atol=1e-12)
    assert np.all(xf > 0)
    before = u.reward_weights
    with pytest.raises(ValueError, match="valid keys"):
        u.set_reward_weights({"internal_force": 1.0, "lost": 1.0})
    with pytest.raises(ValueError, match="finite"):
        u.set_reward_weights({"effort": math.inf})
    assert u.reward_weights == before  # a refused change changes nothing
