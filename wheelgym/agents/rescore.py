"""Score a results CSV's runs again from their run folders, without training
(``wheelgym benchmark --rescore``): for a change to the evaluation (a metric's definition)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as _as_completed
from pathlib import Path

from wheelgym.agents.config import load_run_config
from wheelgym.agents.grid import worker_init
from wheelgym.agents.scoring import (
    baseline_scores,
    score_agent,
    score_columns,
    steps_to_baseline,
)
from wheelgym.agents.store import DEFAULT_CSV, parse_number, read_rows, replace_rows, row_key

__all__ = ["rescore"]


def _rescore_group(rows: list[dict[str, str]]) -> tuple[list[dict[str, str]], list[str]]:
    """Score the finished runs of one config's rows (same episodes) again from their run
    folders: the rows with every score column replaced, and a note per row whose success or
    return came out different (the evaluation is deterministic: a difference is a finding)."""
    episodes = int(float(rows[0]["episodes"]))
    levels = baseline_scores(Path(rows[0]["run_dir"]) / "config.yml", episodes)
    out, changed = [], []
    for old in rows:
        run_dir = Path(old["run_dir"])
        row = dict(old)
        agent_s = score_agent(run_dir, load_run_config(run_dir / "config.yml"), episodes)
        score_columns(row, agent_s, levels)
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
        replace_rows(csv_path, {row_key(r): r for r in new_rows})
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
                                 initializer=worker_init) as pool:
            futures = {pool.submit(_rescore_group, g): key for key, g in groups.items()}
            try:
                for fut in _as_completed(futures):
                    done(futures[fut], fut.result())
            except KeyboardInterrupt:
                pool.shutdown(wait=False, cancel_futures=True)
                raise
    return notes
