"""Reference trajectories: pose, body twist and twist rate at time t.

Every reference is a planar curve ``p(s)`` traversed by a time law ``s(t)``. With the heading
tangent to the path (the default) the body twist is ``(v, 0, kappa v)`` with ``v = |p_s| sdot``
and the curvature ``kappa``, so nonholonomic robots can follow it (``vy = 0``); with a fixed
heading (``heading=<float>``, holonomic robots only) the twist is the world velocity rotated
into the body frame (docs/physics/conventions.md).

| output       | shape     | entries                   | units                 |
|--------------|-----------|---------------------------|-----------------------|
| ``pose``       | (..., 3)  | x, y, yaw (world)         | m, m, rad (unwrapped) |
| ``twist``      | (..., 3)  | vx, vy, wz (body)         | m/s, m/s, rad/s       |
| ``twist_rate`` | (..., 3)  | d/dt of the body twist    | m/s², m/s², rad/s²    |

``t`` may be a scalar or an array of any shape; the outputs carry its shape plus ``(3,)``.
Evaluating a whole episode at once (``evaluate(np.arange(n) * dt)``) is much cheaper than n
scalar calls.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from wheelgym.models import elementwise as ew

__all__ = [
    "Reference",
    "QuinticCircle",
    "Circle",
    "FigureEight",
    "Line",
    "PointToPoint",
    "quintic_scaling",
    "evaluate_batch",
]


def _positive(name: str, value: Any) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return v


def _finite(name: str, value: Any) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v


def _vec(name: str, value: Any, n: int) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return a


def _heading_arg(heading: Any) -> float | None:
    if isinstance(heading, str):
        if heading != "tangent":
            raise ValueError(f"heading must be 'tangent' or a finite angle (rad), got {heading!r}")
        return None
    return _finite("heading", heading)


def quintic_scaling(t: np.ndarray, duration: float, total: float = 1.0):
    """Rest-to-rest quintic ``s(t) = total (10 tau^3 - 15 tau^4 + 6 tau^5)``, ``tau = t/T``.

    ``t`` is clamped to ``[0, duration]``. Returns ``(s, sdot, sddot, sdddot)``. With
    ``total = 2 pi`` and ``duration = 60`` this is the three-wheel paper's beta(t) of section 5
    (``a3 = 20 pi / 60^3``, ``a4 = -30 pi / 60^4``, ``a5 = 12 pi / 60^5``;
    docs/physics/three-wheel.md TW-7).
    """
    # an array of durations broadcasts against t (evaluate_batch)
    T = duration if isinstance(duration, np.ndarray) else float(duration)
    # integer powers as products: NumPy's power of an array runs SVML on AVX-512 machines
    # and libm elsewhere (a different last bit); a product is exact IEEE arithmetic everywhere
    tau = np.clip(t / T, 0.0, 1.0)
    inside = (t > 0.0) & (t < T)
    tau2 = tau * tau
    u = 1.0 - tau
    s = total * (tau2 * tau) * (10.0 - 15.0 * tau + 6.0 * tau2)
    sd = total / T * 30.0 * tau2 * (u * u) * inside
    sdd = total / (T * T) * 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * tau2) * inside
    sddd = total / (T * T * T) * 60.0 * (1.0 - 6.0 * tau + 6.0 * tau2) * inside
    return s, sd, sdd, sddd


class Reference:
    """Base class: a curve ``p(s)`` (with three s-derivatives) and a time law ``s(t)``.

    Subclasses implement :meth:`_time_law` and :meth:`_curve`; ``heading`` is ``None`` for a
    path-tangent heading or a constant yaw (rad) for holonomic robots.

    Attributes:
        duration: the reference's nominal length in time (s): one lap for closed curves, the
            motion time for rest-to-rest references.
    """

    duration: float
    _heading: float | None = None
    #: Whether :func:`evaluate_batch` may turn the parameters into columns (scalars, and
    #: vectors indexed by their first axis only).
    _batchable: bool = False

    # subclasses --------------------------------------------------------------------
    def _time_law(self, t: np.ndarray):
        """``(s, sdot, sddot, sdddot)`` at times ``t``."""
        raise NotImplementedError

    def _curve(self, s: np.ndarray):
        """``(p, p_s, p_ss, p_sss)``, each ``(..., 2)``, at curve parameter ``s``."""
        raise NotImplementedError

    def _tangent_yaw(self, s: np.ndarray, p_s: np.ndarray) -> np.ndarray:
        """Unwrapped tangent heading; subclasses with a closed form override this."""
        return ew.arctan2(p_s[..., 1], p_s[..., 0])

    def _yaw_law(self, t, s, sd, sdd):
        """Prescribed ``(yaw, wz, wzdot)`` for a non-tangent heading; constant by default."""
        z = np.zeros_like(t)
        return self._heading + z, z, z

    # public ------------------------------------------------------------------------
    def evaluate(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose, body twist and body twist rate at time(s) ``t`` (s); see the module table."""
        t = np.asarray(t, dtype=np.float64)
        if not np.all(np.isfinite(t)):
            raise ValueError("t must be finite")
        s, sd, sdd, _ = self._time_law(t)
        p, ps, pss, psss = self._curve(s)
        pose = np.empty(t.shape + (3,))
        twist = np.empty(t.shape + (3,))
        rate = np.empty(t.shape + (3,))
        pose[..., :2] = p
        if self._heading is None:
            # heading tangent to the path: u = (v, 0, kappa v)
            sigma = ew.hypot(ps[..., 0], ps[..., 1])  # |p_s| > 0 on every curve here
            cross1 = ps[..., 0] * pss[..., 1] - ps[..., 1] * pss[..., 0]
            cross2 = ps[..., 0] * psss[..., 1] - ps[..., 1] * psss[..., 0]
            dot1 = ps[..., 0] * pss[..., 0] + ps[..., 1] * pss[..., 1]
            sigma_s = dot1 / sigma
            sigma3 = sigma * sigma * sigma
            kappa = cross1 / sigma3
            kappa_s = cross2 / sigma3 - 3.0 * cross1 * sigma_s / (sigma3 * sigma)
            v = sigma * sd
            vdot = sigma_s * (sd * sd) + sigma * sdd
            pose[..., 2] = self._tangent_yaw(s, ps)
            twist[..., 0] = v
            twist[..., 1] = 0.0
            twist[..., 2] = kappa * v
            rate[..., 0] = vdot
            rate[..., 1] = 0.0
            rate[..., 2] = kappa_s * sd * v + kappa * vdot
        else:
            # prescribed heading (holonomic): u_lin = R^T pdot,
            # udot_lin = R^T pddot - wz S R^T pdot with S = [[0, -1], [1, 0]]
            yaw, wz, wzd = self._yaw_law(t, s, sd, sdd)
            c, sn = ew.cos(yaw), ew.sin(yaw)
            pd = ps * sd[..., None]
            pdd = pss * (sd * sd)[..., None] + ps * sdd[..., None]
            pose[..., 2] = yaw
            twist[..., 0] = c * pd[..., 0] + sn * pd[..., 1]
            twist[..., 1] = -sn * pd[..., 0] + c * pd[..., 1]
            twist[..., 2] = wz
            rate[..., 0] = c * pdd[..., 0] + sn * pdd[..., 1] + wz * twist[..., 1]
            rate[..., 1] = -sn * pdd[..., 0] + c * pdd[..., 1] - wz * twist[..., 0]
            rate[..., 2] = wzd
        return pose, twist, rate

    def __call__(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.evaluate(t)

    def initial_pose(self) -> np.ndarray:
        """Pose at t = 0, shape (3,)."""
        return self.evaluate(0.0)[0]


class _CircleCurve(Reference):
    """``p(s) = c + R (sin s, -cos s)`` (counter-clockwise, tangent heading ``s``) or mirrored."""

    _batchable = True

    def __init__(self, radius: float, center: Any, clockwise: bool, phase: float) -> None:
        self.radius = _positive("radius", radius)
        self.center = _vec("center", center, 2)
        if not isinstance(clockwise, (bool, np.bool_)):
            raise TypeError(f"clockwise must be a bool, got {type(clockwise).__name__}")
        self.clockwise = bool(clockwise)
        self.phase = _finite("phase", phase)
        self._sgn = -1.0 if self.clockwise else 1.0

    def _curve(self, s):
        R, k = self.radius, self._sgn
        a = self.phase + k * s  # tangent heading
        ca, sa = ew.cos(a), ew.sin(a)
        # p = c + k R (sin a, -cos a): dp/ds = R (cos a, sin a) for both directions
        p = np.stack([self.center[0] + k * R * sa, self.center[1] - k * R * ca], axis=-1)
        ps = np.stack([R * ca, R * sa], axis=-1)
        pss = np.stack([-k * R * sa, k * R * ca], axis=-1)  # k = +-1: exact
        psss = np.stack([-R * ca, -R * sa], axis=-1)
        return p, ps, pss, psss

    def _tangent_yaw(self, s, p_s):
        return self.phase + self._sgn * s  # unwrapped


class QuinticCircle(_CircleCurve):
    """The three-wheel paper's circle (section 5, docs/physics/three-wheel.md TW-7).

    Heading ``beta(t) = a3 t^3 + a4 t^4 + a5 t^5`` rises from 0 to 2 pi over ``duration`` with
    zero rate and acceleration at both ends; the platform's x axis stays tangent to a circle of
    ``radius`` that starts at ``start`` heading along world x. Outside ``[0, duration]`` the
    robot rests at the start/end pose.

    Args:
        radius: circle radius (m), default 1.
        duration: time for one lap (s), default 60.
        start: starting position (m), default (0, 0).
        heading: ``"tangent"`` (default) or a constant yaw (rad) for holonomic robots.
    """

    def __init__(
        self,
        radius: float = 1.0,
        duration: float = 60.0,
        start: Any = (0.0, 0.0),
        heading: Any = "tangent",
    ) -> None:
        start = _vec("start", start, 2)
        r = _positive("radius", radius)
        super().__init__(r, start + np.array([0.0, r]), False, 0.0)
        self.duration = _positive("duration", duration)
        self._heading = _heading_arg(heading)

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """``(a3, a4, a5)`` of beta(t); the paper's values at duration 60 s."""
        T = self.duration
        return 20.0 * math.pi / T**3, -30.0 * math.pi / T**4, 12.0 * math.pi / T**5

    def _time_law(self, t):
        return quintic_scaling(t, self.duration, 2.0 * math.pi)


class Circle(_CircleCurve):
    """A circle at constant speed (periodic; ``duration`` is one lap).

    Args:
        radius: m (default 1).
        speed: path speed (m/s, default 0.5).
        center: (m), default (0, radius) so the robot starts at the origin heading along x.
        clockwise: direction of travel.
        heading: ``"tangent"`` (default) or a constant yaw (rad) for holonomic robots.
    """

    def __init__(
        self,
        radius: float = 1.0,
        speed: float = 0.5,
        center: Any = None,
        clockwise: bool = False,
        heading: Any = "tangent",
    ) -> None:
        r = _positive("radius", radius)
        if center is None:
            center = (0.0, -r if clockwise else r)
        super().__init__(r, center, clockwise, 0.0)
        self.speed = _positive("speed", speed)
        self._rate = self.speed / self.radius
        self.duration = 2.0 * math.pi / self._rate
        self._heading = _heading_arg(heading)

    def _time_law(self, t):
        z = np.zeros_like(t)
        return self._rate * t, self._rate + z, z, z


class FigureEight(Reference):
    """Lemniscate of Gerono ``p = c + (A sin wt, (A/2) sin 2wt)`` (periodic).

    The path speed varies along the curve (it never stops); ``duration = 2 pi / w`` is one lap.

    Args:
        size: half-width A (m, default 1); the eight spans 2A by A.
        period: time for one lap (s, default 30).
        center: (m), default (0, 0) (the crossing point, passed heading along +x +y).
        heading: ``"tangent"`` (default) or a constant yaw (rad) for holonomic robots.
    """

    _batchable = True

    def __init__(
        self, size: float = 1.0, period: float = 30.0, center: Any = (0.0, 0.0),
        heading: Any = "tangent",
    ) -> None:
        self.size = _positive("size", size)
        self.duration = _positive("period", period)
        self.center = _vec("center", center, 2)
        self._w = 2.0 * math.pi / self.duration
        self._heading = _heading_arg(heading)

    def _time_law(self, t):
        z = np.zeros_like(t)
        return t, 1.0 + z, z, z

    def _curve(self, s):
        A, w = self.size, self._w
        s1, c1 = ew.sin(w * s), ew.cos(w * s)
        s2, c2 = ew.sin(2 * w * s), ew.cos(2 * w * s)
        w2 = w * w  # a column in evaluate_batch: products, not NumPy's power (see above)
        p = np.stack([self.center[0] + A * s1, self.center[1] + 0.5 * A * s2], axis=-1)
        ps = np.stack([A * w * c1, A * w * c2], axis=-1)
        pss = np.stack([-A * w2 * s1, -2.0 * A * w2 * s2], axis=-1)
        psss = np.stack([-A * (w2 * w) * c1, -4.0 * A * (w2 * w) * c2], axis=-1)
        return p, ps, pss, psss

    def _tangent_yaw(self, s, p_s):
        # The tangent (cos ws, cos 2ws) turns by 0 net per lap. Where cos ws > 0 it points to
        # x > 0 and atan2 is continuous; in the x < 0 lobe (w s in (pi/2, 3pi/2)) it passes
        # angle pi, so measure it from -x there: atan2(-y, -x) + pi - 2 pi, which joins
        # continuously at the lobe ends (angle -pi/2).
        raw = ew.arctan2(p_s[..., 1], p_s[..., 0])
        alt = ew.arctan2(-p_s[..., 1], -p_s[..., 0]) - np.pi
        phase = np.mod(self._w * s, 2.0 * np.pi)
        inside = (phase > 0.5 * np.pi) & (phase < 1.5 * np.pi)
        return np.where(inside, alt, raw)


class Line(Reference):
    """A straight line at constant speed (extrapolates past ``duration = length / speed``).

    Args:
        start: (m), default (0, 0).
        direction: direction of travel (rad, world), default 0.
        speed: m/s (default 0.5).
        length: m (default 5), sets ``duration``.
        heading: ``"tangent"`` (default: yaw = direction) or a constant yaw (rad).
    """

    def __init__(
        self, start: Any = (0.0, 0.0), direction: float = 0.0, speed: float = 0.5,
        length: float = 5.0, heading: Any = "tangent",
    ) -> None:
        self.start = _vec("start", start, 2)
        self.direction = _finite("direction", direction)
        self.speed = _positive("speed", speed)
        self.length = _positive("length", length)
        self.duration = self.length / self.speed
        self._heading = _heading_arg(heading)
        self._e = np.array([math.cos(self.direction), math.sin(self.direction)])

    def _time_law(self, t):
        z = np.zeros_like(t)
        return self.speed * t, self.speed + z, z, z

    def _curve(self, s):
        z = np.zeros(np.shape(s) + (2,))
        return self.start + s[..., None] * self._e, self._e + z, z, z

    def _tangent_yaw(self, s, p_s):
        return np.full(np.shape(s), self.direction)


class PointToPoint(Reference):
    """Rest-to-rest motion from one pose to another in ``duration`` (quintic time law).

    Tangent heading (default): a cubic Hermite curve whose end tangents follow the start and
    goal headings (tangent length ``shape`` times the distance), so a nonholonomic robot can
    follow it. Holonomic (``holonomic=True``): a straight segment with the yaw interpolated by
    the same time law. Outside ``[0, duration]`` the robot rests at the start/goal pose.

    Args:
        start: (x, y, yaw) (m, m, rad).
        goal: (x, y, yaw).
        duration: s (default 10).
        holonomic: see above.
        shape: Hermite tangent length over distance (default 1).
    """

    def __init__(
        self, start: Any = (0.0, 0.0, 0.0), goal: Any = (2.0, 1.0, 0.0), duration: float = 10.0,
        holonomic: bool = False, shape: float = 1.0,
    ) -> None:
        self.start = _vec("start", start, 3)
        self.goal = _vec("goal", goal, 3)
        self.duration = _positive("duration", duration)
        if not isinstance(holonomic, (bool, np.bool_)):
            raise TypeError(f"holonomic must be a bool, got {type(holonomic).__name__}")
        self.holonomic = bool(holonomic)
        self.shape = _positive("shape", shape)
        self._heading = self.start[2] if self.holonomic else None
        dist = float(np.hypot(*(self.goal[:2] - self.start[:2])))
        if dist == 0.0 and not self.holonomic:
            raise ValueError("start and goal positions coincide: use holonomic=True to turn "
                             "on the spot")
        L = self.shape * dist
        self._m0 = L * np.array([math.cos(self.start[2]), math.sin(self.start[2])])
        self._m1 = L * np.array([math.cos(self.goal[2]), math.sin(self.goal[2])])

    def _time_law(self, t):
        return quintic_scaling(t, self.duration, 1.0)

    def _curve(self, s):
        p0, p1 = self.start[:2], self.goal[:2]
        if self.holonomic:
            d = p1 - p0
            z = np.zeros(np.shape(s) + (2,))
            return p0 + s[..., None] * d, d + z, z, z
        m0, m1 = self._m0, self._m1
        s_ = s[..., None]
        q2 = s_ * s_
        q3 = q2 * s_
        h00, h10, h01, h11 = 2 * q3 - 3 * q2 + 1, q3 - 2 * q2 + s_, -2 * q3 + 3 * q2, q3 - q2
        d00, d10, d01, d11 = 6 * q2 - 6 * s_, 3 * q2 - 4 * s_ + 1, -6 * q2 + 6 * s_, \
            3 * q2 - 2 * s_
        e00, e10, e01, e11 = 12 * s_ - 6, 6 * s_ - 4, -12 * s_ + 6, 6 * s_ - 2
        p = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
        ps = d00 * p0 + d10 * m0 + d01 * p1 + d11 * m1
        pss = e00 * p0 + e10 * m0 + e01 * p1 + e11 * m1
        psss = np.broadcast_to(12 * p0 + 6 * m0 - 12 * p1 + 6 * m1, p.shape)
        return p, ps, pss, psss

    def _tangent_yaw(self, s, p_s):
        # unwrap relative to the start heading
        raw = ew.arctan2(p_s[..., 1], p_s[..., 0])
        return self.start[2] + (raw - self.start[2] + np.pi) % (2 * np.pi) - np.pi

    def _yaw_law(self, t, s, sd, sdd):
        dyaw = self.goal[2] - self.start[2]
        return self.start[2] + s * dyaw, sd * dyaw, sdd * dyaw


def evaluate_batch(refs: Sequence[Reference], t: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Evaluate ``n`` references of one class in one NumPy pass: row ``r`` of ``t (n, W)`` on
    ``refs[r]``.

    Returns ``(pose, twist, rate)``, each ``(n, W, 3)``. Every parameter of the references
    becomes a column ``(n, 1)`` (a vector one ``(k, n, 1)``) that broadcasts against ``t``,
    so row ``r`` goes through the same element-wise operations as ``refs[r].evaluate(t[r])``;
    the environments' track task evaluates its reference windows this way (one call per
    class instead of one per robot). Classes whose vector parameters broadcast on the last
    axis (``Line``, ``PointToPoint``) are evaluated row by row.

    Raises:
        ValueError: ``refs`` is empty, mixes classes, or ``t`` is not ``(len(refs), W)``.
    """
    if len(refs) == 0:
        raise ValueError("refs must hold at least one Reference")
    cls = type(refs[0])
    if any(type(r) is not cls for r in refs):
        names = sorted({type(r).__name__ for r in refs})
        raise ValueError(f"refs must all be of one class, got {names}")
    t = np.asarray(t, dtype=np.float64)
    if t.ndim != 2 or t.shape[0] != len(refs):
        raise ValueError(f"t must have shape ({len(refs)}, W), got {t.shape}")
    if not cls._batchable:  # vector parameters broadcast on the last axis: one row at a time
        out = [r.evaluate(t[k]) for k, r in enumerate(refs)]
        return tuple(np.stack([o[j] for o in out]) for j in range(3))  # type: ignore[return-value]
    batch = object.__new__(cls)
    for name, v0 in vars(refs[0]).items():
        vals = [vars(r)[name] for r in refs]
        if v0 is None or isinstance(v0, str):
            if any(v != v0 for v in vals):
                raise ValueError(f"refs differ in {name!r}, which cannot be batched")
            setattr(batch, name, v0)
        elif isinstance(v0, np.ndarray):
            setattr(batch, name, np.stack(vals, axis=-1)[..., None])
        else:  # numbers and flags: a column
            setattr(batch, name, np.array(vals)[:, None])
    return batch.evaluate(t)
