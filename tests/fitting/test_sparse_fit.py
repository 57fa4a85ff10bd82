"""``fit`` on a log of GPS fixes and IMU headings on different rows: the known ICRs come back."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.errors import EstimationError
from terrain_odom.fitting import (
    FitOptions,
    fit_model,
    parse_horizon,
    segment_set,
    training_windows,
)
from tests.evaluation.test_sparse import ANTENNA, ICR, _log

QUICK = FitOptions(popsize=8, maxiter=60)  # then polished by least squares


def _fit(positions, headings, antenna=ANTENNA, model="icr-slip"):
    log = _log(positions=positions, headings=headings)
    anchor = "position" if positions else "heading"
    windows = training_windows(log, parse_horizon("3m"), anchor=anchor)
    segments = segment_set([log], [windows], anchor=anchor, antenna=antenna)
    return fit_model(model, segments, track_width=1.0, options=QUICK)


@pytest.mark.parametrize("headings", [True, False])
def test_fixes_with_or_without_headings_give_back_the_true_icrs(headings):
    result = _fit(True, headings)
    np.testing.assert_allclose(result.params, ICR, atol=2e-3)


def test_a_lever_arm_left_out_is_fitted_as_a_wrong_x_icr():
    result = _fit(True, True, antenna=(0.0, 0.0))
    assert abs(result.params[2] - ICR[2]) > 0.1


def test_headings_alone_give_the_turn_rate_only():
    """Headings see one combination only: omega = alpha (v_r - v_l) / (y_l - y_r)."""
    result = _fit(False, True)
    y_l, y_r, _, alpha = result.params
    assert alpha / (y_l - y_r) == pytest.approx(ICR[3] / (ICR[0] - ICR[1]), rel=1e-4)


def test_fixes_alone_on_a_straight_line_are_refused_for_lack_of_turning():
    log = _log(headings=False)
    straight = type(log)(log.t, log.v_l, log.v_l, log.pose, None, log.segment, "<straight>")
    windows = training_windows(straight, parse_horizon("3m"), anchor="position")
    segments = segment_set([straight], [windows], anchor="position", antenna=ANTENNA)
    with pytest.raises(EstimationError, match="turn 0.0 deg in all"):
        fit_model("icr", segments, track_width=1.0)
