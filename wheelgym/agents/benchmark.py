"""The results table: every config (id x task x action mode) trained on several seeds, scored
against the analytic baseline and a random policy on the same evaluation seeds.

:func:`run_benchmark` trains each (config, seed) job and appends its row to a CSV
(by default :data:`DEFAULT_CSV`, see its comment) as soon as it ends: one line, appended,
flushed and fsync'd, so a killed process loses at most its running jobs. Run again, it skips the
jobs whose row is there (same config, seed, budget and evaluation episodes), so the table can be
built over several sittings. ``workers`` > 1 runs jobs in parallel local processes, each with
one torch and one numba thread; ``ray`` runs them as Ray tasks instead, on this machine or a
cluster (:mod:`wheelgym.agents.cluster`). Either way only the main process writes the CSV.

Per config, before its jobs, the baseline and random policies are scored on the evaluation seeds
(``EVAL_SEED + i``, ``i < episodes``, the agents' too), and the baseline once more on the seeds
of the training's periodic evaluation (``EVAL_HISTORY_SEED + i``, ``i < eval_episodes``): its
level there (``baseline_eval_*``) is what ``steps_to_baseline`` compares the run's eval.csv
with: the first evaluation with a success rate within 5 points of the baseline's (``goal``,
``navigate``) or an RMS tracking error within 2x the baseline's (``track``); empty if never.
A ``budget`` (training steps) other than the config's scales its ``eval_freq`` alike.

CSV columns (:data:`COLUMNS`): ``success`` and ``saturation`` are fractions, ``rms`` [m],
``energy`` [J], ``internal_force`` [N·m] means over episodes; empty where the metric does not
apply (RMS off ``track``, energy on kinematic robots, internal force but on ThreeWheel) or the
baseline is missing. ``train_s``: training wall time; ``cpu_s``: the job's CPU time (training and
evaluation). ``run_dir``: the run folder, for the learning curves.

:func:`format_table` turns rows into the README's Markdown table (mean ± std over seeds);
:func:`plot_curves` draws learning curves from the run folders' eval.csv.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import signal
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures import as_completed as _as_completed
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

import wheelgym.agents.train as train_mod
from wheelgym import resources
from wheelgym.agents.cluster import WORKER_ENV, run_on_ray
from wheelgym.agents.common import make_single_env
from wheelgym.agents.config import (
    ON_POLICY,
    WHEELGYM_BLOCK,
    TrainConfig,
    configs_dir,
    load_config,
    parse_config,
    safe_load_config_yaml,
)
from wheelgym.agents.evaluate import _figure, applicable_metrics, evaluate_policy_episodes
from wheelgym.agents.policies import RandomPolicy, load_agent, make_baseline
from wheelgym.agents.train import EVAL_HISTORY_SEED

__all__ = [
    "COLUMNS",
    "DEFAULT_CSV",
    "run_benchmark",
    "run_jobs",
    "read_rows",
    "format_table",
    "plot_curves",
    "steps_to_baseline",
    "default_configs",
    "config_digest",
    "BenchmarkSummary",
    "rescore",
]

EVAL_SEED = 200_000
#: The repository's committed CSV in a source checkout, else runs/benchmark/training.csv.
DEFAULT_CSV = resources.results_csv()

#: Columns of the results CSV, in order.
COLUMNS: tuple[str, ...] = (
    "config", "algo", "seed", "n_timesteps", "episodes", "train_s", "cpu_s", "steps_to_baseline",
    "agent_success", "baseline_success", "random_success",
    "agent_rms", "baseline_rms",
    "agent_return", "baseline_return", "random_return",
    "agent_energy", "baseline_energy",
    "agent_internal_force", "baseline_internal_force",
    "agent_saturation", "baseline_saturation",
    "baseline_eval_success", "baseline_eval_rms",
    "run_dir", "finished_utc", "config_sha",
)

#: Episode attributes behind the metric columns: column suffix -> Episode attribute.
_METRICS: dict[str, str] = {
    "success": "success",
    "rms": "rms_tracking_error",
    "return": "ret",
    "energy": "energy",
    "internal_force": "mean_internal_force",
    "saturation": "saturation",
}

#: Steps-to-baseline levels: success within this many points, RMS within this factor.
SUCCESS_POINTS = 5.0
RMS_FACTOR = 2.0


def default_configs() -> list[Path]:
    """Every shipped config (:func:`wheelgym.resources.configs_dir`), sorted."""
    return sorted(configs_dir().glob("*.yml"))


# --------------------------------------------------------------------------------------------
# scoring
# --------------------------------------------------------------------------------------------


def _fmt(v: float | None) -> str:
    return "" if v is None else f"{v:.6g}"


def parse_number(text: Any) -> float | None:
    """A CSV cell as a finite float, or None (empty, not a number, or not finite)."""
    if text is None or str(text).strip() == "":
        return None
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def _mean(values: Sequence[Any]) -> float | None:
    vals = [float(v) for v in values if v is not None]
    return float(np.mean(vals)) if vals else None


def _score(episodes: list | None, applicable: Sequence[str]) -> dict[str, float | None]:
    """Mean over episodes of each metric column (``None`` where it does not apply)."""
    out: dict[str, float | None] = {}
    for col, attr in _METRICS.items():
        if episodes is None or attr not in applicable:
            out[col] = None
        else:
            out[col] = _mean([getattr(e, attr) for e in episodes])
    return out


def _baseline_scores(path: Path, episodes: int) -> dict[str, Any]:
    """Baseline and random on the evaluation seeds, and the baseline on eval.csv's seeds."""
    config = load_config(path)
    seeds = [EVAL_SEED + i for i in range(episodes)]
    env = make_single_env(config)
    try:
        applicable = applicable_metrics(env)
        try:
            baseline = make_baseline(env)
        except ValueError:
            baseline = None
        base_eps = eval_eps = None
        if baseline is not None:
            base_eps = evaluate_policy_episodes(env, baseline, seeds, record=False)
            hist = [EVAL_HISTORY_SEED + i for i in range(config.eval_episodes)]
            eval_eps = evaluate_policy_episodes(env, baseline, hist, record=False)
        rand_eps = evaluate_policy_episodes(env, RandomPolicy(env.action_space), seeds,
                                            record=False)
    finally:
        env.close()
    base = _score(base_eps, applicable)
    ev = _score(eval_eps, applicable)
    return {"baseline": base, "random": _score(rand_eps, applicable),
            "eval_success": ev["success"], "eval_rms": ev["rms"]}


