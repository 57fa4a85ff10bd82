"""Outage windows and errors at their boundaries: spacing, thresholds, tolerances, hand answers.

Written for the survivors of a mutation run (docs/testing.md). The logs are
straight drives at 1 m/s with times exact in binary (steps of 0.25 or 0.5 s).
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import (
    Windows,
    frozen_icr_table,
    is_sparse,
    model_twist,
    outage_errors,
    outage_spacing,
    outage_starts,
    outage_table,
    outage_windows,
)
from terrain_odom.kinematics import get_model
from terrain_odom.records import WheelLog

IDD = model_twist(get_model("idd"), [], 1.0)


def _straight(t: np.ndarray, pose: np.ndarray) -> WheelLog:
    return WheelLog(t, np.ones(t.size), np.ones(t.size), pose, None, np.zeros(t.size, int))


def _late_fixes() -> WheelLog:
    """40 s along x at 1 m/s, positions (no heading) on every row from t = 3 s on."""
    t = np.arange(0.0, 40.0, 0.5)
    pose = np.c_[t, 0 * t, np.full(t.size, np.nan)]
    pose[t < 3.0, :2] = np.nan
    return _straight(t, pose)


def test_windows_start_every_given_seconds_from_each_runs_first_fix():
    log = _late_fixes()
    w = outage_windows(log, 10.0, every=5.0)
    assert log.t[w.start].tolist() == [3.0, 8.0, 13.0, 18.0, 23.0, 28.0]
    assert log.t[w.end].tolist() == [13.0, 18.0, 23.0, 28.0, 33.0, 38.0]
    np.testing.assert_array_equal(outage_starts(log, (10.0,), every=5.0), w.start)
    # a spacing below a second is a spacing too
    assert log.t[outage_windows(log, 10.0, every=0.5).start].tolist() == list(
        np.arange(3.0, 30.75, 0.5)  # the last ends at 39.5 s, 1 s short
    )


def test_outage_starts_are_only_window_starts():
    log = _late_fixes()  # the first fix is row 6
    starts = outage_starts(log, (10.0, 20.0))
    assert log.t[starts].tolist() == [3.0, 13.0, 23.0]
    assert outage_starts(log, (100.0,)).size == 0


def test_the_shortest_outage_and_the_spacing_are_checked_at_their_bounds():
    log = _late_fixes()
    assert len(outage_windows(log, 1.0)) > 0  # MIN_OUTAGE itself is accepted
    for every in (0.0, -1.0):
        with pytest.raises(ValueError, match=f"outage windows start every > 0 s, got {every}"):
            outage_windows(log, 10.0, every=every)


def test_outage_table_and_frozen_icr_table_use_the_given_spacing():
    log = _late_fixes()
    table = outage_table(log, (10.0,), lambda rows: 0.0 * rows, {"idd": lambda _w: IDD},
                         every=5.0)  # fmt: skip
    assert log.t[table[10.0]["idd"].windows.start].tolist() == [3.0, 8.0, 13.0, 18.0, 23.0, 28.0]
    starts = outage_starts(log, (10.0,), every=5.0)
    states = np.tile([0.0, 0.5, -0.5, 0.0, 1.0], (starts.size, 1))
    frozen = frozen_icr_table(log, (10.0,), starts, states, (0.5, -0.5, 0.0, 1.0),
                              track_width=1.0, every=5.0)  # fmt: skip
    for name in ("learned", "nominal", "idd"):
        np.testing.assert_array_equal(frozen[10.0][name].windows.start, starts)
        assert frozen[10.0][name].position.max() < 1e-12  # the exact model on a straight line


def test_heading_rows_within_the_given_tolerance_are_compared():
    """Headings 0.75 s after the start and before the end: counted with 1 s, not with 0.5 s."""
    t = np.arange(0.0, 10.25, 0.25)
    pose = np.full((t.size, 3), np.nan)
    pose[[0, -1], :2] = [[0.0, 0.0], [10.0, 0.0]]
    pose[3, 2], pose[-4, 2] = 0.3, 0.8  # t = 0.75 s and 9.25 s: turned 0.5 rad, drove straight
    log = _straight(t, pose)
    w = Windows(np.array([0]), np.array([t.size - 1]), np.array([10.0]))
    err = outage_errors(log, w, [0.0], IDD, duration=10.0, tolerance=1.0)
    assert err.position[0] == pytest.approx(0.0, abs=1e-12)
    assert err.heading[0] == pytest.approx(0.5, abs=1e-12)
    assert err.duration == 10.0
    assert np.isnan(outage_errors(log, w, [0.0], IDD, duration=10.0).heading[0])
    d = err.to_dict()
    assert list(d) == ["position_m", "heading_deg"]
    assert d["heading_deg"]["median"] == pytest.approx(np.degrees(0.5))
    assert d["position_m"]["count"] == 1


def _poses(t: np.ndarray, heading: np.ndarray) -> WheelLog:
    """Positions on every row, headings on the rows ``heading`` marks."""
    pose = np.c_[t, 0 * t, np.where(heading, 0.0, np.nan)]
    return _straight(t, pose)


def test_sparse_at_its_thresholds():
    two = np.arange(2) * 0.5
    assert is_sparse(_poses(two, np.zeros(2, bool)))  # two fixes without heading suffice
    ten_hz = np.arange(5) * 0.125
    # half the fixes with a heading is not "fewer than half": the rate decides (8 Hz: dense)
    assert not is_sparse(_poses(ten_hz[:4], np.array([True, False, True, False])))
    # two of five is fewer than half: sparse at any rate
    assert is_sparse(_poses(ten_hz, np.array([True, False, True, False, False])))
    # full poses every 0.15 s exactly are sparse (the bound), every 0.125 s are not
    assert is_sparse(_poses(np.arange(3) * 0.15, np.ones(3, bool)))
    assert not is_sparse(_poses(np.arange(3) * 0.125, np.ones(3, bool)))


def test_a_long_log_spaces_its_windows_over_the_fixes_time_in_each_segment():
    """Two 30-min segments 30 min apart: 3600 s of fixes over 120 windows, the gap not counted."""
    t = np.r_[np.arange(0.0, 1800.5, 0.5), np.arange(3600.0, 5400.5, 0.5)]
    pose = np.c_[t, 0 * t, np.full(t.size, np.nan)]
    log = WheelLog(t, np.ones(t.size), np.ones(t.size), pose, None, (t > 2000.0).astype(int))
    assert outage_spacing(log) == pytest.approx(3600.0 / 120)
    assert outage_spacing(log.take(t <= 600.0)) == 10.0  # shorter: the default spacing
    assert outage_spacing(log, every=40.0) == 40.0  # wider than the log's share: kept
