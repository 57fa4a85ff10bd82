"""Windows' path lengths and anchors against hand-computed values (written for mutation survivors)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import (
    Windows,
    anchor_mask,
    log_anchor,
    non_overlapping,
    padded_steps,
    prediction_windows,
    spatial_windows,
    time_windows,
    wheel_path,
)
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
    assert near.length.tolist() == [1.5] * 7  # the poses' path, 1 m/s for 1.5 s
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


def test_non_overlapping_chains_windows_end_to_start():
    w = Windows(np.array([0, 1, 2, 3, 4]), np.array([2, 3, 4, 6, 6]), np.arange(1.0, 6.0))
    kept = non_overlapping(w)
    assert kept.start.tolist() == [0, 2, 4] and kept.end.tolist() == [2, 4, 6]
    assert kept.length.tolist() == [1.0, 3.0, 5.0]
    none = Windows(np.zeros(0, int), np.zeros(0, int), np.zeros(0))
    assert len(non_overlapping(none)) == 0


def test_padded_steps_by_hand():
    t = np.array([0.0, 1.0, 3.0, 6.0, 10.0])
    log = WheelLog(t, np.ones(5), np.ones(5), np.zeros((5, 3)), None, np.zeros(5, int))
    w = Windows(np.array([0, 1]), np.array([2, 4]), np.ones(2))
    rows, valid, dt = padded_steps(log, w, np.array([0, 1]))
    assert rows.tolist() == [[0, 1, 1], [1, 2, 3]]  # padding repeats the last real row
    assert valid.tolist() == [[True, True, False], [True, True, True]]
    assert dt.tolist() == [[1.0, 2.0, 0.0], [2.0, 3.0, 4.0]] and dt.dtype == np.float64
    rows, valid, dt = padded_steps(log, w, np.array([1]))
    assert rows.tolist() == [[1, 2, 3]] and dt.tolist() == [[2.0, 3.0, 4.0]]


def test_anchor_mask_of_each_anchor_and_a_wrong_one():
    pose = np.array([[0.0, 0.0, np.nan], [np.nan, np.nan, 0.1], [1.0, 0.0, 0.2]])
    log = WheelLog(np.arange(3.0), np.ones(3), np.ones(3), pose, None, np.zeros(3, int))
    assert anchor_mask(log, "pose").tolist() == [False, False, True]
    assert anchor_mask(log, "position").tolist() == [True, False, True]
    assert anchor_mask(log, "heading").tolist() == [False, True, True]
    with pytest.raises(ValueError) as err:
        anchor_mask(log, "gps")
    assert (
        str(err.value) == "window anchor must be one of ('pose', 'position', 'heading'), got 'gps'"
    )


def test_spatial_windows_need_a_horizon_of_a_millimetre():
    log = _half_speed_poses()
    assert len(spatial_windows(log, 1e-3)) == 8  # MIN_HORIZON itself: the next pose
    for bad in (5e-4, 0.0, float("nan")):
        with pytest.raises(ValueError) as err:
            spatial_windows(log, bad)
        assert str(err.value) == f"window horizon must be >= 0.001 m, got {bad}"


def test_spatial_windows_by_default_are_2_m_between_poses():
    w = spatial_windows(_half_speed_poses())  # poses 0.5 m apart
    assert (w.end - w.start).tolist() == [4] * 5 and w.length.tolist() == [2.0] * 5
    by_wheels = spatial_windows(_half_speed_poses(), anchor="position")  # the wheels: 1 m/s
    assert (by_wheels.end - by_wheels.start).tolist() == [2] * 7


def test_spatial_windows_measure_only_positions_and_only_within_their_segment():
    """Poses 0.5 m apart turning 1 rad a row; the second segment starts 100 m away."""
    x = np.r_[0.5 * np.arange(4), 100.0 + 0.5 * np.arange(4)]
    pose = np.c_[x, 0 * x, np.angle(np.exp(1j * np.arange(8.0)))]
    log = WheelLog(np.arange(8.0), np.ones(8), np.ones(8), pose, None, np.repeat([0, 1], 4))
    w = spatial_windows(log, 1.0)
    assert w.start.tolist() == [0, 1, 4, 5] and w.end.tolist() == [2, 3, 6, 7]
    assert w.length.tolist() == [1.0] * 4


def test_prediction_windows_of_a_run_at_negative_times():
    """A log's time need only increase within a segment: the second run may start at -100 s."""
    t = np.r_[np.arange(5.0), -100.0 + np.arange(5.0)]
    segment = np.repeat([0, 1], 5)
    w = prediction_windows(_poses_at(t, segment), 1.0)
    assert w.start.tolist() == [0, 1, 2, 3, 5, 6, 7, 8]
    assert w.end.tolist() == [1, 2, 3, 4, 6, 7, 8, 9]


def test_a_window_never_ends_on_its_own_start():
    """Rows 1 s apart, horizon 0.25 s: the nearest row is the start itself, within 0.3 s."""
    assert len(prediction_windows(_poses_at(np.arange(5.0), np.zeros(5, int)), 0.25,
                                  tolerance=0.3)) == 0  # fmt: skip
