"""Windows' path lengths and anchors against hand-computed values (written for mutation survivors)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import log_anchor, time_windows, wheel_path
from terrain_odom.records import WheelLog


def test_wheel_path_holds_each_rows_mean_speed_and_freezes_across_segments():
    t = np.array([0.0, 1.0, 3.0, 4.0, 6.0])
    v_l = np.array([1.0, 2.0, 3.0, 4.0, 0.0])
    v_r = np.array([3.0, 2.0, -5.0, 0.0, 0.0])
    log = WheelLog(t, v_l, v_r, np.full((5, 3), np.nan), None, np.array([0, 0, 0, 1, 1]))
    # |v_l + v_r| / 2 * dt: 2 * 1, 2 * 2, (across the segment change: 0), 2 * 2
    assert wheel_path(log).tolist() == [0.0, 2.0, 6.0, 6.0, 10.0]


def _half_speed_poses(n: int = 9) -> WheelLog:
    """Wheels say 1 m/s, the poses 0.5 m/s: a pose every second."""
    t = np.arange(float(n))
    pose = np.c_[0.5 * t, 0 * t, 0 * t]
    return WheelLog(t, np.ones(n), np.ones(n), pose, None, np.zeros(n, int))


def test_time_windows_between_poses_are_as_long_as_the_poses_say():
    w = time_windows(_half_speed_poses(), 2.0)  # the default anchor: full poses
    assert w.start.tolist() == list(range(7)) and (w.end - w.start).tolist() == [2] * 7
    assert w.length.tolist() == [1.0] * 7  # measured, not the wheels' 2 m
    assert time_windows(_half_speed_poses(), 2.0, anchor="position").length.tolist() == [2.0] * 7


@pytest.mark.parametrize("duration", [0.0, -1.0])
def test_time_windows_need_a_positive_duration(duration):
    with pytest.raises(ValueError, match=f"window duration must be > 0 s, got {duration}"):
        time_windows(_half_speed_poses(), duration)


def test_log_anchor_is_what_the_log_measures():
    log = _half_speed_poses(4)
    assert log_anchor(log) == "pose"
    gps = log.pose.copy()
    gps[:, 2] = np.nan
    imu = np.full((4, 3), np.nan)
    imu[:, 2] = 0.0
    assert log_anchor(WheelLog(log.t, log.v_l, log.v_r, gps, None, log.segment)) == "position"
    assert log_anchor(WheelLog(log.t, log.v_l, log.v_r, imu, None, log.segment)) == "heading"
