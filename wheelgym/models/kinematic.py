"""Kinematic models: unicycle, bicycle, differential drive, Ackermann (docs/physics/kinematic.md).

The equations and input options are those of the kinematic-model reference (its ``VehicleInputs``
names); the differential-drive relations are the diff-drive lecture's section 3. Every model has
the pose state ``(x, y, yaw)`` (m, m, rad); :class:`Ackermann` adds the steering angle ``psi``.
There are no forces: the input is a velocity command and the derivative is the reference's ODE.

Saturation (applied inside the derivative, so ``derivative`` and ``step`` see the limited
command; :meth:`KinematicModel.effective_input` returns it):

* Unicycle, both modes: the command becomes a wheel speed ``phidot`` (``v / r`` in
  ``VehicleSpeedHeadingRate``), which is clipped to ``wheel_speed_range``; then ``v = r phidot``
  is clipped to ``speed_range``; the heading rate is clipped to ``[-max_heading_rate,
  max_heading_rate]``.
* Differential drive, both modes: the command becomes wheel speeds ``(phidot_L, phidot_R)``
  (``(v -+ w d / 2) / r`` in ``VehicleSpeedHeadingRate``), each is clipped to
  ``wheel_speed_range`` (as the motor drivers do; this can change the curvature), they are
  converted back to ``v = r (L + R) / 2``, ``w = r (R - L) / d``, and ``v`` alone is then
  clipped to ``speed_range``.
* Bicycle: ``v`` is clipped to ``speed_range``; in ``VehicleSpeedSteeringAngle`` the steering
  angle is clipped to ``[-max_steering_angle, max_steering_angle]``; in
  ``VehicleSpeedHeadingRate`` the heading rate is clipped to what that steering limit allows at
  the clipped speed, ``|w| <= |v| tan(max_steering_angle) / l`` (no turning at standstill).
* Ackermann: ``v`` is clipped to ``speed_range`` and ``psidot`` to ``[-max_steering_rate,
  max_steering_rate]``; the steering angle stops at ``+-max_steering_angle`` (``psidot`` is
  zeroed when it would push ``psi`` past the limit, and ``tan`` reads ``psi`` clipped to it).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from wheelgym.models._base import LENGTH, RATE, SPEED, Model, Params
from wheelgym.models.diffdrive import wheel_speeds
from wheelgym.models.kernels import kinematic as _kern
from wheelgym.models.kernels.kinematic import (
    K_ACK,
    K_BIC,
    K_DD,
    K_UNI,
    M_VSHR,
    M_VSSA,
    M_VSSR,
    M_WS,
    M_WSHR,
    NP,
    P_D,
    P_KIND,
    P_L,
    P_MODE,
    P_PSIDMAX,
    P_PSIMAX,
    P_R,
    P_VHI,
    P_VLO,
    P_WMAX,
    P_WSHI,
    P_WSLO,
)

__all__ = [
    "KinematicModel",
    "Unicycle",
    "UnicycleParams",
    "Bicycle",
    "BicycleParams",
    "DifferentialDrive",
    "DifferentialDriveParams",
    "Ackermann",
    "AckermannParams",
]

# Input mode codes stored at P_MODE of the packed array (kernels.kinematic).
_MODE_CODES = {
    "WheelSpeedHeadingRate": M_WSHR,
    "VehicleSpeedHeadingRate": M_VSHR,
    "VehicleSpeedSteeringAngle": M_VSSA,
    "WheelSpeeds": M_WS,
    "VehicleSpeedSteeringRate": M_VSSR,
}


def _check_range(obj: Params, name: str) -> tuple[float, float]:
    value = getattr(obj, name)
    if np.ndim(value) != 1 or len(value) != 2:
        raise ValueError(
            f"{type(obj).__name__}.{name} must be a (low, high) pair, got {value!r}"
        )
    lo, hi = float(value[0]), float(value[1])
    if not lo <= hi:
        raise ValueError(f"{type(obj).__name__}.{name} must have low <= high, got {value!r}")
    return lo, hi


def _check_wheel_speeds(obj: Params) -> None:
    """Wheeled models: both ranges are (low, high) pairs and the vehicle-speed range overlaps
    the speeds the wheels can reach (``wheel_radius * wheel_speed_range``)."""
    _check_range(obj, "speed_range")
    _check_range(obj, "wheel_speed_range")
    _intersect(obj, obj.speed_range, obj.wheel_radius * np.asarray(obj.wheel_speed_range),
               "speed_range and wheel_radius * wheel_speed_range")


def _check_steering_angle(obj: Params) -> None:
    """Car-like models: the steering limit must lie in (0, pi/2) (``tan`` of it is finite)."""
    if not obj.max_steering_angle < math.pi / 2:
        raise ValueError(
            f"{type(obj).__name__}.max_steering_angle must be in (0, pi/2), "
            f"got {obj.max_steering_angle!r}"
        )


def _intersect(obj: Params, a: tuple[float, float], b: tuple[float, float], what: str):
    lo, hi = max(a[0], b[0]), min(a[1], b[1])
    if lo > hi:
        raise ValueError(
            f"{type(obj).__name__}: {what} do not overlap ({a} and {b}); no speed is reachable"
        )
    return lo, hi


# ---------------------------------------------------------------------------- parameters
@dataclasses.dataclass(frozen=True)
class UnicycleParams(Params):
    """Unicycle parameters (kinematic-model reference, unicycle).

    | name              | default      | unit  | meaning                                  |
    |-------------------|--------------|-------|------------------------------------------|
    | wheel_radius      | 0.1          | m     | wheel radius ``r``                       |
    | speed_range       | (-1.0, 1.0)  | m/s   | vehicle speed limits ``v``               |
    | wheel_speed_range | (-15., 15.)  | rad/s | wheel speed limits ``phidot``            |
    | max_heading_rate  | 2.0          | rad/s | heading-rate limit ``abs(w)``            |
    """

    wheel_radius: float = 0.1
    speed_range: tuple[float, float] = (-1.0, 1.0)
    wheel_speed_range: tuple[float, float] = (-15.0, 15.0)
    max_heading_rate: float = 2.0

    _positive: ClassVar[tuple[str, ...]] = ("wheel_radius", "max_heading_rate")
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "wheel_radius": LENGTH, "speed_range": SPEED, "wheel_speed_range": RATE,
        "max_heading_rate": RATE,
    }
    _kind: ClassVar[int] = K_UNI

    def _check(self) -> None:
        _check_wheel_speeds(self)

    def pack(self) -> np.ndarray:
        p = np.zeros(NP)
        p[P_KIND] = self._kind
        p[P_R] = self.wheel_radius
        p[P_VLO], p[P_VHI] = self.speed_range
        p[P_WSLO], p[P_WSHI] = self.wheel_speed_range
        p[P_WMAX] = self.max_heading_rate
        return p


@dataclasses.dataclass(frozen=True)
class BicycleParams(Params):
    """Bicycle parameters (kinematic-model reference, bicycle).

    | name               | default      | unit | meaning                                   |
    |--------------------|--------------|------|-------------------------------------------|
    | wheelbase          | 0.5          | m    | axle distance ``l``                       |
    | speed_range        | (-1.0, 2.0)  | m/s  | vehicle speed limits ``v``                |
    | max_steering_angle | 0.5236       | rad  | steering limit ``abs(psi)`` (30 deg)      |
    """

    wheelbase: float = 0.5
    speed_range: tuple[float, float] = (-1.0, 2.0)
    max_steering_angle: float = math.radians(30.0)

    _positive: ClassVar[tuple[str, ...]] = ("wheelbase", "max_steering_angle")
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "wheelbase": LENGTH, "speed_range": SPEED,
    }
    _kind: ClassVar[int] = K_BIC

    def _check(self) -> None:
        _check_range(self, "speed_range")
        _check_steering_angle(self)

    def pack(self) -> np.ndarray:
        p = np.zeros(NP)
        p[P_KIND] = self._kind
        p[P_L] = self.wheelbase
        p[P_VLO], p[P_VHI] = self.speed_range
        p[P_PSIMAX] = self.max_steering_angle
        return p


@dataclasses.dataclass(frozen=True)
class DifferentialDriveParams(Params):
    """Differential-drive parameters (kinematic-model reference; diff-drive lecture).

    | name              | default      | unit  | meaning                                  |
    |-------------------|--------------|-------|------------------------------------------|
    | wheel_radius      | 0.1          | m     | wheel radius ``r``                       |
    | track_width       | 0.5          | m     | wheel distance ``d`` (lecture: ``2a``)   |
    | speed_range       | (-1.0, 1.0)  | m/s   | vehicle speed limits ``v``               |
    | wheel_speed_range | (-12., 12.)  | rad/s | limits of each wheel speed               |
    """

    wheel_radius: float = 0.1
    track_width: float = 0.5
    speed_range: tuple[float, float] = (-1.0, 1.0)
    wheel_speed_range: tuple[float, float] = (-12.0, 12.0)

    _positive: ClassVar[tuple[str, ...]] = ("wheel_radius", "track_width")
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "wheel_radius": LENGTH, "track_width": LENGTH, "speed_range": SPEED,
        "wheel_speed_range": RATE,
    }
    _kind: ClassVar[int] = K_DD

    def _check(self) -> None:
        _check_wheel_speeds(self)

    def pack(self) -> np.ndarray:
        p = np.zeros(NP)
        p[P_KIND] = self._kind
        p[P_R] = self.wheel_radius
        p[P_D] = self.track_width
        p[P_VLO], p[P_VHI] = self.speed_range
        p[P_WSLO], p[P_WSHI] = self.wheel_speed_range
        return p


@dataclasses.dataclass(frozen=True)
class AckermannParams(Params):
    """Ackermann parameters (kinematic-model reference, Ackermann).

    | name               | default      | unit  | meaning                                  |
    |--------------------|--------------|-------|------------------------------------------|
    | wheelbase          | 0.5          | m     | axle distance ``l``                      |
    | track_width        | 0.4          | m     | wheel distance (geometry only; the ODE   |
    |                    |              |       | of the reference does not use it)        |
    | speed_range        | (-1.0, 2.0)  | m/s   | vehicle speed limits ``v``               |
    | max_steering_angle | 0.5236       | rad   | steering limit ``abs(psi)`` (30 deg)     |
    | max_steering_rate  | 1.5          | rad/s | steering-rate limit ``abs(psidot)``      |
    """

    wheelbase: float = 0.5
    track_width: float = 0.4
    speed_range: tuple[float, float] = (-1.0, 2.0)
    max_steering_angle: float = math.radians(30.0)
    max_steering_rate: float = 1.5

    _positive: ClassVar[tuple[str, ...]] = (
        "wheelbase", "track_width", "max_steering_angle", "max_steering_rate"
    )
    _bounds: ClassVar[dict[str, tuple[float, float, str]]] = {
        "wheelbase": LENGTH, "track_width": LENGTH, "speed_range": SPEED,
        "max_steering_rate": RATE,
    }
    _kind: ClassVar[int] = K_ACK

    def _check(self) -> None:
        _check_range(self, "speed_range")
        _check_steering_angle(self)

    def pack(self) -> np.ndarray:
        p = np.zeros(NP)
        p[P_KIND] = self._kind
        p[P_D] = self.track_width
        p[P_L] = self.wheelbase
        p[P_VLO], p[P_VHI] = self.speed_range
        p[P_PSIMAX] = self.max_steering_angle
        p[P_PSIDMAX] = self.max_steering_rate
        return p


# ---------------------------------------------------------------------------- the models
class KinematicModel(Model):
    """Shared machinery of the kinematic models: input modes, saturation, bounds.

    Args:
        params: the parameter dataclass, a mapping, or ``None`` for the defaults.
        input_mode: one of the model's :attr:`input_modes` (the reference's names).
        **overrides: parameter overrides.

    Raises:
        ValueError: on an unknown ``input_mode`` (the message lists the valid ones).
    """

    state_names = ("x", "y", "yaw")
    #: Valid input modes and the names of their two inputs.
    input_modes: ClassVar[dict[str, tuple[str, str]]] = {}
    default_input_mode: ClassVar[str] = ""
    default_sim_dt = 0.05  # exact for constant commands up to RK4 round-off

    _k_deriv = _kern.KERNELS.deriv
    _k_step = _kern.KERNELS.step
    _k_step_par = _kern.KERNELS.step_par
    _k_step1 = _kern.KERNELS.step1
    _k_deriv1 = _kern.KERNELS.deriv1

    def __init__(
        self,
        params: Params | dict[str, Any] | None = None,
        input_mode: str | None = None,
        **overrides: Any,
    ):
        super().__init__(params, **overrides)
        mode = self.default_input_mode if input_mode is None else input_mode
        if not isinstance(mode, str):
            raise TypeError(
                f"input_mode must be a str, one of {list(self.input_modes)}, "
                f"got {type(mode).__name__}"
            )
        if mode not in self.input_modes:
            raise ValueError(
                f"unknown input_mode {mode!r} for {type(self).__name__}; valid modes: "
                f"{list(self.input_modes)}"
            )
        self.input_mode = mode
        self.input_names = self.input_modes[mode]
        self._p[P_MODE] = _MODE_CODES[mode]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r}, input_mode={self.input_mode!r})"

    def effective_input(self, x: Any, u: Any) -> np.ndarray:
        """The saturated command ``(v, w)`` (m/s, rad/s), plus ``psidot`` for Ackermann.

        Shape ``(..., 2)`` (``(..., 3)`` for Ackermann); this is what the derivative integrates.
        """
        X, U, lead = self._prepare(x, u)
        out = np.empty((X.shape[0], 3))
        _kern.k_effective(X, U, self._p, out)
        k = 3 if self.state_dim > 3 else 2
        return out[:, :k].reshape(lead + (k,))

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of the current mode's inputs in physical units.

        These are the reachable ranges after all limits (for example the unicycle's vehicle
        speed in ``VehicleSpeedHeadingRate`` is the intersection of ``speed_range`` and
        ``wheel_radius * wheel_speed_range``); environments scale actions in [-1, 1] onto them.
        """
        lo, hi = self._bounds()
        return np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)

    @property
    def input_high(self) -> np.ndarray:
        """Upper input bounds of the current mode (see :meth:`input_bounds`)."""
        return self.input_bounds()[1]

    @property
    def input_low(self) -> np.ndarray:
        """Lower input bounds of the current mode (see :meth:`input_bounds`)."""
        return self.input_bounds()[0]

    def action_bounds(self, actual: KinematicModel) -> tuple[np.ndarray, np.ndarray]:
        """Bounds an environment scales its actions onto when this is the nominal model and
        ``actual`` the robot drawn by domain randomisation (same class and mode).

        The actual model's :meth:`input_bounds` by default; :class:`Unicycle` keeps its own
        (the command's scale is fixed, the drawn wheel radius acts on the motion)."""
        return actual.input_bounds()

    def check_randomize(self, ranges: dict[str, tuple[float, float]]) -> None:
        """Raise ``ValueError`` for randomisation ranges (group -> factor range) that cannot
        change this model's motion in its input mode; nothing by default."""

    def validation_state(self) -> np.ndarray:
        """A generic start state inside every limit (for :mod:`wheelgym.validate`)."""
        x = np.zeros(self.state_dim)
        x[:3] = (0.3, -0.2, 0.4)
        return x

    def _bounds(self) -> tuple[tuple[float, float], tuple[float, float]]:
        raise NotImplementedError


