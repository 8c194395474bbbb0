"""goal_conditioned=True: Dict observations, compute_reward for HER (Gymnasium-Robotics)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from tests.vector.conftest import assert_same, env_id

#: compute_reward on the observed goals vs the step reward: the goals are float32 (the state
#: rounded to ~2e-7 m at these distances), the reward's progress term a difference of distances.
ATOL = 1e-5

CASES = [("ThreeWheel", "goal", "velocity"), ("Bicycle", "goal", "VehicleSpeedSteeringAngle"),
         ("DiffDrive", "navigate", None)]


def make(robot: str, task: str, mode: str | None, **kw):
    if mode is not None:
        kw["action_mode"] = mode
    return gym.make(env_id(robot), task=task, goal_conditioned=True, **kw)


def rollout(env, steps: int, seed: int = 0):
    """Random actions (bang-bang half the time: overspeed ends); the transitions as HER
    stores them: next achieved goal, desired goal, info, reward, terminated."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    out = []
    for _ in range(steps):
        a = rng.uniform(-1.0, 1.0, env.action_space.shape)
        if rng.random() < 0.3:
            a = np.sign(a)
        obs, r, term, trunc, info = env.step(a)
        out.append((obs["achieved_goal"], obs["desired_goal"], info, r, term))
        if term or trunc:
            obs, _ = env.reset()
    return out


@pytest.mark.parametrize("robot,task,mode", CASES)
def test_spaces_and_check_env(robot, task, mode):
    env = make(robot, task, mode)
    space = env.observation_space
    assert isinstance(space, spaces.Dict)
    assert set(space) == {"observation", "achieved_goal", "desired_goal"}
    dim = 2 if task == "navigate" else 4
    assert space["achieved_goal"].shape == space["desired_goal"].shape == (dim,)
    plain = gym.make(env_id(robot), task=task, **({} if mode is None else {"action_mode": mode}))
    assert space["observation"] == plain.observation_space
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=1)
    plain_obs, _ = plain.reset(seed=1)
    np.testing.assert_array_equal(obs["observation"], plain_obs)  # the plain observation
    pose, goal = env.unwrapped.core.pose[0], env.unwrapped.core.task.goal[0]
    # one dtype in the whole Dict space (float32), the goals the float64 state rounded
    assert {s.dtype for s in space.values()} == {np.dtype(np.float32)}
    assert {v.dtype for v in obs.values()} == {np.dtype(np.float32)}
    np.testing.assert_array_equal(obs["achieved_goal"][:2], pose[:2].astype(np.float32))
    np.testing.assert_array_equal(obs["desired_goal"][:2], goal[:2].astype(np.float32))
    if dim == 4:
        np.testing.assert_allclose(obs["achieved_goal"][2:], [np.cos(pose[2]), np.sin(pose[2])],
                                   rtol=0, atol=1e-7)


@pytest.mark.parametrize("robot,task,mode", CASES)
def test_her_reward_equals_step_reward(robot, task, mode):
    env = make(robot, task, mode)
    data = rollout(env, 400)
    u = env.unwrapped
    for ag, dg, info, r, term in data:  # one transition at a time
        assert abs(u.compute_reward(ag, dg, info) - r) < ATOL
        assert u.compute_terminated(ag, dg, info) == term
        assert u.compute_truncated(ag, dg, info) is False
    # batched as HerReplayBuffer calls it: (batch, goal_dim) and an object array of infos
    ag = np.array([d[0] for d in data])
    dg = np.array([d[1] for d in data])
    infos = np.array([d[2] for d in data], dtype=object)
    rew = np.array([d[3] for d in data])
    np.testing.assert_allclose(u.compute_reward(ag, dg, infos), rew, rtol=0, atol=ATOL)
    np.testing.assert_array_equal(u.compute_terminated(ag, dg, list(infos)),
                                  [d[4] for d in data])
    assert u.compute_truncated(ag, dg, infos).shape == (len(data),)
    # relabelled with the achieved goal itself: success (unless failure or collision)
    succ = u.compute_reward(ag, ag, infos)
    w = u.core.task.weights["success"]
    allowed = np.array([i["success_allowed"] for i in infos])
    assert np.all(succ[allowed] > rew[allowed] - 1e-9)
    assert np.all(u.compute_terminated(ag, ag, infos)[allowed])
    assert w > 0


