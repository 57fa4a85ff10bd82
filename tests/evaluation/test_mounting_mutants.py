"""The mounting the log shows, by hand: chords of exact runs, and the findings at their thresholds.

Written for mutation survivors (docs/testing.md). A finding is reported
beyond ``heading_offset`` (5 deg) and 3.76 standard errors; the chords'
offset only with ``min_judged`` (20) straight chords and only where
calibrate's own fit (``windowed``) is not given. The chords are counted by
hand on straight runs whose times and positions are exact in binary.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.evaluation.calibration import CalibrationLimits, Estimate, LeverArm
from terrain_odom.evaluation.mounting import (
    MountingFit,
    MountingLimits,
    _heading_at,
    fit_mounting,
    mounting_findings,
)
from terrain_odom.evaluation.mounting import _chords as mounting_chords
from terrain_odom.records import WheelLog

NO_LEVER = LeverArm(0.0, 0.0, 0.01, 0.01, 1.0)


def _chords(offset_deg: float, spread_deg: float, n: int, correlation: float = 1.0) -> MountingFit:
    return MountingFit(
        math.radians(offset_deg), math.radians(spread_deg), n, NO_LEVER, (0.0, 0.0), correlation
    )


def test_the_chords_offset_is_reported_in_full():
    assert mounting_findings(_chords(8.0, 5.0, 20), 0.5) == [
        (
            "heading_offset",
            "the measured heading is +8.0 deg off the course of the positions on 20 straight "
            "stretches (spread 5.0 deg): a heading sensor mounted turned, or magnetic "
            "declination; set pose_sensor.heading_offset (radians, or auto)",
        )
    ]


def test_the_chords_offset_needs_min_judged_chords():
    assert mounting_findings(_chords(8.0, 5.0, 19), 0.5) == []
    assert mounting_findings(_chords(8.0, 5.0, 0), 0.5) == []


def test_the_offset_must_exceed_5_deg():
    assert mounting_findings(_chords(5.0, 0.1, 100), 0.5) == []  # exactly the limit
    assert len(mounting_findings(_chords(5.001, 0.1, 100), 0.5)) == 1
    assert len(mounting_findings(_chords(-5.001, 0.1, 100), 0.5)) == 1


@pytest.mark.parametrize("correlation", [1.0, 4.0])
def test_the_offset_must_exceed_3_76_standard_errors_of_correlated_chords(correlation):
    """The standard error is spread sqrt(correlation / n): 100 chords, 8 deg, at 3.76 of them."""
    spread = 8.0 / 3.76 * math.sqrt(100 / correlation)
    assert mounting_findings(_chords(8.0, spread * 1.001, 100, correlation), 0.5) == []
    assert len(mounting_findings(_chords(8.0, spread * 0.999, 100, correlation), 0.5)) == 1


def _windowed(offset_deg: float, std_deg: float, chords_deg: float = 20.0) -> MountingFit:
    est = Estimate(math.radians(offset_deg), math.radians(std_deg), True, "windows")
    return MountingFit(
        math.radians(chords_deg), math.radians(1.0), 100, NO_LEVER, (0.0, 0.0), 1.0, est
    )


def test_calibrates_own_offset_replaces_the_chords():
    # the chords say 20 deg, calibrate's fit 1 deg: nothing to report
    assert mounting_findings(_windowed(1.0, 0.1), 0.5) == []
    assert mounting_findings(_windowed(5.0, 0.1), 0.5) == []  # exactly the limit
    assert mounting_findings(_windowed(-8.0, 8.0 / 3.76 * 1.001), 0.5) == []
    ((check, message),) = mounting_findings(_windowed(-8.0, 8.0 / 3.76 * 0.999), 0.5)
    assert check == "heading_offset" and message.startswith("the measured heading is -8.0 deg")


def test_the_heading_offset_calibrate_leaves_is_reported_in_full():
    assert mounting_findings(_windowed(10.0, 0.5, chords_deg=0.0), 1.0) == [
        (
            "heading_offset",
            "the measured heading is +10.0 deg (+-0.5) off the robot's against the wheel path "
            "in windows of positions: a heading sensor mounted turned, or magnetic declination; "
            "add it to pose_sensor.heading_offset (radians), or set auto (terrain-odom "
            "calibrate finds it)",
        )
    ]


def _lever(x: float, y: float, std: float, antenna=(0.0, 0.0)) -> MountingFit:
    return MountingFit(0.0, 0.01, 100, LeverArm(x, y, std, std, 0.5), antenna, 1.0)


def test_a_lever_arm_left_is_reported_in_full_for_each_axis():
    assert mounting_findings(_lever(0.0, 0.6, 0.05), 0.5) == [
        (
            "lever_arm",
            "in turns the positions swing as from an antenna at y = +0.60 m (+-0.05) from the "
            "point that does not slide sideways, +0.60 m from pose_sensor.antenna_y +0.00: set "
            "it to +0.60, or to auto (terrain-odom calibrate finds it)",
        )
    ]
    assert mounting_findings(_lever(-0.6, 0.0, 0.2, antenna=(-5.0, 0.0)), 0.5) == [
        (
            "lever_arm",
            "in turns the positions swing as from an antenna at x = -0.60 m (+-0.20) from the "
            "point that does not slide sideways, +4.40 m from pose_sensor.antenna_x -5.00: "
            "measure the antenna (the log cannot tell it from 0), or set 0",
        )
    ]
    both = mounting_findings(_lever(0.5, -0.5, 0.05), 0.5)
    assert [m.split(" m (")[0][-9:] for _, m in both] == ["x = +0.50", "y = -0.50"]


def test_headings_at_times_interpolate_unwrapped_within_the_gap():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    yaw = np.array([3.0, np.nan, -3.0, -2.9])  # through +-pi; row 1 has no heading
    at = np.array([-0.5, -0.75, 1.0, 1.5, 3.5, 3.75])
    got = _heading_at(t, yaw, at, 0.5)
    turn = 2 * np.pi - 6.0  # from 3.0 to -3.0 the short way, over 2 s
    np.testing.assert_allclose(
        got, [3.0, np.nan, np.nan, 3.0 + 0.75 * turn, 3.0 + turn + 0.1, np.nan],
        atol=1e-12,
    )  # fmt: skip
    # 0.4 s after a heading and 0.6 s before the next: near enough
    assert _heading_at(t, yaw, np.array([2.4]), 0.5)[0] == pytest.approx(3.0 + turn + 0.04)
    # the gap is measured to the nearer heading, before or after (both 1 s from 1.0 s)
    assert _heading_at(t, yaw, np.array([1.0]), 1.0)[0] == pytest.approx(3.0 + turn / 2)
    assert np.isnan(_heading_at(t, yaw, np.array([1.0]), 0.9)[0])
    assert np.isnan(_heading_at(t, np.full(4, np.nan), np.array([0.0, 1.0]), 0.5)).all()
    assert _heading_at(t, np.full(4, np.nan), np.array([0.0, 1.0]), 0.5).dtype == float


def _straight_run(speed: float, offset: float, seconds: float = 20.0, heading_every: int = 1):
    """Along x at ``speed`` m/s, rows every 0.125 s (exact), headings ``offset`` rad off."""
    t = np.arange(0.0, seconds + 1e-9, 0.125)
    yaw = np.full(t.size, offset)
    yaw[np.arange(t.size) % heading_every != 0] = np.nan
    pose = np.c_[speed * t, 0 * t, yaw]
    v = np.full(t.size, speed)
    return WheelLog(t, v, v.copy(), pose, None, np.zeros(t.size, int))


def test_straight_chords_of_a_straight_run_by_hand():
    """3-m chords every row: 24 rows each at 1 m/s; 161 rows give 137 chords, all 0.1 rad off."""
    fit = fit_mounting(_straight_run(1.0, 0.1), 1.0)
    assert fit.straight == 137
    assert fit.heading_offset == pytest.approx(0.1, abs=1e-12)
    assert fit.heading_spread == pytest.approx(0.0, abs=1e-12)
    assert fit.antenna == (0.0, 0.0) and fit.windowed is None  # 20 s: too short for windows
    configured = fit_mounting(_straight_run(1.0, 0.1), 1.0, offset=0.25, antenna=(0.5, -0.2))
    assert configured.heading_offset == pytest.approx(-0.15, abs=1e-12)
    assert configured.antenna == (0.5, -0.2)


def test_chords_longer_than_max_chord_time_are_dropped():
    """At 0.125 m/s a 3-m chord takes exactly 24 s."""
    slow = _straight_run(0.125, 0.1, seconds=40.0)
    assert fit_mounting(slow, 1.0).straight == 0  # 24 s > 20 s
    limits = MountingLimits(max_chord_time=24.0)
    assert fit_mounting(slow, 1.0, limits=limits).straight == 129  # 321 rows - 192 steps


def test_positions_far_from_a_heading_make_no_chord():
    """Headings every 1 s: a position more than 0.5 s from one has no heading."""
    run = _straight_run(1.0, 0.1, heading_every=8)
    assert fit_mounting(run, 1.0).straight == 137  # every row within 0.5 s of a heading
    tight = MountingLimits(yaw_gap=0.375)
    assert fit_mounting(run, 1.0, limits=tight).straight == 0  # rows 4, 12, ... have none


def test_too_few_straight_chords_give_no_offset():
    short = _straight_run(1.0, 0.1, seconds=3.5)  # 29 rows: chords from rows 0 .. 4
    fit = fit_mounting(short, 1.0)
    assert fit.straight == 5 and fit.heading_offset == pytest.approx(0.1, abs=1e-12)
    fewer = fit_mounting(short, 1.0, limits=MountingLimits(min_straight=6))
    assert fewer.straight == 5 and np.isnan(fewer.heading_offset)
    assert np.isnan(fewer.heading_spread) and fewer.correlation == 1.0


def test_chords_are_3_m_of_wheel_travel_at_any_speed():
    """1 m/s for 10 s, then 0.5 m/s: 15 m in all, a chord from every row up to 12 m (14 s)."""
    run = _straight_run(1.0, 0.1)
    slow = run.t >= 10.0
    v = np.where(slow, 0.5, 1.0)
    x = np.where(slow, 10.0 + 0.5 * (run.t - 10.0), run.t)
    run = dataclasses.replace(run, v_l=v, v_r=v.copy(), pose=np.c_[x, 0 * x, run.pose[:, 2]])
    fit = fit_mounting(run, 1.0)
    assert fit.straight == 113 and fit.heading_offset == pytest.approx(0.1, abs=1e-12)


def test_no_chord_crosses_from_one_run_to_the_next():
    one = _straight_run(1.0, 0.1, seconds=10.0)  # 81 rows: 57 chords
    two = dataclasses.replace(
        one,
        t=np.r_[one.t, one.t],  # the second run starts again at 0 s, 100 m away
        v_l=np.r_[one.v_l, one.v_l],
        v_r=np.r_[one.v_r, one.v_r],
        pose=np.r_[one.pose, one.pose + [100.0, 0.0, 0.0]],
        segment=np.repeat([0, 1], one.t.size),
    )
    assert fit_mounting(one, 1.0).straight == 57
    assert fit_mounting(two, 1.0).straight == 114


def test_a_row_with_x_but_no_y_or_y_but_no_x_is_no_position():
    run = _straight_run(1.0, 0.1)
    rows = np.arange(10, 150, 7)
    half, none = run.pose.copy(), run.pose.copy()
    half[rows, 1] = np.nan
    none[rows, :2] = np.nan
    got = fit_mounting(dataclasses.replace(run, pose=half), 1.0)
    assert got.straight == fit_mounting(dataclasses.replace(run, pose=none), 1.0).straight
    assert got.heading_offset == pytest.approx(0.1, abs=1e-12)
    half = run.pose.copy()
    half[rows, 0] = np.nan  # and a y without x
    assert fit_mounting(dataclasses.replace(run, pose=half), 1.0).straight == got.straight


def test_a_chord_over_a_position_without_heading_is_dropped():
    """Headings missing for 9 rows around row 80: only row 80 is over 0.5 s from one."""
    run = _straight_run(1.0, 0.1)
    run.pose[76:85, 2] = np.nan
    # the 25 chords from rows 56 .. 80 (24 rows each) hold row 80
    assert fit_mounting(run, 1.0).straight == 137 - 25


def test_a_log_of_two_rows_3_m_apart_has_one_chord():
    two = _straight_run(1.0, 0.1, seconds=24 * 0.125).take([0, 24])  # 3 m apart
    assert len(two) == 2 and fit_mounting(two, 1.0).straight == 1


def test_a_log_of_one_row_has_no_chord():
    one = _straight_run(1.0, 0.1, seconds=0.0)
    assert len(one) == 1
    fit = fit_mounting(one, 1.0)
    assert fit.straight == 0 and np.isnan(fit.heading_offset)


def test_the_configured_antenna_is_taken_off_before_the_course():
    """Drive a 100-m circle at 1 m/s, read by an antenna at (1.0, 0.5) m.

    3-m chords turn 0.03 rad (straight): with the antenna configured the offset is 0; without,
    its swing biases the course.
    """
    t = np.arange(0.0, 40.0 + 1e-9, 0.125)
    omega, radius, antenna = 0.01, 100.0, np.array([1.0, 0.5])
    yaw = omega * t
    c, s = np.cos(yaw), np.sin(yaw)
    x = radius * s + c * antenna[0] - s * antenna[1]
    y = radius * (1.0 - c) + s * antenna[0] + c * antenna[1]
    v_l, v_r = np.full(t.size, 1.0 - omega / 2), np.full(t.size, 1.0 + omega / 2)
    log = WheelLog(t, v_l, v_r, np.c_[x, y, yaw], None, np.zeros(t.size, int))
    configured = fit_mounting(log, 1.0, antenna=(1.0, 0.5))
    assert configured.straight == 297
    assert configured.heading_offset == pytest.approx(0.0, abs=1e-6)
    assert abs(fit_mounting(log, 1.0).heading_offset) > 1e-3


def test_calibrates_own_offset_uses_the_given_limits_and_the_configured_offset():
    """40 s straight: four 10-s windows, enough only if calibrate's limits ask for two."""
    run = _straight_run(1.0, 0.1, seconds=40.0)
    assert fit_mounting(run, 1.0, offset=0.02).windowed is None  # 8 windows by default
    lim = MountingLimits(lever=CalibrationLimits(min_windows=2))
    windowed = fit_mounting(run, 1.0, offset=0.02, limits=lim).windowed
    assert windowed is not None and windowed.observable is True
    assert windowed.value == pytest.approx(0.08, abs=1e-9)  # 0.1 measured, 0.02 configured
    assert (
        windowed.how == "circular median of measured heading minus the wheel path's over 4 windows"
    )


