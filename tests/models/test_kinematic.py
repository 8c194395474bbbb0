"""Kinematic models: analytic answers, saturation, modes, batching (docs/physics/kinematic.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym.models import (
    Ackermann,
    Bicycle,
    BicycleParams,
    DifferentialDrive,
    DifferentialDriveParams,
    Unicycle,
    UnicycleParams,
)

ALL = (Unicycle, Bicycle, DifferentialDrive, Ackermann)


def _x0(model, yaw=0.0, psi=0.0):
    x = np.zeros(model.state_dim)
    x[2] = yaw
    if model.state_dim > 3:
        x[3] = psi
    return x


def _straight_input(model, v):
    """The input that drives straight at speed v in the model's mode."""
    name = model.input_mode
    if name == "WheelSpeedHeadingRate":
        return np.array([v / model.params.wheel_radius, 0.0])
    if name == "WheelSpeeds":
        return np.full(2, v / model.params.wheel_radius)
    return np.array([v, 0.0])


@pytest.mark.parametrize("cls, mode", [(c, m) for c in ALL for m in c.input_modes])
def test_straight_line_distance(cls, mode):
    model = cls(input_mode=mode)
    yaw, v, t = 0.7, 0.6, 3.0
    x = model.step(_x0(model, yaw), _straight_input(model, v), t, 3)
    np.testing.assert_allclose(x[:2], v * t * np.array([math.cos(yaw), math.sin(yaw)]),
                               rtol=0, atol=1e-14)
    assert x[2] == yaw


def _circle(radius, yaw_rate, t):
    """Position after t on a circle entered at the origin heading +x (yaw0 = 0)."""
    return np.array([radius * math.sin(yaw_rate * t), radius * (1.0 - math.cos(yaw_rate * t))])


@pytest.mark.parametrize("mode", ["VehicleSpeedHeadingRate", "WheelSpeedHeadingRate"])
def test_unicycle_circle_radius(mode):
    model = Unicycle(input_mode=mode)
    v, w, t = 0.5, 0.8, 5.0
    u = np.array([v if mode.startswith("Vehicle") else v / model.params.wheel_radius, w])
    x = model.step(_x0(model), u, t, 400)
    np.testing.assert_allclose(x[:2], _circle(v / w, w, t), atol=1e-10)
    assert abs(x[2] - w * t) < 1e-12
    # a full period closes the circle
    x = model.step(_x0(model), u, 2 * math.pi / w, 400)
    np.testing.assert_allclose(x[:2], 0.0, atol=1e-10)


def test_bicycle_and_ackermann_turning_radius():
    psi, v, t = 0.3, 1.2, 2.0
    bic = Bicycle()
    radius = bic.params.wheelbase / math.tan(psi)
    x = bic.step(_x0(bic), np.array([v, psi]), t, 400)
    np.testing.assert_allclose(x[:2], _circle(radius, v / radius, t), atol=1e-10)
    ack = Ackermann()
    x = ack.step(_x0(ack, psi=psi), np.array([v, 0.0]), t, 400)
    np.testing.assert_allclose(x[:2], _circle(radius, v / radius, t), atol=1e-10)
    assert x[3] == psi
    # the heading-rate form of the bicycle is the unicycle with the same (v, w)
    b2 = Bicycle(input_mode="VehicleSpeedHeadingRate")
    uni = Unicycle(input_mode="VehicleSpeedHeadingRate")
    x0 = np.array([0.3, -0.2, 1.0])
    np.testing.assert_array_equal(b2.step(x0, np.array([0.5, 0.4]), 1.0, 10),
                                  uni.step(x0, np.array([0.5, 0.4]), 1.0, 10))


def test_ackermann_steering_integrates():
    ack = Ackermann()
    x = ack.step(_x0(ack), np.array([1.0, 0.2]), 1.0, 50)
    assert abs(x[3] - 0.2) < 1e-14
    # yaw = int v tan(0.2 t) / l dt = -ln(cos(0.2)) / (0.2 l)
    expected = -math.log(math.cos(0.2)) / (0.2 * ack.params.wheelbase)
    assert abs(x[2] - expected) < 1e-9


