"""Steps per second of ``env.step`` for every wheelgym id and task vs Gymnasium's Pendulum-v1.

Run: ``python benchmarks/envs.py [--steps 3000] [--repeats 5] [--robots ...] [--motor-only]
[--maps-only] [--breakdown]``. Prints a Markdown table of the median time per step (us) and
the ratio of steps/s to Pendulum-v1 measured in the same run (higher is faster), the cost of
the DC motor model (``motor="dc"`` vs ``"ideal"``, goal task, torque mode, timed alternately in
the same run; ``--motor-only``: that table alone), the cost of map-based ``navigate`` (each
shipped map vs the random arena, timed alternately; ``--maps-only``: that table alone), plus
``gym.make`` time once the compiled caches exist. ``--breakdown``: only where a single env's
step goes (the compiled physics, the core, the wrappers and info), against Pendulum-v1.
``--hint-only``: only the cost of navigate -v1's waypoint hint (single and 32-row vector env).
``--substeps``: only the speed/accuracy table of the dynamic robots' ``sim_dt`` (each robot's
default and coarser divisors of ``ctrl_dt``): RK4's error against an 8x finer step and the single
env's step against Pendulum-v1, both action modes.
Actions are sampled before timing; episodes that end are reset outside the timed region's
count.
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import numpy as np

import wheelgym  # noqa: F401  (registers the ids)
from wheelgym.envs.robots import available_robots
from wheelgym.registration import env_id
from wheelgym.validate import step_refinement_error, stiffness_margin

TARGETS = {"ThreeWheel": 0.3, "SkidSteer": 0.5, "CasterAGV": 0.3, "DiffDrive": 1.0,
           "Unicycle": 1.0, "Bicycle": 1.0, "Ackermann": 1.0}
NAVIGATE_TARGET = 0.2


def _one_run(env: gym.Env, acts: np.ndarray, seed: int) -> float:
    """Seconds per ``env.step`` over ``acts`` (resets after episode ends are not timed)."""
    n = len(acts)
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
    return t_total / n


def _actions(env: gym.Env, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, (n,) + env.action_space.shape).astype(np.float32)


def time_steps(env: gym.Env, n: int, repeats: int, seed: int = 0,
               ref: gym.Env | None = None) -> tuple[float, float]:
    """Median seconds per step of ``env`` and of ``ref`` (Pendulum), measured alternately
    (``repeats`` runs of ``n`` steps each) so that a changing machine load hits both."""
    acts = _actions(env, n, seed)
    _one_run(env, acts[:200], seed)  # warm-up
    ref = ref if ref is not None else gym.make("Pendulum-v1")
    racts = _actions(ref, n, seed)
    _one_run(ref, racts[:200], seed)
    mine, theirs = [], []
    for _ in range(repeats):
        theirs.append(_one_run(ref, racts, seed))
        mine.append(_one_run(env, acts, seed))
    return statistics.median(mine), statistics.median(theirs)


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


def bench_motor(robots: list[str], steps: int, repeats: int) -> None:
    """Goal task, torque mode: us/step with ``motor="dc"`` and ``"ideal"`` (timed alternately,
    the same actions) and their ratio, for the robots with a motor model."""
    print("| id | motor=ideal us/step | motor=dc us/step | dc / ideal |")
    print("|---|---|---|---|")
    for robot in robots:
        if not wheelgym.envs.robots.get_spec(robot).has_dc_motors:
            continue
        dc = gym.make(env_id(robot), task="goal", action_mode="torque", motor="dc")
        ideal = gym.make(env_id(robot), task="goal", action_mode="torque")
        t_dc, t_id = time_steps(dc, steps, repeats, ref=ideal)
        print(f"| {env_id(robot)} | {t_id * 1e6:.1f} | {t_dc * 1e6:.1f} | {t_dc / t_id:.2f}x |")
        dc.close()
        ideal.close()


def bench_maps(robots: list[str], steps: int, repeats: int) -> None:
    """navigate, the robot's first action mode: us/step on each shipped map and on the random
    arena (timed alternately, the same actions) and their ratio."""
    from wheelgym.world import MAPS

    print("| id | arena | map us/step | random arena us/step | map / random |")
    print("|---|---|---|---|---|")
    for robot in robots:
        rand = gym.make(env_id(robot), task="navigate")
        for name in MAPS:
            env = gym.make(env_id(robot), task="navigate", arena=name)
            t_map, t_rand = time_steps(env, steps, repeats, ref=rand)
            print(f"| {env_id(robot)} | {name} | {t_map * 1e6:.1f} | {t_rand * 1e6:.1f} | "
                  f"{t_map / t_rand:.2f}x |")
            env.close()
        rand.close()


def bench_hint(robots: list[str], steps: int, repeats: int) -> None:
    """navigate -v1 on the random arena, the robot's first action mode: us/step of a single
    env with the waypoint hint (a planned path per episode, the nearest path point each step)
    and without it (timed alternately, the same actions), and of a 32-row vector env's step
    per row, with and without."""
    print("| id | single env, hint us/step | no hint us/step | hint / no hint | "
          "vector env (32 rows), hint us/row-step | no hint us/row-step |")
    print("|---|---:|---:|---:|---:|---:|")
    for robot in robots:
        eid = env_id(robot, 1)
        hint = gym.make(eid, task="navigate", waypoint_hint=True)
        plain = gym.make(eid, task="navigate")
        t_hint, t_plain = time_steps(hint, steps, repeats, ref=plain)
        rows = []
        for kw in (dict(waypoint_hint=True), {}):
            vec = gym.make_vec(eid, num_envs=32, vectorization_mode="vector_entry_point",
                               task="navigate", **kw)
            vec.reset(seed=0)
            acts = np.random.default_rng(0).uniform(
                -1, 1, (max(1, steps // 8),) + vec.action_space.shape).astype(np.float32)
            runs = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                for a in acts:
                    vec.step(a)
                runs.append((time.perf_counter() - t0) / (len(acts) * 32))
            rows.append(statistics.median(runs))
            vec.close()
        print(f"| {eid} | {t_hint * 1e6:.1f} | {t_plain * 1e6:.1f} | {t_hint / t_plain:.2f}x | "
              f"{rows[0] * 1e6:.1f} | {rows[1] * 1e6:.1f} |")
        hint.close()
        plain.close()


def bench_breakdown(robots: list[str], steps: int, repeats: int) -> None:
    """Where a single env's step goes (goal task, every action mode): ``env.step`` through
    ``gym.make``, the core's step (physics, controller, task kernel) on its own action buffer
    as the env calls it, the compiled physics kernel alone, and Pendulum-v1's step, each the
    median of ``repeats`` runs of ``steps`` calls, interleaved round by round."""
    print("| robot, action mode | env.step us | physics kernel us | WheelCore.step us | "
          "wrappers, checks, info us | Pendulum-v1 us | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    pend = gym.make("Pendulum-v1")
    pend.reset(seed=0)
    pa = np.zeros(1, dtype=np.float32)
    for robot in robots:
        for mode in wheelgym.envs.robots.get_spec(robot).action_modes:
            env = gym.make(env_id(robot), task="goal", action_mode=mode)
            env.reset(seed=0)
            core = env.unwrapped.core
            a = np.zeros(env.action_space.shape, dtype=np.float32)
            A = core.A  # the env's action buffer: its step's path (the kernels' entry points)

            def step(env=env, a=a):
                _, _, te, tr, _ = env.step(a)
                if te or tr:
                    env.reset()

            def kernel(core=core, A=A):
                core._k_step(core.X, A, core.LH, core.P, core.h, core.n_sub, core.Xo, core.B,
                             core.F)

            fns = {"env": step, "kernel": kernel, "core": lambda core=core, A=A: core.step(A),
                   "pend": lambda: pend.step(pa)}
            times: dict[str, list[float]] = {k: [] for k in fns}
            for r in range(repeats + 1):
                for k, f in fns.items():
                    t0 = time.perf_counter()
                    for _ in range(steps):
                        f()
                    if r:  # the first round warms up
                        times[k].append((time.perf_counter() - t0) / steps * 1e6)
            m = {k: statistics.median(v) for k, v in times.items()}
            print(f"| {robot}, {mode} | {m['env']:.1f} | {m['kernel']:.1f} | {m['core']:.1f} | "
                  f"{m['env'] - m['core']:.1f} | {m['pend']:.1f} | {m['pend'] / m['env']:.2f}x |")
            env.close()


#: ``sim_dt`` values of the ``--substeps`` table (s): divisors of the 0.05 s control period.
SUBSTEP_DTS = (0.00125, 0.002, 0.0025, 0.005)


def bench_substeps(robots: list[str], steps: int, repeats: int) -> None:
    """Speed against accuracy of the RK4 substep ``sim_dt`` (an env keyword) for the dynamic
    robots: the largest relative state error over a 10 s validation manoeuvre against a run at
    ``sim_dt / 8`` (:func:`wheelgym.validate.step_refinement_error`; 1e-6 is 1 um, 1 urad or
    1 um/s where the state stays below 1), RK4's stiffness margin ``lambda sim_dt`` (stable
    below 2.79), and the single env's goal-task step against Pendulum-v1 (timed alternately)."""
    print("| robot | sim_dt (s) | substeps | relative error (10 s) | lambda sim_dt | "
          "action mode | us/step | ratio vs Pendulum |")
    print("|---|---:|---:|---:|---:|---|---:|---:|")
    pend = gym.make("Pendulum-v1")
    for robot in robots:
        spec = wheelgym.envs.robots.get_spec(robot)
        if spec.kinematic:
            continue  # its default step is exact for constant commands
        model = spec.make_model(None, spec.action_modes[0])
        for sdt in SUBSTEP_DTS:
            if sdt < model.default_sim_dt:
                continue
            err = step_refinement_error(model, 10.0, 8, sdt)
            margin = stiffness_margin(model, sdt)
            default = " (default)" if sdt == model.default_sim_dt else ""
            n_sub = model.n_substeps(model.default_ctrl_dt, sdt)
            for mode in spec.action_modes:
                env = gym.make(env_id(robot), task="goal", action_mode=mode, sim_dt=sdt)
                t, t_ref = time_steps(env, steps, repeats, ref=pend)
                print(f"| {robot} | {sdt:g}{default} | {n_sub}"
                      f" | {err:.1e} | {margin:.2f} | {mode} | {t * 1e6:.1f} | {t_ref / t:.2f}x |")
                env.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--robots", nargs="*", default=None)
    ap.add_argument("--motor-only", action="store_true",
                    help="only the motor='dc' vs 'ideal' table")
    ap.add_argument("--maps-only", action="store_true",
                    help="only the map-based navigate vs random arena table")
    ap.add_argument("--breakdown", action="store_true",
                    help="only the table of where a single env's step goes")
    ap.add_argument("--substeps", action="store_true",
                    help="only the speed/accuracy table of sim_dt for the dynamic robots")
    ap.add_argument("--hint-only", action="store_true",
                    help="only the navigate -v1 waypoint hint's cost table")
    args = ap.parse_args()
    if args.hint_only:
        bench_hint(args.robots or available_robots(), args.steps, args.repeats)
        return
    if args.substeps:
        bench_substeps(args.robots or available_robots(), args.steps, args.repeats)
        return
    if args.breakdown:
        bench_breakdown(args.robots or available_robots(), args.steps, args.repeats)
        return
    if args.motor_only:
        bench_motor(args.robots or available_robots(), args.steps, args.repeats)
        return
    if args.maps_only:
        bench_maps(args.robots or available_robots(), args.steps, args.repeats)
        return
    pend = gym.make("Pendulum-v1")
    print("Pendulum-v1 is timed alternately with each row (its us/step in the last column).\n")
    print("| id | task | action mode | us/step | steps/s | ratio vs Pendulum | target | "
          "Pendulum us/step |")
    print("|---|---|---|---|---|---|---|---|")
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
                t, t_ref = time_steps(env, args.steps, args.repeats, ref=pend)
                target = NAVIGATE_TARGET if task == "navigate" else TARGETS.get(robot, 1.0)
                ratio = t_ref / t
                flag = "ok" if ratio >= target else "MISS"
                print(f"| {env_id(robot)} | {task} | {mode} | {t * 1e6:.1f} | {1 / t:,.0f} | "
                      f"{ratio:.2f}x | >= {target}x {flag} | {t_ref * 1e6:.1f} |")
                env.close()
        if args.repeats and spec.name == "ThreeWheel":
            for backend in ("analytic", "pymunk"):
                env = gym.make(env_id(robot), task="navigate", range_backend=backend)
                t, t_ref = time_steps(env, args.steps, args.repeats, ref=pend)
                print(f"| {env_id(robot)} | navigate, rays: {backend} | torque | {t * 1e6:.1f} "
                      f"| {1 / t:,.0f} | {t_ref / t:.2f}x | | {t_ref * 1e6:.1f} |")
    print()
    bench_motor(robots, args.steps, args.repeats)
    print()
    bench_maps(robots, args.steps, args.repeats)
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
        fresh = _fresh_make(robot)
        print(f"gym.make({env_id(robot)!r}): {statistics.median(times) * 1e3:.1f} ms in a warm "
              f"process; in a fresh process (compiled caches on disk) import wheelgym "
              f"{fresh[0] * 1e3:.0f} ms, first gym.make {fresh[1] * 1e3:.0f} ms, first "
              f"reset+step {fresh[2] * 1e3:.0f} ms (target: make < 500 ms)")


def _fresh_make(robot: str) -> list[float]:
    import subprocess
    import sys

    code = (
        "import time; t0 = time.perf_counter(); import gymnasium as gym, wheelgym; "
        "t1 = time.perf_counter(); "
        f"env = gym.make({env_id(robot)!r}); t2 = time.perf_counter(); "
        "env.reset(seed=0); env.step(env.action_space.sample()); t3 = time.perf_counter(); "
        "print(t1 - t0, t2 - t1, t3 - t2)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    return [float(v) for v in out]


if __name__ == "__main__":
    main()
