"""The planning baseline against the reactive one on navigate: success per robot and arena.

    python benchmarks/planner.py                       # 7 robots x 4 arenas, 3 seeds x 50
    python benchmarks/planner.py --robots ThreeWheel --arenas maze --seeds 1 --episodes 10
    python benchmarks/planner.py --robots ThreeWheel SkidSteer CasterAGV --action-mode velocity

For each robot and arena (``random``: a new random arena each episode; ``warehouse``,
``office``, ``maze``: the shipped maps) and each seed ``s``, a native vector env of
``episodes`` sub-envs is reset with ``seed=1000 s`` (sub-env i draws its episode from seed
``1000 s + i``), and each sub-env's first episode is scored: success, collision, timeout. Both
policies see the same episodes: ``wheelgym.baseline(env)`` (reactive: the potential field on the
16 rays) and ``wheelgym.baseline(env, planner="auto")`` (grid A* for the robots that turn in
place, hybrid A* for the cars; docs/topics/planning.md). Success is the mean over the seeds of
each seed's success rate, with the standard deviation over the seeds; the planner's columns add
its share of steps with ``info["saturated"]`` (a command at its bound or a clipped torque), its
planning time per plan (mean and max, ms, wall clock on this machine, first compile
excluded by a warm-up plan) and its plans per scored episode (1 + re-plans).

Prints a Markdown table; ``--out FILE`` also writes it. ``--cost``: instead, the planning cost
against the env's own step in one process (``python benchmarks/planner.py --cost --robots
ThreeWheel Bicycle --arenas random maze``).
"""

from __future__ import annotations

import argparse
import time
import warnings

import gymnasium as gym
import numpy as np

import wheelgym
from wheelgym.registration import available_robots, env_id

ARENAS = ("random", "warehouse", "office", "maze")
#: The issue's targets: planner success on every arena (ThreeWheel, SkidSteer, CasterAGV,
#: DiffDrive, Unicycle; the cars).
TARGET = {"Bicycle": 0.85, "Ackermann": 0.85}
TARGET_OTHERS = 0.95


def env_kwargs(arena: str = "random", action_mode: str | None = None) -> dict[str, str]:
    """The navigate env's kwargs: the arena (a map, or none for the random arenas) and the
    action mode (none: the robot's first)."""
    kw = {"task": "navigate"}
    if arena != "random":
        kw["arena"] = arena
    if action_mode is not None:
        kw["action_mode"] = action_mode
    return kw


def run_batch(robot: str, arena: str, seed: int, episodes: int, planner: str | None,
              action_mode: str | None = None) -> dict[str, float]:
    """One seed: the first episode of each of ``episodes`` sub-envs."""
    env = gym.make_vec(env_id(robot), num_envs=episodes, vectorization_mode="vector_entry_point",
                       **env_kwargs(arena, action_mode))
    pol = wheelgym.baseline(env, planner=planner)
    obs, _ = env.reset(seed=1000 * seed)
    n = episodes
    done = np.zeros(n, dtype=bool)
    plans = np.zeros(n)
    win = np.zeros(n, dtype=bool)
    hit = np.zeros(n, dtype=bool)
    sat = steps = 0
    core = pol.core
    t0 = time.perf_counter()
    for _ in range(500):
        obs, _, term, trunc, info = env.step(pol.predict(obs)[0])
        sat += int(np.count_nonzero(np.asarray(info["saturated"], dtype=bool) & ~done))
        steps += int(np.count_nonzero(~done))
        end = (term | trunc) & ~done
        if pol.navigator is not None:
            plans[end] = pol.navigator.row_plans[end]
        win |= end & np.asarray(info["is_success"], dtype=bool)
        hit |= end & core.coll
        done |= end
        if done.all():
            break
    out = {"success": float(win.mean()), "collision": float(hit.mean()),
           "timeout": float((done & ~win & ~hit).mean()), "saturation": sat / max(steps, 1),
           "wall_s": time.perf_counter() - t0}
    if pol.navigator is not None:
        st = pol.navigator.stats()
        out.update(plan_ms=st["plan_ms_mean"], plan_ms_max=st["plan_ms_max"],
                   plans_per_episode=float(plans.mean()), failures=st["failures"])
        out["plan_times"] = list(pol.navigator.plan_times)
    env.close()
    return out


