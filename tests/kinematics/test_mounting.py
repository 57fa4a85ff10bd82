"""Where the pose sensors sit: what they measure at a robot pose, and back."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.mounting import (
    Mounting,
    robot_pose,
    rotation_with_derivative,
    sensor_pose,
)

MOUNT = Mounting(0.5, -0.2, np.radians(10.0))


def test_antenna_ahead_of_a_robot_facing_left_is_left_of_it():
    # robot at (1, 2) facing +y: an antenna 0.5 m ahead, 0.2 m to the right is at (1.2, 2.5)
    z = sensor_pose([1.0, 2.0, np.pi / 2], MOUNT)
    np.testing.assert_allclose(z, [1.2, 2.5, np.pi / 2 + np.radians(10.0)], atol=1e-12)
    np.testing.assert_allclose(robot_pose(z, MOUNT), [1.0, 2.0, np.pi / 2], atol=1e-12)


def test_robot_pose_of_a_position_alone_takes_the_given_yaw():
    z = np.array([1.2, 2.5, np.nan])
    np.testing.assert_allclose(robot_pose(z, MOUNT, yaw=np.pi / 2), [1.0, 2.0, np.pi / 2])
    with pytest.raises(ValueError, match="^robot_pose needs a heading: in z, or as yaw$"):
        robot_pose(z, MOUNT)


def test_robot_pose_inverts_sensor_pose_across_the_wrap():
    rng = np.random.default_rng(3)
    for yaw in (np.pi - 0.01, -np.pi + 0.01, *rng.uniform(-np.pi, np.pi, 20)):
        pose = np.array([*rng.normal(size=2), yaw])
        back = robot_pose(sensor_pose(pose, MOUNT), MOUNT)
        np.testing.assert_allclose(back[:2], pose[:2], atol=1e-12)
        assert abs(wrap_angle(back[2] - pose[2])) < 1e-12


@pytest.mark.parametrize("yaw", [0.0, 0.7, 3.1, -2.4])
def test_rotation_derivative_matches_finite_differences(yaw):
    rot, d_rot = rotation_with_derivative(yaw)
    eps = 1e-6
    numeric = (rotation_with_derivative(yaw + eps)[0] - rotation_with_derivative(yaw - eps)[0]) / (
        2 * eps
    )
    np.testing.assert_allclose(d_rot, numeric, atol=1e-9)
    np.testing.assert_allclose(rot @ rot.T, np.eye(2), atol=1e-15)
    assert np.linalg.det(rot) == pytest.approx(1.0)
