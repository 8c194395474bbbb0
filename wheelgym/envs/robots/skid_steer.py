"""SkidSteer for the environments: compiled step kernel and geometry
(docs/physics/skid-steer.md)."""

from __future__ import annotations

import numpy as np
from numba import njit

import wheelgym.models.friction as _friction
import wheelgym.models.kernels.skid_steer as _kern
from wheelgym.envs.robots._spec import RobotSpec, guard_cache
from wheelgym.envs.robots.body import (
    env_step_block,
    env_step_blocks,
    env_step_blocks_par,
    env_step_body,
)
from wheelgym.models import SkidSteer, SkidSteerParams
from wheelgym.models import motor as _motor
from wheelgym.models.kernels.skid_steer import (
    P_C,
    P_R,
    P_XICR,
    deriv_one,
    deriv_one_dc,
    k_block,
    power_t,
    power_t_dc,
)

guard_cache(__file__, _kern.__file__, _friction.__file__, _motor.__file__)

#: The model's block kernel with DC motors (a lazy dispatcher: compiled on first use).
_k_block_dc = _kern.dc_kernels().block

__all__ = ["SPEC"]


@njit(cache=True, inline="always")
def _jrate(x, p, out):  # pragma: no cover - compiled
    # SS-1: omega_L = (vx - c wz)/r, omega_R = (vx + c wz)/r, motors [1, 2, 3, 4] = [L, L, R, R]
    wl = (x[3] - p[P_C] * x[4]) / p[P_R]
    wr = (x[3] + p[P_C] * x[4]) / p[P_R]
    out[0] = wl
    out[1] = wl
    out[2] = wr
    out[3] = wr


@njit(cache=True, inline="always")
def _feats(x, u, p, pose, twist, feat):  # pragma: no cover - compiled
    pose[0] = x[0]
    pose[1] = x[1]
    pose[2] = x[2]
    twist[0] = x[3]
    twist[1] = -p[P_XICR] * x[4]  # SS-1 ICR constraint
    twist[2] = x[4]
    return 0.0


# The serial kernels: a row at a time (the single env and small batches), and from LANES rows
# in the model's vectorised blocks (the same bits); separate, so that each compiles only what
# its batch size runs (RobotSpec.serial_kernel picks one)
@njit(cache=True)
def k_env_step(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body(deriv_one, power_t, _jrate, _feats, X, A, LH, P, h, n, Xo, B, F)


@njit(cache=True)
def k_env_blocks(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_blocks(k_block, _jrate, _feats, X, A, LH, P, h, n, Xo, B, F)


@njit(cache=True)
def k_env_block(b0, X, A, LH, P, h, n, Xo, B, F, W):  # pragma: no cover - compiled
    env_step_block(k_block, _jrate, _feats, b0, X, A, LH, P, h, n, Xo, B, F, W)


@njit(cache=True, parallel=True)
def k_env_step_par(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_blocks_par(k_env_block, X, A, LH, P, h, n, Xo, B, F)


# DC motors (``motor="dc"``): the same kernels on the model's DC derivative and electrical power
@njit(cache=True)
def k_env_step_dc(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body(deriv_one_dc, power_t_dc, _jrate, _feats, X, A, LH, P, h, n, Xo, B,
                         F)


@njit(cache=True)
def k_env_blocks_dc(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_blocks(_k_block_dc, _jrate, _feats, X, A, LH, P, h, n, Xo, B, F)


@njit(cache=True)
def k_env_block_dc(b0, X, A, LH, P, h, n, Xo, B, F, W):  # pragma: no cover - compiled
    env_step_block(_k_block_dc, _jrate, _feats, b0, X, A, LH, P, h, n, Xo, B, F, W)


@njit(cache=True, parallel=True)
def k_env_step_par_dc(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_blocks_par(k_env_block_dc, X, A, LH, P, h, n, Xo, B, F)


def _input_bounds(params: SkidSteerParams, mode: str) -> tuple[np.ndarray, np.ndarray]:
    t = np.full(4, params.tau_max)
    return -t, t


def _initial_state(pose: np.ndarray, params: SkidSteerParams) -> np.ndarray:
    X = np.zeros((pose.shape[0], 5))
    X[:, :3] = pose
    return X


def _geometry(p: SkidSteerParams) -> dict:
    return {
        "footprint": np.array([[-p.a - 0.12, p.c - 0.06], [p.b + 0.12, p.c - 0.06],
                               [p.b + 0.12, -p.c + 0.06], [-p.a - 0.12, -p.c + 0.06]]),
        "wheel_radius": p.r,
        "wheel_width": 0.11,
    }


def _wheels(x: np.ndarray, p: SkidSteerParams) -> np.ndarray:
    w = np.zeros((4, 3))
    w[:, :2] = p.wheel_positions
    return w


SPEC = RobotSpec(
    name="SkidSteer",
    model_cls=SkidSteer,
    k_env_step=k_env_step,
    k_env_step_par=k_env_step_par,
    k_env_step_dc=k_env_step_dc,
    k_env_step_par_dc=k_env_step_par_dc,
    k_env_blocks=k_env_blocks,
    k_env_blocks_dc=k_env_blocks_dc,
    input_bounds=_input_bounds,
    action_modes=("torque", "velocity"),
    twist_dim=2,
    twist_max=(1.0, 2.0),
    v_max=2.5,
    w_max=5.0,
    feat_names=(),
    feat_high=(),
    radius=0.55,
    randomize={
        "mass": (("m", "rel"),),
        "inertia": (("I", "rel"),),
        "friction": (("mu_s", "rel"), ("mu_l", "rel")),
        "x_icr": (("x_icr", "abs"),),
        "wheel_radius": (("r", "rel"),),
        "torque_limit": (("tau_max", "rel"),),
        "motor": (("k_t", "rel"), ("R_w", "rel"), ("V_s", "rel")),
    },
    default_randomize={
        "mass": (0.8, 1.2), "inertia": (0.8, 1.2), "friction": (0.7, 1.3),
        "x_icr": (-0.08, 0.02), "wheel_radius": (0.95, 1.05), "torque_limit": (0.8, 1.2),
    },
    initial_state=_initial_state,
    n_motor=4,
    has_internal_force=False,
    geometry=_geometry,
    wheels=_wheels,
    motor_names=("rear_left", "front_left", "front_right", "rear_right"),
    baseline_controllers=True,
    compile_s={"step": 5.0, "dc": 5.0, "blocks": 5.0},  # benchmarks/coldstart.py
)
