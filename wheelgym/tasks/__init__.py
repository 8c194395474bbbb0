"""Tasks: the environments' goal, track and navigate tasks, and the view of the batch they use.

The reference trajectories live in :mod:`wheelgym.kinematics.references`; they are exported
here too, as the track task's ``reference`` reset option takes them.
"""

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
from wheelgym.tasks.view import BatchView, RobotConstants

__all__ = [
    "BatchView",
    "RobotConstants",
    "Reference",
    "QuinticCircle",
    "Circle",
    "FigureEight",
    "Line",
    "PointToPoint",
    "quintic_scaling",
    "evaluate_batch",
]
