"""Differential-drive inverse kinematics and rotate-translate-rotate (diff-drive lecture 3, 5.1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym.kinematics import body_velocity, plan_rtr, rtr, wheel_speeds, wrap_angle
from wheelgym.models import DifferentialDrive


def test_wheel_speeds_invert_body_velocity():
    rng = np.random.default_rng(0)
    v, w = rng.normal(size=(2, 4, 5))
    ph = wheel_speeds(v, w, 0.1, 0.5)
    assert ph.shape == (4, 5, 2)
    np.testing.assert_allclose(body_velocity(ph, 0.1, 0.5), np.stack([v, w], -1), atol=1e-14)
    # lecture cases: pure translation (equal speeds), spin on the spot (opposite speeds)
    np.testing.assert_allclose(wheel_speeds(1.0, 0.0, 0.1, 0.5), [10.0, 10.0])
    np.testing.assert_allclose(wheel_speeds(0.0, 2.0, 0.1, 0.5), [-5.0, 5.0])
    # lecture case 3: left wheel still -> w = v_R / (2a), v = v_R / 2
    np.testing.assert_allclose(body_velocity([0.0, 4.0], 0.1, 0.5), [0.2, 0.8])


def _drive(model, start, plan):
    x = np.asarray(start, dtype=np.float64)
    for motion in plan:
        if motion.duration > 0:
            x = model.step(x, np.array(motion.wheel_speeds), motion.duration, 1)
    return x


@pytest.mark.parametrize("allow_reverse", [False, True])
def test_rtr_reaches_the_goal_exactly(allow_reverse):
    model = DifferentialDrive()
    rng = np.random.default_rng(11)
    for _ in range(20):
        start = np.array([*rng.uniform(-3, 3, 2), rng.uniform(-4, 4)])
        goal = np.array([*rng.uniform(-3, 3, 2), rng.uniform(-4, 4)])
        plan = plan_rtr(model, start, goal, allow_reverse=allow_reverse)
        assert [m.kind for m in plan] == ["rotate", "translate", "rotate"]
        x = _drive(model, start, plan)
        np.testing.assert_allclose(x[:2], goal[:2], rtol=0, atol=1e-12)
        assert abs(wrap_angle(x[2] - goal[2])) < 1e-12
        ws = model.max_symmetric_wheel_speed()
        for m in plan:
            assert m.duration >= 0
            assert np.all(np.abs(m.wheel_speeds) <= ws)
            if m.kind == "rotate":  # lecture: equal and opposite wheel speeds
                assert m.wheel_speeds[0] == -m.wheel_speeds[1] and abs(m.amount) <= math.pi
            else:
                assert m.wheel_speeds[0] == m.wheel_speeds[1]
        if allow_reverse:
            assert abs(plan[0].amount) <= math.pi / 2 + 1e-12


def test_rtr_durations():
    r, d, ws = 0.1, 0.5, 5.0
    plan = rtr([0, 0, 0], [0, 2, 0], r, d, ws)  # turn +90 deg, drive 2 m, turn -90 deg
    np.testing.assert_allclose([m.amount for m in plan], [math.pi / 2, 2.0, -math.pi / 2])
    turn = (math.pi / 2) * d / (2 * r * ws)
    np.testing.assert_allclose([m.duration for m in plan], [turn, 2.0 / (r * ws), turn])
    same = rtr([1, 1, 0.5], [1, 1, 0.5], r, d, ws)
    assert all(m.duration == 0 for m in same)
    back = rtr([0, 0, 0], [-1, 0, 0], r, d, ws, allow_reverse=True)
    assert back[0].duration == 0 and back[1].v < 0 and back[2].duration == 0


def test_rtr_bad_arguments():
    with pytest.raises(ValueError, match="wheel_speed"):
        rtr([0, 0, 0], [1, 1, 1], 0.1, 0.5, 0.0)
    with pytest.raises(ValueError, match="goal"):
        rtr([0, 0, 0], [1, 1], 0.1, 0.5, 1.0)
    with pytest.raises(ValueError, match="start"):
        rtr([0, np.nan, 0], [1, 1, 0], 0.1, 0.5, 1.0)
    with pytest.raises(ValueError, match="track_width"):
        wheel_speeds(1.0, 1.0, 0.1, -0.5)
    forward_only = DifferentialDrive(speed_range=(0.0, 1.0))
    with pytest.raises(ValueError, match="symmetric"):
        plan_rtr(forward_only, [0, 0, 0], [1, 1, 0])
