"""Throughput of the Tianshou adapter against ``DummyVectorEnv`` of single envs.

Run: ``python benchmarks/clients.py [--num-envs 16] [--steps 300] [--rounds 3]`` (needs the
``clients`` extra).

Prints a Markdown table of env-steps/s (sub-env steps per second, random actions in [-1, 1],
ThreeWheel ``goal`` task, 100-step episodes, ended sub-envs reset as Tianshou's ``Collector``
resets them) of the native vector env alone, :class:`~wheelgym.vector.tianshou.TianshouVectorEnv`
with ``info_keys=()`` and with the whole info, and Tianshou's ``DummyVectorEnv`` of single envs;
then each one's ratio to ``DummyVectorEnv`` in the same round. The four are timed in
interleaved rounds, so a drift in the machine's speed cannot favour one of them.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import gymnasium as gym
import numpy as np
from tianshou.env import DummyVectorEnv

import wheelgym  # noqa: F401
from wheelgym.vector import make_tianshou_vec_env

ID = "wheelgym/ThreeWheel-v0"
KW: dict[str, Any] = {"task": "goal", "max_episode_steps": 100}


def tianshou_rate(env: Any, n: int, steps: int) -> float:
    env.seed(0)
    env.reset()
    rng = np.random.default_rng(0)
    t = time.perf_counter()
    for _ in range(steps):
        out = env.step(rng.uniform(-1.0, 1.0, (n, 6)))
        done = np.flatnonzero(out[2] | out[3])
        if done.size:
            env.reset(done)
    return n * steps / (time.perf_counter() - t)


def native_rate(n: int, steps: int) -> float:
    vec = gym.make_vec(ID, num_envs=n, vectorization_mode="vector_entry_point", **KW)
    vec.reset(seed=0)
    rng = np.random.default_rng(0)
    t = time.perf_counter()
    for _ in range(steps):
        vec.step(rng.uniform(-1.0, 1.0, (n, 6)))
    return n * steps / (time.perf_counter() - t)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=16)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    n, steps = args.num_envs, args.steps
    print(f"ThreeWheel goal, N = {n}, {steps} steps a round; env-steps/s (ratio to "
          "DummyVectorEnv)\n")
    print("| round | native env | adapter info_keys=() | adapter (whole info) | DummyVectorEnv |")
    print("|---|---|---|---|---|")
    for r in range(args.rounds):
        raw = native_rate(n, steps)
        bare = tianshou_rate(make_tianshou_vec_env(ID, n, info_keys=(), **KW), n, steps)
        full = tianshou_rate(make_tianshou_vec_env(ID, n, **KW), n, steps)
        ref = tianshou_rate(DummyVectorEnv([lambda: gym.make(ID, **KW) for _ in range(n)]), n,
                            steps)
        print(f"| {r} | {raw:,.0f} ({raw / ref:.2f}x) | {bare:,.0f} ({bare / ref:.2f}x) | "
              f"{full:,.0f} ({full / ref:.2f}x) | {ref:,.0f} |")


if __name__ == "__main__":
    main()