def test_success_terminates_and_matches():
    env = make("ThreeWheel", "goal", "velocity")
    obs, _ = env.reset(seed=0, options={"start": (0.0, 0.0, 0.0), "goal": (0.02, 0.0, 0.05)})
    obs, r, term, _, info = env.step(np.zeros(env.action_space.shape))
    assert term and info["is_success"]
    u = env.unwrapped
    assert u.compute_terminated(obs["achieved_goal"], obs["desired_goal"], info)
    assert abs(u.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) - r) < ATOL
    far = obs["desired_goal"] + np.array([1.0, 0.0, 0.0, 0.0])
    assert not u.compute_terminated(obs["achieved_goal"], far, info)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP],
                         ids=["next_step", "same_step"])
@pytest.mark.parametrize("robot,task,amode", CASES[::2])
def test_vector_matches_single_bit_for_bit(robot, task, amode, mode):
    kw = {"task": task, "goal_conditioned": True, "max_episode_steps": 60}
    if amode is not None:
        kw["action_mode"] = amode
    eid = env_id(robot)
    n = 3
    vec = gym.make_vec(eid, num_envs=n, vectorization_mode="vector_entry_point",
                       autoreset_mode=mode, **kw)
    ref = SyncVectorEnv([lambda: gym.make(eid, **kw) for _ in range(n)], autoreset_mode=mode)
    assert vec.single_observation_space == ref.single_observation_space
    assert vec.observation_space == ref.observation_space
    rng = np.random.default_rng(5)
    assert_same(vec.reset(seed=5), ref.reset(seed=5), "reset")
    ends = 0
    for t in range(150):
        a = rng.uniform(-1.3, 1.3, vec.action_space.shape)
        a[rng.random(n) < 0.3] = 1.0
        a = a.astype(np.float32)
        out = vec.step(a)
        assert_same(out, ref.step(a), f"step {t}")
        ends += int((out[2] | out[3]).sum())
        obs, rew, info = out[0], out[1], out[4]
        stepped = ~np.isin(np.arange(n), np.flatnonzero(info["task"]["_name"])) \
            if "task" in info else np.ones(n, bool)
        c = vec.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        np.testing.assert_allclose(c[stepped], rew[stepped], rtol=0, atol=ATOL)
    assert ends > 0


@pytest.mark.slow  # torch import and SAC's first updates: up to a minute on a busy machine
def test_sb3_her_replay_buffer_runs():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import SAC, HerReplayBuffer

    from wheelgym.vector import make_sb3_vec_env

    venv = make_sb3_vec_env(env_id("ThreeWheel"), num_envs=2, seed=0, task="goal",
                            action_mode="velocity", goal_conditioned=True, max_episode_steps=50)
    obs = venv.reset()
    assert set(obs) == {"observation", "achieved_goal", "desired_goal"}
    model = SAC("MultiInputPolicy", venv, learning_starts=120, batch_size=32, seed=0,
                policy_kwargs={"net_arch": [16, 16]}, replay_buffer_class=HerReplayBuffer,
                replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future",
                                      "copy_info_dict": True})
    model.learn(300)
    buf = model.replay_buffer
    # the adapter answers env_method("compute_reward") through the batched env
    n = buf.pos
    ag = buf.next_observations["achieved_goal"][:n, 0]
    dg = buf.observations["desired_goal"][:n, 0]
    r = venv.env_method("compute_reward", ag, dg, buf.infos[:n, 0], indices=[0])[0]
    np.testing.assert_allclose(r, buf.rewards[:n, 0], rtol=0, atol=1e-5)  # float32 store


def test_bad_values_raise():
    with pytest.raises(TypeError, match="goal_conditioned"):
        gym.make(env_id("ThreeWheel"), goal_conditioned="yes")
    with pytest.raises(ValueError, match="goal_conditioned"):
        gym.make(env_id("ThreeWheel"), task="track", goal_conditioned=True)
    with pytest.raises(ValueError, match="goal_conditioned"):
        gym.make_vec(env_id("ThreeWheel"), num_envs=2, vectorization_mode="vector_entry_point",
                     task="track", goal_conditioned=True)
    env = make("ThreeWheel", "goal", None)
    env.reset(seed=0)
    u = env.unwrapped
    with pytest.raises(ValueError, match="achieved_goal"):
        u.compute_reward(np.zeros(3), np.zeros(3), {})
    assert not hasattr(gym.make(env_id("ThreeWheel")).unwrapped, "compute_reward")


