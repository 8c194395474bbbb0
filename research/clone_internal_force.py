"""How much ``clone_internal_force`` takes the internal force out of a clone of the baseline.

Usage: ``python research/clone_internal_force.py [CONFIG] [--steps 65536] [--held 8192]
[--epochs 5] [--weights 0 10 30 100 300 1000]``.

The analytic baseline labels ``--steps`` steps of the config's training envs (default
``configs/ThreeWheel-navigate-torque.yml``, its network and ``VecNormalize``), then ``--held``
more (new episodes, held out). For each weight ``w`` a fresh policy (torch seed 0) is fitted
to the first rows, ``--epochs`` passes, by :func:`wheelgym.agents.clone.fit_mean` with the
loss ``(|e|^2 + w |W e|^2) / m`` (``W``: :func:`wheelgym.agents.clone.internal_force_rows`,
the null space of the six motors, TW-6). Prints a Markdown table of the held-out rows: the
mean squared action error (normalised torques) and the mean internal force of the error as a
share of ``|tau_max|`` (the reward term's measure; :func:`wheelgym.agents.clone.force_error`),
and that share over the first weight's (the unweighted fit by default). The baseline's own
actions have (to round-off) no internal force at the states it labels, so the third column is
the clone's internal force.
One torch and one numba thread; deterministic for a given machine.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", nargs="?", default="configs/ThreeWheel-navigate-torque.yml")
    ap.add_argument("--steps", type=int, default=65_536, help="labelled rows to fit")
    ap.add_argument("--held", type=int, default=8192, help="held-out rows to score")
    ap.add_argument("--epochs", type=int, default=5, help="passes of each fit")
    ap.add_argument("--weights", type=float, nargs="+", default=[0, 10, 30, 100, 300, 1000])
    args = ap.parse_args(argv)
    for name in ("steps", "held", "epochs"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} must be >= 1, got {getattr(args, name)}")
    if any(not np.isfinite(w) or w < 0 for w in args.weights):
        ap.error(f"--weights must be finite and >= 0, got {args.weights}")

    import torch as th

    from wheelgym.agents.clone import demonstrate, fit_mean, force_error, mean_error
    from wheelgym.agents.common import build_model, make_train_env, wrap_normalize
    from wheelgym.agents.config import load_config

    th.set_num_threads(1)
    cfg = load_config(args.config)
    venv = wrap_normalize(make_train_env(cfg), cfg)
    t0 = time.perf_counter()
    demo = demonstrate(venv, args.steps, internal_force=True)
    held = demonstrate(venv, args.held, internal_force=True)
    base = np.linalg.norm(np.einsum("nkm,nm->nk", held.force_rows, held.actions), axis=1)
    print(f"{args.config}: {len(demo.obs)} rows fitted, {len(held.obs)} held out "
          f"({time.perf_counter() - t0:.0f} s); the baseline's own internal force share on the "
          f"held-out rows: {base.mean():.2e}\n")
    print("| weight w | action MSE | internal force of the error / tau_max "
          "| vs the first weight | fit [s] |")
    print("|---|---|---|---|---|")
    ref = None
    for w in args.weights:
        th.manual_seed(0)
        model = build_model(cfg, venv)
        t0 = time.perf_counter()
        fit_mean(model, demo.obs, demo.actions, epochs=args.epochs, seed=0,
                 force_rows=demo.force_rows, force_weight=float(w))
        dt = time.perf_counter() - t0
        mse = mean_error(model, held.obs, held.actions)
        fe = force_error(model, held.obs, held.actions, held.force_rows)
        ref = fe if ref is None else ref
        print(f"| {w:g} | {mse:.4f} | {fe:.4f} | {fe / ref:.2f}x | {dt:.0f} |", flush=True)
    venv.close()


if __name__ == "__main__":
    main()
