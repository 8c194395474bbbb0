"""What an environment needs to know about a robot, beyond its model (one object per robot)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from wheelgym.models import Model, Params

__all__ = ["RobotSpec", "RANDOMIZE_GROUPS"]

#: Randomisation groups accepted by ``randomize=``; each robot supports a subset.
RANDOMIZE_GROUPS = (
    "mass", "inertia", "friction", "x_icr", "wheel_radius", "caster_trail", "torque_limit",
)


@dataclasses.dataclass(frozen=True)
class RobotSpec:
    """Static description of one robot for the environments.

    Attributes:
        name: robot name used in ids (``"SkidSteer"``...).
        model_cls: the :class:`~wheelgym.models.Model` subclass.
        k_env_step: compiled ``k_env_step(X, A, LH, P, h, n, Xo, B, F) -> bool`` (see
            ``_body.env_step_body``; ThreeWheel and SkidSteer step ``LANES`` rows or more in
            vectorised blocks, ``_body.env_step_blocks``, with the same bits per row).
        k_env_step_par: the same kernel with the rows (or blocks) spread over numba's
            threads (``parallel=True``; same bits per row), used from ``_body.PAR_MIN_ROWS``
            rows.
        input_bounds: ``input_bounds(params, mode) -> (lo, hi)`` physical bounds of the
            action in that action mode (torques N·m, or the kinematic inputs).
        action_modes: valid ``action_mode`` values, the default first.
        twist_dim: 3 (vx, vy, wz) or 2 (vx, wz) for the velocity mode's command.
        twist_max: bounds of the velocity-mode command in its units (m/s, rad/s).
        v_max, w_max: sanity limits (m/s, rad/s): beyond them an episode ends (``overspeed``).
        feat_names, feat_high: names and bounds of the robot's extra observation features.
        radius: collision radius of the footprint (m).
        randomize: group -> tuple of (field, "rel" | "abs") entries.
        default_randomize: ranges used by ``randomize=True``.
        initial_state: ``initial_state(pose (N, 3), params) -> X (N, n_x)``.
        n_motor: motors (0 for kinematic robots: no torque, no energy).
        has_internal_force: whether ``xf`` (the internal-force measure) is meaningful.
        geometry: ``geometry(params) -> dict`` for rendering (footprint, wheel size).
        wheels: ``wheels(x, params) -> (k, 3)`` wheel centres (m, in B) and angles (rad, in B).
        motor_names: names of the motors in input order (``n_motor`` of them; empty for
            kinematic robots), for plots and tables.
    """

    name: str
    model_cls: type[Model]
    k_env_step: Any
    k_env_step_par: Any
    input_bounds: Callable[[Params, str], tuple[np.ndarray, np.ndarray]]
    action_modes: tuple[str, ...]
    twist_dim: int
    twist_max: tuple[float, ...]
    v_max: float
    w_max: float
    feat_names: tuple[str, ...]
    feat_high: tuple[float, ...]
    radius: float
    randomize: Mapping[str, tuple[tuple[str, str], ...]]
    default_randomize: Mapping[str, tuple[float, float]]
    initial_state: Callable[[np.ndarray, Params], np.ndarray]
    n_motor: int
    has_internal_force: bool
    geometry: Callable[[Params], dict]
    wheels: Callable[[np.ndarray, Params], np.ndarray]
    motor_names: tuple[str, ...] = ()


def guard_cache(module_file: str, *deps: str) -> None:
    """Drop a robot module's numba cache when a file its kernels inline has changed.

    The robot kernels inline the model's derivative and ``_body.env_step_body`` from other
    files (and link the models' compiled block kernels, which inline ``integrators.py``);
    see :mod:`wheelgym._numba_cache`. ``_body.py`` and ``integrators.py`` are always
    dependencies.
    """
    import os

    from wheelgym import _numba_cache
    from wheelgym import integrators as _integrators

    body = os.path.join(os.path.dirname(os.path.abspath(module_file)), "_body.py")
    _numba_cache.guard(module_file, body, _integrators.__file__, *deps)

