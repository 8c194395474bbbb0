"""Perturbation specs (``perturbation=``) and the controllers' model choice
(``controller_model``, ``BaselinePolicy(model=...)``): docs/topics/robustness.md."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import wheelgym  # noqa: F401  (registers the ids)
from wheelgym.envs.baseline import BaselinePolicy
from wheelgym.envs.core import WheelCore
from wheelgym.envs.perturbation import LEVELS, Perturbation, parse_perturbation
from wheelgym.vector import WheelVectorEnv

CASES = [("ThreeWheel", "goal", "torque"), ("SkidSteer", "track", "velocity"),
         ("DiffDrive", "goal", "WheelSpeeds")]


def _rollout_single(robot, task, mode, pert, seed, actions):
    env = gym.make(f"wheelgym/{robot}-v0", task=task, action_mode=mode, perturbation=pert)
    obs = [env.reset(seed=seed)[0]]
    rew = []
    for a in actions:
        o, r, te, tr, _ = env.step(a)
        obs.append(o)
        rew.append(r)
        if te or tr:
            break
    env.close()
    return np.array(obs), np.array(rew)


@pytest.mark.parametrize("robot,task,mode", CASES)
@pytest.mark.parametrize("lvl", ["medium", "hard"])
def test_levels_are_deterministic_and_vector_equals_single(robot, task, mode, lvl):
    rng = np.random.default_rng(3)
    env = gym.make(f"wheelgym/{robot}-v0", task=task, action_mode=mode)
    d = env.action_space.shape[0]
    env.close()
    A = rng.uniform(-1, 1, (40, 3, d))
    seeds = [11, 12, 13]
    o1, r1 = _rollout_single(robot, task, mode, lvl, seeds[1], A[:, 1])
    o2, r2 = _rollout_single(robot, task, mode, lvl, seeds[1], A[:, 1])
    assert np.array_equal(o1, o2) and np.array_equal(r1, r2)  # same seed, same bits
    o0, _ = _rollout_single(robot, task, mode, None, seeds[1], A[:, 1])
    assert not np.array_equal(o0[: len(o1)], o1[: len(o0)])  # the perturbation acts
    ve = WheelVectorEnv(3, robot=robot, task=task, action_mode=mode, perturbation=lvl)
    vo, _ = ve.reset(seed=seeds)
    assert np.array_equal(vo[1], o1[0])
    for k in range(len(r1)):
        vo, vr, *_ = ve.step(A[k])
        assert np.array_equal(vo[1], o1[k + 1]), k
        assert vr[1] == r1[k]


def test_vector_env_autoreset_rows_draw_as_the_single_env():
    """A sub-env that ends and autoresets takes its draws as the single env's next episode."""
    pert = Perturbation(obs_noise=0.05, action_stuck=(0.1, 2), obs_dropped=(0.1, 2))
    ve = WheelVectorEnv(2, robot="DiffDrive", task="goal", action_mode="WheelSpeeds",
                        max_episode_steps=5, perturbation=pert)
    env = gym.make("wheelgym/DiffDrive-v0", task="goal", action_mode="WheelSpeeds",
                   max_episode_steps=5, perturbation=pert)
    vo, _ = ve.reset(seed=[5, 6])
    o, _ = env.reset(seed=5)
    a = np.full((2, 2), 0.3)
    for k in range(12):
        vo, _, vte, vtr, _ = ve.step(a)
        if k % 6 == 5:  # the autoreset step: the single env resets (no seed: its generator)
            o, _ = env.reset()
        else:
            o, _, te, tr, _ = env.step(a[0])
        assert np.array_equal(vo[0], o), k


