"""The analytic baseline on ``track`` for the car-like robots (Bicycle, Ackermann).

Usage: ``python benchmarks/car_track.py [--episodes 50] [--seed0 0] [--label-steps 200]``.
Prints two Markdown tables. The first: per robot and action mode, over the episodes reset with
seeds ``seed0 .. seed0 + episodes - 1``,

* success: share of episodes with ``info["is_success"]`` at their last step (within
  ``TrackTask.tol_pos`` = 5 cm of the reference), and how many ended early (lost: more than
  1 m from the reference);
* RMS tracking error (m): mean ± std over episodes of each episode's
  ``sqrt(mean(e^2))`` of ``info["tracking_error"]`` over its steps, and the worst episode.

The second: the rate at which the baseline labels states off the reference, as when a clone
drives (``imitate`` stages, ``wheelgym/agents/clone.py``): 32 robots in one vector env, every
other step driven by a random action, ``label-steps`` steps; the share of rows the receding-horizon
search labelled (the rest the feedback law) and the labels per second of ``actions()``.

The episodes run through :func:`wheelgym.agents.evaluate.run_episode`, the loop that
``wheelgym evaluate`` scores agents and the baseline with, so the numbers are the same metric.
Deterministic: the same seeds give the same table on any machine (the baseline's arithmetic is
element-wise; see ``wheelgym/envs/baseline.py``).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import wheelgym  # noqa: E402,F401  (registers the environments)
from wheelgym.agents.evaluate import run_episode  # noqa: E402
from wheelgym.envs.baseline import baseline  # noqa: E402

#: (robot, action mode) rows of the table.
CASES = (
    ("Bicycle", "VehicleSpeedHeadingRate"),
    ("Bicycle", "VehicleSpeedSteeringAngle"),
    ("Ackermann", "VehicleSpeedSteeringRate"),
)


def measure(robot: str, mode: str, seeds: range) -> dict:
    """Success rate, RMS errors and early ends of the baseline over ``seeds``."""
    env = gym.make(f"wheelgym/{robot}-v0", task="track", action_mode=mode)
    pol = baseline(env)
    rms, wins, lost = [], [], 0
    for s in seeds:
        ep = run_episode(env, pol, s, record=False)
        rms.append(float(ep.rms_tracking_error))
        wins.append(bool(ep.success))
        lost += ep.length < env.spec.max_episode_steps
    env.close()
    return {"success": float(np.mean(wins)), "rms": np.asarray(rms), "lost": lost}


def label_rate(robot: str, mode: str, steps: int, num_envs: int = 32,
               seed: int = 0) -> dict:
    """Labels per second of the baseline on ``num_envs`` robots driven off the reference
    (every other step a random action), and the share of rows its search labelled."""
    venv = gym.make_vec(f"wheelgym/{robot}-v0", num_envs=num_envs, task="track",
                        action_mode=mode)
    venv.reset(seed=seed)
    venv.action_space.seed(seed)
    pol = baseline(venv)
    searched, busy = 0, 0.0
    for k in range(steps):
        t0 = time.perf_counter()
        a = pol.actions()
        busy += time.perf_counter() - t0
        searched += int(pol._car_track.warm.sum())  # the rows the search labelled this step
        venv.step(a if k % 2 == 0 else venv.action_space.sample())
    venv.close()
    return {"rate": num_envs * steps / busy, "searched": searched / (num_envs * steps)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--label-steps", type=int, default=200)
    args = ap.parse_args(argv)
    seeds = range(args.seed0, args.seed0 + args.episodes)
    print(f"Baseline on track, seeds {seeds.start}..{seeds.stop - 1} ({args.episodes} episodes)")
    print()
    print("| robot | action mode | success [%] | ended early | RMS error [cm] (mean ± std) "
          "| worst RMS [cm] | time [s] |")
    print("|---|---|---|---|---|---|---|")
    for robot, mode in CASES:
        t0 = time.perf_counter()
        r = measure(robot, mode, seeds)
        rms = 100.0 * r["rms"]
        print(f"| {robot} | {mode} | {100.0 * r['success']:.0f} | {r['lost']} "
              f"| {rms.mean():.2f} ± {rms.std():.2f} | {rms.max():.2f} "
              f"| {time.perf_counter() - t0:.1f} |", flush=True)
    print()
    print(f"Labelling off the reference: 32 robots, {args.label_steps} steps, every other "
          "step a random action")
    print()
    print("| robot | action mode | rows searched [%] | labels/s |")
    print("|---|---|---|---|")
    for robot, mode in CASES:
        r = label_rate(robot, mode, args.label_steps)
        print(f"| {robot} | {mode} | {100.0 * r['searched']:.0f} | {r['rate']:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
