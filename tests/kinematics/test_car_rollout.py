"""The compiled plan rollout of the car-like track baseline (wheelgym.kinematics.car_rollout)."""

from __future__ import annotations

import numpy as np
import pytest

from wheelgym.kinematics.car_rollout import plan_costs
from wheelgym.models import elementwise as ew


def _numpy_costs(start, V, D, ref_xy, dt, wheelbase, rate):
    """The same model in element-wise NumPy on wheelgym's compiled sin/cos ufuncs, a step at a
    time over all rows and plans (the baseline's implementation before the compiled one)."""
    n, H, K = V.shape
    x, y, th, psi = (np.repeat(start[:, c:c + 1], K, axis=1) for c in range(4))
    vdt = V * dt
    cost = np.zeros((n, K))
    for k in range(H):
        if rate is None:
            dth = vdt[:, k] * (ew.sin(D[:, k]) / ew.cos(D[:, k]) / wheelbase)
        else:
            turn = np.clip(D[:, k] - psi, -rate * dt, rate * dt)
            mid = psi + 0.5 * turn
            psi = psi + turn
            dth = vdt[:, k] * (ew.sin(mid) / ew.cos(mid) / wheelbase)
        th_mid = th + 0.5 * dth
        x = x + vdt[:, k] * ew.cos(th_mid)
        y = y + vdt[:, k] * ew.sin(th_mid)
        th = th + dth
        ex, ey = x - ref_xy[:, k, 0:1], y - ref_xy[:, k, 1:2]
        cost = cost + (ex * ex + ey * ey)
    return cost


def _plans(rng, n=5, H=30, K=97):
    start = np.column_stack([rng.normal(size=(n, 3)), rng.uniform(-0.5, 0.5, n)])
    V = rng.uniform(-1.0, 2.0, (n, H, K))
    D = rng.uniform(-0.6, 0.6, (n, H, K))
    ref = rng.normal(size=(n, H + 1, 6))[:, 1:, :2]  # a strided view, as the baseline passes
    return start, V, D, ref


@pytest.mark.parametrize("rate", [None, 0.8])
def test_plan_costs_equal_the_elementwise_numpy_model_bit_for_bit(rate):
    """Bicycle (no rate limit) and Ackermann (0.8 rad/s): every cost equals the NumPy
    formulation's, also on a row whose yaw (1e9 rad) takes libm's sine and cosine."""
    start, V, D, ref = _plans(np.random.default_rng(3))
    start[2, 2] = 1e9
    got = plan_costs(start, V, D, ref, 0.05, 0.3, rate)
    want = _numpy_costs(start, V, D, ref, 0.05, 0.3, rate)
    assert got.shape == (5, 97)
    np.testing.assert_array_equal(got, want)


def test_a_batch_equals_its_rows():
    start, V, D, ref = _plans(np.random.default_rng(4))
    batch = plan_costs(start, V, D, ref, 0.05, 0.3, 1.2)
    for i in range(start.shape[0]):
        one = plan_costs(start[i:i + 1], V[i:i + 1], D[i:i + 1], ref[i:i + 1], 0.05, 0.3, 1.2)
        np.testing.assert_array_equal(one[0], batch[i])


@pytest.mark.parametrize("rate", [None, 2.0])
def test_straight_plan_cost_is_the_sum_of_squares(rate):
    """Zero steering from rest at the origin, yaw 0, speed v: the car is at ``x = v dt k``
    after step k, so against a reference held at the origin the cost is
    ``(v dt)^2 H (H + 1) (2H + 1) / 6``; against a reference that moves with it, 0."""
    H, v, dt = 30, 1.5, 0.05
    V = np.full((1, H, 2), v)
    D = np.zeros((1, H, 2))
    at_origin = np.zeros((1, H, 2))
    moving = np.zeros((1, H, 2))
    moving[0, :, 0] = v * dt * np.arange(1, H + 1)
    start = np.zeros((1, 4))
    cost = plan_costs(start, V, D, at_origin, dt, 0.3, rate)
    np.testing.assert_allclose(cost, (v * dt) ** 2 * H * (H + 1) * (2 * H + 1) / 6, rtol=1e-12)
    assert plan_costs(start, V, D, moving, dt, 0.3, rate).max() < 1e-24


def test_a_constant_steering_angle_drives_the_bicycle_on_its_circle():
    """Steering angle delta: yaw rate v tan(delta) / l, the circle of radius R = l / tan(delta)
    through the start. Each step's chord at the midpoint heading points along the circle's
    chord but is v dt long instead of 2 R sin(v dt / 2R), so the car drifts outward by at most
    (v dt)^3 / (24 R^2) a step: against a reference at the circle's centre the cost lies
    between H R^2 and H (R + H (v dt)^3 / (24 R^2))^2."""
    H, v, dt, l, delta = 30, 1.0, 0.05, 0.3, 0.4
    R = l / np.tan(delta)
    centre = np.zeros((1, H, 2))
    centre[0, :, 1] = R  # a left turn from the origin facing +x
    cost = plan_costs(np.zeros((1, 4)), np.full((1, H, 1), v), np.full((1, H, 1), delta),
                      centre, dt, l, None)[0, 0]
    drift = H * (v * dt) ** 3 / (24 * R ** 2)
    assert H * R ** 2 < cost < H * (R + drift) ** 2


@pytest.mark.parametrize("rate", [None, 0.8])
def test_shared_plans_cost_as_if_copied_into_every_row(rate):
    """``shared`` plans come first in the result and cost what they cost as each row's own
    plans (also on the row whose yaw takes libm)."""
    start, V, D, ref = _plans(np.random.default_rng(5))
    start[1, 2] = 1e9
    rng = np.random.default_rng(6)
    TV, TD = rng.uniform(-1.0, 2.0, (30, 41)), rng.uniform(-0.6, 0.6, (30, 41))
    got = plan_costs(start, V, D, ref, 0.05, 0.3, rate, shared=(TV, TD))
    n = start.shape[0]
    Vc = np.concatenate([np.broadcast_to(TV, (n, 30, 41)), V], axis=2)
    Dc = np.concatenate([np.broadcast_to(TD, (n, 30, 41)), D], axis=2)
    assert got.shape == (n, 41 + 97)
    np.testing.assert_array_equal(got, plan_costs(start, Vc, Dc, ref, 0.05, 0.3, rate))
