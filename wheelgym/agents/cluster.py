"""Beyond one machine: the benchmark grid on Ray, and a throwaway PostgreSQL server.

:func:`run_on_ray` runs benchmark jobs as Ray tasks (one CPU each, one torch and one numba
thread) and hands each result to the caller as it completes, so that only the driver writes
the results CSV. ``address``: ``local`` (a Ray instance in this process, on 127.0.0.1 only,
``num_cpus`` CPUs), ``auto`` (the cluster started on this machine with ``ray start``) or
``host:port`` (a head node's GCS address). A task that raises is reported and submitted once
more; Ctrl-C cancels the running tasks. Needs the ``cluster`` extra (``ray``).

:class:`LocalPostgres` starts a PostgreSQL server on 127.0.0.1 in a fresh data folder (the
binaries of the ``pgserver`` wheel, else Debian's ``postgresql``), with a random password, and
stops it and removes the folder on exit: a study storage for tests and trials on one machine.
:func:`rdb_storage` opens an Optuna database storage whose schema workers started together on a
fresh PostgreSQL database create once (under an advisory lock) instead of racing to create it.
"""

from __future__ import annotations

import importlib.util
import os
import secrets
import shutil
import signal
import socket
import subprocess
import tempfile
import time
import zlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["run_on_ray", "connect_ray", "LocalPostgres", "postgres_bin", "rdb_storage",
           "SCHEMA_LOCK_KEY"]

#: Ray's switch that keeps a single-machine instance on the loopback interface.
_RAY_LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


def _short(e: BaseException) -> str:
    return f"{type(e).__name__}: {' '.join(str(e).split())[:300]}"


# --------------------------------------------------------------------------------------------
# Ray
# --------------------------------------------------------------------------------------------


def connect_ray(address: str, num_cpus: int | None = None) -> bool:
    """Connect this process to Ray (see the module docstring); ``True`` if it started Ray
    here (then the caller shuts it down). A process already connected is used as it is."""
    if address == "auto":  # what Ray's "auto" means: RAY_ADDRESS, else this machine's cluster
        current = Path(tempfile.gettempdir()) / "ray" / "ray_current_cluster"
        found = os.environ.get("RAY_ADDRESS") or (
            current.read_text().strip() if current.is_file() else "")
        if not found:
            raise ValueError("--ray 'auto': no Ray cluster on this machine (start one with "
                             "`ray start --head`, or give 'local' or HOST:PORT)")
        address = found
    host, _, port = address.rpartition(":")
    if address == "local" or host.strip("[]") in ("127.0.0.1", "localhost", "::1"):
        os.environ.setdefault(_RAY_LOOPBACK_ENV, "0")  # before ray is imported: stay on loopback
    if host and port.isdigit() and "://" not in address:
        try:  # Ray itself retries an unreachable head for minutes
            socket.create_connection((host.strip("[]"), int(port)), timeout=10).close()
        except OSError as e:
            raise ValueError(f"--ray {address!r}: no Ray head node answers there ({e}); start "
                             "one with `ray start --head`, or give 'auto' or 'local'") from None
    try:
        import ray
    except ImportError:
        raise ValueError("--ray needs ray: pip install 'wheelgym[cluster]'") from None
    if ray.is_initialized():
        return False
    kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                              "configure_logging": False}
    if address == "local":
        kwargs.update(address="local", num_cpus=num_cpus or os.cpu_count() or 1,
                      _node_ip_address="127.0.0.1")
    else:
        kwargs["address"] = address
    try:
        ray.init(**kwargs)
    except Exception as e:  # no cluster at the address, a refused connection, bad address
        raise ValueError(f"--ray {address!r}: {_short(e)}") from None
    return kwargs["address"] == "local"


#: Set to "1" in a benchmark worker's process (a local pool worker or a Ray task): the job
#: trains on one torch thread.
WORKER_ENV = "WHEELGYM_BENCHMARK_WORKER"


def _limit_threads() -> None:
    """A Ray task's process: one torch thread, one numba thread (the task holds one CPU)."""
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", WORKER_ENV):
        os.environ[var] = "1"
    import numba
    import torch

    torch.set_num_threads(1)
    numba.set_num_threads(1)


