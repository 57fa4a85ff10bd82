"""Plausibility checks pinned where mutation testing found them loose (issue 28).

Each test states a property with a hand-computed answer: the travel chords
and the noise taken out of them, the position noise estimated from second
differences, each run's rows compared once, the inclusive bounds, the yaw
messages in full, and what the result carries. The logs are those of
``test_plausibility_thresholds.py``: rows every 1/8 s, a pose on every 4th
row, track width 1 m.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.evaluation.mounting import MountingFit
from terrain_odom.evaluation.plausibility import (
    PlausibilityLimits,
    _position_noise,
    check_log,
)
from terrain_odom.evaluation.robust import MAD_TO_STD
from terrain_odom.records import WheelLog
from tests.evaluation.test_plausibility_thresholds import (
    DT,
    LIM,
    TRACK,
    _drive,
    _heading_log,
    _log,
    _rows,
)


# ------------------------------------------------------------ travel chords
@pytest.mark.parametrize(
    ("speed", "sigma", "chords"),
    [
        (1.0, 0.5, 12),  # chords of 5 sigma = 2.5 m: 12 over 30 m
        (0.25, 0.1, 15),  # chords of 0.5 m, 2 s each at 0.25 m/s: 15 over 30 s
    ],
)
def test_chords_are_five_sigma_of_wheel_travel_less_two_sigma_squared(speed, sigma, chords):
    """Exact straight poses at ``speed`` for 30 s, a stated noise ``sigma``.

    Each chord runs ``travel_chords * sigma`` of wheel travel and its length
    ``L`` counts as ``sqrt(L**2 - 2 sigma**2)``. Chords of 0.5 s instead
    would be shorter than the noise and count nothing.
    """
    n = _rows(30.0)
    log = _drive(np.full(n, speed), np.full(n, speed), pose_speed=speed)
    result = check_log(log, TRACK, LIM, position_noise=sigma)
    length = LIM.travel_chords * sigma
    assert result.wheel_travel == pytest.approx(chords * length, rel=1e-12)
    assert result.pose_travel == pytest.approx(
        chords * np.sqrt(length**2 - 2.0 * sigma**2), rel=1e-12
    )


def test_wheel_travel_follows_each_rows_speed():
    """Standing 10 s, then 20 s at 1 m/s: 20 m of wheel travel (not the first row's 0 m/s)."""
    n = _rows(30.0)
    v = np.where(np.arange(n) < _rows(10.0) - 1, 0.0, 1.0)
    result = check_log(_drive(v, v), TRACK, LIM, position_noise=1e-9)
    assert result.wheel_travel == pytest.approx(20.0, rel=1e-12)


# --------------------------------------------------------- position noise
def _positions(xy) -> WheelLog:
    xy = np.asarray(xy, float)
    n = xy.shape[0]
    pose = np.c_[xy, np.zeros(n)]
    return WheelLog(np.arange(n) * DT, np.ones(n), np.ones(n), pose, None, np.zeros(n, int))


def test_position_noise_of_gaussian_positions_is_their_standard_deviation():
    """A straight path at 1 m per row plus N(0, 0.3 m) per axis: the estimate within 5 %."""
    rng = np.random.default_rng(1)
    k = np.arange(4000.0)
    xy = np.c_[k, np.zeros_like(k)] + rng.normal(0.0, 0.3, (k.size, 2))
    assert _position_noise(_positions(xy)) == pytest.approx(0.3, rel=0.05)


def test_three_fixes_give_one_second_difference():
    """Fixes (0, 0), (1, 0), (2, 2e): the second difference (0, 2e), median |.| e."""
    e = 0.01
    expected = MAD_TO_STD * e / np.sqrt(6.0)
    assert _position_noise(_positions([(0.0, 0.0), (1.0, 0.0), (2.0, 2 * e)])) == pytest.approx(
        expected, rel=1e-12
    )


@pytest.mark.parametrize("missing", [0, 1])
def test_a_row_with_only_one_coordinate_is_not_a_position(missing):
    """As ``WheelLog.has_position`` says: x without y (or y without x) is no fix."""
    rng = np.random.default_rng(2)
    xy = np.c_[np.arange(40.0), np.zeros(40)] + rng.normal(0.0, 0.1, (40, 2))
    half = np.r_[xy, [[41.0, 0.0]]]
    half[-1, missing] = np.nan
    assert _position_noise(_positions(half)) == _position_noise(_positions(xy))


# ------------------------------------------------------- runs of the log
def test_each_run_s_intervals_are_counted_once():
    """Two segments of 6 s each with poses moving 1 m/s and the wheels still: 12 s of motion."""
    n = _rows(6.0)
    one = _drive(np.zeros(n), np.zeros(n), pose_speed=1.0)
    both = WheelLog(
        np.r_[one.t, 100.0 + one.t], np.r_[one.v_l, one.v_l], np.r_[one.v_r, one.v_r],
        np.r_[one.pose, one.pose], None, np.repeat([0, 1], n),
    )  # fmt: skip
    (finding,) = check_log(both, TRACK, LIM).findings
    assert finding.message == (
        "the poses move while the wheels stand still over 100 % of 12 s of motion: "
        "wrong wheel columns, or poses of another run"
    )


# ------------------------------------------------------------ bounds
def test_a_median_time_step_of_exactly_the_upper_bound_is_plausible():
    n = 60
    step = LIM.time_step[1]
    log = _log(np.ones(n), np.ones(n), np.full((n, 3), np.nan), dt=step)
    result = check_log(log, TRACK, LIM)
    assert result.median_step == step
    assert result.ok, result.findings


@pytest.mark.parametrize("side", [0, 1])
def test_a_yaw_scale_exactly_at_a_bound_is_plausible(side):
    log = _heading_log(1.0, scale=0.8)
    scale = check_log(log, TRACK, LIM).yaw_scale
    bounds = list(LIM.yaw_scale)
    bounds[side] = scale
    result = check_log(log, TRACK, dataclasses.replace(LIM, yaw_scale=tuple(bounds)))
    assert result.yaw_scale == scale
    assert result.ok, result.findings


# ---------------------------------------------------------------- yaw
def test_a_heading_turning_less_than_min_turn_is_not_judged_however_far_the_wheels_turn():
    """Wheels 3 rad, the heading 0.3 rad against them: too little heading turn to judge."""
    log = _heading_log(-1.0, scale=0.1, turn=3.0)
    assert check_log(log, TRACK, LIM).ok


def test_the_yaw_sign_message_in_full():
    (finding,) = check_log(_heading_log(-1.0, turn=3.0), TRACK, LIM).findings
    assert finding == dataclasses.replace(
        finding,
        check="yaw_sign",
        message="the heading turns against the wheels (correlation -1.00): left and right "
        "wheels swapped, or yaw not counter-clockwise",
    )


@pytest.mark.parametrize(
    ("corr", "scale", "told"),
    [
        (0.1, 1.0, "the heading does not follow the wheels' turn (correlation 0.10"),
        (1.0, 5.0, "the heading turns x5 as fast as the wheels say (correlation 1.00"),
    ],
)
def test_the_yaw_follow_messages_in_full(corr, scale, told):
    (finding,) = check_log(_heading_log(corr, scale=scale / corr), TRACK, LIM).findings
    assert finding.check == "yaw_follow"
    assert finding.message == f"{told}): yaw in degrees, or a track width far off"


def test_a_heading_that_never_changes_gives_no_yaw_fit():
    """Wheels turning 3 rad, the heading constant: no scale and no correlation (NaN), no warning."""
    log = _heading_log(1.0, scale=1.0, turn=3.0)
    pose = log.pose.copy()
    pose[np.isfinite(pose[:, 2]), 2] = 0.25
    result = check_log(dataclasses.replace(log, pose=pose), TRACK, LIM)
    assert np.isnan(result.yaw_scale) and np.isnan(result.yaw_correlation)
    assert result.ok, result.findings


def test_positions_without_headings_get_no_yaw_finding():
    """An exact arc of 3 rad, its headings left out: nothing to judge the heading by."""
    n = _rows(30.0)
    log = _drive(np.full(n, 0.9), np.full(n, 1.1))
    pose = log.pose.copy()
    pose[:, 2] = np.nan
    result = check_log(dataclasses.replace(log, pose=pose), TRACK, LIM, position_noise=1e-9)
    assert np.isnan(result.yaw_scale)
    assert not [f for f in result.findings if f.check.startswith("yaw")], result.findings


# ------------------------------------------------------------ the result
def test_the_unit_findings_still_report_the_top_speed():
    n = _rows(20.0)
    v = np.ones(n)
    v[40] = 1.01 * LIM.max_speed
    result = check_log(_drive(v, v), TRACK, LIM)
    assert [f.check for f in result.findings] == ["absurd_speed"]
    assert result.max_speed == 1.01 * LIM.max_speed


def test_the_result_carries_the_mounting_fit():
    """Straight at 1 m/s for 60 s, the heading measured 0.1 rad off the course."""
    n = _rows(60.0)
    log = _drive(np.ones(n), np.ones(n), pose_speed=1.0)
    pose = log.pose.copy()
    pose[np.isfinite(pose[:, 2]), 2] = 0.1
    result = check_log(dataclasses.replace(log, pose=pose), TRACK, PlausibilityLimits())
    assert isinstance(result.mounting, MountingFit)
    assert result.mounting.heading_offset == pytest.approx(0.1, abs=1e-9)