def steps_to_baseline(eval_csv: str | Path, success: float | None, rms: float | None) -> int | None:
    """The first evaluation's steps in ``eval_csv`` at the baseline's level, else ``None``.

    With an RMS level (``track``): RMS error at most :data:`RMS_FACTOR` x ``rms``; otherwise a
    success rate at least ``success`` minus :data:`SUCCESS_POINTS` points (rates as fractions).
    """
    path = Path(eval_csv)
    if not path.is_file() or (success is None and rms is None):
        return None
    with path.open(newline="") as f:
        for row in csv.DictReader(f):
            steps = parse_number(row.get("timesteps"))
            if steps is None:
                continue
            if rms is not None:
                err = parse_number(row.get("rms_tracking_error"))
                if err is not None and err <= RMS_FACTOR * rms:
                    return int(steps)
            elif success is not None:
                rate = parse_number(row.get("success_rate"))
                if rate is not None and 100 * rate >= 100 * success - SUCCESS_POINTS - 1e-9:
                    return int(steps)
    return None


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
class _Job:
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


def _score_agent(run_dir: Path, config: TrainConfig, episodes: int) -> dict[str, float | None]:
    """The scores of the run's final model on the evaluation seeds."""
    agent = load_agent(run_dir / "model.zip", config.algo, run_dir / "vecnormalize.pkl",
                       device=config.device)
    env = make_single_env(config)
    try:
        applicable = applicable_metrics(env)
        eps = evaluate_policy_episodes(env, agent, [EVAL_SEED + i for i in range(episodes)],
                                       record=False)
    finally:
        env.close()
    return _score(eps, applicable)


def _run_job(job: _Job) -> dict | None:
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
    agent_s = _score_agent(result.run_dir, config, job.episodes)
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
    _score_columns(row, agent_s, lv)
    return row


def _worker_init() -> None:
    """A pool process: one torch thread, one numba thread; Ctrl-C is the training's to handle."""
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


# --------------------------------------------------------------------------------------------
# the CSV
# --------------------------------------------------------------------------------------------


