"""Time to the first step of a new user's first ``gym.make`` (numba's cache empty), and warm.

Run: ``python benchmarks/coldstart.py [--quick] [--robots ...] [--tasks ...] [--modes ...]
[--motor all|ideal|dc] [--rev REV]
[--kernels] [--json FILE]`` (``--rev worktree``: the working tree's files instead).
``--twice [PYTEST_ARG ...]``: instead, the warm-up's jobs (or pytest with those arguments) in
one process on a fresh copy, its CPU seconds and every dispatcher compiled for more than one
signature (a read-only array, another layout or index type each compile a kernel again).

For every robot x action mode x task (and ``motor="dc"`` and the voltage mode where the robot
has DC motors) it extracts a fresh copy of the package at ``REV`` (``git archive REV wheelgym |
tar -x``, default ``HEAD``: no numba cache), then runs ``gym.make(id, task=..., ...)``,
``reset`` and one ``step`` in a fresh Python process on that copy: the **cold** seconds (the
process's wall time, interpreter start and imports included: what the user waits for; also
its CPU seconds, which depend less on what else the machine runs). A
second process on the same copy, whose cache the first one filled, gives the **warm** seconds.
Each process also counts the numba dispatchers it compiled (numba's ``numba:compile``
events; a load from the disk cache is no compile). Prints a Markdown table and the total;
``--kernels`` adds each combination's slowest compiles (inclusive CPU seconds), ``--json`` writes
the rows. ``--quick``: each robot's first action mode on the goal task only (smoke use).

The other packages (numpy, numba, gymnasium...) are the running interpreter's; only
wheelgym's own cache starts empty, as after a fresh ``pip install`` or ``git clone``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TASKS = ("goal", "track", "navigate")

# The child process: first gym.make + reset + step, with numba's compile events recorded.
CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import numba.core.event as ev
stack, done = [], []
class Rec(ev.Listener):
    def on_start(self, e):
        d = e.data["dispatcher"]
        stack.append((f"{d.py_func.__module__}.{d.py_func.__qualname__}", time.process_time()))
    def on_end(self, e):
        name, t = stack.pop()
        done.append((name, time.process_time() - t, len(stack)))
ev.register("numba:compile", Rec())
import gymnasium as gym
import wheelgym
kw = json.loads(sys.argv[1])
env = gym.make(kw.pop("id"), **kw)
env.reset(seed=0)
env.step(env.action_space.sample())
print(json.dumps({"inside_s": time.perf_counter() - t0, "compiles": done}))
"""


def combinations(robots: list[str], tasks: tuple[str, ...], quick: bool,
                 motor: str = "all", modes: tuple[str, ...] = ()) -> list[dict]:
    """The ``gym.make`` keywords of every combination (``quick``: first mode, goal only;
    ``motor``: ``"ideal"`` or ``"dc"`` (the voltage mode included) for one motor model only;
    ``modes``: only these action modes)."""
    sys.path.insert(0, str(REPO))
    from wheelgym.envs.robots import get_spec
    from wheelgym.registration import env_id

    out = []
    for robot in robots:
        spec = get_spec(robot)
        kws = [{"action_mode": m} for m in spec.action_modes]
        if spec.has_dc_motors:
            kws += [{"action_mode": m, "motor": "dc"} for m in spec.action_modes]
            kws += [{"action_mode": m} for m in spec.dc_action_modes]
        if motor != "all":
            kws = [kw for kw in kws if (kw.get("motor") == "dc"
                                        or kw["action_mode"] in spec.dc_action_modes)
                   == (motor == "dc")]
        if modes:
            kws = [kw for kw in kws if kw["action_mode"] in modes]
        if quick:
            kws, tasks_r = kws[:1], ("goal",)
        else:
            tasks_r = tasks
        for kw in kws:
            for task in tasks_r:
                out.append({"id": env_id(robot), "task": task, **kw})
    return out


def _run_child(pkg: Path, kw: dict) -> dict:
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)  # the cache next to the sources of the fresh copy
    env["PYTHONPATH"] = str(pkg)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, json.dumps(kw)], cwd=pkg, env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{kw}: the child failed:\n{proc.stderr[-3000:]}")
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    res["wall_s"] = wall
    res["cpu_s"] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    res["stderr"] = proc.stderr
    return res


