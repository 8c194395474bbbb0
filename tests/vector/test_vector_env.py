"""The batched vector env against the single env, bit for bit, and its Gymnasium semantics.

The reference is Gymnasium's ``SyncVectorEnv`` of single environments (``gym.make`` with the
same ``max_episode_steps``): it loops the single env in Python and builds its infos with
Gymnasium's own ``_add_info``, so equality with it is equality with the single env, sub-env
by sub-env, including the autoreset and info conventions.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from tests.vector.conftest import ROBOTS, assert_same, combos, env_id
from wheelgym.vector import ThreeWheelVectorEnv, WheelVectorEnv

NEXT, SAME, DISABLED = AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED


def make_pair(robot: str, n: int, mode: AutoresetMode = NEXT, **kw):
    eid = env_id(robot)
    vec = gym.make_vec(eid, num_envs=n, vectorization_mode="vector_entry_point",
                       autoreset_mode=mode, **kw)
    ref = SyncVectorEnv([lambda: gym.make(eid, **kw) for _ in range(n)], autoreset_mode=mode)
    return vec, ref


def actions(rng: np.random.Generator, shape, bang: float = 0.5) -> np.ndarray:
    """Mixed actions: bang-bang in a fraction ``bang`` of the sub-envs (ends episodes by
    overspeed), the others inside and outside [-1, 1]."""
    a = rng.uniform(-1.3, 1.3, shape)
    rows = rng.random(shape[0]) < bang
    a[rows] = np.sign(a[rows])
    return a.astype(np.float32)


def rollout_equal(vec, ref, steps: int, seed: int = 11, partial_at: int = 3,
                  bang: float = 0.5) -> tuple[int, int]:
    """Drive both with the same actions; every output must match exactly. Returns the
    numbers of terminations and truncations seen."""
    n = vec.num_envs
    rng = np.random.default_rng(seed)
    assert_same(vec.reset(seed=seed), ref.reset(seed=seed), "reset")
    nterm = ntrunc = 0
    for t in range(steps):
        if t == partial_at:  # desynchronise the episodes: reset sub-env 1 alone
            m = np.zeros(n, dtype=bool)
            m[1] = True
            assert_same(vec.reset(options={"reset_mask": m}),
                        ref.reset(options={"reset_mask": m.copy()}), f"partial reset {t}")
        a = actions(rng, vec.action_space.shape, bang)
        out = vec.step(a)
        assert_same(out, ref.step(a), f"step {t}")
        nterm += int(out[2].sum())
        ntrunc += int(out[3].sum())
    return nterm, ntrunc


@pytest.mark.parametrize("mode", [NEXT, SAME], ids=["next_step", "same_step"])
@pytest.mark.parametrize("robot,task,action_mode", combos())
def test_matches_single_env(robot, task, action_mode, mode):
    vec, ref = make_pair(robot, 3, mode, task=task, action_mode=action_mode,
                         max_episode_steps=6)
    _, ntrunc = rollout_equal(vec, ref, 16)
    assert ntrunc > 0


@pytest.mark.parametrize("robot", ROBOTS)
def test_matches_single_env_randomized_noisy(robot):
    """Parameter randomisation and observation noise: every draw from each sub-env's own
    generator, in the single env's order, across autoresets."""
    from wheelgym.envs.robots import get_spec

    # robots with nothing to draw refuse randomize=True (tests/envs/test_envs.py)
    vec, ref = make_pair(robot, 3, NEXT, task="goal",
                         randomize=bool(get_spec(robot).default_randomize), obs_noise=0.02,
                         max_episode_steps=5)
    rollout_equal(vec, ref, 14)


def test_matches_single_env_pymunk_ranges():
    vec, ref = make_pair("SkidSteer", 3, SAME, task="navigate", range_backend="pymunk",
                         max_episode_steps=5)
    rollout_equal(vec, ref, 12)


