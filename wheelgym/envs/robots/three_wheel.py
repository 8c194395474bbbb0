"""ThreeWheel for the environments: compiled step kernel and geometry
(docs/physics/three-wheel.md)."""

from __future__ import annotations

import numpy as np
from numba import njit

import wheelgym.control.distribution as _distribution
import wheelgym.models.friction as _friction
import wheelgym.models.kernels.three_wheel as _kern
from wheelgym.control.distribution import internal_force_one
from wheelgym.envs.robots._spec import RobotSpec, guard_cache
from wheelgym.envs.robots.body import (
    env_step_block,
    env_step_blocks,
    env_step_blocks_par,
    env_step_body,
)
from wheelgym.integrators import fma
from wheelgym.models import ThreeWheel, ThreeWheelParams
from wheelgym.models import motor as _motor
from wheelgym.models.kernels.three_wheel import (
    P_INVD,
    P_INVR,
    deriv_one,
    deriv_one_dc,
    dot3,
    gh,
    jacobian_rows,
    k_block,
    power_t,
    power_t_dc,
    trig,
)

guard_cache(__file__, _kern.__file__, _friction.__file__, _distribution.__file__,
            _motor.__file__)

#: The model's block kernel with DC motors (a lazy dispatcher: compiled on first use).
_k_block_dc = _kern.dc_kernels().block

__all__ = ["SPEC"]


@njit(cache=True, inline="always")
def _jrate(x, p, out):  # pragma: no cover - compiled
    # TW-1: thetadot_i = g_i.u / r, psidot_i = h_i.u / d - wz; motor order [drive, steer]
    # (the products with 1/r, 1/d that deriv_one's rates use)
    cs = trig(x[6], x[7], x[8])
    vx = x[3]
    vy = x[4]
    wz = x[5]
    for i in range(3):
        g, h = gh(cs, i, p)
        out[i] = dot3(g, vx, vy, wz) * p[P_INVR]
        out[3 + i] = fma(dot3(h, vx, vy, wz), p[P_INVD], -wz)


@njit(cache=True, inline="always")
def _feats(x, u, p, pose, twist, feat):  # pragma: no cover - compiled
    cs = trig(x[6], x[7], x[8])  # (cos psi_1, sin psi_1, ...), the model's sin/cos
    for k in range(3):
        pose[k] = x[k]
        twist[k] = x[3 + k]
        feat[k] = cs[2 * k]
        feat[3 + k] = cs[2 * k + 1]
    # internal force |(I - J (J^T J)^-1 J^T) tau| (TW-6, paper (36)), distribution's formula;
    # J's rows as tuples (no array per row), the model's jacobian_rows (TW-1): drive rows g_i / r,
    # then steer rows h_i / d - e_3
    g, h = gh(cs, 0, p)
    jd1, js1 = jacobian_rows(g, h, p)
    g, h = gh(cs, 1, p)
    jd2, js2 = jacobian_rows(g, h, p)
    g, h = gh(cs, 2, p)
    jd3, js3 = jacobian_rows(g, h, p)
    return internal_force_one((jd1, jd2, jd3, js1, js2, js3), u, None)


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


def _input_bounds(params: ThreeWheelParams, mode: str) -> tuple[np.ndarray, np.ndarray]:
    t = params.tau_max
    return -t, t


def _initial_state(pose: np.ndarray, params: ThreeWheelParams) -> np.ndarray:
    X = np.zeros((pose.shape[0], 12))
    X[:, :3] = pose  # at rest, every wheel trailing straight back (psi = 0)
    return X


def _geometry(p: ThreeWheelParams) -> dict:
    a = p.axes_array
    lo = a.min(axis=0) - 0.08
    hi = a.max(axis=0) + 0.08
    return {
        "footprint": np.array([[lo[0], hi[1]], [hi[0], 0.6 * hi[1]], [hi[0], 0.6 * lo[1]],
                               [lo[0], lo[1]]]),
        "wheel_radius": p.r,
        "wheel_width": 0.035,
    }


def _wheels(x: np.ndarray, p: ThreeWheelParams) -> np.ndarray:
    a = p.axes_array
    psi = np.asarray(x[6:9])
    w = np.zeros((3, 3))
    w[:, 0] = a[:, 0] - p.d * np.cos(psi)  # p_i = a_i - d e_i (TW-1)
    w[:, 1] = a[:, 1] - p.d * np.sin(psi)
    w[:, 2] = psi
    return w


#: The 8 steering configurations psi_i in {0, pi/2} at which the randomisation corners'
#: stiffness is evaluated (~40x cheaper than the full grid, scaled by full/coarse at base).
_STIFFNESS_PROBE = tuple(tuple(float(a) for a in row) for row in np.stack(
    np.meshgrid(*((0.0, 0.5 * np.pi),) * 3, indexing="ij"), -1).reshape(-1, 3))

SPEC = RobotSpec(
    name="ThreeWheel",
    model_cls=ThreeWheel,
    k_env_step=k_env_step,
    k_env_step_par=k_env_step_par,
    k_env_step_dc=k_env_step_dc,
    k_env_step_par_dc=k_env_step_par_dc,
    k_env_blocks=k_env_blocks,
    k_env_blocks_dc=k_env_blocks_dc,
    input_bounds=_input_bounds,
    action_modes=("torque", "velocity"),
    twist_dim=3,
    twist_max=(1.0, 1.0, 2.0),
    v_max=2.0,
    w_max=4.0,
    feat_names=("cos_psi_1", "cos_psi_2", "cos_psi_3", "sin_psi_1", "sin_psi_2", "sin_psi_3"),
    feat_high=(1.0,) * 6,
    radius=0.36,
    randomize={
        "mass": (("m_b", "rel"), ("m_w", "rel")),
        "inertia": (("I_b", "rel"), ("I_wy", "rel"), ("I_wz", "rel")),
        "friction": (("mu_r", "rel"), ("mu_p", "rel"), ("b_drive", "rel"), ("b_steer", "rel")),
        "wheel_radius": (("r", "rel"),),
        "caster_trail": (("d", "rel"),),
        "torque_limit": (("tau_drive_max", "rel"), ("tau_steer_max", "rel")),
        "motor": (("k_t_drive", "rel"), ("k_t_steer", "rel"), ("R_w_drive", "rel"),
                  ("R_w_steer", "rel"), ("V_s", "rel")),
    },
    default_randomize={
        "mass": (0.8, 1.2), "inertia": (0.8, 1.2), "friction": (0.5, 1.5),
        "wheel_radius": (0.95, 1.05), "caster_trail": (0.8, 1.2), "torque_limit": (0.8, 1.2),
    },
    initial_state=_initial_state,
    n_motor=6,
    has_internal_force=True,
    geometry=_geometry,
    wheels=_wheels,
    motor_names=("drive_1", "drive_2", "drive_3", "steer_1", "steer_2", "steer_3"),
    holonomic=True,
    baseline_controllers=True,
    n_steer_motor=3,
    stiffness_probe=_STIFFNESS_PROBE,
    compile_s={"step": 10.0, "dc": 8.0, "blocks": 12.0},  # benchmarks/coldstart.py
)
