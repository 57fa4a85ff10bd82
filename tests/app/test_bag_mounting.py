"""``import_bag``: the pose sensors' mounting from ``/tf_static`` and the pose noise per component."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from terrain_odom.app.bag_import import import_bag
from terrain_odom.config import load_config
from terrain_odom.errors import InputFileError
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.writer import MessageFactory, write_bag

M = MessageFactory()
BASE = 1_700_000_000 * 10**9
STEP = 100_000_000
OFFSET = math.radians(10.0)
# base_link -> mast: 0.3 m ahead, 0.5 m up, turned 90 deg left; mast -> gps: 0.2 m along the
# mast's x (the base's y), 0.1 m along its y (the base's -x): the antenna at (0.2, 0.2) in the base
MAST = ("base_link", "mast", (0.3, 0.0, 0.5), Rotation.from_euler("z", 90, degrees=True).as_quat())
GPS = ("mast", "gps", (0.2, 0.1, 0.3), (0.0, 0.0, 0.0, 1.0))
# base_link -> imu: mounted upside down (rolled half a turn) and turned 10 deg left
IMU = ("base_link", "imu", (0.0, 0.0, 0.2), Rotation.from_euler("ZX", [OFFSET, math.pi]).as_quat())


def _bag(folder: Path, static: list | None, extra: list) -> Path:
    """Odometry wheels at 10 Hz for 1 s, ``/tf_static`` (if given) and ``extra`` records."""
    records = [
        ("/odom", "nav_msgs/msg/Odometry", BASE + k * STEP, M.odometry(BASE + k * STEP))
        for k in range(10)
    ]
    if static is not None:
        records.append(("/tf_static", "tf2_msgs/msg/TFMessage", BASE, M.tf_static(BASE, static)))
    return write_bag(folder / "m.bag", "ros1", sorted(records + extra, key=lambda r: r[2]))


def _fixes_and_headings() -> list:
    fixes = [
        (
            "/fix",
            "sensor_msgs/msg/NavSatFix",
            BASE + k * STEP + 1000,
            M.nav_sat_fix(BASE + k * STEP + 1000, 1e-5 * k, 0.0, sigma=0.4),
        )
        for k in range(1, 9, 2)
    ]
    imu = [
        ("/imu", "sensor_msgs/msg/Imu", BASE + k * STEP + 2000, M.imu(BASE + k * STEP + 2000, 0.1))
        for k in range(9)
    ]
    return fixes + imu


GPS_IMU = ImportOptions("/odom", pose_topic="/fix", heading_topic="/imu", track_width=0.5)


def test_antenna_and_imu_mounting_from_tf_static(tmp_path: Path) -> None:
    bag = _bag(tmp_path, [MAST, GPS, IMU], _fixes_and_headings())
    result = import_bag(bag, tmp_path / "out", GPS_IMU, progress=False)
    cfg = load_config(result.config_yaml)
    sensor = cfg.pose_sensor
    assert (sensor.antenna_x, sensor.antenna_y) == pytest.approx((0.2, 0.2), abs=1e-12)
    assert sensor.heading_offset == pytest.approx(OFFSET, abs=1e-12)
    assert result.fill_keys == ()
    assert "# pose_sensor.* from /tf_static" in result.config_yaml.read_text()
    sources = json.loads(result.import_json.read_text())["config_sources"]
    assert sources["pose_sensor.antenna_x"] == "/tf_static base_link -> gps"
    assert sources["pose_sensor.heading_offset"] == "/tf_static base_link -> imu (yaw)"
    assert sources["robot.track_width"] == "--track-width"


def test_pose_noise_per_component_for_both_estimators(tmp_path: Path) -> None:
    bag = _bag(tmp_path, [MAST, GPS, IMU], _fixes_and_headings())
    result = import_bag(bag, tmp_path / "out", GPS_IMU, progress=False)
    cfg = load_config(result.config_yaml)
    # position from the NavSatFix covariance (0.4 m), yaw from the Imu's (0.01 rad)
    assert (cfg.ekf.sigma_r.x, cfg.ekf.sigma_r.y, cfg.ekf.sigma_r.yaw) == pytest.approx(
        (0.4, 0.4, 0.01)
    )
    # the slip EKF measures the change between two independent measurements: sqrt(2) as much
    slip = cfg.slip_ekf.sigma_r
    assert (slip.dx, slip.dy, slip.dyaw) == pytest.approx(
        np.sqrt(2) * np.array([0.4, 0.4, 0.01]), rel=1e-5
    )
    sources = json.loads(result.import_json.read_text())["config_sources"]
    assert sources["ekf.sigma_r.x"] == "/fix covariances (median of 4)"
    assert sources["ekf.sigma_r.yaw"] == "/imu orientation covariances (median of 9)"
    assert sources["slip_ekf.sigma_r.dyaw"].startswith("sqrt(2) ekf.sigma_r.yaw")


def test_a_pose_covariance_sets_each_component_and_its_yaw_beats_the_imu(tmp_path: Path) -> None:
    poses = [
        (
            "/pose",
            "nav_msgs/msg/Odometry",
            BASE + 3 * STEP + 1000,
            M.odometry(BASE + 3 * STEP + 1000, sigma=(0.1, 0.2, 0.05)),
        )
    ]
    bag = _bag(tmp_path, None, poses + _fixes_and_headings()[4:])
    opts = ImportOptions("/odom", pose_topic="/pose", heading_topic="/imu", track_width=0.5)
    cfg = load_config(import_bag(bag, tmp_path / "out", opts, progress=False).config_yaml)
    assert (cfg.ekf.sigma_r.x, cfg.ekf.sigma_r.y, cfg.ekf.sigma_r.yaw) == pytest.approx(
        (0.1, 0.2, 0.05)
    )
    slip = cfg.slip_ekf.sigma_r
    assert (slip.dx, slip.dy, slip.dyaw) == pytest.approx(
        np.sqrt(2) * np.array([0.1, 0.2, 0.05]), rel=1e-5
    )


def test_a_gps_antenna_the_bag_does_not_place_is_to_fill(tmp_path: Path) -> None:
    bag = _bag(tmp_path, None, _fixes_and_headings())
    result = import_bag(bag, tmp_path / "out", GPS_IMU, progress=False)
    assert result.fill_keys == ("pose_sensor.antenna_x", "pose_sensor.antenna_y")
    cfg = load_config(result.config_yaml)
    assert (cfg.pose_sensor.antenna_x, cfg.pose_sensor.heading_offset) == (0.0, 0.0)
    sources = json.loads(result.import_json.read_text())["config_sources"]
    assert sources["pose_sensor.antenna_y"] == "not set: /tf_static base_link -> gps not in the bag"
    assert "pose_sensor.heading_offset" not in sources


def test_a_pose_yaw_and_an_imu_turned_from_it_is_one_line(tmp_path: Path) -> None:
    poses = [("/pose", "nav_msgs/msg/Odometry", BASE + STEP + 1000, M.odometry(BASE + STEP + 1000))]
    bag = _bag(tmp_path, [IMU], poses + _fixes_and_headings()[4:])
    opts = ImportOptions("/odom", pose_topic="/pose", heading_topic="/imu", track_width=0.5)
    with pytest.raises(InputFileError, match=r"of base_link, --heading-topic /imu of imu, turned "):
        import_bag(bag, tmp_path / "out", opts, progress=False)
