"""Steps per second of ``env.step`` for every wheelgym id and task vs Gymnasium's Pendulum-v1.

Run: ``python benchmarks/envs.py [--steps 3000] [--repeats 5]``. Prints a Markdown table of the
median time per step (us) and the ratio of steps/s to Pendulum-v1 measured in the same run
(higher is faster), plus ``gym.make`` time once the compiled caches exist. Actions are sampled
before timing; episodes that end are reset outside the timed region's count.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import numpy as np

import wheelgym  # noqa: F401  (registers the ids)
from wheelgym.envs.registration import env_id
from wheelgym.envs.robots import available_robots

TARGETS = {"ThreeWheel": 0.3, "SkidSteer": 0.5, "CasterAGV": 0.3, "DiffDrive": 1.0,
           "Unicycle": 1.0, "Bicycle": 1.0, "Ackermann": 1.0}
NAVIGATE_TARGET = 0.2


def time_steps(env: gym.Env, n: int, repeats: int, seed: int = 0) -> float:
    """Median seconds per ``env.step`` over ``repeats`` runs of ``n`` steps."""
    rng = np.random.default_rng(seed)
    acts = rng.uniform(-1, 1, (n,) + env.action_space.shape).astype(np.float32)
    env.reset(seed=seed)
    for a in acts[:200]:  # warm-up
        _, _, te, tr, _ = env.step(a)
        if te or tr:
            env.reset()
    out = []
    for _ in range(repeats):
        env.reset(seed=seed)
        t_total = 0.0
        k = 0
        while k < n:
            t0 = time.perf_counter()
            while k < n:
                _, _, te, tr, _ = env.step(acts[k])
                k += 1
                if te or tr:
                    break
            t_total += time.perf_counter() - t0
            env.reset()
        out.append(t_total / n)
    return statistics.median(out)


def bench_rays(n: int = 2000) -> None:
    """16 range rays in one navigate arena: pymunk segment queries vs the compiled kernel."""
    from wheelgym.world import Arena, build_space, k_ranges, pymunk_ranges

    arena = Arena()
    w = arena.generate(np.random.default_rng(0), 0.4)
    space = build_space(w)
    C = np.zeros((1, arena.max_circles, 3))
    S = np.zeros((1, arena.max_segments, 4))
    C[0, : len(w.circles)] = w.circles
    S[0, : len(w.segments)] = w.segments
    nc, ns = np.array([len(w.circles)]), np.array([len(w.segments)])
    pose = w.start[None].copy()
    out = np.zeros((1, 16))
    k_ranges(pose, C, nc, S, ns, 3.0, out)

    def tm(f) -> float:
        res = []
        for _ in range(5):
            t0 = time.perf_counter()
            for _ in range(n):
                f()
            res.append((time.perf_counter() - t0) / n)
        return statistics.median(res)

    t_pm = tm(lambda: pymunk_ranges(space, pose[0], 16, 3.0, out[0]))
    t_nb = tm(lambda: k_ranges(pose, C, nc, S, ns, 3.0, out))
    print(f"16 range rays: pymunk segment queries {t_pm * 1e6:.1f} us, "
          f"analytic numba kernel {t_nb * 1e6:.1f} us ({t_pm / t_nb:.0f}x)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--robots", nargs="*", default=None)
    args = ap.parse_args()
    pend = gym.make("Pendulum-v1")
    t_ref = time_steps(pend, args.steps, args.repeats)
    print(f"Pendulum-v1: {t_ref * 1e6:.1f} us/step ({1 / t_ref:,.0f} steps/s)\n")
    print("| id | task | action mode | us/step | steps/s | ratio vs Pendulum | target |")
    print("|---|---|---|---|---|---|---|")
    robots = args.robots or available_robots()
    for robot in robots:
        spec = wheelgym.envs.robots.get_spec(robot)
        for task in ("goal", "track", "navigate"):
            modes = spec.action_modes if task == "goal" else spec.action_modes[:1]
            for mode in modes:
                try:
                    env = gym.make(env_id(robot), task=task, action_mode=mode)
                except ValueError as exc:  # e.g. the velocity mode's controller is missing
                    print(f"| {env_id(robot)} | {task} | {mode} | n/a ({exc}) | | | |")
                    continue
                t = time_steps(env, args.steps, args.repeats)
                target = NAVIGATE_TARGET if task == "navigate" else TARGETS.get(robot, 1.0)
                ratio = t_ref / t
                flag = "ok" if ratio >= target else "MISS"
                print(f"| {env_id(robot)} | {task} | {mode} | {t * 1e6:.1f} | {1 / t:,.0f} | "
                      f"{ratio:.2f}x | >= {target}x {flag} |")
                env.close()
        if args.repeats and spec.name == "ThreeWheel":
            for backend in ("analytic", "pymunk"):
                env = gym.make(env_id(robot), task="navigate", range_backend=backend)
                t = time_steps(env, args.steps, args.repeats)
                print(f"| {env_id(robot)} | navigate, rays: {backend} | torque | {t * 1e6:.1f} "
                      f"| {1 / t:,.0f} | {t_ref / t:.2f}x | |")
    print()
    bench_rays()
    print()
    for robot in robots:
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            env = gym.make(env_id(robot))
            times.append(time.perf_counter() - t0)
            env.close()
        print(f"gym.make({env_id(robot)!r}): {statistics.median(times) * 1e3:.1f} ms "
              f"(target < 500 ms)")


if __name__ == "__main__":
    main()