def read_rows(path: str | Path) -> list[dict[str, str]]:
    """The rows of a results CSV (a torn last line from a killed writer is skipped)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"results CSV {str(path)!r} not found")
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in ("config", "seed", "n_timesteps") if c not in (reader.fieldnames
                                                                            or [])]
        if missing:
            raise ValueError(f"{path}: not a results CSV (no columns {missing})")
        return [r for r in reader if _is_row(r)]


def config_digest(config: TrainConfig) -> str:
    """12 hex digits of SHA-256 over the config's file form, without what does not change a
    result row (the seed, which each job sets, and the checkpoint period) and the budget (the
    row key holds it): the ``config_sha`` column, by which a re-tuned config's old rows are told
    apart from its new ones."""
    data = config.to_dict()
    for key in ("seed", "checkpoint_freq"):
        data[WHEELGYM_BLOCK].pop(key, None)
    next(v for k, v in data.items() if k != WHEELGYM_BLOCK).pop("n_timesteps", None)
    text = json.dumps(data, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _rewrite_rows(path: Path, transform: Callable[[list[dict[str, str]]], list[dict[str, Any]]]
                  ) -> tuple[int, int]:
    """Rewrite ``path`` in place with ``transform`` of its whole rows, under the lock the
    appenders take (so that a row appended meanwhile by another process is kept); the numbers
    of rows before and after."""
    with path.open("r+", newline="") as f:
        _lock(f)
        reader = csv.DictReader(f)
        header = list(reader.fieldnames or COLUMNS)
        rows = [r for r in reader if None not in r and None not in r.values()]
        new = transform(rows)
        f.seek(0)
        f.truncate()
        w = csv.DictWriter(f, fieldnames=header, extrasaction="ignore")
        w.writeheader()
        w.writerows(new)
        f.flush()
        os.fsync(f.fileno())
    return len(rows), len(new)


def _drop_rows(path: Path, stale: Callable[[dict[str, str]], bool]) -> int:
    """Rewrite ``path`` without the whole rows for which ``stale(row)`` holds
    (:func:`_rewrite_rows`); the number dropped."""
    before, after = _rewrite_rows(
        path, lambda rows: [r for r in rows if not (_is_row(r) and stale(r))])
    return before - after


def _is_row(r: dict[str, str]) -> bool:
    """A whole row (not a torn line) with a config name, seed and budget."""
    return (None not in r and None not in r.values() and bool(r.get("config"))
            and parse_number(r.get("n_timesteps")) is not None
            and parse_number(r.get("seed")) is not None)


def _lock(f) -> None:
    """Hold an exclusive lock on the open CSV ``f`` (appenders and rewriters take it; a no-op
    where ``fcntl`` is missing)."""
    try:
        import fcntl

        fcntl.flock(f, fcntl.LOCK_EX)
    except (ImportError, OSError):
        pass


def _row_key(r: dict[str, str]) -> tuple[str, int, int, int]:
    return (r["config"], int(float(r["seed"])), int(float(r["n_timesteps"])),
            int(float(r.get("episodes") or 0)))


def _append_row(path: Path, row: dict[str, Any]) -> None:
    """Append one row (header first in a new file); flushed and fsync'd before returning."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a+", newline="") as f:
        _lock(f)  # another benchmark process appending meanwhile
        f.seek(0, os.SEEK_END)
        if f.tell() == 0:
            header = list(COLUMNS)
        else:
            f.seek(0)
            header = next(csv.reader(f), list(COLUMNS))
            f.seek(0, os.SEEK_END)
            f.seek(f.tell() - 1)
            if f.read(1) != "\n":  # a torn line from a killed writer: start a new one
                f.write("\n")
        missing = [c for c in COLUMNS if c not in header]
        if missing:
            raise ValueError(f"{path}: its header lacks columns {missing}; use another --csv")
        w = csv.DictWriter(f, fieldnames=header, extrasaction="ignore")
        if f.tell() == 0:
            w.writeheader()
        w.writerow(row)
        f.flush()
        os.fsync(f.fileno())


# --------------------------------------------------------------------------------------------
# run
# --------------------------------------------------------------------------------------------


@dataclass
class BenchmarkSummary:
    """What a benchmark call did: rows written, jobs skipped and failed, its rows, wall time."""

    csv_path: Path
    written: int
    skipped: int
    failed: list[str]
    rows: list[dict[str, str]]
    wall_s: float


