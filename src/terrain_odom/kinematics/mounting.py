"""Where the pose sensors sit on the robot: antenna lever arm, heading offset.

A GPS antenna is rarely at the robot's reference point, and a heading sensor
(IMU, compass) reads the robot's yaw plus an offset (its mounting, the
magnetic declination). With the robot's pose ``x, y, yaw`` and the sensor
mounting of ``pose_sensor`` in the configuration
(:class:`~terrain_odom.config.PoseSensorConfig`), the sensors measure

- ``x, y``: the antenna's position, ``p + R(yaw) @ a`` with the antenna at
  ``a = (antenna_x, antenna_y)`` in the robot frame (x forward, y left);
- ``yaw``: the sensor's heading, ``yaw + heading_offset`` (wrapped).

During a turn at rate ``omega`` an antenna ``antenna_x`` ahead of the
reference point moves sideways at ``omega * antenna_x``: exactly what an
ICR ``x_icr`` does, so an unmodelled lever arm is learned as one.

:func:`sensor_pose` gives what the sensors measure at a robot pose,
:func:`robot_pose` inverts it; the filters' measurement model over their
state, with its Jacobian, is :mod:`terrain_odom.estimation.pose_measurement`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.kinematics.integration import wrap_angle

__all__ = ["Mounting", "robot_pose", "rotation_with_derivative", "sensor_pose"]

_YAW = 2


@dataclass(frozen=True)
class Mounting:
    """Where the pose sensors sit on the robot (numbers; ``auto`` resolved).

    Attributes
    ----------
    antenna_x, antenna_y : float
        Position antenna in the robot frame, m (x forward, y left).
    heading_offset : float
        Measured heading minus the robot's yaw, rad.

    Examples
    --------
    >>> Mounting(0.5, 0.0, 0.0).antenna.tolist()
    [0.5, 0.0]
    """

    antenna_x: float = 0.0
    antenna_y: float = 0.0
    heading_offset: float = 0.0

    @property
    def antenna(self) -> np.ndarray:
        """Antenna position in the robot frame, m, shape (2,)."""
        return np.array([self.antenna_x, self.antenna_y], dtype=float)


def rotation_with_derivative(yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the rotation ``R(yaw)`` of the plane and ``dR/dyaw``, each shape (2, 2).

    Examples
    --------
    >>> rot, d_rot = rotation_with_derivative(np.pi / 2)
    >>> (rot @ [1.0, 0.0]).round(6).tolist(), (d_rot @ [1.0, 0.0]).round(6).tolist()
    ([0.0, 1.0], [-1.0, 0.0])
    """
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]]), np.array([[-s, -c], [c, -s]])


def sensor_pose(pose: ArrayLike, mounting: Mounting) -> np.ndarray:
    """Return what the sensors measure at robot pose ``x, y, yaw`` (antenna, heading).

    Parameters
    ----------
    pose : array_like, shape (3,)
        The robot's ``x, y`` (m) and yaw (rad).
    mounting : Mounting
        Antenna lever arm and heading offset.

    Returns
    -------
    ndarray, shape (3,)
        Antenna ``x, y`` (m) and sensor heading (rad, wrapped).

    Examples
    --------
    >>> sensor_pose([0.0, 0.0, 0.0], Mounting(0.5, 0.1, 0.2)).round(6).tolist()
    [0.5, 0.1, 0.2]
    """
    p = np.asarray(pose, dtype=float)
    rot, _ = rotation_with_derivative(p[_YAW])
    return np.r_[p[:2] + rot @ mounting.antenna, wrap_angle(p[_YAW] + mounting.heading_offset)]


def robot_pose(z: ArrayLike, mounting: Mounting, yaw: float | None = None) -> np.ndarray:
    """Invert :func:`sensor_pose`: the robot pose from antenna position and heading.

    Parameters
    ----------
    z : array_like, shape (3,)
        Measured antenna ``x, y`` and sensor heading; the heading may be NaN
        if ``yaw`` is given.
    mounting : Mounting
    yaw : float, optional
        The robot's yaw where ``z`` has no heading (e.g. an estimate).

    Returns
    -------
    ndarray, shape (3,)
        ``x, y, yaw`` of the robot (NaN where ``z`` has no position).

    Examples
    --------
    >>> m = Mounting(0.5, 0.1, 0.2)
    >>> robot_pose(sensor_pose([1.0, 2.0, 0.3], m), m).round(6).tolist()
    [1.0, 2.0, 0.3]
    """
    z = np.asarray(z, dtype=float)
    if np.isfinite(z[_YAW]):
        yaw = float(wrap_angle(z[_YAW] - mounting.heading_offset))
    if yaw is None:
        raise ValueError("robot_pose needs a heading: in z, or as yaw")
    rot, _ = rotation_with_derivative(yaw)
    return np.r_[z[:2] - rot @ mounting.antenna, yaw]
