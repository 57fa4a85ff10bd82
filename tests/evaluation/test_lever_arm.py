"""The one lever-arm estimator against truth it did not see (simulated ICR robots, degraded GPS).

Only ``antenna - (x_icr, (y_l + y_r) / 2)`` is identifiable from wheels and
positions: with the robot's own ``x_icr`` moved by ``dx``, the estimate
moves by ``-dx`` and by nothing else.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.app.calibration import calibrate_inputs
from terrain_odom.config import Config, load_config
from terrain_odom.config.sections import RobotConfig
from terrain_odom.evaluation import check_log
from terrain_odom.evaluation.calibration import fit_sensors
from terrain_odom.io import read_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log

TRACK = 0.5
ANTENNA = -0.8  # m, behind the reference point
Y_L, Y_R = 0.42, -0.40


def _robot(x_icr: float, seconds: float = 300.0) -> WheelLog:
    """Return an ICR-model robot with exact poses (the truth to degrade)."""
    return constant_model_log(
        "icr", (Y_L, Y_R, x_icr), seconds=seconds, seed=4, track_width=TRACK, noise=(0, 0, 0)
    )


def _gps(clean: WheelLog, noise: float, seed: int, antenna: float = ANTENNA) -> WheelLog:
    d = Degradation(gps_noise=noise, gps_walk=0.0, antenna=(antenna, 0.0), seed=seed)
    return degrade_log(clean, d).log


@pytest.fixture(scope="module")
def robots() -> dict[float, WheelLog]:
    return {x: _robot(x) for x in (0.0, 0.3)}


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("noise", [0.1, 0.3])
def test_lever_arm_within_0_15_m_of_antenna_minus_x_icr(robots, noise, seed):
    for x_icr, clean in robots.items():
        fit = fit_sensors(_gps(clean, noise, seed), TRACK)
        est = fit.antenna_x
        assert est.observable, (x_icr, est.how)
        assert est.value == pytest.approx(ANTENNA - x_icr, abs=0.15), (x_icr, noise, seed)
        assert abs(est.value - (ANTENNA - x_icr)) < 4.0 * est.std + 0.03
        assert fit.antenna_y.value == pytest.approx(-0.5 * (Y_L + Y_R), abs=0.15)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_robots_x_icr_moves_the_estimate_by_exactly_minus_its_change(robots, seed):
    """The confound: the same noise, x_icr 0.3 m further forward: the antenna 0.3 m further back."""
    a0 = fit_sensors(_gps(robots[0.0], 0.3, seed), TRACK).lever
    a3 = fit_sensors(_gps(robots[0.3], 0.3, seed), TRACK).lever
    assert a3.x - a0.x == pytest.approx(-0.3, abs=0.06)
    assert a3.y - a0.y == pytest.approx(0.0, abs=0.06)


def test_short_noisy_log_is_not_observable_and_the_check_agrees(robots):
    """An antenna 0.2 m behind, two minutes at 1.5 m noise: not told from noise or x_icr."""
    short = _gps(_robot(0.0, 120.0), 1.5, 0, antenna=-0.2)
    fit = fit_sensors(short, TRACK)
    assert not fit.antenna_x.observable and np.isnan(fit.antenna_x.value)
    assert fit.lever.std_x > 0.1 and "measure the antenna" in fit.antenna_x.how
    assert "lever_arm" not in [f.check for f in check_log(short, TRACK).findings]


def test_the_check_passes_after_calibrate_and_refuses_without(robots):
    """What calibrate applied is never refused; left out, the same estimator flags it."""
    log = _gps(robots[0.3], 0.3, 0)
    cfg = Config(robot=RobotConfig(track_width=TRACK))
    cfg = dataclasses.replace(
        cfg,
        pose_sensor=dataclasses.replace(
            cfg.pose_sensor, antenna_x="auto", antenna_y="auto", heading_offset="auto"
        ),
    )
    delayed, resolved, found, _ = calibrate_inputs(log, cfg)
    ax = float(resolved.pose_sensor.antenna_x)
    assert ax == pytest.approx(ANTENNA - 0.3, abs=0.15)
    assert not [n for n in found.notes if "lever_arm" in n]
    offset = float(resolved.pose_sensor.heading_offset)
    arm = (ax, float(resolved.pose_sensor.antenna_y))
    assert check_log(delayed, TRACK, antenna=arm, heading_offset=offset).ok
    without = check_log(delayed, TRACK, heading_offset=offset).findings
    (finding,) = [f for f in without if f.check == "lever_arm"]
    told = float(finding.message.split("set it to ")[1].split(",")[0])
    # the same estimator; the check fits the position delay left in the delayed log again
    assert told == pytest.approx(ax, abs=0.15)


def test_a_log_too_short_for_windows_takes_the_chords_offset_and_passes(drive_dir):
    """85 s of real driving, an IMU 166 deg off: calibrate and the check use the same chords."""
    warthog = load_config(Path(__file__).parents[2] / "config" / "warthog.yaml")
    path = drive_dir / "warthog_wheels_grass_2024_7_29_14h8s51.csv"
    clean = read_wheel_log(path, wheel_radius=0.3)
    d = Degradation(
        gps_rate=5.0, gps_noise=0.6, antenna=(0.0, 0.0), heading_offset=np.radians(166.0), seed=0
    )
    out = degrade_log(clean, d).log
    sensor = dataclasses.replace(warthog.pose_sensor, heading_offset="auto")
    cfg = dataclasses.replace(warthog, pose_sensor=sensor)
    delayed, resolved, found, _ = calibrate_inputs(out, cfg)  # the checks pass
    (offset,) = [f for f in found.found if f.key == "pose_sensor.heading_offset"]
    assert "straight chords" in offset.how and "too few" in offset.how
    truth = np.interp(
        out.t[out.has_yaw], clean.t[clean.has_pose], np.unwrap(clean.pose[clean.has_pose, 2])
    )
    realised = np.angle(np.mean(np.exp(1j * (out.pose[out.has_yaw, 2] - truth))))
    value = float(resolved.pose_sensor.heading_offset)
    # a short log: within four of its standard errors of the realised offset
    assert abs(np.angle(np.exp(1j * (value - realised)))) < 4.0 * offset.std + np.radians(2.0)
    assert check_log(delayed, 1.08, heading_offset=value).ok