def test_positions_and_headings_on_different_rows_make_chords():
    """A GPS on even rows without heading, an IMU on odd rows: the headings are interpolated."""
    run = _straight_run(1.0, 0.1)
    pose = run.pose.copy()
    pose[0::2, 2] = np.nan
    pose[1::2, :2] = np.nan
    fit = fit_mounting(dataclasses.replace(run, pose=pose), 1.0)
    assert fit.straight == 69  # fixes every 0.25 s: 3-m chords of 12 fixes, from 81 fixes
    assert fit.heading_offset == pytest.approx(0.1, abs=1e-12)


def test_a_chord_the_wheels_turn_exactly_straight_turn_is_not_straight():
    """Wheels turning 1/32 rad/s: a 3-m chord (3 s) turns them 0.09375 rad exactly."""
    run = _straight_run(1.0, 0.0)  # the GPS and the IMU say straight
    turning = dataclasses.replace(run, v_l=run.v_l - 1 / 64, v_r=run.v_r + 1 / 64)
    at = MountingLimits(straight_turn=0.09375)
    assert fit_mounting(turning, 1.0, limits=at).straight == 0
    assert fit_mounting(turning, 1.0, limits=MountingLimits(straight_turn=0.0938)).straight == 137
    # on a track of 0.5 m, half the speed difference turns as much
    narrow = dataclasses.replace(run, v_l=run.v_l - 1 / 128, v_r=run.v_r + 1 / 128)
    assert fit_mounting(narrow, 0.5, limits=at).straight == 0
    assert fit_mounting(narrow, 0.5, limits=MountingLimits(straight_turn=0.0938)).straight == 137
    # the same turn measured by the IMU alone, the wheels straight
    pose = run.pose.copy()
    pose[:, 2] = run.t / 32
    imu = dataclasses.replace(run, pose=pose)
    assert fit_mounting(imu, 1.0, limits=at).straight == 0
    assert fit_mounting(imu, 1.0, limits=MountingLimits(straight_turn=0.0938)).straight == 137


def test_a_chord_driven_back_and_forth_is_not_straight():
    """2.25 m forward, 0.75 m back: 3 m of wheel travel for 1.5 m of chord (moved 0.5 < 0.7)."""
    t = np.arange(25) * 0.125
    v = np.where(np.arange(25) < 18, 1.0, -1.0)
    x = np.r_[0.0, np.cumsum(v[:-1] * 0.125)]
    log = WheelLog(t, v, v.copy(), np.c_[x, 0 * x, 0 * x], None, np.zeros(25, int))
    chords = mounting_chords(log, 1.0, np.zeros(2), 0.0, MountingLimits())
    assert chords.moved.tolist() == [0.5]
    assert fit_mounting(log, 1.0).straight == 0
    assert fit_mounting(log, 1.0, limits=MountingLimits(min_moved=0.5)).straight == 0  # not beyond
    assert fit_mounting(log, 1.0, limits=MountingLimits(min_moved=0.4999)).straight == 1
