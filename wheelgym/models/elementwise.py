"""Compiled element-wise sin, cos, arctan, arctan2 and hypot with the same bits on every x86 CPU.

NumPy picks its transcendental loops by CPU and by array layout: on AVX-512 machines a
contiguous ``np.sin``, ``np.arctan2`` or ``np.power`` runs SVML's vector code, a strided one or
a Python float runs libm, and the two differ in the last bit. The reference trajectories
(:mod:`wheelgym.kinematics.references`) are evaluated one reference at a time (``evaluate``) and as
a batch of parameter columns (``evaluate_batch``, the vector env's track task), and the two
must agree bit for bit on any machine; so they, and the analytic baseline
(:mod:`wheelgym.envs.baseline`, whose batch must equal its single robot), call these
functions instead.

Each is a NumPy ufunc (any shape, broadcasting, scalars, ``out=``) whose loop is one compiled
scalar body built
from :func:`wheelgym.models.friction.sincos` and :func:`~wheelgym.models.friction.atan`:
plain IEEE arithmetic and fused multiply-adds, no libm and no table, so an element's value
depends on that element alone, not on the CPU's vector width nor on the array's layout.

| function      | accuracy (vs libm)                                   |
|---------------|------------------------------------------------------|
| ``sin, cos``  | 2 ulp for ``|x| < 1e8`` rad; libm's call beyond       |
| ``arctan``    | 1 ulp                                                |
| ``arctan2``   | 2 ulp plus the rounding of ``y / x`` (a few ulp)     |
| ``hypot``     | ``sqrt(x^2 + y^2)`` by one fused multiply-add, 1 ulp |

``hypot`` has no overflow guard (its arguments here are far below 1e150).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, vectorize

from wheelgym.integrators import fma
from wheelgym.models.friction import atan, sincos

__all__ = ["sin", "cos", "sincos_wide", "REDUCE_MAX", "arctan", "arctan2", "hypot", "wrap",
           "wrap_angle"]

_TWO_PI = 2.0 * math.pi

#: Beyond this |x| (rad) sin and cos call libm (the compiled reduction is exact below 2e8).
REDUCE_MAX = 1e8


@njit(cache=True, inline="always")
def sincos_wide(x):  # pragma: no cover - compiled
    """``(sin x, cos x)`` for any ``x``: :func:`~wheelgym.models.friction.sincos` below
    :data:`REDUCE_MAX`, libm beyond; the bits of :data:`sin` and :data:`cos`, for compiled
    callers."""
    if abs(x) < REDUCE_MAX:
        return sincos(x)
    return math.sin(x), math.cos(x)


@vectorize(["float64(float64)"], cache=True)
def _sin(x):  # pragma: no cover - compiled
    """``sin x`` (see the module table)."""
    return sincos_wide(x)[0]


@vectorize(["float64(float64)"], cache=True)
def _cos(x):  # pragma: no cover - compiled
    """``cos x`` (see the module table)."""
    return sincos_wide(x)[1]


@vectorize(["float64(float64)"], cache=True)
def _arctan(x):  # pragma: no cover - compiled
    """``arctan x`` (see the module table)."""
    return atan(x)


@vectorize(["float64(float64, float64)"], cache=True)
def _arctan2(y, x):  # pragma: no cover - compiled
    """Angle of ``(x, y)`` in ``[-pi, pi]`` with ``arctan2``'s quadrant and signed-zero
    conventions (``arctan2(+-0, -1) = +-pi``)."""
    if math.isnan(x) or math.isnan(y):
        return math.nan
    neg_y = y < 0.0 or (y == 0.0 and math.copysign(1.0, y) < 0.0)
    if x == 0.0 or (math.isinf(y) and not math.isinf(x)):
        if y == 0.0:
            a = 0.0 if math.copysign(1.0, x) > 0.0 else math.pi
        else:
            a = 0.5 * math.pi
        return -a if neg_y else a
    if math.isinf(x) and math.isinf(y):
        a = 0.25 * math.pi if x > 0.0 else 0.75 * math.pi
        return -a if neg_y else a
    # The compiler may evaluate both sides of a select (atan computes -1 / |t| for every t),
    # so every division sees a divisor far from 0 and NumPy's error flags stay clear. For
    # |q| < 1e-9, atan(q) rounds to q; beyond 1e300 to +-pi/2.
    q = y / (x if x != 0.0 else 1.0)
    aq = abs(q)
    small = aq < 1e-9
    huge = aq > 1e300
    r = atan(1.0 if (small or huge) else q)
    r = q if small else r
    r = math.copysign(0.5 * math.pi, q) if huge else r
    if x > 0.0:
        return r
    return r - math.pi if neg_y else r + math.pi


@njit(cache=True, inline="always")
def wrap(a):  # pragma: no cover - compiled
    """Angle ``a`` (rad) wrapped to ``(-pi, pi]``, the package's one convention (compiled).

    ``a`` itself (exact) when already there, else ``a - 2 pi ceil((a - pi) / (2 pi))``.
    """
    if -math.pi < a <= math.pi:
        return a
    return a - _TWO_PI * np.ceil((a - math.pi) / _TWO_PI)


@vectorize(["float64(float64)"], cache=True)
def _wrap_angle(a):  # pragma: no cover - compiled
    """:func:`wrap` element-wise."""
    return wrap(a)


@vectorize(["float64(float64, float64)"], cache=True)
def _hypot(x, y):  # pragma: no cover - compiled
    """``sqrt(x^2 + y^2)`` (see the module table)."""
    return math.sqrt(fma(x, x, y * y))


# the plain NumPy ufuncs behind numba's wrappers: a call costs what np.sin's does (0.25 us on
# one element, against 1.3 us through the wrapper)
sin: np.ufunc = _sin.ufunc
cos: np.ufunc = _cos.ufunc
arctan: np.ufunc = _arctan.ufunc
arctan2: np.ufunc = _arctan2.ufunc
hypot: np.ufunc = _hypot.ufunc
#: Angles wrapped to ``(-pi, pi]`` (:func:`wrap` element-wise), for NumPy and scalar code.
wrap_angle: np.ufunc = _wrap_angle.ufunc
