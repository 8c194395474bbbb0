"""Where SAC+HER's time goes: steps per second and a cProfile of a short stretch of training.

Run from the repository root: ``python research/her_profile.py [CONFIG] [--steps N]``
(default ``configs/ThreeWheel-goal-velocity-her.yml``, 2000 steps after 3000 of warm-up).
Prints the steps per second and the 25 most expensive calls by cumulative time.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

from wheelgym.agents.common import build_model, make_train_env, wrap_normalize
from wheelgym.agents.config import load_config


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("config", nargs="?", default="configs/ThreeWheel-goal-velocity-her.yml")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--warmup", type=int, default=3000, help="steps before the profile")
    args = ap.parse_args()
    config = load_config(args.config)
    model = build_model(config, wrap_normalize(make_train_env(config, seed=0), config))
    model.learn(args.warmup)  # past learning_starts: the profile sees gradient steps
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    model.learn(args.steps, reset_num_timesteps=False)
    prof.disable()
    print(f"{args.steps / (time.perf_counter() - t0):.0f} steps/s (under the profiler)")
    pstats.Stats(prof).sort_stats("cumtime").print_stats(25)


if __name__ == "__main__":
    main()
