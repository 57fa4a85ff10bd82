"""The yaw scale found from positions alone, against the scale the positions were drawn with.

Written for the survivors of a mutation run (docs/testing.md). The
positions are the wheel path itself with the ideal yaw scaled by a known
``k`` (noise-free), so the least squares is exact at ``k`` and the
parabola through the grid's costs must find it between grid points.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation.wheel_path import (
    Fixes,
    ideal_yaw,
    run_time,
    wheel_track,
    window_fixes,
    yaw_scale_from_positions,
)
from terrain_odom.records import WheelLog


def _drawn_with(
    k: float, turning: bool = True, speed: float = 1.0
) -> tuple[WheelLog, np.ndarray, Fixes]:
    """Two minutes of varying track speeds at 20 Hz, positions at 5 Hz drawn with scale ``k``."""
    t = np.arange(0.0, 120.0, 0.05)
    v_l = speed * (1.0 + 0.5 * np.sin(t / 3.0))
    v_r = speed * (1.0 + 0.5 * np.cos(t / 2.0)) if turning else v_l.copy()
    log = WheelLog(t, v_l, v_r, np.full((t.size, 3), np.nan), None, np.zeros(t.size, int))
    time = run_time(log)
    q = wheel_track(log, time, k * ideal_yaw(log, time, 1.0)).q
    log.pose[::4, 0], log.pose[::4, 1] = q.real[::4], q.imag[::4]
    return log, time, window_fixes(log, time, 10.0, 5)


@pytest.mark.parametrize(("k", "speed"), [(0.73, 1.0), (1.12, 1.0), (0.73, 0.01)])
def test_the_scale_between_grid_points_is_found(k, speed):
    """At any speed (a slow robot's costs are tiny: the parabola still applies)."""
    log, time, fixes = _drawn_with(k, speed=speed)
    assert yaw_scale_from_positions(log, time, 1.0, fixes, (0.3, 1.5)) == pytest.approx(k, abs=3e-3)


def test_a_scale_near_the_top_of_the_range_uses_the_top_grid_point():
    log, time, fixes = _drawn_with(0.74)
    assert yaw_scale_from_positions(log, time, 1.0, fixes, (0.5, 0.75)) == pytest.approx(
        0.74, abs=3e-3
    )


@pytest.mark.parametrize(("k", "bound"), [(0.9, 0.75), (0.2, 0.3)])
def test_a_scale_beyond_the_range_is_found_at_its_bound(k, bound):
    """Not extrapolated beyond the range searched (the parabola's step is at most a grid step)."""
    log, time, fixes = _drawn_with(k)
    low = 0.5 if bound == 0.75 else 0.3
    got = yaw_scale_from_positions(log, time, 1.0, fixes, (low, low + 0.25 if k > 0.5 else 1.5))
    assert got == pytest.approx(bound, abs=1e-9)


def test_without_positions_or_turns_the_scale_is_what_the_search_cannot_move():
    log, time, _ = _drawn_with(1.0)
    none = Fixes(np.zeros(0), np.zeros(0, complex), np.zeros(0, int))
    assert yaw_scale_from_positions(log, time, 1.0, none, (0.3, 1.5)) == 1.0
    # straight driving: every scale fits alike; no parabola through equal costs (no NaN)
    log, time, fixes = _drawn_with(1.0, turning=False)
    got = yaw_scale_from_positions(log, time, 1.0, fixes, (0.3, 1.5))
    assert 0.3 <= got <= 1.5
    assert np.isclose(got / 0.05, round(got / 0.05), atol=1e-9)  # a grid point, not moved
