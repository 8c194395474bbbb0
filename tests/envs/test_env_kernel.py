"""The step kernel's motor work against RK4 of the augmented state on the SAME stages.

``rk4_work`` reads each stage's joint rates from the stage derivative (``_kpower``) instead of
recomputing them from the state; that must equal, to rounding, the classical RK4 of
``z = (x, E)`` with ``E' = model.motor_power(x, u)`` at the kernel's own substep, and the joint
velocities it reports must be the model's at the new state.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.envs.conftest import DYNAMIC
from wheelgym.envs.core import WheelCore
from wheelgym.envs.robots import get_spec
from wheelgym.envs.robots._body import layout


def _rk4_augmented(model, x0, u, h, n):
    """Classical RK4 of ``(x, E)`` written out here (models' ``derivative`` and
    ``motor_power``, both NumPy-facing public methods)."""

    def f(z):
        return np.append(model.derivative(z[:-1], u), model.motor_power(z[:-1], u))

    z = np.append(x0, 0.0)
    for _ in range(n):
        k1 = f(z)
        k2 = f(z + 0.5 * h * k1)
        k3 = f(z + 0.5 * h * k2)
        k4 = f(z + h * k3)
        z = z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return z[:-1], z[-1]


def _moving_state(core, rng):
    nx = core.X.shape[1]
    x = np.zeros(nx)
    x[:3] = rng.uniform(-1.0, 1.0, 3)
    if core.spec.name == "ThreeWheel":  # twist (vx, vy, wz), steering angles psi_i
        x[3:6] = (0.6, -0.3, 0.8)
        x[6:9] = rng.uniform(-np.pi, np.pi, 3)
    elif core.spec.name == "CasterAGV":  # (v, w), swivel angle sigma
        x[3:5] = (0.7, -0.9)
        x[5] = 2.0
    else:  # SkidSteer (vx, wz)
        x[3:5] = (0.8, 0.7)
    return x


@pytest.mark.parametrize("robot", DYNAMIC)
def test_step_work_is_rk4_of_augmented_state(robot):
    spec = get_spec(robot)
    core = WheelCore(robot, 1)
    core.reset(None, [np.random.default_rng(0)])
    rng = np.random.default_rng(4)
    x0 = _moving_state(core, rng)
    X = x0[None].copy()
    A = rng.uniform(-0.9, 0.9, (1, core.m))
    Xo = np.empty_like(X)
    B = np.zeros_like(core.B)
    F = np.zeros_like(core.F)
    assert spec.k_env_step(X, A, core.LH, core.P, core.h, core.n_sub, Xo, B, F)
    assert F[0, 1]
    lay = layout(core.m, B.shape[1] - 2 * core.m - 11)
    u = B[0, lay["U"]]
    np.testing.assert_allclose(u, core.LO[0] + 0.5 * (A[0] + 1.0) * (core.HI[0] - core.LO[0]),
                               rtol=1e-14, atol=1e-14)
    x_ref, e_ref = _rk4_augmented(core.model, x0, u, core.h, core.n_sub)
    np.testing.assert_allclose(Xo[0], x_ref, rtol=1e-11, atol=1e-12)
    assert abs(e_ref) > 1e-3  # the motors did work
    assert abs(B[0, lay["energy"]] - e_ref) <= 1e-11 * abs(e_ref)
    jv = core.model.joint_velocity(Xo[0])[: core.m]
    np.testing.assert_allclose(B[0, lay["jv"]], jv, rtol=1e-12, atol=1e-12)
