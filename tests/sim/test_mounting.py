"""GPS and IMU as a robot mounts them: 0.5 m antenna lever arm, 0.3 m fixes at 2.5 Hz, 10 deg IMU.

With the mounting configured, the ICR EKF converges to the true ICRs; left
out, the log checks flag it before the run (instead of the filter learning
the lever arm as an ``x_icr`` and the offset as a skew of the ICRs).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.app.run import resolve_heading_offset
from terrain_odom.config import Config, PoseSensorConfig, PoseSigmas
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.evaluation import check_log
from terrain_odom.records import WheelLog
from terrain_odom.sim import TERRAIN_TABLE, get_scenario, simulate

ANTENNA, OFFSET = 0.5, math.radians(10.0)
GRASS = TERRAIN_TABLE["grass"]
TRACK = 0.5


@pytest.fixture(scope="module")
def sim_log() -> WheelLog:
    """Three minutes of the mixed tour, all on grass, with the mounted GPS and IMU."""
    scenario = dataclasses.replace(
        get_scenario("mixed"),
        table=dict.fromkeys(TERRAIN_TABLE, GRASS),
        duration=180.0,
        pose_rate=2.5,
        sigma_xy=0.3,
        antenna=(ANTENNA, 0.0),
        heading_offset=OFFSET,
    )
    sim = simulate(scenario, seed=1)
    segment = np.zeros(sim.motion.t.size, dtype=int)
    return WheelLog(sim.motion.t, sim.v_l, sim.v_r, sim.measured_pose, None, segment, "<sim>")


def _config(antenna: float, offset: float | str) -> Config:
    ekf = dataclasses.replace(Config().ekf, sigma_r=PoseSigmas(0.3, 0.3, 0.01))
    return Config(ekf=ekf, pose_sensor=PoseSensorConfig(antenna, 0.0, offset))  # type: ignore[arg-type]


def _icrs(log: WheelLog, cfg: Config) -> np.ndarray:
    """Mean ``y_l, y_r, x_icr`` over the second half of the run."""
    result = run_icr_ekf(log, cfg)
    return result.states[len(log) // 2 :, 3:6].mean(axis=0)


def test_simulated_fixes_are_the_antenna_and_the_heading_is_offset(sim_log):
    sc = get_scenario("mixed")
    assert int(np.isfinite(sim_log.pose[:, 0]).sum()) == int(180 * 2.5)
    sim = simulate(
        dataclasses.replace(
            sc,
            duration=2.0,
            sigma_xy=0.0,
            sigma_yaw=0.0,
            antenna=(ANTENNA, 0.1),
            heading_offset=OFFSET,
        )
    )
    rows = np.isfinite(sim.measured_pose[:, 0])
    pose, measured = sim.motion.pose[rows], sim.measured_pose[rows]
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    np.testing.assert_allclose(measured[:, 0], pose[:, 0] + ANTENNA * c - 0.1 * s, atol=1e-12)
    np.testing.assert_allclose(measured[:, 1], pose[:, 1] + ANTENNA * s + 0.1 * c, atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (measured[:, 2] - pose[:, 2]))), OFFSET)


def test_with_the_mounting_the_icrs_converge_to_the_truth(sim_log):
    estimate = _icrs(sim_log, _config(ANTENNA, OFFSET))
    np.testing.assert_allclose(estimate, [GRASS.y_l, GRASS.y_r, GRASS.x_icr], atol=0.04)


def test_without_the_lever_arm_the_filter_would_learn_it_and_the_checks_flag_it(sim_log):
    estimate = _icrs(sim_log, _config(0.0, OFFSET))
    assert estimate[2] == pytest.approx(GRASS.x_icr - ANTENNA, abs=0.1)  # what the check prevents
    found = check_log(sim_log, TRACK, heading_offset=OFFSET)
    assert [f.check for f in found.findings] == ["lever_arm"]
    assert found.mounting is not None
    assert found.mounting.x_icr == pytest.approx(GRASS.x_icr - ANTENNA, abs=0.15)
    assert "antenna" in found.findings[0].message


def test_without_the_heading_offset_the_checks_flag_it(sim_log):
    found = check_log(sim_log, TRACK, antenna=(ANTENNA, 0.0))
    assert [f.check for f in found.findings] == ["heading_offset"]
    assert "+9." in found.findings[0].message or "+10." in found.findings[0].message
    both = check_log(sim_log, TRACK)
    assert sorted(f.check for f in both.findings) == ["heading_offset", "lever_arm"]


def test_with_the_mounting_the_checks_pass(sim_log):
    assert check_log(sim_log, TRACK, antenna=(ANTENNA, 0.0), heading_offset=OFFSET).ok


def test_auto_heading_offset_finds_the_imu_offset(sim_log):
    cfg, calibration = resolve_heading_offset(sim_log, _config(ANTENNA, "auto"))
    assert calibration is not None and calibration.stretches >= 50
    assert cfg.pose_sensor.heading_offset == pytest.approx(OFFSET, abs=math.radians(1.0))
    assert calibration.spread == pytest.approx(math.radians(11.0), abs=math.radians(3.0))
