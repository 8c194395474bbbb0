"""Robot descriptions for the environments (one :class:`RobotSpec` per robot)."""

from __future__ import annotations

import importlib

from wheelgym.envs.robots._spec import RANDOMIZE_GROUPS, RobotSpec

__all__ = ["RobotSpec", "RANDOMIZE_GROUPS", "ROBOT_MODULES", "get_spec", "available_robots"]

#: Robot name -> module defining ``SPEC`` (or ``module:NAME``); ids are ``wheelgym/<name>-v0``.
ROBOT_MODULES = {
    "ThreeWheel": "wheelgym.envs.robots.three_wheel",
    "SkidSteer": "wheelgym.envs.robots.skid_steer",
    "CasterAGV": "wheelgym.envs.robots.caster_agv",
    "DiffDrive": "wheelgym.envs.robots.kinematic:DIFFDRIVE",
    "Unicycle": "wheelgym.envs.robots.kinematic:UNICYCLE",
    "Bicycle": "wheelgym.envs.robots.kinematic:BICYCLE",
    "Ackermann": "wheelgym.envs.robots.kinematic:ACKERMANN",
}

_cache: dict[str, RobotSpec] = {}


def get_spec(name: str) -> RobotSpec:
    """The :class:`RobotSpec` of ``name``; ``ValueError`` listing the robots."""
    if name in _cache:
        return _cache[name]
    if name not in ROBOT_MODULES:
        raise ValueError(f"unknown robot {name!r}; valid robots: {available_robots()}")
    spec = _load(ROBOT_MODULES[name])
    _cache[name] = spec
    return spec


def _load(target: str) -> RobotSpec:
    modname, _, attr = target.partition(":")
    return getattr(importlib.import_module(modname), attr or "SPEC")


def available_robots() -> list[str]:
    """Every robot (:func:`wheelgym.registration.available_robots`)."""
    from wheelgym.registration import available_robots as _available

    return _available()
