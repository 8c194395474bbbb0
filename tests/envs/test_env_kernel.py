"""The step kernel's motor work against RK4 of the augmented state on the SAME stages.

``integrators.rk4_power`` and the block kernels read each stage's joint rates from the stage
derivative (the models' ``_power_t``) instead of recomputing them from the state; that must
equal, to rounding, the classical RK4 of ``z = (x, E)`` with ``E' = model.motor_power(x, u)`` at the
kernel's own substep, and the joint velocities it reports must be the model's at the new
state.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.envs.conftest import DYNAMIC
from wheelgym.envs.core import WheelCore
from wheelgym.envs.robots import get_spec
from wheelgym.envs.robots.body import layout
from wheelgym.integrators import LANES


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


@pytest.mark.parametrize("rows", [1, LANES + 3], ids=["row", "blocks"])
@pytest.mark.parametrize("robot", DYNAMIC)
def test_step_work_is_rk4_of_augmented_state(robot, rows):
    """One row (the single env's path) and 11 rows (ThreeWheel and SkidSteer step these in
    vectorised blocks of LANES robots): every row's state, work and joint rates."""
    spec = get_spec(robot)
    core = WheelCore(robot, rows)
    core.reset(None, [np.random.default_rng(k) for k in range(rows)])
    rng = np.random.default_rng(4)
    X = np.array([_moving_state(core, rng) for _ in range(rows)])
    A = rng.uniform(-0.9, 0.9, (rows, core.m))
    Xo = np.empty_like(X)
    B = np.zeros_like(core.B)
    F = np.zeros_like(core.F)
    assert spec.serial_kernel(False, rows)(X, A, core.LH, core.P, core.h, core.n_sub, Xo, B, F)
    lay = layout(core.m, B.shape[1] - 2 * core.m - 11)
    for i in range(rows):
        assert F[i, 1]
        u = B[i, lay["U"]]
        np.testing.assert_allclose(
            u, core.LO[i] + 0.5 * (A[i] + 1.0) * (core.HI[i] - core.LO[i]), rtol=1e-14,
            atol=1e-14)
        x_ref, e_ref = _rk4_augmented(core.model, X[i], u, core.h, core.n_sub)
        np.testing.assert_allclose(Xo[i], x_ref, rtol=1e-11, atol=1e-12)
        assert abs(e_ref) > 1e-3  # the motors did work
        assert abs(B[i, lay["energy"]] - e_ref) <= 1e-11 * abs(e_ref)
        jv = core.model.joint_velocity(Xo[i])[: core.m]
        np.testing.assert_allclose(B[i, lay["jv"]], jv, rtol=1e-12, atol=1e-12)