def test_baseline_takes_the_dict_observation():
    """The evaluation loop hands the baseline the Dict observation: one action of the action
    space's shape for a single env (not a batch of one)."""
    import wheelgym

    env = gym.make("wheelgym/Bicycle-v0", task="goal", action_mode="VehicleSpeedSteeringAngle",
                   goal_conditioned=True)
    obs, _ = env.reset(seed=0)
    policy = wheelgym.baseline(env)
    for _ in range(5):
        action, _ = policy.predict(obs)
        assert action.shape == env.action_space.shape
        obs, *_ = env.step(action)


# ---------------------------------------------------------------- goal_free_observation
@pytest.mark.parametrize("robot,task,mode", CASES)
def test_goal_free_observation_drops_the_goal_entries(robot, task, mode):
    """The kept columns are the plain observation's minus the task's goal entries (the history's
    copies too), in order, and their bounds come with them."""
    kw = {"obs_history": 1}
    free = make(robot, task, mode, goal_free_observation=True, **kw)
    full = make(robot, task, mode, **kw)
    names = full.unwrapped.core.obs_names
    goal = set(full.unwrapped.core.task.goal_entries)
    keep = [i for i, n in enumerate(names) if n.removeprefix("prev_obs_1_") not in goal]
    assert 0 < len(keep) < len(names) - len(goal)  # the history's goal entries left out too
    box, ref = free.observation_space["observation"], full.observation_space["observation"]
    np.testing.assert_array_equal(box.low, ref.low[keep])
    np.testing.assert_array_equal(box.high, ref.high[keep])
    check_env(free.unwrapped, skip_render_check=True)
    rng = np.random.default_rng(3)
    o1, _ = free.reset(seed=3)
    o2, _ = full.reset(seed=3)
    for _ in range(20):
        np.testing.assert_array_equal(o1["observation"], o2["observation"][keep])
        np.testing.assert_array_equal(o1["desired_goal"], o2["desired_goal"])
        a = rng.uniform(-1.0, 1.0, free.action_space.shape)
        o1, *_ = free.step(a)
        o2, *_ = full.step(a)


def test_goal_free_observation_does_not_see_the_goal():
    """Two goals from the same start: the 'observation' key is the same bits under the same
    actions (HER's relabelled goal reaches the policy only as desired_goal), while the plain
    observation differs."""
    start = (0.0, 0.0, 0.0)
    for free, differs in ((True, False), (False, True)):
        kw = {"goal_free_observation": True} if free else {}
        a_env, b_env = (make("ThreeWheel", "goal", "velocity", **kw) for _ in range(2))
        oa, _ = a_env.reset(seed=0, options={"start": start, "goal": (2.0, 1.0, 0.5)})
        ob, _ = b_env.reset(seed=0, options={"start": start, "goal": (-1.0, 2.0, -1.0)})
        assert not np.array_equal(oa["desired_goal"], ob["desired_goal"])
        for t in range(10):
            assert (not np.array_equal(oa["observation"], ob["observation"])) == differs, t
            a = np.full(a_env.action_space.shape, 0.3)
            oa, *_ = a_env.step(a)
            ob, *_ = b_env.step(a)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP],
                         ids=["next_step", "same_step"])
def test_goal_free_observation_vector_matches_single(mode):
    kw = {"task": "goal", "action_mode": "velocity", "goal_conditioned": True,
          "goal_free_observation": True, "max_episode_steps": 40}
    eid, n = env_id("ThreeWheel"), 3
    vec = gym.make_vec(eid, num_envs=n, vectorization_mode="vector_entry_point",
                       autoreset_mode=mode, **kw)
    ref = SyncVectorEnv([lambda: gym.make(eid, **kw) for _ in range(n)], autoreset_mode=mode)
    assert vec.single_observation_space == ref.single_observation_space
    rng = np.random.default_rng(7)
    assert_same(vec.reset(seed=7), ref.reset(seed=7), "reset")
    for t in range(90):
        a = rng.uniform(-1.0, 1.0, vec.action_space.shape).astype(np.float32)
        assert_same(vec.step(a), ref.step(a), f"step {t}")


