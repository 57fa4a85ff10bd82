"""Non-finite track speeds are refused, one by one and in a compiled stretch, before they reach the state."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain_odom.config import EkfConfig
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import IcrEkf


def _ekf() -> IcrEkf:
    ekf = IcrEkf(EkfConfig())
    ekf.reset_pose([0.0, 0.0, 0.0])
    return ekf


@pytest.mark.parametrize("v_l, v_r", [(math.nan, 1.0), (1.0, math.nan), (math.inf, 1.0)])
def test_predict_refuses_a_speed_that_is_not_finite_and_keeps_the_state(v_l, v_r):
    ekf = _ekf()
    before, p_before, t_before = ekf.x.copy(), ekf.P.copy(), ekf.t
    with pytest.raises(EstimationError, match="finite track speeds"):
        ekf.predict(v_l, v_r, 0.1)
    np.testing.assert_array_equal(ekf.x, before)  # nothing half-applied
    np.testing.assert_array_equal(ekf.P, p_before)
    assert ekf.t == t_before


@pytest.mark.parametrize("where", ["since", "v_l", "v_r"])
def test_run_rows_refuses_a_speed_that_is_not_finite_and_keeps_the_state(where):
    ekf = _ekf()
    t = np.array([0.1, 0.2, 0.3])
    v_l, v_r = np.full(3, 0.5), np.full(3, 0.6)
    since = (0.0, 0.5, 0.6)
    if where == "since":
        since = (0.0, math.nan, 0.6)
    else:
        (v_l if where == "v_l" else v_r)[1] = math.nan
    before = ekf.x.copy()
    with pytest.raises(EstimationError, match="finite track speeds"):
        ekf.run_rows(since, t, (v_l, v_r), np.full((3, 3), np.nan))
    np.testing.assert_array_equal(ekf.x, before)


def test_finite_speeds_still_move_the_pose_as_before():
    ekf = _ekf()
    ekf.predict(1.0, 1.0, 0.5)  # straight ahead: 0.5 m along x whatever the ICRs
    assert ekf.x[0] == pytest.approx(0.5, abs=1e-12)
    assert ekf.x[1] == pytest.approx(0.0, abs=1e-12)