@pytest.mark.parametrize("robot", ["DiffDrive", "Bicycle"])
def test_matches_single_env_with_the_waypoint_hint(robot):
    """navigate -v1's hint, computed for all rows at once (DiffDrive: the path search of
    WaypointHint.points; Bicycle: each row's car tracker), equals each single env's, through
    episode starts and replans after straying (random actions stray)."""
    kw = dict(task="navigate", waypoint_hint=True, max_episode_steps=40)
    eid = env_id(robot, 1)
    vec = gym.make_vec(eid, num_envs=4, vectorization_mode="vector_entry_point", **kw)
    ref = SyncVectorEnv([lambda: gym.make(eid, **kw) for _ in range(4)])
    _, ntrunc = rollout_equal(vec, ref, 90, bang=0.3)
    assert ntrunc > 0


@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer"])
def test_matches_single_env_in_vectorised_blocks(robot):
    """From LANES rows on, the dynamic robots step in blocks of robots evaluated together
    (integrators.rk4_block): 11 sub-envs (a full block and a partial one) still equal the
    single env, which steps a row at a time, bit for bit."""
    from wheelgym.integrators import LANES

    vec, ref = make_pair(robot, LANES + 3, NEXT, task="goal", action_mode="torque",
                         max_episode_steps=7)
    nterm, ntrunc = rollout_equal(vec, ref, 15, bang=0.3)
    assert ntrunc > 0


@pytest.mark.parametrize("robot,action_mode", [("DiffDrive", None), ("ThreeWheel", "velocity")])
def test_matches_single_env_long_track_episodes(robot, action_mode):
    """Track episodes long enough that every sub-env's reference window moves on (every
    ``window - ahead`` = 33 steps), desynchronised by a partial reset, with time limits."""
    kw = {"task": "track", "max_episode_steps": 90}
    if action_mode:
        kw["action_mode"] = action_mode
    from wheelgym.tasks.tasks import TrackTask

    n = TrackTask.whole_up_to + 2  # windows here, the whole reference in the single envs
    vec, ref = make_pair(robot, n, NEXT, **kw)
    rng = np.random.default_rng(5)
    assert_same(vec.reset(seed=3), ref.reset(seed=3), "reset")
    moved = 0
    for t in range(140):
        if t == 20:
            m = np.zeros(n, dtype=bool)
            m[1] = True
            assert_same(vec.reset(options={"reset_mask": m}),
                        ref.reset(options={"reset_mask": m.copy()}), f"partial reset {t}")
        a = (0.05 * rng.uniform(-1, 1, vec.action_space.shape)).astype(np.float32)
        kb = vec.unwrapped.core.task.kbase.copy()
        assert_same(vec.step(a), ref.step(a), f"step {t}")
        moved += int(np.sum(vec.unwrapped.core.task.kbase > kb))
    assert moved >= 6


def test_terminations_and_autoreset_covered():
    """A run where sub-envs terminate (overspeed under bang-bang torques) at different steps
    and are truncated, in both autoreset modes, still equal to the single env."""
    for mode in (NEXT, SAME):
        vec, ref = make_pair("ThreeWheel", 4, mode, task="goal", max_episode_steps=12)
        nterm, ntrunc = rollout_equal(vec, ref, 40, bang=1.0)
        assert nterm >= 3 and ntrunc >= 1


def test_sub_env_i_is_single_env_seed_s_plus_i():
    """Directly: sub-env i of N = 5 reset with seed 7 equals a single env reset with 7 + i."""
    n, s = 5, 7
    vec = gym.make_vec("wheelgym/SkidSteer-v0", num_envs=n, vectorization_mode="vector_entry_point",
                       task="track")
    obs, _ = vec.reset(seed=s)
    rng = np.random.default_rng(0)
    acts = [rng.uniform(-1, 1, vec.action_space.shape).astype(np.float32) for _ in range(10)]
    traj = [obs]
    for a in acts:
        traj.append(vec.step(a)[0])
    for i in range(n):
        env = gym.make("wheelgym/SkidSteer-v0", task="track")
        o, _ = env.reset(seed=s + i)
        assert o.tobytes() == traj[0][i].tobytes()
        for k, a in enumerate(acts):
            o = env.step(a[i])[0]
            assert o.tobytes() == traj[k + 1][i].tobytes()
    # a list of seeds selects the same generators
    obs2, _ = vec.reset(seed=[s + i for i in range(n)])
    assert obs2.tobytes() == traj[0].tobytes()


