"""Train an agent from a YAML config: ``python agents/train.py CONFIG [options]``.

The same as ``wheelgym train``; the implementation lives in :mod:`wheelgym.agents.train` so the
installed ``wheelgym`` command can import it.
"""

import sys

from wheelgym.cli import main

if __name__ == "__main__":
    sys.exit(main(["train", *sys.argv[1:]]))
