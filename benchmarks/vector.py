"""Throughput of the native batched vector envs against the single env and ``SyncVectorEnv``.

Run: ``python benchmarks/vector.py [--quick] [--sections steps,navigate,memory,ppo]``.

Prints Markdown tables (all ratios are measured in the same run, on the same machine):

* **steps**: env-steps/s (sub-env steps per second, autoresets included, random actions in
  [-1, 1], ``goal`` task, default action mode) of ``gym.make_vec(...,
  vectorization_mode="vector_entry_point")`` at N = 1, 16, 256, 1024, 4096, next to the single
  env (``gym.make``, reset when an episode ends), Gymnasium's ``SyncVectorEnv`` of N single
  envs, and the batch's ``WheelCore.step`` alone (the ceiling: physics, controller and task
  kernels without the vector-env layer). Targets at N = 1024: >= 10x the single env and >= 20x
  ``SyncVectorEnv``. The four are timed in interleaved rounds (best of 5 each; rounds 4x
  longer from N = 1024), so a drift in the machine's speed cannot favour one of them.
* **navigate**: the ``navigate`` task with the compiled ray caster (``range_backend=
  "analytic"``) and with pymunk segment queries (``"pymunk"``, one space per sub-env).
* **memory**: bytes per sub-env: ``tracemalloc`` growth of building, resetting and stepping the
  vector env at 2N minus N, divided by N; and the core's array ``nbytes`` per row. Target < 10 KB.
* **ppo**: SB3 PPO frames/s (``learn`` wall time) on 64 robots through the adapter
  (``make_sb3_vec_env``) against ``DummyVecEnv`` of 64 single envs, ``torch`` on one thread.
"""

from __future__ import annotations

import argparse
import gc
import time
import tracemalloc
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import wheelgym  # noqa: F401  (registers the ids)
from wheelgym.registration import env_id

ROBOTS = ("ThreeWheel", "SkidSteer", "DiffDrive")
NS = (1, 16, 256, 1024, 4096)


def _rate(step: Callable[[], int], min_time: float, repeats: int = 5) -> float:
    """Sub-env steps per second of ``step`` (which returns how many it did): the best of
    ``repeats`` rounds of at least ``min_time / repeats`` seconds (and 2 calls) each, after one
    warm-up call. The best round is the one least disturbed by other load on the machine."""
    return _rates({"step": step}, min_time, repeats)["step"]


def _rates(steps: dict[str, Callable[[], int]], min_time: float,
           repeats: int = 5) -> dict[str, float]:
    """:func:`_rate` of several step functions with their rounds interleaved (round r of
    each, then round r + 1 of each...), so that a change in the machine's speed during the
    measurement (other load, clock) reaches all of them alike and their ratios stay fair."""
    for step in steps.values():
        step()
    best = dict.fromkeys(steps, 0.0)
    for _ in range(repeats):
        for name, step in steps.items():
            n = 0
            calls = 0
            t0 = time.perf_counter()
            while True:
                n += step()
                calls += 1
                dt = time.perf_counter() - t0
                if dt >= min_time / repeats and calls >= 2:
                    break
            best[name] = max(best[name], n / dt)
    return best


def single_step(eid: str, **kw) -> Callable[[], int]:
    """A step function (64 steps of one single env, reset at episode ends) for :func:`_rate`."""
    env = gym.make(eid, **kw)
    env.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-1, 1, (64, *env.action_space.shape)) \
        .astype(np.float32)
    def step() -> int:
        for a in acts:
            _, _, te, tr, _ = env.step(a)
            if te or tr:
                env.reset()
        return len(acts)

    return step


def single_rate(eid: str, min_time: float, **kw) -> float:
    return _rate(single_step(eid, **kw), min_time)


def vector_step(venv) -> Callable[[], int]:
    """A step function (one step of every sub-env, random actions) for :func:`_rate`."""
    venv.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-1, 1, (8, *venv.action_space.shape)) \
        .astype(np.float32)
    n = venv.num_envs
    k = [0]

    def step() -> int:
        venv.step(acts[k[0] % 8])
        k[0] += 1
        return n

    return step


def vector_rate(venv, min_time: float) -> float:
    return _rate(vector_step(venv), min_time)


