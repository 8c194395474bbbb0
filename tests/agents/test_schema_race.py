"""Two ``wheelgym tune`` workers started at the same moment on a fresh PostgreSQL database (the
README's scaling recipe on first use): both create the study storage's schema, and neither
fails (``wheelgym.agents.cluster.rdb_storage`` creates it under an advisory lock). A real
server on 127.0.0.1; each round on a new database of it.

The fast test opens the storage as ``wheelgym tune`` does (``make_storage``) from two threads
released together (each its own connections: the race is in the database); the slow one
starts two ``wheelgym tune`` processes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")
optuna = pytest.importorskip("optuna")
psycopg = pytest.importorskip("psycopg")

from wheelgym.agents.cluster import SCHEMA_LOCK_KEY, LocalPostgres, rdb_storage  # noqa: E402
from wheelgym.agents.tune import make_storage  # noqa: E402

ENV_ID = "wheelgym/ThreeWheel-v0"
ROUNDS = 3
THREAD_ROUNDS = 4


def _config(tmp_path: Path) -> Path:
    data = {
        ENV_ID: {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 100_000, "normalize": True,
                 "n_steps": 128, "batch_size": 128, "n_epochs": 1,
                 "policy_kwargs": {"net_arch": [16, 16]}},
        "wheelgym": {"algo": "ppo", "env_kwargs": {"task": "goal", "action_mode": "velocity"},
                     "seed": 0, "eval_freq": 25_000, "eval_episodes": 1, "checkpoint_freq": 0},
    }
    path = tmp_path / "tiny.yml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def pg():
    with LocalPostgres() as server:
        yield server


def _connect(pg: LocalPostgres, dbname: str = "postgres"):
    return psycopg.connect(host="127.0.0.1", port=pg.port, user="postgres",
                           password=pg.password, dbname=dbname, autocommit=True)


def _fresh_database(pg: LocalPostgres, name: str) -> str:
    with _connect(pg) as conn:
        conn.execute(f"CREATE DATABASE {name}")
    return pg.url.rsplit("/", 1)[0] + f"/{name}"


def _open_study(url: str, start, errors: list) -> None:
    """What a ``wheelgym tune`` worker does first: open the storage, create or load the study."""
    try:
        start.wait(30)
        store = make_storage(url, heartbeat=1)
        optuna.create_study(storage=store, study_name="together", load_if_exists=True)
    except BaseException as e:  # reported by the test's thread
        errors.append(e)


def test_storages_opened_together_on_a_fresh_database(pg):
    import threading

    for k in range(THREAD_ROUNDS):
        url = _fresh_database(pg, f"threads{k}")
        start = threading.Barrier(2)
        errors: list[BaseException] = []
        threads = [threading.Thread(target=_open_study, args=(url, start, errors))
                   for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(120)
        assert not errors, (k, [str(e)[:300] for e in errors])
        names = [s.study_name for s in optuna.get_all_study_summaries(make_storage(url))]
        assert names == ["together"]


@pytest.mark.slow
def test_tune_workers_started_together_on_a_fresh_database(tmp_path, pg):
    cfg = _config(tmp_path)
    for k in range(ROUNDS):
        url = _fresh_database(pg, f"fresh{k}")
        root = tmp_path / f"runs{k}"
        cmd = [sys.executable, "-m", "wheelgym.cli", "tune", str(cfg), "--storage", url,
               "--study-name", "together", "--runs-root", str(root), "--trials", "1",
               "--timesteps", "256", "--evals", "1", "--eval-episodes", "1"]
        workers = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    text=True) for _ in range(2)]
        try:
            outs = [w.communicate(timeout=300)[0] for w in workers]
        finally:
            for w in workers:  # none left running if this test fails
                w.kill()
                w.wait()
        assert [w.returncode for w in workers] == [0, 0], (k, [o[-800:] for o in outs])
        study = optuna.load_study(study_name="together", storage=make_storage(url))
        assert sorted(t.number for t in study.trials) == [0, 1]
        assert [t.state.name for t in study.trials] == ["COMPLETE"] * 2
        assert len({t.user_attrs["worker"] for t in study.trials}) == 2


def test_rdb_storage_waits_for_the_schema_lock(pg):
    """While another session holds the schema lock, creating a storage waits for it (and
    creates nothing meanwhile); released, it goes on and the storage works."""
    import threading

    url = _fresh_database(pg, "locked")
    dbname = url.rsplit("/", 1)[1]
    holder = _connect(pg, dbname)
    holder.execute("SELECT pg_advisory_lock(%s)", (SCHEMA_LOCK_KEY,))
    made: list = []
    thread = threading.Thread(target=lambda: made.append(rdb_storage(url)))
    thread.start()
    thread.join(3.0)
    try:
        assert thread.is_alive() and not made  # waiting for the lock
        tables = holder.execute("SELECT count(*) FROM pg_tables WHERE schemaname = 'public'"
                                ).fetchone()[0]
        assert tables == 0
    finally:
        holder.execute("SELECT pg_advisory_unlock(%s)", (SCHEMA_LOCK_KEY,))
        thread.join(60)
        holder.close()
    assert made and not thread.is_alive()
    study = optuna.create_study(storage=made[0], study_name="s")
    assert study.study_name == "s"
    # and the lock is not left held by the storage's process
    with _connect(pg, dbname) as c:
        assert c.execute("SELECT pg_try_advisory_lock(%s)", (SCHEMA_LOCK_KEY,)
                         ).fetchone()[0] is True


def test_rdb_storage_elsewhere_is_optunas(tmp_path):
    store = rdb_storage(f"sqlite:///{tmp_path / 'a.db'}")
    assert isinstance(store, optuna.storages.RDBStorage)
