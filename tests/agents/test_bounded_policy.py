"""BoundedMeanPolicy (``mean_bound`` in a config): the squashed Gaussian mean."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402

from tests.agents.test_agents_train import tiny_config, tiny_sac_config  # noqa: E402
from wheelgym.agents.benchmark import config_digest  # noqa: E402
from wheelgym.agents.bounded_policy import BoundedMeanPolicy  # noqa: E402
from wheelgym.agents.common import build_model, make_train_env  # noqa: E402
from wheelgym.agents.config import parse_config  # noqa: E402
from wheelgym.agents.policies import load_agent  # noqa: E402
from wheelgym.agents.train import train  # noqa: E402


def test_mean_bound_is_checked_and_written_only_when_set():
    plain = parse_config(tiny_config())
    assert plain.mean_bound is None
    assert "mean_bound" not in plain.to_dict()["wheelgym/ThreeWheel-v0"]["policy_kwargs"]
    cfg = parse_config(tiny_config(mean_bound=1.2))
    pk = cfg.to_dict()["wheelgym/ThreeWheel-v0"]["policy_kwargs"]
    assert cfg.mean_bound == 1.2 and pk["mean_bound"] == 1.2
    assert parse_config(cfg.to_dict()) == cfg
    assert config_digest(cfg) != config_digest(plain)  # a new setting: its own rows
    for bad in (0.9, -1.0, float("inf"), "1.1", True):
        with pytest.raises(ValueError, match="mean_bound"):
            parse_config(tiny_config(mean_bound=bad))
    sac = tiny_sac_config(mean_bound=1.1)
    with pytest.raises(ValueError, match=r"policy_kwargs unknown key 'mean_bound'"):
        parse_config(sac)
    sde = tiny_config(mean_bound=1.1)
    sde["wheelgym/ThreeWheel-v0"]["use_sde"] = True
    with pytest.raises(ValueError, match="without use_sde"):
        parse_config(sde)


def _model(bound: float):
    cfg = parse_config(tiny_config(mean_bound=bound)).replace(vec_env="dummy")
    venv = make_train_env(cfg)
    return build_model(cfg, venv), venv


def _raw_and_mean(model, obs):
    pol = model.policy
    with th.no_grad():
        features = pol.extract_features(obs, pol.pi_features_extractor)
        latent_pi = pol.mlp_extractor.forward_actor(features)
        raw = pol.action_net(latent_pi)
        mean = pol.get_distribution(obs).distribution.mean
    return raw, mean


def test_the_mean_is_squashed_and_the_noise_is_sb3s():
    model, venv = _model(1.2)
    pol = model.policy
    assert isinstance(pol, BoundedMeanPolicy) and pol.mean_bound == 1.2
    obs = th.as_tensor(np.random.default_rng(0).normal(
        size=(256, venv.observation_space.shape[0])).astype(np.float32))
    with th.no_grad():
        for p in pol.action_net.parameters():
            p.mul_(1e4)  # SB3 inits with gain 0.01: raw means of tens to hundreds
    raw, mean = _raw_and_mean(model, obs)
    assert raw.abs().max() > 50.0
    assert mean.abs().max() <= 1.2 and mean.abs().max() > 1.19
    th.testing.assert_close(mean, 1.2 * th.tanh(raw / 1.2))
    # log-probability: the diagonal Gaussian of that mean and SB3's state-independent std
    a = th.as_tensor(np.random.default_rng(1).uniform(-1, 1, size=mean.shape).astype(np.float32))
    with th.no_grad():
        _, logp, _ = pol.evaluate_actions(obs, a)
    std = th.exp(pol.log_std.detach())
    ref = (-0.5 * ((a - mean) / std) ** 2 - th.log(std) - 0.5 * math.log(2 * math.pi)).sum(1)
    th.testing.assert_close(logp, ref)
    with th.no_grad():
        for p in pol.action_net.parameters():
            p.mul_(1e-6)  # raw means near 0: the squash is the identity to first order
    raw, mean = _raw_and_mean(model, obs)
    th.testing.assert_close(mean, raw, rtol=1e-5, atol=1e-9)
    venv.close()


def test_policy_refuses_a_bound_below_the_box():
    model, venv = _model(1.1)
    with pytest.raises(ValueError, match="mean_bound must be a finite number >= 1"):
        BoundedMeanPolicy(venv.observation_space, venv.action_space, lambda _: 3e-4,
                          mean_bound=0.5)
    venv.close()


def test_a_bounded_run_saves_and_loads_its_policy(tmp_path):
    cfg = parse_config(tiny_config(mean_bound=1.3))
    res = train(cfg, runs_root=tmp_path, progress=False)
    assert res.status == "finished"
    written = yaml.safe_load((res.run_dir / "config.yml").read_text())
    assert written["wheelgym/ThreeWheel-v0"]["policy_kwargs"]["mean_bound"] == 1.3
    agent = load_agent(res.run_dir / "model.zip", "ppo", res.run_dir / "vecnormalize.pkl")
    pol = agent.model.policy
    assert isinstance(pol, BoundedMeanPolicy) and pol.mean_bound == 1.3
