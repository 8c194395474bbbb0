"""Reference trajectories: twist and twist rate against finite differences of the pose."""

import math

import numpy as np
import pytest

from wheelgym.kinematics.references import (
    Circle,
    FigureEight,
    Line,
    PointToPoint,
    QuinticCircle,
    quintic_scaling,
)

REFS = {
    "quintic_circle": QuinticCircle(),
    "circle": Circle(radius=1.5, speed=0.4),
    "circle_cw": Circle(clockwise=True),
    "figure_eight": FigureEight(size=1.2, period=25.0),
    "line": Line(start=(1.0, -1.0), direction=0.4),
    "p2p": PointToPoint(start=(0.0, 0.0, 0.5), goal=(2.0, 1.0, -0.5), duration=8.0),
    "p2p_holonomic": PointToPoint(goal=(1.0, 2.0, 1.0), holonomic=True),
    "circle_fixed_heading": Circle(heading=0.3),
    "figure_eight_fixed_heading": FigureEight(heading=-1.0),
}


@pytest.mark.parametrize("name", sorted(REFS))
def test_twist_and_rate_match_finite_differences(name):
    ref = REFS[name]
    t = np.linspace(-1.0, 1.3 * ref.duration, 40001)
    dt = t[1] - t[0]
    pose, twist, rate = ref.evaluate(t)
    yaw = pose[:, 2]
    assert np.abs(np.diff(yaw)).max() < 0.01  # unwrapped, continuous
    dp = np.gradient(pose, dt, axis=0)
    c, s = np.cos(yaw), np.sin(yaw)
    body = np.stack([c * dp[:, 0] + s * dp[:, 1], -s * dp[:, 0] + c * dp[:, 1], dp[:, 2]], -1)
    inner = slice(3, -3)
    # central differences: O(dt^2) ~ 1e-8 relative; kinks of rest-to-rest laws at the ends
    assert np.abs(body - twist)[inner].max() < 1e-5
    drate = np.gradient(twist, dt, axis=0)
    assert np.abs(drate - rate)[inner].max() < 1e-3


@pytest.mark.parametrize("name", ["quintic_circle", "circle", "figure_eight", "line", "p2p"])
def test_tangent_heading_is_nonholonomic(name):
    _, twist, rate = REFS[name].evaluate(np.linspace(0, REFS[name].duration, 101))
    assert np.all(twist[:, 1] == 0.0) and np.all(rate[:, 1] == 0.0)
    assert np.all(twist[:, 0] >= 0.0)


def test_quintic_circle_is_the_papers():
    ref = QuinticCircle()
    a3, a4, a5 = ref.coefficients
    assert a3 == pytest.approx(20 * math.pi / 60**3)
    assert a4 == pytest.approx(-30 * math.pi / 60**4)
    assert a5 == pytest.approx(12 * math.pi / 60**5)
    t = np.linspace(0.0, 60.0, 7)
    pose, twist, rate = ref.evaluate(t)
    beta = a3 * t**3 + a4 * t**4 + a5 * t**5  # three-wheel paper section 5
    np.testing.assert_allclose(pose[:, 2], beta, atol=1e-12)
    np.testing.assert_allclose(twist[:, 2], 3 * a3 * t**2 + 4 * a4 * t**3 + 5 * a5 * t**4,
                               atol=1e-14)
    np.testing.assert_allclose(rate[:, 0], 1.0 * (6 * a3 * t + 12 * a4 * t**2 + 20 * a5 * t**3),
                               atol=1e-14)
    # on the unit circle through the origin, centre (0, 1)
    np.testing.assert_allclose(np.hypot(pose[:, 0], pose[:, 1] - 1.0), 1.0, atol=1e-12)
    # rest at both ends and outside [0, 60]
    for tt in (0.0, 60.0, -5.0, 70.0):
        _, tw, rt = ref.evaluate(tt)
        assert np.all(tw == 0.0) and np.all(rt == 0.0)
    np.testing.assert_allclose(ref.evaluate(70.0)[0], [0.0, 0.0, 2 * math.pi], atol=1e-12)