def run_jobs(
    configs: Sequence[str | Path] | None = None,
    *,
    seeds: int = 3,
    episodes: int = 50,
    budget: int | None = None,
    quick: bool = False,
    csv_path: str | Path = DEFAULT_CSV,
    runs_root: str | Path = "runs/benchmark",
    workers: int | None = None,
    ray: str | None = None,
    drop_stale: bool = False,
    log: Callable[[str], None] | None = None,
) -> BenchmarkSummary:
    """Train and score every (config, seed) whose row is not in ``csv_path`` yet; append rows.

    ``budget`` overrides each config's ``n_timesteps``; ``quick``: a tenth of each budget (at
    least 2048 steps). ``workers``: parallel local processes (default 1); with ``ray`` (an
    address: ``local``, ``auto`` or ``host:port``) the jobs are Ray tasks instead, ``workers``
    then caps the tasks at a time (``local``: the instance's CPUs; default all), and a task
    that raised is retried once. Ctrl-C keeps the finished rows (running jobs stop and are
    dropped) and re-raises ``KeyboardInterrupt``; a job that raised is reported in ``failed``.

    A row is finished when its key (config name, seed, budget, episodes) is in the CSV and its
    ``config_sha`` is the config's :func:`config_digest` (or empty: a row from before the
    column). Rows of a config made with other settings (a re-tuned config) are stale: the call
    refuses (``ValueError``) unless ``drop_stale``, which removes them first, and with them,
    when no ``budget`` or ``quick`` is given, the config's rows at budgets other than its
    ``n_timesteps``; the stale rows' runs are then trained again.
    """
    for name, value in (("seeds", seeds), ("episodes", episodes), ("workers", workers)):
        if value is None and name == "workers":
            continue
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if ray is not None and (not isinstance(ray, str) or not ray.strip()):
        raise ValueError(f"ray must be 'local', 'auto' or 'host:port', got {ray!r}")
    if budget is not None and (not isinstance(budget, int) or budget < 1):
        raise ValueError(f"budget must be an integer >= 1, got {budget!r}")
    csv_path, root = Path(csv_path), Path(runs_root)
    if ray is not None:
        root = root.resolve()  # a task's working folder is not the driver's
    if root.exists() and not root.is_dir():
        raise ValueError(f"runs root {str(root)!r} exists and is not a folder")
    if csv_path.is_dir():
        raise ValueError(f"--csv {str(csv_path)!r} is a folder; give a file name")
    paths = [Path(p) for p in configs] if configs else default_configs()
    loaded = [(p, load_config(p)) for p in paths]  # every config checked before any work
    present = read_rows(csv_path) if csv_path.is_file() else []
    digests = {p.stem: config_digest(c) for p, c in loaded}
    budgets = {p.stem: c.n_timesteps for p, c in loaded}
    def is_stale(r: dict[str, str]) -> bool:
        """A row of a config given, made with other settings (or, with ``drop_stale`` and no
        ``budget``, at another budget than its ``n_timesteps``). Judged row by row, so a row
        with the config's own digest is kept beside a stale one of the same seed."""
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
        n = _drop_rows(csv_path, is_stale)
        if log is not None:
            log(f"benchmark: dropped {n} stale row(s) of "
                f"{sorted({r['config'] for r in stale})} from {csv_path}")
        present = read_rows(csv_path)
    done = {_row_key(r) for r in present}

    jobs: list[_Job] = []
    skipped = 0
    for path, config in loaded:
        steps = budget if budget is not None else (
            max(config.n_timesteps // 10, 2048) if quick else config.n_timesteps)
        for s in range(seeds):
            job = _Job(str(path), path.stem, s, steps, episodes, str(root),
                       digest=digests[path.stem])
            if ray is not None:
                job.data = safe_load_config_yaml(path)
            if job.key in done:
                skipped += 1
            else:
                jobs.append(job)
    if log is not None:
        where = (f"Ray at {ray}" if ray is not None else f"{workers or 1} worker(s)")
        log(f"benchmark: {len(jobs)} run(s) to do, {skipped} already in {csv_path}; {where}")
    t0 = time.perf_counter()
    written = 0
    failed: list[str] = []
    levels: dict[tuple[str, int], dict] = {}

    def prepare(job: _Job) -> _Job:
        lk = (job.path, job.episodes)
        if lk not in levels:
            t = time.perf_counter()
            levels[lk] = _baseline_scores(Path(job.path), job.episodes)
            if log is not None:
                b = levels[lk]["baseline"]
                succ = "n/a" if b["success"] is None else f"{100 * b['success']:.0f}%"
                log(f"{job.name}: baseline success {succ}, random "
                    f"{_pct(levels[lk]['random']['success'])} on {job.episodes} episodes "
                    f"({time.perf_counter() - t:.0f} s)")
        job.levels = levels[lk]
        return job

    def finish(job: _Job, row: dict | None, error: BaseException | None) -> None:
        nonlocal written
        if error is not None:
            msg = f"{job.name} seed {job.seed}: {type(error).__name__}: {error}"
            failed.append(" ".join(msg.split())[:300])
            if log is not None:
                log(f"  FAILED {failed[-1]}")
            return
        if row is None:
            return
        _append_row(csv_path, row)
        written += 1
        if log is not None:
            reach = row["steps_to_baseline"]
            log(f"  {job.name} seed {job.seed}: {job.budget} steps in {float(row['train_s']):.0f}"
                f" s, success {_pct(parse_number(row['agent_success']))} (baseline "
                f"{_pct(parse_number(row['baseline_success']))}), return {row['agent_return']}, "
                f"baseline level {'never' if reach == '' else f'at {reach} steps'} "
                f"[{written}/{len(jobs)}]")

    interrupted = False
    if ray is not None:
        interrupted = run_on_ray(jobs, ray, run=_run_job, prepare=prepare, finish=finish,
                                 limit=workers, log=log)
    elif (workers or 1) == 1:
        for job in jobs:
            row = None
            try:
                row = _run_job(prepare(job))
            except KeyboardInterrupt:
                interrupted = True
                break
            except Exception as e:
                finish(job, None, e)
                continue
            if row is None:
                interrupted = True
                break
            finish(job, row, None)
    else:
        import multiprocessing as mp

        pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                   initializer=_worker_init)
        running: dict[Future, _Job] = {}
        queue = list(jobs)
        try:
            while queue or running:
                while queue and len(running) < workers:
                    job = prepare(queue.pop(0))
                    running[pool.submit(_run_job, job)] = job
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                for fut in finished:
                    job = running.pop(fut)
                    try:
                        row = fut.result()
                    except Exception as e:
                        finish(job, None, e)
                        continue
                    if row is None:
                        interrupted = True
                    finish(job, row, None)
                if interrupted:
                    break
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if interrupted:  # the workers got SIGINT too: keep what ends, start nothing new
                try:
                    for fut in list(running):
                        try:
                            row = fut.result()
                        except Exception:
                            row = None
                        finish(running.pop(fut), row, None)
                except KeyboardInterrupt:
                    pass
            pool.shutdown(wait=True, cancel_futures=True)
    rows = read_rows(csv_path) if csv_path.is_file() else []
    summary = BenchmarkSummary(csv_path, written, skipped, failed, rows,
                               time.perf_counter() - t0)
    if interrupted:
        if log is not None:
            log(f"interrupted: {written} row(s) written to {csv_path}")
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
    workers: int | None = None,
    ray: str | None = None,
    drop_stale: bool = False,
    log: Callable[[str], None] | None = None,
) -> str:
    """:func:`run_jobs`, then the Markdown table of this call's configs, budgets and episodes.

    Defaults: 3 seeds, 50 evaluation episodes, each config's ``n_timesteps``; ``quick``: 1 seed,
    5 episodes, a tenth of each budget (at least 2048 steps). Raises ``RuntimeError`` naming the
    jobs that failed (after writing the others).
    """
    n_seeds = seeds if seeds is not None else (1 if quick else 3)
    n_eps = episodes if episodes is not None else (5 if quick else 50)
    paths = [Path(p) for p in configs] if configs else default_configs()
    summary = run_jobs(paths, seeds=n_seeds, episodes=n_eps, budget=budget, quick=quick,
                       csv_path=csv_path, runs_root=runs_root, workers=workers, ray=ray,
                       drop_stale=drop_stale, log=log)
    wanted = set()
    for p in paths:
        c = load_config(p)
        steps = budget if budget is not None else (
            max(c.n_timesteps // 10, 2048) if quick else c.n_timesteps)
        wanted |= {(p.stem, s, steps, n_eps) for s in range(n_seeds)}
    rows = [r for r in summary.rows if _row_key(r) in wanted]
    table = format_table(rows)
    if summary.failed:
        raise RuntimeError(f"{len(summary.failed)} run(s) failed (their rows are missing; run "
                           f"again to retry): {'; '.join(summary.failed)}")
    return table


# --------------------------------------------------------------------------------------------
# re-scoring
# --------------------------------------------------------------------------------------------


def _score_columns(row: dict[str, Any], agent_s: dict[str, float | None],
                   levels: dict[str, Any]) -> None:
    """Put the agent's, baseline's and random scores into ``row``."""
    for col in _METRICS:
        row[f"agent_{col}"] = _fmt(agent_s[col])
        row[f"baseline_{col}"] = _fmt(levels["baseline"][col])
    row["random_success"] = _fmt(levels["random"]["success"])
    row["random_return"] = _fmt(levels["random"]["return"])
    row["baseline_eval_success"] = _fmt(levels["eval_success"])
    row["baseline_eval_rms"] = _fmt(levels["eval_rms"])


def _rescore_group(rows: list[dict[str, str]]) -> tuple[list[dict[str, str]], list[str]]:
    """Score the finished runs of one config's rows (same episodes) again from their run
    folders: the rows with every score column replaced, and a note per row whose success or
    return came out different (the evaluation is deterministic: a difference is a finding)."""
    episodes = int(float(rows[0]["episodes"]))
    levels = _baseline_scores(Path(rows[0]["run_dir"]) / "config.yml", episodes)
    out, changed = [], []
    for old in rows:
        run_dir = Path(old["run_dir"])
        row = dict(old)
        agent_s = _score_agent(run_dir, load_config(run_dir / "config.yml"), episodes)
        _score_columns(row, agent_s, levels)
        reach = steps_to_baseline(run_dir / "eval.csv", levels["eval_success"],
                                  levels["eval_rms"])
        row["steps_to_baseline"] = "" if reach is None else reach
        for col in ("agent_success", "agent_return", "baseline_success"):
            a, b = parse_number(old.get(col)), parse_number(row[col])
            if (a is None) != (b is None) or (a is not None and abs(a - b) > 1e-9 * max(1, abs(a))):
                changed.append(f"{old['config']} seed {old['seed']}: {col} {old.get(col)} -> "
                               f"{row[col]}")
        out.append(row)
    return out, changed


def _replace_rows(path: Path, new: dict[tuple[str, int, int, int], dict[str, Any]]) -> None:
    """Rewrite ``path`` with the rows whose key is in ``new`` replaced (:func:`_rewrite_rows`)."""
    _rewrite_rows(path, lambda rows: [new.get(_row_key(r), r) if _is_row(r) else r
                                      for r in rows])


def rescore(
    csv_path: str | Path = DEFAULT_CSV,
    configs: Sequence[str] | None = None,
    *,
    workers: int | None = None,
    log: Callable[[str], None] | None = None,
) -> list[str]:
    """Score the rows of ``csv_path`` again from their run folders, without training.

    For a change to the evaluation (a metric's definition): each row's agent is loaded from its
    ``run_dir`` and evaluated on the same seeds, the baseline and random policy are scored
    again per config, and the row's score columns are replaced (its training columns are
    kept). ``configs``: the config names to re-score (default all). Each config's rows are
    written as soon as they are scored (a Ctrl-C keeps those). Returns the notes of rows
    whose success or return changed (they should not: the policies are deterministic)."""
    csv_path = Path(csv_path)
    rows = read_rows(csv_path)
    names = sorted({r["config"] for r in rows})
    if configs:
        bad = sorted(set(configs) - set(names))
        if bad:
            raise ValueError(f"configs {bad} have no rows in {csv_path}; configs there: {names}")
        names = [n for n in names if n in set(configs)]
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool)
                                or workers < 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    groups: dict[tuple[str, str], list[dict[str, str]]] = {}
    for r in rows:
        if r["config"] in names:
            groups.setdefault((r["config"], r.get("episodes", "")), []).append(r)
    missing = [r["run_dir"] for g in groups.values() for r in g
               if not (Path(r["run_dir"]) / "model.zip").is_file()]
    if missing:
        raise ValueError(f"{len(missing)} row(s) have no model in their run_dir: {missing[:3]}")
    notes: list[str] = []
    t0 = time.perf_counter()

    def done(key: tuple[str, str], result: tuple[list[dict[str, str]], list[str]]) -> None:
        new_rows, changed = result
        _replace_rows(csv_path, {_row_key(r): r for r in new_rows})
        notes.extend(changed)
        if log is not None:
            log(f"{key[0]}: {len(new_rows)} row(s) re-scored"
                f"{f', {len(changed)} changed' if changed else ''} "
                f"({time.perf_counter() - t0:.0f} s)")

    if (workers or 1) == 1:
        for key, g in groups.items():
            done(key, _rescore_group(g))
    else:
        import multiprocessing as mp

        with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                                 initializer=_worker_init) as pool:
            futures = {pool.submit(_rescore_group, g): key for key, g in groups.items()}
            try:
                for fut in _as_completed(futures):
                    done(futures[fut], fut.result())
            except KeyboardInterrupt:
                pool.shutdown(wait=False, cancel_futures=True)
                raise
    return notes


