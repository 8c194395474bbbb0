"""The cars' waypoint hint on the maps, and a car clone against its teacher.

Run from the repository root:

- ``python research/car_hint.py [--arena warehouse] [--episodes 10]``: the planning baseline
  drives Bicycle (``VehicleSpeedSteeringAngle``, navigate -v1, ``waypoint_hint=True``); over
  its steps that move and steer, how often the hint's point (``waypoint_y_b``) lies on the side
  the planner steers to, how often its ``plan_direction`` is the planner's gear, and how often
  the planner's steering is the tracker's feedback law of the observed frame (since
  2026-12-04 the cars' hint is the tracker's own frame, so this is 100% up to float32).
- ``--agent RUN_DIR``: the run's agent drives instead; on the states it reaches the planner's
  labels against its commands (gear agreement, correlation of speed and steering, their means).
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import wheelgym


def _env(arena: str) -> gym.Env:
    return gym.make("wheelgym/Bicycle-v1", task="navigate",
                    action_mode="VehicleSpeedSteeringAngle", arena=arena, waypoint_hint=True)


def hint_agreement(arena: str, episodes: int) -> tuple[float, float, float, int]:
    """Steering-side, gear and feedback-law agreement of the hint with the planner, and the
    steering steps counted."""
    from wheelgym.kinematics.car_tracking import rear_wheel_steering

    env = _env(arena)
    planner = wheelgym.baseline(env, planner="auto")
    names = env.unwrapped.core.obs_names
    ix, k = names.index("waypoint_x_b"), names.index("plan_offset")
    side, gear, law = [], [], []
    for ep in range(episodes):
        obs, _ = env.reset(seed=ep)
        while True:
            a = np.asarray(planner.predict(obs)[0])
            car = planner.navigator.cars[0]
            lo, hi = planner._lo_nominal[0], planner._hi_nominal[0]
            v = 0.5 * (hi + lo) + 0.5 * (hi - lo) * a[0]  # the commanded speed (m/s)
            if abs(v) > 0.05:
                gear.append(obs[k + 3] == np.sign(v))
                if abs(a[1]) > 0.1:
                    side.append(np.sign(obs[ix + 1]) == np.sign(a[1]))
                    lim = car.limits
                    want = rear_wheel_steering(*(float(v) for v in obs[k:k + 3]),
                                               int(obs[k + 3]), lim.wheelbase, car.k_e,
                                               car.k_theta)
                    want = min(max(want, -lim.max_steering_angle), lim.max_steering_angle)
                    law.append(abs(want - car._delta) < 1e-4)
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                break
    env.close()
    return float(np.mean(side)), float(np.mean(gear)), float(np.mean(law)), len(side)


def agent_against_planner(run_dir: str, arena: str, episodes: int) -> dict[str, float]:
    """The planner's labels on the states the run's agent reaches, against its commands."""
    from wheelgym.agents.policies import load_agent

    agent = load_agent(f"{run_dir}/model.zip", "ppo", f"{run_dir}/vecnormalize.pkl")
    env = _env(arena)
    planner = wheelgym.baseline(env, planner="auto")
    A, T = [], []
    for ep in range(episodes):
        obs, _ = env.reset(seed=2000 + ep)
        while True:
            a = np.asarray(agent.predict(obs, deterministic=True)[0])
            A.append(a)
            T.append(np.asarray(planner.predict(obs)[0]))
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                break
    env.close()
    A, T = np.array(A), np.array(T)
    return {"gear agreement": float(np.mean(np.sign(A[:, 0]) == np.sign(T[:, 0]))),
            "speed correlation": float(np.corrcoef(A[:, 0], T[:, 0])[0, 1]),
            "steering correlation": float(np.corrcoef(A[:, 1], T[:, 1])[0, 1]),
            "agent mean speed command": float(A[:, 0].mean()),
            "planner mean speed label": float(T[:, 0].mean())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arena", default=None, help="warehouse or office (default: both)")
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--agent", default=None, metavar="RUN_DIR")
    args = ap.parse_args()
    arenas = [args.arena] if args.arena else ["warehouse", "office"]
    if args.agent:
        for arena in arenas:
            for k, v in agent_against_planner(args.agent, arena, args.episodes).items():
                print(f"{arena}: {k} {v:.2f}")
        return
    print("| arena | hint side = steering side | plan_direction = gear | steering = law of the "
          "frame | steering steps |")
    print("|---|---:|---:|---:|---:|")
    for arena in arenas:
        side, gear, law, n = hint_agreement(arena, args.episodes)
        print(f"| {arena} | {100 * side:.0f}% | {100 * gear:.0f}% | {100 * law:.0f}% | {n} |")

if __name__ == "__main__":
    main()
