"""Run folders (issue 14): run.json statuses, Ctrl-C with subprocess workers, the run-folder
lock, and the evaluation history's wall clock across a resume."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")

from wheelgym.agents.config import parse_config  # noqa: E402
from wheelgym.agents.policies import load_agent  # noqa: E402
from wheelgym.agents.train import LOCK_NAME, RunLock, resume, train  # noqa: E402
from wheelgym.cli import main  # noqa: E402

ENV_ID = "wheelgym/ThreeWheel-v0"


def _config(n_timesteps: int = 512, **wheelgym_block) -> dict:
    return {
        ENV_ID: {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": n_timesteps,
                 "normalize": True, "n_steps": 128, "batch_size": 128, "n_epochs": 1,
                 "policy_kwargs": {"net_arch": [16, 16]}},
        "wheelgym": {"algo": "ppo", "env_kwargs": {"task": "goal", "action_mode": "velocity"},
                     "seed": 0, "eval_freq": 0, "checkpoint_freq": 0, **wheelgym_block},
    }


def _status(run: Path) -> dict:
    return json.loads((run / "run.json").read_text())


def _wait_running(proc: subprocess.Popen, run: Path, timeout: float = 300) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        info = run / "run.json"
        try:
            if info.is_file() and _status(run).get("status") == "running":
                return
        except json.JSONDecodeError:
            pass
        time.sleep(0.2)
    raise AssertionError(f"training did not start: rc {proc.poll()}")


def test_sigint_with_subprocess_workers_saves_and_second_run_is_refused(tmp_path, capsys):
    """Ctrl-C reaches the whole process group (as from a terminal): the workers ignore it, the
    main process saves and exits with 130. Meanwhile a second run into the same folder (and a
    resume of it) is refused."""
    cfg = tmp_path / "c.yml"
    cfg.write_text(yaml.safe_dump(_config(10_000_000, vec_env="subproc")))
    run = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "wheelgym.cli", "train", str(cfg), "--run-dir", str(run),
         "--no-progress"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"}, start_new_session=True,
    )
    try:
        _wait_running(proc, run)
        assert (run / LOCK_NAME).read_text().split()[0] == str(proc.pid)
        assert main(["train", str(cfg), "--run-dir", str(run), "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert "in use by another wheelgym process" in err and str(proc.pid) in err
        assert main(["train", "--resume", str(run), "--no-progress"]) == 2
        assert "in use" in capsys.readouterr().err
        time.sleep(1.5)
        assert proc.poll() is None, proc.stdout.read()
        os.killpg(proc.pid, signal.SIGINT)  # the terminal's Ctrl-C: every process in the group
        out, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, out
    assert "Traceback" not in out and "EOFError" not in out, out
    info = _status(run)
    assert info["status"] == "interrupted" and "error" not in info
    assert "notes" not in info, info["notes"]  # the workers survived and closed cleanly
    assert (run / "model.zip").is_file() and (run / "vecnormalize.pkl").is_file()
    assert not (run / LOCK_NAME).exists()
    agent = load_agent(run / "model.zip", "ppo", run / "vecnormalize.pkl")
    assert agent.obs_norm is not None
    assert 0 < agent.model.num_timesteps == info["timesteps"] < 10_000_000


def test_crashed_run_is_recorded_failed(tmp_path, capsys):
    """Training that diverges (NaN policy) raises: run.json says failed, with the error."""
    data = _config(2048)
    data[ENV_ID].update(learning_rate=1e30, n_steps=64, batch_size=64, normalize=False)
    run = tmp_path / "run"
    with pytest.raises(ValueError, match="invalid values"):
        train(parse_config(data), run_dir=run, progress=False)
    info = _status(run)
    assert info["status"] == "failed"
    assert info["error"].startswith("ValueError: ") and "\n" not in info["error"]
    assert 0 < info["timesteps"] < 2048
    assert (run / "model.zip").is_file() and not (run / LOCK_NAME).exists()

    cfg = tmp_path / "c.yml"  # the same through the command: one line, nonzero, still failed
    cfg.write_text(yaml.safe_dump(data))
    assert main(["train", str(cfg), "--run-dir", str(tmp_path / "run2"), "--no-progress"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "invalid values" in err[0], err
    assert _status(tmp_path / "run2")["status"] == "failed"


def test_finished_run_is_recorded_finished(tmp_path):
    res = train(parse_config(_config(256)), run_dir=tmp_path / "run", progress=False)
    assert res.status == "finished"
    info = _status(res.run_dir)
    assert info["status"] == "finished" and "error" not in info
    assert not (res.run_dir / LOCK_NAME).exists()


def test_run_dir_lock_refuses_a_live_holder_and_takes_over_a_stale_one(tmp_path):
    cfg = parse_config(_config(256))
    run = tmp_path / "run"
    run.mkdir()
    with RunLock(run):  # held by a live process (this one)
        with pytest.raises(ValueError, match=r"in use by another wheelgym process \(pid"):
            train(cfg, run_dir=run, progress=False)
        assert [p.name for p in run.iterdir()] == [LOCK_NAME]
    assert not any(run.iterdir())

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (run / LOCK_NAME).write_text(f"{dead.pid}\n")  # a run killed without cleaning up
    res = train(cfg, run_dir=run, progress=False)
    assert res.status == "finished" and not (run / LOCK_NAME).exists()
    with pytest.raises(ValueError, match="not empty"):  # done: the folder is never reused
        train(cfg, run_dir=run, progress=False)


def test_resume_continues_the_eval_wall_clock(tmp_path):
    cfg = parse_config(_config(512, eval_freq=256, eval_episodes=1))
    run = train(cfg, run_dir=tmp_path / "run", progress=False).run_dir
    wall_before = _status(run)["wall_s"]
    res = resume(run, total_timesteps=1024, progress=False)
    assert res.timesteps == 1024
    with (run / "eval.csv").open() as f:
        rows = [(int(r["timesteps"]), float(r["wall_s"])) for r in csv.DictReader(f)]
    assert [s for s, _ in rows] == [256, 512, 768, 1024]
    walls = [w for _, w in rows]
    assert walls == sorted(walls), walls
    assert walls[2] >= wall_before, (walls, wall_before)
    assert _status(run)["wall_s"] >= walls[-1]
