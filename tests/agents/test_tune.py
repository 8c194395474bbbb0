"""``wheelgym tune``: tiny Optuna studies to a loadable config, export, shared storage, the
search spaces, and the training hook that pruning stops."""

from __future__ import annotations

import csv
import json
import sqlite3
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")
optuna = pytest.importorskip("optuna")

import wheelgym.agents.tune as tune_mod  # noqa: E402
from wheelgym.agents.config import load_config, parse_config  # noqa: E402
from wheelgym.agents.pipeline import migrate  # noqa: E402
from wheelgym.agents.train import EVAL_COLUMNS, train  # noqa: E402
from wheelgym.agents.tune import (  # noqa: E402
    SEARCH_SPACES,
    _base_for_algo,
    apply_params,
    make_storage,
    sample_params,
    tune,
)
from wheelgym.cli import main  # noqa: E402

ENV_ID = "wheelgym/ThreeWheel-v0"


def _config(task: str = "goal") -> dict:
    return {
        ENV_ID: {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 100_000, "normalize": True,
                 "n_steps": 128, "batch_size": 128, "n_epochs": 2, "gamma": 0.99,
                 "policy_kwargs": {"net_arch": [16, 16]}},
        "wheelgym": {"algo": "ppo", "env_kwargs": {"task": task, "action_mode": "velocity"},
                     "seed": 0, "eval_freq": 20_000, "eval_episodes": 1, "checkpoint_freq": 0},
    }


