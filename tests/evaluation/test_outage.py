"""Outage windows: dead reckoning a frozen model through a loss of the poses, against hand-checked cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain_odom.evaluation import (
    Windows,
    frozen_icr_table,
    icr_twist_per_window,
    is_sparse,
    model_twist,
    outage_errors,
    outage_starts,
    outage_table,
    outage_windows,
)
from terrain_odom.kinematics import get_model, integrate, twist_icr
from terrain_odom.records import WheelLog

ICR = (0.9, -0.8, 0.15, 0.95)  # y_l, y_r, x_icr, alpha of the "true" robot
ANTENNA = (-1.0, 0.3)
RATE = 20.0


def _arc_log(seconds=130.0, v_l=0.8, v_r=1.2, segment=None, heading_offset=2.7):
    """Constant track speeds on a circle with known ICRs: antenna fixes at 2.5 Hz, headings between.

    Positions are the antenna's (``ANTENNA``), with no yaw; headings (true yaw
    plus a mounting offset) on other rows, with no position.
    """
    t = np.arange(0.0, seconds, 1.0 / RATE)
    n = t.size
    vl, vr = np.full(n, v_l), np.full(n, v_r)
    true = integrate(*twist_icr(vl[:-1], vr[:-1], *ICR), np.diff(t), start=[3.0, -2.0, 0.4])
    pose = np.full((n, 3), np.nan)
    fixes = np.arange(2, n, 8)  # 2.5 Hz, after the first heading
    c, s = np.cos(true[fixes, 2]), np.sin(true[fixes, 2])
    pose[fixes, 0] = true[fixes, 0] + c * ANTENNA[0] - s * ANTENNA[1]
    pose[fixes, 1] = true[fixes, 1] + s * ANTENNA[0] + c * ANTENNA[1]
    heads = np.setdiff1d(np.arange(1, n, 2), fixes)
    pose[heads, 2] = np.angle(np.exp(1j * (true[heads, 2] + heading_offset)))
    seg = np.zeros(n, dtype=int) if segment is None else segment(t)
    return WheelLog(t, vl, vr, pose, None, seg, "<arc>"), true


def test_the_true_model_from_the_true_heading_dead_reckons_without_error():
    log, true = _arc_log()
    w = outage_windows(log, 30.0)
    assert len(w) == 11  # a fix every 10 s of the 130-s log; the last ends 0.4 s short
    assert np.allclose(log.t[w.end] - log.t[w.start], 30.0, atol=0.41)
    n = len(w)
    twist = icr_twist_per_window(*(np.full(n, v) for v in ICR))
    err = outage_errors(log, w, true[w.start, 2], twist, duration=30.0, antenna=ANTENNA)
    assert err.position.max() < 1e-9
    assert err.heading.max() < 1e-9  # the 2.7-rad mounting offset cancels in the change
    # left out, the lever arm shows: the antenna circles the ICR on its own radius
    wrong = outage_errors(log, w, true[w.start, 2], twist, duration=30.0)
    assert wrong.position.min() > 0.1


def test_idd_with_the_nominal_track_ends_where_the_chords_say():
    """ICRs 2 m apart, idd with B = 1 m: a 5-m circle where the robot drives a 10-m one."""
    t = np.arange(4001) * 0.01
    v_l, v_r = np.full(t.size, 0.9), np.full(t.size, 1.1)
    true = integrate(*twist_icr(v_l[:-1], v_r[:-1], 1.0, -1.0, 0.0), np.diff(t))
    pose = np.full((t.size, 3), np.nan)
    pose[::100, :2] = true[::100, :2]  # 1-Hz positions only
    log = WheelLog(t, v_l, v_r, pose, None, np.zeros(t.size, int))
    w = outage_windows(log, 10.0, every=10.0)
    assert len(w) == 4 and np.allclose(log.t[w.end] - log.t[w.start], 10.0)
    idd = model_twist(get_model("idd"), [], 1.0)
    err = outage_errors(log, w, true[w.start, 2], idd, duration=10.0)

    def chord(radius, turn, heading):
        length = 2.0 * radius * math.sin(turn / 2.0)
        return length * np.array([math.cos(heading + turn / 2), math.sin(heading + turn / 2)])

    for k, row in enumerate(w.start):
        yaw = true[row, 2]
        expected = np.linalg.norm(chord(5.0, 2.0, yaw) - chord(10.0, 1.0, yaw))
        assert err.position[k] == pytest.approx(expected, abs=1e-9)
    assert np.isnan(err.heading).all()  # no heading rows: no heading error
    assert err.heading_stats.count == 0 and err.position_stats.count == 4


def test_outage_windows_stay_in_their_segment_and_vanish_when_too_long():
    """Also where time starts again in each segment (a log's time need only rise within one)."""
    log, _ = _arc_log(segment=lambda t: (t >= 70.0).astype(int))
    w = outage_windows(log, 30.0)
    runs = log.segment_runs()
    assert np.array_equal(runs[w.start], runs[w.end])
    # fixes at 0.1 s + 0.4 k: the ends nearest 70.1 s and 130.1 s lie short, in their segment
    assert np.allclose(log.t[w.start], [0.1, 10.1, 20.1, 30.1, 40.1, 70.1, 80.1, 90.1, 100.1])
    assert len(outage_windows(log, 80.0)) == 0
    restarted = WheelLog(log.t - 70.0 * log.segment, log.v_l, log.v_r, log.pose, None,
                         log.segment)  # fmt: skip
    again = outage_windows(restarted, 30.0)
    assert np.array_equal(again.start, w.start) and np.array_equal(again.end, w.end)
    for bad in (0.0, 0.5, -5.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="outage duration"):
            outage_windows(log, bad)


def test_outage_table_matches_window_by_window_dead_reckoning():
    """Constant models integrated once per segment, frozen ones once per start: the same numbers."""
    log, true = _arc_log(segment=lambda t: (t >= 70.0).astype(int))
    rng = np.random.default_rng(3)
    per_row = np.c_[
        rng.uniform(0.5, 1.0, len(log)),
        rng.uniform(-1.0, -0.5, len(log)),
        rng.uniform(-0.2, 0.2, len(log)),
        np.ones(len(log)),
    ]

    def learned(w: Windows):
        return icr_twist_per_window(*per_row[w.start].T)

    idd_rows = get_model("idd").twist(log.v_l, log.v_r, [], 1.08)
    table = outage_table(
        log,
        (20.0, 30.0),
        lambda rows: true[rows, 2],
        {"learned": learned, "idd": idd_rows},
        antenna=ANTENNA,
    )
    assert set(table) == {20.0, 30.0}
    idd = model_twist(get_model("idd"), [], 1.08)
    for duration, models in table.items():
        w = models["learned"].windows
        yaw = true[w.start, 2]
        one = outage_errors(log, w, yaw, learned(w), duration=duration, antenna=ANTENNA)
        np.testing.assert_allclose(models["learned"].position, one.position, atol=1e-9)
        np.testing.assert_allclose(models["learned"].heading, one.heading, atol=1e-9)
        two = outage_errors(log, w, yaw, idd, duration=duration, antenna=ANTENNA)
        np.testing.assert_allclose(models["idd"].position, two.position, atol=1e-8)
        np.testing.assert_allclose(models["idd"].heading, two.heading, atol=1e-9)


def test_frozen_icr_table_reads_the_states_it_was_given():
    log, true = _arc_log()
    starts = outage_starts(log, (30.0, 60.0))
    states = np.c_[true[starts, 2], np.tile(ICR, (starts.size, 1))]
    table = frozen_icr_table(
        log, (30.0, 60.0), starts, states, (0.54, -0.54, 0.0, 1.0), track_width=1.08,
        antenna=ANTENNA,
    )  # fmt: skip
    for models in table.values():
        assert models["learned"].position.max() < 1e-9
        # nominal (y = +-0.54, no x_icr, alpha 1) is exactly the idd of B = 1.08 m
        np.testing.assert_allclose(models["nominal"].position, models["idd"].position)
        assert models["idd"].position.min() > 1.0


def test_sparse_means_fixes_without_heading_or_slower_than_7_hz():
    log, _ = _arc_log()
    assert is_sparse(log)
    t = np.arange(0.0, 10.0, 0.05)
    full = np.c_[t, 0 * t, 0 * t]
    dense = WheelLog(t, t, t, full, None, np.zeros(t.size, int))
    assert not is_sparse(dense)
    assert is_sparse(dense.take(np.arange(t.size) % 5 == 0))  # 4 Hz full poses
    none = WheelLog(t, t, t, np.full((t.size, 3), np.nan), None, np.zeros(t.size, int))
    assert not is_sparse(none)
