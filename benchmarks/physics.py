"""Physics speed of every model in ``wheelgym.models``, with same-run references.

Usage: ``python benchmarks/physics.py [--quick]``. Prints Markdown tables:

1. per model: one RK4 substep on one state (``model.step(x, u, sim_dt, 1)``), one control step
   at the default ``ctrl_dt``/``sim_dt``, and batched throughput (state-substeps/s) at
   N = 1, 64, 1024, 16384 (one control step per call on an ``(N, n)`` batch);
2. references measured in the same run: Gymnasium ``Pendulum-v1`` ``env.step`` through
   ``gym.make`` and a plain NumPy RK4 substep of a model of the same state size, with ratios.

Times are medians over repeats after a warm-up; states and inputs are generated beforehand.
Models appear automatically as they are exported from ``wheelgym.models``.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

from wheelgym.integrators import rk4
from wheelgym.validate import input_scale, model_classes

SIZES = (1, 64, 1024, 16384)

# (model, what) -> (bound, unit, "<=" or ">="); ratios to SkidSteer are handled separately
TARGETS: dict[tuple[str, str], float] = {
    ("ThreeWheel", "substep_us"): 3.0,
    ("SkidSteer", "substep_us"): 1.5,
}
KINEMATIC_CTRL_US = 2.0  # control step of a kinematic model (no friction state)
BATCH_TARGET = 3e6  # state-substeps/s at N = 16384 (ThreeWheel)
CASTER_VS_SKID = 1.5
PENDULUM_QUIET_US = 16.0  # design/performance.md, same machine class without other load


def per_call_us(fn: Callable[[int], None], n_calls: int, repeats: int) -> float:
    """Median over ``repeats`` of the time per call (us) of ``fn(i)`` for i in range(n_calls)."""
    fn_warm = min(n_calls, 200)
    for i in range(fn_warm):
        fn(i)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for i in range(n_calls):
            fn(i)
        times.append((time.perf_counter() - t0) / n_calls)
    return statistics.median(times) * 1e6


def bench_model(cls, quick: bool) -> dict:
    model = cls()
    rng = np.random.default_rng(0)
    k = 64
    xs = [np.ascontiguousarray(v) for v in rng.normal(0, 0.3, (k, model.state_dim))]
    us = [np.ascontiguousarray(v) for v in
          rng.uniform(-1, 1, (k, model.input_dim)) * 0.5 * input_scale(model)]
    sim_dt, ctrl_dt = model.default_sim_dt, model.default_ctrl_dt
    n_sub = model.n_substeps()
    reps = 3 if quick else 5
    calls = 2000 if quick else 10000
    step = model.step

    sub = per_call_us(lambda i: step(xs[i % k], us[i % k], sim_dt, 1), calls, reps)
    ctrl = per_call_us(lambda i: step(xs[i % k], us[i % k], ctrl_dt, n_sub), calls // 4, reps)
    thr = {}
    for n in SIZES:
        if quick and n > 1024:
            n = 4096  # quick mode caps the batch
        X = rng.normal(0, 0.3, (n, model.state_dim))
        U = rng.uniform(-1, 1, (n, model.input_dim)) * 0.5 * input_scale(model)
        budget = 1e5 if quick else 5e5  # state-substeps per repeat
        n_calls = max(1, int(budget // (n * n_sub)))
        t = per_call_us(lambda i, X=X, U=U: step(X, U, ctrl_dt, n_sub), n_calls, reps)
        thr[n] = n * n_sub / (t * 1e-6)
    return {"name": cls.__name__, "nx": model.state_dim, "nu": model.input_dim,
            "n_sub": n_sub, "sim_dt": sim_dt, "substep_us": sub, "ctrl_us": ctrl, "thr": thr,
            "kinematic": not callable(getattr(model, "stiffness", None))}


def bench_numpy_rk4(nx: int, nu: int, quick: bool) -> float:
    """Plain NumPy RK4 substep (us) of ``x' = solve(M, A x + B tanh(u))``, one state of size nx."""
    rng = np.random.default_rng(1)
    a = rng.normal(size=(nx, nx)) * 0.1
    b = rng.normal(size=(nx, nu))
    q = rng.normal(size=(nx, nx))
    m = q @ q.T + nx * np.eye(nx)

    def f(x, u):
        return np.linalg.solve(m, a @ x + b @ np.tanh(u))

    x, u = rng.normal(size=nx), rng.normal(size=nu)
    calls = 500 if quick else 3000
    return per_call_us(lambda i: rk4(f, x, u, 0.002, 1), calls, 3 if quick else 5)


