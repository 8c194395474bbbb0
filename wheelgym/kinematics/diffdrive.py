"""Differential-drive motion planning (diff-drive lecture section 5.1).

The wheel-speed relations themselves (lecture section 3) are :mod:`wheelgym.models.diffdrive`
(re-exported here as :func:`wheel_speeds` and :func:`body_velocity`).

* :func:`rtr` is the lecture's rotate-translate-rotate (RTR) method: the 3x2 Jacobian has no
  inverse, so a pose change is split into a turn on the spot toward the goal, a straight run,
  and a turn on the spot to the goal heading; in each motion the two wheel speeds are equal or
  opposite, and each motion is integrated exactly by any consistent scheme.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from wheelgym.models.diffdrive import body_velocity, wheel_speeds
from wheelgym.models.elementwise import wrap_angle

__all__ = ["wheel_speeds", "body_velocity", "Motion", "rtr", "plan_rtr", "wrap_angle"]


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return value


class Motion(NamedTuple):
    """One motion of an RTR plan: constant wheel speeds held for ``duration`` seconds.

    Attributes:
        kind: ``"rotate"`` or ``"translate"``.
        duration: time (s), >= 0 (0 for a motion that is not needed).
        wheel_speeds: ``(phidot_L, phidot_R)`` (rad/s).
        v: body speed (m/s).
        w: yaw rate (rad/s).
        amount: angle turned (rad) or signed distance driven (m).
    """

    kind: str
    duration: float
    wheel_speeds: tuple[float, float]
    v: float
    w: float
    amount: float


def rtr(
    start: Any,
    goal: Any,
    wheel_radius: float,
    track_width: float,
    wheel_speed: float,
    allow_reverse: bool = False,
) -> tuple[Motion, Motion, Motion]:
    """Rotate-translate-rotate decomposition of a pose change (diff-drive lecture 5.1).

    Args:
        start: start pose ``(x, y, yaw)`` (m, m, rad).
        goal: goal pose ``(x, y, yaw)``.
        wheel_radius: ``r`` (m).
        track_width: ``d`` (m).
        wheel_speed: magnitude of the wheel speeds used in every motion (rad/s), > 0.
        allow_reverse: drive the straight segment backwards when the goal lies behind (turns
            less than pi/2 then).

    Returns:
        Three :class:`Motion` records (rotate, translate, rotate). Holding each motion's wheel
        speeds for its duration, in order, takes the robot from ``start`` to ``goal`` exactly
        (the final yaw equals the goal's modulo 2 pi; each turn is at most pi).
    """
    r = _positive("wheel_radius", wheel_radius)
    d = _positive("track_width", track_width)
    ws = _positive("wheel_speed", wheel_speed)
    s = np.asarray(start, dtype=np.float64)
    g = np.asarray(goal, dtype=np.float64)
    for name, a in (("start", s), ("goal", g)):
        if a.shape != (3,):
            raise ValueError(f"{name} must be a pose (x, y, yaw), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite, got {a}")
    dx, dy = g[0] - s[0], g[1] - s[1]
    dist = math.hypot(dx, dy)
    if dist > 0.0:
        a1 = wrap_angle(math.atan2(dy, dx) - s[2])
        if allow_reverse and abs(a1) > 0.5 * math.pi:
            a1 = wrap_angle(a1 - math.pi)
            dist = -dist
    else:
        a1 = 0.0
    a2 = wrap_angle(g[2] - s[2] - a1)

    def rotate(angle: float) -> Motion:
        sgn = math.copysign(1.0, angle) if angle != 0.0 else 0.0
        w = sgn * 2.0 * r * ws / d  # lecture case 2: v_L = -v_R, w = v_R / a
        return Motion("rotate", abs(angle) * d / (2.0 * r * ws), (-sgn * ws, sgn * ws), 0.0, w,
                      angle)

    sgn = math.copysign(1.0, dist) if dist != 0.0 else 0.0
    translate = Motion("translate", abs(dist) / (r * ws), (sgn * ws, sgn * ws), sgn * r * ws, 0.0,
                       dist)  # lecture case 1: v = v_L = v_R
    return rotate(a1), translate, rotate(a2)


def plan_rtr(model: Any, start: Any, goal: Any, wheel_speed: float | None = None,
             allow_reverse: bool = False) -> tuple[Motion, Motion, Motion]:
    """Rotate-translate-rotate plan of a :class:`~wheelgym.models.DifferentialDrive` model.

    Args:
        model: the differential-drive model (its wheel radius, track width and limits).
        start: pose ``(x, y, yaw)``.
        goal: pose ``(x, y, yaw)``.
        wheel_speed: wheel-speed magnitude (rad/s); default the model's
            ``max_symmetric_wheel_speed()`` (every motion then stays inside the limits).
        allow_reverse: drive backwards when the goal lies behind.

    Returns:
        Three :class:`Motion` records; feeding each motion's ``wheel_speeds`` in
        ``WheelSpeeds`` mode for its ``duration`` reaches the goal exactly.

    Raises:
        ValueError: if the limits admit no symmetric wheel speed (a robot that cannot both
            turn on the spot and drive), or ``wheel_speed`` is not positive.
    """
    if wheel_speed is None:
        wheel_speed = model.max_symmetric_wheel_speed()
        if not wheel_speed > 0:
            raise ValueError(
                "the speed ranges of this DifferentialDrive admit no symmetric wheel "
                "speed (both signs must be reachable for rotate-translate-rotate)"
            )
    return rtr(start, goal, model.params.wheel_radius, model.params.track_width, wheel_speed,
               allow_reverse)
