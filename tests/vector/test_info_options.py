"""The vector env's info options for clients (``reward_terms``, ``reset_info``), the info value
types, ``vector_kwargs`` as Gymnasium takes them, and what skrl's ``wrap_env`` reads
(docs/topics/clients.md)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from tests.vector.conftest import assert_same, env_id
from wheelgym.vector import env as vector_env

ID = env_id("ThreeWheel")
SAME = AutoresetMode.SAME_STEP


def flatten(info: dict, reward_terms: str, reset_info: bool) -> dict:
    """What the options should make of a default (nested) info."""
    out = {}
    for k, v in info.items():
        if k in ("reward_terms", "_reward_terms"):
            if k == "reward_terms" and reward_terms == "flat":
                out.update({("_reward_" + n[1:]) if n.startswith("_") else "reward_" + n: x
                            for n, x in v.items()})
            if reward_terms == "nested":
                out[k] = v
        elif k in ("params", "_params", "task", "_task") and not reset_info:
            continue
        elif k == "final_info":
            out[k] = flatten(v, reward_terms, reset_info)
        else:
            out[k] = v
    return out


@pytest.mark.parametrize("reward_terms,reset_info",
                         [("flat", False), ("none", True), ("nested", False), ("flat", True)])
def test_options_only_reshape_the_info(reward_terms, reset_info):
    kw = {"num_envs": 3, "vectorization_mode": "vector_entry_point", "autoreset_mode": SAME,
          "max_episode_steps": 12}
    ref = gym.make_vec(ID, **kw)
    vec = gym.make_vec(ID, reward_terms=reward_terms, reset_info=reset_info, **kw)
    assert vec.reward_terms == reward_terms and vec.reset_info is reset_info
    o, i = vec.reset(seed=4)
    ro, ri = ref.reset(seed=4)
    assert_same((o, i), (ro, flatten(ri, reward_terms, reset_info)), "reset")
    rng = np.random.default_rng(0)
    ends = 0
    for t in range(40):
        a = rng.uniform(-1, 1, vec.action_space.shape)
        a[rng.random(3) < 0.3] = 1.0
        out, want = vec.step(a), ref.step(a)
        assert_same(out, (*want[:4], flatten(want[4], reward_terms, reset_info)), f"step {t}")
        ends += int((out[2] | out[3]).sum())
        if reward_terms == "flat":  # the flat terms add up to the reward (of the ended step:
            info = out[4]           # final_info, SAME_STEP's new episode has zero terms)
            terms = sum(v for k, v in info.items() if k.startswith("reward_"))
            if "final_info" in info:
                ended = info["_final_info"]
                final = sum(v for k, v in info["final_info"].items() if k.startswith("reward_"))
                terms = np.where(ended, final, terms)
            np.testing.assert_allclose(terms, out[1], rtol=0, atol=1e-12)
    assert ends >= 3


def test_flat_and_no_reset_info_keep_the_same_keys_at_every_reset_and_step():
    vec = gym.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point",
                       max_episode_steps=3, reward_terms="flat", reset_info=False)
    _, info = vec.reset(seed=0)
    keys = set(info)
    assert "reward_progress" in keys and "_reward_progress" in keys
    assert not {"params", "task", "reward_terms"} & keys
    for _ in range(8):  # NEXT_STEP autoresets on the way
        _, _, _, _, info = vec.step(np.zeros((2, 6)))
        assert set(info) == keys
        assert all(isinstance(v, np.ndarray) and v.dtype != object for v in info.values())


def test_bad_option_values():
    with pytest.raises(ValueError, match=r"reward_terms must be one of \['nested', 'flat'"):
        vector_env.ThreeWheelVectorEnv(num_envs=2, reward_terms="flattened")
    with pytest.raises(TypeError, match="reset_info must be a bool"):
        vector_env.ThreeWheelVectorEnv(num_envs=2, reset_info="no")


def test_single_env_info_values_have_dtypes():
    """Numbers are NumPy float64 scalars (TorchRL's info reader reads ``.dtype``); flags stay
    Python bools, which ``SyncVectorEnv`` batches into bool arrays (``np.bool_`` it would
    batch into object arrays)."""
    env = gym.make(ID)
    _, info = env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    for k in ("tracking_error", "energy", "electrical_power", "internal_force"):
        assert type(info[k]) is np.float64, k
    assert all(type(v) is np.float64 for v in info["reward_terms"].values())
    assert type(info["is_success"]) is bool
    sync = SyncVectorEnv([lambda: gym.make(ID) for _ in range(2)])
    sync.reset(seed=0)
    _, _, _, _, vinfo = sync.step(np.zeros((2, 6)))
    assert vinfo["tracking_error"].dtype == np.float64 and vinfo["is_success"].dtype == bool
    assert vinfo["reward_terms"]["progress"].dtype == np.float64


def test_vector_kwargs_as_gymnasium_takes_them():
    # Gymnasium passes vector_kwargs to SyncVectorEnv / AsyncVectorEnv ...
    sync = gym.make_vec(ID, num_envs=2, vectorization_mode="sync",
                        vector_kwargs={"autoreset_mode": SAME})
    assert isinstance(sync, SyncVectorEnv) and sync.metadata["autoreset_mode"] is SAME
    # ... and refuses them for a vector_entry_point, whose arguments are plain keywords
    with pytest.raises(gym.error.Error, match="only through kwargs"):
        gym.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point",
                     vector_kwargs={"autoreset_mode": SAME})
    native = gym.make_vec(ID, num_envs=2, autoreset_mode=SAME)  # (the default mode: native)
    assert isinstance(native.unwrapped, vector_env.ThreeWheelVectorEnv)
    assert native.metadata["autoreset_mode"] is SAME


@pytest.mark.parametrize("name", [n for n in vector_env.__all__ if n.endswith("VectorEnv")
                                  and n != "WheelVectorEnv"])
def test_direct_bases_name_a_gymnasium_class(name):
    """skrl's ``wrap_env(env)`` (``wrapper="auto"``) looks for ``gymnasium.*`` among the
    names of the env class's direct bases."""
    cls = getattr(vector_env, name)
    assert any(b.__module__.startswith("gymnasium.") for b in cls.__bases__)
    assert cls.__mro__[1] is vector_env.WheelVectorEnv
