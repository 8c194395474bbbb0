"""Pure, batched physics models (physics.md). No gymnasium, no pygame, no globals."""

from wheelgym.models._base import Model, Params
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

__all__ = ["Model", "Params", "SkidSteer", "SkidSteerParams", "ThreeWheel", "ThreeWheelParams",
           "Unicycle", "UnicycleParams", "Bicycle", "BicycleParams", "DifferentialDrive",
           "DifferentialDriveParams", "Ackermann", "AckermannParams", "CasterAGV",
           "CasterAGVParams"]
