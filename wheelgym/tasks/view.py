"""What a task sees of a batch of robots: :class:`BatchView`, a narrow typed view.

A task (:mod:`wheelgym.tasks.tasks`) reads its batch's blocks and constants and writes the
observation, the reward terms and the flags; it never needs the rest of the environment's core.
:class:`BatchView` lists exactly what it uses. It is a structural type (``typing.Protocol``):
the environments' core (``wheelgym.envs.core.WheelCore``, a layer above) satisfies it with its
own attributes, so the tasks' compiled calls read the core's arrays directly, with no wrapper or
copy on the step path, and the tasks import nothing of ``wheelgym.envs``.

Block layout (``B``: one float row per robot; ``F``: one flag row) is the envs' step kernel's;
the task kernels (:mod:`wheelgym.tasks.kernels`) read it given ``m``, the model's input size.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

__all__ = ["RobotConstants", "BatchView"]


class RobotConstants(Protocol):
    """The robot's constants a task reads (the envs' robot spec has them)."""

    @property
    def name(self) -> str:
        """Robot name (``"ThreeWheel"``...)."""

    @property
    def v_max(self) -> float:
        """Speed limit (m/s): beyond it an episode ends (``overspeed``)."""

    @property
    def w_max(self) -> float:
        """Yaw-rate limit (rad/s)."""

    @property
    def radius(self) -> float:
        """Collision radius of the footprint (m)."""

    @property
    def twist_max(self) -> tuple[float, ...]:
        """Bounds of the velocity-mode command (m/s, rad/s)."""

    @property
    def feat_names(self) -> tuple[str, ...]:
        """Names of the robot's extra observation features."""

    @property
    def feat_high(self) -> tuple[float, ...]:
        """Bounds of those features."""

    @property
    def has_internal_force(self) -> bool:
        """Whether the internal-force measure (and its reward term) is meaningful."""


class BatchView(Protocol):
    """The batch of N robots as a task sees it: sizes, constants and the shared buffers.

    The arrays are the batch's own (bound once; a task keeps no copies): ``B``, ``F``,
    ``pose`` and ``coll`` are written by the step kernel and read by the task (``coll`` is
    also written by the navigate task's sensing); ``obs`` and ``terms`` are written by the
    task.
    """

    #: Batch size N.
    num: int
    #: Model input size (the block layout's first width).
    m: int
    #: Control period (s).
    dt: float
    #: Control steps of the track reference that small batches evaluate at each reset.
    horizon: int
    #: Whether the batch spreads its rows over numba's threads.
    threaded: bool
    #: Observation bounds of the twist (m/s, rad/s) and of the robot's features.
    vclip: float
    wclip: float
    fclip: np.ndarray
    #: Every row index ``(N,)`` int64 (the kernels' row list for "all rows").
    all_rows: np.ndarray
    #: Float block ``(N, width)`` and flag block ``(N, 5)`` bool.
    B: np.ndarray
    F: np.ndarray
    #: Pose ``(N, 3)`` (x, y, yaw: a view into ``B``) and collision flags ``(N,)`` (into ``F``).
    pose: np.ndarray
    coll: np.ndarray
    #: Observation ``(N, obs_dim)`` float32 and reward terms ``(N, n_columns)``, task-written.
    obs: np.ndarray
    terms: np.ndarray
    #: The nominal parameters (the model's Params dataclass; rows may draw others).
    base_params: Any

    @property
    def spec(self) -> RobotConstants:
        """The robot's constants."""
