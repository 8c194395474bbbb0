"""Full drive command with ``motor="dc"``, 400 steps from ``reset(seed=0)``: the motor's
no-load rim speed ``v_0 = r V_s / (k_t n)`` against the env's overspeed limit ``v_max``, how many
steps run, why the episode ends, and the last and largest body speed
(docs/topics/motors.md).

    python benchmarks/dc_overspeed.py
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import wheelgym  # noqa: F401  (registers the ids)

GEAR = {"ThreeWheel": "gear_ratio_drive", "CasterAGV": "gear_ratio", "SkidSteer": "gear_ratio"}


def main() -> None:
    print("| robot | gear ratio n | v_0 = r V_s / (k_t n) (m/s) | v_max (m/s) | steps run "
          "| ended on | last speed (m/s) | max speed (m/s) |")
    print("|---|---|---|---|---|---|---|---|")
    for robot in ("ThreeWheel", "SkidSteer", "CasterAGV"):
        env = gym.make(f"wheelgym/{robot}-v0", motor="dc", max_episode_steps=400)
        env.reset(seed=0)
        core = env.unwrapped.core
        sp, p = core.spec, core.base_params
        kt = p.k_t_drive if robot == "ThreeWheel" else p.k_t
        gear = getattr(p, GEAR[robot])
        a = np.zeros(env.action_space.shape, dtype=np.float32)
        a[: sp.n_motor - sp.n_steer_motor] = 1.0
        speeds = []
        for _ in range(400):
            _, _, term, trunc, info = env.step(a)
            speeds.append(float(np.hypot(*info["twist"][:2])))
            if term or trunc:
                break
        why = ("overspeed" if info["reward_terms"]["overspeed"]
               else "time limit" if trunc else "other")
        v0 = p.r * p.V_s / (kt * gear)
        print(f"| {robot} | {gear:g} | {v0:.3f} | {sp.v_max} | {len(speeds)} | {why} "
              f"| {speeds[-1]:.3f} | {max(speeds):.3f} |")
        env.close()


if __name__ == "__main__":
    main()
