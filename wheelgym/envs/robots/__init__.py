"""Robot descriptions for the environments; a robot appears once its model exists."""

from __future__ import annotations

import importlib

from wheelgym.envs.robots._spec import RANDOMIZE_GROUPS, RobotSpec

__all__ = ["RobotSpec", "RANDOMIZE_GROUPS", "ROBOT_MODULES", "get_spec", "available_robots"]

#: Robot name -> module defining ``SPEC`` (ids are ``wheelgym/<name>-v0``).
ROBOT_MODULES = {
    "ThreeWheel": "wheelgym.envs.robots.three_wheel",
    "SkidSteer": "wheelgym.envs.robots.skid_steer",
    "CasterAGV": "wheelgym.envs.robots.caster_agv",
    "DiffDrive": "wheelgym.envs.robots.kinematic_diffdrive",
    "Unicycle": "wheelgym.envs.robots.kinematic_unicycle",
    "Bicycle": "wheelgym.envs.robots.kinematic_bicycle",
    "Ackermann": "wheelgym.envs.robots.kinematic_ackermann",
}

_cache: dict[str, RobotSpec] = {}


def get_spec(name: str) -> RobotSpec:
    """The :class:`RobotSpec` of ``name``; ``ValueError`` listing the available robots."""
    if name in _cache:
        return _cache[name]
    if name not in ROBOT_MODULES:
        raise ValueError(f"unknown robot {name!r}; valid robots: {available_robots()}")
    try:
        mod = importlib.import_module(ROBOT_MODULES[name])
    except ImportError as exc:  # its model has not landed
        raise ValueError(
            f"robot {name!r} is not available ({exc}); valid robots: {available_robots()}"
        ) from exc
    _cache[name] = mod.SPEC
    return mod.SPEC


def available_robots() -> list[str]:
    """Robots whose models import."""
    out = []
    for name, modname in ROBOT_MODULES.items():
        if name in _cache:
            out.append(name)
            continue
        try:
            importlib.import_module(modname)
        except ImportError:
            continue
        out.append(name)
    return out