def _ray_task(run: Callable[[Any], dict | None], job: Any) -> dict | None:
    _limit_threads()
    return run(job)


def run_on_ray(
    jobs: Sequence[Any],
    address: str,
    *,
    run: Callable[[Any], dict | None],
    prepare: Callable[[Any], Any],
    finish: Callable[[Any, dict | None, BaseException | None], None],
    limit: int | None = None,
    log: Callable[[str], None] | None = None,
) -> bool:
    """Run ``jobs`` (benchmark ``_Job``s) as Ray tasks of ``run(job)`` (a module-level
    function: Ray pickles it by reference), at most ``limit`` at a time (default
    all; with ``local``: the instance's CPUs), ``prepare`` each before it is submitted and pass
    each outcome to ``finish`` in the order they complete. A task that raises is logged and
    submitted once more; its second error goes to ``finish``. Returns ``True`` when stopped by
    Ctrl-C (running tasks cancelled) or by a job that reported an interruption."""
    if not jobs:
        return False
    started = connect_ray(address, num_cpus=limit)
    import ray

    task = ray.remote(num_cpus=1, max_retries=0)(_ray_task)
    queue = list(jobs)
    running: dict[Any, tuple[Any, int]] = {}  # ref -> (job, attempt)
    cap = limit or len(queue)
    interrupted = False
    if log is not None:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        log(f"ray: {len(queue)} task(s) on {cpus} CPU(s) ({address})")
    try:
        while queue or running:
            while queue and len(running) < cap:
                job = prepare(queue.pop(0))
                running[task.remote(run, job)] = (job, 1)
            done, _ = ray.wait(list(running), num_returns=1, timeout=1.0)
            for ref in done:
                job, attempt = running.pop(ref)
                try:
                    row = ray.get(ref)
                except Exception as e:
                    cause = getattr(e, "cause", None)
                    error = cause if isinstance(cause, BaseException) else e
                    if attempt == 1:
                        if log is not None:
                            log(f"  {job.name} seed {job.seed} failed on Ray ({_short(error)}); "
                                "retrying once")
                        running[task.remote(run, job)] = (job, 2)
                    else:
                        finish(job, None, error)
                    continue
                if row is None:
                    interrupted = True
                finish(job, row, None)
            if interrupted:
                break
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if interrupted or running:
            for ref in running:
                try:
                    ray.cancel(ref, force=True)
                except Exception:  # already finished, or the cluster is gone
                    pass
        if started:
            ray.shutdown()
    return interrupted


# --------------------------------------------------------------------------------------------
# PostgreSQL
# --------------------------------------------------------------------------------------------


def postgres_bin() -> Path:
    """The folder of ``initdb`` and ``pg_ctl``: the ``pgserver`` wheel's, else Debian's."""
    spec = importlib.util.find_spec("pgserver")  # not imported: it has import-time effects
    for folder in (spec.submodule_search_locations or []) if spec is not None else []:
        if (Path(folder) / "pginstall" / "bin" / "pg_ctl").is_file():
            return Path(folder) / "pginstall" / "bin"
    found = shutil.which("pg_ctl")
    if found:
        return Path(found).parent
    debian = sorted(Path("/usr/lib/postgresql").glob("*/bin/pg_ctl"))
    if debian:
        return debian[-1].parent
    raise ValueError("no PostgreSQL binaries: pip install 'wheelgym[cluster]' (pgserver) or "
                     "apt-get install postgresql")


#: Key of the PostgreSQL advisory lock (``pg_advisory_lock(bigint)``, per database) under which
#: :func:`rdb_storage` creates a study storage's schema: the CRC-32 of "wheelgym optuna schema".
SCHEMA_LOCK_KEY = zlib.crc32(b"wheelgym optuna schema")


