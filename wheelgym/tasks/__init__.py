"""Tasks: reference trajectories, and the environments' goal, track and navigate tasks."""

from wheelgym.tasks.references import (
    Circle,
    FigureEight,
    Line,
    PointToPoint,
    QuinticCircle,
    Reference,
    evaluate_batch,
    quintic_scaling,
)

__all__ = [
    "Reference",
    "QuinticCircle",
    "Circle",
    "FigureEight",
    "Line",
    "PointToPoint",
    "quintic_scaling",
    "evaluate_batch",
]
