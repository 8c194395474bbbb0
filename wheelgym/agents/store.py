"""The results CSV (``benchmarks/results/training.csv``): one row per (config, seed, budget,
evaluation episodes), appended under a file lock, flushed and fsync'd, so that a killed writer
loses at most the row it was writing and parallel writers do not interleave.

The ``config_sha`` column (:func:`config_digest`) tells the rows of a config as it is now from
those of a re-tuned one: a digest of the config's recipe form
(:meth:`wheelgym.agents.config.TrainConfig.recipe_form`), which does not depend on how its
pipeline is spelled.

CSV columns (:data:`COLUMNS`): ``success`` and ``saturation`` are fractions, ``rms`` [m],
``energy`` [J], ``internal_force`` [N·m] means over episodes; empty where the metric does not
apply (RMS off ``track``, energy on kinematic robots, internal force but on ThreeWheel) or the
baseline is missing. ``train_s``: training wall time; ``cpu_s``: the job's CPU time (training and
evaluation). ``run_dir``: the run folder, for the learning curves. ``recipe``: the config's
pipeline in short (:attr:`wheelgym.agents.config.TrainConfig.recipe`; rows from before the
column have none, the table then reads it from the config file).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from wheelgym import resources
from wheelgym.agents.config import WHEELGYM_BLOCK, TrainConfig

__all__ = ["COLUMNS", "DEFAULT_CSV", "parse_number", "read_rows", "config_digest", "json_digest",
           "append_row", "drop_rows", "replace_rows", "row_key", "is_row"]

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
    "run_dir", "finished_utc", "config_sha", "recipe",
)


#: Columns a CSV written before them may lack (the rows appended to it then leave them out).
OPTIONAL: frozenset[str] = frozenset({"recipe"})


def parse_number(text: Any) -> float | None:
    """A CSV cell as a finite float, or None (empty, not a number, or not finite)."""
    if text is None or str(text).strip() == "":
        return None
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


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
        return [r for r in reader if is_row(r)]


def config_digest(config: TrainConfig) -> str:
    """12 hex digits of SHA-256 over the config's recipe form
    (:meth:`~wheelgym.agents.config.TrainConfig.recipe_form`), without what does not change a
    result row (the seed, which each job sets, and the checkpoint period) and the budget (the
    row key holds it): the ``config_sha`` column, by which a re-tuned config's old rows are told
    apart from its new ones."""
    data = config.recipe_form()
    for key in ("seed", "checkpoint_freq"):
        data[WHEELGYM_BLOCK].pop(key, None)
    next(v for k, v in data.items() if k != WHEELGYM_BLOCK).pop("n_timesteps", None)
    return json_digest(data)


def json_digest(data: Any) -> str:
    """12 hex digits of SHA-256 over ``data`` as JSON with sorted keys (values JSON cannot
    hold as their ``str``): the results CSVs' digest columns."""
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


def drop_rows(path: Path, stale: Callable[[dict[str, str]], bool]) -> int:
    """Rewrite ``path`` without the whole rows for which ``stale(row)`` holds
    (:func:`_rewrite_rows`); the number dropped."""
    before, after = _rewrite_rows(
        path, lambda rows: [r for r in rows if not (is_row(r) and stale(r))])
    return before - after


def is_row(r: dict[str, str]) -> bool:
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


def row_key(r: dict[str, str]) -> tuple[str, int, int, int]:
    return (r["config"], int(float(r["seed"])), int(float(r["n_timesteps"])),
            int(float(r.get("episodes") or 0)))


def append_row(path: Path, row: dict[str, Any]) -> None:
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
        missing = [c for c in COLUMNS if c not in header and c not in OPTIONAL]
        if missing:
            raise ValueError(f"{path}: its header lacks columns {missing}; use another --csv")
        w = csv.DictWriter(f, fieldnames=header, extrasaction="ignore")
        if f.tell() == 0:
            w.writeheader()
        w.writerow(row)
        f.flush()
        os.fsync(f.fileno())


def replace_rows(path: Path, new: dict[tuple[str, int, int, int], dict[str, Any]]) -> None:
    """Rewrite ``path`` with the rows whose key is in ``new`` replaced (:func:`_rewrite_rows`)."""
    _rewrite_rows(path, lambda rows: [new.get(row_key(r), r) if is_row(r) else r
                                      for r in rows])
