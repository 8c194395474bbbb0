"""Shared helpers of the vector-environment tests."""

from __future__ import annotations

from typing import Any

import numpy as np

import wheelgym  # noqa: F401
from wheelgym.envs.robots import available_robots, get_spec
from wheelgym.registration import env_id

ROBOTS = available_robots()
TASKS = ("goal", "track", "navigate")


def modes(robot: str) -> tuple[str, ...]:
    return get_spec(robot).action_modes


def combos() -> list[tuple[str, str, str]]:
    return [(r, t, m) for r in ROBOTS for t in TASKS for m in modes(r)]


def assert_same(a: Any, b: Any, path: str = "") -> None:
    """Recursive equality, bit for bit for arrays (same dtype, shape and bytes)."""
    assert type(a) is type(b), f"{path}: type {type(a)} != {type(b)}"
    if isinstance(a, (tuple, list)):
        assert len(a) == len(b), f"{path}: length {len(a)} != {len(b)}"
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{path}[{k}]")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), f"{path}: keys {sorted(a)} != {sorted(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype, f"{path}: dtype {a.dtype} != {b.dtype}"
        assert a.shape == b.shape, f"{path}: shape {a.shape} != {b.shape}"
        if a.dtype == object:
            for k, (x, y) in enumerate(zip(a, b, strict=True)):
                assert_same(x, y, f"{path}[{k}]")
        else:
            assert a.tobytes() == b.tobytes(), f"{path}: {a} != {b}"
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


__all__ = ["ROBOTS", "TASKS", "modes", "combos", "assert_same", "env_id"]