def test_parse_and_errors():
    assert parse_perturbation(None) is None
    assert parse_perturbation("easy") is LEVELS["easy"]
    p = parse_perturbation({"action_delay": 2, "obs_stuck": (0.1, 3)})
    assert p.action_delay == (2, 2) and p.obs_stuck == (0.1, 3)
    with pytest.raises(ValueError, match="valid levels"):
        parse_perturbation("extreme")
    # a level with some fields replaced: the rest of the level as it is
    p = parse_perturbation({"level": "medium", "action_delay": [0, 2]})
    assert p.action_delay == (0, 2) and LEVELS["medium"].action_delay == (2, 2)
    assert p == Perturbation(**{**{f: getattr(LEVELS["medium"], f) for f in
                                   ("scales", "actuator_lag", "obs_noise", "action_noise",
                                    "action_dropped", "action_stuck", "obs_dropped",
                                    "obs_stuck")}, "action_delay": (0, 2)})
    assert parse_perturbation({"level": "hard"}) == LEVELS["hard"]
    with pytest.raises(ValueError, match="valid levels"):
        parse_perturbation({"level": "extreme"})
    with pytest.raises(TypeError, match="level name"):
        parse_perturbation({"level": 2})
    with pytest.raises(ValueError, match="must be 0 <= low <= high"):
        parse_perturbation({"level": "medium", "action_delay": [3, 1]})
    with pytest.raises(ValueError, match="valid fields"):
        parse_perturbation({"delay": 2})
    with pytest.raises(ValueError, match="both zero or both positive"):
        Perturbation(obs_dropped=(0.1, 0))
    with pytest.raises(ValueError, match="factors must be > 0"):
        Perturbation(scales={"mass": (0.0, 1.0)})
    with pytest.raises(ValueError, match="unknown group"):
        WheelCore("ThreeWheel", 1, perturbation={"scales": {"weight": (1, 2)}})
    with pytest.raises(ValueError, match="both draw"):
        WheelCore("ThreeWheel", 1, randomize={"mass": (0.9, 1.1)},
                  perturbation={"scales": {"mass": (1, 2)}})
    with pytest.raises(ValueError, match="both set"):
        WheelCore("ThreeWheel", 1, action_delay=1, perturbation={"action_delay": 2})
    with pytest.raises(ValueError, match="perturbation scales .* drawn as randomize"):
        WheelCore("ThreeWheel", 1, perturbation={"scales": {"caster_trail": (0.01, 0.01)}})
    with pytest.raises(ValueError, match="controller_model must be one of"):
        WheelCore("ThreeWheel", 1, action_mode="velocity", controller_model="exact")
    with pytest.raises(ValueError, match="model must be one of"):
        BaselinePolicy(WheelCore("ThreeWheel", 1), model="exact")


def test_scales_are_drawn_from_the_seed():
    c = WheelCore("SkidSteer", 2, perturbation={"scales": {"mass": (0.5, 2.0),
                                                           "x_icr": (-0.02, 0.02)}})
    c.reset(None, [np.random.default_rng(1), np.random.default_rng(1)])
    assert c.drawn[0] == c.drawn[1]
    m0 = c.base_params.m
    assert 0.5 * m0 <= c.params_rows[0].m <= 2.0 * m0
    assert abs(c.params_rows[0].x_icr - c.base_params.x_icr) <= 0.02 + 1e-12


def test_stuck_and_dropped_actions():
    """A stuck entry repeats the last delivered action; a dropped one delivers 0."""
    for field, expect in (("action_stuck", "held"), ("action_dropped", "zero")):
        c = WheelCore("DiffDrive", 1, action_mode="WheelSpeeds",
                      perturbation={field: (1.0, 2)})
        c.reset(None, [np.random.default_rng(0)])
        c.step(np.array([[0.5, -0.5]]))
        first = c.U[0].copy()
        c.step(np.array([[0.9, 0.9]]))
        if expect == "zero":
            assert np.all(first == 0) and np.all(c.U[0] == 0)
        else:  # stuck at the zero action of the reset, then the fault runs on
            assert np.array_equal(c.U[0], first)