def bench_pendulum(quick: bool) -> float:
    import gymnasium as gym

    env = gym.make("Pendulum-v1")
    env.reset(seed=0)
    actions = [env.action_space.sample() for _ in range(1000)]
    calls = 2000 if quick else 20000

    def one(i):
        _, _, term, trunc, _ = env.step(actions[i % 1000])
        if term or trunc:
            env.reset()

    t = per_call_us(one, calls, 3 if quick else 5)
    env.close()
    return t


def verdict(ok: bool | None) -> str:
    return "" if ok is None else (" (ok)" if ok else " (MISSED)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="wheelgym physics benchmark")
    parser.add_argument("--quick", action="store_true",
                        help="fewer repeats, batch capped at N = 4096")
    args = parser.parse_args(argv)
    quick = args.quick

    import numba

    load = os.getloadavg()
    pend = bench_pendulum(quick)
    rows = [bench_model(cls, quick) for cls in model_classes()]
    np_ref = {}
    for r in rows:
        key = (r["nx"], r["nu"])
        if key not in np_ref:
            np_ref[key] = bench_numpy_rk4(*key, quick)

    out = sys.stdout.write
    out(f"# wheelgym physics benchmark{' (quick)' if quick else ''}\n\n")
    out(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, numba "
        f"{numba.__version__} with {numba.get_num_threads()} threads, Python "
        f"{platform.python_version()}. Medians of repeats after warm-up. Load average at the "
        f"start: {load[0]:.2f} (other processes share the CPUs; compare ratios, not absolute "
        f"times).\n\n")
    out(f"Same-run references: Gymnasium `Pendulum-v1` step via `gym.make`: {pend:.2f} us "
        f"({pend / PENDULUM_QUIET_US:.2f}x the {PENDULUM_QUIET_US:g} us of "
        f"design/performance.md on a quiet machine of this class).\n\n")

    skid = next((r for r in rows if r["name"] == "SkidSteer"), None)
    out("| model | state/input | sim_dt (s) x substeps | RK4 substep, 1 state (us) | "
        "NumPy RK4 substep, same size (us) | speed-up | control step (us) | "
        "control step / Pendulum step |\n")
    out("| --- | --- | --- | --- | --- | --- | --- | --- |\n")
    for r in rows:
        ref = np_ref[(r["nx"], r["nu"])]
        target = TARGETS.get((r["name"], "substep_us"))
        ok_sub = None if target is None else r["substep_us"] <= target
        ctrl_note = ""
        if r["kinematic"]:
            ctrl_note = verdict(r["ctrl_us"] <= KINEMATIC_CTRL_US)
        sub_note = verdict(ok_sub)
        if r["name"] == "CasterAGV" and skid is not None:
            sub_note = verdict(r["substep_us"] <= CASTER_VS_SKID * skid["substep_us"])
        out(f"| {r['name']} | {r['nx']}/{r['nu']} | {r['sim_dt']:g} x {r['n_sub']} | "
            f"{r['substep_us']:.2f}{sub_note} | {ref:.1f} | {ref / r['substep_us']:.0f}x | "
            f"{r['ctrl_us']:.2f}{ctrl_note} | {r['ctrl_us'] / pend:.2f} |\n")
    out("\nBatched throughput, state-substeps/s (one control step per call on an (N, n) "
        "batch; N >= 512 uses the multi-threaded kernel):\n\n")
    sizes = list(rows[0]["thr"]) if rows else []
    out("| model | " + " | ".join(f"N = {n}" for n in sizes) + " |\n")
    out("| --- |" + " --- |" * len(sizes) + "\n")
    for r in rows:
        cells = []
        for n in sizes:
            note = ""
            if r["name"] == "ThreeWheel" and n == 16384:
                note = verdict(r["thr"][n] >= BATCH_TARGET)
            cells.append(f"{r['thr'][n]:.3g}{note}")
        out(f"| {r['name']} | " + " | ".join(cells) + " |\n")
    out("\nTargets: ThreeWheel substep <= 3 us, SkidSteer <= 1.5 us, ThreeWheel >= 3e6 "
        "state-substeps/s at N = 16384, kinematic control step <= 2 us, CasterAGV substep "
        "within 1.5x of SkidSteer.\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
