"""Kinematic models of skid-steer robots, exact planar pose integration, sensor mounting.

:mod:`~terrain_odom.kinematics.mounting`: where the pose sensors sit on the robot.
"""

from terrain_odom.kinematics.integration import (
    arc_increment,
    arc_increment_jacobian,
    arc_increment_with_jacobian,
    compose,
    integrate,
    relative_pose,
    wrap_angle,
)
from terrain_odom.kinematics.models import (
    MODELS,
    KinematicModel,
    eccentricity,
    get_model,
    icr_from_chen,
    icr_from_martinez,
    icr_to_martinez,
    steering_efficiency,
    twist_edd_asym,
    twist_edd_sym,
    twist_icr,
    twist_icr_jacobian,
    twist_idd,
    twist_linear,
    twist_roc,
)

__all__ = [
    "MODELS",
    "KinematicModel",
    "arc_increment",
    "arc_increment_jacobian",
    "arc_increment_with_jacobian",
    "compose",
    "eccentricity",
    "get_model",
    "icr_from_chen",
    "icr_from_martinez",
    "icr_to_martinez",
    "integrate",
    "relative_pose",
    "steering_efficiency",
    "twist_edd_asym",
    "twist_edd_sym",
    "twist_icr",
    "twist_icr_jacobian",
    "twist_idd",
    "twist_linear",
    "twist_roc",
    "wrap_angle",
]
