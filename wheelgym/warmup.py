"""Compile wheelgym's environment kernels into numba's disk cache, split over processes.

A fresh checkout compiles each kernel on first use. Two processes that need the same kernel at
once (the test workers of ``pytest -n 2``) both compile it; the costliest take minutes. Run
before them, :func:`warm` compiles each kernel in one process only::

    python -m wheelgym.warmup --processes 2 --skip-dc ThreeWheel --skip-threaded-dc

(``make test`` does; ThreeWheel's DC-motor kernels and the threaded DC-motor kernels, used from
``PAR_MIN_ROWS`` robots, are not used by its tests.) A warm cache is loaded in seconds.
:mod:`wheelgym._numba_cache` keeps the cache consistent with the sources.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from functools import partial

import gymnasium as gym
import numpy as np

from wheelgym.agents.policies import make_baseline
from wheelgym.envs.robots import available_robots, get_spec
from wheelgym.envs.robots.body import PAR_MIN_ROWS
from wheelgym.kinematics.car_rollout import plan_costs
from wheelgym.models import PARALLEL_MIN_BATCH
from wheelgym.registration import env_id

#: (robots, motor family): one dynamic robot with ``"ideal"`` (its action modes with ideal
#: motors) or ``"dc"`` (the voltage mode and the modes with ``motor="dc"``), or every kinematic
#: robot with ``None`` (they step through one set of kernels).
Job = tuple[tuple[str, ...], "str | None"]


def warm_jobs(skip_dc: tuple[str, ...] = ()) -> list[Job]:
    """The jobs, costliest first; no ``"dc"`` job for the robots in ``skip_dc``.

    A job holds the combinations that share compiled kernels (a robot's torque and velocity
    modes step through one kernel; the kinematic robots share theirs), so that no two processes
    compile the same kernel.
    """
    unknown = [r for r in skip_dc if r not in available_robots()]
    if unknown:
        raise ValueError(f"skip_dc: unknown robots {unknown}; valid: {available_robots()}")
    cost = {"ThreeWheel": 0, "SkidSteer": 1, "CasterAGV": 2}  # measured: 60 / 27 / 22 s CPU
    jobs: list[Job] = []
    kinematic: list[str] = []
    for robot in sorted(available_robots(), key=lambda r: cost.get(r, 3)):
        spec = get_spec(robot)
        if spec.kinematic:
            kinematic.append(robot)
            continue
        if spec.has_dc_motors and robot not in skip_dc:
            jobs.append(((robot,), "dc"))
        jobs.append(((robot,), "ideal"))
    if kinematic:
        jobs.append((tuple(kinematic), None))
    return jobs


def _combos(job: Job) -> list[tuple[str, dict[str, str]]]:
    """Each robot of a job with the ``gym.make`` keywords of one combination (without the
    task)."""
    robots, family = job
    out: list[tuple[str, dict[str, str]]] = []
    for robot in robots:
        spec = get_spec(robot)
        if family == "dc":
            out += [(robot, {"action_mode": m}) for m in spec.dc_action_modes]
            out += [(robot, {"action_mode": m, "motor": "dc"}) for m in spec.action_modes]
        else:
            out += [(robot, {"action_mode": m}) for m in spec.action_modes]
    return out


def warm_one(job: Job, threaded_dc: bool = True) -> tuple[Job, float]:
    """Step the robots' models (ideal motors), and build, reset and step the single and vector
    envs of ``job``'s combinations (every task; a batch above the threaded kernels' threshold
    too, for a ``"dc"`` job only with ``threaded_dc``) and their baselines; returns the job and
    the seconds."""
    t0 = time.perf_counter()
    robots, family = job
    # the models' own kernels (ideal motors): one state, a batch, a threaded batch
    for robot in robots if family != "dc" else ():
        spec = get_spec(robot)
        model = spec.model_cls(None, input_mode=spec.action_modes[0]) if spec.kinematic \
            else spec.model_cls()
        for lead in ((), (3,), (PARALLEL_MIN_BATCH,)):
            x = np.zeros(lead + (model.state_dim,))
            u = np.zeros(lead + (model.input_dim,))
            model.derivative(x, u)
            model.step(x, u, 0.01, 2)
    if family is None:  # the car-like track baseline's search (it runs off the reference only;
        # one compiled signature serves Bicycle and Ackermann)
        plan_costs(np.zeros((1, 4)), np.zeros((1, 2, 3)), np.zeros((1, 2, 3)),
                   np.zeros((1, 2, 2)), 0.05, 1.0, None)
    for robot, kw in _combos(job):
        for task in ("goal", "track", "navigate"):
            env = gym.make(env_id(robot), task=task, **kw)
            obs, _ = env.reset(seed=0)
            env.step(env.action_space.sample())
            try:
                make_baseline(env).predict(obs)
            except ValueError:  # no baseline for this combination
                pass
            env.close()
            for n in (2, PAR_MIN_ROWS + 1) if threaded_dc or family != "dc" else (2,):
                venv = gym.make_vec(env_id(robot), num_envs=n,
                                    vectorization_mode="vector_entry_point", task=task, **kw)
                venv.reset(seed=0)
                venv.step(venv.action_space.sample())
                venv.close()
    return job, time.perf_counter() - t0


def job_name(job: Job) -> str:
    """``"SkidSteer dc"``, ``"ThreeWheel ideal"``, ``"kinematic (DiffDrive, ...)"``."""
    robots, family = job
    if family is None:
        return f"kinematic ({', '.join(robots)})"
    return f"{robots[0]} {family}"


def warm(processes: int = 2, skip_dc: tuple[str, ...] = (), threaded_dc: bool = True) -> None:
    """Compile (or load) the environment kernels of :func:`warm_jobs` into the disk cache,
    ``processes`` at a time, each in one process only; prints each job's seconds."""
    t0 = time.perf_counter()
    jobs = warm_jobs(skip_dc)
    with mp.get_context("spawn").Pool(processes, maxtasksperchild=None) as pool:
        for job, s in pool.imap_unordered(partial(warm_one, threaded_dc=threaded_dc), jobs):
            print(f"numba cache: {job_name(job)} {s:.1f} s", flush=True)
    print(f"numba cache: {len(jobs)} jobs in {time.perf_counter() - t0:.1f} s", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        prog="python -m wheelgym.warmup",
        description="Compile wheelgym's environment kernels into numba's disk cache in "
                    "parallel processes (make test runs it before the suite).")
    parser.add_argument("--processes", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--skip-dc", action="append", default=[], metavar="ROBOT",
                        help="leave out ROBOT's DC-motor and voltage-mode kernels (repeatable)")
    parser.add_argument("--skip-threaded-dc", action="store_true",
                        help="leave out the DC-motor kernels of batches from "
                             f"{PAR_MIN_ROWS} robots (the threaded ones)")
    args = parser.parse_args()
    if args.processes < 1:
        parser.error(f"--processes must be >= 1, got {args.processes}")
    try:
        warm(args.processes, tuple(args.skip_dc), not args.skip_threaded_dc)
    except ValueError as e:
        parser.error(str(e))