# --------------------------------------------------------------------------------------------
# table
# --------------------------------------------------------------------------------------------


def _cell(values: Sequence[float | None], scale: float, digits: int, spread: bool = True) -> str:
    vals = [v for v in values if v is not None]
    if not vals:
        return "-"
    a = np.asarray(vals, dtype=np.float64) * scale
    if len(a) == 1 or not spread:
        return f"{a.mean():.{digits}f}"
    return f"{a.mean():.{digits}f} ± {a.std():.{digits}f}"


def _reach_cell(values: Sequence[float | None]) -> str:
    hit = [v for v in values if v is not None]
    if not hit:
        return "never"
    mean = float(np.mean(hit))
    text = f"{mean / 1000:.0f}k" if mean >= 10_000 else f"{mean:.0f}"
    return text if len(hit) == len(values) else f"{text} ({len(hit)}/{len(values)})"


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


TABLE_HEAD: tuple[str, ...] = (
    "config", "algo", "steps", "seeds", "episodes",
    "agent success [%]", "baseline success [%]", "random success [%]",
    "agent RMS [m]", "baseline RMS [m]", "agent return", "baseline return", "random return",
    "energy / baseline", "internal force / baseline", "agent saturation [%]",
    "steps to baseline", "train [s/seed]", "targets",
)