def _write(tmp_path: Path, data: dict, name: str = "tiny.yml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def _body(path: Path) -> str:
    return "".join(line for line in path.read_text().splitlines(True) if not line.startswith("#"))


def test_tiny_study_writes_a_loadable_config_and_export_gives_the_same(tmp_path, capsys):
    data = _config()  # the distillation (torque mode only) would fail these velocity trials
    data["wheelgym"]["pipeline"] = [{"stage": "rl"}, {
        "stage": "imitate", "teacher": "self_without_internal_force", "steps": 4096, "rounds": 2}]
    cfg = _write(tmp_path, data)
    root = tmp_path / "runs"
    rc = main(["tune", str(cfg), "--trials", "2", "--timesteps", "512", "--evals", "2",
               "--eval-episodes", "1", "--runs-root", str(root), "--study-name", "tiny"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert sum(line.startswith("trial ") for line in out.splitlines()) == 2, out
    best = root / "tiny" / "best.yml"
    tuned = load_config(best)
    header = best.read_text().splitlines()[0]
    assert header.startswith("# Tuned by `wheelgym tune`: study 'tiny'") and "2 complete" in header
    # The config's own budget, seed and evaluation settings; tuned keys from the search space.
    assert tuned.n_timesteps == 100_000 and tuned.seed == 0 and tuned.eval_freq == 20_000
    assert tuned.hyperparams["n_epochs"] in SEARCH_SPACES["ppo"]["n_epochs"][1]
    # trials train without the distillation after training; the written config keeps it
    assert (tuned.pipeline[-1].steps, tuned.pipeline[-1].rounds) == (4096, 2)

    study = optuna.load_study(study_name="tiny", storage=f"sqlite:///{root / 'tiny' / 'study.db'}")
    first = study.trials[0]
    assert first.params["n_steps"] == 128 and first.params["gamma"] == 0.99  # the config's own
    # SB3's own defaults where the config names none (PPO: Tanh, initial log std 0)
    assert first.params["activation_fn"] == "tanh" and first.params["log_std_init"] == 0.0
    assert [t.user_attrs["seed"] for t in study.trials] == [0, 1]
    for t in study.trials:
        assert Path(t.user_attrs["run_dir"]).parent == root / "tiny"
        assert "pipeline" not in t.user_attrs["config"]["wheelgym"]

    exported = tmp_path / "exported.yml"
    rc = main(["tune", "--export", "tiny", "--storage", f"sqlite:///{root / 'tiny' / 'study.db'}",
               "--out", str(exported)])
    assert rc == 0
    assert load_config(exported).to_dict() == tuned.to_dict()
    assert _body(exported) == _body(best)
    # Default storage and output: the study folder under --runs-root.
    best.unlink()
    assert main(["tune", "--export", "tiny", "--runs-root", str(root)]) == 0
    assert load_config(best).to_dict() == tuned.to_dict()


def test_two_calls_on_one_storage_add_up_their_trials(tmp_path):
    cfg = _write(tmp_path, _config())
    db = tmp_path / "shared.db"
    kw = dict(timesteps=256, n_evals=1, eval_episodes=1, storage=db, study_name="shared",
              runs_root=tmp_path / "runs", seed=3)
    first = tune(cfg, trials=2, **kw)
    second = tune(cfg, trials=1, **kw)
    assert first.counts["all"] == 2 and second.counts["all"] == 3 and second.trials_run == 1
    study = optuna.load_study(study_name="shared", storage=f"sqlite:///{db}")
    assert [t.number for t in study.trials] == [0, 1, 2]
    assert [t.user_attrs["seed"] for t in study.trials] == [3, 4, 5]
    assert len({t.user_attrs["run_dir"] for t in study.trials}) == 3
    assert second.best_config is not None and load_config(second.best_config)
    with pytest.raises(ValueError, match="other timesteps"):
        tune(cfg, trials=1, **{**kw, "timesteps": 512})


def _running_with_heartbeat(db) -> bool:
    """Whether the SQLite storage ``db`` holds a RUNNING trial whose first heartbeat is written
    (a trial killed before that has none, and the heartbeat cannot tell it is stale); read
    only, so it never touches the schema the worker is creating."""
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=1.0)
        try:
            running = con.execute("SELECT COUNT(*) FROM trials WHERE state = 'RUNNING'")
            beats = con.execute("SELECT COUNT(*) FROM trial_heartbeats")
            return running.fetchone()[0] > 0 and beats.fetchone()[0] > 0
        finally:
            con.close()
    except sqlite3.Error:  # not created yet, or locked for a moment
        return False


def test_a_killed_workers_trial_is_marked_failed(tmp_path, monkeypatch):
    """The storage's heartbeat: a worker killed mid-trial leaves a RUNNING trial that the next
    worker on the study marks failed once its heartbeat is older than the grace period."""
    cfg = _write(tmp_path, _config())
    db = tmp_path / "k.db"
    code = ("import wheelgym.agents.tune as t; t.HEARTBEAT_S = 1; t.GRACE_S = 2; "
            f"t.tune({str(cfg)!r}, trials=1, timesteps=10**7, storage={str(db)!r}, "
            f"study_name='k', runs_root={str(tmp_path / 'runs')!r})")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            # read-only SQL, not optuna.load_study: a second process creating Optuna's schema
            # while the worker does races it (UNIQUE constraint on alembic_version)
            if db.is_file() and _running_with_heartbeat(db):
                break
            time.sleep(0.5)
        else:
            raise AssertionError(f"the trial did not start (rc {proc.poll()})")
    finally:
        proc.kill()
        proc.wait()
    time.sleep(3)
    monkeypatch.setattr(tune_mod, "GRACE_S", 2)
    study = optuna.load_study(study_name="k", storage=make_storage(db))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        optuna.storages.fail_stale_trials(study)  # what optimize() does before each trial
    assert [t.state.name for t in study.trials] == ["FAIL"]


@pytest.mark.parametrize("algo", sorted(SEARCH_SPACES))
def test_search_spaces_give_valid_configs(algo):
    base = _base_for_algo(parse_config(_config()), algo)
    bounded = _config()
    bounded["wheelgym"].update(mean_bound=1.1, clone_baseline=4096, clone_rounds=2,
                               clone_epochs=3, clone_internal_force=5.0,
                               distill_internal_force=2048, distill_weight=10.0)
    bounded = migrate(bounded)
    stages = bounded["wheelgym"]["pipeline"]
    based = _base_for_algo(parse_config(bounded), algo)
    wg = based["wheelgym"]
    on_policy = algo in ("ppo", "a2c")  # the stages are kept for these, dropped for the others
    env_id = next(k for k in based if k != "wheelgym")
    assert based[env_id].get("policy_kwargs", {}).get("mean_bound") == (
        1.1 if on_policy else None)
    assert wg.get("pipeline") == (stages if on_policy else None)
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    for _ in range(8):
        trial = study.ask()
        data = apply_params(base, algo, sample_params(trial, algo), timesteps=1000)
        config = parse_config(data)
        hp = config.hyperparams
        assert config.algo == algo
        if algo == "ppo":
            assert hp["n_steps"] * config.n_envs <= 1000 or hp["n_steps"] == 16
            assert hp["batch_size"] <= hp["n_steps"] * config.n_envs
        else:
            assert hp["learning_starts"] <= 100 and hp["gradient_steps"] == hp["train_freq"]
            assert (config.noise is not None) == (algo == "td3")
        study.tell(trial, 0.0)


def _saturated_share(run_dir: Path, episodes: int) -> float:
    """The final model's share of saturated steps, counted from ``info["saturated"]`` here."""
    import numpy as np

    from wheelgym.agents.common import make_single_env
    from wheelgym.agents.policies import load_agent

    config = load_config(run_dir / "config.yml")
    agent = load_agent(run_dir / "model.zip", "ppo", run_dir / "vecnormalize.pkl")
    env = make_single_env(config)
    shares = []
    for seed in range(100_000, 100_000 + episodes):
        obs, _ = env.reset(seed=seed)
        n = sat = 0
        done = False
        while not done:
            obs, _, term, trunc, info = env.step(agent.predict(obs, deterministic=True)[0])
            n += 1
            sat += bool(np.any(info["saturated"]))
            done = term or trunc
        shares.append(sat / n)
    env.close()
    return float(np.mean(shares))


def test_saturation_constraint_makes_saturated_trials_infeasible(tmp_path, capsys):
    data = _config("track")
    data[ENV_ID]["policy_kwargs"]["log_std_init"] = -1.0
    # weak motors: the velocity controller's torques clip at nearly any command
    data["wheelgym"]["env_kwargs"]["params"] = {"tau_drive_max": 0.01, "tau_steer_max": 0.01}
    cfg = _write(tmp_path, data)
    root = tmp_path / "runs"
    args = ["tune", str(cfg), "--trials", "2", "--timesteps", "512", "--evals", "1",
            "--eval-episodes", "1", "--runs-root", str(root)]
    assert main([*args, "--study-name", "loose", "--max-saturation", "1"]) == 0
    study = optuna.load_study(study_name="loose",
                              storage=f"sqlite:///{root / 'loose' / 'study.db'}")
    assert study.trials[0].params["log_std_init"] == -1.0  # the config's own, enqueued
    shares = []
    for t in study.trials:  # each trial's saturation, recounted from its final model
        share = _saturated_share(Path(t.user_attrs["run_dir"]), 1)
        assert t.user_attrs["saturation"] == pytest.approx(share, abs=1e-12)
        assert list(t.constraints.values()) == [pytest.approx(share - 1.0)]
        shares.append(share)
    assert max(shares) > 0.0
    assert "# constraint: saturation <= 100%" in (root / "loose" / "best.yml").read_text()
    capsys.readouterr()
    # No saturation allowed: the saturated trials are infeasible, never the best.
    assert main([*args, "--study-name", "strict", "--max-saturation", "0"]) == 0
    out = capsys.readouterr().out
    study = optuna.load_study(study_name="strict",
                              storage=f"sqlite:///{root / 'strict' / 'study.db'}")
    feasible = [t for t in study.trials if t.user_attrs["saturation"] <= 0.0]
    if feasible:
        assert study.best_trial.number in {t.number for t in feasible}
    else:
        assert "no complete (feasible) trial, no config written" in out
        assert not (root / "strict" / "best.yml").exists()
    with pytest.raises(ValueError, match="max_saturation must be a share in"):
        tune(cfg, trials=1, timesteps=512, max_saturation=1.5, runs_root=root)


def test_on_eval_hook_sees_each_evaluation_and_can_stop_training(tmp_path):
    data = _config("track")
    data[ENV_ID]["n_timesteps"] = 2048
    data["wheelgym"]["eval_freq"] = 256
    seen: list[dict] = []

    def hook(row: dict) -> bool:
        seen.append(row)
        return len(seen) < 2

    res = train(parse_config(data), runs_root=tmp_path, progress=False, on_eval=hook)
    assert res.status == "stopped" and res.timesteps < 2048
    assert json.loads((res.run_dir / "run.json").read_text())["status"] == "stopped"
    assert len(seen) == 2 and seen[0]["rms_tracking_error"] is not None
    with (res.run_dir / "eval.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == EVAL_COLUMNS and len(rows) == 2
    assert float(rows[0]["rms_tracking_error"]) == pytest.approx(seen[0]["rms_tracking_error"],
                                                                 rel=1e-5)


def test_tune_errors_are_one_line(tmp_path, capsys):
    cfg = _write(tmp_path, _config())
    root = tmp_path / "runs"
    bad = [
        ["tune"],
        ["tune", str(cfg), "--trials", "0"],
        ["tune", str(cfg), "--timeout", "-5"],
        ["tune", str(cfg), "--algo", "dqn"],
        ["tune", str(cfg), "--metric", "rms", "--runs-root", str(root)],
        ["tune", str(cfg), "--storage", "nosuchdb://x", "--runs-root", str(root)],
        ["tune", "--export", "nosuch", "--runs-root", str(root)],
        ["tune", "--export", "nosuch", str(cfg)],
        ["tune", str(cfg), "--out", str(tmp_path)],
    ]
    for argv in bad:
        capsys.readouterr()
        rc = _run_main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2, argv
        assert len(err) == 1 and err[0].startswith("wheelgym"), (argv, err)
    assert not any(root.rglob("ThreeWheel-*-s*"))  # no trial was trained


def _run_main(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as e:  # argparse
        return e.code if isinstance(e.code, int) else 1
