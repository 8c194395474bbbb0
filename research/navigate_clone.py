"""Clone the analytic baseline into a config's policy network, then let PPO fine-tune it.

Usage: ``python research/navigate_clone.py CONFIG [--steps 1000000] [--rounds 1] [--epochs 10]
[--internal-force W] [--finetune 1000000] [--learning-rate LR] [--episodes 50] [--out runs/clone]``.

A diagnostic of the results that start from the baseline (README, results section; written
for ``navigate``, it takes any PPO config with ``normalize``): the clone alone and the clone
after PPO, scored with the discounted return PPO maximises (training with the config keys
``clone_baseline`` and ``clone_rounds`` is ``wheelgym train``'s job). It answers two questions
about a config whose PPO agent stays below the baseline:

* **Is the observation enough?** :func:`wheelgym.agents.clone.clone_baseline`: the baseline
  labels ``--steps`` steps of the config's training envs (driving them, or with ``--rounds K``
  the clone drives after the first of K rounds: DAgger) and the policy's Gaussian mean is
  fitted to its actions. The clone sees only the agent's observation.
* **Does the reward prefer what the success rate measures?** PPO then trains the clone for
  ``--finetune`` steps with the config's hyperparameters (no reward schedule; 0: none).

Prints, for the baseline, the clone and the fine-tuned clone on the benchmark's evaluation
seeds (``wheelgym.agents.benchmark.EVAL_SEED`` on): success, collisions, the mean return, the
mean return discounted at the config's ``gamma`` (the objective PPO maximises), and the
energy and internal force over the baseline's where the robot has them. The models are saved
under ``--out`` (``clone/`` and ``finetuned/``, each ``model.zip`` and ``vecnormalize.pkl``).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import torch as th  # noqa: E402

from wheelgym.agents.benchmark import EVAL_SEED  # noqa: E402
from wheelgym.agents.clone import clone_baseline  # noqa: E402
from wheelgym.agents.common import (  # noqa: E402
    build_model,
    make_single_env,
    make_train_env,
    wrap_normalize,
)
from wheelgym.agents.config import load_config  # noqa: E402
from wheelgym.agents.evaluate import run_episode  # noqa: E402
from wheelgym.agents.policies import load_agent, make_baseline  # noqa: E402


def score(config, policy, episodes: int, gamma: float) -> dict[str, float]:
    """Success, collisions, return and discounted return over the evaluation seeds."""
    env = make_single_env(config)
    if policy == "baseline":
        policy = make_baseline(env)
    eps = [run_episode(env, policy, EVAL_SEED + k) for k in range(episodes)]
    env.close()
    discounts = gamma ** np.arange(max(e.length for e in eps))

    def mean(attr: str) -> float | None:
        vals = [getattr(e, attr) for e in eps if getattr(e, attr) is not None]
        return float(np.mean(vals)) if vals else None

    return {"success": float(np.mean([bool(e.success) for e in eps])),
            "collisions": sum(e.terminated and not e.success and not e.numerical_failure
                              for e in eps),
            "return": float(np.mean([e.ret for e in eps])),
            "discounted": float(np.mean([discounts[:e.length] @ e.rewards for e in eps])),
            "energy": mean("energy"), "internal_force": mean("mean_internal_force")}


def _ratio(s: dict, base: dict, key: str) -> str:
    return "-" if s[key] is None or not base[key] else f"{s[key] / base[key]:.2f}x"


def save(model, venv, out: Path):
    out.mkdir(parents=True, exist_ok=True)
    model.save(out / "model.zip")
    venv.save(str(out / "vecnormalize.pkl"))
    return load_agent(out / "model.zip", "ppo", out / "vecnormalize.pkl")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", type=Path)
    ap.add_argument("--steps", type=int, default=1_000_000, help="baseline steps to clone")
    ap.add_argument("--rounds", type=int, default=1,
                    help="DAgger rounds over the --steps (clone_rounds; 1: the baseline drives)")
    ap.add_argument("--epochs", type=int, default=None,
                    help="passes of each round's fit (clone_epochs; default clone.EPOCHS)")
    ap.add_argument("--internal-force", type=float, default=None, metavar="W",
                    help="the fit's weight on the internal force of the action error "
                         "(default: the config's clone_internal_force)")
    ap.add_argument("--finetune", type=int, default=1_000_000,
                    help="PPO steps after cloning (0: none)")
    ap.add_argument("--learning-rate", type=float, default=None, metavar="LR",
                    help="PPO's learning rate for the fine-tuning (default: the config's)")
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--out", type=Path, default=Path("runs/clone"))
    a = ap.parse_args()
    th.set_num_threads(1)
    config = load_config(a.config)
    if a.learning_rate is not None:
        hp = {**config.hyperparams, "learning_rate": a.learning_rate}
        config = config.replace(hyperparams=hp)
    if config.algo != "ppo" or config.normalize is None:
        raise SystemExit(f"{a.config}: needs a PPO config with normalize on")
    gamma = float(config.hyperparams.get("gamma", 0.99))
    venv = wrap_normalize(make_train_env(config), config)
    model = build_model(config, venv)
    t0 = time.perf_counter()
    w = config.clone_internal_force if a.internal_force is None else a.internal_force
    fit = clone_baseline(model, a.steps, seed=config.seed, rounds=a.rounds, epochs=a.epochs,
                         internal_force=w)
    print(f"{a.config.name}: cloned {fit['steps']} baseline-labelled steps in {a.rounds} "
          f"round(s), {time.perf_counter() - t0:.0f} s (mean squared action error "
          f"{fit['mse_before']:.2g} -> {fit['mse_after']:.2g})")
    if "force_error_after" in fit:
        print(f"  internal-force weight {w:g}: internal force of the action error "
              f"{fit['force_error_before']:.2g} -> {fit['force_error_after']:.2g} of |tau_max|")
    for k, r in enumerate(fit.get("rounds", [])):
        print(f"  round {k + 1}: the {r['driver']} drove {r['episodes']} episodes, "
              f"{r['success']:.0%} success")
    rows = [("baseline", score(config, "baseline", a.episodes, gamma)),
            ("clone", score(config, save(model, venv, a.out / "clone"), a.episodes, gamma))]
    if a.finetune > 0:
        t0 = time.perf_counter()
        model.learn(a.finetune)
        print(f"PPO fine-tuning: {a.finetune} steps in {time.perf_counter() - t0:.0f} s")
        rows.append((f"clone + PPO {a.finetune // 1000}k",
                     score(config, save(model, venv, a.out / "finetuned"), a.episodes, gamma)))
    base = rows[0][1]
    print(f"| policy | success | collisions | return | return discounted at {gamma} | "
          f"energy / baseline | internal force / baseline |")
    print("|---|---|---|---|---|---|---|")
    for name, s in rows:
        print(f"| {name} | {s['success']:.0%} | {s['collisions']} | {s['return']:.2f} | "
              f"{s['discounted']:.2f} | {_ratio(s, base, 'energy')} | "
              f"{_ratio(s, base, 'internal_force')} |")


if __name__ == "__main__":
    main()