# The child of ``--twice``: the warm-up's jobs (or pytest on given paths) on the fresh copy in
# one process, each top-level compile recorded with its signature and its exclusive CPU time.
TWICE_CHILD = r"""
import json, sys, time
import numba.core.event as ev
stack, done = [], []
class Rec(ev.Listener):
    def on_start(self, e):
        d = e.data["dispatcher"]
        name = f"{d.py_func.__module__}.{d.py_func.__qualname__}"
        stack.append([name, str(e.data.get("args")), time.process_time(), 0.0])
    def on_end(self, e):
        name, sig, t, inner = stack.pop()
        incl = time.process_time() - t
        if stack:
            stack[-1][3] += incl
        done.append((name, sig, incl - inner))
ev.register("numba:compile", Rec())
sys.path.insert(0, sys.argv[2])  # the fresh copy before the checkout (the cwd of pytest's run)
import wheelgym  # imported now: the tests then use the fresh copy's modules
args = json.loads(sys.argv[1])
jobs = {}
t0 = time.process_time()
if args:
    import pytest
    rc = pytest.main(["-q", "-p", "no:cacheprovider", "-p", "no:randomly", *args])
    jobs["pytest exit code " + str(int(rc))] = 0.0  # (the checkout's tests on another rev)
else:
    from wheelgym import warmup
    for job in warmup.warm_jobs():
        t = time.process_time()
        warmup.warm_one(job)
        name = warmup.job_name(job) if hasattr(warmup, "job_name") else " ".join(
            j for j in job if j)  # (a revision before the kinematic robots' one job)
        jobs[name] = time.process_time() - t
print(json.dumps({"cpu_s": time.process_time() - t0, "jobs": jobs, "compiles": done}))
"""


def compiled_twice(rev: str | None, pytest_args: list[str]) -> dict:
    """On a fresh copy of ``rev`` (None: the working tree), the warm-up's jobs (or pytest on
    ``pytest_args``, run from the checkout) in one process: its CPU seconds, each job's, and
    every wheelgym dispatcher compiled for more than one signature, with each signature's
    exclusive CPU seconds (numba's compile events; a read-only array, an ``'A'`` layout or a
    ``uint64`` index is a signature of its own)."""
    tmp = Path(tempfile.mkdtemp(prefix="wheelgym-twice-"))
    try:
        fresh_copy(tmp, rev)
        env = dict(os.environ)
        env.pop("NUMBA_CACHE_DIR", None)
        env["PYTHONPATH"] = str(tmp)
        proc = subprocess.run([sys.executable, "-c", TWICE_CHILD, json.dumps(pytest_args),
                               str(tmp)],
                              cwd=REPO if pytest_args else tmp, env=env, capture_output=True,
                              text=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if proc.returncode != 0:
        raise RuntimeError(f"the child failed:\n{proc.stdout[-2000:]}{proc.stderr[-3000:]}")
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    sigs: dict[str, list[tuple[str, float]]] = {}
    for name, sig, s in res["compiles"]:
        if name.startswith("wheelgym."):
            sigs.setdefault(name, []).append((sig, s))
    res["twice"] = {k: v for k, v in sigs.items() if len(v) > 1}
    return res


def fresh_copy(dest: Path, rev: str | None) -> None:
    """The package without any numba cache into ``dest``: ``git archive rev wheelgym``, or
    (``rev`` None) the working tree's ``wheelgym/`` without its ``__pycache__`` folders."""
    if rev is None:
        shutil.copytree(REPO / "wheelgym", dest / "wheelgym",
                        ignore=shutil.ignore_patterns("__pycache__"))
        return
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev, "wheelgym"],
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)


def measure(kw: dict, rev: str | None = "HEAD", keep: bool = False) -> dict:
    """Cold and warm seconds of one combination on a fresh copy of ``rev`` (None: of the
    working tree, :func:`fresh_copy`)."""
    tmp = Path(tempfile.mkdtemp(prefix="wheelgym-coldstart-"))
    try:
        fresh_copy(tmp, rev)
        cold = _run_child(tmp, dict(kw))
        warm = _run_child(tmp, dict(kw))
    finally:
        if not keep:
            shutil.rmtree(tmp, ignore_errors=True)
    return {
        **{k: v for k, v in kw.items()},
        "cold_s": cold["wall_s"], "warm_s": warm["wall_s"],
        "cold_cpu_s": cold["cpu_s"], "warm_cpu_s": warm["cpu_s"],
        "compiled": len(cold["compiles"]), "warm_compiled": len(warm["compiles"]),
        "kernels": sorted(cold["compiles"], key=lambda c: -c[1]),
        "notice": [ln for ln in cold["stderr"].splitlines() if ln.startswith("wheelgym:")],
        "warm_notice": [ln for ln in warm["stderr"].splitlines()
                        if ln.startswith("wheelgym:")],
    }


