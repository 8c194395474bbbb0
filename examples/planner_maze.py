"""The planning baseline on the maze: the grid, the planned paths and the driven trails.

    python examples/planner_maze.py --seed 3 --out docs/topics/planning_maze.png

Left: ThreeWheel (grid A*, smoothed and centred); right: Bicycle (hybrid A* over Reeds-Shepp
primitives, its cusps marked). Each panel shows the solid map, the cells the robot's footprint
cannot centre on (grey), the first plan and the trail the robot drove, and prints the outcome.
"""

from __future__ import annotations

import argparse
import warnings

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import wheelgym  # noqa: E402
from wheelgym.kinematics.reeds_shepp import sample  # noqa: E402
from wheelgym.planning import grid_from_world  # noqa: E402
from wheelgym.registration import env_id  # noqa: E402


def drive(robot: str, seed: int):
    env = gym.make(env_id(robot), task="navigate", arena="maze")
    pol = wheelgym.baseline(env, planner="auto")
    obs, _ = env.reset(seed=seed)
    core = env.unwrapped.core
    trail = [core.pose[0, :2].copy()]
    pol.predict(obs)
    nav = pol.navigator
    first = nav.waypoints(0)
    car_path = nav.cars[0].path if nav.cars else None
    steps = 0
    while steps < 500:
        obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
        steps += 1
        trail.append(core.pose[0, :2].copy())
        if term or trunc:
            break
    grid = grid_from_world(core.task.worlds[0], core.task.arena, core.spec.radius)
    return dict(first=first, car=car_path, trail=np.array(trail), grid=grid,
                start=core.task.worlds[0].start, goal=core.task.goal[0], ok=info["is_success"],
                steps=steps, dt=core.dt, stats=nav.stats(), arena=core.task.arena)


def panel(ax, r, title):
    g = r["grid"]
    H, W = g.gap.shape
    ext = (g.origin[0], g.origin[0] + W * g.res, g.origin[1], g.origin[1] + H * g.res)
    img = np.where(g.gap < -g.radius + 1e-9, 0.0, np.where(g.gap < 0, 0.75, 1.0))
    ax.imshow(img, origin="lower", extent=ext, cmap="gray", vmin=0, vmax=1)
    if r["first"] is not None:
        ax.plot(*r["first"].T, "-", color="tab:blue", lw=1.5, label="first plan")
    if r["car"] is not None and r["car"].segments:
        smp = sample(r["car"], r["car"].start, 0.05)
        d = smp.direction
        cusp = np.flatnonzero(d[1:-1] != d[2:]) + 1
        ax.plot(*smp.poses[cusp, :2].T, "x", color="tab:purple", ms=8, mew=2, label="cusps")
    ax.plot(*r["trail"].T, "-", color="tab:orange", lw=1.0, label="driven")
    ax.plot(*r["start"][:2], "o", color="tab:green", ms=7, label="start")
    ax.plot(*r["goal"][:2], "*", color="tab:red", ms=12, label="goal")
    ax.set_title(f"{title}: {'success' if r['ok'] else 'failed'} in {r['steps'] * r['dt']:.1f} s")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--out", default="planning_maze.png")
    a = ap.parse_args()
    warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
    fig, axes = plt.subplots(1, 2, figsize=(12, 6.2))
    for ax, robot, title in zip(axes, ("ThreeWheel", "Bicycle"),
                                ("ThreeWheel, grid A*", "Bicycle, hybrid A*"), strict=True):
        r = drive(robot, a.seed)
        panel(ax, r, title)
        print(f"{robot} on maze, seed {a.seed}: success {r['ok']} after {r['steps']} steps; "
              f"planner {r['stats']}")
    axes[0].legend(loc="lower left", fontsize=8)
    axes[1].legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(f"saved {a.out}")


if __name__ == "__main__":
    main()