def warm_up(robot: str, action_mode: str | None = None) -> None:
    """Compile the planner's kernels (one short episode), so no plan time includes it."""
    env = gym.make(env_id(robot), **env_kwargs(action_mode=action_mode))
    pol = wheelgym.baseline(env, planner="auto")
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs = env.step(pol.predict(obs)[0])[0]


def cost(robot: str, arena: str, action_mode: str | None = None) -> str:
    """Planning cost against the env's step, one process (single env, seeds 1-10, up to 100
    steps each): us per ``env.step`` and per ``predict`` of both baselines, ms per plan."""
    env = gym.make(env_id(robot), **env_kwargs(arena, action_mode))
    pol = wheelgym.baseline(env, planner="auto")
    react = wheelgym.baseline(env)
    obs, _ = env.reset(seed=0)
    pol.predict(obs)  # the map's grid and the compiled kernels
    ts, tp, tr = [], [], []
    for s in range(1, 11):
        obs, _ = env.reset(seed=s)
        for _ in range(100):
            t0 = time.perf_counter()
            a = pol.predict(obs)[0]
            t1 = time.perf_counter()
            react.predict(obs)
            t2 = time.perf_counter()
            obs, _, term, trunc, _ = env.step(a)
            t3 = time.perf_counter()
            ts.append(t3 - t2)
            tp.append(t1 - t0)
            tr.append(t2 - t1)
            if term or trunc:
                break
    step, plan = np.mean(ts), np.mean(pol.navigator.plan_times[1:])
    return (f"| {robot} | {arena} | {step * 1e6:.0f} | {np.mean(tp) / step:.1f}x | "
            f"{np.mean(tr) / step:.1f}x | {plan * 1e3:.1f} ms = {plan / step:.0f} steps |")


def main() -> None:
    # the -v0 ids are the ones measured; Gymnasium's notice that -v1 exists is not news here
    warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", nargs="+", default=available_robots())
    ap.add_argument("--arenas", nargs="+", default=list(ARENAS), choices=ARENAS)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--action-mode", default=None,
                    help="the robots' action mode (default: each robot's first, torque for "
                         "the dynamic robots)")
    ap.add_argument("--no-reactive", action="store_true", help="the planner's columns only")
    ap.add_argument("--out", default=None)
    ap.add_argument("--cost", action="store_true",
                    help="only the planning cost against the env step (robots x arenas)")
    a = ap.parse_args()
    if a.cost:
        print("| robot | arena | env.step us | planner predict | reactive predict | one plan |\n"
              "|---|---|---|---|---|---|")
        for robot in a.robots:
            for arena in a.arenas:
                print(cost(robot, arena, a.action_mode), flush=True)
        return
    lines = ["| robot | arena | planner success | reactive success | planner collisions / "
             "timeouts | planner saturation | plan ms (mean / max) | plans per episode | "
             "target |",
             "|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    t_all = time.perf_counter()
    for robot in a.robots:
        warm_up(robot, a.action_mode)
        for arena in a.arenas:
            P = [run_batch(robot, arena, s, a.episodes, "auto", a.action_mode)
                 for s in range(a.seeds)]
            ps = np.array([p["success"] for p in P])
            times = np.concatenate([p["plan_times"] for p in P]) * 1e3
            if a.no_reactive:
                rtxt = "-"
            else:
                R = [run_batch(robot, arena, s, a.episodes, None, a.action_mode)
                     for s in range(a.seeds)]
                rs = np.array([r["success"] for r in R])
                rtxt = f"{rs.mean():.1%} +- {rs.std():.1%}"
            target = TARGET.get(robot, TARGET_OTHERS)
            met = "met" if ps.mean() >= target else "missed"
            line = (f"| {robot} | {arena} | {ps.mean():.1%} +- {ps.std():.1%} | {rtxt} | "
                    f"{np.mean([p['collision'] for p in P]):.1%} / "
                    f"{np.mean([p['timeout'] for p in P]):.1%} | "
                    f"{np.mean([p['saturation'] for p in P]):.1%} | "
                    f"{times.mean():.1f} / {times.max():.0f} | "
                    f"{np.mean([p['plans_per_episode'] for p in P]):.2f} | "
                    f">= {target:.0%} ({met}) |")
            lines.append(line)
            print(line, flush=True)
    foot = (f"\n{a.seeds} seeds x {a.episodes} episodes per cell; "
            f"{time.perf_counter() - t_all:.0f} s in all")
    print(foot)
    if a.out:
        with open(a.out, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n" + foot + "\n")


if __name__ == "__main__":
    main()
