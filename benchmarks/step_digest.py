"""Seeded rollout digests: whether a change to the kernels changed any bit of an env's output.

Run: ``python benchmarks/step_digest.py [--steps 300] [--robots ...] [--dc] [--out FILE]``.
For every robot x action mode x task (``--dc``: also ``motor="dc"`` and the voltage mode
where the robot has DC motors) it steps the single env (``gym.make``) and a vector env of 20
rows (the vectorised block kernels of ThreeWheel and SkidSteer: 16 rows and more) with
seeded uniform actions and prints a SHA-256 digest of the observations, rewards,
terminations and ``info`` arrays of every step (one line per combination). Two runs on two
revisions print the same lines exactly when the bits are the same; ``--out`` writes them as
JSON, ``--compare FILE`` prints the combinations whose digest differs from that file's.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys

import gymnasium as gym
import numpy as np

import wheelgym  # noqa: F401  (registers the ids)
from wheelgym.envs.robots import available_robots, get_spec
from wheelgym.registration import env_id

TASKS = ("goal", "track")
N_VEC = 20


def _feed(h, value) -> None:
    if isinstance(value, dict):
        for k in sorted(value):
            h.update(k.encode())
            _feed(h, value[k])
    else:
        a = np.asarray(value)
        if a.dtype.kind == "O":  # object arrays (the vector env's task names): their text,
            h.update(repr(a.tolist()).encode())  # not the addresses of their objects
        else:
            h.update(np.ascontiguousarray(a).tobytes())


def digest_single(robot: str, task: str, kw: dict, steps: int, seed: int = 0) -> str:
    """Digest of ``steps`` steps of the single env (reset on episode end)."""
    env = gym.make(env_id(robot), task=task, **kw)
    rng = np.random.default_rng(seed)
    acts = rng.uniform(-1, 1, (steps,) + env.action_space.shape)
    h = hashlib.sha256()
    obs, _ = env.reset(seed=seed)
    _feed(h, obs)
    for a in acts:
        obs, r, te, tr, info = env.step(a)
        for v in (obs, r, te, tr):
            _feed(h, v)
        _feed(h, {k: v for k, v in info.items() if not k.startswith("_")})
        if te or tr:
            obs, _ = env.reset()
            _feed(h, obs)
    env.close()
    return h.hexdigest()[:16]


def digest_vector(robot: str, task: str, kw: dict, steps: int, seed: int = 0) -> str:
    """Digest of ``steps`` steps of a native vector env of :data:`N_VEC` rows."""
    env = gym.make_vec(env_id(robot), num_envs=N_VEC, vectorization_mode="vector_entry_point",
                       task=task, **kw)
    rng = np.random.default_rng(seed)
    acts = rng.uniform(-1, 1, (steps,) + env.action_space.shape)
    h = hashlib.sha256()
    obs, _ = env.reset(seed=seed)
    _feed(h, obs)
    for a in acts:
        obs, r, te, tr, info = env.step(a)
        for v in (obs, r, te, tr):
            _feed(h, v)
        _feed(h, {k: v for k, v in info.items() if not k.startswith("_")
                  and k != "final_info" and k != "final_obs"})
    env.close()
    return h.hexdigest()[:16]


def combos(robots: list[str], dc: bool) -> list[tuple[str, str, dict]]:
    """``(robot, task, gym.make keywords)`` of every combination."""
    out = []
    for robot in robots:
        spec = get_spec(robot)
        kws = [{"action_mode": m} for m in spec.action_modes]
        if dc and spec.has_dc_motors:
            kws += [{"action_mode": m, "motor": "dc"} for m in spec.action_modes]
            kws += [{"action_mode": m} for m in spec.dc_action_modes]
        for kw in kws:
            for task in TASKS:
                out.append((robot, task, kw))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--robots", nargs="*", default=None)
    ap.add_argument("--dc", action="store_true", help="also motor='dc' and the voltage mode")
    ap.add_argument("--out", default=None, help="write the digests as JSON")
    ap.add_argument("--compare", default=None, help="JSON of an earlier run to compare with")
    args = ap.parse_args(argv)
    robots = args.robots or available_robots()
    result: dict[str, str] = {}
    for robot, task, kw in combos(robots, args.dc):
        key = f"{robot} {task} " + " ".join(f"{k}={v}" for k, v in kw.items())
        for kind, fn in (("single", digest_single), ("vector", digest_vector)):
            d = fn(robot, task, kw, args.steps)
            result[f"{key} {kind}"] = d
            print(f"{key} {kind}: {d}", flush=True)
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(result, fh, indent=1, sort_keys=True)
    if args.compare:
        with open(args.compare) as fh:
            old = json.load(fh)
        diff = [k for k in result if k in old and old[k] != result[k]]
        print(f"{len(diff)} of {len(result)} digests differ" + "".join(f"\n  {k}" for k in diff))
        return 1 if diff else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