@pytest.mark.parametrize("robot", ROBOTS)
def test_shapes_dtypes_and_spaces(robot):
    n = 4
    vec = gym.make_vec(env_id(robot), num_envs=n, vectorization_mode="vector_entry_point",
                       task="navigate")
    assert isinstance(vec, WheelVectorEnv)
    assert vec.metadata["autoreset_mode"] is NEXT
    single = gym.make(env_id(robot), task="navigate")
    assert vec.single_observation_space == single.observation_space
    assert vec.single_action_space == single.action_space
    assert vec.observation_space.shape == (n, *single.observation_space.shape)
    assert vec.action_space.shape == (n, *single.action_space.shape)
    obs, info = vec.reset(seed=0)
    assert obs.dtype == np.float32 and obs in vec.observation_space
    for _ in range(3):
        obs, rew, term, trunc, info = vec.step(vec.action_space.sample())
        assert obs.shape == (n, *single.observation_space.shape) and obs.dtype == np.float32
        assert obs in vec.observation_space
        assert rew.shape == (n,) and rew.dtype == np.float64
        assert term.shape == trunc.shape == (n,) and term.dtype == trunc.dtype == np.bool_

        def check(d):
            for k, v in d.items():
                if isinstance(v, dict):
                    check(v)
                    continue
                assert isinstance(v, np.ndarray) and v.shape[0] == n, k
                if k.startswith("_"):
                    assert v.dtype == np.bool_ and k[1:] in d
                else:
                    assert "_" + k in d
                    if v.dtype != object:
                        assert np.all(np.isfinite(v)), k

        check(info)
        assert info["pose"].shape == (n, 3) and info["pose"].dtype == np.float64
        np.testing.assert_allclose(
            rew, sum(v for k, v in info["reward_terms"].items() if not k.startswith("_")),
            rtol=1e-12, atol=1e-12)


def test_next_step_autoreset_semantics():
    n, T = 3, 4
    vec = ThreeWheelVectorEnv(num_envs=n, max_episode_steps=T)
    obs, _ = vec.reset(seed=1)
    a = np.tile(np.array([0.3, 0.3, 0.3, 0, 0, 0], dtype=np.float32), (n, 1))
    for _t in range(T - 1):
        _, _, term, trunc, _ = vec.step(a)
        assert not trunc.any()
    _, _, term, trunc, info = vec.step(a)
    assert trunc.all() and "params" not in info
    last_energy = info["energy"].copy()
    # next step: actions ignored (even non-finite), reward 0, flags false, a fresh episode
    bad = np.full((n, 6), np.nan, dtype=np.float32)
    obs2, rew, term, trunc, info = vec.step(bad)
    assert np.all(rew == 0.0) and not term.any() and not trunc.any()
    assert info["_params"].all() and info["_task"].all()
    assert np.all(info["energy"] == 0.0) and np.any(last_energy != 0.0)
    assert not np.array_equal(obs2, obs)  # generators continued: new starts and goals
    with pytest.raises(ValueError, match="finite"):
        vec.step(bad)  # now they step


def test_same_step_autoreset_semantics():
    n, T = 3, 4
    vec = ThreeWheelVectorEnv(num_envs=n, max_episode_steps=T, autoreset_mode="SameStep")
    assert vec.metadata["autoreset_mode"] is SAME
    vec.reset(seed=1)
    a = np.tile(np.array([0.3, 0.3, 0.3, 0, 0, 0], dtype=np.float32), (n, 1))
    for _ in range(T - 1):
        _, _, _, _, info = vec.step(a)
        assert "final_obs" not in info
    obs, rew, term, trunc, info = vec.step(a)
    assert trunc.all() and info["_final_obs"].all() and info["_final_info"].all()
    final = np.stack(info["final_obs"])
    assert final.dtype == np.float32 and not np.array_equal(final, obs)
    assert np.all(info["final_info"]["energy"] != 0.0) and np.all(info["energy"] == 0.0)
    assert info["_params"].all()
    assert np.all(rew != 0.0)  # the ending step's reward, not a reset's 0


def test_disabled_autoreset_needs_manual_reset():
    vec = ThreeWheelVectorEnv(num_envs=2, max_episode_steps=2, autoreset_mode=DISABLED)
    vec.reset(seed=0)
    a = np.zeros((2, 6), dtype=np.float32)
    vec.step(a)
    _, _, _, trunc, _ = vec.step(a)
    assert trunc.all()
    with pytest.raises(RuntimeError, match="reset_mask"):
        vec.step(a)
    vec.reset(options={"reset_mask": np.array([True, True])})
    vec.step(a)


