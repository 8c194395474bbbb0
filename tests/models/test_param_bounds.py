"""Physical bounds of every parameter dataclass."""

from __future__ import annotations

import pytest

from wheelgym.models._base import LENGTH, MASS
from wheelgym.models.caster_agv import CasterAGVParams
from wheelgym.models.kinematic import (
    AckermannParams,
    BicycleParams,
    DifferentialDriveParams,
    UnicycleParams,
)
from wheelgym.models.skid_steer import SkidSteerParams
from wheelgym.models.three_wheel import ThreeWheelParams

CLASSES = [ThreeWheelParams, SkidSteerParams, CasterAGVParams, UnicycleParams, BicycleParams,
           DifferentialDriveParams, AckermannParams]


@pytest.mark.parametrize(("cls", "field", "value"), [
    (ThreeWheelParams, "r", 1e30), (ThreeWheelParams, "d", 1e-5), (ThreeWheelParams, "m_b", 1e9),
    (ThreeWheelParams, "I_b", 1e-30), (ThreeWheelParams, "tau_drive_max", 1e12),
    (ThreeWheelParams, "axes", ((-1e3, 0.2), (-0.2, -0.2), (0.25, 0.0))),
    (SkidSteerParams, "r", 1e30), (SkidSteerParams, "m", 1e-9), (SkidSteerParams, "mu_l", 1e6),
    (SkidSteerParams, "g", 1e5), (SkidSteerParams, "k_s", 1e12),
    (CasterAGVParams, "r_c", 1e-30), (CasterAGVParams, "m_c", 1e30),
    (CasterAGVParams, "b_drive", 1e9),
    (UnicycleParams, "wheel_radius", 1e30), (UnicycleParams, "speed_range", (-1e9, 1.0)),
    (UnicycleParams, "max_heading_rate", 1e30),
    (BicycleParams, "wheelbase", 1e-30), (DifferentialDriveParams, "track_width", 1e-30),
    (DifferentialDriveParams, "wheel_radius", 1e30), (AckermannParams, "wheelbase", 1e-30),
    (AckermannParams, "max_steering_rate", 1e30),
])
def test_absurd_values_refused_naming_field_and_bound(cls, field, value):
    with pytest.raises(ValueError, match=rf"{cls.__name__}\.{field} must be within the physical "
                                         r"bounds \["):
        cls(**{field: value})


@pytest.mark.parametrize("cls", CLASSES)
def test_defaults_inside_bounds(cls):
    p = cls()
    assert p._bounds, "every parameter class declares bounds"
    assert set(p._bounds) <= set(cls.field_names())


@pytest.mark.parametrize("cls", [ThreeWheelParams, SkidSteerParams, CasterAGVParams])
def test_bounds_are_inclusive_at_plausible_extremes(cls):
    # a heavy robot at the mass bound and a small wheel at the length bound are accepted
    mass = {"ThreeWheelParams": "m_b", "SkidSteerParams": "m", "CasterAGVParams": "m_b"}
    cls(**{mass[cls.__name__]: MASS[1]})
    with pytest.raises(ValueError, match="physical bounds"):
        cls(**{mass[cls.__name__]: MASS[1] * 1.01})
    assert LENGTH[0] <= cls().r <= LENGTH[1]
