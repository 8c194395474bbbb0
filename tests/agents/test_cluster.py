"""Beyond one machine, against real servers: ``wheelgym tune`` workers sharing a study on a
PostgreSQL server on 127.0.0.1 (a killed worker's trial marked failed by the heartbeat), and
``wheelgym benchmark --ray`` on a local Ray instance giving the local mode's rows."""

from __future__ import annotations

import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
import yaml

# Ray on one machine binds the loopback interface only (read when ray is imported).
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")

pytest.importorskip("stable_baselines3")
optuna = pytest.importorskip("optuna")
pytest.importorskip("psycopg")
pytest.importorskip("ray")

from wheelgym.agents.benchmark import read_rows, run_jobs  # noqa: E402
from wheelgym.agents.cluster import LocalPostgres, run_on_ray  # noqa: E402
from wheelgym.agents.grid import Job as _Job  # noqa: E402
from wheelgym.agents.grid import run_job as _run_job  # noqa: E402
from wheelgym.agents.tune import make_storage  # noqa: E402
from wheelgym.cli import main  # noqa: E402

ENV_ID = "wheelgym/ThreeWheel-v0"
#: Columns that measure time or place, not the result: they differ between two runs.
TIMING = ("train_s", "cpu_s", "finished_utc", "run_dir")


def _config(tmp_path: Path, name: str, task: str) -> Path:
    data = {
        ENV_ID: {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 100_000, "normalize": True,
                 "n_steps": 128, "batch_size": 128, "n_epochs": 1,
                 "policy_kwargs": {"net_arch": [16, 16]}},
        "wheelgym": {"algo": "ppo", "env_kwargs": {"task": task, "action_mode": "velocity"},
                     "seed": 0, "eval_freq": 25_000, "eval_episodes": 1, "checkpoint_freq": 0},
    }
    path = tmp_path / f"{name}.yml"
    path.write_text(yaml.safe_dump(data))
    return path


def _wheelgym(*args: str) -> list[str]:
    return [sys.executable, "-m", "wheelgym.cli", *args]


