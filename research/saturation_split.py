"""Where a velocity-mode policy's saturation comes from: its commands or the controller's torques.

Usage: ``python research/saturation_split.py TARGET [--episodes 50] [--seed 100000]``, TARGET a
shipped agent's name or a run folder (as ``wheelgym robustness``). In the velocity action mode
``info["saturated"]`` marks a step with a twist command at its bound, a torque the twist
controller clipped, or (with actuator lag) a filtered input at its limit. Over the episodes
of a native vector env reset with ``seed`` (the config's env kwargs, its perturbation level
included; the controllers with the nominal model), for the agent, the analytic baseline and,
on navigate, the planning baseline, prints the share of the running steps with each cause
and the share with each command entry at its bound, and the mean episode length.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import wheelgym  # noqa: E402
from wheelgym.agents.evaluate import make_eval_venv  # noqa: E402
from wheelgym.agents.robustness import load_target  # noqa: E402
from wheelgym.envs.perturbation import level  # noqa: E402


def split(venv, policy, seed: int, steps: int = 500) -> dict[str, object]:
    """Counts over each row's first episode."""
    core = venv.unwrapped.core if hasattr(venv.unwrapped, "core") else venv.unwrapped
    obs, _ = venv.reset(seed=seed)
    n = venv.num_envs
    alive = np.ones(n, dtype=bool)
    tally = {"steps": 0, "saturated": 0, "command": 0, "torque": 0, "lag": 0}
    at_bound = np.zeros(venv.single_action_space.shape[0])
    for _ in range(steps):
        a, _ = policy.predict(obs, deterministic=True)
        obs, _, term, trunc, info = venv.step(a)
        tally["steps"] += int(alive.sum())
        tally["saturated"] += int((np.asarray(info["saturated"], dtype=bool) & alive).sum())
        tally["command"] += int((core._clipped & alive).sum())
        tally["torque"] += int((core._csat & alive).sum())
        tally["lag"] += int((core._lag_sat & alive).sum())
        at_bound += (np.abs(np.clip(a, -1, 1)) >= 1.0)[alive].sum(axis=0)
        alive &= ~(term | trunc)
        if not alive.any():
            break
    s = max(tally["steps"], 1)
    return {**{k: v / s for k, v in tally.items() if k != "steps"},
            "entries": at_bound / s, "length": tally["steps"] / n}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("target")
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--seed", type=int, default=100000)
    a = ap.parse_args()
    _, agent, cfg = load_target(a.target)
    lvl = cfg.env_kwargs.get("perturbation")
    pert = level(lvl) if isinstance(lvl, str) else lvl
    policies = {"agent": lambda v: agent, "baseline": lambda v: wheelgym.baseline(v)}
    if cfg.env_kwargs.get("task") == "navigate":
        policies["planner"] = lambda v: wheelgym.baseline(v, planner="auto")
    print("| policy | saturated | command at bound | torque clipped | lag input at limit | "
          "entries at bound | steps an episode |\n|---|---|---|---|---|---|---|")
    for name, make in policies.items():
        venv = make_eval_venv(cfg, a.episodes, pert)
        r = split(venv, make(venv), a.seed)
        ent = " / ".join(f"{100 * x:.1f}" for x in r["entries"])
        print(f"| {name} | {100 * r['saturated']:.1f}% | {100 * r['command']:.1f}% | "
              f"{100 * r['torque']:.1f}% | {100 * r['lag']:.1f}% | {ent}% | "
              f"{r['length']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