def test_copy_keeps_the_faults_state():
    c = WheelCore("ThreeWheel", 2, perturbation="hard")
    c.reset(None, [np.random.default_rng(0), np.random.default_rng(1)])
    a = np.full((2, 6), 0.2)
    for _ in range(3):
        c.step(a)
    d = copy.deepcopy(c)
    d.rngs = copy.deepcopy(c.rngs)
    o1 = c.step(a)[0].copy()
    o2 = d.step(a)[0].copy()
    assert np.array_equal(o1, o2)


# ---------------------------------------------------------------- nominal vs true model
def _twist_errors(robot, cm, f, steps=40):
    c = WheelCore(robot, 1, task="goal", action_mode="velocity", controller_model=cm,
                  perturbation={"scales": {"mass": (f, f), "inertia": (f, f)}})
    c.reset(None, [np.random.default_rng(1)])
    a = np.full((1, c.action_dim), 0.1)
    errs = []
    for k in range(steps):
        if k == steps // 2:
            a = np.full((1, c.action_dim), 0.15)
        c.step(a)
        tw = c.twist[0] if c.action_dim == 3 else c.twist[0, [0, 2]]
        errs.append(np.abs(tw - c._cmd[0]).max())
    return np.array(errs), c.X.copy()


@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer", "CasterAGV"])
def test_velocity_controller_nominal_vs_true(robot):
    """Nominal == true on the nominal plant (bit for bit); on a 1.6x heavier plant the
    nominal model's loop misses the command by far more, the true model's follows it."""
    e_nom1, x_nom1 = _twist_errors(robot, "nominal", 1.0)
    e_tru1, x_tru1 = _twist_errors(robot, "true", 1.0)
    assert np.array_equal(x_nom1, x_tru1) and np.array_equal(e_nom1, e_tru1)
    e_nom, _ = _twist_errors(robot, "nominal", 1.6)
    e_tru, _ = _twist_errors(robot, "true", 1.6)
    k = slice(21, 40)  # after the command step
    assert e_nom[k].mean() > 2.0 * e_tru[k].mean()  # (SkidSteer: its PI loop halves it)
    assert e_tru[k].mean() < 2.0 * e_nom1[k].mean() + 1e-4


def test_velocity_default_is_v0_nominal():
    """The default controller_model is the nominal one (v0's behaviour)."""
    kw = dict(task="goal", action_mode="velocity", randomize={"mass": (0.5, 2.0)})
    a, b = WheelCore("ThreeWheel", 1, **kw), WheelCore("ThreeWheel", 1, controller_model="nominal",
                                                       **kw)
    assert a.controller_model == "nominal"
    for c in (a, b):
        c.reset(None, [np.random.default_rng(4)])
        for _ in range(10):
            c.step(np.full((1, 3), 0.3))
    assert np.array_equal(a.X, b.X)


@pytest.mark.parametrize("robot,task,mode,group", [
    ("ThreeWheel", "goal", "torque", "mass"), ("ThreeWheel", "track", "torque", "inertia"),
    ("SkidSteer", "track", "torque", "mass"), ("SkidSteer", "goal", "voltage", "motor"),
    ("CasterAGV", "goal", "torque", "mass"),
    ("DiffDrive", "goal", "VehicleSpeedHeadingRate", "wheel_radius"),
])
def test_baseline_nominal_differs_from_true_exactly_when_perturbed(robot, task, mode, group):
    out = {}
    for f in (1.0, 1.1):
        for m in ("nominal", "true"):
            c = WheelCore(robot, 2, task=task, action_mode=mode,
                          perturbation={"scales": {group: (f, f)}})
            c.reset(None, [np.random.default_rng(1), np.random.default_rng(2)])
            b = BaselinePolicy(c, model=m)
            for _ in range(5):
                a, _ = b.predict()
                c.step(a)
            out[(m, f)] = a
    assert np.array_equal(out[("nominal", 1.0)], out[("true", 1.0)])
    assert not np.array_equal(out[("nominal", 1.1)], out[("true", 1.1)])
