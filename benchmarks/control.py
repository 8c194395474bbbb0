"""Speed of the load distribution and of one controller step, with same-run references.

Usage: ``python benchmarks/control.py [--quick]``. Prints Markdown tables:

1. load distribution on one ThreeWheel configuration (``J`` 6x3): minimum-norm, weighted,
   limit-respecting (when the weighted solution fits, and when it does not and the exact
   null-space search runs), the paper's ``[I : G^T]`` form; and on a batch of 1024;
2. one controller step (``torques``) on one state, for each controller and model, and on a
   batch of 1024 states;
3. same-run references: Gymnasium ``Pendulum-v1`` ``env.step`` through ``gym.make``, one
   ``ThreeWheel.step`` control step (25 RK4 substeps) and ``np.linalg.pinv`` of a 3x6 matrix.

Target: a ThreeWheel controller step <= 20 us on one state. The environments call the
controller once per control step (``ctrl_dt = 0.05 s``) and hold the torques over the
substeps, so the controller costs one call per env step, next to 25 RK4 substeps.
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

from wheelgym.control import (
    TrackingController,
    TwistController,
    min_norm,
    paper_distribution,
    weighted,
    within_limits,
)
from wheelgym.models import CasterAGV, SkidSteer, ThreeWheel

TARGET_TW_STEP_US = 20.0


def per_call_us(fn: Callable[[], object], n_calls: int, repeats: int) -> float:
    """Median over ``repeats`` of the time per call (us) after a warm-up."""
    for _ in range(min(n_calls, 200)):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n_calls):
            fn()
        times.append((time.perf_counter() - t0) / n_calls)
    return statistics.median(times) * 1e6


def bench_pendulum(calls: int, repeats: int) -> float:
    import gymnasium as gym

    env = gym.make("Pendulum-v1")
    env.reset(seed=0)
    actions = [env.action_space.sample() for _ in range(1000)]
    i = [0]

    def one() -> None:
        _, _, term, trunc, _ = env.step(actions[i[0] % 1000])
        i[0] += 1
        if term or trunc:
            env.reset()

    t = per_call_us(one, calls, repeats)
    env.close()
    return t


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="wheelgym control benchmark")
    parser.add_argument("--quick", action="store_true", help="fewer calls and repeats")
    args = parser.parse_args(argv)
    calls = 2000 if args.quick else 10000
    reps = 3 if args.quick else 5
    rng = np.random.default_rng(0)
    load = os.getloadavg()

    tw = ThreeWheel()
    ss = SkidSteer()
    tmax = tw.params.tau_max
    psi = np.array([0.3, -0.2, 0.1])
    J = tw.jacobian(psi)
    Q_fit = np.array([20.0, 5.0, 2.0])  # weighted solution within the limits
    Q_out = np.array([0.0, 200.0, 0.0])  # weighted solution over a limit; an internal force fits
    _, st_fit = within_limits(J, Q_fit, tmax)
    _, st_out = within_limits(J, Q_out, tmax)
    assert int(st_fit) == 0 and int(st_out) == 1, (st_fit, st_out)
    JB = tw.jacobian(rng.uniform(-np.pi, np.pi, (1024, 3)))
    QB = rng.normal(size=(1024, 3)) * [40.0, 40.0, 10.0]
    JT = np.ascontiguousarray(J.T)

    dist = [
        ("min_norm", lambda: min_norm(J, Q_fit), lambda: min_norm(JB, QB)),
        ("weighted", lambda: weighted(J, Q_fit, tmax), lambda: weighted(JB, QB, tmax)),
        ("within_limits, weighted fits", lambda: within_limits(J, Q_fit, tmax),
         lambda: within_limits(JB, QB * 0.3, tmax)),
        ("within_limits, null-space search", lambda: within_limits(J, Q_out, tmax),
         lambda: within_limits(JB, QB * 2.0, tmax)),
        ("paper [I : G^T] (35)-(36)", lambda: paper_distribution(J, Q_fit),
         lambda: paper_distribution(JB, QB)),
        ("reference: np.linalg.pinv(J^T)", lambda: np.linalg.pinv(JT), None),
    ]
    dist_rows = []
    for name, one, batch in dist:
        t1 = per_call_us(one, calls, reps)
        tb = per_call_us(batch, max(10, calls // 100), reps) / 1024 if batch else float("nan")
        dist_rows.append((name, t1, tb))

    x_tw = np.zeros(12)
    x_tw[3:9] = [0.3, 0.05, 0.2, 0.1, -0.1, 0.05]
    x_ss = np.array([0.0, 0.0, 0.0, 0.4, 0.2])
    pose = np.array([0.02, 0.01, 0.01])
    twist = np.array([0.4, 0.0, 0.2])
    rate = np.array([0.05, 0.0, 0.01])
    XB_tw = np.broadcast_to(x_tw, (1024, 12)).copy()
    XB_ss = np.broadcast_to(x_ss, (1024, 5)).copy()
    ca = CasterAGV()
    x_ca = np.array([0.0, 0.0, 0.0, 0.4, 0.2, 0.1, 0.0, 0.0, 0.0])
    XB_ca = np.broadcast_to(x_ca, (1024, 9)).copy()
    ctrl = []
    for label, model, x, XB, cmd in (("ThreeWheel", tw, x_tw, XB_tw, np.array([0.4, 0.1, 0.2])),
                                     ("SkidSteer", ss, x_ss, XB_ss, np.array([0.4, 0.2])),
                                     ("CasterAGV", ca, x_ca, XB_ca, np.array([0.4, 0.2]))):
        modes = {"ThreeWheel": ("min_norm", "within_limits"), "SkidSteer": ("min_norm", "loads"),
                 "CasterAGV": ("min_norm",)}[label]
        for mode in modes:
            c = TwistController(model, distribution=mode)
            ctrl.append((f"{label} TwistController ({mode})",
                         lambda c=c, x=x, cmd=cmd: c.torques(x, cmd),
                         lambda c=c, XB=XB, cmd=cmd: c.torques(XB, cmd)))
            c = TrackingController(model, distribution=mode)
            ctrl.append((f"{label} TrackingController ({mode})",
                         lambda c=c, x=x: c.torques(x, pose, twist, rate),
                         lambda c=c, XB=XB: c.torques(XB, pose, twist, rate)))
    ctrl_rows = []
    for name, one, batch in ctrl:
        t1 = per_call_us(one, calls, reps)
        tb = per_call_us(batch, max(10, calls // 100), reps) / 1024
        ctrl_rows.append((name, t1, tb))

    pend = bench_pendulum(calls, reps)
    u = np.full(6, 0.5)
    step_us = per_call_us(lambda: tw.step(x_tw, u, 0.05, 25), calls // 4, reps)

    import numba

    out = sys.stdout.write
    out(f"# wheelgym control benchmark{' (quick)' if args.quick else ''}\n\n")
    out(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, numba "
        f"{numba.__version__}, Python {platform.python_version()}. Medians of {reps} repeats "
        f"after warm-up. Load average at the start: {load[0]:.2f} (other processes share the "
        "CPUs: compare ratios, not absolute times).\n\n")
    out(f"Same-run references: Gymnasium `Pendulum-v1` step {pend:.2f} us; ThreeWheel control "
        f"step (25 RK4 substeps, one state) {step_us:.2f} us.\n\n")
    out("| load distribution, ThreeWheel J (6x3) | one (us) | per state in a batch of 1024 "
        "(us) | one / Pendulum step |\n| --- | --- | --- | --- |\n")
    for name, t1, tb in dist_rows:
        tb_s = "-" if np.isnan(tb) else f"{tb:.3f}"
        out(f"| {name} | {t1:.2f} | {tb_s} | {t1 / pend:.2f} |\n")
    out("\n| controller step (`torques`) | one state (us) | per state in a batch of 1024 (us) "
        "| one / Pendulum step | one / ThreeWheel control step |\n"
        "| --- | --- | --- | --- | --- |\n")
    for name, t1, tb in ctrl_rows:
        note = ""
        if name.startswith("ThreeWheel") and "min_norm" in name:
            note = " (ok)" if t1 <= TARGET_TW_STEP_US else " (MISSED)"
        out(f"| {name} | {t1:.2f}{note} | {tb:.3f} | {t1 / pend:.2f} | {t1 / step_us:.2f} |\n")
    out(f"\nTarget: ThreeWheel controller step <= {TARGET_TW_STEP_US:g} us on one state "
        "(min_norm). The limit-respecting mode costs more only where the weighted solution "
        "exceeds a limit (the exact search over the null space's faces).\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
