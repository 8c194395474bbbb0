"""``wheelgym export``: a trained agent's deterministic policy, normalisation included, as one
ONNX graph whose ONNX Runtime actions match SB3's ``predict(deterministic=True)`` to 1e-5 on
1,000 observations, for one agent of each algorithm and action space: the shipped PPO agents
(with and without ``mean_bound``), and small trained SAC, TD3 and SAC + HER (Dict
observation) runs. The snippet of docs/topics/export.md runs with torch unavailable."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")
pytest.importorskip("onnx")
pytest.importorskip("onnxscript")
ort = pytest.importorskip("onnxruntime")

from wheelgym.agents.export import (  # noqa: E402
    check_export,
    export_onnx,
    load_source,
    onnx_actions,
    sample_observations,
)
from wheelgym.cli import main  # noqa: E402

DOC = Path(__file__).resolve().parents[2] / "docs" / "topics" / "export.md"
TOL = 1e-5
N_OBS = 1000


def _observations(agent, config, n: int = N_OBS, seed: int = 0):
    """Half from the agent's own rollouts in its env (resets included), half drawn from the
    observation space (far out, where the normalisation clips)."""
    from wheelgym.agents.common import make_single_env

    env = make_single_env(config)
    rows = []
    obs, _ = env.reset(seed=seed)
    while len(rows) < n // 2:
        rows.append(obs)
        action = agent.predict(obs, deterministic=True)[0]
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            obs, _ = env.reset()
    env.close()
    drawn = sample_observations(agent, n - len(rows), seed=seed)
    if isinstance(obs, dict):
        return {k: np.concatenate([np.stack([r[k] for r in rows]), drawn[k]]).astype(
            drawn[k].dtype) for k in drawn}
    return np.concatenate([np.stack(rows), drawn]).astype(drawn.dtype)


def _same_actions(path: Path, agent, config) -> float:
    obs = _observations(agent, config)
    err = check_export(path, agent, obs)
    assert err <= TOL, err
    return err


@pytest.fixture(scope="module")
def shipped(tmp_path_factory):
    """The shipped ThreeWheel goal/torque agent (PPO, ``mean_bound``, normalised), exported."""
    path = tmp_path_factory.mktemp("onnx") / "policy.onnx"
    res = export_onnx("ThreeWheel-goal-torque", path)
    return res, load_source("ThreeWheel-goal-torque")


def test_shipped_ppo_agent_matches_sb3(shipped):
    res, (agent, config, _) = shipped
    assert type(agent.model.policy).__name__ == "BoundedMeanPolicy"
    assert agent.obs_norm is not None and agent.obs_norm.norm_obs
    _same_actions(res.path, agent, config)
    # one file, its metadata, a dynamic batch axis
    assert [p.name for p in res.path.parent.iterdir()] == ["policy.onnx"]
    session = ort.InferenceSession(str(res.path), providers=["CPUExecutionProvider"])
    meta = session.get_modelmeta().custom_metadata_map
    assert meta["wheelgym.env_id"] == config.env_id == "wheelgym/ThreeWheel-v0"
    assert json.loads(meta["wheelgym.env_kwargs"]) == config.env_kwargs
    assert meta["wheelgym.algo"] == "ppo" and json.loads(meta["wheelgym.inputs"]) == ["obs"]
    assert res.inputs == {"obs": ("float32", (13,))} and res.action_dim == 6
    one = sample_observations(agent, 1, seed=3)
    np.testing.assert_allclose(onnx_actions(res.path, one)[0],
                               agent.predict(one[0], deterministic=True)[0], rtol=0, atol=TOL)


def test_normalisation_is_in_the_graph(shipped):
    """The same network without the statistics gives other actions: the graph holds them."""
    res, (agent, config, _) = shipped
    obs = sample_observations(agent, 200, seed=1)
    raw = agent.model.predict(obs, deterministic=True)[0]  # no normalisation
    assert np.max(np.abs(onnx_actions(res.path, obs) - raw)) > 0.1


def test_docs_snippet_runs_without_torch(shipped, tmp_path):
    res, _ = shipped
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)
    assert len(blocks) == 1
    (tmp_path / "policy.onnx").write_bytes(res.path.read_bytes())
    guard = ("import sys\n"
             "for _m in ('torch', 'stable_baselines3'):\n"
             "    sys.modules[_m] = None  # import fails: the snippet must not need them\n")
    script = tmp_path / "snippet.py"
    script.write_text(guard + blocks[0])
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600,
                          env={**__import__("os").environ, "PYTHONPATH": str(root)})
    assert done.returncode == 0, done.stderr[-2000:]
    assert re.search(r"ThreeWheel-goal-torque: return -?\d+\.\d+ in \d+ steps, success",
                     done.stdout), done.stdout


def test_cli_export_and_check(tmp_path, capsys):
    out = tmp_path / "a.onnx"
    assert main(["export", "configs/DiffDrive-goal-WheelSpeeds.yml", "--onnx", str(out),
                 "--check", "300"]) == 0
    text = capsys.readouterr().out
    assert "PPO agent DiffDrive-goal-WheelSpeeds (wheelgym/DiffDrive-v0)" in text
    m = re.search(r"on 300 observations: max \|difference\| (\S+)", text)
    assert m and float(m.group(1)) <= TOL
    assert out.is_file()


@pytest.mark.parametrize("args, message", [
    (["no-such-agent", "--onnx", "x.onnx"], "neither a run folder nor a shipped agent"),
    (["ThreeWheel-goal-torque", "--onnx", "x.txt"], "must end in .onnx"),
    (["ThreeWheel-goal-torque", "--onnx", "nowhere/x.onnx"], "does not exist"),
    (["ThreeWheel-goal-torque", "--best", "--onnx", "x.onnx"], "--best applies to a run"),
])
def test_cli_errors(args, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["export", *args]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_a_folder_that_is_not_a_run(tmp_path, capsys):
    assert main(["export", str(tmp_path), "--onnx", str(tmp_path / "x.onnx")]) == 2
    assert "not a run folder" in capsys.readouterr().err


# ------------------------------------------------------------------------- slow: more agents
@pytest.mark.slow
def test_shipped_ppo_agent_without_mean_bound(tmp_path):
    agent, config, _ = load_source("CasterAGV-goal-torque")
    assert type(agent.model.policy).__name__ == "ActorCriticPolicy"
    res = export_onnx("CasterAGV-goal-torque", tmp_path / "p.onnx")
    _same_actions(res.path, agent, config)


ENV_ID = "wheelgym/DiffDrive-v0"


def _tiny_run(tmp_path: Path, algo: str, her: bool = False) -> Path:
    from wheelgym.agents.train import train

    hp = {"policy": "MultiInputPolicy" if her else "MlpPolicy", "n_envs": 2,
          "n_timesteps": 300, "normalize": True, "batch_size": 32, "learning_starts": 120,
          "policy_kwargs": {"net_arch": [16, 16]}}
    kwargs = {"task": "goal", "action_mode": "WheelSpeeds"}
    if her:
        hp.update(replay_buffer_class="HerReplayBuffer",
                  replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future",
                                        "copy_info_dict": True})
        kwargs.update(goal_conditioned=True, max_episode_steps=50)  # episodes end before 120
    data = {ENV_ID: hp, "wheelgym": {"algo": algo, "env_kwargs": kwargs, "seed": 0,
                                     "eval_freq": 10_000, "eval_episodes": 1,
                                     "checkpoint_freq": 0}}
    cfg = tmp_path / f"tiny-{algo}{'-her' if her else ''}.yml"
    cfg.write_text(yaml.safe_dump(data))
    result = train(cfg, run_dir=tmp_path / "run", progress=False)
    assert result.status == "finished"
    return result.run_dir


@pytest.mark.slow
@pytest.mark.parametrize("algo, her", [("sac", False), ("td3", False), ("sac", True)],
                         ids=["sac", "td3", "sac-her-dict"])
def test_trained_off_policy_runs(tmp_path, capsys, algo, her):
    run = _tiny_run(tmp_path, algo, her)
    out = tmp_path / "p.onnx"
    assert main(["export", str(run), "--onnx", str(out), "--check", "0"]) == 0
    agent, config, _ = load_source(run)
    assert agent.model.policy.squash_output  # the unscaling branch of the graph
    if her:
        session = ort.InferenceSession(str(out), providers=["CPUExecutionProvider"])
        assert [i.name for i in session.get_inputs()] == ["achieved_goal", "desired_goal",
                                                          "observation"]
    _same_actions(out, agent, config)
