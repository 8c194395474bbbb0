"""Pure, batched physics models (docs/physics/index.md). No gymnasium, no pygame, no globals.

The model modules are imported on first use (PEP 562), so ``gym.make`` of one robot loads
only that robot's compiled kernels from numba's cache, not every model's.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from wheelgym.models._base import PARALLEL_MIN_BATCH, Model, Params

#: public name -> defining module
_LAZY = {
    "SkidSteer": "skid_steer", "SkidSteerParams": "skid_steer",
    "ThreeWheel": "three_wheel", "ThreeWheelParams": "three_wheel",
    "CasterAGV": "caster_agv", "CasterAGVParams": "caster_agv",
    "Unicycle": "kinematic", "UnicycleParams": "kinematic",
    "Bicycle": "kinematic", "BicycleParams": "kinematic",
    "DifferentialDrive": "kinematic", "DifferentialDriveParams": "kinematic",
    "Ackermann": "kinematic", "AckermannParams": "kinematic",
}

__all__ = ["Model", "Params", "PARALLEL_MIN_BATCH", "SkidSteer", "SkidSteerParams", "ThreeWheel",
           "ThreeWheelParams",
           "Unicycle", "UnicycleParams", "Bicycle", "BicycleParams", "DifferentialDrive",
           "DifferentialDriveParams", "Ackermann", "AckermannParams", "CasterAGV",
           "CasterAGVParams"]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'wheelgym.models' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"wheelgym.models.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # pragma: no cover - static analysers see the eager imports
    from wheelgym.models.caster_agv import CasterAGV, CasterAGVParams
    from wheelgym.models.kinematic import (
        Ackermann,
        AckermannParams,
        Bicycle,
        BicycleParams,
        DifferentialDrive,
        DifferentialDriveParams,
        Unicycle,
        UnicycleParams,
    )
    from wheelgym.models.skid_steer import SkidSteer, SkidSteerParams
    from wheelgym.models.three_wheel import ThreeWheel, ThreeWheelParams
