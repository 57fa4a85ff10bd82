"""Which ``auto`` values ``calibrate_config`` resolves, and how it says what it did."""

from __future__ import annotations

import dataclasses

import pytest

from terrain_odom.app.calibration import apply_delays, calibrate_config
from terrain_odom.config import Config, PoseSensorConfig, PoseSigmas, RobotConfig, TimeConfig
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log

ROBOT = RobotConfig(track_width=1.0)


@pytest.fixture(scope="module")
def clean() -> WheelLog:
    return constant_model_log("idd", [], seconds=300.0, track_width=1.0, noise=(0.0, 0.0, 0.0))


def test_nothing_auto_is_nothing_estimated(clean):
    cfg = Config(robot=ROBOT)
    resolved, found, timing = calibrate_config(clean, cfg)
    assert resolved is cfg and not found.found and timing.pose_delay == 0.0


def test_a_log_of_full_poses_keeps_one_clock(clean):
    # x, y and yaw on the same rows (ICP): pose_delay auto is the heading-based one, for both
    cfg = Config(robot=ROBOT, time=TimeConfig(pose_delay="auto"))
    resolved, found, timing = calibrate_config(clean, cfg)
    assert timing.heading_delay_applied == timing.pose_delay == pytest.approx(0.0, abs=0.02)
    assert resolved.time.position_delay is None and resolved.time.heading_delay is None
    assert len(apply_delays(clean, timing)) == len(clean)  # no heading moved onto rows of its own


def test_a_gps_and_an_imu_get_a_delay_each(clean):
    log = degrade_log(
        clean, Degradation(latency=0.5, imu_latency=0.0, seed=0, gps_noise=0.1, heading_wander=0.0)
    ).log
    cfg = Config(robot=ROBOT, time=TimeConfig(position_delay="auto", heading_delay="auto"))
    resolved, _, timing = calibrate_config(log, cfg)
    assert timing.pose_delay == pytest.approx(0.5, abs=0.05)
    assert timing.heading_delay_applied == pytest.approx(0.0, abs=0.03)
    assert resolved.time.delays == (timing.pose_delay, timing.heading_delay_applied)


def test_a_noise_claimed_larger_than_found_is_kept_and_said(clean):
    # the delays and the antenna as configured (0): a GPS on time at the reference point
    quiet = {"gps_walk": 0.0, "latency": 0.0, "antenna": (0.0, 0.0), "heading_wander": 0.0}
    log = degrade_log(clean, Degradation(gps_noise=0.2, seed=0, **quiet)).log
    ekf = dataclasses.replace(Config().ekf, sigma_r=PoseSigmas(1.0, 1.0, 0.5))
    cfg = Config(robot=ROBOT, ekf=ekf, pose_sensor=PoseSensorConfig(noise="auto"))
    resolved, found, _ = calibrate_config(log, cfg)
    assert resolved.ekf.sigma_r.x == 1.0 and resolved.ekf.sigma_r.yaw == 0.5
    values = {f.key: f for f in found.found}
    assert values["ekf.sigma_r.x"].value == pytest.approx(0.2, rel=0.3)
    assert not values["ekf.sigma_r.x"].applied
    assert "not used" in values["ekf.sigma_r.x"].line()
    assert any(note.startswith("GPS noise 0.2") and "using 1.00" in note for note in found.notes)


def test_noise_auto_without_positions_says_it_kept_the_config(clean):
    log = degrade_log(clean, Degradation(gps_rate=0.0, seed=0)).log
    cfg = Config(robot=ROBOT, pose_sensor=PoseSensorConfig(noise="auto"))
    resolved, found, _ = calibrate_config(log, cfg)
    assert resolved.ekf.sigma_r == cfg.ekf.sigma_r
    assert found.notes and "no positions" in found.notes[0]
