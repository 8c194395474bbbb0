"""Load distribution (pure functions) and analytic baseline controllers (docs/physics/three-wheel.md
TW-6, docs/physics/skid-steer.md SS-4).

The analytic baseline *policy* that drives an environment is ``wheelgym.baseline(env)``
(:mod:`wheelgym.envs.baseline`).
"""

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
