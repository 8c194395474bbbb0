"""The benchmark grid: every (config, seed) trained and scored, one results-CSV row each.

:func:`run_jobs` trains each (config, seed) job and appends its row to the CSV
(:mod:`wheelgym.agents.store`; ``benchmarks/results/training.csv`` by default) as soon as it
ends. Run again, it skips the jobs whose row is there (same config, seed, budget and evaluation
episodes), so the table can be built over several sittings, and seeds added later (``seeds=5``
after 3) train only the new ones; ``first_seed`` starts the seeds elsewhere than 0, for
seeds that no recipe was chosen on. ``workers`` > 1 runs jobs in parallel local processes, each
with one torch and one numba thread; ``ray`` runs them as Ray tasks instead, on this machine or
a cluster (:mod:`wheelgym.agents.cluster`). Either way only the main process writes the CSV.
Scores: :mod:`wheelgym.agents.scoring`. A ``budget`` (training steps) other than the config's
scales its ``eval_freq`` alike.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import wheelgym.agents.train as train_mod
from wheelgym.agents.cluster import WORKER_ENV, run_on_ray
from wheelgym.agents.config import (
    ON_POLICY,
    TrainConfig,
    configs_dir,
    load_config,
    parse_config,
    safe_load_config_yaml,
)
from wheelgym.agents.scoring import (
    baseline_scores,
    score_agent,
    score_columns,
    steps_to_baseline,
)
from wheelgym.agents.store import (
    DEFAULT_CSV,
    append_row,
    config_digest,
    drop_rows,
    parse_number,
    read_rows,
    row_key,
)
from wheelgym.agents.table import format_table

__all__ = ["run_jobs", "run_benchmark", "default_configs", "BenchmarkSummary", "Job", "run_job",
           "worker_init"]

def default_configs() -> list[Path]:
    """Every shipped config (:func:`wheelgym.resources.configs_dir`), sorted."""
    return sorted(configs_dir().glob("*.yml"))


def _scaled_eval_freq(config: TrainConfig, budget: int) -> int:
    """The config's evaluation period scaled to ``budget``, at least one rollout."""
    if budget == config.n_timesteps:
        return config.eval_freq
    freq = (config.eval_freq * budget // config.n_timesteps) if config.eval_freq else budget // 10
    rollout = config.n_envs * int(config.hyperparams.get("n_steps", 1))
    if config.algo not in ON_POLICY:
        rollout = config.n_envs
    return max(freq, rollout, 1)


@dataclass
class Job:
    path: str
    name: str
    seed: int
    budget: int
    episodes: int
    runs_root: str
    levels: dict[str, Any] = field(default_factory=dict)
    #: The config's file form, for a worker that cannot read ``path`` (another machine).
    data: dict | None = None
    #: :func:`config_digest` of the config as the benchmark was called with it.
    digest: str = ""

    @property
    def key(self) -> tuple[str, int, int, int]:
        return (self.name, self.seed, self.budget, self.episodes)


def run_job(job: Job) -> dict | None:
    """Train and score one (config, seed); the CSV row, or ``None`` when interrupted."""
    cpu0 = time.process_time()
    config = load_config(job.path) if job.data is None else parse_config(job.data, job.path)
    changes: dict[str, Any] = {"seed": job.seed, "n_timesteps": job.budget,
                               "eval_freq": _scaled_eval_freq(config, job.budget)}
    if os.environ.get(WORKER_ENV):
        changes["torch_threads"] = 1
    config = config.replace(**changes)
    # Looked up on the module at call time, so a wrapped train_mod.train is the one called.
    result = train_mod.train(config, runs_root=job.runs_root, progress=False)
    if result.status != "finished":
        return None
    agent_s = score_agent(result.run_dir, config, job.episodes)
    lv = job.levels
    reach = steps_to_baseline(result.run_dir / "eval.csv", lv["eval_success"], lv["eval_rms"])
    row: dict[str, Any] = {
        "config": job.name, "algo": config.algo, "seed": job.seed, "n_timesteps": job.budget,
        "episodes": job.episodes, "train_s": f"{result.wall_s:.1f}",
        "cpu_s": f"{time.process_time() - cpu0:.1f}",
        "steps_to_baseline": "" if reach is None else reach,
        "run_dir": str(result.run_dir),
        "finished_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "config_sha": job.digest,
    }
    row["recipe"] = config.recipe
    score_columns(row, agent_s, lv)
    return row


def end_with_parent() -> None:
    """Have this process receive SIGTERM when the process that started it ends (Linux's
    ``PR_SET_PDEATHSIG``; elsewhere nothing): a pool worker whose parent was killed stops
    instead of training on for a row nobody will write. A parent already gone ends it now."""
    import ctypes
    import sys

    if not sys.platform.startswith("linux"):
        return
    parent = os.getppid()
    try:  # the C library's prctl, already loaded in this process
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM), 0, 0, 0)  # PDEATHSIG
    except (OSError, AttributeError):
        return
    if parent == 1 or os.getppid() != parent:  # the parent ended before the call took effect
        os.kill(os.getpid(), signal.SIGTERM)


