"""The baseline's twist loop under action delay: the stability limit, the levels, the gain grid.

Usage: ``python benchmarks/baseline_gains.py [--episodes 200] [--seed0 200000] [--grid]``.
Prints Markdown tables (docs/topics/robustness.md, "A twist loop for the delayed plant"):

1. the largest stable gain ``g = k_v ctrl_dt`` of a proportional loop on a plant that
   integrates its input, with a delay of ``d`` control steps: where the roots of
   ``z^(d+1) - z^d + g`` leave the unit circle, against ``2 sin(pi / (2 (2d + 1)))``;
2. SkidSteer goal, torque mode, nominal model: success and mean episode length at each
   combined level for the default (deadbeat) loop and the loop for a two-step delay
   (``wheelgym.baseline(env, w_cap=1.0, twist_gains={"k_v": 12, "k_i": 20})``);
3. with ``--grid``: success at ``medium`` over ``g`` x ``w_cap`` x ``k_i ctrl_dt^2``, with the
   failures split into overspeed ends and time-outs.

Each line is one native vector env of ``--episodes`` rows reset with seeds ``seed0 ..``,
scored by :func:`wheelgym.agents.evaluate.run_episodes_vector` (the robustness sweep's loop).
"""

from __future__ import annotations

import argparse
import itertools
import math
import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import wheelgym  # noqa: E402
from wheelgym.agents.evaluate import run_episodes_vector  # noqa: E402

DELAYED = {"w_cap": 1.0, "twist_gains": {"k_v": 12.0, "k_i": 20.0}}
LEVELS = ("none", "easy", "medium", "hard")


def stable_gain(d: int, n: int = 4000) -> float:
    """The largest ``g`` on a grid of ``n`` in (0, 2] with every root of
    ``z^(d+1) - z^d + g`` inside the unit circle."""
    best = 0.0
    for g in np.linspace(2.0 / n, 2.0, n):
        coeffs = [1.0, -1.0, *([0.0] * (d - 1)), g] if d else [1.0, g - 1.0]
        if np.max(np.abs(np.roots(coeffs))) < 1.0:
            best = float(g)
    return best


def score(level: str, seeds: list[int], **kw) -> tuple[float, int, int, float]:
    """Success, overspeed ends, time-outs and mean length of the baseline with ``kw``."""
    venv = gym.make_vec("wheelgym/SkidSteer-v0", num_envs=len(seeds), task="goal",
                        action_mode="torque", perturbation=None if level == "none" else level)
    eps = run_episodes_vector(venv, wheelgym.baseline(venv, **kw), seeds)
    venv.close()
    fail = [e for e in eps if not e.success]
    return (float(np.mean([e.success for e in eps])), sum(e.terminated for e in fail),
            sum(not e.terminated for e in fail), float(np.mean([e.length for e in eps])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument("--seed0", type=int, default=200000)
    ap.add_argument("--grid", action="store_true", help="also the gain grid at medium")
    args = ap.parse_args()
    seeds = list(range(args.seed0, args.seed0 + args.episodes))

    print("| delay d (steps) | largest stable g (roots) | 2 sin(pi / (2 (2d + 1))) |\n"
          "|---|---|---|")
    for d in (0, 1, 2, 3):
        print(f"| {d} | {stable_gain(d):.3f} | {2 * math.sin(math.pi / (2 * (2 * d + 1))):.3f} |")

    print(f"\nSkidSteer goal, torque mode, {args.episodes} episodes a level (seeds {seeds[0]}-"
          f"{seeds[-1]}): success (mean episode length)\n")
    print("| loop | " + " | ".join(LEVELS) + " |\n|---|" + "---|" * len(LEVELS))
    for name, kw in (("deadbeat, w_cap 1.5 (default)", {}),
                     ("k_v 12/s, k_i 20/s², w_cap 1.0", DELAYED)):
        cells = [score(lv, seeds, **kw) for lv in LEVELS]
        print(f"| {name} | " + " | ".join(f"{s:.1%} ({n:.0f})" for s, _, _, n in cells) + " |")

    if args.grid:
        print("\nAt medium: success, overspeed ends / time-outs\n")
        print("| g | w_cap | k_i dt² | success | overspeed | time-out |\n|---|---|---|---|---|---|")
        dt = gym.make("wheelgym/SkidSteer-v0").unwrapped.dt  # the control period
        for g, wc, ki in itertools.product((1.0, 0.8, 0.7, 0.6), (0.8, 1.0, 1.2),
                                           (0.0, 0.05, 0.1, 0.15)):
            s, over, tout, _ = score("medium", seeds, w_cap=wc,
                                     twist_gains={"k_v": g / dt, "k_i": ki / dt**2})
            print(f"| {g} | {wc} | {ki} | {s:.1%} | {over} | {tout} |")


if __name__ == "__main__":
    main()
