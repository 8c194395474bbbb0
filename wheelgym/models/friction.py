"""Smoothed Coulomb friction (physics.md section 0, skid-steer notes)."""

from __future__ import annotations

import math

from numba import njit

_TWO_OVER_PI = 2.0 / math.pi


@njit(cache=True, inline="always")
def sgn_s(s, k_s):  # pragma: no cover - compiled
    """Smoothed sign ``(2/pi) arctan(k_s s)`` (physics.md section 0); in (-1, 1)."""
    return _TWO_OVER_PI * math.atan(k_s * s)


@njit(cache=True, inline="always")
def dsgn_s(s, k_s):  # pragma: no cover - compiled
    """Derivative of :func:`sgn_s` with respect to ``s``; largest, ``2 k_s / pi``, at 0."""
    ks = k_s * s
    return _TWO_OVER_PI * k_s / (1.0 + ks * ks)