#: The results targets (issue 15), on the means over seeds: success (goal: >= 95% and >= the
#: baseline's - 5 points; navigate: >= the baseline's - 5 points; track: >= 90%), track RMS
#: error <= max(2x the baseline's, 2 cm), ThreeWheel torque mode internal force <= 3x and energy
#: <= 1.5x the baseline's, saturation <= 25% of the episode, training <= 10 min per seed.
TARGETS = {"goal_success": 0.95, "track_success": 0.90, "below_baseline": 0.05,
           "rms_factor": 2.0, "rms_floor": 0.02, "internal_force_factor": 3.0,
           "energy_factor": 1.5, "saturation": 0.25, "train_s": 600.0}


def target_misses(config: str, col: Callable[[str], list[float | None]]) -> list[str]:
    """The targets (:data:`TARGETS`) that the means over seeds of a config's rows miss.

    ``config`` is a config name ``Robot-task-mode[-...]`` (the task is its second field);
    ``col(name)`` gives the CSV column ``name`` of the config's rows as numbers."""
    t = TARGETS
    parts = config.split("-")
    task = parts[1] if len(parts) > 1 else ""
    m = {c: _mean(col(c)) for c in (
        "agent_success", "baseline_success", "agent_rms", "baseline_rms", "agent_energy",
        "baseline_energy", "agent_internal_force", "baseline_internal_force",
        "agent_saturation", "train_s")}
    miss = []
    succ, base = m["agent_success"], m["baseline_success"]
    if succ is not None:
        floor = {"goal": t["goal_success"], "track": t["track_success"]}.get(task, 0.0)
        if base is not None:
            floor = max(floor, base - t["below_baseline"]) if task != "track" else floor
        if succ < floor - 1e-9:
            miss.append("success")
    if task == "track" and m["agent_rms"] is not None and m["baseline_rms"] is not None:
        if m["agent_rms"] > max(t["rms_factor"] * m["baseline_rms"], t["rms_floor"]):
            miss.append("RMS")
    if config.endswith("-torque") or "-torque-" in config:
        xf, bxf = m["agent_internal_force"], m["baseline_internal_force"]
        if xf is not None and bxf is not None and xf > t["internal_force_factor"] * bxf:
            miss.append("internal force")
        e, be = m["agent_energy"], m["baseline_energy"]
        if (xf is not None and e is not None and be is not None
                and e > t["energy_factor"] * be):
            miss.append("energy")
    if m["agent_saturation"] is not None and m["agent_saturation"] > t["saturation"]:
        miss.append("saturation")
    if m["train_s"] is not None and m["train_s"] > t["train_s"]:
        miss.append("time")
    return miss


