"""Evaluate a run folder: ``python agents/evaluate.py RUN [--episodes N] [--video]``.

The same as ``wheelgym evaluate``; the implementation lives in :mod:`wheelgym.agents.evaluate`
(the trained agent, the analytic baseline and a random policy through one loop, same seeds).
"""

import sys

from wheelgym.cli import main

if __name__ == "__main__":
    sys.exit(main(["evaluate", *sys.argv[1:]]))
