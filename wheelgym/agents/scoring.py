"""Scoring for the results table: the agent, the analytic baseline and a random policy on the
same evaluation seeds, and the steps a run took to reach the baseline's level.

Per config the baseline and random policies are scored on the evaluation seeds (``EVAL_SEED +
i``, ``i < episodes``, the agents' too), and the baseline once more on the seeds of the
training's periodic evaluation (``EVAL_HISTORY_SEED + i``, ``i < eval_episodes``): its level
there (``baseline_eval_*``) is what :func:`steps_to_baseline` compares the run's eval.csv with:
the first evaluation with a success rate within :data:`SUCCESS_POINTS` points of the baseline's
(``goal``, ``navigate``) or an RMS tracking error within :data:`RMS_FACTOR` x the baseline's
(``track``); empty if never.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from wheelgym.agents.common import make_single_env
from wheelgym.agents.config import TrainConfig, load_run_config
from wheelgym.agents.evaluate import applicable_metrics, evaluate_policy_episodes
from wheelgym.agents.policies import RandomPolicy, load_agent, make_baseline
from wheelgym.agents.store import parse_number
from wheelgym.agents.train import EVAL_HISTORY_SEED

__all__ = ["EVAL_SEED", "SUCCESS_POINTS", "RMS_FACTOR", "baseline_scores", "score_agent",
           "score_columns", "steps_to_baseline"]

EVAL_SEED = 200_000


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


def _fmt(v: float | None) -> str:
    return "" if v is None else f"{v:.6g}"


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


def baseline_scores(path: Path, episodes: int) -> dict[str, Any]:
    """Baseline and random on the evaluation seeds, and the baseline on eval.csv's seeds."""
    config = load_run_config(path)
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


def score_agent(run_dir: Path, config: TrainConfig, episodes: int) -> dict[str, float | None]:
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


def score_columns(row: dict[str, Any], agent_s: dict[str, float | None],
                   levels: dict[str, Any]) -> None:
    """Put the agent's, baseline's and random scores into ``row``."""
    for col in _METRICS:
        row[f"agent_{col}"] = _fmt(agent_s[col])
        row[f"baseline_{col}"] = _fmt(levels["baseline"][col])
    row["random_success"] = _fmt(levels["random"]["success"])
    row["random_return"] = _fmt(levels["random"]["return"])
    row["baseline_eval_success"] = _fmt(levels["eval_success"])
    row["baseline_eval_rms"] = _fmt(levels["eval_rms"])
