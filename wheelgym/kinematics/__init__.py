"""Kinematic analysis: differential-drive inverse kinematics and singularity analysis."""

from wheelgym.kinematics.diffdrive import Motion, body_velocity, rtr, wheel_speeds, wrap_angle

__all__ = ["Motion", "body_velocity", "rtr", "wheel_speeds", "wrap_angle"]
