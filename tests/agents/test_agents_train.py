"""Training and evaluation smoke tests: train, save, reload, resume, evaluate, Ctrl-C."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

from wheelgym.agents.config import parse_config  # noqa: E402
from wheelgym.agents.evaluate import METRICS, evaluate_run  # noqa: E402
from wheelgym.agents.pipeline import migrate  # noqa: E402
from wheelgym.agents.policies import load_agent  # noqa: E402
from wheelgym.agents.train import latest_model, resume, train  # noqa: E402

ENV_ID = "wheelgym/ThreeWheel-v0"
ENV_KWARGS = {"task": "goal", "action_mode": "velocity"}


def tiny_config(**wheelgym_block) -> dict:
    """A tiny PPO config; the keyword arguments go into its ``wheelgym`` block, where the flat
    recipe keys of old (``clone_baseline=...``, ``mean_bound=...``) are written in the pipeline
    spelling (:func:`wheelgym.agents.pipeline.migrate`)."""
    return migrate(tiny_config_flat(**wheelgym_block))


def tiny_config_flat(**wheelgym_block) -> dict:
    """:func:`tiny_config` with the keyword arguments as given (old flat keys kept)."""
    return {
        ENV_ID: {
            "policy": "MlpPolicy",
            "n_envs": 2,
            "n_timesteps": 1024,
            "normalize": True,
            "n_steps": 256,
            "batch_size": 128,
            "n_epochs": 2,
            "policy_kwargs": {"net_arch": [16, 16]},
        },
        "wheelgym": {"algo": "ppo", "env_kwargs": dict(ENV_KWARGS), "seed": 0,
                     "eval_freq": 512, "eval_episodes": 1, "checkpoint_freq": 512,
                     **wheelgym_block},
    }


def tiny_sac_config(**wheelgym_block) -> dict:
    """:func:`tiny_config` switched to SAC (PPO's rollout keys removed)."""
    data = tiny_config_flat(algo="sac", **wheelgym_block)
    for k in ("n_steps", "n_epochs"):
        del data[ENV_ID][k]
    return migrate(data)


def _finite_csv_numbers(path: Path) -> list[float]:
    with path.open() as f:
        rows = list(csv.reader(f))
    values = [float(c) for r in rows[1:] for c in r[1:] if c != ""]
    assert values and all(math.isfinite(v) for v in values), rows
    return values


def test_train_save_reload_resume_evaluate(tmp_path):
    cfg = parse_config(tiny_config())
    res = train(cfg, runs_root=tmp_path, progress=False)
    run = res.run_dir
    assert res.status == "finished" and res.timesteps == 1024
    for name in ("config.yml", "model.zip", "vecnormalize.pkl", "eval.csv", "run.json",
                 "best_model.zip"):
        assert (run / name).is_file(), name
    assert any((run / "checkpoints").glob("ckpt_*_steps.zip"))
    assert any((run / "tb").rglob("events.out.tfevents*"))
    assert json.loads((run / "run.json").read_text())["status"] == "finished"
    # The saved config is the one used and loads back.
    assert yaml.safe_load((run / "config.yml").read_text())["wheelgym"]["seed"] == 0

    # Reload: same deterministic actions as the in-memory model would give.
    agent = load_agent(run / "model.zip", "ppo", run / "vecnormalize.pkl")
    obs = np.zeros(agent.model.observation_space.shape, dtype=np.float32)
    a1, _ = agent.predict(obs)
    a2, _ = agent.predict(obs)
    assert np.array_equal(a1, a2) and np.all(np.abs(a1) <= 1)

    # A second run of the same config never reuses the folder.
    res_b = train(cfg, runs_root=tmp_path, progress=False, total_timesteps=512)
    assert res_b.run_dir != run

    # Resume continues the same run up to a new total.
    res2 = resume(run, total_timesteps=1536, progress=False)
    assert res2.run_dir == run and res2.timesteps == 1536
    assert len(json.loads((run / "run.json").read_text())["resumed_from"]) == 1
    with (run / "eval.csv").open() as f:
        steps = [int(r["timesteps"]) for r in csv.DictReader(f)]
    assert steps == sorted(steps) and steps[-1] == 1536

    ev = evaluate_run(run, episodes=2)
    for name in ("results.md", "results.csv", "episodes.csv", "trajectories.png", "torques.png"):
        p = ev.files[name]
        assert p.is_file() and p.stat().st_size > 0, name
    assert ev.files["trajectories.png"].read_bytes()[:4] == b"\x89PNG"
    values = _finite_csv_numbers(ev.files["results.csv"])
    assert len(values) >= 3
    table = ev.files["results.md"].read_text()
    assert "| agent (PPO) |" in table and "| random |" in table and "| baseline |" in table
    for attr, header, _ in METRICS:  # goal task: no RMS tracking error column
        assert (header in table) == (attr != "rms_tracking_error"), header
    assert "nan" not in table.lower()
    # Same seeds for every policy.
    seeds = {name: [e.seed for e in eps] for name, eps in ev.episodes.items()}
    assert len({tuple(s) for s in seeds.values()}) == 1
    # A second evaluation never overwrites the first.
    ev2 = evaluate_run(run, episodes=1, include_baseline=False, include_random=False)
    assert ev2.out_dir != ev.out_dir


def test_run_dir_is_never_overwritten(tmp_path):
    cfg = parse_config(tiny_config(eval_freq=0, checkpoint_freq=0))
    target = tmp_path / "run"
    target.mkdir()
    (target / "model.zip").write_text("someone else's")
    with pytest.raises(ValueError, match="not empty"):
        train(cfg, run_dir=target, progress=False)
    assert (target / "model.zip").read_text() == "someone else's"


def train_and_interrupt(cfg_path: Path, run: Path, status: str) -> None:
    """``wheelgym train cfg_path --run-dir run`` in a subprocess, sent SIGINT (as Ctrl-C) once
    its run.json says ``status`` (the SIGINT handler is then in place; a cold numba cache can
    take a while); it must exit with 130."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "wheelgym.cli", "train", str(cfg_path), "--run-dir", str(run),
         "--no-progress"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None:
            info = run / "run.json"
            if info.is_file() and json.loads(info.read_text()).get("status") == status:
                break
            time.sleep(0.2)
        time.sleep(1.5)
        assert proc.poll() is None, proc.stdout.read()
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, out


def test_sigint_leaves_a_loadable_model(tmp_path):
    cfg_path = tmp_path / "c.yml"
    data = tiny_config(eval_freq=0, checkpoint_freq=0)
    data[ENV_ID]["n_timesteps"] = 10_000_000
    cfg_path.write_text(yaml.safe_dump(data))
    run = tmp_path / "run"
    train_and_interrupt(cfg_path, run, "running")
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "interrupted"
    model_path, stats = latest_model(run)
    agent = load_agent(model_path, "ppo", stats)
    assert agent.obs_norm is not None
    assert 0 < agent.model.num_timesteps < 10_000_000


@pytest.mark.parametrize("vec_env", ["native", "dummy"])
def test_reward_schedule_changes_the_training_envs_weights(tmp_path, vec_env):
    # success 10 -> 25 at step 512, effort from its default 0.01 to 0.5 at step 768
    schedule = {"success": [[0, 10.0], [512, 25.0]], "effort": [[768, 0.5]]}
    cfg = parse_config(tiny_config(vec_env=vec_env, reward_schedule=schedule))
    assert cfg.to_dict()["wheelgym"]["pipeline"] == [{"stage": "rl",
                                                      "reward_schedule": schedule}]
    res = train(cfg, runs_root=tmp_path, progress=False)
    assert res.status == "finished"
    with (res.run_dir / "reward_weights.csv").open() as f:
        rows = [(int(r["timesteps"]), r["term"], float(r["weight"])) for r in csv.DictReader(f)]
    # n_envs 2: the callback sees every second step; the weights the envs hold after each change
    assert rows == [(0, "success", 10.0), (512, "success", 25.0),
                    (768, "effort", 0.5), (768, "success", 25.0)]
    # a resumed run starts with the weights of its step, not the env's defaults
    resume(res.run_dir, total_timesteps=1280, progress=False)
    with (res.run_dir / "reward_weights.csv").open() as f:
        tail = list(csv.DictReader(f))[-2:]
    assert [(int(r["timesteps"]), r["term"], float(r["weight"])) for r in tail] == [
        (1024, "effort", 0.5), (1024, "success", 25.0)]


def test_reward_schedule_is_checked(tmp_path):
    with pytest.raises(ValueError, match="steps must increase"):
        parse_config(tiny_config(reward_schedule={"success": [[512, 1.0], [0, 2.0]]}))
    with pytest.raises(ValueError, match=r"\[step >= 0"):
        parse_config(tiny_config(reward_schedule={"success": [[-1, 1.0]]}))
    with pytest.raises(ValueError, match="finite"):
        parse_config(tiny_config(reward_schedule={"success": [[0, float("nan")]]}))
    # a term the env does not have: refused before a run folder is made, naming the terms
    cfg = parse_config(tiny_config(reward_schedule={"lost": [[0, 1.0]]}))
    with pytest.raises(ValueError, match=r"\['lost'\].*valid terms: \['progress'"):
        train(cfg, runs_root=tmp_path, progress=False)
    assert not any(tmp_path.iterdir())