class Unicycle(KinematicModel):
    """Unicycle (kinematic-model reference, unicycle equations).

    | index | state | unit |   | mode                      | inputs      | units        |
    |-------|-------|------|---|---------------------------|-------------|--------------|
    | 0     | x     | m    |   | ``WheelSpeedHeadingRate`` | (phidot, w) | rad/s, rad/s |
    | 1     | y     | m    |   | ``VehicleSpeedHeadingRate`` | (v, w)    | m/s, rad/s   |
    | 2     | yaw   | rad  |   |                           |             |              |

    ``xdot = v cos(yaw)``, ``ydot = v sin(yaw)``, ``yawdot = w`` with ``v = r phidot``.
    Saturation: module docstring. Default mode ``WheelSpeedHeadingRate`` (as the reference).

    The two modes differ in what the wheel radius does (the reference's equations): a wheel
    speed command ``phidot`` moves the robot at ``v = r phidot``, so the speed follows the
    actual radius; a vehicle speed command ``v`` is the speed, and the radius acts only
    through the wheel-speed limit (``|v| <= r max|phidot|``). At the nominal radius the same
    speed is one motion in both. In an environment with ``randomize`` (wheel_radius), the
    action keeps the nominal model's scale (:meth:`action_bounds`; the commanding side does
    not know the drawn radius): ``WheelSpeedHeadingRate`` then drives at ``r' phidot``, and
    ``VehicleSpeedHeadingRate`` is changed only by radii small enough for the wheel-speed
    limit to cut the commanded speed (a range that cannot reach it is refused,
    :meth:`check_randomize`).
    """

    params_type = UnicycleParams
    params: UnicycleParams
    input_modes = {
        "WheelSpeedHeadingRate": ("phidot", "w"),
        "VehicleSpeedHeadingRate": ("v", "w"),
    }
    default_input_mode = "WheelSpeedHeadingRate"

    def _bounds(self):
        p = self.params
        r = p.wheel_radius
        vlo, vhi = _intersect(p, p.speed_range, r * np.asarray(p.wheel_speed_range), "ranges")
        wm = p.max_heading_rate
        if self.input_mode == "WheelSpeedHeadingRate":
            return (vlo / r, -wm), (vhi / r, wm)
        return (vlo, -wm), (vhi, wm)

    def action_bounds(self, actual: KinematicModel) -> tuple[np.ndarray, np.ndarray]:
        """The nominal bounds: a wheel-speed (or vehicle-speed) command keeps its scale and
        the drawn radius acts on the motion (class docstring)."""
        return self.input_bounds()

    def check_randomize(self, ranges: dict[str, tuple[float, float]]) -> None:
        """In ``VehicleSpeedHeadingRate`` a wheel-radius factor range whose smallest radius
        still reaches every commanded speed (``f r wheel_speed_range`` covers the speed
        bounds) cannot change the motion: ``ValueError`` saying so."""
        if self.input_mode != "VehicleSpeedHeadingRate" or "wheel_radius" not in ranges:
            return
        p = self.params
        (vlo, _), (vhi, _) = self._bounds()
        wslo, wshi = p.wheel_speed_range
        # the limit cuts a commanded speed when f r wshi < vhi or f r wslo > vlo
        cuts = [vhi / (p.wheel_radius * wshi)] if wshi > 0 and vhi > 0 else []
        if wslo < 0 and vlo < 0:
            cuts.append(vlo / (p.wheel_radius * wslo))
        f_cut = max(cuts, default=0.0)
        lo, hi = ranges["wheel_radius"]
        if not lo < f_cut:
            raise ValueError(
                f"randomize['wheel_radius'] = ({lo:g}, {hi:g}) cannot change the motion of a "
                f"Unicycle in action_mode 'VehicleSpeedHeadingRate': the vehicle speed is "
                f"commanded, so the wheel radius acts only through the wheel-speed limit, "
                f"which cuts no commanded speed for factors >= {f_cut:.4g}; use action_mode "
                f"'WheelSpeedHeadingRate' (speed = radius x wheel speed) or a low factor below "
                f"{f_cut:.4g}"
            )


