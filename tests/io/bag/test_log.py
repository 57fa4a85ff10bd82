"""Merging wheel, pose and heading streams into one wheel log."""

from __future__ import annotations

import numpy as np

from terrain_odom.io.bag.log import StampedRows, merge_streams

S = 10**9
MS = 10**6


def _wheels(ms: list[int]) -> StampedRows:
    stamps = np.array(ms, dtype=np.int64) * MS + 3 * S
    return StampedRows(stamps, np.column_stack([np.arange(len(ms)), 10.0 + np.arange(len(ms))]))


def test_gaps_start_segments_and_events_in_gaps_are_dropped() -> None:
    wheels = _wheels([0, 100, 200, 900, 1000])
    poses = StampedRows(
        np.array([-50, 150, 850, 1000, 1100]) * MS + 3 * S,
        np.array([[0, 0, 0], [1, 1, 0.1], [2, 2, 0.2], [3, 3, 0.3], [4, 4, 0.4]], dtype=float),
    )
    merged = merge_streams(wheels, poses, None, max_gap=0.5)
    log = merged.log
    np.testing.assert_allclose(log.t, [0.0, 0.1, 0.15, 0.2, 0.9, 1.0])
    assert log.segment.tolist() == [0, 0, 0, 0, 1, 1]
    assert log.v_l.tolist() == [0, 1, 1, 2, 3, 4]  # the pose row holds the speeds before it
    np.testing.assert_allclose(log.pose[5], [3, 3, 0.3])  # same stamp as a wheel row: merged
    assert merged.dropped == {
        "pose outside the wheel samples": 2,  # before the first, after the last
        "pose in a gap of the wheel samples": 1,  # 850 ms: 650 ms after the last wheel row
    }
    assert merged.origin_ns == 3 * S


def test_duplicates_keep_the_last_and_out_of_order_is_counted() -> None:
    wheels = _wheels([0, 200, 100, 100])
    headings = StampedRows(np.array([100, 100]) * MS + 3 * S, np.array([0.5, -0.5]))
    merged = merge_streams(wheels, None, headings, max_gap=1.0)
    assert merged.log.v_l.tolist() == [0, 3, 1]  # stamp 100 twice: the later message (3) wins
    assert np.isnan(merged.log.pose[1, 0]) and merged.log.pose[1, 2] == -0.5
    assert merged.out_of_order == 1
    assert merged.dropped == {"duplicate wheel stamp": 1, "duplicate heading stamp": 1}


def test_position_without_yaw_and_a_heading_share_a_row() -> None:
    wheels = _wheels([0, 100])
    gps = StampedRows(np.array([50]) * MS + 3 * S, np.array([[4.0, 5.0, np.nan]]))
    imu = StampedRows(np.array([50]) * MS + 3 * S, np.array([1.25]))
    merged = merge_streams(wheels, gps, imu, max_gap=1.0)
    np.testing.assert_allclose(merged.log.pose[1], [4.0, 5.0, 1.25])
    assert merged.dropped == {}
