"""The wheel path's least squares against positions drawn from it with known answers.

Written for the survivors of a mutation run (docs/testing.md). The yaw
scale: positions are the wheel path itself with the ideal yaw scaled by a
known ``k`` (noise-free), so the least squares is exact at ``k`` and the
parabola through the grid's costs must find it between grid points. The
windows' fit: a straight line and an uneven turn, by hand. The heading's
scale: over 1-s chains, with an IMU late.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation.wheel_path import (
    Fixes,
    Track,
    fit_windows,
    ideal_yaw,
    run_time,
    wheel_track,
    window_fixes,
    yaw_scale_from_headings,
    yaw_scale_from_positions,
)
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log


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


def test_fit_windows_on_a_straight_line_by_hand():
    """1 m/s along x, fixes at 0..4 s in two windows: info sum (t - 2)^2 = 10, nothing to turn."""
    t = np.arange(0.0, 20.0, 0.5)
    track = Track(t, t + 0j, np.zeros(t.size))
    ft = np.r_[np.arange(5.0), 10.0 + np.arange(5.0)]
    fixes = Fixes(ft, ft + 3.0 + 1j, np.repeat([0, 1], 5))  # shifted by (3, 1): T absorbs it
    fit = fit_windows(track, fixes, 0.0, lever=True)
    np.testing.assert_allclose(fit.info, [10.0, 10.0], atol=1e-12)
    np.testing.assert_allclose(fit.c, [1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(fit.residual, np.zeros(10), atol=1e-12)
    assert fit.residual.shape == (10,) and fit.cost == pytest.approx(0.0, abs=1e-20)
    # a straight line turns nowhere: no information on the lever arm, none of the turning kept
    assert fit.u_kept == 0.0 and fit.a == 0j
    np.testing.assert_array_equal(fit.a_info, np.zeros((2, 2)))


def test_fit_windows_at_the_positions_own_delay_fits_exactly():
    """Positions drawn at wheel time t - 0.3 s: exact at delay 0.3, not at 0."""
    t = np.arange(6000) * 0.01
    psi = 0.8 * np.sin(0.5 * t) + 0.3 * np.sin(1.7 * t)
    q = np.r_[0.0, np.cumsum(np.exp(1j * 0.5 * (psi[1:] + psi[:-1])) * np.diff(t))]
    track = Track(t, q, psi)
    rows = np.arange(100, t.size, 20)
    fixes = Fixes(t[rows] + 0.3, q[rows] * np.exp(0.4j), (t[rows] // 10.0).astype(int))
    at = fit_windows(track, fixes, 0.3, lever=True)
    assert at.cost < 1e-12 and at.a == pytest.approx(0j, abs=1e-6)
    np.testing.assert_allclose(at.c, np.exp(0.4j), atol=1e-9)
    assert fit_windows(track, fixes, 0.0, lever=True).cost > 1e6 * max(at.cost, 1e-20)
    # the information matrix of (a_x, a_y) is |u|^2 times the identity (the design's columns
    # are orthogonal and as long), and a share of the turning is kept
    info = at.a_info
    assert info[0, 1] == pytest.approx(0.0, abs=1e-9) and info[1, 0] == pytest.approx(0.0, abs=1e-9)
    assert info[0, 0] == pytest.approx(info[1, 1], rel=1e-12) and info[0, 0] > 0.0
    # the share kept: |u|^2 over |u~|^2, u~ the heading's unit vector centred per window
    e = np.exp(1j * (psi[rows] + 0.4))
    centred = (
        e
        - (np.bincount(fixes.window, e.real) + 1j * np.bincount(fixes.window, e.imag))[fixes.window]
        / np.bincount(fixes.window)[fixes.window]
    )
    assert at.u_kept == pytest.approx(info[0, 0] / np.sum(np.abs(centred) ** 2), rel=1e-6)
    assert 0.0 < at.u_kept < 1.0
    # without the lever arm nothing of it is fitted
    plain = fit_windows(track, fixes, 0.3, lever=False)
    assert plain.a == 0j and plain.u_kept == 0.0
    np.testing.assert_array_equal(plain.a_info, np.zeros((2, 2)))
    assert plain.cost < 1e-12


def test_the_heading_scale_is_taken_over_1_s_chains_not_consecutive_headings():
    """Check an IMU 0.1 s late, not compensated.

    Over 1-s intervals the turns still mostly agree (scale 0.895); between consecutive
    headings 0.02 s apart they decorrelate (0.79). With the delay given: 1.
    """
    clean = constant_model_log("idd", [], seconds=120.0, track_width=1.0, noise=(0.0, 0.0, 0.0))
    quiet = {"gps_noise": 0.0, "gps_walk": 0.0, "heading_wander": 0.0, "heading_noise": 0.0}
    log = degrade_log(clean, Degradation(imu_latency=0.1, seed=0, **quiet)).log
    time = run_time(log)
    assert yaw_scale_from_headings(log, time, 1.0, 0.0) > 0.85
    assert yaw_scale_from_headings(log, time, 1.0, 0.1) == pytest.approx(1.0, abs=0.02)
