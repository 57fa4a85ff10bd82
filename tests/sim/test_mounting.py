"""GPS and IMU as a robot mounts them: 0.5 m antenna lever arm, 0.3 m fixes at 2.5 Hz, 10 deg IMU.

With the mounting configured, the ICR EKF converges to the true ICRs, and
both estimators estimate what they estimate from the same sensors mounted at
the reference point; left out, the log checks flag it before the run
(instead of the filter learning the lever arm as an ``x_icr`` and the offset
as a skew of the ICRs). The command-line path (``simulate --antenna
--heading-offset``, then ``run``): tests/cli/test_simulate.py.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.app.calibration import calibrate_config
from terrain_odom.config import Config, PoseChangeSigmas, PoseSensorConfig, PoseSigmas
from terrain_odom.estimation.odometry import run_icr_ekf, run_slip_ekf
from terrain_odom.evaluation import check_log
from terrain_odom.records import WheelLog
from terrain_odom.sim import TERRAIN_TABLE, get_scenario, simulate
from terrain_odom.sim.simulation import Simulation

ANTENNA, OFFSET = 0.5, math.radians(10.0)
GRASS = TERRAIN_TABLE["grass"]
TRACK = 0.5


def _grass_sim(antenna: float, offset: float, duration: float = 180.0) -> Simulation:
    """Simulate the mixed tour (3 minutes by default) all on grass, the GPS and IMU mounted so."""
    scenario = dataclasses.replace(
        get_scenario("mixed"),
        table=dict.fromkeys(TERRAIN_TABLE, GRASS),
        duration=duration,
        pose_rate=2.5,
        sigma_xy=0.3,
        antenna=(antenna, 0.0),
        heading_offset=offset,
    )
    return simulate(scenario, seed=1)


def _log(sim: Simulation) -> WheelLog:
    segment = np.zeros(sim.motion.t.size, dtype=int)
    return WheelLog(sim.motion.t, sim.v_l, sim.v_r, sim.measured_pose, None, segment, "<sim>")


@pytest.fixture(scope="module")
def mounted() -> Simulation:
    """Simulate the run with the mounted GPS and IMU."""
    return _grass_sim(ANTENNA, OFFSET)


@pytest.fixture(scope="module")
def sim_log(mounted) -> WheelLog:
    return _log(mounted)


def _config(antenna: float, offset: float | str) -> Config:
    """0.3-m fixes and 0.01-rad headings; the slip EKF's changes of two: sqrt(2) as much."""
    ekf = dataclasses.replace(Config().ekf, sigma_r=PoseSigmas(0.3, 0.3, 0.01))
    change = PoseChangeSigmas(*(math.sqrt(2.0) * np.array([0.3, 0.3, 0.01])))
    slip = dataclasses.replace(Config().slip_ekf, sigma_r=change)
    sensor = PoseSensorConfig(antenna, 0.0, offset)  # type: ignore[arg-type]
    return Config(ekf=ekf, slip_ekf=slip, pose_sensor=sensor)


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
    assert found.mounting.lever.x == pytest.approx(ANTENNA - GRASS.x_icr, abs=0.15)
    assert "antenna" in found.findings[0].message


def test_without_the_heading_offset_the_checks_flag_it(sim_log):
    found = check_log(sim_log, TRACK, antenna=(ANTENNA, 0.0))
    assert [f.check for f in found.findings] == ["heading_offset"]
    assert "+9." in found.findings[0].message or "+10." in found.findings[0].message
    both = check_log(sim_log, TRACK)
    assert sorted(f.check for f in both.findings) == ["heading_offset", "lever_arm"]


def test_with_the_mounting_the_checks_pass(sim_log):
    assert check_log(sim_log, TRACK, antenna=(ANTENNA, 0.0), heading_offset=OFFSET).ok


def test_auto_mounting_finds_the_imu_offset_and_the_antenna(sim_log):
    cfg, found, _ = calibrate_config(sim_log, _config("auto", "auto"))
    assert cfg.pose_sensor.heading_offset == pytest.approx(OFFSET, abs=math.radians(1.0))
    # the antenna from the point that does not slide sideways: ANTENNA - x_icr
    assert cfg.pose_sensor.antenna_x == pytest.approx(ANTENNA - GRASS.x_icr, abs=0.1)
    assert cfg.pose_sensor.antenna_y == pytest.approx(0.0, abs=0.1)
    values = {f.key: f for f in found.found}
    assert 0.0 < values["pose_sensor.antenna_x"].std < 0.1
    assert values["pose_sensor.heading_offset"].applied


def _slip(sim: Simulation, cfg: Config) -> tuple[np.ndarray, float]:
    """Return the slip EKF's mean ``y_l, y_r, x_icr`` over the second half, its position error."""
    result = run_slip_ekf(_log(sim), cfg)
    error = np.hypot(*(result.states[:, :2] - sim.motion.pose[:, :2]).T)
    return result.states[sim.motion.t.size // 2 :, 3:6].mean(axis=0), float(error.mean())


def test_slip_ekf_with_the_mounting_is_the_run_of_sensors_at_the_reference():
    # one minute; the same run (seed, motion, noise) with the GPS and IMU at the reference point
    mounted = _grass_sim(ANTENNA, OFFSET, 60.0)
    at_reference = _slip(_grass_sim(0.0, 0.0, 60.0), _config(0.0, 0.0))
    with_mounting = _slip(mounted, _config(ANTENNA, OFFSET))
    np.testing.assert_allclose(with_mounting[0], at_reference[0], atol=0.005)
    assert with_mounting[1] == pytest.approx(at_reference[1], abs=0.005)
    # the lever arm left out: x_icr pulled toward -antenna (-0.09 m against -0.02 m), the dead
    # reckoning between fixes 0.6 m off the truth on average against 0.4 m
    lever_arm_out = _slip(mounted, _config(0.0, OFFSET))
    assert lever_arm_out[0][2] < with_mounting[0][2] - 0.05
    assert lever_arm_out[1] > with_mounting[1] + 0.15
