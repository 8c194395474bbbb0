"""Shipped pretrained agents (``agents/pretrained/``): export from the benchmark CSV, load, act,
``wheelgym evaluate --pretrained``, ``wheelgym demo --agent``, the README's plain-SB3 snippet,
and every agent actually shipped."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402

from wheelgym import resources  # noqa: E402
from wheelgym.agents.benchmark import COLUMNS, read_rows, run_jobs  # noqa: E402
from wheelgym.agents.common import make_single_env  # noqa: E402
from wheelgym.agents.config import configs_dir, load_config  # noqa: E402
from wheelgym.agents.policies import load_agent  # noqa: E402
from wheelgym.agents.pretrained import (  # noqa: E402
    ROOT_ENV,
    SIZE_LIMIT_MB,
    available,
    best_row,
    export_best,
    load_pretrained,
    pretrained_root,
    read_card,
    slim_model,
)
from wheelgym.cli import main  # noqa: E402

#: The README snippet's agent: the tiny one trained here has its config (and name).
NAME = "ThreeWheel-goal-velocity"
README = Path(__file__).resolve().parents[2] / "README.md"


@pytest.fixture(scope="module")
def bench(tmp_path_factory) -> SimpleNamespace:
    """The real config, on a tiny budget: 2 seeds through the benchmark (real CSV rows, real
    run folders), exported into a temporary ``agents/pretrained``."""
    base = tmp_path_factory.mktemp("pretrained")
    config = load_config(configs_dir() / f"{NAME}.yml").replace(
        n_timesteps=512, n_envs=4, eval_freq=0, checkpoint_freq=0, eval_episodes=1)
    path = base / f"{NAME}.yml"
    config.dump(path)
    csv_path = base / "training.csv"
    summary = run_jobs([path], seeds=2, episodes=1, csv_path=csv_path, runs_root=base / "runs")
    assert summary.written == 2 and not summary.failed
    root = base / "agents" / "pretrained"
    written = export_best(csv_path, out_root=root)
    return SimpleNamespace(base=base, csv=csv_path, root=root, rows=read_rows(csv_path),
                           written=written)


def _acts(agent, config, steps: int = 5) -> None:
    env = make_single_env(config)
    try:
        obs, _ = env.reset(seed=0)
        for _ in range(steps):
            action, _ = agent.predict(obs, deterministic=True)
            action = np.asarray(action)
            assert action.shape == env.action_space.shape
            assert np.all(np.isfinite(action))
            obs, *_ = env.step(action)
    finally:
        env.close()


# --------------------------------------------------------------------------------------------
# export, load, act
# --------------------------------------------------------------------------------------------


def test_export_copies_the_best_seed_with_its_card(bench):
    assert bench.written == [bench.root / NAME]
    assert available(bench.root) == [NAME]
    best = best_row(bench.rows, NAME)
    folder = bench.root / NAME
    assert sorted(p.name for p in folder.iterdir()) == ["card.json", "config.yml", "model.zip",
                                                        "vecnormalize.pkl"]
    run = Path(best["run_dir"])
    # the weights as trained, byte for byte; the optimizer's moments left out (smaller file)
    with zipfile.ZipFile(folder / "model.zip") as shipped, \
            zipfile.ZipFile(run / "model.zip") as trained:
        assert shipped.namelist() == trained.namelist()
        for entry in trained.namelist():
            if entry != "policy.optimizer.pth":
                assert shipped.read(entry) == trained.read(entry), entry
        opt = th.load(io.BytesIO(shipped.read("policy.optimizer.pth")), weights_only=True)
        full = th.load(io.BytesIO(trained.read("policy.optimizer.pth")), weights_only=True)
        assert opt["state"] == {} and full["state"] and opt["param_groups"] == full[
            "param_groups"]
    assert (folder / "model.zip").stat().st_size < 0.6 * (run / "model.zip").stat().st_size
    trained_agent = load_agent(run / "model.zip", "ppo", run / "vecnormalize.pkl")
    obs = np.random.default_rng(0).normal(size=(8, trained_agent.model.observation_space.shape[0]))
    np.testing.assert_array_equal(load_pretrained(NAME, bench.root)[0].predict(obs)[0],
                                  trained_agent.predict(obs)[0])
    assert (folder / "vecnormalize.pkl").read_bytes() == (run / "vecnormalize.pkl").read_bytes()
    card = read_card(NAME, bench.root)
    assert card == json.loads((folder / "card.json").read_text())
    assert card["config"] == NAME and card["algo"] == "ppo" and card["normalize"] is True
    assert card["env_id"] == "wheelgym/ThreeWheel-v0"
    assert card["env_kwargs"] == {"task": "goal", "action_mode": "velocity"}
    assert card["seed"] == int(best["seed"]) and card["n_timesteps"] == 512
    assert card["csv"] == str(bench.csv) and card["finished_utc"] == best["finished_utc"]
    for col in ("agent_success", "baseline_success", "agent_return", "baseline_return",
                "agent_energy", "baseline_energy", "agent_internal_force",
                "baseline_internal_force", "agent_saturation", "baseline_saturation",
                "train_s"):
        assert card["scores"][col] == pytest.approx(float(best[col]))
    assert card["scores"]["agent_rms"] is None  # goal task: no RMS tracking error
    assert card["files"]["model.zip"] == (folder / "model.zip").stat().st_size
    assert not [p for p in bench.root.iterdir() if p.name.startswith(".")]  # no leftovers


def test_slim_model_empties_every_optimizer_of_a_sac_model(tmp_path):
    """SAC saves three optimizers (actor, critic, entropy coefficient): each loses its
    moments, the weights stay byte for byte, and SAC.load acts as the trained model did."""
    import gymnasium as gym
    from stable_baselines3 import SAC

    env = gym.make("wheelgym/DiffDrive-v0", task="goal")
    model = SAC("MlpPolicy", env, learning_starts=50, batch_size=16, seed=0,
                policy_kwargs={"net_arch": [8]})
    model.learn(80)
    model.save(tmp_path / "sac.zip")
    (tmp_path / "slim.zip").write_bytes(slim_model(tmp_path / "sac.zip"))
    with zipfile.ZipFile(tmp_path / "slim.zip") as slim, \
            zipfile.ZipFile(tmp_path / "sac.zip") as full:
        opts = [n for n in full.namelist() if n.endswith("optimizer.pth")]
        assert len(opts) == 3
        for entry in full.namelist():
            if entry in opts:
                a = th.load(io.BytesIO(slim.read(entry)), weights_only=True)
                b = th.load(io.BytesIO(full.read(entry)), weights_only=True)
                assert a["state"] == {} and b["state"], entry
                assert a["param_groups"] == b["param_groups"], entry
            else:
                assert slim.read(entry) == full.read(entry), entry
    obs = np.random.default_rng(0).normal(size=(4, env.observation_space.shape[0]))
    np.testing.assert_array_equal(
        SAC.load(tmp_path / "slim.zip").predict(obs, deterministic=True)[0],
        model.predict(obs, deterministic=True)[0])


def test_best_seed_order_success_then_rms_then_return():
    def row(seed, succ, rms, ret, steps=1000):
        return {"config": "c", "seed": str(seed), "n_timesteps": str(steps),
                "agent_success": succ, "agent_rms": rms, "agent_return": ret}

    rows = [row(0, "0.9", "", "50"), row(1, "1", "", "10"), row(2, "1", "", "12")]
    assert best_row(rows, "c")["seed"] == "2"  # success, then return
    rows = [row(0, "1", "0.02", "10"), row(1, "1", "0.01", "5"), row(2, "0.5", "0.001", "99")]
    assert best_row(rows, "c")["seed"] == "1"  # success, then the lower RMS before return
    rows = [row(0, "1", "", "10"), row(1, "1", "", "10")]
    assert best_row(rows, "c")["seed"] == "0"  # a full tie: the lower seed
    rows = [row(0, "0.5", "", "1", steps=100_000), row(1, "1", "", "9", steps=10_000)]
    assert best_row(rows, "c")["seed"] == "0"  # only the largest budget competes
    rows = [row(0, "", "", "3"), row(1, "0", "", "-3")]
    assert best_row(rows, "c")["seed"] == "1"  # a missing score ranks last


def test_a_perturbed_config_ranks_tied_seeds_by_the_nominal_robot():
    def row(seed, succ, ret, rms=""):
        return {"config": "c", "seed": str(seed), "n_timesteps": "1000",
                "agent_success": succ, "agent_rms": rms, "agent_return": ret}

    nominal = {"0": 0.9, "1": 0.86, "2": 1.0, "3": 1.0, "4": 1.0}
    asked: list[str] = []

    def score(r):
        asked.append(r["seed"])
        return nominal[r["seed"]]

    rows = [row(0, "1", "3"), row(1, "1", "9"), row(2, "0.9", "20"), row(3, "1", "1"),
            row(4, "1", "0")]
    assert best_row(rows, "c")["seed"] == "1"  # without it: the return
    scored: dict[str, float] = {}
    assert best_row(rows, "c", score, scored)["seed"] == "3"
    # the tied seeds in the order of the return, up to the first at 100%; seed 2 is not tied
    assert asked == ["1", "0", "3"] and scored == {"1": 0.86, "0": 0.9, "3": 1.0}
    asked.clear()
    rows = [row(0, "1", "3", "0.02"), row(1, "1", "9", "0.01")]
    assert best_row(rows, "c", score)["seed"] == "1" and asked == []  # no tie: nothing scored
    rows = [row(0, "1", "3"), row(1, "1", "9")]
    assert best_row(rows, "c", lambda r: 0.5)["seed"] == "1"  # equal: the return decides


def test_load_pretrained_acts_on_its_env(bench):
    agent, config = load_pretrained(NAME, bench.root)
    assert agent.obs_norm is not None and agent.obs_norm.training is False
    assert config.env_id == "wheelgym/ThreeWheel-v0" and config.algo == "ppo"
    _acts(agent, config)
    agent2, _ = load_pretrained(f"configs/{NAME}.yml", bench.root)  # a config path: its stem
    assert agent2.name == agent.name


def test_unknown_name_lists_the_available_ones(bench, tmp_path):
    with pytest.raises(ValueError, match=rf"no pretrained agent 'Nope'.*{NAME}"):
        load_pretrained("Nope", bench.root)
    with pytest.raises(ValueError, match="none shipped yet"):
        load_pretrained(NAME, tmp_path)
    with pytest.raises(ValueError, match="no pretrained agent"):
        load_pretrained("../runs", bench.root)


def test_missing_root_is_a_clear_error(monkeypatch, tmp_path):
    monkeypatch.delenv(ROOT_ENV, raising=False)
    pkg = tmp_path / "site-packages" / "wheelgym"  # an installed package without its data
    pkg.mkdir(parents=True)
    monkeypatch.setattr(resources, "package_root", lambda: pkg)
    with pytest.raises(ValueError, match="shipped pretrained agents are missing"):
        pretrained_root()
    with pytest.raises(ValueError, match="shipped pretrained agents are missing"):
        available()
    with pytest.raises(ValueError, match="--root FOLDER"):  # an export needs a folder then
        resources.pretrained_dir(for_writing=True)
    monkeypatch.setenv(ROOT_ENV, str(tmp_path / "nowhere"))
    with pytest.raises(ValueError, match="does not exist"):
        available()
    monkeypatch.setenv(ROOT_ENV, str(tmp_path))
    assert pretrained_root() == tmp_path and available() == []


def test_size_limit_is_refused_before_writing(bench, tmp_path):
    out = tmp_path / "agents"
    with pytest.raises(ValueError, match="over the 0.01 MB limit"):
        export_best(bench.csv, [NAME], out_root=out, size_limit_mb=0.01)
    assert not out.exists()
    # Agents kept in the folder count too.
    out.mkdir()
    (out / "Other").mkdir()
    (out / "Other" / "model.zip").write_bytes(b"\0" * 200_000)
    size = sum(p.stat().st_size for p in (bench.root / NAME).iterdir())
    with pytest.raises(ValueError, match="over the"):
        export_best(bench.csv, [NAME], out_root=out, size_limit_mb=(size + 100_000) / 1e6)
    assert sorted(p.name for p in out.iterdir()) == ["Other"]


def test_export_errors(bench, tmp_path):
    with pytest.raises(ValueError, match=rf"configs \['Nope'\] have no rows.*{NAME}"):
        export_best(bench.csv, ["Nope"], out_root=tmp_path / "a")
    # A row whose run folder is gone: refused, not silently replaced by another seed.
    moved = tmp_path / "moved.csv"
    with moved.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(COLUMNS))
        w.writeheader()
        for r in bench.rows:
            w.writerow({**r, "run_dir": str(tmp_path / "gone" / Path(r["run_dir"]).name)})
    with pytest.raises(ValueError, match="is the run folder on this machine"):
        export_best(moved, out_root=tmp_path / "b")
    assert not (tmp_path / "b").exists()


def test_export_replaces_its_folder_and_keeps_the_others(bench, tmp_path):
    out = tmp_path / "agents"
    (out / "Other").mkdir(parents=True)
    (out / NAME).mkdir()
    (out / NAME / "stale.txt").write_text("old")
    assert export_best(bench.csv, [f"configs/{NAME}.yml"], out_root=out) == [out / NAME]
    assert not (out / NAME / "stale.txt").exists() and (out / NAME / "model.zip").is_file()
    assert sorted(p.name for p in out.iterdir()) == sorted([NAME, "Other"])


# --------------------------------------------------------------------------------------------
# the command line
# --------------------------------------------------------------------------------------------


def test_cli_pretrained_export_and_list(bench, tmp_path, capsys):
    out = tmp_path / "agents"
    assert main(["pretrained", "export", NAME, "--csv", str(bench.csv), "--root", str(out)]) == 0
    assert f"{NAME}: seed" in capsys.readouterr().out
    assert available(out) == [NAME]
    assert main(["pretrained", "list", "--root", str(out)]) == 0
    assert f"{NAME}: PPO, seed" in capsys.readouterr().out
    assert main(["pretrained", "list", "--root", str(tmp_path)]) == 0
    assert "no pretrained agents" in capsys.readouterr().out
    assert main(["pretrained", "export", "Nope", "--csv", str(bench.csv), "--root",
                 str(out)]) == 2
    assert "have no rows" in capsys.readouterr().err
    assert main(["pretrained", "export", NAME, "--csv", str(bench.csv), "--root", str(out),
                 "--size-limit", "0.001"]) == 2
    assert "limit" in capsys.readouterr().err


def test_cli_evaluate_pretrained(bench, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(ROOT_ENV, str(bench.root))
    monkeypatch.chdir(tmp_path)
    assert main(["evaluate", "--pretrained", NAME, "--episodes", "1"]) == 0
    out = tmp_path / "runs" / "pretrained-eval" / NAME
    text = (out / "results.md").read_text()
    assert f"pretrained {NAME}" in text
    for policy in ("agent (PPO)", "baseline", "random"):
        assert f"| {policy} |" in text
    assert (out / "results.csv").is_file() and (out / "trajectories.png").is_file()
    capsys.readouterr()
    assert main(["evaluate", "--pretrained", "Nope"]) == 2
    assert "no pretrained agent 'Nope'" in capsys.readouterr().err
    assert main(["evaluate", str(tmp_path), "--pretrained", NAME]) == 2
    assert "takes no RUN" in capsys.readouterr().err
    assert main(["evaluate"]) == 2
    assert "give a RUN folder or --pretrained" in capsys.readouterr().err


def test_cli_demo_with_an_agent(bench, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(ROOT_ENV, str(bench.root))
    gif = tmp_path / "d.gif"
    assert main(["demo", "SkidSteer-v0", "--agent", NAME, "--out", str(gif)]) == 2
    assert "trained on wheelgym/ThreeWheel-v0, not wheelgym/SkidSteer-v0" in \
        capsys.readouterr().err
    assert main(["demo", "ThreeWheel-v0", "--agent", NAME, "--task", "track",
                 "--out", str(gif)]) == 2
    assert "drop --task" in capsys.readouterr().err
    import gymnasium as gym

    from wheelgym.agents import evaluate
    from wheelgym.agents.policies import AgentPolicy

    made, policies = [], []
    real_make, real_run = gym.make, evaluate.run_episode

    def short_make(env_id, **kwargs):  # 20 steps instead of 500: a short GIF
        made.append((env_id, kwargs))
        return real_make(env_id, max_episode_steps=20, **kwargs)

    def spy_run(env, policy, *args, **kwargs):
        policies.append(policy)
        return real_run(env, policy, *args, **kwargs)

    monkeypatch.setattr(gym, "make", short_make)
    monkeypatch.setattr(evaluate, "run_episode", spy_run)
    assert main(["demo", "ThreeWheel-v0", "--agent", NAME, "--action-mode", "velocity",
                 "--out", str(gif)]) == 0
    assert "episode 0: seed 0, 20 steps" in capsys.readouterr().out
    assert made == [("wheelgym/ThreeWheel-v0", {"render_mode": "rgb_array", "task": "goal",
                                                "action_mode": "velocity"})]
    assert len(policies) == 1 and isinstance(policies[0], AgentPolicy)
    assert gif.stat().st_size > 0


# --------------------------------------------------------------------------------------------
# the README's plain-SB3 snippet
# --------------------------------------------------------------------------------------------


def test_readme_snippet_loads_an_exported_agent(bench):
    blocks = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"),
                        flags=re.MULTILINE | re.DOTALL)
    snippet = [b for b in blocks if "agents/pretrained/" in b]
    assert len(snippet) == 1 and f"agents/pretrained/{NAME}" in snippet[0]
    assert "wheelgym.agents" not in snippet[0]  # plain SB3 and Gymnasium
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, "-c", snippet[0]], cwd=bench.base, env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "success:" in r.stdout


# --------------------------------------------------------------------------------------------
# the agents actually shipped (none until they are exported into agents/pretrained/)
# --------------------------------------------------------------------------------------------


SHIPPED_ROOT = resources._shipped("pretrained")


def _shipped() -> list[str]:
    try:
        return available(SHIPPED_ROOT)
    except ValueError:  # no folder at all: nothing shipped
        return []


@pytest.mark.parametrize("name", _shipped())
def test_every_shipped_agent_loads_and_acts(name):
    agent, config = load_pretrained(name, SHIPPED_ROOT)
    assert Path(name).name == name
    card = read_card(name, SHIPPED_ROOT)
    assert card.get("config") == name and card.get("algo") == config.algo
    assert card.get("env_id") == config.env_id
    _acts(agent, config)


def test_shipped_folder_is_under_the_size_limit():
    if not SHIPPED_ROOT.is_dir():
        pytest.skip("no agents/pretrained folder")
    total = sum(p.stat().st_size for p in SHIPPED_ROOT.rglob("*") if p.is_file())
    assert total <= SIZE_LIMIT_MB * 1e6


def test_export_of_a_perturbed_config_scores_its_tied_seeds_on_the_nominal_robot(bench, tmp_path,
                                                                               capsys):
    import shutil

    from wheelgym.agents.evaluate import nominal_success

    # the fixture's two runs as if trained under `medium`, tied on success
    rows = []
    for r in bench.rows:
        run = tmp_path / "runs" / Path(r["run_dir"]).name
        shutil.copytree(r["run_dir"], run)
        config = load_config(run / "config.yml")
        config.replace(env_kwargs={**config.env_kwargs, "perturbation": "medium"}).dump(
            run / "config.yml")
        rows.append({**r, "run_dir": str(run), "agent_success": "0.5"})
    tied = tmp_path / "tied.csv"
    with tied.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(COLUMNS))
        w.writeheader()
        w.writerows(rows)
    out = tmp_path / "agents"
    assert main(["pretrained", "export", "--csv", str(tied), "--root", str(out)]) == 0
    card = read_card(NAME, out)
    expected = {}
    for r in rows:
        config = load_config(Path(r["run_dir"]) / "config.yml")
        agent = load_agent(Path(r["run_dir"]) / "model.zip", "ppo",
                           Path(r["run_dir"]) / "vecnormalize.pkl")
        expected[r["seed"]] = nominal_success(agent, config)
    # the tiny agents reach no goal: both seeds scored, equal, so the return decides
    assert card["nominal_success"] == {"episodes": 50, "by_seed": expected}
    assert str(card["seed"]) == best_row(rows, NAME)["seed"]
    printed = capsys.readouterr().out
    assert "on the nominal robot (50 episodes" in printed and "nominal robot: seed" in printed
    # a tied seed's run folder gone: refused, naming the seed and the way back
    other = next(r for r in rows if str(r["seed"]) != str(card["seed"]))
    shutil.rmtree(other["run_dir"])
    with pytest.raises(ValueError, match=rf"seed {other['seed']}: seeds tied .* wheelgym bench"):
        export_best(tied, out_root=tmp_path / "b")
