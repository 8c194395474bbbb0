"""The README's results table: trained agents (3 seeds) vs the analytic baseline and random.

    python benchmarks/results.py            # every config in configs/, 3 seeds, full budgets
    python benchmarks/results.py --quick    # 1 seed, a tenth of each budget, 5 episodes
    python benchmarks/results.py configs/ThreeWheel-goal-velocity.yml --seeds 3

The same as ``wheelgym benchmark``; prints a Markdown table with the wall time it took.
"""

import sys

from wheelgym.cli import main

if __name__ == "__main__":
    sys.exit(main(["benchmark", *sys.argv[1:]]))