def test_goal_free_observation_bad_values_raise():
    with pytest.raises(ValueError, match="goal_free_observation needs goal_conditioned"):
        gym.make(env_id("ThreeWheel"), task="goal", goal_free_observation=True)
    with pytest.raises(TypeError, match="goal_free_observation must be a bool"):
        make("ThreeWheel", "goal", None, goal_free_observation=1)
    with pytest.raises(ValueError, match="waypoint_hint"):
        gym.make("wheelgym/ThreeWheel-v1", task="navigate", goal_conditioned=True,
                 waypoint_hint=True, goal_free_observation=True)


# ---------------------------------------------------------------- relabel_observation
GOAL_CASES = [c for c in CASES if c[1] == "goal"]


@pytest.mark.parametrize("robot,task,mode", GOAL_CASES)
def test_relabel_observation_is_the_kernels_observation(robot, task, mode):
    """Independent of the NumPy formula: the same start with another goal, reset through the
    compiled kernel, observes what relabelling the first observation for that goal gives; with
    the episode's own goal relabelling changes nothing (to the goals' float32 rounding)."""
    env = make(robot, task, mode)
    u = env.unwrapped
    start, g1, g2 = np.array([0.3, -0.2, 0.7]), np.array([2.0, 1.0, -2.5]), \
        np.array([-1.5, 2.2, 3.0])
    o1, _ = env.reset(seed=0, options={"start": start, "goal": g1})
    o2, _ = env.reset(seed=0, options={"start": start, "goal": g2})
    got = u.relabel_observation(o1["observation"], o1["achieved_goal"], o2["desired_goal"])
    assert got.dtype == np.float32 and not np.array_equal(o1["observation"], o2["observation"])
    np.testing.assert_allclose(got, o2["observation"], atol=1e-6)
    obs, _ = env.reset(seed=3)
    for _ in range(60):  # moving, with the episode's own goal
        obs, *_ = env.step(0.5 * np.ones(env.action_space.shape))
        np.testing.assert_allclose(
            u.relabel_observation(obs["observation"], obs["achieved_goal"],
                                  obs["desired_goal"]), obs["observation"], atol=1e-6)
    # batched over leading axes, the single env's rows; the vector env gives the same
    vec = gym.make_vec(env_id(robot), num_envs=2, vectorization_mode="vector_entry_point",
                       task=task, goal_conditioned=True,
                       **({} if mode is None else {"action_mode": mode}))
    O = np.stack([o1["observation"]] * 3)
    A = np.stack([o1["achieved_goal"]] * 3)
    G = np.stack([o1["desired_goal"], o2["desired_goal"], o1["desired_goal"]])
    batch = u.relabel_observation(O, A, G)
    np.testing.assert_array_equal(batch[1], got)
    np.testing.assert_array_equal(vec.unwrapped.relabel_observation(O, A, G), batch)


def test_relabel_observation_refuses_what_it_cannot_recompute():
    base = {"task": "goal", "action_mode": "velocity", "goal_conditioned": True}
    for kw, match in (({"goal_free_observation": True}, "goal_free_observation=False"),
                      ({"obs_history": 2}, "obs_history"),
                      ({"obs_noise": 0.01}, "obs_noise"),
                      ({"perturbation": "easy"}, "obs_noise, perturbation obs_dropped")):
        env = gym.make(env_id("ThreeWheel"), **base, **kw)
        obs, _ = env.reset(seed=0)
        with pytest.raises(ValueError, match=match):
            env.unwrapped.relabel_observation(obs["observation"], obs["achieved_goal"],
                                              obs["desired_goal"])
    nav = make("DiffDrive", "navigate", None)
    obs, _ = nav.reset(seed=0)
    with pytest.raises(ValueError, match="navigate task's observation entries"):
        nav.unwrapped.relabel_observation(obs["observation"], obs["achieved_goal"],
                                          obs["desired_goal"])
    env = make("ThreeWheel", "goal", "velocity")
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match="observation must have shape"):
        env.unwrapped.relabel_observation(obs["observation"][:-1], obs["achieved_goal"],
                                          obs["desired_goal"])
