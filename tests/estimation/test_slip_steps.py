"""The slip EKF's steps: the chords a GPS alone measures, and no batch of rows."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import Config
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.estimation.slip_steps import _CourseFixes


def test_course_fixes_measure_a_right_angle_and_skip_a_standing_robot() -> None:
    """Fixes at (0,0), (1,0), (1,1): a chord of 1 m turned +90 deg, variances sigma^2 (1, 2)."""
    course = _CourseFixes(length=1.0, sigma=0.1)
    assert course.add(np.array([0.0, 0.0]), 0) == (True, None)
    assert course.add(np.array([0.2, 0.0]), 1) == (False, None)  # within a quarter chord
    kept, pair = course.add(np.array([1.0, 0.0]), 2)
    assert kept and pair is None  # one chord: no turn yet
    kept, pair = course.add(np.array([1.0, 1.0]), 3)
    assert kept and pair is not None
    (xy_b, b), (xy_a, a) = pair
    assert (b, a) == (0, 2)
    z, variances = course.measured(xy_b, xy_a, np.array([1.0, 1.0]))
    assert z == pytest.approx([1.0, np.pi / 2])
    assert variances == pytest.approx([0.01, 0.02])


def test_the_slip_ekf_runs_rows_one_by_one() -> None:
    """Its steps never offer a batch, anchored or not."""
    odo = OnlineOdometry(Config(), estimator="slip-ekf")
    for k in range(3):
        odo.wheels(0.1 * k, 0.5, 0.5)
        odo.pose(0.1 * k, 0.05 * k, 0.0, 0.0)
        assert odo._steps.batch() is None
