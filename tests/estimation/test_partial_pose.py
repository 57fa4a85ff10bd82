"""Both estimators update on whatever a pose row has: x, y alone; yaw alone; all three."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom import OnlineOdometry
from terrain_odom.config import Config, PoseSensorConfig, PoseSigmas
from terrain_odom.errors import ConfigError
from terrain_odom.estimation.odometry import run_odometry
from terrain_odom.records import WheelLog
from terrain_odom.sim.model_log import constant_model_log

TRUE = (0.42, -0.40, 0.05, 0.93)  # y_l, y_r, x_icr, alpha
CFG = Config(ekf=dataclasses.replace(Config().ekf, sigma_r=PoseSigmas(0.01, 0.01, 0.005)))


@pytest.fixture(scope="module")
def full_log() -> WheelLog:
    """Two minutes of varied driving on the icr-slip model, poses at 10 Hz (3 mm, 2 mrad noise)."""
    return constant_model_log("icr-slip", TRUE, seconds=120.0, seed=4, track_width=0.5)


def _keep(log: WheelLog, columns: list[int]) -> WheelLog:
    pose = np.full_like(log.pose, np.nan)
    pose[:, columns] = log.pose[:, columns]
    return dataclasses.replace(log, pose=pose)


def _run(log: WheelLog, estimator: str = "icr-ekf", cfg: Config = CFG) -> OnlineOdometry:
    odo = OnlineOdometry(cfg, estimator=estimator)  # type: ignore[arg-type]
    run_odometry(log, odo)
    return odo


def test_gps_alone_updates_and_learns_the_icrs(full_log):
    """x, y without yaw: the heading comes from the course, then every fix updates."""
    odo = _run(_keep(full_log, [0, 1]))
    use = odo.pose_use
    assert use.heading == 0 and use.position == int(full_log.has_pose.sum())
    assert use.used_position == use.position and not use.dropped
    held = use.used_position - odo.n_updates  # the first fix, those holding the position
    assert 2 < held < 20  # before the robot moved 1 m, and the course fix: no update
    state = odo.state()
    np.testing.assert_allclose([state["y_l"], state["y_r"], state["x_icr"]], TRUE[:3], atol=0.03)


def test_gps_alone_takes_the_heading_from_the_course(full_log):
    log = _keep(full_log, [0, 1])
    odo = OnlineOdometry(CFG)
    result = run_odometry(log, odo)
    anchored = np.flatnonzero(np.isfinite(result.stds[:, 2]) & (result.stds[:, 2] < 0.2))[0]
    true_yaw = full_log.pose[np.isfinite(full_log.pose[:, 2]), 2]
    error = np.angle(np.exp(1j * (result.states[-1, 2] - true_yaw[-1])))
    assert anchored < 100 and abs(error) < 0.02


def test_heading_alone_updates_at_every_heading(full_log):
    odo = _run(_keep(full_log, [2]))
    use = odo.pose_use
    assert use.used_heading == use.heading and odo.n_updates == use.heading - 1
    state = odo.state()  # a heading observes the turn rate: alpha / (y_l - y_r) only
    turn = state["alpha"] / (state["y_l"] - state["y_r"])
    assert turn == pytest.approx(TRUE[3] / (TRUE[0] - TRUE[1]), rel=0.02)


def test_gps_and_imu_on_separate_rows_update_both_estimators(full_log):
    """Fixes and headings from two sensors, never on one row (GPS at 5 Hz, IMU in between)."""
    pose = np.full_like(full_log.pose, np.nan)
    rows = np.flatnonzero(full_log.has_pose)
    pose[rows[::2], :2] = full_log.pose[rows[::2], :2]
    pose[rows[1::2], 2] = full_log.pose[rows[1::2], 2]
    log = dataclasses.replace(full_log, pose=pose)
    for estimator in ("icr-ekf", "slip-ekf"):
        odo = _run(log, estimator)
        use = odo.pose_use
        assert use.used_position == use.position and use.used_heading == use.heading
        assert not use.dropped
        assert odo.n_updates == use.position + use.heading - 3  # a fix, a heading, a fix anchor
        if estimator == "icr-ekf":  # the slip model's ICRs are no constants to compare
            state = odo.state()
            estimate = [state[name] for name in ("y_l", "y_r", "x_icr", "alpha")]
            np.testing.assert_allclose(estimate, TRUE, atol=0.01)


def test_slip_ekf_between_rare_headings_uses_the_fixes_as_chords(full_log):
    """Its heading is dead reckoning between measured ones: a fix long after one is a chord."""
    pose = full_log.pose.copy()
    pose[:200, 2] = np.nan  # no heading in the first 10 s
    pose[1000:, 2] = np.nan  # nor after 50 s
    odo = _run(dataclasses.replace(full_log, pose=pose), "slip-ekf")
    use = odo.pose_use
    dropped = sum(use.dropped.values())
    assert set(use.dropped) <= {
        "position: no heading, and within a quarter chord of the previous fix (standing)"
    }
    assert use.used_position + dropped == use.position and use.used_heading == use.heading
    chords = (
        use.position - int(full_log.has_pose[200:1000].sum()) - dropped
    )  # fixes without heading
    assert 0.2 * chords < odo.n_updates - (use.heading - 1) < chords


def test_online_odometry_refuses_an_unresolved_auto_heading_offset():
    cfg = Config(pose_sensor=PoseSensorConfig(heading_offset="auto"))
    with pytest.raises(ConfigError, match="heading_offset: auto"):
        OnlineOdometry(cfg)