def worker_init() -> None:
    """A pool process: one torch thread, one numba thread; Ctrl-C is the training's to handle;
    it ends with its parent (:func:`end_with_parent`)."""
    end_with_parent()
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS", WORKER_ENV):
        os.environ[var] = "1"
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # train() installs its own handler meanwhile
    import numba
    import numba.core.config
    import torch

    # numba read NUMBA_NUM_THREADS when this process imported it (before this function ran);
    # reread it before its threads start, or the first compilation in the worker (a cold
    # cache) rereads the changed variable and refuses: "Cannot set NUMBA_NUM_THREADS to a
    # different value once the threads have been launched"
    numba.core.config.reload_config()
    torch.set_num_threads(1)
    numba.set_num_threads(1)


@dataclass
class BenchmarkSummary:
    """What a benchmark call did: rows written, jobs skipped and failed, its rows, wall time."""

    csv_path: Path
    written: int
    skipped: int
    failed: list[str]
    rows: list[dict[str, str]]
    wall_s: float


def _check_args(seeds: Any, episodes: Any, workers: Any, ray: Any, budget: Any,
                first_seed: Any = 0) -> None:
    for name, value in (("seeds", seeds), ("episodes", episodes), ("workers", workers)):
        if value is None and name == "workers":
            continue
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if (not isinstance(first_seed, int) or isinstance(first_seed, bool) or first_seed < 0
            or first_seed + seeds > 2**32):
        raise ValueError(f"first_seed must be an integer >= 0 with first_seed + seeds <= 2**32, "
                         f"got {first_seed!r}")
    if ray is not None and (not isinstance(ray, str) or not ray.strip()):
        raise ValueError(f"ray must be 'local', 'auto' or 'host:port', got {ray!r}")
    if budget is not None and (not isinstance(budget, int) or budget < 1):
        raise ValueError(f"budget must be an integer >= 1, got {budget!r}")


