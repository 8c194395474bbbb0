"""What ``distill_internal_force`` does to a trained ThreeWheel torque-mode agent.

Usage: ``python research/distill_internal_force.py CONFIG MODEL [--stats PKL] [--steps 300000]
[--rounds 6] [--weight 1000] [--lr 1e-4] [--epochs 10] [--episodes 50] [--out DIR]``.

``MODEL`` is a trained agent's ``model.zip`` (or a checkpoint; its ``VecNormalize`` statistics
``--stats``, default ``vecnormalize.pkl`` next to it, or the checkpoint's own) for ``CONFIG``.
:func:`wheelgym.agents.clone.distill_internal_force` refits it on ``CONFIG``'s training envs
(``--steps`` rows in ``--rounds`` rounds, the null-space error weighted ``--weight``, Adam at
``--lr``, ``--epochs`` passes per round; the config's seed), which drives with its own actions
less their internal force as labels. Prints each round's figures and a Markdown table of the
baseline, the agent as given, the agent with its internal force removed exactly at every step
(the labels: what the distillation aims at) and the distilled agent on the benchmark's
evaluation seeds (``wheelgym.agents.benchmark.EVAL_SEED`` on): success, RMS tracking error
(track), energy and internal force over the baseline's, and the seconds the distillation took.
The distilled model is saved under ``--out`` (``model.zip``, ``vecnormalize.pkl``). One torch
and one numba thread.

The run of the shipped track agent's recipe, on the PPO checkpoint of a benchmark run before
its distillation::

    python research/distill_internal_force.py configs/ThreeWheel-track-torque.yml \\
        runs/benchmark/ThreeWheel-track-torque-ppo-s1-*/checkpoints/ckpt_499968_steps.zip
"""

from __future__ import annotations

