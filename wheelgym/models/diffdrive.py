"""Differential-drive inverse and forward kinematics (diff-drive lecture section 3).

:func:`wheel_speeds` inverts the lecture's forward relation ``v = r (w_L + w_R) / 2``,
``w = r (w_R - w_L) / d`` (``d`` the track width, the lecture's ``2a``); :func:`body_velocity`
is that forward relation. :class:`~wheelgym.models.DifferentialDrive` uses them; the
rotate-translate-rotate planner built on them is :mod:`wheelgym.kinematics.diffdrive`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["wheel_speeds", "body_velocity"]


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return value


def wheel_speeds(v: Any, w: Any, wheel_radius: float, track_width: float) -> np.ndarray:
    """Wheel speeds ``(phidot_L, phidot_R)`` (rad/s) of a body velocity ``(v, w)``.

    ``phidot_L = (v - w d / 2) / r``, ``phidot_R = (v + w d / 2) / r`` (diff-drive lecture
    section 3 inverted). ``v`` (m/s) and ``w`` (rad/s) broadcast; returns shape ``(..., 2)``.
    """
    r = _positive("wheel_radius", wheel_radius)
    d = _positive("track_width", track_width)
    v = np.asarray(v, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    return np.stack(np.broadcast_arrays((v - 0.5 * d * w) / r, (v + 0.5 * d * w) / r), axis=-1)


def body_velocity(phidot: Any, wheel_radius: float, track_width: float) -> np.ndarray:
    """Forward kinematics: ``(v, w)`` of wheel speeds ``(..., 2)`` (diff-drive lecture 3)."""
    r = _positive("wheel_radius", wheel_radius)
    d = _positive("track_width", track_width)
    ph = np.asarray(phidot, dtype=np.float64)
    if ph.ndim == 0 or ph.shape[-1] != 2:
        raise ValueError(f"phidot must have shape (..., 2), got {ph.shape}")
    return np.stack([0.5 * r * (ph[..., 0] + ph[..., 1]), r * (ph[..., 1] - ph[..., 0]) / d],
                    axis=-1)