def _steps(config: TrainConfig, budget: int | None, quick: bool) -> int:
    """A job's training steps: ``budget``, a tenth of the config's (``quick``), or its own."""
    if budget is not None:
        return budget
    return max(config.n_timesteps // 10, 2048) if quick else config.n_timesteps


def _present_rows(csv_path: Path, loaded: list[tuple[Path, TrainConfig]], budget: int | None,
                  quick: bool, drop_stale: bool,
                  log: Callable[[str], None] | None) -> list[dict[str, str]]:
    """The CSV's rows, after dropping the stale ones of the configs given (``drop_stale``) or
    refusing them.

    A row is stale when its ``config_sha`` is not the config's :func:`config_digest` (empty:
    a row from before the column, kept), or, with ``drop_stale`` and no ``budget``/``quick``,
    when it is at another budget than the config's ``n_timesteps``. Judged row by row, so a row
    with the config's own digest is kept beside a stale one of the same seed."""
    present = read_rows(csv_path) if csv_path.is_file() else []
    digests = {p.stem: config_digest(c) for p, c in loaded}
    budgets = {p.stem: c.n_timesteps for p, c in loaded}

    def is_stale(r: dict[str, str]) -> bool:
        name = r["config"]
        if name not in digests:
            return False
        sha = r.get("config_sha") or ""
        other_budget = (budget is None and not quick
                        and int(float(r["n_timesteps"])) != budgets[name])
        return bool(sha and sha != digests[name]) or (drop_stale and other_budget)

    stale = [r for r in present if is_stale(r)]
    if stale and not drop_stale:
        names = sorted({r["config"] for r in stale})
        raise ValueError(f"{csv_path} holds {len(stale)} row(s) of {names} made with other "
                         f"settings than the config files now have (column config_sha); give "
                         f"--drop-stale to remove them and train again, or another --csv")
    if stale:
        n = drop_rows(csv_path, is_stale)
        if log is not None:
            log(f"benchmark: dropped {n} stale row(s) of "
                f"{sorted({r['config'] for r in stale})} from {csv_path}")
        present = read_rows(csv_path)
    return present


def _plan(loaded: list[tuple[Path, TrainConfig]], present: list[dict[str, str]],
          seeds: range, episodes: int, budget: int | None, quick: bool, root: Path,
          ray: str | None) -> tuple[list[Job], int]:
    """The jobs whose row is not in the CSV yet, and how many are."""
    done = {row_key(r) for r in present}
    jobs: list[Job] = []
    skipped = 0
    for path, config in loaded:
        digest = config_digest(config)
        for s in seeds:
            job = Job(str(path), path.stem, s, _steps(config, budget, quick), episodes,
                      str(root), digest=digest)
            if ray is not None:
                job.data = safe_load_config_yaml(path)
            if job.key in done:
                skipped += 1
            else:
                jobs.append(job)
    return jobs, skipped


class _Book:
    """The baseline levels per config (scored once, before its first job), the rows written
    and the jobs failed, with the log lines of each."""

    def __init__(self, csv_path: Path, n_jobs: int, log: Callable[[str], None] | None) -> None:
        self.csv_path, self.n_jobs, self.log = csv_path, n_jobs, log
        self.levels: dict[tuple[str, int], dict] = {}
        self.written = 0
        self.failed: list[str] = []

    def prepare(self, job: Job) -> Job:
        lk = (job.path, job.episodes)
        if lk not in self.levels:
            t = time.perf_counter()
            self.levels[lk] = baseline_scores(Path(job.path), job.episodes)
            if self.log is not None:
                b = self.levels[lk]["baseline"]
                succ = "n/a" if b["success"] is None else f"{100 * b['success']:.0f}%"
                self.log(f"{job.name}: baseline success {succ}, random "
                         f"{_pct(self.levels[lk]['random']['success'])} on {job.episodes} "
                         f"episodes ({time.perf_counter() - t:.0f} s)")
        job.levels = self.levels[lk]
        return job

    def finish(self, job: Job, row: dict | None, error: BaseException | None) -> None:
        if error is not None:
            msg = f"{job.name} seed {job.seed}: {type(error).__name__}: {error}"
            self.failed.append(" ".join(msg.split())[:300])
            if self.log is not None:
                self.log(f"  FAILED {self.failed[-1]}")
            return
        if row is None:
            return
        append_row(self.csv_path, row)
        self.written += 1
        if self.log is not None:
            reach = row["steps_to_baseline"]
            self.log(f"  {job.name} seed {job.seed}: {job.budget} steps in "
                     f"{float(row['train_s']):.0f} s, success "
                     f"{_pct(parse_number(row['agent_success']))} (baseline "
                     f"{_pct(parse_number(row['baseline_success']))}), return "
                     f"{row['agent_return']}, baseline level "
                     f"{'never' if reach == '' else f'at {reach} steps'} "
                     f"[{self.written}/{self.n_jobs}]")


def _run_serial(jobs: list[Job], book: _Book) -> bool:
    """The jobs one after the other in this process; whether a Ctrl-C ended them."""
    for job in jobs:
        try:
            row = run_job(book.prepare(job))
        except KeyboardInterrupt:
            return True
        except Exception as e:
            book.finish(job, None, e)
            continue
        if row is None:
            return True
        book.finish(job, row, None)
    return False


def _drain(running: dict[Future, Job], book: _Book) -> None:
    """After a Ctrl-C (the workers got SIGINT too): keep what ends, start nothing new."""
    try:
        for fut in list(running):
            try:
                row = fut.result()
            except Exception:
                row = None
            book.finish(running.pop(fut), row, None)
    except KeyboardInterrupt:
        pass


def _run_pool(jobs: list[Job], workers: int, book: _Book) -> bool:
    """The jobs on ``workers`` local processes; whether a Ctrl-C ended them."""
    import multiprocessing as mp

    pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                               initializer=worker_init)
    running: dict[Future, Job] = {}
    queue = list(jobs)
    interrupted = False
    try:
        while (queue or running) and not interrupted:
            while queue and len(running) < workers:
                job = book.prepare(queue.pop(0))
                running[pool.submit(run_job, job)] = job
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in finished:
                job = running.pop(fut)
                try:
                    row = fut.result()
                except Exception as e:
                    book.finish(job, None, e)
                    continue
                interrupted = interrupted or row is None
                book.finish(job, row, None)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if interrupted:
            _drain(running, book)
        pool.shutdown(wait=True, cancel_futures=True)
    return interrupted


