"""SHA-256 of seeded baseline rollouts on the -v0 ids: run it on two trees to show same bits.

    PYTHONPATH=$PWD python benchmarks/rollout_digest.py

ThreeWheel, Bicycle and SkidSteer; navigate (random arena and the maze), goal and track; two
seeds of up to 150 steps each under the reactive baseline; every observation and reward goes
into the digest.
"""

from __future__ import annotations

import hashlib
import warnings

import gymnasium as gym
import numpy as np

import wheelgym


def main() -> None:
    warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
    h = hashlib.sha256()
    for robot in ("ThreeWheel", "Bicycle", "SkidSteer"):
        for task, arena in (("navigate", None), ("navigate", "maze"), ("goal", None),
                            ("track", None)):
            kw = {"arena": arena} if arena else {}
            env = gym.make(f"wheelgym/{robot}-v0", task=task, **kw)
            pol = wheelgym.baseline(env)
            for s in range(2):
                obs, _ = env.reset(seed=s)
                for _ in range(150):
                    obs, r, term, trunc, _ = env.step(pol.predict(obs)[0])
                    h.update(obs.tobytes())
                    h.update(np.float64(r).tobytes())
                    if term or trunc:
                        break
    print(h.hexdigest())


if __name__ == "__main__":
    main()