def _ratio_cell(col: Callable[[str], list[float | None]], agent: str, base: str) -> str:
    a, b = _mean(col(agent)), _mean(col(base))
    if a is None or b is None or b <= 0.0:
        return "-"
    return f"{a / b:.2f}x" if a / b < 100 else f"{a / b:.0f}x"


def format_table(rows: Sequence[dict[str, str]]) -> str:
    """The Markdown results table of CSV rows: one line per (config, algo, steps, episodes).

    Agent cells: mean ± std (population) over seeds of each seed's mean over episodes; baseline
    and random: the mean over the same episodes (one value per config). Steps to baseline: the
    mean over the seeds that reached the level, ``(k/n)`` when not all did, ``never`` when none.
    Then the total CPU time of the rows (``cpu_s``, else ``train_s``).
    """
    groups: dict[tuple[str, str, int, int], list[dict[str, str]]] = {}
    for r in rows:
        key = (r["config"], r.get("algo", ""), int(float(r["n_timesteps"])),
               int(float(r.get("episodes") or 0)))
        groups.setdefault(key, []).append(r)
    lines = ["| " + " | ".join(TABLE_HEAD) + " |", "|" + "---|" * len(TABLE_HEAD)]
    cpu = 0.0
    for (name, algo, steps, eps), rs in sorted(groups.items()):

        def col(c: str, rs: list[dict[str, str]] = rs) -> list[float | None]:
            return [parse_number(r.get(c)) for r in rs]

        for r in rs:
            cpu += parse_number(r.get("cpu_s")) or parse_number(r.get("train_s")) or 0.0
        lines.append("| " + " | ".join([
            name, algo.upper(), str(steps), str(len(rs)), str(eps),
            _cell(col("agent_success"), 100, 0), _cell(col("baseline_success"), 100, 0, False),
            _cell(col("random_success"), 100, 0, False),
            _cell(col("agent_rms"), 1, 3), _cell(col("baseline_rms"), 1, 3, False),
            _cell(col("agent_return"), 1, 1), _cell(col("baseline_return"), 1, 1, False),
            _cell(col("random_return"), 1, 1, False),
            _ratio_cell(col, "agent_energy", "baseline_energy"),
            _ratio_cell(col, "agent_internal_force", "baseline_internal_force"),
            _cell(col("agent_saturation"), 100, 0),
            _reach_cell(col("steps_to_baseline")),
            _cell(col("train_s"), 1, 0, False),
            ", ".join(f"**{m}**" for m in target_misses(name, col)) or "met",
        ]) + " |")
    lines.append("")
    lines.append(
        "Agent: mean ± std over training seeds of each seed's mean over the evaluation "
        "episodes; baseline and random: mean over the same episodes. Steps to baseline: first "
        "periodic evaluation within 5 points of the baseline's success (track: within 2x its RMS "
        "error), mean over the seeds that reached it. Energy and internal force: the agent's "
        "mean over the baseline's. Targets: `met`, or the ones missed in bold (success: goal "
        ">= 95% and >= baseline - 5 points, navigate >= baseline - 5, track >= 90%; RMS <= "
        "max(2x baseline, 2 cm); torque mode internal force <= 3x and energy <= 1.5x the "
        "baseline's where internal force is defined; saturation <= 25%; time <= 10 min/seed). "
        f"Total CPU time {_duration(cpu)} ({len(rows)} runs)."
    )
    return "\n".join(lines)


