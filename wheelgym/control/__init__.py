"""Load distribution (pure functions) and analytic baseline controllers (physics.md TW-6, SS-4)."""

from wheelgym.control.baseline import BaselinePolicy, baseline
from wheelgym.control.controllers import (
    TrackingController,
    TrackingGains,
    TwistController,
    TwistGains,
    UnicycleTrackingGains,
    inverse_dynamics,
    make_controller,
    tracked_point,
)
from wheelgym.control.distribution import (
    DISTRIBUTIONS,
    PAPER_INPUT_JOINTS,
    distribute,
    independent_joint_force,
    internal_force,
    min_norm,
    null_space_basis,
    null_space_projector,
    paper_distribution,
    skid_steer_split,
    weighted,
    within_limits,
)

__all__ = [
    "baseline",
    "BaselinePolicy",
    "TrackingController",
    "TrackingGains",
    "TwistController",
    "TwistGains",
    "UnicycleTrackingGains",
    "inverse_dynamics",
    "make_controller",
    "tracked_point",
    "DISTRIBUTIONS",
    "PAPER_INPUT_JOINTS",
    "distribute",
    "independent_joint_force",
    "internal_force",
    "min_norm",
    "null_space_basis",
    "null_space_projector",
    "paper_distribution",
    "skid_steer_split",
    "weighted",
    "within_limits",
]