class Bicycle(KinematicModel):
    """Bicycle (kinematic-model reference, bicycle equations; reference point: rear axle).

    | index | state | unit |   | mode                          | inputs   | units      |
    |-------|-------|------|---|-------------------------------|----------|------------|
    | 0     | x     | m    |   | ``VehicleSpeedSteeringAngle`` | (v, psi) | m/s, rad   |
    | 1     | y     | m    |   | ``VehicleSpeedHeadingRate``   | (v, w)   | m/s, rad/s |
    | 2     | yaw   | rad  |   |                               |          |            |

    ``yawdot = v tan(psi) / l`` (turning radius ``l / tan(psi)``). Default mode
    ``VehicleSpeedSteeringAngle`` (as the reference). Saturation: module docstring.
    """

    params_type = BicycleParams
    params: BicycleParams
    input_modes = {
        "VehicleSpeedSteeringAngle": ("v", "psi"),
        "VehicleSpeedHeadingRate": ("v", "w"),
    }
    default_input_mode = "VehicleSpeedSteeringAngle"

    def _bounds(self):
        p = self.params
        vlo, vhi = p.speed_range
        if self.input_mode == "VehicleSpeedSteeringAngle":
            return (vlo, -p.max_steering_angle), (vhi, p.max_steering_angle)
        wm = max(abs(vlo), abs(vhi)) * math.tan(p.max_steering_angle) / p.wheelbase
        return (vlo, -wm), (vhi, wm)