README_BEGIN = "<!-- results-table: begin (wheelgym benchmark --table --readme README.md) -->"
README_END = "<!-- results-table: end -->"


def _table_span(text: str) -> tuple[int, int] | None:
    """Where the table between the README markers starts and ends in ``text`` (None: no
    markers)."""
    i, j = text.find(README_BEGIN), text.find(README_END)
    return None if i < 0 or j < i else (i + len(README_BEGIN), j)


def readme_table(text: str) -> str | None:
    """The results table between the README markers (``README_BEGIN``/``README_END``), or
    None when the markers are missing."""
    span = _table_span(text)
    return None if span is None else text[span[0]:span[1]].strip("\n")


def update_readme(path: str | Path, table: str) -> None:
    """Put ``table`` between the results markers of the Markdown file ``path`` (``ValueError``
    naming the file when they are missing)."""
    path = Path(path)
    text = path.read_text()
    span = _table_span(text)
    if span is None:
        raise ValueError(f"{path}: no results markers ({README_BEGIN!r} ... {README_END!r})")
    path.write_text(text[:span[0]] + "\n" + table + "\n" + text[span[1]:])


# --------------------------------------------------------------------------------------------
# learning curves
# --------------------------------------------------------------------------------------------


def _eval_history(run_dir: Path) -> list[dict[str, float | None]]:
    path = run_dir / "eval.csv"
    if not path.is_file():
        return []
    with path.open(newline="") as f:
        return [{k: parse_number(v) for k, v in r.items() if k is not None}
                for r in csv.DictReader(f)]


def plot_curves(rows: Sequence[dict[str, str]], configs: Sequence[str], out: str | Path,
                log: Callable[[str], None] | None = None) -> Path:
    """Learning curves of ``configs`` (names or config paths: their stems) from the rows' run
    folders: success rate (track: RMS error) against steps and against wall seconds, mean over
    seeds with the min-max spread, and the baseline's level on the same evaluation seeds."""
    names = [Path(c).stem for c in configs] if configs else sorted({r["config"] for r in rows})
    known = sorted({r["config"] for r in rows})
    bad = [n for n in names if n not in known]
    if bad:
        raise ValueError(f"configs {bad} have no rows in the CSV; configs there: {known}")
    groups: dict[tuple[str, int], list[dict[str, str]]] = {}
    for r in rows:
        if r["config"] in names:
            groups.setdefault((r["config"], int(float(r["n_timesteps"]))), []).append(r)
    keys = sorted(groups, key=lambda k: (names.index(k[0]), k[1]))
    fig = _figure(11.0, 3.2 * len(keys))
    axes = fig.subplots(len(keys), 2, squeeze=False)
    for (name, steps), (ax_s, ax_t) in zip(keys, axes, strict=True):
        rs = groups[(name, steps)]
        rms = any(parse_number(r.get("agent_rms")) is not None for r in rs)
        column = "rms_tracking_error" if rms else "success_rate"
        scale, label = (1.0, "RMS tracking error [m]") if rms else (100.0, "success [%]")
        per_step: dict[float, list[tuple[float, float]]] = {}
        n_runs = 0
        for r in rs:
            hist = [h for h in _eval_history(Path(r.get("run_dir", "")))
                    if h.get(column) is not None and h.get("timesteps") is not None]
            if not hist:
                if log is not None:
                    log(f"{name} seed {r['seed']}: no evaluation history in {r.get('run_dir')}")
                continue
            n_runs += 1
            for h in hist:
                per_step.setdefault(h["timesteps"], []).append(
                    (h.get("wall_s") or 0.0, h[column] * scale))
        xs = sorted(per_step)
        ys = [np.array([y for _, y in per_step[x]]) for x in xs]
        ws = [float(np.mean([w for w, _ in per_step[x]])) for x in xs]
        level = _mean([parse_number(r.get("baseline_eval_rms" if rms else "baseline_eval_success"))
                       for r in rs])
        for ax, x, xlabel in ((ax_s, xs, "environment steps"), (ax_t, ws, "wall time [s]")):
            if xs:
                ax.plot(x, [y.mean() for y in ys], color="C0", lw=1.5,
                        label=f"agent (mean of {n_runs})")
                ax.fill_between(x, [y.min() for y in ys], [y.max() for y in ys], color="C0",
                                alpha=0.25, lw=0, label="min-max over seeds")
            else:
                ax.text(0.5, 0.5, "no evaluation history", ha="center", va="center",
                        transform=ax.transAxes)
            if level is not None:
                ax.axhline(level * scale, color="C1", ls="--", lw=1.2, label="baseline")
            if rms and xs and min(float(y.min()) for y in ys) > 0:
                ax.set_yscale("log")  # agent and baseline errors differ by orders of magnitude
            ax.set_xlabel(xlabel)
            ax.set_ylabel(label)
            ax.set_title(f"{name} ({steps} steps)", fontsize=9)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    return out