def test_time_limit_none_never_truncates():
    vec = ThreeWheelVectorEnv(num_envs=2, max_episode_steps=None, task="track",
                              action_mode="velocity")
    vec.reset(seed=0)
    for _ in range(30):
        _, _, _, trunc, _ = vec.step(np.zeros((2, 3), dtype=np.float32))
        assert not trunc.any()


def test_bad_input():
    with pytest.raises(ValueError, match="num_envs"):
        ThreeWheelVectorEnv(num_envs=0)
    with pytest.raises(ValueError, match="autoreset_mode"):
        ThreeWheelVectorEnv(num_envs=2, autoreset_mode="sometimes")
    with pytest.raises(ValueError, match="max_episode_steps"):
        ThreeWheelVectorEnv(num_envs=2, max_episode_steps=0)
    with pytest.raises(ValueError, match="render_mode"):
        ThreeWheelVectorEnv(num_envs=2, render_mode="human")
    with pytest.raises(ValueError, match="task"):
        ThreeWheelVectorEnv(num_envs=2, task="dance")
    with pytest.raises(ValueError, match="robot"):
        WheelVectorEnv(num_envs=2)
    vec = ThreeWheelVectorEnv(num_envs=2)
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(np.zeros((2, 6)))
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        vec.step(np.zeros((3, 6)))
    a = np.zeros((2, 6))
    a[1, 2] = np.inf
    with pytest.raises(ValueError, match="finite"):
        vec.step(a)
    with pytest.raises(ValueError, match="seed"):
        vec.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match="reset_mask"):
        vec.reset(options={"reset_mask": np.zeros(2, dtype=bool)})
    with pytest.raises(ValueError, match="reset_mask"):
        vec.reset(options={"reset_mask": np.ones(3, dtype=bool)})


def test_gymnasium_vector_wrappers():
    """Gymnasium's vector wrappers accept it (episode statistics, normalisation, list infos)."""
    from gymnasium.wrappers.vector import (
        DictInfoToList,
        NormalizeObservation,
        RecordEpisodeStatistics,
    )

    vec = gym.make_vec("wheelgym/SkidSteer-v0", num_envs=4, vectorization_mode="vector_entry_point",
                       max_episode_steps=5)
    env = DictInfoToList(RecordEpisodeStatistics(NormalizeObservation(vec)))
    env.reset(seed=0)
    episodes = 0
    for _ in range(12):
        _, _, _, _, infos = env.step(env.action_space.sample())
        assert isinstance(infos, list) and len(infos) == 4
        episodes += sum("episode" in i for i in infos)
    assert episodes == 8  # two rounds of 5-step episodes in 12 next-step-autoreset steps
    assert env.unwrapped.spec.id == "wheelgym/SkidSteer-v0"
    env.close()


def test_render_rgb_array():
    vec = ThreeWheelVectorEnv(num_envs=5, render_mode="rgb_array")
    vec.reset(seed=0)
    f0 = vec.render()
    assert f0.shape == (600, 600, 3) and f0.dtype == np.uint8
    for _ in range(15):
        vec.step(np.tile([1, 1, 1, 0, 0, 0], (5, 1)).astype(np.float32))
    f1 = vec.render()
    assert np.mean(f0 != f1) > 1e-4  # the robot moved
    # sub-env 0's frame is the single env's frame
    single = gym.make("wheelgym/ThreeWheel-v0", render_mode="rgb_array")
    single.reset(seed=0)
    np.testing.assert_array_equal(single.render(), f0)
    vec.close()
    grid = ThreeWheelVectorEnv(num_envs=5, render_mode="rgb_array", render_envs=4)
    grid.reset(seed=0)
    g = grid.render()
    assert g.shape == (1200, 1200, 3)
    np.testing.assert_array_equal(g[:600, :600], f0)
    assert not np.array_equal(g[:600, 600:], f0)  # sub-env 1 differs
    grid.close()
    with pytest.warns(UserWarning, match="render_mode"):
        assert ThreeWheelVectorEnv(num_envs=2).render() is None
