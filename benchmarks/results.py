"""The results table: trained agents (seeds 0-4) vs the analytic baseline and random.

    python benchmarks/results.py            # every config in configs/, 5 seeds, own budgets
    python benchmarks/results.py --quick    # 1 seed, a tenth of each budget, 5 episodes
    python benchmarks/results.py configs/ThreeWheel-goal-velocity.yml --seeds 3
    python benchmarks/results.py --table    # the Markdown table of the CSV so far
    python benchmarks/results.py --table --page docs/topics/results.md --readme README.md

The same as ``wheelgym benchmark``: one row per (config, seed) appended to
``benchmarks/results/training.csv`` as each run ends (a rerun skips finished rows).
"""

import sys

from wheelgym.cli import main

if __name__ == "__main__":
    sys.exit(main(["benchmark", *sys.argv[1:]]))
