"""The refusal of training data without motion or turning, at its thresholds and in its words.

Hand-made segment sets: two segments of two 0.5-s steps at track speeds
(0.5, 1.5) m/s, one turning left, one right, so that every figure is exact.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrain_odom.errors import EstimationError
from terrain_odom.fitting import fit_model
from terrain_odom.fitting.identify import MIN_TRAVEL, MIN_TURN, _check_excitation
from terrain_odom.fitting.segments import SegmentBlock, SegmentSet


def _segments(length=5.0, dt=0.5, yaw=(1.0, -1.0), speed_scale=1.0):
    """Two segments; wheel travel 0.5 |v_l + v_r| dt = 1 m each at ``dt = 0.5``."""
    v_l = speed_scale * np.array([[0.5, 0.5], [1.5, 1.5]])
    v_r = speed_scale * np.array([[1.5, 1.5], [0.5, 0.5]])
    target = np.zeros((2, 3))
    target[:, 2] = yaw
    block = SegmentBlock(v_l, v_r, np.full((2, 2), dt), target)
    return SegmentSet((block,), 2, length, float(4 * dt))


def test_the_thresholds_are_a_metre_and_half_a_radian():
    assert (MIN_TRAVEL, MIN_TURN) == (1.0, 0.5)


def test_pose_travel_of_exactly_min_travel_is_enough_and_less_is_refused_by_name():
    _check_excitation("edd-sym", _segments(length=MIN_TRAVEL))
    message = "the poses of the training segments travel 0.99 m in all: no motion to fit edd-sym to"
    with pytest.raises(EstimationError, match=f"^{re.escape(message)}$"):
        fit_model("edd-sym", _segments(length=0.99))


def test_wheel_travel_is_the_centre_speed_times_the_time():
    # 0.5 |0.5 + 1.5| * 0.5 s * 2 steps * 2 segments = 2 m; a quarter of the time: 0.5 m
    _check_excitation("edd-sym", _segments(speed_scale=0.5))  # exactly 1 m
    message = "the wheels of the training segments travel 0.50 m in all: no motion to fit icr to"
    with pytest.raises(EstimationError, match=f"^{re.escape(message)}$"):
        fit_model("icr", _segments(dt=0.125))
    with pytest.raises(EstimationError, match="wheels of the training segments travel 0.99 m"):
        fit_model("icr", _segments(speed_scale=0.495))


def test_measured_turn_is_the_sum_of_absolute_heading_changes():
    _check_excitation("edd-sym", _segments(yaw=(0.25, -0.25)))  # exactly MIN_TURN
    message = (
        "the training segments turn 28.1 deg in all: no turning to identify roc from; "
        "fit on a log with turns"
    )
    with pytest.raises(EstimationError, match=f"^{re.escape(message)}$"):
        fit_model("roc", _segments(yaw=(0.245, -0.245)), track_width=1.0)
    # segments without a heading change measured count as not turning where others measured one
    with pytest.raises(EstimationError, match="turn 28.1 deg"):
        fit_model("roc", _segments(yaw=(0.49, np.nan)), track_width=1.0)


def test_without_headings_the_wheels_and_track_width_judge_the_turn():
    unmeasured = (np.nan, np.nan)
    # each segment turns (1.5 - 0.5) / B * 1 s: with B = 4 m, 0.25 rad each way, 0.5 in all
    _check_excitation("icr", _segments(yaw=unmeasured), track_width=4.0)
    with pytest.raises(EstimationError, match=r"turn 28\.5 deg in all"):  # 0.4975 rad
        fit_model("icr", _segments(yaw=unmeasured), track_width=4.02)
    # without a track width there is no judgement: accepted however little the wheels turn
    _check_excitation("icr", _segments(yaw=unmeasured), track_width=None)
