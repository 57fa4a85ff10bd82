"""Plausibility checks: silent on the real logs, each mistake injected into them found by its check."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.evaluation.plausibility import PlausibilityLimits, check_log
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import wrap_angle

RADIUS, TRACK = 0.30, 1.08  # m, config/warthog.yaml
GRASS = "warthog_wheels_grass_2024_7_29_14h4s53.csv"


@pytest.fixture(scope="module")
def grass(drive_dir):
    return read_wheel_log(drive_dir / GRASS, wheel_radius=RADIUS)


def _checks(log, track_width=TRACK):
    return [f.check for f in check_log(log, track_width).findings]


def test_silent_on_every_real_log_and_the_shipped_logs(drive_dir, examples_dir):
    for path in sorted(drive_dir.glob("*.csv")):
        result = check_log(read_wheel_log(path, wheel_radius=RADIUS), TRACK)
        assert result.ok, (path.name, result.findings)
        assert 0.9 < result.pose_travel / result.wheel_travel < 1.05, path.name
        assert 0.5 < result.yaw_scale < 0.65 and result.yaw_correlation > 0.8, path.name
    demo = read_wheel_log(examples_dir / "demo_log.csv")
    assert check_log(demo, 0.5).ok


@pytest.mark.parametrize("radius", [0.10, 1.0])
def test_wrong_wheel_radius_is_a_travel_finding(drive_dir, radius):
    log = read_wheel_log(drive_dir / GRASS, wheel_radius=radius)
    result = check_log(log, TRACK)
    assert [f.check for f in result.findings] == ["travel"]
    assert "wheel radius" in result.findings[0].message


def test_angular_speeds_read_as_surface_speeds_is_a_travel_finding(grass):
    as_rad_s = dataclasses.replace(grass, v_l=grass.v_l / RADIUS, v_r=grass.v_r / RADIUS)
    result = check_log(as_rad_s, TRACK)
    assert _checks(as_rad_s) == ["travel"]
    assert "rad/s" in result.findings[0].message


def test_swapped_wheels_or_clockwise_yaw_is_a_yaw_sign_finding(grass):
    swapped = dataclasses.replace(grass, v_l=grass.v_r, v_r=grass.v_l)
    assert _checks(swapped) == ["yaw_sign"]
    pose = grass.pose.copy()
    pose[:, 2] = -pose[:, 2]
    assert _checks(dataclasses.replace(grass, pose=pose)) == ["yaw_sign"]


def test_yaw_in_degrees_is_a_yaw_follow_finding(grass):
    pose = grass.pose.copy()
    pose[:, 2] = wrap_angle(np.degrees(pose[:, 2]))  # what the reader makes of degrees
    result = check_log(dataclasses.replace(grass, pose=pose), TRACK)
    assert [f.check for f in result.findings] == ["yaw_follow"]
    assert "degrees" in result.findings[0].message


def test_time_in_milliseconds_or_microseconds_is_a_time_step_finding(grass):
    for factor, cause in ((1e3, "milliseconds"), (1e-3, "microseconds")):
        result = check_log(dataclasses.replace(grass, t=grass.t * factor), TRACK)
        assert [f.check for f in result.findings] == ["time_step"]
        assert cause in result.findings[0].message


def test_still_wheels_or_still_poses(grass):
    zero = np.zeros_like(grass.v_l)
    assert _checks(dataclasses.replace(grass, v_l=zero, v_r=zero)) == ["still_wheels"]
    pose = grass.pose.copy()
    pose[np.isfinite(pose[:, 0]), :2] = 0.0
    assert _checks(dataclasses.replace(grass, pose=pose)) == ["still_poses"]


def test_an_absurd_speed_is_found_before_anything_else(grass):
    v_l = grass.v_l.copy()
    v_l[100] = 1e300
    result = check_log(dataclasses.replace(grass, v_l=v_l), TRACK)
    assert [f.check for f in result.findings] == ["absurd_speed"]
    assert f"t = {grass.t[100]:g} s" in result.findings[0].message


def test_a_log_without_poses_or_motion_is_not_judged(grass):
    bare = dataclasses.replace(grass, pose=np.full_like(grass.pose, np.nan))
    result = check_log(bare, TRACK)
    assert result.ok and result.wheel_travel == 0.0 and np.isnan(result.yaw_scale)
    first = slice(0, 50)  # the first 2.5 s: standing, nothing to judge
    still = dataclasses.replace(grass.take(first), terrain=None)
    assert check_log(still, TRACK).ok


def test_heading_only_poses_still_get_the_yaw_checks(grass):
    pose = grass.pose.copy()
    pose[:, :2] = np.nan
    swapped = dataclasses.replace(grass, v_l=grass.v_r, v_r=grass.v_l, pose=pose)
    assert _checks(swapped) == ["yaw_sign"]


def test_limits_are_the_thresholds(grass):
    strict = PlausibilityLimits(travel_ratio=(0.99, 1.01))
    assert [f.check for f in check_log(grass, TRACK, strict).findings] == ["travel"]
