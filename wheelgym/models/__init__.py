"""Pure, batched physics models (physics.md). No gymnasium, no pygame, no globals."""

from wheelgym.models._base import Model, Params
from wheelgym.models.skid_steer import SkidSteer, SkidSteerParams

__all__ = ["Model", "Params", "SkidSteer", "SkidSteerParams"]
