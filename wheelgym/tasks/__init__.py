"""Tasks: reference trajectories (and, later, reward terms and success tests)."""

from wheelgym.tasks.references import (
    Circle,
    FigureEight,
    Line,
    PointToPoint,
    QuinticCircle,
    Reference,
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
]