def test_tune_workers_share_a_study_on_postgresql(tmp_path):
    cfg = _config(tmp_path, "tiny", "goal")
    root = tmp_path / "runs"
    with LocalPostgres() as pg:
        url = pg.url
        base = ["tune", str(cfg), "--storage", url, "--study-name", "shared", "--runs-root",
                str(root), "--evals", "1", "--eval-episodes", "1", "--heartbeat", "1"]
        make_storage(url)  # the tables, before two processes race to make them
        # A worker killed mid-trial (a study of long trials): its trial stays RUNNING.
        log = (tmp_path / "doomed.log").open("w")
        doomed = subprocess.Popen(_wheelgym(*base, "--study-name", "killed", "--trials", "1",
                                            "--timesteps", "10000000"),
                                  stdout=subprocess.DEVNULL, stderr=log)
        try:
            deadline = time.monotonic() + 90
            while True:
                assert doomed.poll() is None and time.monotonic() < deadline, (
                    f"no trial started: {(tmp_path / 'doomed.log').read_text()[-600:]}")
                try:
                    killed = optuna.load_study(study_name="killed", storage=url)
                    if (killed.trials and killed.trials[0].state.name == "RUNNING"
                            and any((root / "killed").glob("*/ThreeWheel-*"))):
                        break  # training: the heartbeat thread started before it
                except KeyError:
                    pass
                time.sleep(0.5)
            time.sleep(1.5)  # a heartbeat recorded (a trial without one is never stale)
        finally:
            doomed.kill()
            doomed.wait()
            log.close()
        t_kill = time.monotonic()

        workers = [subprocess.Popen(_wheelgym(*base, "--trials", "2", "--timesteps", "256"),
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
                   for _ in range(2)]
        try:
            outs = [w.communicate(timeout=240)[0] for w in workers]
        finally:
            for w in workers:  # none left running if this test fails
                w.kill()
                w.wait()
        assert [w.returncode for w in workers] == [0, 0], outs

        study = optuna.load_study(study_name="shared", storage=make_storage(url))
        trials = study.trials
        numbers = [t.number for t in trials]
        assert sorted(numbers) == list(range(4)) and len(set(numbers)) == 4  # none twice
        assert [t.state.name for t in trials] == ["COMPLETE"] * 4
        by_worker: dict[str, list[int]] = {}
        for t in trials:
            by_worker.setdefault(t.user_attrs["worker"], []).append(t.number)
            run_dir = Path(t.user_attrs["run_dir"])
            assert run_dir.parent == root / "shared" / t.user_attrs["worker"]
            assert (run_dir / "eval.csv").is_file()
        assert sorted(len(v) for v in by_worker.values()) == [2, 2]  # both workers' trials
        assert len({tuple(sorted(t.params.items())) for t in trials}) == 4  # no draw twice

        # The killed trial: failed by what a worker runs before each trial, once its last
        # heartbeat is older than the grace period (4 heartbeats).
        time.sleep(max(0.0, t_kill + 4.5 - time.monotonic()))
        killed = optuna.load_study(study_name="killed", storage=make_storage(url, heartbeat=1))
        assert [t.state.name for t in killed.trials] == ["RUNNING"]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            optuna.storages.fail_stale_trials(killed)
        assert [t.state.name for t in killed.trials] == ["FAIL"]

        out = tmp_path / "best.yml"
        assert main(["tune", "--export", "shared", "--storage", url, "--out", str(out)]) == 0
        best = yaml.safe_load(out.read_text())
        assert best[ENV_ID]["n_timesteps"] == 100_000
        assert f"trial {study.best_trial.number}:" in out.read_text()
        folder = pg.folder
        assert folder is not None and folder.is_dir()
    assert not folder.exists()  # the server stopped and its data folder removed
    with pytest.raises(ValueError, match="OperationalError"):
        make_storage(url)


def test_benchmark_on_ray_gives_the_local_rows(tmp_path, capsys):
    import psutil

    ray = pytest.importorskip("ray")
    configs = [_config(tmp_path, "tiny-goal", "goal"), _config(tmp_path, "tiny-track", "track")]
    grid = ["--seeds", "2", "--episodes", "2", "--budget", "512"]
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             _node_ip_address="127.0.0.1")
    try:
        address = ray.get_runtime_context().gcs_address
        assert address.startswith("127.0.0.1:")
        ray_csv = tmp_path / "ray.csv"
        # Another driver process joins this instance by its address, as on a cluster.
        driver = subprocess.Popen(
            _wheelgym("benchmark", *map(str, configs), *grid, "--csv", str(ray_csv),
                      "--runs-root", str(tmp_path / "ray-runs"), "--ray", address),
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:  # meanwhile the local mode, in this process, on the same grid
            local = run_jobs(configs, seeds=2, episodes=2, budget=512,
                             csv_path=tmp_path / "local.csv", runs_root=tmp_path / "local-runs")
            out = driver.communicate(timeout=240)[0]
        finally:
            driver.kill()
            driver.wait()
        assert driver.returncode == 0, out
        assert "4 run(s) to do" in out and "ray: 4 task(s) on 2 CPU(s)" in out, out
        assert local.written == 4 and not local.failed

        def key(r: dict) -> tuple:
            return (r["config"], r["seed"])

        ray_rows = sorted(read_rows(ray_csv), key=key)
        local_rows = sorted(read_rows(tmp_path / "local.csv"), key=key)
        assert [key(r) for r in ray_rows] == [(c, s) for c in ("tiny-goal", "tiny-track")
                                              for s in ("0", "1")]
        strip = [{k: v for k, v in r.items() if k not in TIMING} for r in ray_rows]
        assert strip == [{k: v for k, v in r.items() if k not in TIMING} for r in local_rows]
        assert ray_rows[0]["agent_return"] != ray_rows[1]["agent_return"]  # seeds differ
        for r in ray_rows:
            assert Path(r["run_dir"]).parent == tmp_path / "ray-runs"

        # Again: every row is there, nothing is submitted.
        capsys.readouterr()
        assert main(["benchmark", *map(str, configs), *grid, "--csv", str(ray_csv),
                     "--ray", address]) == 0
        assert "0 run(s) to do, 4 already" in capsys.readouterr().out
        assert len(read_rows(ray_csv)) == 4

        # A task that raises is reported, retried once, and its second error handed on.
        bad = yaml.safe_load(configs[0].read_text())
        bad["wheelgym"]["env_kwargs"]["task"] = "nosuch"  # fails on the worker, not here
        job = _Job(str(configs[0]), "bad", 0, 256, 1, str(tmp_path / "bad-runs"), data=bad)
        lines: list[str] = []
        errors: list[BaseException | None] = []
        assert not run_on_ray([job], address, run=_run_job, prepare=lambda j: j,
                              log=lines.append, finish=lambda j, row, e: errors.append(e))
        assert sum("retrying once" in line and "nosuch" in line for line in lines) == 1, lines
        assert len(errors) == 1 and isinstance(errors[0], ValueError), errors
        assert ray.is_initialized()  # a connection it did not make is left as it was
    finally:
        ray.shutdown()
    time.sleep(0.5)
    left = [p.name() for p in psutil.Process().children(recursive=True)
            if "ray" in p.name() or "gcs" in p.name()]
    assert not left, left
