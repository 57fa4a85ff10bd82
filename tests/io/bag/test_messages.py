"""Conversions of ROS messages: yaw, track speeds, covariances, geodetic to east-north."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from terrain_odom.io.bag.messages import (
    Intrinsics,
    enu_from_geodetic,
    intrinsics,
    joint_speeds,
    match_joints,
    pose_sigmas,
    sensor_mounting,
    track_speeds,
    yaw_from_quaternion,
)


def test_yaw_matches_scipy_zyx_euler_with_roll_and_pitch() -> None:
    rng = np.random.default_rng(1)
    for q in Rotation.random(200, random_state=rng).as_quat():  # x, y, z, w
        expected = Rotation.from_quat(q).as_euler("ZYX")[0]
        assert yaw_from_quaternion(*(3.0 * q)) == pytest.approx(expected, abs=1e-9)  # unnormalised


def test_yaw_is_wrapped_to_minus_pi_pi() -> None:
    assert yaw_from_quaternion(0.0, 0.0, -1.0, 0.0) == math.pi  # not -pi
    assert yaw_from_quaternion(0.0, 0.0, math.sin(-1.0), math.cos(-1.0)) == pytest.approx(-2.0)


def test_track_speeds_invert_the_ideal_differential_drive() -> None:
    v_l, v_r = track_speeds(0.7, -1.3, 0.55)
    assert ((v_l + v_r) / 2, (v_r - v_l) / 0.55) == pytest.approx((0.7, -1.3))


def test_joint_speeds_average_each_side() -> None:
    names = ["front_left", "rear_left", "front_right", "rear_right", "caster"]
    left, right = match_joints(names, ["*left"]), match_joints(names, ["front_right", "rear_r*"])
    assert (left, right) == ([0, 1], [2, 3])
    assert joint_speeds([1.0, 2.0, -3.0, -5.0, 99.0], left, right, 0.2) == pytest.approx(
        (0.3, -0.8)
    )


def test_pose_sigmas_of_the_diagonal() -> None:
    cov = np.zeros(36)
    cov[[0, 7, 14, 35]] = [0.01, 0.04, 99.0, 0.0009]
    assert pose_sigmas(cov) == pytest.approx((0.1, 0.2, 0.03))


@pytest.mark.parametrize("lat0", [0.0, 45.0, -33.9])
def test_enu_small_offsets_follow_the_radii_of_curvature(lat0: float) -> None:
    # hand formulas for small offsets: north = M dlat, east = N cos(lat) dlon (WGS84)
    a, e2 = 6378137.0, 0.00669437999014
    s2 = math.sin(math.radians(lat0)) ** 2
    m = a * (1 - e2) / (1 - e2 * s2) ** 1.5
    n = a / math.sqrt(1 - e2 * s2)
    d = 1e-4  # deg: ~11 m, curvature effects below 0.1 mm
    enu = enu_from_geodetic(
        np.array([lat0 + d, lat0]), np.array([7.0, 7.0 + d]), np.zeros(2), (lat0, 7.0, 0.0)
    )
    np.testing.assert_allclose(enu[0, :2], [0.0, m * math.radians(d)], atol=2e-4)
    east = n * math.cos(math.radians(lat0)) * math.radians(d)
    np.testing.assert_allclose(enu[1, :2], [east, 0.0], atol=2e-4)


def test_enu_up_is_altitude_at_the_origin() -> None:
    enu = enu_from_geodetic(np.array([10.0]), np.array([20.0]), np.array([12.5]), (10.0, 20.0, 2.5))
    np.testing.assert_allclose(enu[0], [0.0, 0.0, 10.0], atol=1e-6)


def test_intrinsics_of_ros1_upper_case_camera_info() -> None:
    from rosbags.typesys import Stores, get_typestore

    t = get_typestore(Stores.ROS1_NOETIC).types
    stamp = t["builtin_interfaces/msg/Time"](sec=5, nanosec=0)
    roi = t["sensor_msgs/msg/RegionOfInterest"](
        x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
    )
    info = t["sensor_msgs/msg/CameraInfo"](
        header=t["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="cam"),
        height=24,
        width=32,
        distortion_model="plumb_bob",
        D=np.array([0.1, 0.0, 0.0, 0.0, 0.0]),
        K=np.array([40.0, 0, 15.5, 0, 41.0, 11.5, 0, 0, 1]),
        R=np.eye(3).ravel(),
        P=np.zeros(12),
        binning_x=0,
        binning_y=0,
        roi=roi,
    )
    assert intrinsics(info) == Intrinsics(32, 24, 40.0, 41.0, 15.5, 11.5, (0.1, 0.0, 0.0, 0.0, 0.0))


def test_sensor_mounting_yaw_is_what_a_mounted_imu_adds_to_the_base_yaw() -> None:
    # REP 145: an Imu reports its own frame's orientation; on a level base at yaw psi with the
    # IMU mounted at M, that is R_z(psi) @ M, whose yaw is psi plus the mounting's
    rng = np.random.default_rng(3)
    for mount, psi in zip(
        Rotation.random(100, random_state=rng), rng.uniform(-3, 3, 100), strict=True
    ):
        matrix = np.eye(4)
        matrix[:3, :3] = mount.as_matrix()
        matrix[:3, 3] = rng.normal(size=3)
        if abs(matrix[2, 0]) > 0.99:  # the IMU's x axis vertical: no yaw
            continue
        world = (Rotation.from_euler("z", psi) * mount).as_quat()
        antenna_x, antenna_y, offset = sensor_mounting(matrix)
        assert (antenna_x, antenna_y) == (matrix[0, 3], matrix[1, 3])
        turn = yaw_from_quaternion(*world) - psi - offset
        assert math.remainder(turn, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
