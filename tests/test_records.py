"""records: the one home of segment runs (checked against a row-by-row definition)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from terrain_odom.records import GroundTruth, WheelLog, change_runs, run_starts

keys = st.lists(st.integers(0, 2), min_size=1, max_size=40)


def _naive_runs(*columns: list) -> list[int]:
    """Run id per row by walking the rows: +1 wherever any column differs from the row before."""
    runs = [0]
    for i in range(1, len(columns[0])):
        runs.append(runs[-1] + any(c[i] != c[i - 1] for c in columns))
    return runs


@given(keys)
def test_change_runs_equals_the_row_walk(segment):
    assert change_runs(segment).tolist() == _naive_runs(segment)


@given(st.lists(st.tuples(st.integers(0, 2), st.sampled_from("ab")), min_size=1, max_size=40))
def test_change_runs_splits_on_any_key(rows):
    segment, terrain = [r[0] for r in rows], [r[1] for r in rows]
    assert change_runs(segment, terrain).tolist() == _naive_runs(segment, terrain)
    starts = run_starts(segment, terrain).tolist()
    runs = _naive_runs(segment, terrain)
    assert starts == [i for i in range(len(runs)) if i == 0 or runs[i] != runs[i - 1]]
    assert len(set(starts)) == len(starts)


def _log(segment: list[int]) -> WheelLog:
    n = len(segment)
    pose = np.full((n, 3), np.nan)
    return WheelLog(
        np.arange(n, dtype=float), np.ones(n), np.ones(n), pose, None, np.array(segment)
    )


@given(keys)
def test_run_ranges_cover_every_row_once_and_never_cross_a_change(segment):
    log = _log(segment)
    ranges = log.run_ranges()
    assert [i for r in ranges for i in r] == list(range(len(log)))
    assert log.n_runs == len(ranges) == log.segment_runs()[-1] + 1
    for r in ranges:
        assert len(set(log.segment[r.start : r.stop].tolist())) == 1


def test_empty_log_has_no_runs():
    log = _log([])
    assert log.n_runs == 0 and log.run_ranges() == [] and change_runs([]).size == 0


def test_pose_masks_tell_full_heading_only_and_missing_rows_apart():
    log = _log([0, 0, 0])
    log.pose[0] = [1.0, 2.0, 0.1]
    log.pose[1, 2] = 0.2  # heading only
    assert log.has_pose.tolist() == [True, False, False]
    assert log.has_yaw.tolist() == [True, True, False]
    assert log.has_position.tolist() == [True, False, False]


def test_ground_truth_changes_and_coverage():
    t = np.arange(5.0)
    gt = GroundTruth(
        t, np.zeros((5, 3)), np.zeros((5, 3)), None, np.array(list("aabbb")), "truth.csv"
    )
    assert gt.changes() == [(2.0, "a", "b")]
    assert gt.covers(np.array([0.0, 4.0])) and not gt.covers(np.array([0.0, 4.5]))


def test_take_keeps_the_rows_their_segments_and_the_source():
    n = 10
    pose = np.full((n, 3), np.nan)
    pose[::3] = np.arange(12.0).reshape(4, 3)
    terrain = np.array(["grass"] * 5 + ["sand"] * 5)
    log = WheelLog(0.1 * np.arange(n), np.ones(n), 2 * np.ones(n), pose, terrain,
                   np.repeat([0, 1], 5), "log.csv")  # fmt: skip
    part = log.take(np.array([0, 3, 4, 6, 9]))
    assert part.t.tolist() == pytest.approx([0.0, 0.3, 0.4, 0.6, 0.9])
    assert part.segment.tolist() == [0, 0, 0, 1, 1] and part.n_runs == 2
    assert part.terrain.tolist() == ["grass", "grass", "grass", "sand", "sand"]
    np.testing.assert_array_equal(part.pose[[0, 1, 3, 4]], pose[[0, 3, 6, 9]])
    assert part.source == "log.csv" and log.take(slice(0, 2), "head").source == "head"
    no_terrain = WheelLog(log.t, log.v_l, log.v_r, log.pose, None, log.segment)
    assert no_terrain.take(log.segment == 1).terrain is None