def test_diffdrive_equals_unicycle_with_converted_inputs():
    dd = DifferentialDrive()
    uni = Unicycle(input_mode="VehicleSpeedHeadingRate", max_heading_rate=100.0)
    r, d = dd.params.wheel_radius, dd.params.track_width
    rng = np.random.default_rng(1)
    for _ in range(5):
        wl, wr = rng.uniform(-8, 8, size=2)
        v, w = r * (wl + wr) / 2, r * (wr - wl) / d  # reference: differential-drive equations
        x0 = rng.normal(size=3)
        a = dd.step(x0, np.array([wl, wr]), 1.0, 20)
        b = uni.step(x0, np.array([v, w]), 1.0, 20)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)
        np.testing.assert_allclose(dd.wheel_speeds(v, w), [wl, wr], atol=1e-12)


def test_unicycle_saturation_order():
    p = UnicycleParams(wheel_radius=0.1, speed_range=(-0.5, 2.0), wheel_speed_range=(-8.0, 8.0),
                       max_heading_rate=1.0)
    m = Unicycle(p)
    eff = m.effective_input(np.zeros(3), np.array([[20.0, 3.0], [-20.0, -3.0], [4.0, 0.5]]))
    # wheel limit 8 rad/s -> 0.8 m/s (inside speed_range); negative: wheel -> -0.8, speed -> -0.5
    np.testing.assert_allclose(eff, [[0.8, 1.0], [-0.5, -1.0], [0.4, 0.5]])
    lo, hi = m.input_bounds()
    np.testing.assert_allclose(lo, [-5.0, -1.0])
    np.testing.assert_allclose(hi, [8.0, 1.0])
    mv = Unicycle(p, input_mode="VehicleSpeedHeadingRate")
    lo, hi = mv.input_bounds()
    np.testing.assert_allclose([lo, hi], [[-0.5, -1.0], [0.8, 1.0]])
    np.testing.assert_allclose(mv.effective_input(np.zeros(3), hi), hi)
    np.testing.assert_allclose(mv.effective_input(np.zeros(3), lo), lo)


def test_diffdrive_saturation_order():
    p = DifferentialDriveParams(wheel_radius=0.1, track_width=0.5, speed_range=(-1.0, 0.9),
                                wheel_speed_range=(-10.0, 10.0))
    m = DifferentialDrive(p)
    eff = m.effective_input(np.zeros(3), np.array([[15.0, 5.0], [12.0, 12.0]]))
    # (15, 5): left clipped to 10 -> v = 0.1 (10 + 5) / 2 = 0.75, w = 0.1 (5 - 10) / 0.5 = -1
    np.testing.assert_allclose(eff[0], [0.75, -1.0])
    # (12, 12): wheels -> 10 -> v = 1.0, then the speed range clips v to 0.9, w untouched
    np.testing.assert_allclose(eff[1], [0.9, 0.0])
    mv = DifferentialDrive(p, input_mode="VehicleSpeedHeadingRate")
    eff = mv.effective_input(np.zeros(3), np.array([[0.8, 2.0], [5.0, 0.0]]))
    # (0.8, 2): wheels (3, 13) -> (3, 10): v = 0.65, w = 1.4
    np.testing.assert_allclose(eff, [[0.65, 1.4], [0.9, 0.0]])
    lo, hi = mv.input_bounds()
    np.testing.assert_allclose([lo, hi], [[-1.0, -4.0], [0.9, 4.0]])
    np.testing.assert_allclose(mv.effective_input(np.zeros(3), [0.0, hi[1]]), [0.0, hi[1]])


def test_bicycle_saturation():
    m = Bicycle(BicycleParams(speed_range=(-1.0, 2.0), max_steering_angle=0.4, wheelbase=0.5))
    eff = m.effective_input(np.zeros(3), np.array([[3.0, 1.0], [-3.0, -1.0]]))
    np.testing.assert_allclose(eff, [[2.0, 2.0 * math.tan(0.4) / 0.5],
                                     [-1.0, -1.0 * math.tan(-0.4) / 0.5]])
    mh = Bicycle(m.params, input_mode="VehicleSpeedHeadingRate")
    eff = mh.effective_input(np.zeros(3), np.array([[0.0, 1.0], [1.0, 5.0], [1.0, 0.3]]))
    np.testing.assert_allclose(eff, [[0.0, 0.0], [1.0, math.tan(0.4) / 0.5], [1.0, 0.3]])