class DifferentialDrive(KinematicModel):
    """Differential drive (kinematic-model reference; diff-drive lecture section 3).

    | index | state | unit |   | mode                        | inputs              | units  |
    |-------|-------|------|---|-----------------------------|---------------------|--------|
    | 0     | x     | m    |   | ``WheelSpeeds``             | (phidot_L, phidot_R) | rad/s |
    | 1     | y     | m    |   | ``VehicleSpeedHeadingRate`` | (v, w)              | m/s, rad/s |
    | 2     | yaw   | rad  |   |                             |                     |        |

    ``v = r (phidot_L + phidot_R) / 2``, ``w = r (phidot_R - phidot_L) / d``. Default mode
    ``WheelSpeeds`` (as the reference). Saturation: module docstring. Inverse kinematics:
    :mod:`wheelgym.models.diffdrive`; the rotate-translate-rotate plan:
    :func:`wheelgym.kinematics.diffdrive.plan_rtr`.
    """

    params_type = DifferentialDriveParams
    params: DifferentialDriveParams
    input_modes = {
        "WheelSpeeds": ("phidot_L", "phidot_R"),
        "VehicleSpeedHeadingRate": ("v", "w"),
    }
    default_input_mode = "WheelSpeeds"

    def _bounds(self):
        p = self.params
        r, d = p.wheel_radius, p.track_width
        wslo, wshi = p.wheel_speed_range
        if self.input_mode == "WheelSpeeds":
            return (wslo, wslo), (wshi, wshi)
        vlo, vhi = _intersect(p, p.speed_range, (r * wslo, r * wshi), "ranges")
        wm = r * (wshi - wslo) / d
        return (vlo, -wm), (vhi, wm)

    def wheel_speeds(self, v: Any, w: Any) -> np.ndarray:
        """Inverse kinematics ``(phidot_L, phidot_R)`` (rad/s) of a body velocity (no limits).

        See :func:`wheelgym.models.diffdrive.wheel_speeds`.
        """
        return wheel_speeds(v, w, self.params.wheel_radius, self.params.track_width)

    def max_symmetric_wheel_speed(self) -> float:
        """Largest ``s`` (rad/s) with wheel speeds ``+-s`` and ``v = +-r s`` inside all limits."""
        p = self.params
        wslo, wshi = p.wheel_speed_range
        vlo, vhi = p.speed_range
        return float(min(-wslo, wshi, -vlo / p.wheel_radius, vhi / p.wheel_radius))


class Ackermann(KinematicModel):
    """Ackermann steering (kinematic-model reference, Ackermann equations).

    | index | state | unit |   | index | input  | unit  |
    |-------|-------|------|---|-------|--------|-------|
    | 0     | x     | m    |   | 0     | v      | m/s   |
    | 1     | y     | m    |   | 1     | psidot | rad/s |
    | 2     | yaw   | rad  |   |       |        |       |
    | 3     | psi   | rad  |   |       |        |       |

    ``yawdot = v tan(psi) / l``, ``psidot`` integrates (the reference's only form; its mode is
    named ``VehicleSpeedSteeringRate`` here). Saturation: module docstring.
    """

    state_names = ("x", "y", "yaw", "psi")
    params_type = AckermannParams
    params: AckermannParams
    input_modes = {"VehicleSpeedSteeringRate": ("v", "psidot")}
    default_input_mode = "VehicleSpeedSteeringRate"

    def _bounds(self):
        p = self.params
        vlo, vhi = p.speed_range
        return (vlo, -p.max_steering_rate), (vhi, p.max_steering_rate)
