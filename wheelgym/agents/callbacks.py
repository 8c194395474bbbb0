"""The Stable-Baselines3 callbacks of the ``rl`` stage (:func:`wheelgym.agents.train.train`).

================ ===========================================================================
callback         job
================ ===========================================================================
StopOnRequest    ends training at the next step once Ctrl-C asked for it
EvalHistory      every ``eval_freq`` steps: deterministic episodes on fixed seeds, a row of
                 eval.csv, ``best_model.zip``, and the caller's ``on_eval`` hook
RewardSchedule   sets the ``rl`` stage's ``reward_schedule`` weights on the training envs as
                 the steps pass its points; each change is a row of reward_weights.csv
================ ===========================================================================

Imports Stable-Baselines3 at import (train.py imports this module when training starts).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import (
    BaseCallback,
    CallbackList,
    CheckpointCallback,
    ProgressBarCallback,
)

from wheelgym.agents.common import make_single_env
from wheelgym.agents.config import TrainConfig, weights_at
from wheelgym.agents.evaluate import applicable_metrics, evaluate_policy_episodes
from wheelgym.agents.policies import AgentPolicy

__all__ = ["StopOnRequest", "EvalHistory", "RewardSchedule", "make_callbacks"]


class StopOnRequest(BaseCallback):
    """Ends training at the next step once ``requested()`` says so (a Ctrl-C)."""

    def __init__(self, requested: Callable[[], bool]) -> None:
        super().__init__()
        self.requested = requested

    def _on_step(self) -> bool:
        return not self.requested()


class EvalHistory(BaseCallback):
    """Every ``eval_freq`` steps: deterministic episodes on fixed seeds -> eval.csv.

    Args:
        config: the run's config (evaluation env, episodes, reward schedule).
        run_dir: the run folder (eval.csv, best_model.zip).
        n_envs: the training envs (the period in vector steps is ``eval_freq // n_envs``).
        wall: the run's training wall time so far (s), continued across resumes.
        on_eval: sees each evaluation's row; ``False`` stops training.
        columns: eval.csv's columns of a new file; first episode seed ``seed``.
    """

    def __init__(self, config: TrainConfig, run_dir: Path, n_envs: int,
                 wall: Callable[[], float], on_eval: Callable[[dict], bool] | None,
                 columns: tuple[str, ...], seed: int) -> None:
        super().__init__()
        self.config = config
        self.every = max(config.eval_freq // n_envs, 1)
        self.path = run_dir / "eval.csv"
        self.run_dir = run_dir
        self.wall = wall
        self.on_eval = on_eval
        self.seed = seed
        self.best = -math.inf
        self.env: gym.Env | None = None
        self.columns: list[str] = list(columns)

    def _on_training_start(self) -> None:
        if not self.path.exists():
            with self.path.open("w", newline="") as f:
                csv.writer(f).writerow(self.columns)
        else:  # resumed: keep the best so far, and the file's own columns (older runs)
            with self.path.open() as f:
                reader = csv.DictReader(f)
                rows = list(reader)
                self.columns = list(reader.fieldnames or self.columns)
            if rows:
                self.best = max(float(r["mean_return"]) for r in rows)

    def _evaluate(self) -> dict[str, Any]:
        """The evaluation's figures (rates and RMS ``None`` where not reported)."""
        config = self.config
        if self.env is None:
            self.env = make_single_env(config)
            self.with_rms = "rms_tracking_error" in applicable_metrics(self.env)
        if config.reward_schedule:  # returns scored with the weights training has now
            self.env.unwrapped.set_reward_weights(
                weights_at(config.reward_schedule, self.num_timesteps))
        policy = AgentPolicy(self.model, self.model.get_vec_normalize_env())
        seeds = [self.seed + i for i in range(config.eval_episodes)]
        episodes = evaluate_policy_episodes(self.env, policy, seeds, record=False)
        rets = np.array([e.ret for e in episodes])
        succ = [e.success for e in episodes if e.success is not None]
        errs = [e.rms_tracking_error for e in episodes if e.rms_tracking_error is not None]
        return {"timesteps": int(self.num_timesteps), "wall_s": self.wall(),
                "mean_return": float(rets.mean()), "std_return": float(rets.std()),
                "success_rate": float(np.mean(succ)) if succ else None,
                "mean_length": float(np.mean([e.length for e in episodes])),
                "rms_tracking_error": (float(np.mean(errs)) if errs and self.with_rms
                                       else None)}

    def _write(self, row: dict[str, Any]) -> None:
        rate, rms = row["success_rate"], row["rms_tracking_error"]
        cells = {
            "timesteps": row["timesteps"], "wall_s": f"{row['wall_s']:.2f}",
            "mean_return": f"{row['mean_return']:.6g}", "std_return": f"{row['std_return']:.6g}",
            "success_rate": "" if rate is None else f"{rate:.4f}",
            "mean_length": f"{row['mean_length']:.1f}",
            "rms_tracking_error": "" if rms is None else f"{rms:.6g}",
        }
        with self.path.open("a", newline="") as f:
            csv.writer(f).writerow([cells.get(c, "") for c in self.columns])
        self.logger.record("eval/mean_reward", row["mean_return"])
        if rate is not None:
            self.logger.record("eval/success_rate", rate)

    def _on_step(self) -> bool:
        if self.n_calls % self.every:
            return True
        row = self._evaluate()
        self._write(row)
        if row["mean_return"] > self.best:
            self.best = row["mean_return"]
            self.model.save(self.run_dir / "best_model.zip")
            norm = self.model.get_vec_normalize_env()
            if norm is not None:
                norm.save(str(self.run_dir / "best_vecnormalize.pkl"))
        return self.on_eval is None or bool(self.on_eval(row))

    def _on_training_end(self) -> None:
        if self.env is not None:
            self.env.close()


class RewardSchedule(BaseCallback):
    """Sets ``schedule``'s weights on the training envs as steps pass its points (also at the
    start, so a resumed run continues with its weights); each change is a row of
    ``run_dir/reward_weights.csv`` (step, term, the weight the envs then hold)."""

    def __init__(self, schedule: dict, run_dir: Path) -> None:
        super().__init__()
        self.schedule = schedule
        self.path = run_dir / "reward_weights.csv"
        self.now: dict[str, float] | None = None

    def _apply(self) -> None:
        w = weights_at(self.schedule, self.num_timesteps)
        if w == self.now:
            return
        self.training_env.env_method("set_reward_weights", w)
        set_now = self.training_env.get_attr("reward_weights")[0]
        new = not self.path.exists()
        with self.path.open("a", newline="") as f:
            out = csv.writer(f)
            if new:
                out.writerow(["timesteps", "term", "weight"])
            for k in sorted(w):
                out.writerow([self.num_timesteps, k, repr(set_now[k])])
        self.now = w
        for k, v in w.items():
            self.logger.record(f"reward_weights/{k}", v)

    def _on_training_start(self) -> None:
        self._apply()

    def _on_step(self) -> bool:
        self._apply()
        return True


def make_callbacks(config: TrainConfig, run_dir: Path, model, requested: Callable[[], bool],
                   progress: bool, wall: Callable[[], float],
                   on_eval: Callable[[dict], bool] | None, columns: tuple[str, ...],
                   seed: int) -> CallbackList:
    """The ``rl`` stage's callbacks: stop on request, the reward schedule, a progress bar,
    checkpoints and the evaluation history (the last two where their periods are set)."""
    n_envs = model.get_env().num_envs
    callbacks: list = [StopOnRequest(requested)]
    if config.reward_schedule:
        callbacks.append(RewardSchedule(config.reward_schedule, run_dir))
    if progress:
        callbacks.append(ProgressBarCallback())
    if config.checkpoint_freq > 0:
        callbacks.append(CheckpointCallback(
            save_freq=max(config.checkpoint_freq // n_envs, 1),
            save_path=str(run_dir / "checkpoints"), name_prefix="ckpt",
            save_vecnormalize=True))
    if config.eval_freq > 0:
        callbacks.append(EvalHistory(config, run_dir, n_envs, wall, on_eval, columns, seed))
    return CallbackList(callbacks)