def rdb_storage(url: str, **kwargs: Any):
    """``optuna.storages.RDBStorage(url, **kwargs)``, safe against workers started together.

    Creating an ``RDBStorage`` creates the schema where it is missing (the tables, on
    PostgreSQL also the enum types such as ``studydirection``, the version row and Alembic's
    revision), each step checking first whether it exists. Two processes doing that at the same
    moment on a fresh database both find it missing and one fails (``UniqueViolation ...
    pg_type_typname_nsp_index``, ``CREATE TYPE studydirection``). On PostgreSQL the creation
    therefore runs while this process holds a session advisory lock, :data:`SCHEMA_LOCK_KEY`,
    on a connection of its own: the workers create the schema one after the other, and the
    second finds it complete. The lock goes with the connection (released as well if the
    process dies). Other databases (SQLite, MySQL) are opened as they are.
    """
    import optuna
    import sqlalchemy

    if sqlalchemy.engine.make_url(url).get_backend_name() != "postgresql":
        return optuna.storages.RDBStorage(url, **kwargs)
    engine = sqlalchemy.create_engine(url, poolclass=sqlalchemy.pool.NullPool,
                                      **kwargs.get("engine_kwargs", {}))
    try:
        with engine.connect() as conn:
            conn.execute(sqlalchemy.text("SELECT pg_advisory_lock(:key)"),
                         {"key": SCHEMA_LOCK_KEY})
            try:
                return optuna.storages.RDBStorage(url, **kwargs)
            finally:
                conn.execute(sqlalchemy.text("SELECT pg_advisory_unlock(:key)"),
                             {"key": SCHEMA_LOCK_KEY})
    finally:
        engine.dispose()


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class LocalPostgres:
    """A PostgreSQL server on 127.0.0.1 in a new temporary data folder (a context manager).

    ``url``: ``postgresql+psycopg://postgres:<password>@127.0.0.1:<port>/postgres``. As root the
    server runs as ``user`` (PostgreSQL refuses root). :meth:`stop` stops it (fast shutdown)
    and removes the folder; so does leaving the ``with`` block.
    """

    def __init__(self, port: int | None = None, user: str = "nobody") -> None:
        self.port = port or _free_port()
        self.password = secrets.token_hex(12)
        self.bin = postgres_bin()
        self._user = user if os.geteuid() == 0 else None
        self.folder: Path | None = None
        self.url = (f"postgresql+psycopg://postgres:{self.password}@127.0.0.1:{self.port}"
                    "/postgres")

    def _run(self, *args: str, timeout: float = 60) -> None:
        done = subprocess.run([str(self.bin / args[0]), *args[1:]], capture_output=True,
                              text=True, timeout=timeout, user=self._user)
        if done.returncode != 0:
            raise RuntimeError(f"{args[0]} failed: {' '.join(done.stderr.split())[:300]}")

    def start(self) -> LocalPostgres:
        self.folder = Path(tempfile.mkdtemp(prefix="wheelgym-pg-"))
        data, pw = self.folder / "data", self.folder / "pw"
        pw.write_text(self.password + "\n")
        if self._user is not None:
            for p in (self.folder, pw):
                shutil.chown(p, user=self._user)
        try:
            self._run("initdb", "-D", str(data), "-U", "postgres", "--pwfile", str(pw),
                      "--auth-local=trust", "--auth-host=scram-sha-256", "--encoding=UTF8",
                      "--locale=C")
            self._run("pg_ctl", "-D", str(data), "-w", "-l", str(self.folder / "server.log"),
                      "-o", f"-h 127.0.0.1 -p {self.port} -k ''", "start")
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Stop the server (fast shutdown; killed if it does not stop) and remove its folder."""
        if self.folder is None:
            return
        data = self.folder / "data"
        pid_file = data / "postmaster.pid"
        if pid_file.is_file():
            pid = int(pid_file.read_text().split()[0])
            try:
                self._run("pg_ctl", "-D", str(data), "-w", "-m", "fast", "stop", timeout=30)
            except (RuntimeError, subprocess.TimeoutExpired):
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            for _ in range(100):  # the postmaster gone before its folder goes
                try:
                    os.kill(pid, 0)
                except ProcessLookupError:
                    break
                time.sleep(0.1)
        shutil.rmtree(self.folder, ignore_errors=True)
        self.folder = None

    def __enter__(self) -> LocalPostgres:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
