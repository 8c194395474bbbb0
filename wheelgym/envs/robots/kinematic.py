"""Kinematic robots for the environments (docs/physics/kinematic.md): one kernel for all four.

They have no motors: the action is the model's velocity input (scaled onto its bounds), the
joint rates are reported as empty, and the motor work stays 0.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np
from numba import njit

import wheelgym.models.kernels.kinematic as _kern
from wheelgym.envs.robots._spec import RobotSpec, guard_cache
from wheelgym.envs.robots.body import env_step_body, env_step_body_par, env_step_row
from wheelgym.models import Ackermann, Bicycle, DifferentialDrive, Unicycle
from wheelgym.models.kernels.kinematic import deriv_one, effective

guard_cache(__file__, _kern.__file__)

__all__ = ["UNICYCLE", "BICYCLE", "DIFFDRIVE", "ACKERMANN"]


@njit(cache=True, inline="always")
def _kpower(x, k, u, p):  # pragma: no cover - compiled
    return 0.0  # no motors


@njit(cache=True, inline="always")
def _jrate(x, p, out):  # pragma: no cover - compiled
    for j in range(out.shape[0]):
        out[j] = 0.0


@njit(cache=True, inline="always")
def _feats(x, u, p, pose, twist, feat):  # pragma: no cover - compiled
    v, w, _ = effective(x, u, p)  # the saturated command the derivative integrates
    pose[0] = x[0]
    pose[1] = x[1]
    pose[2] = x[2]
    twist[0] = v
    twist[1] = 0.0
    twist[2] = w
    if x.shape[0] > 3:  # Ackermann's steering angle
        feat[0] = math.cos(x[3])
        feat[1] = math.sin(x[3])
    return 0.0


@njit(cache=True)
def k_env_step(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body(deriv_one, _kpower, _jrate, _feats, X, A, LH, P, h, n, Xo, B, F)


@njit(cache=True)
def k_env_row(i, X, A, LH, P, h, n, Xo, B, F, work):  # pragma: no cover - compiled
    env_step_row(deriv_one, _kpower, _jrate, _feats, i, X, A, LH, P, h, n, Xo, B, F, work)


@njit(cache=True, parallel=True)
def k_env_step_par(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body_par(k_env_row, X, A, LH, P, h, n, Xo, B, F)


def _input_bounds(params, mode):  # the core asks the model instance instead
    raise NotImplementedError


def _initial_state(nx: int, pose: np.ndarray, params) -> np.ndarray:
    """Rest state of ``nx`` entries at ``pose (N, 3)`` (module-level, bound with
    ``functools.partial``, so a spec and the environments holding it can be pickled)."""
    X = np.zeros((pose.shape[0], nx))
    X[:, :3] = pose
    return X


def _geometry(length: float, width: float, r: float, p) -> dict:
    """Rendering geometry (bound with ``functools.partial``, picklable)."""
    return {"footprint": np.array([[-0.35 * length, 0.5 * width], [0.65 * length, 0.5 * width],
                                   [0.65 * length, -0.5 * width],
                                   [-0.35 * length, -0.5 * width]]),
            "wheel_radius": r, "wheel_width": 0.05}


def _wheels_dd(x, p):
    t = 0.5 * getattr(p, "track_width", 0.4)
    return np.array([[0.0, t, 0.0], [0.0, -t, 0.0]])


def _wheels_uni(x, p):
    return np.zeros((1, 3))


def _wheels_bic(x, p):
    return np.array([[0.0, 0.0, 0.0], [p.wheelbase, 0.0, 0.0]])


def _wheels_ack(x, p):
    t = 0.5 * p.track_width
    psi = float(np.clip(x[3], -p.max_steering_angle, p.max_steering_angle))
    return np.array([[0.0, t, 0.0], [0.0, -t, 0.0], [p.wheelbase, t, psi],
                     [p.wheelbase, -t, psi]])


def _spec(name, cls, nx, geom, wheels, feats=(), randomize=None, default=None,
          turns_in_place=True) -> RobotSpec:
    return RobotSpec(
        name=name, model_cls=cls, k_env_step=k_env_step,
        k_env_step_par=k_env_step_par, input_bounds=_input_bounds,
        action_modes=tuple(cls.input_modes), twist_dim=2, twist_max=(1.0, 2.0),
        v_max=10.0, w_max=20.0, feat_names=feats, feat_high=(1.0,) * len(feats), radius=0.35,
        randomize=randomize or {}, default_randomize=default or {},
        initial_state=partial(_initial_state, nx), n_motor=0, has_internal_force=False,
        geometry=geom, wheels=wheels, twist_modes=(), turns_in_place=turns_in_place,
        compile_s={"step": 6.0},  # benchmarks/coldstart.py
    )


_WR = {"wheel_radius": (("wheel_radius", "rel"),)}
UNICYCLE = _spec("Unicycle", Unicycle, 3, partial(_geometry, 0.4, 0.4, 0.1), _wheels_uni,
                 randomize=_WR, default={"wheel_radius": (0.95, 1.05)})
DIFFDRIVE = _spec("DiffDrive", DifferentialDrive, 3, partial(_geometry, 0.5, 0.5, 0.1),
                  _wheels_dd,
                  randomize=_WR, default={"wheel_radius": (0.95, 1.05)})
BICYCLE = _spec("Bicycle", Bicycle, 3, partial(_geometry, 0.8, 0.3, 0.15), _wheels_bic,
                turns_in_place=False)
ACKERMANN = _spec("Ackermann", Ackermann, 4, partial(_geometry, 0.8, 0.5, 0.1), _wheels_ack,
                  feats=("cos_psi", "sin_psi"), turns_in_place=False)