import argparse
import math
import os
import re
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def _stats_for(model: Path) -> Path:
    m = re.search(r"ckpt_(\d+)_steps\.zip$", model.name)
    if m:
        return model.with_name(f"ckpt_vecnormalize_{m.group(1)}_steps.pkl")
    return model.with_name("vecnormalize.pkl")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", type=Path)
    ap.add_argument("model", type=Path, help="the trained agent's model.zip or checkpoint")
    ap.add_argument("--stats", type=Path, default=None,
                    help="its VecNormalize statistics (default: next to the model)")
    ap.add_argument("--steps", type=int, default=300_000, help="rows of the distillation")
    ap.add_argument("--rounds", type=int, default=6, help="DAgger rounds over the --steps")
    ap.add_argument("--weight", type=float, default=1000.0,
                    help="weight of the internal force of the fit's error")
    ap.add_argument("--lr", type=float, default=None, help="Adam's learning rate "
                    "(default: wheelgym.agents.clone.DISTILL_LR)")
    ap.add_argument("--epochs", type=int, default=None, help="passes of each round's fit "
                    "(default: wheelgym.agents.clone.EPOCHS)")
    ap.add_argument("--episodes", type=int, default=50, help="evaluation episodes")
    ap.add_argument("--out", type=Path, default=Path("runs/distill"))
    a = ap.parse_args(argv)
    for name in ("steps", "rounds", "episodes"):
        if getattr(a, name) < 1:
            ap.error(f"--{name} must be >= 1, got {getattr(a, name)}")
    if a.epochs is not None and a.epochs < 1:
        ap.error(f"--epochs must be >= 1, got {a.epochs}")
    if not math.isfinite(a.weight) or a.weight < 0:
        ap.error(f"--weight must be finite and >= 0, got {a.weight}")
    if a.lr is not None and not (math.isfinite(a.lr) and a.lr > 0):
        ap.error(f"--lr must be finite and > 0, got {a.lr}")
    stats = a.stats or _stats_for(a.model)
    for path in (a.config, a.model, stats):
        if not path.is_file():
            ap.error(f"{path}: no such file")

    import torch as th
    from stable_baselines3.common.vec_env import VecNormalize

    from wheelgym.agents.benchmark import EVAL_SEED
    from wheelgym.agents.clone import DISTILL_LR, distill_internal_force, without_internal_force
    from wheelgym.agents.common import algo_class, make_single_env, make_train_env
    from wheelgym.agents.config import load_config
    from wheelgym.agents.evaluate import evaluate_policy_episodes
    from wheelgym.agents.policies import load_agent, make_baseline
    from wheelgym.envs.baseline import baseline

    th.set_num_threads(1)
    config = load_config(a.config)

    class Projected:
        """The agent's action less its internal force, exactly, at every step: the labels."""

        def __init__(self, agent, env) -> None:
            self.agent, self.core = agent, baseline(env).core

        def reset(self, seed: int | None = None) -> None:
            self.agent.reset(seed)

        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            a = self.agent.predict(obs, state, episode_start, deterministic)[0]
            return without_internal_force(self.core, np.reshape(a, (1, -1)))[0], state

    def score(policy, project: bool = False) -> dict[str, float | None]:
        env = make_single_env(config)
        if policy is None:
            policy = make_baseline(env)
        elif project:
            policy = Projected(policy, env)
        eps = evaluate_policy_episodes(env, policy, [EVAL_SEED + k for k in range(a.episodes)],
                                       record=False)  # scores only, no traces
        env.close()

        def mean(attr: str) -> float | None:
            vals = [getattr(e, attr) for e in eps if getattr(e, attr) is not None]
            return float(np.mean(vals)) if vals else None

        return {"success": float(np.mean([bool(e.success) for e in eps])),
                "rms": mean("rms_tracking_error"), "energy": mean("energy"),
                "internal_force": mean("mean_internal_force")}

    venv = VecNormalize.load(str(stats), make_train_env(config))
    model = algo_class(config.algo).load(str(a.model), env=venv, device="cpu")
    t0 = time.perf_counter()
    fit = distill_internal_force(model, a.steps, rounds=a.rounds, weight=a.weight,
                                 epochs=a.epochs, seed=config.seed, lr=a.lr or DISTILL_LR)
    took = time.perf_counter() - t0
    print(f"{a.model}: distilled on {fit['steps']} rows in {a.rounds} round(s), weight "
          f"{a.weight:g}, lr {a.lr or DISTILL_LR:g}, {fit['epochs']} passes each, {took:.0f} s")
    for k, r in enumerate(fit["rounds"]):
        succ = "-" if r["success"] is None else f"{r['success']:.0%}"
        print(f"  round {k + 1}: {r['episodes']} episodes ended, {succ} of them succeeded, "
              f"internal force {r['force_before']:.2e} of |tau_max| before the refit")
    print(f"  after: internal force {fit['force_after']:.2e} of |tau_max|, mean squared "
          f"distance to the labels {fit['mse_after']:.2e}\n")
    a.out.mkdir(parents=True, exist_ok=True)
    model.save(a.out / "model.zip")
    venv.save(str(a.out / "vecnormalize.pkl"))
    venv.close()
    agent = load_agent(a.model, config.algo, stats)
    rows = [("baseline", score(None)), ("agent", score(agent)),
            ("agent, its internal force removed exactly at every step", score(agent, True)),
            ("distilled", score(load_agent(a.out / "model.zip", config.algo,
                                           a.out / "vecnormalize.pkl")))]
    base = rows[0][1]

    def ratio(s: dict, key: str) -> str:
        return "-" if s[key] is None or not base[key] else f"{s[key] / base[key]:.2f}x"

    print("| policy | success | RMS error [cm] | energy / baseline | internal force / baseline |")
    print("|---|---|---|---|---|")
    for name, s in rows:
        rms = "-" if s["rms"] is None else f"{100 * s['rms']:.2f}"
        print(f"| {name} | {s['success']:.0%} | {rms} | {ratio(s, 'energy')} | "
              f"{ratio(s, 'internal_force')} |")
    print(f"\nbaseline internal force {base['internal_force']} N·m; distillation {took:.0f} s")


if __name__ == "__main__":
    main()
