"""Where a trained PPO/A2C agent puts its Gaussian mean, and how its failed episodes end.

Usage: ``python research/policy_probe.py RUN_DIR [--episodes 50] [--seed0 1000]``, RUN_DIR a
run folder of ``wheelgym train`` or ``wheelgym benchmark`` (its ``config.yml``, ``model.zip``
and ``vecnormalize.pkl``). Prints, over the episodes reset with seeds ``seed0 ..
seed0 + episodes - 1`` and the deterministic policy:

* the policy's std (``exp(log_std)``) per action entry;
* percentiles of the Gaussian mean per entry, before the clip to [-1, 1], and the share of
  steps with the mean at or beyond a bound (the bang-bang of the README's results section);
* the success rate and, per failed episode, its length, how it ended (``collision`` on
  navigate, ``timeout``, or ``ended``), the nearest range reading at the start (navigate) and
  the mean of the first action entry (the speed command of the kinematic robots).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import torch as th  # noqa: E402

from wheelgym.agents.common import make_single_env  # noqa: E402
from wheelgym.agents.config import load_run_config  # noqa: E402
from wheelgym.agents.policies import load_agent  # noqa: E402
from wheelgym.tasks.tasks import NavigateTask  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--seed0", type=int, default=1000)
    a = ap.parse_args()
    config = load_run_config(a.run_dir / "config.yml")
    agent = load_agent(a.run_dir / "model.zip", config.algo, a.run_dir / "vecnormalize.pkl")
    policy = agent.model.policy
    env = make_single_env(config)
    navigate = config.task == "navigate"
    n_rays = NavigateTask.n_rays if navigate else 0  # the range readings end the observation
    means, fails, wins = [], [], 0
    for k in range(a.episodes):
        obs, _ = env.reset(seed=a.seed0 + k)
        near0 = float(obs[-n_rays:].min()) if n_rays else float("nan")
        done, steps, first = False, 0, []
        while not done:
            o = agent.obs_norm.normalize_obs(obs) if agent.obs_norm is not None else obs
            with th.no_grad():
                dist = policy.get_distribution(policy.obs_to_tensor(o)[0])
            mean = dist.distribution.mean.numpy()[0]
            means.append(mean)
            first.append(float(np.clip(mean[0], -1.0, 1.0)))
            obs, _, term, trunc, info = env.step(np.clip(mean, -1.0, 1.0).astype(np.float32))
            steps += 1
            done = term or trunc
        if info.get("is_success"):
            wins += 1
            continue
        hit = bool(navigate and term and not info.get("numerical_failure"))
        fails.append((k, steps, "collision" if hit else "timeout" if trunc else "ended", near0,
                      float(np.mean(first))))
    m = np.array(means)
    std = np.exp(policy.log_std.detach().numpy())
    print(f"{a.run_dir.name}: {len(m)} steps of {a.episodes} episodes")
    print("| entry | std | mean p0 | p10 | p50 | p90 | p100 | steps at a bound |")
    print("|---|---|---|---|---|---|---|---|")
    for j in range(m.shape[1]):
        p = np.percentile(m[:, j], [0, 10, 50, 90, 100])
        print(f"| {j} | {std[j]:.3f} | " + " | ".join(f"{v:.2f}" for v in p)
              + f" | {np.mean(np.abs(m[:, j]) >= 1.0):.0%} |")
    print(f"any entry at a bound: {np.mean(np.any(np.abs(m) >= 1.0, axis=1)):.1%} of the steps")
    print(f"success: {wins}/{a.episodes}")
    if fails:
        print("| episode seed | steps | end | nearest range at start [m] | mean action[0] |")
        print("|---|---|---|---|---|")
        for k, steps, end, near0, v in fails:
            print(f"| {a.seed0 + k} | {steps} | {end} | {near0:.2f} | {v:+.2f} |")


if __name__ == "__main__":
    main()
