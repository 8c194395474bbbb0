"""Compile wheelgym's environment kernels into numba's disk cache, split over processes.

A fresh checkout compiles each kernel on first use. Two processes that need the same kernel at
once (the test workers of ``pytest -n 2``) both compile it; the costliest take minutes. Run
before them, :func:`warm` compiles each kernel in one process only::

    python -m wheelgym.warmup --processes 2 --skip-dc ThreeWheel

(``make test`` does; ThreeWheel's DC-motor kernels serve only the slow tests.) A warm cache is
loaded in seconds. :mod:`wheelgym._numba_cache` keeps the cache consistent with the sources.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time

import gymnasium as gym

from wheelgym.agents.policies import make_baseline
from wheelgym.envs.robots import available_robots, get_spec
from wheelgym.envs.robots.body import PAR_MIN_ROWS
from wheelgym.registration import env_id

#: (robot, action mode, motor or None for the mode's own)
Job = tuple[str, str, "str | None"]


def warm_jobs(skip_dc: tuple[str, ...] = ()) -> list[Job]:
    """(robot, action mode, motor) combinations whose kernels differ, costliest first; none
    with DC motors (``motor="dc"``, the voltage mode) for the robots in ``skip_dc``.

    A fresh checkout compiles each on first use; two test processes that need the same kernel
    at once both compile it (ThreeWheel's DC kernels alone take minutes).
    """
    unknown = [r for r in skip_dc if r not in available_robots()]
    if unknown:
        raise ValueError(f"skip_dc: unknown robots {unknown}; valid: {available_robots()}")
    jobs: list[Job] = []
    for robot in available_robots():
        spec = get_spec(robot)
        if spec.n_motor > 0:
            dc = robot not in skip_dc
            if dc:
                jobs.append((robot, "voltage", None))
            for mode in spec.action_modes:
                jobs += [(robot, mode, "ideal")] + ([(robot, mode, "dc")] if dc else [])
        else:
            jobs += [(robot, mode, None) for mode in spec.action_modes]
    # the DC-motor torque/velocity kernels last: they share pieces with the voltage mode's,
    # which are then in the cache
    order = {"ThreeWheel": 0, "SkidSteer": 1, "CasterAGV": 2}
    return sorted(jobs, key=lambda j: (j[2] == "dc", order.get(j[0], 3), j[1] != "voltage"))


def warm_one(job: Job) -> tuple[Job, float]:
    """Build, reset and step ``job``'s single and vector envs (every task; a batch above the
    threaded kernels' threshold too) and its baseline; returns the job and the seconds."""
    t0 = time.perf_counter()
    robot, mode, motor = job
    kw = {"action_mode": mode} if motor is None else {"action_mode": mode, "motor": motor}
    for task in ("goal", "track", "navigate"):
        env = gym.make(env_id(robot), task=task, **kw)
        obs, _ = env.reset(seed=0)
        env.step(env.action_space.sample())
        try:
            make_baseline(env).predict(obs)
        except ValueError:  # no baseline for this combination
            pass
        env.close()
        for n in (2, PAR_MIN_ROWS + 1):
            venv = gym.make_vec(env_id(robot), num_envs=n, vectorization_mode="vector_entry_point",
                                task=task, **kw)
            venv.reset(seed=0)
            venv.step(venv.action_space.sample())
            venv.close()
    return job, time.perf_counter() - t0


def warm(processes: int = 2, skip_dc: tuple[str, ...] = ()) -> None:
    """Compile (or load) the environment kernels of :func:`warm_jobs` into the disk cache,
    ``processes`` at a time, each in one process only; prints each job's seconds."""
    t0 = time.perf_counter()
    jobs = warm_jobs(skip_dc)
    with mp.get_context("spawn").Pool(processes, maxtasksperchild=None) as pool:
        for (robot, mode, motor), s in pool.imap_unordered(warm_one, jobs):
            print(f"numba cache: {robot} {mode}{'' if motor is None else ' ' + motor} "
                  f"{s:.1f} s", flush=True)
    print(f"numba cache: {len(jobs)} jobs in {time.perf_counter() - t0:.1f} s", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        prog="python -m wheelgym.warmup",
        description="Compile wheelgym's environment kernels into numba's disk cache in "
                    "parallel processes (make test runs it before the suite).")
    parser.add_argument("--processes", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--skip-dc", action="append", default=[], metavar="ROBOT",
                        help="leave out ROBOT's DC-motor and voltage-mode kernels (repeatable)")
    args = parser.parse_args()
    if args.processes < 1:
        parser.error(f"--processes must be >= 1, got {args.processes}")
    try:
        warm(args.processes, tuple(args.skip_dc))
    except ValueError as e:
        parser.error(str(e))