def core_step(venv) -> Callable[[], int]:
    """A step function of the batch's ``WheelCore.step`` alone (physics, controller, task; no
    vector-env layer): the ceiling of the vector env. It steps ``venv``'s core behind the
    vector env's back: give it a vector env of its own."""
    core = venv.unwrapped.core
    venv.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-1, 1, (8, *venv.action_space.shape))
    k = [0]

    def step() -> int:
        core.step(acts[k[0] % 8])
        k[0] += 1
        return core.num

    return step


def native(eid: str, n: int, **kw):
    return gym.make_vec(eid, num_envs=n, vectorization_mode="vector_entry_point", **kw)


def sync(eid: str, n: int, **kw):
    return gym.vector.SyncVectorEnv([lambda: gym.make(eid, **kw) for _ in range(n)])


def fmt(x: float) -> str:
    return f"{x:,.0f}"


def section_steps(ns: tuple[int, ...], sync_max: int, min_time: float,
                  robots: tuple[str, ...] = ROBOTS) -> None:
    print("\n### Env-steps/s, goal task (higher is faster)\n")
    print("| robot | N | single env | SyncVectorEnv | native vector | WheelCore.step alone "
          "| native / single | native / Sync |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    checks = []
    for robot in robots:
        eid = env_id(robot)
        for n in ns:
            steps = {"single": single_step(eid), "native": vector_step(native(eid, n)),
                     "core": core_step(native(eid, n))}
            if n <= sync_max:
                steps["sync"] = vector_step(sync(eid, n))
            r = _rates(steps, 4 * min_time if n >= 1024 else min_time)
            s, v, c = r["single"], r["native"], r["core"]
            if n <= sync_max:
                sv = r["sync"]
                sync_s, ratio = fmt(sv), f"{v / sv:.1f}x"
            else:
                sync_s = ratio = "-"
            print(f"| {robot} | {n} | {fmt(s)} | {sync_s} | {fmt(v)} | {fmt(c)} | {v / s:.1f}x "
                  f"| {ratio} |", flush=True)
            if n == 1024 and n <= sync_max:
                checks.append(f"{robot}: {v / s:.1f}x single ({'met' if v >= 10 * s else 'not met'}"
                              f"), {v / sv:.1f}x Sync ({'met' if v >= 20 * sv else 'not met'}); "
                              f"native is {v / c:.0%} of the WheelCore.step ceiling")
    if checks:
        print("\nTargets at N = 1024 (>= 10x single, >= 20x SyncVectorEnv):\n")
        for line in checks:
            print(f"- {line}")


def section_navigate(ns: tuple[int, ...], min_time: float) -> None:
    print("\n### navigate task: range sensor backends, env-steps/s\n")
    print("| robot | N | single (analytic) | native, analytic | native, pymunk "
          "| analytic / pymunk |")
    print("|---|---:|---:|---:|---:|---:|")
    for robot in ("ThreeWheel", "DiffDrive"):
        eid = env_id(robot)
        for n in ns:
            s = single_rate(eid, min_time, task="navigate")
            a = vector_rate(native(eid, n, task="navigate"), min_time)
            p = vector_rate(native(eid, n, task="navigate", range_backend="pymunk"), min_time)
            print(f"| {robot} | {n} | {fmt(s)} | {fmt(a)} | {fmt(p)} | {a / p:.1f}x |",
                  flush=True)


def _grow(eid: str, n: int, **kw) -> int:
    gc.collect()
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    venv = native(eid, n, **kw)
    venv.reset(seed=0)
    for _ in range(3):
        venv.step(np.zeros(venv.action_space.shape, dtype=np.float32))
    used = tracemalloc.get_traced_memory()[0] - base
    tracemalloc.stop()
    del venv
    return used


def section_memory(n: int) -> None:
    print(f"\n### Memory per sub-env (N = {n} vs {2 * n}; target < 10 KB)\n")
    print("| robot | task | tracemalloc (bytes/sub-env) | core arrays nbytes (bytes/sub-env) |")
    print("|---|---|---:|---:|")
    for robot in ROBOTS:
        eid = env_id(robot)
        for task in ("goal", "track", "navigate"):
            _grow(eid, 4, task=task)  # first build loads kernels and caches: not per sub-env
            per = (_grow(eid, 2 * n, task=task) - _grow(eid, n, task=task)) / n
            venv = native(eid, n, task=task)
            venv.reset(seed=0)
            objs = [venv.unwrapped.core, venv.unwrapped.core.task]
            nb = sum(v.nbytes for o in objs for v in vars(o).values()
                     if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == n)
            print(f"| {robot} | {task} | {per:,.0f} | {nb / n:,.0f} |", flush=True)


def section_ppo(n_envs: int, steps: int, robots: tuple[str, ...]) -> None:
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    from wheelgym.vector import make_sb3_vec_env

    torch.set_num_threads(1)
    print(f"\n### SB3 PPO frames/s, {n_envs} robots, goal task, velocity mode "
          f"({steps} steps, n_steps=64, batch 1024, 4 epochs)\n")
    print("| robot | DummyVecEnv of single envs | wheelgym SB3VecEnv | ratio "
          "| env only: Dummy | env only: SB3VecEnv | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for robot in robots:
        eid = env_id(robot)
        kw = {"task": "goal", "action_mode": "velocity"}

        def dummy(eid=eid, kw=kw):
            v = DummyVecEnv([lambda: gym.make(eid, **kw) for _ in range(n_envs)])
            v.seed(0)
            return VecMonitor(v)

        def mine(eid=eid, kw=kw):
            return make_sb3_vec_env(eid, n_envs, seed=0, monitor=True, **kw)

        res = []
        for make in (dummy, mine):
            venv = make()
            model = PPO("MlpPolicy", venv, n_steps=64, batch_size=1024, n_epochs=4, seed=0)
            model.learn(n_envs * 64)  # warm-up
            t0 = time.perf_counter()
            model.learn(steps, reset_num_timesteps=False)
            res.append(steps / (time.perf_counter() - t0))
            venv.reset()
            a = np.zeros((n_envs, *venv.action_space.shape), dtype=np.float32)

            def step(venv=venv, a=a) -> int:
                venv.step(a)
                return n_envs

            res.append(_rate(step, 0.5))
        fd, ed, fm, em = res
        print(f"| {robot} | {fmt(fd)} | {fmt(fm)} | {fm / fd:.2f}x | {fmt(ed)} | {fmt(em)} "
              f"| {em / ed:.1f}x |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="shorter timings, N up to 1024")
    ap.add_argument("--sections", default="steps,navigate,memory,ppo",
                    help="comma-separated: steps, navigate, memory, ppo")
    ap.add_argument("--sync-max", type=int, default=None,
                    help="largest N for SyncVectorEnv (default 1024, quick 256)")
    ap.add_argument("--ppo-robots", default="ThreeWheel,SkidSteer",
                    help="robots of the ppo section (comma-separated)")
    ap.add_argument("--robots", default=",".join(ROBOTS),
                    help=f"robots of the steps section (comma-separated; default {ROBOTS})")
    args = ap.parse_args()
    quick = args.quick
    min_time = 0.3 if quick else 1.0
    ns = NS[:-1] if quick else NS
    sync_max = args.sync_max or (1024 if not quick else 256)
    sections = args.sections.split(",")
    valid = {"steps", "navigate", "memory", "ppo"}
    if not set(sections) <= valid:
        ap.error(f"--sections: valid names are {sorted(valid)}")
    print(f"# wheelgym vector benchmark ({'quick' if quick else 'full'}; rates are the best of "
          "5 rounds; the steps table times its columns in interleaved rounds at each N)")
    if "steps" in sections:
        robots = tuple(args.robots.split(","))
        if not set(robots) <= set(ROBOTS):
            ap.error(f"--robots: valid names are {list(ROBOTS)}")
        section_steps(ns, sync_max, min_time, robots)
    if "navigate" in sections:
        section_navigate(ns, min_time)
    if "memory" in sections:
        section_memory(256 if quick else 1024)
    if "ppo" in sections:
        section_ppo(64, 64 * 64 * (2 if quick else 6), tuple(args.ppo_robots.split(",")))


if __name__ == "__main__":
    main()