def test_shapes_and_constant_speed():
    ref = Circle(radius=2.0, speed=0.5)
    pose, twist, rate = ref.evaluate(np.zeros((4, 5)))
    assert pose.shape == twist.shape == rate.shape == (4, 5, 3)
    pose, twist, rate = ref.evaluate(3.0)
    assert pose.shape == (3,)
    np.testing.assert_allclose(twist, [0.5, 0.0, 0.25])
    np.testing.assert_allclose(rate, 0.0, atol=1e-15)
    assert ref.duration == pytest.approx(2 * math.pi * 2.0 / 0.5)


def test_point_to_point_reaches_goal():
    ref = REFS["p2p"]
    pose, twist, _ = ref.evaluate(ref.duration)
    np.testing.assert_allclose(pose, [2.0, 1.0, -0.5], atol=1e-12)
    np.testing.assert_allclose(twist, 0.0, atol=1e-15)
    np.testing.assert_allclose(ref.initial_pose(), [0.0, 0.0, 0.5], atol=1e-12)


def test_quintic_scaling_boundary_values():
    s, sd, sdd, _ = quintic_scaling(np.array([0.0, 5.0, 10.0]), 10.0, 3.0)
    np.testing.assert_allclose(s, [0.0, 1.5, 3.0])
    assert sd[0] == sd[2] == 0.0 and sdd[0] == sdd[2] == 0.0


@pytest.mark.parametrize(
    "make",
    [
        lambda: Circle(radius=0.0),
        lambda: Circle(speed=-1.0),
        lambda: Circle(heading="sideways"),
        lambda: QuinticCircle(duration=float("nan")),
        lambda: FigureEight(center=(0.0,)),
        lambda: Line(length=0.0),
        lambda: PointToPoint(goal=(0.0, 0.0, 1.0)),
        lambda: PointToPoint(start=(0.0, 0.0)),
    ],
)
def test_invalid_arguments_raise(make):
    with pytest.raises(ValueError):
        make()


def test_non_finite_time_raises():
    with pytest.raises(ValueError):
        Circle().evaluate(np.array([0.0, np.inf]))
    with pytest.raises(TypeError):
        Circle(clockwise="yes")


@pytest.mark.parametrize("make", [
    lambda r: Circle(radius=r.uniform(0.5, 2.0), speed=r.uniform(0.2, 1.0),
                     clockwise=bool(r.integers(2))),
    lambda r: FigureEight(size=r.uniform(1.0, 2.0), period=r.uniform(5.0, 20.0)),
    lambda r: QuinticCircle(radius=r.uniform(0.8, 1.5), duration=r.uniform(20.0, 40.0)),
    lambda r: Line(direction=r.uniform(-3.0, 3.0), speed=r.uniform(0.2, 1.0)),
    lambda r: PointToPoint(goal=(2.0, r.uniform(-1.0, 1.0), 0.3)),
], ids=["circle", "figure_eight", "quintic_circle", "line", "point_to_point"])
def test_evaluate_batch_is_each_reference_bit_for_bit(make):
    """The track task evaluates due rows of one class in one pass: row r of the batch must be
    ``refs[r].evaluate(t[r])`` exactly (parameters become broadcasting columns)."""
    from wheelgym.tasks import evaluate_batch

    rng = np.random.default_rng(11)
    refs = [make(rng) for _ in range(7)]
    t = rng.uniform(-1.0, 50.0, (7, 64))
    batch = evaluate_batch(refs, t)
    for r, ref in enumerate(refs):
        for got, want in zip(batch, ref.evaluate(t[r]), strict=True):
            assert got[r].tobytes() == want.tobytes()
    with pytest.raises(ValueError, match="one class"):
        evaluate_batch([refs[0], Circle()] if not isinstance(refs[0], Circle)
                       else [refs[0], Line()], t[:2])
    with pytest.raises(ValueError, match="shape"):
        evaluate_batch(refs, t[:3])