def run_jobs(
    configs: Sequence[str | Path] | None = None,
    *,
    seeds: int = 5,
    episodes: int = 50,
    budget: int | None = None,
    quick: bool = False,
    csv_path: str | Path = DEFAULT_CSV,
    first_seed: int = 0,
    runs_root: str | Path = "runs/benchmark",
    workers: int | None = None,
    ray: str | None = None,
    drop_stale: bool = False,
    log: Callable[[str], None] | None = None,
) -> BenchmarkSummary:
    """Train and score every (config, seed) whose row is not in ``csv_path`` yet; append rows.

    ``seeds``: seeds ``first_seed .. first_seed + seeds - 1`` per config (``first_seed`` 0:
    the table's; a later one gives seeds that no recipe was chosen on). ``budget`` overrides
    each config's ``n_timesteps``; ``quick``: a tenth of each budget (at least 2048 steps).
    ``workers``: parallel local processes (default 1); with ``ray`` (an address: ``local``,
    ``auto`` or ``host:port``) the jobs are Ray tasks instead, ``workers`` then caps the tasks
    at a time (``local``: the instance's CPUs; default all), and a task that raised is retried
    once.
    Ctrl-C keeps the finished rows (running jobs stop and are dropped) and re-raises
    ``KeyboardInterrupt``; a job that raised is reported in ``failed``.

    A row is finished when its key (config name, seed, budget, episodes) is in the CSV and its
    ``config_sha`` is the config's :func:`config_digest` (or empty: a row from before the
    column). Rows of a config made with other settings (a re-tuned config) are stale: the call
    refuses (``ValueError``) unless ``drop_stale``, which removes them first, and with them,
    when no ``budget`` or ``quick`` is given, the config's rows at budgets other than its
    ``n_timesteps``; the stale rows' runs are then trained again.
    """
    _check_args(seeds, episodes, workers, ray, budget, first_seed)
    csv_path, root = Path(csv_path), Path(runs_root)
    if ray is not None:
        root = root.resolve()  # a task's working folder is not the driver's
    if root.exists() and not root.is_dir():
        raise ValueError(f"runs root {str(root)!r} exists and is not a folder")
    if csv_path.is_dir():
        raise ValueError(f"--csv {str(csv_path)!r} is a folder; give a file name")
    paths = [Path(p) for p in configs] if configs else default_configs()
    loaded = [(p, load_config(p)) for p in paths]  # every config checked before any work
    present = _present_rows(csv_path, loaded, budget, quick, drop_stale, log)
    jobs, skipped = _plan(loaded, present, range(first_seed, first_seed + seeds), episodes,
                          budget, quick, root, ray)
    if log is not None:
        where = (f"Ray at {ray}" if ray is not None else f"{workers or 1} worker(s)")
        log(f"benchmark: {len(jobs)} run(s) to do, {skipped} already in {csv_path}; {where}")
    t0 = time.perf_counter()
    book = _Book(csv_path, len(jobs), log)
    if ray is not None:
        interrupted = run_on_ray(jobs, ray, run=run_job, prepare=book.prepare,
                                 finish=book.finish, limit=workers, log=log)
    elif (workers or 1) == 1:
        interrupted = _run_serial(jobs, book)
    else:
        interrupted = _run_pool(jobs, workers, book)
    rows = read_rows(csv_path) if csv_path.is_file() else []
    summary = BenchmarkSummary(csv_path, book.written, skipped, book.failed, rows,
                               time.perf_counter() - t0)
    if interrupted:
        if log is not None:
            log(f"interrupted: {book.written} row(s) written to {csv_path}")
        raise KeyboardInterrupt
    return summary


def _pct(v: float | None) -> str:
    return "n/a" if v is None else f"{100 * v:.0f}%"


def run_benchmark(
    configs: Sequence[str | Path] | None = None,
    *,
    quick: bool = False,
    seeds: int | None = None,
    episodes: int | None = None,
    budget: int | None = None,
    runs_root: str | Path = "runs/benchmark",
    csv_path: str | Path = DEFAULT_CSV,
    first_seed: int = 0,
    workers: int | None = None,
    ray: str | None = None,
    drop_stale: bool = False,
    log: Callable[[str], None] | None = None,
) -> str:
    """:func:`run_jobs`, then the Markdown table of this call's configs, budgets and episodes.

    Defaults: 5 seeds from ``first_seed`` (0-4; the rows of seeds already in the CSV are
    kept; the table shows this call's seeds only), 50 evaluation episodes, each config's
    ``n_timesteps``; ``quick``: 1 seed, 5 episodes, a tenth of each budget (at least 2048
    steps). Raises ``RuntimeError`` naming the jobs that failed (after writing the others).
    """
    n_seeds = seeds if seeds is not None else (1 if quick else 5)
    n_eps = episodes if episodes is not None else (5 if quick else 50)
    paths = [Path(p) for p in configs] if configs else default_configs()
    summary = run_jobs(paths, seeds=n_seeds, episodes=n_eps, budget=budget, quick=quick,
                       csv_path=csv_path, first_seed=first_seed, runs_root=runs_root,
                       workers=workers, ray=ray, drop_stale=drop_stale, log=log)
    wanted = set()
    for p in paths:
        steps = _steps(load_config(p), budget, quick)
        wanted |= {(p.stem, s, steps, n_eps)
                   for s in range(first_seed, first_seed + n_seeds)}
    rows = [r for r in summary.rows if row_key(r) in wanted]
    table = format_table(rows)
    if summary.failed:
        raise RuntimeError(f"{len(summary.failed)} run(s) failed (their rows are missing; run "
                           f"again to retry): {'; '.join(summary.failed)}")
    return table
