"""Gymnasium environments of wheelgym (one class per robot; documentation per class)."""

from wheelgym.envs.core import WheelCore
from wheelgym.envs.wheel_env import _DOC, WheelEnv

__all__ = ["WheelCore", "WheelEnv", "SkidSteerEnv", "ThreeWheelEnv", "CasterAGVEnv",
           "DiffDriveEnv", "UnicycleEnv", "BicycleEnv", "AckermannEnv"]


class SkidSteerEnv(WheelEnv):
    """Four-wheel skid-steer robot (Husky-like; docs/physics/skid-steer.md, Kozlowski-Pazderski).

    ## Description
    A 56.6 kg platform with four fixed wheels, two motors per side; turning skids the wheels
    sideways (lateral friction ``mu_l``), the ICR sits at ``x_icr`` (SS-1).

    ## Action Space
    ``Box(-1, 1, (4,))``. ``torque``: ``tau_k = a_k tau_max`` (30 N·m), motors [rear-left,
    front-left, front-right, rear-right]. ``velocity``: ``(vx, wz) = a * (1.0 m/s, 2.0 rad/s)``
    tracked by :class:`wheelgym.control.TwistController` (shape ``(2,)``). ``voltage``
    (implies ``motor="dc"``): terminal voltages ``V_k = a_k V_s`` (24 V), same motor order.

    Robot features: none (``vy = -x_icr wz`` is part of the twist). Speed limits: 2.5 m/s,
    5 rad/s. ``randomize`` groups: mass, inertia, friction, x_icr (absolute, m), wheel_radius,
    torque_limit.
    """

    robot = "SkidSteer"


class ThreeWheelEnv(WheelEnv):
    """Three-wheel redundantly actuated robot (docs/physics/three-wheel.md, three-wheel paper).

    ## Description
    A 23 kg platform on three off-centred steerable wheel modules (rear-left, rear-right,
    front), each with a drive and a steering motor: six motors for three degrees of freedom.

    ## Action Space
    ``torque``: ``Box(-1, 1, (6,))``, ``tau = a * (6, 6, 6, 3, 3, 3) N·m`` in motor order
    [drive_1..3, steer_1..3]. ``velocity``: ``Box(-1, 1, (3,))``, ``(vx, vy, wz) = a * (1.0,
    1.0, 2.0)`` (m/s, m/s, rad/s) tracked by :class:`wheelgym.control.TwistController`.
    ``voltage`` (implies ``motor="dc"``): ``Box(-1, 1, (6,))``, terminal voltages
    ``V_k = a_k V_s`` (24 V), same motor order.

    Robot features: cos psi_1..3, sin psi_1..3 (steering angles, -). Speed limits: 2.0 m/s,
    4 rad/s. ``internal_force`` is the norm of the null-space component of the motor torques,
    ``(I - J (J^T J)^-1 J^T) tau`` (TW-6, three-wheel paper (36)): torques that push the motors
    against each other through the ground. ``randomize`` groups: mass, inertia, friction,
    wheel_radius, caster_trail, torque_limit.
    """

    robot = "ThreeWheel"


class CasterAGVEnv(WheelEnv):
    """Differential-drive AGV with a passive trailing caster (docs/physics/caster-robots.md).

    ## Description
    A 23 kg platform on two driven wheels and a passive front caster whose swivel angle is a
    state (body origin at the axle midpoint).

    ## Action Space
    ``torque``: ``Box(-1, 1, (2,))``, ``tau = a * 6 N·m`` (left, right). ``velocity``:
    ``Box(-1, 1, (2,))``, ``(v, w) = a * (1.0 m/s, 2.0 rad/s)`` of the axle midpoint, tracked by
    :class:`wheelgym.control.TwistController`. ``voltage`` (implies ``motor="dc"``):
    ``Box(-1, 1, (2,))``, terminal voltages ``V = a * V_s`` (24 V; left, right).

    Robot features: cos sigma, sin sigma (caster swivel angle). Speed limits: 2.0 m/s, 5 rad/s.
    """

    robot = "CasterAGV"


class DiffDriveEnv(WheelEnv):
    """Kinematic differential drive (docs/physics/kinematic.md).

    ## Action Space
    ``Box(-1, 1, (2,))`` mapped onto the input mode's bounds: ``WheelSpeeds`` (phidot_L,
    phidot_R in rad/s, default) or ``VehicleSpeedHeadingRate`` (v m/s, w rad/s).
    No motors: ``motor_torque`` and ``joint_velocity`` are empty and ``energy`` stays 0.
    """

    robot = "DiffDrive"


class UnicycleEnv(WheelEnv):
    """Kinematic unicycle (docs/physics/kinematic.md); action modes ``WheelSpeedHeadingRate``
    (default) and ``VehicleSpeedHeadingRate``, scaled onto the nominal model's input bounds.
    With ``randomize`` (wheel_radius) a wheel-speed command drives at the drawn radius; a
    vehicle-speed command is changed only where the wheel-speed limit cuts it
    (:class:`wheelgym.models.Unicycle`)."""

    robot = "Unicycle"


class BicycleEnv(WheelEnv):
    """Kinematic bicycle (docs/physics/kinematic.md); action modes ``VehicleSpeedSteeringAngle``
    (default) and ``VehicleSpeedHeadingRate``, scaled onto the model's input bounds."""

    robot = "Bicycle"


class AckermannEnv(WheelEnv):
    """Kinematic Ackermann car (docs/physics/kinematic.md); action ``(v, psidot)`` scaled onto the
    model's bounds; the steering angle is an extra feature (cos, sin)."""

    robot = "Ackermann"


for _cls in (SkidSteerEnv, ThreeWheelEnv, CasterAGVEnv, DiffDriveEnv, UnicycleEnv, BicycleEnv,
             AckermannEnv):
    _cls.__doc__ = (_cls.__doc__ or "") + _DOC
