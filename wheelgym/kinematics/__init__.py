"""Kinematic analysis: differential-drive inverse kinematics and singularity analysis."""

from wheelgym.kinematics.diffdrive import Motion, body_velocity, rtr, wheel_speeds, wrap_angle
from wheelgym.kinematics.singularity import (
    SingularConfigurationError,
    SingularityAnalysis,
    SingularScan,
)

__all__ = [
    "Motion",
    "SingularConfigurationError",
    "SingularScan",
    "SingularityAnalysis",
    "body_velocity",
    "rtr",
    "wheel_speeds",
    "wrap_angle",
]
