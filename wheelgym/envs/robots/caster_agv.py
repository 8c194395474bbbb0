"""CasterAGV for the environments: compiled step kernel and geometry
(docs/physics/caster-robots.md)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

import wheelgym.models.friction as _friction
import wheelgym.models.kernels.caster_agv as _kern
from wheelgym.envs.robots._spec import RobotSpec, guard_cache
from wheelgym.envs.robots.body import env_step_body, env_step_body_par, env_step_row
from wheelgym.models import CasterAGV, CasterAGVParams
from wheelgym.models import motor as _motor
from wheelgym.models.kernels.caster_agv import (
    P_C,
    P_R,
    deriv_one,
    deriv_one_dc,
    power_t,
    power_t_dc,
)

guard_cache(__file__, _kern.__file__, _friction.__file__, _motor.__file__)

__all__ = ["SPEC"]


@njit(cache=True, inline="always")
def _jrate(x, p, out):  # pragma: no cover - compiled
    # module docstring of caster_agv: thetadot_L,R = (v -+ c w) / r
    out[0] = (x[3] - p[P_C] * x[4]) / p[P_R]
    out[1] = (x[3] + p[P_C] * x[4]) / p[P_R]


@njit(cache=True, inline="always")
def _feats(x, u, p, pose, twist, feat):  # pragma: no cover - compiled
    pose[0] = x[0]
    pose[1] = x[1]
    pose[2] = x[2]
    twist[0] = x[3]
    twist[1] = 0.0  # no-skid of the driven axle (body origin at the axle midpoint)
    twist[2] = x[4]
    feat[0] = math.cos(x[5])
    feat[1] = math.sin(x[5])
    return 0.0


# stage power: the model's power_t (tau_L thetadot_L + tau_R thetadot_R from the stage's
# derivative), or power_t_dc (the electrical power of DC motors, ``motor="dc"``)
@njit(cache=True)
def k_env_step(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body(deriv_one, power_t, _jrate, _feats, X, A, LH, P, h, n, Xo, B, F)


@njit(cache=True)
def k_env_row(i, X, A, LH, P, h, n, Xo, B, F, work):  # pragma: no cover - compiled
    env_step_row(deriv_one, power_t, _jrate, _feats, i, X, A, LH, P, h, n, Xo, B, F, work)


@njit(cache=True, parallel=True)
def k_env_step_par(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body_par(k_env_row, X, A, LH, P, h, n, Xo, B, F)


@njit(cache=True)
def k_env_step_dc(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body(deriv_one_dc, power_t_dc, _jrate, _feats, X, A, LH, P, h, n, Xo, B,
                         F)


@njit(cache=True)
def k_env_row_dc(i, X, A, LH, P, h, n, Xo, B, F, work):  # pragma: no cover - compiled
    env_step_row(deriv_one_dc, power_t_dc, _jrate, _feats, i, X, A, LH, P, h, n, Xo, B, F,
                 work)


@njit(cache=True, parallel=True)
def k_env_step_par_dc(X, A, LH, P, h, n, Xo, B, F):  # pragma: no cover - compiled
    return env_step_body_par(k_env_row_dc, X, A, LH, P, h, n, Xo, B, F)


def _input_bounds(params: CasterAGVParams, mode: str) -> tuple[np.ndarray, np.ndarray]:
    t = np.full(2, params.tau_max)
    return -t, t


def _initial_state(pose: np.ndarray, params: CasterAGVParams) -> np.ndarray:
    X = np.zeros((pose.shape[0], 9))
    X[:, :3] = pose
    X[:, 5] = 0.0  # sigma = 0: wheel centre a - d e behind its axis, trailing for forward travel
    return X


def _geometry(p: CasterAGVParams) -> dict:
    c = 0.5 * p.track_width
    ax = p.caster_axis[0]
    return {"footprint": np.array([[-0.12, c + 0.02], [ax + 0.06, 0.5 * c],
                                   [ax + 0.06, -0.5 * c], [-0.12, -c - 0.02]]),
            "wheel_radius": p.r, "wheel_width": 0.03}


def _wheels(x: np.ndarray, p: CasterAGVParams) -> np.ndarray:
    c = 0.5 * p.track_width
    s = float(x[5])
    a = np.asarray(p.caster_axis, dtype=np.float64)
    return np.array([[0.0, c, 0.0], [0.0, -c, 0.0],
                     [a[0] - p.d * math.cos(s), a[1] - p.d * math.sin(s), s]])


SPEC = RobotSpec(
    name="CasterAGV",
    model_cls=CasterAGV,
    k_env_step=k_env_step,
    k_env_step_par=k_env_step_par,
    k_env_step_dc=k_env_step_dc,
    k_env_step_par_dc=k_env_step_par_dc,
    input_bounds=_input_bounds,
    action_modes=("torque", "velocity"),
    twist_dim=2,
    twist_max=(1.0, 2.0),
    v_max=2.0,
    w_max=5.0,
    feat_names=("cos_sigma", "sin_sigma"),
    feat_high=(1.0, 1.0),
    radius=0.33,
    randomize={
        "mass": (("m_b", "rel"), ("m_w", "rel"), ("m_c", "rel")),
        "inertia": (("I_b", "rel"), ("I_wy", "rel"), ("I_cz", "rel")),
        "friction": (("mu_r", "rel"), ("mu_p", "rel"), ("b_drive", "rel"), ("b_caster", "rel")),
        "wheel_radius": (("r", "rel"),),
        "caster_trail": (("d", "rel"),),
        "torque_limit": (("tau_max", "rel"),),
        "motor": (("k_t", "rel"), ("R_w", "rel"), ("V_s", "rel")),
    },
    default_randomize={
        "mass": (0.8, 1.2), "inertia": (0.8, 1.2), "friction": (0.5, 1.5),
        "wheel_radius": (0.95, 1.05), "caster_trail": (0.8, 1.2), "torque_limit": (0.8, 1.2),
    },
    initial_state=_initial_state,
    n_motor=2,
    has_internal_force=False,
    geometry=_geometry,
    wheels=_wheels,
    motor_names=("drive_L", "drive_R"),
    compile_s={"step": 5.0, "dc": 5.0},  # benchmarks/coldstart.py
)