def _label(row: dict) -> str:
    mode = row.get("action_mode", "")
    return mode + (" (dc)" if row.get("motor") == "dc" else "")


def table(rows: list[dict]) -> str:
    lines = ["| robot | task | action mode | cold s | cold CPU s | warm s | kernels compiled |",
             "|---|---|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['id'].split('/')[1].rsplit('-', 1)[0]} | {r['task']} | "
                     f"{_label(r)} | {r['cold_s']:.1f} | {r['cold_cpu_s']:.1f} | "
                     f"{r['warm_s']:.1f} | {r['compiled']} |")
    total = sum(r["cold_s"] for r in rows)
    lines.append(f"| **total** ({len(rows)}) | | | **{total:.1f}** | "
                 f"{sum(r['cold_cpu_s'] for r in rows):.1f} | "
                 f"{sum(r['warm_s'] for r in rows):.1f} | "
                 f"{sum(r['compiled'] for r in rows)} |")
    if rows:
        lines.append(f"\nmedian cold {statistics.median(r['cold_s'] for r in rows):.1f} s, "
                     f"max {max(r['cold_s'] for r in rows):.1f} s; "
                     f"median warm {statistics.median(r['warm_s'] for r in rows):.1f} s")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="each robot's first action mode on the goal task only")
    ap.add_argument("--robots", nargs="*", default=None, help="default: every robot")
    ap.add_argument("--tasks", nargs="*", default=list(TASKS), choices=TASKS)
    ap.add_argument("--motor", default="all", choices=("all", "ideal", "dc"),
                    help="one motor model only (dc: motor='dc' and the voltage mode)")
    ap.add_argument("--modes", nargs="*", default=[], help="only these action modes")
    ap.add_argument("--rev", default="HEAD",
                    help="git revision to copy (default HEAD); 'worktree': the working tree")
    ap.add_argument("--kernels", action="store_true", help="each combination's top compiles")
    ap.add_argument("--json", default=None, help="write the rows as JSON")
    ap.add_argument("--twice", nargs="*", default=None, metavar="PYTEST_ARG",
                    help="instead: the warm-up's jobs (or pytest with these arguments) in one "
                         "process on a fresh copy; its CPU seconds and the dispatchers "
                         "compiled for more than one signature")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(REPO))
    if args.twice is not None:
        res = compiled_twice(None if args.rev == "worktree" else args.rev, args.twice)
        for job, cpu in res["jobs"].items():
            print(f"{job}: {cpu:.1f} s CPU")
        print(f"total: {res['cpu_s']:.1f} s CPU, {len(res['compiles'])} compiles")
        print("\n| dispatcher | signature | exclusive CPU s |\n|---|---|---:|")
        for name, compiles in sorted(res["twice"].items()):
            for sig, cpu in compiles:
                print(f"| {name} | `{sig}` | {cpu:.2f} |")
        return 0
    from wheelgym.envs.robots import available_robots

    robots = args.robots or available_robots()
    bad = [r for r in robots if r not in available_robots()]
    if bad:
        ap.error(f"--robots: unknown {bad}; valid: {available_robots()}")
    rows = []
    for kw in combinations(robots, tuple(args.tasks), args.quick, args.motor,
                           tuple(args.modes)):
        row = measure(kw, None if args.rev == "worktree" else args.rev)
        rows.append(row)
        print(f"{row['id']} {row['task']} {_label(row)}: cold {row['cold_s']:.1f} s "
              f"({row['cold_cpu_s']:.1f} s CPU, {row['compiled']} kernels), "
              f"warm {row['warm_s']:.1f} s", flush=True)
        for line in row["notice"]:
            print(f"    notice: {line}", flush=True)
        if args.kernels:
            for name, s, depth in row["kernels"][:8]:
                print(f"    {'  ' * depth}{name} {s:.2f} s CPU", flush=True)
    print()
    print(table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
