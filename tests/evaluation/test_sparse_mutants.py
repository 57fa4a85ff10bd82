"""Sparse windows at their edges: headings near the ends, padding, tolerances, every anchor.

Written for the survivors of a mutation run (docs/testing.md); each test
states a property with a known answer.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.config import Config
from terrain_odom.errors import ConfigError
from terrain_odom.evaluation import (
    Windows,
    heading_at,
    heading_change,
    icr_twist_from_rows,
    model_twist,
    sparse_window_errors,
    spatial_windows,
    window_errors,
)
from terrain_odom.evaluation.sparse import anchored_window_errors, antenna_of
from terrain_odom.kinematics import get_model, integrate, twist_icr
from terrain_odom.records import WheelLog

ICR = (0.9, -0.8, 0.15, 0.95)
ANTENNA = (-1.0, 0.3)


def _headings() -> WheelLog:
    """Rows 1 s apart, headings 0.1, 0.7, 1.3 rad on rows 2, 4, 6 only."""
    pose = np.full((8, 3), np.nan)
    pose[[2, 4, 6], 2] = [0.1, 0.7, 1.3]
    return WheelLog(np.arange(8.0), np.ones(8), np.ones(8), pose, None, np.zeros(8, int))


def test_heading_at_each_side_of_the_heading_rows():
    log = _headings()
    got = heading_at(log, [0, 1, 2, 4, 5, 6, 7], tolerance=1.0)
    # 2 s before the first: none; 1 s before: the first; own rows as they are; between the
    # last two: halfway; 1 s after the last: the last
    np.testing.assert_array_equal(got[[0]], [np.nan])
    assert got[1:].tolist() == [0.1, 0.1, 0.7, pytest.approx(1.0, abs=1e-12), 1.3, 1.3]
    assert heading_at(log, [4], tolerance=1.0).tolist() == [0.7]  # a single row
    assert heading_at(log, [3], tolerance=1.0).tolist() == [pytest.approx(0.4, abs=1e-12)]
    assert np.isnan(heading_at(log, [1, 7], tolerance=0.5)).all()  # 1 s away, 0.5 s allowed


def test_a_heading_row_reads_its_own_heading_bit_for_bit():
    """Not re-derived from the heading before it (-3.1 + wrap(-0.9 + 3.1) is -0.8999999999999999)."""
    pose = np.full((2, 3), np.nan)
    pose[:, 2] = [-3.1, -0.9]
    log = WheelLog(np.arange(2.0), np.ones(2), np.ones(2), pose, None, np.zeros(2, int))
    assert heading_at(log, [0, 1], tolerance=1.0).tolist() == [-3.1, -0.9]


def _quarter_log() -> WheelLog:
    """Drive 10 s straight at 1 m/s, rows every 0.25 s, positions at 0, 5 and 10 s.

    Headings 0.75 s after the start, at 5 s, and 0.75 s before the end (0.2, 0.5, 0.9 rad).
    """
    t = np.arange(0.0, 10.25, 0.25)
    pose = np.full((t.size, 3), np.nan)
    pose[[0, 20, 40], :2] = [[0.0, 0.0], [5.0, 0.0], [10.0, 0.0]]
    pose[[3, 20, 37], 2] = [0.2, 0.5, 0.9]
    return WheelLog(t, np.ones(t.size), np.ones(t.size), pose, None, np.zeros(t.size, int))


def test_heading_change_takes_the_tolerance_at_both_ends():
    log = _quarter_log()
    change = heading_change(log, [0, 20], [20, 40], tolerance=1.0)
    np.testing.assert_allclose(change, [0.3, 0.4], atol=1e-12)
    assert np.isnan(heading_change(log, [0, 20], [20, 40])).all()  # 0.75 s > 0.5 s


def test_sparse_window_errors_take_the_heading_tolerance():
    log = _quarter_log()
    w = Windows(np.array([0, 20]), np.array([20, 40]), np.array([5.0, 5.0]))
    straight = model_twist(get_model("idd"), [], 1.0)
    err = sparse_window_errors(log, w, straight, tolerance=1.0)
    np.testing.assert_allclose(err.rotation, [0.3, 0.4], atol=1e-12)  # it predicts no turn
    np.testing.assert_allclose(err.translation, [0.0, 0.0], atol=1e-12)
    assert err.predicted.shape == (2, 3)
    np.testing.assert_allclose(err.predicted, [[5.0, 0.0, 0.0], [10.0, 0.0, 0.0]], atol=1e-12)
    assert np.isnan(sparse_window_errors(log, w, straight).rotation).all()


def _every_row(seconds: float = 30.0) -> tuple[WheelLog, np.ndarray]:
    """Varying track speeds of a robot with known ICRs; an antenna fix and a heading on every row."""
    t = np.arange(0.0, seconds, 0.05)
    v_l = 0.8 + 0.3 * np.sin(t / 4.0)
    v_r = 0.8 + 0.3 * np.cos(t / 3.0)
    true = integrate(*twist_icr(v_l[:-1], v_r[:-1], *ICR), np.diff(t), start=[5.0, 1.0, 2.0])
    c, s = np.cos(true[:, 2]), np.sin(true[:, 2])
    pose = np.c_[
        true[:, 0] + c * ANTENNA[0] - s * ANTENNA[1],
        true[:, 1] + s * ANTENNA[0] + c * ANTENNA[1],
        true[:, 2],
    ]
    return WheelLog(t, v_l, v_r, pose, None, np.zeros(t.size, int)), true


def test_windows_of_different_lengths_fit_only_their_own_fixes():
    """Windows of a chunk are padded to the longest: the padding is no fix of the shorter ones."""
    log, _ = _every_row()
    w = spatial_windows(log, 3.0, anchor="position")
    assert np.unique(w.end - w.start).size > 5  # a chunk holds windows of several lengths
    true = icr_twist_from_rows(w, *(np.full(len(log), v) for v in ICR))
    err = sparse_window_errors(log, w, true, antenna=ANTENNA)
    assert err.translation.shape == (len(w),)
    assert err.translation.max() < 1e-9
    assert err.rotation.max() < 1e-9


def test_heading_windows_score_no_translation_even_where_rows_hold_positions():
    log, _ = _every_row(10.0)
    w = spatial_windows(log, 2.0, anchor="heading")
    true = icr_twist_from_rows(w, *(np.full(len(log), v) for v in ICR))
    err = sparse_window_errors(log, w, true, anchor="heading")
    assert np.isnan(err.translation).all() and np.isnan(err.predicted[:, :2]).all()
    assert err.rotation.max() < 1e-9


def test_anchored_window_errors_dispatch_on_the_anchor():
    log, _ = _every_row(10.0)
    for anchor in ("pose", "position", "heading"):
        w = spatial_windows(log, 2.0, anchor=anchor)
        twist = model_twist(get_model("idd"), [], 1.0)
        got = anchored_window_errors(log, w, twist, anchor=anchor, antenna=ANTENNA)
        if anchor == "pose":
            want = window_errors(log, w, twist)
        else:
            want = sparse_window_errors(log, w, twist, anchor=anchor, antenna=ANTENNA)
        assert got.windows is w
        np.testing.assert_array_equal(got.predicted, want.predicted)
        np.testing.assert_array_equal(got.translation, want.translation)
        np.testing.assert_array_equal(got.rotation, want.rotation)
    # the lever arm is passed on: without it the true model's antenna path is wrong
    w = spatial_windows(log, 2.0, anchor="position")
    true = icr_twist_from_rows(w, *(np.full(len(log), v) for v in ICR))
    assert (
        anchored_window_errors(log, w, true, anchor="position", antenna=ANTENNA).translation.max()
        < 1e-9
    )
    assert anchored_window_errors(log, w, true, anchor="position").translation.max() > 0.01


def test_a_window_without_turn_predicts_a_heading_change_of_plus_zero():
    """The start is +0.0 and a sum with +0.0 is never -0.0: no -0.0 reaches a report."""
    log = _quarter_log()
    w = Windows(np.array([0, 20]), np.array([20, 40]), np.array([5.0, 5.0]))

    def minus_zero_turn(v_l, v_r, _i):
        return 0.5 * (v_l + v_r), 0.0 * v_l, -0.0 * v_l

    for anchor in ("position", "heading"):
        turn = sparse_window_errors(log, w, minus_zero_turn, anchor=anchor).predicted[:, 2]
        assert turn.tolist() == [0.0, 0.0] and not np.signbit(turn).any()


@pytest.mark.parametrize(("name", "value"), [("antenna_x", "auto"), ("antenna_y", math.nan)])
def test_a_lever_arm_that_is_no_number_yet_is_refused_by_name(name, value):
    config = Config()
    config = dataclasses.replace(
        config, pose_sensor=dataclasses.replace(config.pose_sensor, **{name: value})
    )
    with pytest.raises(ConfigError) as err:
        antenna_of(config)
    assert str(err.value) == (
        f"pose_sensor.{name} is {value!r}: scoring needs the lever arm in metres (a run's "
        "config.yaml has the value it used)"
    )
