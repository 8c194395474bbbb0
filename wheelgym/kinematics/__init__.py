"""Kinematic analysis: reference trajectories, differential-drive planning, singularities."""

from wheelgym.kinematics.car_tracking import (
    CarCommand,
    CarLimits,
    CarTracker,
    min_turning_radius,
    rear_wheel_steering,
)
from wheelgym.kinematics.diffdrive import (
    Motion,
    body_velocity,
    plan_rtr,
    rtr,
    wheel_speeds,
    wrap_angle,
)
from wheelgym.kinematics.reeds_shepp import (
    PathSamples,
    ReedsSheppPath,
    Segment,
    reeds_shepp_candidates,
    reeds_shepp_path,
    sample,
)
from wheelgym.kinematics.references import (
    Circle,
    FigureEight,
    Line,
    PointToPoint,
    QuinticCircle,
    Reference,
    evaluate_batch,
    quintic_scaling,
)
from wheelgym.kinematics.singularity import (
    SingularConfigurationError,
    SingularityAnalysis,
    SingularScan,
)

__all__ = [
    "CarCommand",
    "CarLimits",
    "CarTracker",
    "Circle",
    "FigureEight",
    "Line",
    "Motion",
    "PathSamples",
    "PointToPoint",
    "QuinticCircle",
    "Reference",
    "ReedsSheppPath",
    "Segment",
    "SingularConfigurationError",
    "SingularScan",
    "SingularityAnalysis",
    "body_velocity",
    "evaluate_batch",
    "min_turning_radius",
    "plan_rtr",
    "quintic_scaling",
    "rear_wheel_steering",
    "reeds_shepp_path",
    "reeds_shepp_candidates",
    "rtr",
    "sample",
    "wheel_speeds",
    "wrap_angle",
]