def test_ackermann_saturation():
    m = Ackermann()
    pmax = m.params.max_steering_angle
    eff = m.effective_input(np.array([[0, 0, 0, pmax], [0, 0, 0, 0.0]]),
                            np.array([[5.0, 1.0], [-5.0, -9.0]]))
    np.testing.assert_allclose(eff, [[2.0, 2.0 * math.tan(pmax) / 0.5, 0.0],
                                     [-1.0, 0.0, -m.params.max_steering_rate]])
    x = m.step(np.array([0, 0, 0, pmax - 0.01]), np.array([1.0, 1.0]), 1.0, 100)
    assert pmax - 1e-3 <= x[3] <= pmax + 0.03  # stops at the limit (within one substep)


@pytest.mark.parametrize("cls", ALL)
def test_batched_equals_one_by_one(cls):
    for mode in cls.input_modes:
        model = cls(input_mode=mode)
        rng = np.random.default_rng(5)
        X = rng.normal(size=(600, model.state_dim))
        U = rng.normal(size=(600, 2)) * 3
        batch = model.step(X, U, 0.05, 3)  # the prange kernel
        small = model.step(X[:5], U[:5], 0.05, 3)
        for i in range(5):
            one = model.step(X[i], U[i], 0.05, 3)  # the single-state fast path
            assert np.array_equal(one, batch[i])
            assert np.array_equal(one, small[i])
            assert np.array_equal(model.derivative(X[i], U[i]),
                                  model.derivative(X, U)[i])


@pytest.mark.parametrize("cls", ALL)
def test_modes_and_names(cls):
    m = cls()
    assert m.input_mode == cls.default_input_mode
    assert len(m.input_names) == 2 and m.input_dim == 2
    lo, hi = m.input_bounds()
    assert lo.shape == hi.shape == (2,) and np.all(lo < hi)
    with pytest.raises(ValueError, match="valid modes") as err:
        cls(input_mode="Teleport")
    for mode in cls.input_modes:
        assert mode in str(err.value)
    with pytest.raises(TypeError, match="input_mode"):
        cls(input_mode=3)


def test_mode_names_per_model():
    assert Unicycle(input_mode="VehicleSpeedHeadingRate").input_names == ("v", "w")
    assert DifferentialDrive().input_names == ("phidot_L", "phidot_R")
    assert Bicycle().input_names == ("v", "psi")
    assert Ackermann().input_names == ("v", "psidot")
    with pytest.raises(ValueError, match="WheelSpeeds"):
        Unicycle(input_mode="WheelSpeeds")


@pytest.mark.parametrize(
    "cls, kwargs, match",
    [
        (Unicycle, {"wheel_radius": 0.0}, "wheel_radius"),
        (Unicycle, {"speed_range": (1.0, -1.0)}, "low <= high"),
        (Unicycle, {"speed_range": (2.0, 3.0), "wheel_speed_range": (-1.0, 1.0)}, "overlap"),
        (DifferentialDrive, {"track_width": -0.1}, "track_width"),
        (DifferentialDrive, {"speed_range": (0.0, 1.0, 2.0)}, "pair"),
        (Bicycle, {"max_steering_angle": 2.0}, "pi/2"),
        (Ackermann, {"max_steering_rate": 0.0}, "max_steering_rate"),
        (Ackermann, {"wheelbase": float("inf")}, "finite"),
    ],
)
def test_bad_params(cls, kwargs, match):
    with pytest.raises(ValueError, match=match):
        cls(**kwargs)


def test_unknown_param_and_non_finite():
    with pytest.raises(TypeError, match="valid names"):
        Unicycle(radius=1.0)
    m = DifferentialDrive()
    with pytest.raises(ValueError, match="not finite"):
        m.step(np.zeros(3), np.array([np.inf, 0.0]), 0.05, 1)
    with pytest.raises(ValueError, match="not finite"):
        m.step(np.array([np.nan, 0.0, 0.0]), np.zeros(2), 0.05, 1)
