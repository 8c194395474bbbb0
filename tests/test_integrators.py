"""RK4 and time-step bookkeeping (physics.md section 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym.integrators import check_substeps, n_substeps, rk4
from wheelgym.models import SkidSteer


def _decay(x, u):
    return -x + u


def test_rk4_linear_decay_fourth_order():
    # x' = -x, x(0) = 1: exact exp(-t). The global error at t = 1 falls 16x per halving.
    errors = []
    for n in (10, 20, 40, 80):
        x = rk4(_decay, np.array([1.0]), 0.0, 1.0, n)
        errors.append(abs(x[0] - math.exp(-1.0)))
    ratios = [errors[i] / errors[i + 1] for i in range(3)]
    for r in ratios:
        assert 16 * 0.75 <= r <= 16 * 1.25, ratios
    # one step of RK4 on a linear ODE is the 4th-order Taylor polynomial of exp(-h)
    h = 0.1
    one = rk4(_decay, np.array([1.0]), 0.0, h, 1)[0]
    assert one == pytest.approx(1 - h + h**2 / 2 - h**3 / 6 + h**4 / 24, rel=1e-15)


def test_rk4_harmonic_oscillator_and_constant_input():
    def osc(x, u):
        return np.stack([x[..., 1], -x[..., 0] + u], axis=-1)

    x = rk4(osc, np.array([1.0, 0.0]), 0.0, 2 * np.pi, 2000)
    np.testing.assert_allclose(x, [1.0, 0.0], atol=1e-10)
    # a constant input shifts the equilibrium: x = u (1 - cos t) from rest
    x = rk4(osc, np.zeros(2), 0.5, np.pi, 2000)
    assert x[0] == pytest.approx(0.5 * (1 - math.cos(math.pi)), abs=1e-10)


def test_rk4_keeps_input_and_batches():
    x0 = np.array([[1.0], [2.0]])
    x = rk4(_decay, x0, 0.0, 0.5, 5)
    assert x.shape == (2, 1)
    assert x0[0, 0] == 1.0  # not modified in place
    np.testing.assert_allclose(x[1], 2 * x[0], rtol=1e-15)


def test_compiled_step_is_the_python_rk4():
    # The model's compiled kernel (rk4_inplace) and the reference rk4 on model.derivative
    # perform the same operations in the same order.
    model = SkidSteer()
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.normal(0, 0.5, 5)
        u = rng.uniform(-20, 20, 4)
        fast = model.step(x, u, 0.05, 40)
        ref = rk4(model.derivative, x, u, 0.05, 40)
        np.testing.assert_allclose(fast, ref, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize(
    ("ctrl_dt", "sim_dt", "n"),
    [(0.05, 0.002, 25), (0.05, 0.00125, 40), (0.05, 0.05, 1), (0.1, 0.001, 100), (1, 0.25, 4)],
)
def test_n_substeps_divides(ctrl_dt, sim_dt, n):
    assert n_substeps(ctrl_dt, sim_dt) == n


@pytest.mark.parametrize(
    ("ctrl_dt", "sim_dt", "match"),
    [
        (0.05, 0.003, "whole multiple"),
        (0.05, 0.1, "whole multiple"),
        (0.05, 0.0, "sim_dt"),
        (0.05, -0.001, "sim_dt"),
        (float("nan"), 0.001, "ctrl_dt"),
        (0.05, float("inf"), "sim_dt"),
        (0.0, 0.001, "ctrl_dt"),
    ],
)
def test_n_substeps_rejects(ctrl_dt, sim_dt, match):
    with pytest.raises(ValueError, match=match):
        n_substeps(ctrl_dt, sim_dt)


def test_check_substeps():
    assert check_substeps(3) == 3
    assert check_substeps(np.int64(2)) == 2
    for bad in (1.0, 2.5, True, "2", None):
        with pytest.raises(TypeError, match="n_substeps"):
            check_substeps(bad)
    for bad in (0, -1):
        with pytest.raises(ValueError, match="n_substeps"):
            check_substeps(bad)
    with pytest.raises(ValueError):
        rk4(_decay, np.ones(1), 0.0, 1.0, 0)
