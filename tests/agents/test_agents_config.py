"""Configs: every file in configs/ loads and builds; unknown keys and bad values are named."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")

from wheelgym.agents.common import algo_kwargs, build_model, make_train_env  # noqa: E402
from wheelgym.agents.config import (  # noqa: E402
    ALGOS,
    TrainConfig,
    default_config_path,
    load_config,
    parse_config,
)

CONFIGS = sorted((Path(__file__).resolve().parents[2] / "configs").glob("*.yml"))

BASE = {
    "wheelgym/ThreeWheel-v0": {
        "policy": "MlpPolicy",
        "n_envs": 2,
        "n_timesteps": 1000,
        "normalize": True,
        "n_steps": 64,
        "batch_size": 64,
        "learning_rate": "lin_0.001",
        "policy_kwargs": {"net_arch": [16, 16], "activation_fn": "tanh"},
    },
    "wheelgym": {"algo": "ppo", "env_kwargs": {"task": "goal"}, "seed": 3},
}


def _with(block: str, key: str, value) -> dict:
    data = copy.deepcopy(BASE)
    data[block][key] = value
    return data


def test_configs_exist_and_default_is_there():
    assert CONFIGS, "configs/ holds no YAML file"
    assert default_config_path().resolve() in [p.resolve() for p in CONFIGS]


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_every_config_loads_and_builds(path):
    cfg = load_config(path)
    assert cfg.algo in ALGOS and cfg.env_id.startswith("wheelgym/")
    assert cfg.task in ("goal", "track", "navigate") and cfg.action_mode is not None
    # RL Zoo layout: the env-id block alone is an rl_zoo3 hyperparams entry of plain values.
    raw = yaml.safe_load(path.read_text())
    assert set(raw) == {cfg.env_id, "wheelgym"}
    assert "n_timesteps" in raw[cfg.env_id] and "policy" in raw[cfg.env_id]
    venv = make_train_env(cfg)
    try:
        model = build_model(cfg, venv)
        assert model.observation_space.shape == venv.observation_space.shape
    finally:
        venv.close()


def test_round_trip_and_replace():
    cfg = parse_config(BASE)
    assert cfg.n_envs == 2 and cfg.normalize == {} and cfg.seed == 3
    assert parse_config(cfg.to_dict()) == cfg
    cfg2 = cfg.replace(seed=7, n_timesteps=5000)
    assert (cfg2.seed, cfg2.n_timesteps) == (7, 5000) and cfg.seed == 3
    kw = algo_kwargs(cfg)
    assert callable(kw["learning_rate"]) and kw["learning_rate"](0.5) == pytest.approx(5e-4)
    import torch

    assert kw["policy_kwargs"]["activation_fn"] is torch.nn.Tanh


@pytest.mark.parametrize(
    ("block", "key", "value", "named"),
    [
        ("wheelgym/ThreeWheel-v0", "lerning_rate", 0.001, "lerning_rate"),
        ("wheelgym", "sed", 1, "sed"),
        ("wheelgym/ThreeWheel-v0", "learning_rate", -1.0, "learning_rate"),
        ("wheelgym/ThreeWheel-v0", "learning_rate", "exp_0.1", "learning_rate"),
        ("wheelgym/ThreeWheel-v0", "n_envs", 0, "n_envs"),
        ("wheelgym/ThreeWheel-v0", "gamma", 1.5, "gamma"),
        ("wheelgym/ThreeWheel-v0", "n_steps", 2.5, "n_steps"),
        ("wheelgym/ThreeWheel-v0", "batch_size", 1, "batch_size"),
        ("wheelgym/ThreeWheel-v0", "policy", "CnnPolicy", "policy"),
        ("wheelgym/ThreeWheel-v0", "normalize", "dict(norm_obs=True)", "normalize"),
        ("wheelgym/ThreeWheel-v0", "policy_kwargs", "dict(net_arch=[64, 64])", "policy_kwargs"),
        ("wheelgym/ThreeWheel-v0", "policy_kwargs", {"net_arch": [64, "x"]}, "net_arch"),
        ("wheelgym/ThreeWheel-v0", "policy_kwargs", {"activation_fn": "nn.Tanh"},
         "activation_fn"),
        ("wheelgym/ThreeWheel-v0", "policy_kwargs", {"optimizer_class": "Adam"},
         "optimizer_class"),
        ("wheelgym/ThreeWheel-v0", "noise_type", "normal", "noise_type"),
        ("wheelgym", "algo", "dqn", "algo"),
        ("wheelgym", "vec_env", "threads", "vec_env"),
        ("wheelgym", "eval_episodes", 0, "eval_episodes"),
        ("wheelgym", "env_kwargs", ["goal"], "env_kwargs"),
    ],
)
def test_unknown_key_or_bad_value_is_named(block, key, value, named):
    with pytest.raises(ValueError, match=named):
        parse_config(_with(block, key, value), source="bad.yml")


def test_sac_keys_checked_per_algorithm():
    data = _with("wheelgym", "algo", "sac")
    with pytest.raises(ValueError, match="n_steps"):  # a PPO key in a SAC config
        parse_config(data)
    block = data["wheelgym/ThreeWheel-v0"]
    for k in ("n_steps", "batch_size"):
        block.pop(k)
    block.update(buffer_size=1000, train_freq=[1, "episode"], ent_coef="auto_0.1",
                 noise_type="normal", noise_std=0.1)
    cfg = parse_config(data)
    assert cfg.noise == ("normal", 0.1)
    block["ent_coef"] = "auto_x"
    with pytest.raises(ValueError, match="ent_coef"):
        parse_config(data)


def test_file_errors_are_value_errors(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        load_config(tmp_path / "missing.yml")
    p = tmp_path / "c.yml"
    p.write_text("wheelgym/ThreeWheel-v0: {n_timesteps: 10}\n")  # no wheelgym block
    with pytest.raises(ValueError, match="'wheelgym' block"):
        load_config(p)
    p.write_text("a: {n_timesteps: 10}\nb: {}\nwheelgym: {algo: ppo}\n")
    with pytest.raises(ValueError, match="exactly one env-id block"):
        load_config(p)
    p.write_text("wheelgym/ThreeWheel-v0: {n_timesteps: .nan}\nwheelgym: {algo: ppo}\n")
    with pytest.raises(ValueError, match="finite"):
        load_config(p)
    # YAML tags that build Python objects are not plain values: safe_load refuses them.
    p.write_text("wheelgym/ThreeWheel-v0: !!python/object/apply:os.getcwd []\n"
                 "wheelgym: {algo: ppo}\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_config(p)


def test_unregistered_env_id_is_named():
    data = copy.deepcopy(BASE)
    data["wheelgym/Nope-v0"] = data.pop("wheelgym/ThreeWheel-v0")
    cfg = parse_config(data)
    assert isinstance(cfg, TrainConfig)
    with pytest.raises(ValueError, match="Nope-v0"):
        make_train_env(cfg)


@pytest.mark.parametrize("vec_env", ["dummy", "native"])
@pytest.mark.parametrize(("env_kwargs", "named"), [({"task": "fly"}, "task"),
                                                   ({"tsk": "goal"}, "tsk")])
def test_bad_env_kwarg_is_named(vec_env, env_kwargs, named):
    data = _with("wheelgym", "env_kwargs", env_kwargs)
    data["wheelgym"]["vec_env"] = vec_env
    with pytest.raises(ValueError, match=named):
        make_train_env(parse_config(data))


@pytest.mark.parametrize("algo", ALGOS)
def test_each_algorithm_builds_and_steps(algo, tmp_path):
    block = {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 64, "normalize": True,
             "policy_kwargs": {"net_arch": [16, 16], "activation_fn": "relu"}}
    if algo in ("ppo", "a2c"):
        block.update(n_steps=16, learning_rate="lin_0.001")
    else:
        block.update(buffer_size=1000, learning_starts=16, batch_size=16, train_freq=[1, "step"],
                     noise_type="normal", noise_std=0.1)
    if algo == "ppo":
        block["batch_size"] = 16
    cfg = parse_config({"wheelgym/ThreeWheel-v0": block,
                        "wheelgym": {"algo": algo, "vec_env": "native",
                                     "env_kwargs": {"task": "goal", "action_mode": "velocity"}}})
    venv = make_train_env(cfg)
    model = build_model(cfg, venv)
    model.learn(64)
    assert model.num_timesteps >= 64
    if algo in ("sac", "td3"):
        assert model.action_noise is not None
    venv.close()


# --------------------------------------------------------------------------------------------
# YAML aliases (issue 14, item 10)
# --------------------------------------------------------------------------------------------


def _alias_bomb(levels: int = 9, width: int = 9) -> str:
    lines = ["a0: &a0 [" + ", ".join(["1"] * width) + "]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]"
              for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("text", [
    _alias_bomb() + "wheelgym: {algo: ppo}\n",  # 9^10 shared nodes
    "a: &a [*a]\nwheelgym: {algo: ppo}\n",  # recursive
    "wheelgym/ThreeWheel-v0: &b {n_timesteps: 10}\nwheelgym: {algo: ppo, env_kwargs: *b}\n",
    "d: &d {seed: 1}\nwheelgym: {<<: *d, algo: ppo}\n",  # merge key
], ids=["bomb", "recursive", "plain-alias", "merge-key"])
def test_yaml_aliases_are_refused_in_one_line(tmp_path, text):
    import time

    p = tmp_path / "alias.yml"
    p.write_text(text)
    t0 = time.perf_counter()
    with pytest.raises(ValueError) as e:
        load_config(p)
    assert time.perf_counter() - t0 < 2.0
    msg = str(e.value)
    assert msg.startswith(f"{p}: ") and "aliases are not allowed" in msg and "\n" not in msg


def test_config_yaml_loader_is_safe_load_without_aliases(tmp_path):
    from wheelgym.agents.config import safe_load_config_yaml

    for path in CONFIGS:  # every shipped config reads as yaml.safe_load reads it
        assert safe_load_config_yaml(path) == yaml.safe_load(path.read_text()), path
    p = tmp_path / "c.yml"
    p.write_text("x: !!python/name:os.system\n")  # safe_load's refusal of object tags stays
    with pytest.raises(ValueError, match="not valid YAML"):
        safe_load_config_yaml(p)
    p.write_text("anchor_only: &a 3\nb: [1, 2]\n")  # an anchor without alias is harmless
    assert safe_load_config_yaml(p) == {"anchor_only": 3, "b": [1, 2]}


@pytest.mark.parametrize("vec_env", ["dummy", "native"])
def test_train_env_kwargs_set_the_training_envs_only(vec_env):
    from wheelgym.agents.common import make_single_env
    from wheelgym.agents.store import config_digest

    data = _with("wheelgym", "env_kwargs", {"task": "goal", "perturbation": "medium"})
    data["wheelgym"]["vec_env"] = vec_env
    plain = parse_config(data)
    data["wheelgym"]["train_env_kwargs"] = {
        "perturbation": {"level": "medium", "action_delay": [0, 2]}}
    cfg = parse_config(data)
    assert plain.train_env_kwargs == {} and "train_env_kwargs" not in plain.to_dict()["wheelgym"]
    assert parse_config(cfg.to_dict()) == cfg and config_digest(cfg) != config_digest(plain)
    assert cfg.training_env_kwargs["perturbation"]["action_delay"] == [0, 2]
    assert cfg.training_env_kwargs["task"] == "goal"

    def delays(venv):
        if vec_env == "native":
            return venv.venv.venv.core.perturbation.action_delay
        return venv.venv.envs[0].unwrapped.core.perturbation.action_delay

    venv = make_train_env(cfg)
    try:
        assert delays(venv) == (0, 2)
    finally:
        venv.close()
    env = make_single_env(cfg)  # evaluation: the task's env
    assert env.unwrapped.core.perturbation.action_delay == (2, 2)
    env.close()


def test_train_env_kwargs_errors():
    data = _with("wheelgym", "train_env_kwargs", [1, 2])
    with pytest.raises(ValueError, match="train_env_kwargs must be a mapping"):
        parse_config(data)
    data = _with("wheelgym", "train_env_kwargs", {"task": "track"})
    with pytest.raises(ValueError, match=r"may not set \['task'\]"):
        parse_config(data)
    # another observation space than the task's: refused when the training envs are built
    cfg = parse_config(_with("wheelgym", "train_env_kwargs", {"action_history": 2}))
    with pytest.raises(ValueError, match="change the observation space"):
        make_train_env(cfg)
