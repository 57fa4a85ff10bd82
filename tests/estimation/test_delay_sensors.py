"""A position delay and a different heading delay applied to one log (time_offset.delay_sensors)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.estimation.time_offset import delay_sensors, delay_wheel_speeds
from terrain_odom.records import WheelLog


def _gps_imu_log() -> WheelLog:
    """Two runs: wheel rows at 10 Hz with varying speeds, fixes at 2 Hz, headings at 5 Hz."""
    rng = np.random.default_rng(0)
    t = np.round(np.arange(0.0, 20.0, 0.1), 6)
    pose = np.full((t.size, 3), np.nan)
    pose[::5, :2] = rng.normal(size=(t[::5].size, 2))
    pose[1::2, 2] = rng.uniform(-3.0, 3.0, t[1::2].size)
    segment = (t >= 10.0).astype(int)
    t = np.where(segment == 1, t - 10.0, t)  # the second run starts again at 0
    v = rng.uniform(0.0, 2.0, (t.size, 2))
    return WheelLog(t, v[:, 0], v[:, 1], pose, None, segment, "gps+imu")


def _travel(log: WheelLog, rows: np.ndarray) -> np.ndarray:
    """Integral of v_l between consecutive ``rows`` of one run (speeds held)."""
    cum = np.r_[0.0, np.cumsum(log.v_l[:-1] * np.diff(log.t))]
    return np.diff(cum[rows])


def test_equal_delays_are_delay_wheel_speeds():
    log = _gps_imu_log()
    same = delay_sensors(log, 0.3, 0.3)
    np.testing.assert_array_equal(same.v_l, delay_wheel_speeds(log, 0.3).v_l)
    assert same.pose is log.pose


def test_headings_move_to_the_positions_clock_and_speeds_keep_their_integral():
    log = _gps_imu_log()
    out = delay_sensors(log, 0.5, 0.0)  # a GPS 0.5 s late, an IMU on time: headings +0.5 s
    for run in (0, 1):
        rows, new = log.segment == run, out.segment == run
        t0, t1 = log.t[rows][0], log.t[rows][-1]
        # positions keep their stamps; each heading stamped t sits at t + 0.5 (within the run)
        fixes = rows & log.has_position
        np.testing.assert_array_equal(out.t[new & out.has_position], log.t[fixes])
        yaw = rows & log.has_yaw
        moved = log.t[yaw] + 0.5
        inside = moved <= t1
        np.testing.assert_allclose(out.t[new & out.has_yaw], moved[inside], atol=1e-9)
        np.testing.assert_array_equal(out.pose[new & out.has_yaw, 2], log.pose[yaw, 2][inside])
        # between any two output rows the distance is the recorded speeds' over [t - 0.5]
        t_out = out.t[new]
        cum = np.interp(
            t_out - 0.5,
            log.t[rows],
            np.r_[0.0, np.cumsum(log.v_l[rows][:-1] * np.diff(log.t[rows]))],
        )
        # before the run's first row the first speed is held
        cum = np.where(t_out - 0.5 < t0, (t_out - 0.5 - t0) * log.v_l[rows][0], cum)
        idx = np.flatnonzero(new)
        np.testing.assert_allclose(out.v_l[idx[:-1]] * np.diff(t_out), np.diff(cum), atol=1e-9)
        assert np.all(np.diff(t_out) > 0)


def test_a_heading_on_a_row_without_one_joins_that_row():
    t = np.arange(0.0, 3.0, 0.5)
    pose = np.full((t.size, 3), np.nan)
    pose[:, 0] = pose[:, 1] = 0.0  # fixes on every row
    pose[0, 2] = 1.0  # a heading on the first row, moved 1 s: onto the row at 1.0
    log = WheelLog(t, np.ones(t.size), np.ones(t.size), pose, None, np.zeros(t.size, int))
    out = delay_sensors(log, 1.0, 0.0)
    assert len(out) == len(log)
    assert out.pose[2, 2] == pytest.approx(1.0) and np.isnan(out.pose[0, 2])
