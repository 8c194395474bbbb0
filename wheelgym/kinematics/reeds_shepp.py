"""Reeds-Shepp curves: the shortest path of a car that drives forwards and backwards.

A car whose reference point (the rear axle) moves along its heading with curvature at most
``1 / R`` joins two poses by a path of at most five pieces: arcs of radius ``R`` turning left
(``L``) or right (``R``) and straight lines (``S``), each driven forwards or backwards, with
cusps (direction changes) between them. Reeds & Shepp (1990, "Optimal paths for a car that
goes both forwards and backwards", Pacific J. Math. 145) showed that the shortest one is in one
of these families (``|`` a cusp, ``u`` two arcs of equal length, ``pi/2`` an arc of a quarter
turn):

| family | words                                    | solver (this module)           |
|--------|------------------------------------------|--------------------------------|
| CSC    | ``CSC``                                  | ``_csc``: LSL, LSR             |
| CCC    | ``C|C|C``, ``CC|C``, ``C|CC``            | ``_ccc``: LRL                  |
| CCCC   | ``CCu|CuC``, ``C|CuCu|C``                | ``_cccc``: LRLR                |
| CCSC   | ``C|C(pi/2)SC``, ``CSC(pi/2)|C``         | ``_ccsc``: LRSL, LRSR          |
| CCSCC  | ``C|C(pi/2)SC(pi/2)|C``                  | ``_ccscc``: LRSLR              |

Each solver works in the start's frame scaled by ``R`` (start ``(0, 0, 0)``, goal
``(x, y, phi)``, unit radius) and, unlike the paper's formulas, keeps the segment lengths
signed: every branch of the closing equations is returned, whatever the signs, so one solver
covers all the forward/backward patterns of its word. The three symmetries of the paper
(section 7) give the other words:

| symmetry  | goal ``(x, y, phi)`` becomes                         | path becomes                  |
|-----------|------------------------------------------------------|-------------------------------|
| time flip | ``(-x, y, -phi)``                                    | every length negated          |
| reflect   | ``(x, -y, -phi)``                                    | ``L`` and ``R`` swapped       |
| backwards | ``(x cos phi + y sin phi, x sin phi - y cos phi, phi)`` | segments in reverse order  |

The time flip is built in: each solver already returns every sign branch, and the flipped
pass adds no candidate (a test checks it), so only reflection and backwards are enumerated.
Every candidate is checked by composing its segments (``_advance``) and kept only if it ends on
the goal, so a branch that does not close cannot be returned; the shortest (ties: fewer cusps,
then fewer segments) is the Reeds-Shepp path.

Units:

| quantity              | unit | note                                                    |
|-----------------------|------|---------------------------------------------------------|
| pose ``(x, y, yaw)``  | m, m, rad | rear-axle position and heading                     |
| ``radius``            | m    | minimum turning radius ``R`` of the plan               |
| ``Segment.length``    | m    | signed arc length: ``> 0`` forwards, ``< 0`` backwards  |
| curvature             | 1/m  | ``d yaw / d s`` per signed metre: ``+1/R`` on ``L``,    |
|                       |      | ``-1/R`` on ``R``, 0 on ``S``                           |
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any, NamedTuple

import numpy as np

from wheelgym.models.elementwise import wrap_angle

__all__ = [
    "Segment",
    "ReedsSheppPath",
    "PathSamples",
    "reeds_shepp_path",
    "path_from_segments",
    "reeds_shepp_candidates",
    "sample",
]

_PI = math.pi
_TWO_PI = 2.0 * math.pi
#: closing tolerance of a candidate in the unit-radius frame (its end pose against the goal)
_CLOSE_TOL = 1e-9
#: segments shorter than this (unit radius) are dropped
_ZERO = 1e-12

# A raw candidate: segment kinds and signed unit-radius lengths.
_Raw = tuple[str, tuple[float, ...]]


def _wrap(a: float) -> float:
    """``a`` wrapped to (-pi, pi] (``elementwise.wrap_angle``) as a Python float."""
    return float(wrap_angle(a))


def _polar(x: float, y: float) -> tuple[float, float]:
    return math.hypot(x, y), math.atan2(y, x)


def _acos(c: float) -> float | None:
    """``acos(c)``, with ``c`` up to round-off outside [-1, 1] clipped; ``None`` beyond."""
    if c > 1.0 + 1e-10 or c < -1.0 - 1e-10:
        return None
    return math.acos(min(1.0, max(-1.0, c)))


def _sqrt(a: float) -> float | None:
    if a < -1e-10:
        return None
    return math.sqrt(max(0.0, a))


def _e_center(h: float) -> tuple[float, float]:
    """Unit vector to the right of heading ``h``: ``e(h) = (sin h, -cos h)``."""
    return math.sin(h), -math.cos(h)


# ---------------------------------------------------------------------------- base solvers
# Notation (unit radius, start (0, 0, 0), goal (x, y, phi)): the left circle of the start has
# its centre at A = (0, 1); the left and right circles of the goal have their centres at
# B = (x - sin phi, y + cos phi) and D = (x + sin phi, y - cos phi). Driving an arc of one
# kind and then switching to the other kind at heading h moves the circle centre by
# +2 e(h) (L -> R) or -2 e(h) (R -> L), with e(h) = (sin h, -cos h); a straight of signed
# length u moves it by u (cos h, sin h). Writing the chain of centres from A to B or D gives
# each word's closing equation. Heading: L(t) adds t, R(t) subtracts t.


def _csc(x: float, y: float, phi: float) -> list[_Raw]:
    """``L(t) S(u) L(v)`` and ``L(t) S(u) R(v)``."""
    out: list[_Raw] = []
    # LSL: B - A = u (cos t, sin t)  (the two left circles joined by an outer tangent)
    rho, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    for u, t in ((rho, theta), (-rho, theta + _PI)):
        t = _wrap(t)
        out.append(("LSL", (t, u, _wrap(phi - t))))
    # LSR: D - A = u (cos t, sin t) + 2 e(t), |D - A|^2 = u^2 + 4 (an inner tangent);
    # the vector (u, -2) turned by t is D - A, so t = theta + atan2(2, u)
    rho, theta = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    r = _sqrt(rho * rho - 4.0)
    if r is not None:
        for u in (r, -r):
            t = _wrap(theta + math.atan2(2.0, u))
            out.append(("LSR", (t, u, _wrap(t - phi))))
    return out


def _ccc(x: float, y: float, phi: float) -> list[_Raw]:
    """``L(t) R(u) L(v)``: B - A = 2 e(t) - 2 e(t - u) = 4 sin(u/2) (cos m, sin m),
    ``m = t - u / 2`` (sum-to-product), so ``|sin(u/2)| = |B - A| / 4``."""
    out: list[_Raw] = []
    rho, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    if rho > 4.0 + 1e-10:
        return out
    a = math.asin(min(1.0, rho / 4.0))
    # sin(u/2) = +rho/4 with m = theta, or -rho/4 with m = theta + pi
    for u, m in ((2 * a, theta), (_TWO_PI - 2 * a, theta),
                 (-2 * a, theta + _PI), (-(_TWO_PI - 2 * a), theta + _PI)):
        t = _wrap(m + 0.5 * u)
        out.append(("LRL", (t, u, _wrap(phi - t + u))))
    return out


def _cccc(x: float, y: float, phi: float) -> list[_Raw]:
    """``L(t) R(a) L(b) R(v)`` with ``|a| = |b|``:
    D - A = 2 (e(h1) - e(h2) + e(h3)), ``h1 = t``, ``h2 = t - a``, ``h3 = h2 + b``.

    * ``b = -a`` (``CCu|CuC``): ``e(t) + e(t - 2a) = 2 cos(a) e(t - a)``, so
      ``D - A = 2 (2 cos a - 1) e(t - a)``.
    * ``b = a`` (``C|CuCu|C``): ``D - A = 2 (2 e(t) - e(t - a))``, ``|D - A|^2 = 4 (5 - 4 cos a)``.
    """
    out: list[_Raw] = []
    rho, theta = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    for s in (1.0, -1.0):  # 2 cos a - 1 = s rho / 2; e(t - a) along s (cos theta, sin theta)
        c = _acos(0.5 * (1.0 + 0.5 * s * rho))
        if c is None:
            continue
        for a in (c, -c):
            t = _wrap(theta + 0.5 * _PI + a + (0.0 if s > 0 else _PI))
            out.append(("LRLR", (t, a, -a, _wrap(t - 2.0 * a - phi))))
    c = _acos((20.0 - rho * rho) / 16.0)
    if c is not None:
        for a in (c, -c):
            # D - A = -2i e^{it} (2 - e^{-ia}) as complex numbers: arg = theta
            t = _wrap(theta + 0.5 * _PI - math.atan2(math.sin(a), 2.0 - math.cos(a)))
            out.append(("LRLR", (t, a, a, _wrap(t - phi))))
    return out


def _ccsc(x: float, y: float, phi: float) -> list[_Raw]:
    """``L(t) R(a) S(u) L(v)`` and ``L(t) R(a) S(u) R(v)`` with ``|a| = pi/2``.

    With ``h = t - a`` the heading on the straight, ``-2i e^{ia}`` is ``2`` for ``a = pi/2`` and
    ``-2`` for ``a = -pi/2`` (as complex numbers):

    * LRSL: ``B - A = e^{ih} (u + 2 sa + 2i)``, ``|B - A|^2 = (u + 2 sa)^2 + 4``;
    * LRSR: ``D - A = e^{ih} (u + 2 sa)``.
    """
    out: list[_Raw] = []
    rho, theta = _polar(x - math.sin(phi), y - 1.0 + math.cos(phi))
    r = _sqrt(rho * rho - 4.0)
    if r is not None:
        for sa in (1.0, -1.0):
            for w in (r, -r):  # w = u + 2 sa
                h = theta - math.atan2(2.0, w)
                t = _wrap(h + sa * 0.5 * _PI)
                out.append(("LRSL", (t, sa * 0.5 * _PI, w - 2.0 * sa, _wrap(phi - h))))
    rho, theta = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    for sa in (1.0, -1.0):
        for w, h in ((rho, theta), (-rho, theta + _PI)):  # w = u + 2 sa
            t = _wrap(h + sa * 0.5 * _PI)
            out.append(("LRSR", (t, sa * 0.5 * _PI, w - 2.0 * sa, _wrap(h - phi))))
    return out


def _ccscc(x: float, y: float, phi: float) -> list[_Raw]:
    """``L(t) R(a) S(u) L(b) R(v)`` with ``|a| = |b| = pi/2``:
    ``D - A = e^{ih} (u + 2 sa + 2 sb + 2i)`` (``h = t - a``), so
    ``|D - A|^2 = (u + 2 (sa + sb))^2 + 4``."""
    out: list[_Raw] = []
    rho, theta = _polar(x + math.sin(phi), y - 1.0 - math.cos(phi))
    r = _sqrt(rho * rho - 4.0)
    if r is None:
        return out
    for sa in (1.0, -1.0):
        for sb in (1.0, -1.0):
            k = 2.0 * (sa + sb)
            for w in (r, -r):  # w = u + k
                h = theta - math.atan2(2.0, w)
                a, b = sa * 0.5 * _PI, sb * 0.5 * _PI
                t = _wrap(h + a)
                out.append(("LRSLR", (t, a, w - k, b, _wrap(h + b - phi))))
    return out


_SOLVERS = (_csc, _ccc, _cccc, _ccsc, _ccscc)


# ---------------------------------------------------------------------------- composition
def _advance(pose: tuple[float, float, float], kind: str, s: float,
             radius: float = 1.0) -> tuple[float, float, float]:
    """Pose after one segment of signed length ``s`` (m) on a circle of ``radius`` (exact).

    ``L``: ``x += R (sin(h + s/R) - sin h)``, ``y += R (cos h - cos(h + s/R))``, ``h += s/R``;
    ``R``: the same with ``s/R`` and the circle side negated; ``S``: ``(x, y) += s (cos h, sin h)``.
    """
    x, y, h = pose
    if kind == "S":
        return x + s * math.cos(h), y + s * math.sin(h), h
    k = s / radius if kind == "L" else -s / radius
    h2 = h + k
    ds, dc = math.sin(h2) - math.sin(h), math.cos(h2) - math.cos(h)
    if kind == "L":
        return x + radius * ds, y - radius * dc, h2
    return x - radius * ds, y + radius * dc, h2


def _end(kinds: str, lengths: Sequence[float]) -> tuple[float, float, float]:
    pose = (0.0, 0.0, 0.0)
    for kind, s in zip(kinds, lengths, strict=True):
        pose = _advance(pose, kind, s)
    return pose


def _candidates(x: float, y: float, phi: float, time_flip: bool = False) -> list[_Raw]:
    """Every raw candidate of all solvers under reflection and backwards (the goal is
    transformed, solved, and the path transformed back; module docstring).

    The time flip adds nothing: each solver returns every sign branch of its closing
    equations, and those are symmetric under ``(x, phi, lengths) -> (-x, -phi, -lengths)``;
    ``time_flip=True`` adds the flipped pass anyway (for the tests that check this)."""
    out: list[_Raw] = []
    flips = (False, True) if time_flip else (False,)
    for back in (False, True):
        gx, gy, gp = x, y, phi
        if back:
            c, s = math.cos(phi), math.sin(phi)
            gx, gy = x * c + y * s, x * s - y * c
        for refl in (False, True):
            rx, ry, rp = (gx, -gy, -gp) if refl else (gx, gy, gp)
            for flip in flips:
                fx, fy, fp = (-rx, ry, -rp) if flip else (rx, ry, rp)
                for solver in _SOLVERS:
                    for kinds, lengths in solver(fx, fy, fp):
                        if flip:
                            lengths = tuple(-v for v in lengths)
                        if refl:
                            kinds = kinds.translate(_SWAP)
                        if back:
                            kinds, lengths = kinds[::-1], lengths[::-1]
                        out.append((kinds, lengths))
    return out


_SWAP = str.maketrans("LR", "RL")


def _closes(kinds: str, lengths: Sequence[float], x: float, y: float, phi: float) -> bool:
    ex, ey, eh = _end(kinds, lengths)
    return (abs(ex - x) <= _CLOSE_TOL and abs(ey - y) <= _CLOSE_TOL
            and abs(_wrap(eh - phi)) <= _CLOSE_TOL)


def _simplify(kinds: str, lengths: Sequence[float]) -> tuple[str, tuple[float, ...]]:
    """Drop empty segments and merge neighbours of the same kind and direction."""
    ks: list[str] = []
    ls: list[float] = []
    for k, v in zip(kinds, lengths, strict=True):
        if abs(v) <= _ZERO:
            continue
        if ks and ks[-1] == k and (ls[-1] > 0) == (v > 0):
            ls[-1] += v
        else:
            ks.append(k)
            ls.append(v)
    return "".join(ks), tuple(ls)


# ---------------------------------------------------------------------------- public API
class Segment(NamedTuple):
    """One piece of a Reeds-Shepp path.

    Attributes:
        kind: ``"L"`` (arc turning left), ``"S"`` (straight) or ``"R"`` (arc turning right).
        length: signed arc length (m): ``> 0`` driven forwards, ``< 0`` backwards.
    """

    kind: str
    length: float

    @property
    def direction(self) -> int:
        """Driving direction: ``+1`` forwards, ``-1`` backwards."""
        return 1 if self.length > 0 else -1


class ReedsSheppPath(NamedTuple):
    """A path of arcs of ``radius`` and straights from ``start`` to ``goal``.

    Attributes:
        segments: the pieces in driving order (no empty ones).
        radius: turning radius ``R`` of the arcs (m).
        start: start pose ``(x, y, yaw)`` (m, m, rad).
        goal: goal pose ``(x, y, yaw)``.
    """

    segments: tuple[Segment, ...]
    radius: float
    start: tuple[float, float, float]
    goal: tuple[float, float, float]

    @property
    def length(self) -> float:
        """Total arc length ``sum |length|`` (m)."""
        return float(sum(abs(s.length) for s in self.segments))

    @property
    def word(self) -> str:
        """The segment kinds with their directions, e.g. ``"L+R-L+"``."""
        return "".join(f"{s.kind}{'+' if s.length > 0 else '-'}" for s in self.segments)

    @property
    def cusps(self) -> int:
        """Number of direction changes."""
        d = [s.direction for s in self.segments]
        return sum(a != b for a, b in zip(d, d[1:], strict=False))

    def end_pose(self) -> tuple[float, float, float]:
        """The pose reached by composing the segments from ``start`` (yaw wrapped)."""
        pose = self.start
        for seg in self.segments:
            pose = _advance(pose, seg.kind, seg.length, self.radius)
        return pose[0], pose[1], _wrap(pose[2])


def _pose(p: Any, name: str) -> tuple[float, float, float]:
    a = np.asarray(p, dtype=np.float64).reshape(-1)
    if a.shape[0] < 3 or not np.all(np.isfinite(a[:3])):
        raise ValueError(f"{name} must be a finite pose (x, y, yaw), got {p!r}")
    return float(a[0]), float(a[1]), float(a[2])


def _local(start: Any, goal: Any, radius: float):
    r = float(radius)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"radius must be a positive finite number of metres, got {radius!r}")
    s, g = _pose(start, "start"), _pose(goal, "goal")
    # goal in the start's frame, scaled to unit radius
    c, sn = math.cos(s[2]), math.sin(s[2])
    dx, dy = g[0] - s[0], g[1] - s[1]
    return r, s, g, (c * dx + sn * dy) / r, (-sn * dx + c * dy) / r, _wrap(g[2] - s[2])


def _rank(kinds: str, lengths: tuple[float, ...]) -> tuple[float, int, int]:
    """Sort key: length (rounded, unit radius), then cusps, then segments."""
    cusps = sum((a > 0) != (b > 0) for a, b in zip(lengths, lengths[1:], strict=False))
    return round(sum(abs(v) for v in lengths), 9), cusps, len(kinds)


def _make(kinds: str, lengths: tuple[float, ...], r: float, s, g) -> ReedsSheppPath:
    segs = tuple(Segment(k, v * r) for k, v in zip(kinds, lengths, strict=True))
    return ReedsSheppPath(segs, r, s, g)


def reeds_shepp_candidates(start: Any, goal: Any, radius: float) -> list[ReedsSheppPath]:
    """Every closed-form candidate from ``start`` to ``goal`` (all families, all symmetries),
    without duplicates, shortest first (ties: fewer cusps, then fewer segments).

    Args:
        start: pose ``(x, y, yaw)`` (m, m, rad); extra entries (a steering angle) are ignored.
        goal: pose ``(x, y, yaw)``.
        radius: turning radius ``R`` (m), positive.

    Raises:
        ValueError: on a non-positive radius or a non-finite pose.
    """
    r, s, g, x, y, phi = _local(start, goal, radius)
    found: dict[tuple[str, tuple[float, ...]], tuple[str, tuple[float, ...]]] = {}
    for kinds, lengths in _candidates(x, y, phi):
        if _closes(kinds, lengths, x, y, phi):
            kinds, lengths = _simplify(kinds, lengths)
            found.setdefault((kinds, tuple(round(v, 9) for v in lengths)), (kinds, lengths))
    ranked = sorted(found.values(), key=lambda kl: _rank(*kl))
    return [_make(k, v, r, s, g) for k, v in ranked]


def reeds_shepp_path(start: Any, goal: Any, radius: float) -> ReedsSheppPath:
    """The shortest Reeds-Shepp path from ``start`` to ``goal`` with turning radius ``radius``.

    Args:
        start: pose ``(x, y, yaw)`` (m, m, rad); extra entries are ignored.
        goal: pose ``(x, y, yaw)``.
        radius: turning radius ``R`` (m), positive.

    Returns:
        The :class:`ReedsSheppPath` (first of :func:`reeds_shepp_candidates`); for
        ``start == goal`` it has no segments.

    Raises:
        ValueError: on a non-positive radius or a non-finite pose.
    """
    r, s, g, x, y, phi = _local(start, goal, radius)
    best: tuple[str, tuple[float, ...]] | None = None
    best_key = (math.inf, 0, 0)
    for kinds, lengths in _candidates(x, y, phi):
        total = sum(abs(v) for v in lengths)
        if total > best_key[0] + 1e-8 or not _closes(kinds, lengths, x, y, phi):
            continue
        kl = _simplify(kinds, lengths)
        key = _rank(*kl)
        if key < best_key:
            best, best_key = kl, key
    if best is None:  # pragma: no cover - the CSC family closes every pose pair
        raise RuntimeError(f"no Reeds-Shepp path closed from {start!r} to {goal!r}")
    return _make(*best, r, s, g)


class PathSamples(NamedTuple):
    """Poses along a path, every ``step`` metres of arc length or closer.

    Attributes:
        poses: ``(N, 3)`` poses ``(x, y, yaw)`` (m, m, rad; yaw wrapped to (-pi, pi]).
        direction: ``(N,)`` driving direction ``+1``/``-1`` of the segment each pose ends.
        curvature: ``(N,)`` ``d yaw / d s`` along the signed arc length (1/m) there.
        s: ``(N,)`` arc length driven from the start (m, non-decreasing).
        segment: ``(N,)`` index of that segment (``0`` for the start pose).
    """

    poses: np.ndarray
    direction: np.ndarray
    curvature: np.ndarray
    s: np.ndarray
    segment: np.ndarray


def sample(path: ReedsSheppPath, start: Any = None, step: float = 0.05) -> PathSamples:
    """Sample ``path`` from ``start`` (default ``path.start``) at most ``step`` metres apart.

    Each segment is split evenly; its end pose is exact (the closed form of ``_advance`` from
    the segment's start), so the first pose is ``start``, the last the end of the path, and a
    cusp appears once, as the last pose of the segment that ends there.

    Args:
        path: a :class:`ReedsSheppPath`.
        start: pose ``(x, y, yaw)`` to drive the segments from.
        step: largest arc length between poses (m), positive.
    """
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"step must be a positive number of metres, got {step!r}")
    pose = path.start if start is None else _pose(start, "start")
    R = path.radius
    segs = path.segments
    first = segs[0] if segs else Segment("S", 0.0)
    poses = [(pose[0], pose[1], _wrap(pose[2]))]
    direction = [first.direction]
    curvature = [_curv(first.kind, R)]
    s_acc = [0.0]
    index = [0]
    total = 0.0
    for i, seg in enumerate(segs):
        n = max(1, math.ceil(abs(seg.length) / step - 1e-9))
        kappa = _curv(seg.kind, R)
        for k in range(1, n + 1):
            p = _advance(pose, seg.kind, seg.length * k / n, R)
            poses.append((p[0], p[1], _wrap(p[2])))
            direction.append(seg.direction)
            curvature.append(kappa)
            s_acc.append(total + abs(seg.length) * k / n)
            index.append(i)
        pose = _advance(pose, seg.kind, seg.length, R)
        total += abs(seg.length)
    return PathSamples(np.array(poses), np.array(direction, dtype=np.int64),
                       np.array(curvature), np.array(s_acc), np.array(index, dtype=np.int64))


def _curv(kind: str, radius: float) -> float:
    return 1.0 / radius if kind == "L" else (-1.0 / radius if kind == "R" else 0.0)


def path_from_segments(segments: Iterable[tuple[str, float]], radius: float,
                       start: Any = (0.0, 0.0, 0.0)) -> ReedsSheppPath:
    """A :class:`ReedsSheppPath` made of given ``(kind, signed length)`` pieces (its goal is
    where they end); for lattice walks and tests."""
    s = _pose(start, "start")
    segs = tuple(Segment(str(k), float(v)) for k, v in segments)
    path = ReedsSheppPath(segs, float(radius), s, s)
    return path._replace(goal=path.end_pose())
