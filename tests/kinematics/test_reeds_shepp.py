"""Reeds-Shepp paths (wheelgym.kinematics.reeds_shepp) and the car tracker that follows them.

Lengths against cases derived by hand, the symmetries of Reeds & Shepp (1990), a brute-force
check against exhaustive lattice searches, the samples (continuity, ends, curvature), and the
closed loop with the real Bicycle and Ackermann models on the goal task's distribution.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import pytest

from wheelgym.kinematics import (
    CarTracker,
    rear_wheel_steering,
    reeds_shepp_candidates,
    reeds_shepp_path,
    sample,
)
from wheelgym.kinematics.reeds_shepp import _candidates, _closes, path_from_segments
from wheelgym.models import Ackermann, Bicycle

R = 0.8  # turning radius of the planning tests (m)
PI = math.pi


def _wrap(a):
    return (np.asarray(a) + PI) % (2 * PI) - PI


def _random_pose(rng, span=3.0):
    return (rng.uniform(-span, span), rng.uniform(-span, span), rng.uniform(-PI, PI))


# ---------------------------------------------------------------------------- known cases
@pytest.mark.parametrize(
    ("goal", "length", "word"),
    [
        ((2.0, 0.0, 0.0), 2.0, "S+"),  # straight ahead: the distance
        ((-1.5, 0.0, 0.0), 1.5, "S-"),  # straight behind: reverse
        ((R, R, PI / 2), R * PI / 2, "L+"),  # quarter turn left
        ((R, -R, -PI / 2), R * PI / 2, "R+"),  # quarter turn right
        ((-R, R, -PI / 2), R * PI / 2, "L-"),  # quarter turn backwards
        ((0.0, 2 * R, PI), R * PI, "L+"),  # half turn
    ],
)
def test_known_lengths(goal, length, word):
    # Each value is also a lower bound: the length is at least the distance, and at least
    # R |yaw change| (|yawdot| <= |v| / R); the listed word attains it.
    path = reeds_shepp_path((0.0, 0.0, 0.0), goal, R)
    assert path.length == pytest.approx(length, abs=1e-12)
    assert path.word == word
    np.testing.assert_allclose(path.end_pose(), goal, atol=1e-12)


def test_turn_around_on_the_spot():
    """Back to the same position facing the other way, (0, 0, pi): the heading must turn by
    pi, so the length is >= pi R, and C|C|C attains it. The three circles of L+ R- L+ (centres
    A = (0, R), (sqrt(3) R, 0), B = (0, -R)) form an equilateral triangle of side 2R, so each
    arc is pi/3: total pi R (the CCC family's closing equation |sin(u/2)| = |AB| / 4R = 1/2)."""
    path = reeds_shepp_path((0.0, 0.0, 0.0), (0.0, 0.0, PI), R)
    assert path.length == pytest.approx(PI * R, abs=1e-12)
    assert len(path.segments) == 3 and path.cusps == 2
    assert {s.kind for s in path.segments} <= {"L", "R"}
    for seg in path.segments:
        assert abs(seg.length) == pytest.approx(PI * R / 3, abs=1e-12)
    assert reeds_shepp_path((0, 0, 0), (0, 0, 0), R).segments == ()


def test_start_pose_and_scale():
    rng = np.random.default_rng(3)
    for _ in range(50):
        goal = _random_pose(rng, 2.0)
        base = reeds_shepp_path((0, 0, 0), goal, R).length
        # a rigid motion of both poses changes nothing; scaling poses and radius scales it
        a, t = rng.uniform(-PI, PI), rng.uniform(-2, 2, 2)
        c, s = math.cos(a), math.sin(a)
        g2 = (t[0] + c * goal[0] - s * goal[1], t[1] + s * goal[0] + c * goal[1], goal[2] + a)
        assert reeds_shepp_path((t[0], t[1], a), g2, R).length == pytest.approx(base, abs=1e-9)
        k = 1.7
        assert reeds_shepp_path((0, 0, 0), (k * goal[0], k * goal[1], goal[2]), k * R).length == (
            pytest.approx(k * base, abs=1e-9))


def test_symmetries_give_equal_lengths():
    """Reflection (y, yaw negated), time flip (x, yaw negated) and backwards (start and goal
    swapped) of Reeds & Shepp section 7 keep the optimal length."""
    rng = np.random.default_rng(4)
    for _ in range(100):
        x, y, phi = _random_pose(rng, 2.5)
        d = pytest.approx(reeds_shepp_path((0, 0, 0), (x, y, phi), R).length, abs=1e-9)
        assert reeds_shepp_path((0, 0, 0), (x, -y, -phi), R).length == d
        assert reeds_shepp_path((0, 0, 0), (-x, y, -phi), R).length == d
        assert reeds_shepp_path((x, y, phi), (0, 0, 0), R).length == d


def test_every_candidate_closes_and_every_family_is_used():
    """Each solver's closing equations (all branches, all symmetries) end on the goal, and
    each family is the optimum somewhere."""
    rng = np.random.default_rng(5)
    families = set()
    for n in range(400):
        x, y, phi = _random_pose(rng, 3.0)
        path = reeds_shepp_path((0, 0, 0), (x, y, phi), 1.0)
        kinds = "".join(s.kind for s in path.segments)
        families.add(kinds.replace("L", "C").replace("R", "C"))
        if n >= 150:
            continue
        raw = _candidates(x, y, phi, time_flip=True)
        assert raw and all(_closes(k, v, x, y, phi) for k, v in raw)
        # the signed solvers contain the time flip: the flipped pass adds no candidate
        direct = {(k, tuple(np.round(v, 8))) for k, v in _candidates(x, y, phi)}
        assert {(k, tuple(np.round(v, 8))) for k, v in raw} == direct
    assert {"CSC", "CCC", "CCCC", "CCSC", "CSCC", "CCSCC"} <= families


def test_triangle_inequality_and_symmetry():
    """The optimum is a metric: no detour through a third pose is shorter."""
    rng = np.random.default_rng(6)
    for _ in range(200):
        a, b, c = (_random_pose(rng, 2.0) for _ in range(3))
        ac = reeds_shepp_path(a, c, R).length
        assert ac <= reeds_shepp_path(a, b, R).length + reeds_shepp_path(b, c, R).length + 1e-9
        assert reeds_shepp_path(c, a, R).length == pytest.approx(ac, abs=1e-9)


# ---------------------------------------------------------------------------- brute force
_ARCS = [k * PI / 4 for k in range(1, 5)]  # lattice arc angles (rad)
_LINES = [0.5, 1.0, 1.5, 2.0]  # lattice straights (in units of R)


def _lattice():
    """All primitives of the lattice: L, R (angles ``_ARCS``) and S (``_LINES`` R), forwards
    and backwards, as (kind, signed length in m)."""
    prims = []
    for sign in (1.0, -1.0):
        prims += [(k, sign * a * R) for k in "LR" for a in _ARCS]
        prims += [("S", sign * d * R) for d in _LINES]
    return prims


def _check_samples(path, step=0.05):
    smp = sample(path, step=step)
    p = smp.poses
    np.testing.assert_allclose(p[0], path.start, atol=1e-12)
    assert np.all(np.abs(p[-1, :2] - path.goal[:2]) <= 1e-9)
    assert abs(_wrap(p[-1, 2] - path.goal[2])) <= 1e-9
    ds = np.diff(smp.s)
    assert np.all(ds >= 0) and np.all(ds <= step + 1e-12)
    assert smp.s[-1] == pytest.approx(path.length, abs=1e-9)
    chord = np.hypot(*np.diff(p[:, :2], axis=0).T)
    dyaw = np.abs(_wrap(np.diff(p[:, 2])))
    # continuous; each step turns at most ds / R; a chord of an arc of curvature <= 1/R is at
    # least 2 R sin(ds / 2R) long (so no sample jumps sideways)
    assert np.all(chord <= ds + 1e-12)
    assert np.all(dyaw <= ds / path.radius + 1e-12)
    assert np.all(chord >= 2 * path.radius * np.sin(ds / (2 * path.radius)) - 1e-12)
    assert np.all(np.abs(smp.curvature) <= 1.0 / path.radius + 1e-12)
    np.testing.assert_allclose(_wrap(np.diff(p[:, 2])), smp.curvature[1:] * smp.direction[1:] * ds,
                               atol=1e-12)
    # motion along the heading, forwards or backwards as the direction says
    mid = p[:-1, 2] + 0.5 * smp.curvature[1:] * smp.direction[1:] * ds
    along = np.cos(mid) * np.diff(p[:, 0]) + np.sin(mid) * np.diff(p[:, 1])
    np.testing.assert_allclose(along, smp.direction[1:] * chord, atol=1e-12)
    assert np.count_nonzero(np.diff(smp.direction[1:])) == path.cusps


def test_brute_force_exhaustive_lattice():
    """Exhaustive search over all lattice paths of up to three primitives (24 primitives:
    13 824 paths): for 200 of the poses they reach (drawn at random), the Reeds-Shepp optimum is
    no longer than the shortest lattice path found to that pose, and its samples are right."""
    prims = _lattice()
    best: dict[tuple[float, float, float], tuple[float, tuple]] = {}
    for n in (1, 2, 3):
        for combo in itertools.product(prims, repeat=n):
            walk = path_from_segments(combo, R)
            key = tuple(np.round([*walk.goal[:2], _wrap(walk.goal[2])], 6))
            if key not in best or walk.length < best[key][0]:
                best[key] = (walk.length, walk.goal)
    assert len(best) > 2000
    rng = np.random.default_rng(7)
    keys = list(best)
    for idx in rng.choice(len(keys), size=200, replace=False):
        lattice_length, goal = best[keys[idx]]
        path = reeds_shepp_path((0.0, 0.0, 0.0), goal, R)
        assert path.length <= lattice_length + 1e-9
        _check_samples(path)


def test_brute_force_random_walks():
    """200 random walks of one to five primitives on a finer lattice (arcs of k pi/8, straights
    of k R/4, either direction): the optimum to each walk's end is no longer than the walk, and
    all candidates returned close with their samples right."""
    rng = np.random.default_rng(8)
    arcs = [k * PI / 8 for k in range(1, 9)]
    lines = [0.25 * k * R for k in range(1, 9)]
    equal = 0
    for _ in range(200):
        segs = []
        for _ in range(rng.integers(1, 6)):
            kind = "LSR"[rng.integers(3)]
            size = (lines if kind == "S" else [a * R for a in arcs])[rng.integers(8)]
            segs.append((kind, float(rng.choice([-1.0, 1.0])) * size))
        walk = path_from_segments(segs, R, start=_random_pose(rng, 1.0))
        paths = reeds_shepp_candidates(walk.start, walk.goal, R)
        assert paths[0].length <= walk.length + 1e-9
        equal += paths[0].length > walk.length - 1e-9
        assert all(p.length >= paths[0].length - 1e-9 for p in paths)
        assert paths[0].length == pytest.approx(reeds_shepp_path(walk.start, walk.goal, R).length)
        _check_samples(paths[0])
        _check_samples(paths[-1])
    assert equal > 20  # many short walks are themselves optimal: the bound is attained


# ---------------------------------------------------------------------------- closed loop
def test_rear_wheel_steering_signs():
    """On the path it steers the path's curvature ``atan(l kappa)`` in either direction; left
    of the path or heading left of it, it turns back toward the path in the driving direction
    (forwards: steer right; backwards: the yaw rate v tan(psi) / l turns the tail back)."""
    l, ke, kt = 0.5, 4.0, 4.0
    for d in (1, -1):
        assert rear_wheel_steering(0.0, 0.0, 0.7, d, l, ke, kt) == pytest.approx(math.atan(l * 0.7))
    assert rear_wheel_steering(0.1, 0.0, 0.0, 1, l, ke, kt) < 0  # left, forwards: right
    assert rear_wheel_steering(0.0, 0.1, 0.0, 1, l, ke, kt) < 0
    # backwards, left of the path: the rear axle leads, so turning its heading counter-
    # clockwise (yaw rate > 0 needs psi < 0 at v < 0) swings the axle right, back to the path
    assert rear_wheel_steering(0.1, 0.0, 0.0, -1, l, ke, kt) < 0
    assert rear_wheel_steering(0.0, 0.1, 0.0, -1, l, ke, kt) > 0


def _draw(seed):
    """The goal task's draw: start in [-1, 1]^2 with a random heading, goal 1-3 m away in a
    random direction with a random heading."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-1.0, 1.0, 2)
    yaw = rng.uniform(-PI, PI)
    d, a, gyaw = rng.uniform(1.0, 3.0), rng.uniform(-PI, PI), rng.uniform(-PI, PI)
    return np.array([x, y, yaw]), np.array([x + d * math.cos(a), y + d * math.sin(a), gyaw])


def _episode(model, seed, steps=500, dt=0.05, kick=None, psi0=0.0):
    start, goal = _draw(seed)
    x = np.zeros(model.state_dim)
    x[:3] = start
    if model.state_dim > 3:
        x[3] = psi0
    tracker = CarTracker.from_model(model)
    tracker.reset(x, goal)
    lo, hi = model.input_bounds()
    reached = None
    for k in range(steps):
        if reached is None and (math.hypot(*(x[:2] - goal[:2])) <= 0.1
                                and abs(_wrap(x[2] - goal[2])) <= 0.2):
            reached = k
        if kick is not None and k == kick:
            x[:2] += 0.3 * np.array([-math.sin(x[2]), math.cos(x[2])])  # pushed sideways
            x[2] += 0.3
        u = tracker.action(x, dt)
        assert np.all(u >= lo - 1e-12) and np.all(u <= hi + 1e-12)
        x = model.step(x, u, dt, 1)
    return reached, x, goal, tracker


@pytest.mark.parametrize(
    "make", [lambda: Bicycle(input_mode="VehicleSpeedSteeringAngle"), lambda: Ackermann()],
    ids=["Bicycle", "Ackermann"])
def test_closed_loop_goal_success(make):
    """Goal task distribution, 50 seeds, 500 steps of 0.05 s: within 0.1 m and 0.2 rad for
    >= 90% (measured: 50/50 for both), and the robot stops on the goal."""
    model = make()
    reached = 0
    for seed in range(50):
        k, x, goal, tracker = _episode(model, seed)
        reached += k is not None
        if k is not None:  # stopped there: still inside the tolerance at the end
            assert math.hypot(*(x[:2] - goal[:2])) <= 0.1 and abs(_wrap(x[2] - goal[2])) <= 0.2
            assert tracker.command(x).done and tracker.command(x).v == 0.0
    print(f"{type(model).__name__}: goal success {reached}/50")
    assert reached >= 45


def test_tracker_replans_and_other_modes():
    """A push off the path makes it replan and still arrive; an Ackermann starting with its
    steering at the limit and a bicycle in VehicleSpeedHeadingRate arrive too."""
    k, _, _, tracker = _episode(Bicycle(), 3, kick=40)
    assert k is not None and tracker.replans >= 1
    for seed in range(5):
        assert _episode(Ackermann(), seed, psi0=-math.radians(30))[0] is not None
        assert _episode(Bicycle(input_mode="VehicleSpeedHeadingRate"), seed)[0] is not None


def test_plan_and_step_are_fast():
    """One plan per episode and one tracking step per control step fit the env's budget."""
    model = Ackermann()
    start, goal = _draw(0)
    x = np.array([*start, 0.0])
    tracker = CarTracker.from_model(model)
    tracker.reset(x, goal)  # warm
    t0 = time.perf_counter()
    for _ in range(20):
        tracker.reset(x, goal)
    plan = (time.perf_counter() - t0) / 20
    t0 = time.perf_counter()
    for _ in range(200):
        tracker.action(x)
    step = (time.perf_counter() - t0) / 200
    print(f"plan {plan * 1e3:.2f} ms, tracking step {step * 1e6:.0f} us")
    assert plan < 0.05 and step < 0.002
