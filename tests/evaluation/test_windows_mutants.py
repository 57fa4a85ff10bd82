"""Windows' path lengths and anchors against hand-computed values (written for mutation survivors)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import log_anchor, prediction_windows, time_windows, wheel_path
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


def _poses_at(t: np.ndarray, segment: np.ndarray) -> WheelLog:
    n = t.size
    return WheelLog(t, np.ones(n), np.ones(n), np.c_[t, 0 * t, 0 * t], None, segment)


def test_prediction_windows_end_on_the_nearest_pose_the_earlier_on_a_tie():
    log = _poses_at(np.arange(0.0, 5.0, 0.5), np.zeros(10, int))
    near = prediction_windows(log, 1.6)  # t + 1.5 is 0.1 s off, t + 2.0 0.4 s
    assert (near.end - near.start).tolist() == [3] * 7
    tie = prediction_windows(log, 1.25)  # t + 1.0 and t + 1.5 both 0.25 s off: the earlier
    assert (tie.end - tie.start).tolist() == [2] * 8


def test_prediction_windows_never_reach_into_the_next_run():
    """A run's last pose within the tolerance is the end, however near the next run starts."""
    t = np.r_[0.0, 1.0, 2.0, 3.0, 4.0, 4.3, 0.0, 1.0, 2.0]  # the second run starts again at 0
    w = prediction_windows(_poses_at(t, np.r_[np.zeros(6, int), np.ones(3, int)]), 1.0,
                           tolerance=0.9)  # fmt: skip
    assert w.start.tolist() == [0, 1, 2, 3, 4, 6, 7]
    assert w.end.tolist() == [1, 2, 3, 4, 5, 7, 8]


def test_prediction_windows_of_a_run_whose_last_step_is_long():
    """The same windows whether each run's time starts again or runs on."""
    t = np.r_[0.0, 1.0, 2.0, 100.0, np.arange(8.0)]
    segment = np.repeat([0, 1], [4, 8])
    again = prediction_windows(_poses_at(t, segment), 1.0)
    on = prediction_windows(_poses_at(t + 200.0 * segment, segment), 1.0)
    assert again.start.tolist() == on.start.tolist() == [0, 1, *range(4, 11)]
    assert again.end.tolist() == on.end.tolist() == [1, 2, *range(5, 12)]


def test_prediction_windows_of_a_single_pose_and_of_no_horizon():
    assert len(prediction_windows(_poses_at(np.zeros(1), np.zeros(1, int)), 1.0)) == 0
    with pytest.raises(ValueError, match="prediction horizon must be > 0 s, got 0.0"):
        prediction_windows(_poses_at(np.arange(3.0), np.zeros(3, int)), 0.0)
