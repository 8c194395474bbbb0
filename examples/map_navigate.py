"""The analytic baseline on a shipped map: one navigate episode, drawn.

    python examples/map_navigate.py --arena warehouse --robot ThreeWheel --seed 2 \\
        --out docs/navigate_warehouse.png

Prints the outcome and saves the last frame (the robot's trail, the range rays, the goal) as
a PNG. ``--success-rate N`` scores the baseline over N seeds instead.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import wheelgym


def episode(env, seed: int) -> tuple[dict, int]:
    pol = wheelgym.baseline(env)
    obs, info = env.reset(seed=seed)
    for k in range(1, 501):
        obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
        if term or trunc:
            return info, k
    return info, 500


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--arena", default="warehouse", help="a shipped map or a map YAML")
    ap.add_argument("--robot", default="ThreeWheel")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--out", default="navigate_map.png")
    ap.add_argument("--success-rate", type=int, default=0, metavar="N")
    a = ap.parse_args()
    kw = {"task": "navigate", "arena": a.arena}
    if a.success_rate:
        env = gym.make(f"wheelgym/{a.robot}-v0", **kw)
        wins = [episode(env, s)[0]["is_success"] for s in range(a.success_rate)]
        print(f"{a.robot} on {a.arena}: baseline success {np.mean(wins):.0%} over "
              f"{a.success_rate} seeds")
        return
    env = gym.make(f"wheelgym/{a.robot}-v0", render_mode="rgb_array", **kw)
    pol = wheelgym.baseline(env)
    obs, info = env.reset(seed=a.seed)
    steps, frame = 0, env.render()
    while steps < 500:
        obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
        steps += 1
        frame = env.render()  # every step: the renderer keeps the trail
        if term or trunc:
            break
    import pygame

    surf = pygame.surfarray.make_surface(np.transpose(frame, (1, 0, 2)))
    pygame.image.save(surf, a.out)
    print(f"{a.robot} on {a.arena}, seed {a.seed}: success {info['is_success']} after {steps} "
          f"steps ({steps * env.unwrapped.dt:.1f} s); saved {a.out}")


if __name__ == "__main__":
    main()
