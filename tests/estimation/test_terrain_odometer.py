"""``Odometer.arrival`` (the arrival rule over a log) against hand-integrated distances.

Written for mutants of ``estimation/terrain.py`` no test killed
(docs/testing.md): the tests drove at one constant speed from a row in the
middle of the log, so the speed of the wrong row, an odometer not starting
at 0, and a zero distance interpolated instead of returned were all alike.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.estimation.terrain import Odometer
from terrain_odom.records import WheelLog

ICRS = np.array([0.3, -0.3, 0.0])  # straight ahead the model's speed is the tracks' speed


def _odometer(speed: list[float], segment: list[int] | None = None) -> Odometer:
    """Straight drive, one row a second, each row's speed held until the next row."""
    n = len(speed)
    v = np.asarray(speed, dtype=float)
    seg = np.zeros(n, dtype=int) if segment is None else np.asarray(segment)
    log = WheelLog(np.arange(float(n)), v, v, np.full((n, 3), np.nan), None, seg)
    return Odometer(log, np.tile(np.r_[np.zeros(3), ICRS], (n, 1)))


def test_arrival_interpolates_in_the_row_whose_speed_holds_there():
    # 1, 2, 3, 4, 5 m/s for a second each: 0, 1, 3, 6, 10, 15 m at t = 0 .. 5 s
    odometer = _odometer([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert odometer.arrival(0, 0.0, 5.0) == pytest.approx(2.0 + 2.0 / 3.0)  # 3 m + 2 m at 3 m/s
    assert odometer.arrival(0, 0.0, 1.0) == pytest.approx(1.0)
    assert odometer.arrival(0, 0.0, 12.0) == pytest.approx(4.0 + 2.0 / 5.0)
    # from t = 1.5 s (2 m at 2 m/s), 4 m further: 1 m to t = 2 s, 3 m at 3 m/s
    assert odometer.arrival(1, 1.5, 4.0) == pytest.approx(3.0)
    assert odometer.arrival(2, 2.5, 100.0) is None  # the log ends first


def test_zero_distance_is_reached_at_once_even_standing_still():
    still = _odometer([0.0] * 6)
    for row in range(6):
        assert still.arrival(row, float(row), 0.0) == float(row)
    assert still.arrival(2, 2.0, 0.5) is None  # standing still, no ground is reached
    moving = _odometer([1.0, 2.0, 3.0])
    assert moving.arrival(2, 2.0, 0.0) == 2.0  # the last row: nothing to interpolate in


def test_arrival_in_a_later_segment_does_not_depend_on_earlier_ones():
    """Only the distance inside one run counts: a run's arrivals are those of the run alone."""
    speed = [2.0, 2.0, 2.0, 1.0, 2.0, 3.0, 4.0, 1.0, 1.0]
    segment = [0, 0, 0, 1, 1, 1, 1, 2, 2]
    whole = _odometer(speed, segment)
    alone = _odometer(speed[3:7])
    for row, t, distance in [(3, 3.0, 2.5), (4, 4.5, 1.0), (3, 3.2, 5.0), (5, 5.0, 2.9)]:
        expected = alone.arrival(row - 3, t - 3.0, distance)
        assert expected is not None
        assert whole.arrival(row, t, distance) == pytest.approx(expected + 3.0)
    # run 1 holds 1 + 2 + 3 = 6 m up to its last row, and no more
    assert whole.arrival(3, 3.0, 6.5) is None
    assert whole.arrival(2, 2.0, 1.0) is None  # run 0's last row: its ground is never reached
