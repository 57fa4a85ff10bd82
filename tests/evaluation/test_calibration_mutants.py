"""Self-calibration's estimates against injected truth and by hand, and when the log cannot give them.

Written for the survivors of a mutation run (docs/testing.md). Mostly two
minutes of ideal differential drive (speeds changing every 0.5 s) with a GPS
and an IMU injected by :func:`~terrain_odom.sim.degrade.degrade_log`,
noise-free; the heading offset and wander also by hand on eight windows.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from terrain_odom.evaluation.calibration import (
    CalibrationLimits,
    Estimate,
    _heading_offset,
    _heading_wander,
    fit_sensors,
    lever_significant,
    x_icr_limit,
)
from terrain_odom.evaluation.robust import MAD_TO_STD, correlation_time
from terrain_odom.evaluation.wheel_path import Fixes, WindowFit
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log

QUIET = {"gps_noise": 0.0, "gps_walk": 0.0, "heading_wander": 0.0, "heading_noise": 0.0}


@pytest.fixture(scope="module")
def clean() -> WheelLog:
    return constant_model_log("idd", [], seconds=120.0, track_width=1.0, noise=(0.0, 0.0, 0.0))


def _unknown(est: Estimate, how: str) -> None:
    assert math.isnan(est.value) and math.isnan(est.std)
    assert est.observable is False
    assert est.how == how


def test_a_delay_at_the_edge_of_the_search_is_not_observable(clean):
    log = degrade_log(clean, Degradation(latency=0.4, seed=0, **QUIET)).log
    fit = fit_sensors(log, 1.0, limits=CalibrationLimits(max_delay=0.2))
    _unknown(
        fit.position_delay,
        "the best position delay lies at the edge of +-0.2 s: drive with starts, stops and "
        "turns, or give the delay in seconds",
    )
    # a lever arm at an untimed delay can be anything: fitted as at delay 0, error unknown
    assert fit.lever.std_x == fit.lever.std_y == math.inf
    at_zero = fit_sensors(log, 1.0, position_delay=0.0, limits=CalibrationLimits(max_delay=0.2))
    assert (fit.lever.x, fit.lever.y) == (at_zero.lever.x, at_zero.lever.y)
    # and the headings are compared at delay 0 as well
    assert fit.heading_offset.value == at_zero.heading_offset.value
    assert not fit.antenna_x.observable and not fit.antenna_y.observable


def test_without_headings_the_heading_estimates_say_so(clean):
    log = degrade_log(clean, Degradation(imu_rate=0.0, latency=0.4, seed=0, **QUIET)).log
    fit = fit_sensors(log, 1.0)
    for est in (fit.heading_offset, fit.heading_noise, fit.heading_wander):
        _unknown(est, "the log has no headings")


def test_eight_windows_are_enough_and_two_headings_are_headings(clean):
    log = degrade_log(clean.take(slice(0, 1600)), Degradation(seed=0, **QUIET)).log  # 80 s
    fit = fit_sensors(log, 1.0)
    assert fit.windows == 8 and fit.position_noise.observable
    two = dataclasses.replace(log, pose=log.pose.copy())
    rows = np.flatnonzero(np.isfinite(two.pose[:, 2]))
    two.pose[rows[2:], 2] = np.nan  # two headings left
    assert fit_sensors(two, 1.0).heading_offset.how != "the log has no headings"


def test_too_few_windows_leave_every_estimate_unknown(clean):
    log = degrade_log(clean.take(slice(0, 600)), Degradation(seed=0, **QUIET)).log  # 30 s
    fit = fit_sensors(log, 1.0)
    assert fit.windows == 3
    why = (
        "only 3 windows of 10 s with 5 positions over 5 s or more (at least 8; runs of the log "
        "shorter than that count none): record longer with positions while driving"
    )
    for name in ("position_delay", "heading_offset", "antenna_x", "antenna_y",
                 "position_noise", "heading_noise", "heading_wander"):  # fmt: skip
        _unknown(getattr(fit, name), why)


def test_windows_that_hardly_move_give_no_heading_offset(clean):
    """The same run 50 times smaller (track width 2 cm): every window's path spans < 0.5 m."""
    small = dataclasses.replace(
        clean, v_l=clean.v_l / 50, v_r=clean.v_r / 50, pose=clean.pose * [0.02, 0.02, 1.0]
    )
    fit = fit_sensors(degrade_log(small, Degradation(seed=0, **QUIET)).log, 0.02)
    assert fit.windows >= 8
    _unknown(
        fit.heading_offset,
        "fewer than 8 windows of 10 s moving 0.5 m: drive further with positions and headings",
    )
    _unknown(fit.heading_wander, "too few moving windows")


def test_white_heading_noise_is_measured_within_3_percent(clean):
    """6,000 heading increments at 50 Hz: the robust estimate's own error is ~1.3 %."""
    d = Degradation(seed=0, **{**QUIET, "heading_noise": 0.01})
    est = fit_sensors(degrade_log(clean, d).log, 1.0).heading_noise
    assert est.observable and est.value == pytest.approx(0.01, rel=0.03)
    assert est.std == pytest.approx(est.value / math.sqrt(5994), rel=1e-9)
    assert est.how == "robust std of 5994 consecutive heading increments about the wheels' turn"


def test_twenty_heading_increments_are_enough(clean):
    log = degrade_log(clean, Degradation(seed=0, **QUIET)).log
    pose = log.pose.copy()
    rows = np.flatnonzero(np.isfinite(pose[:, 2]))
    pose[np.setdiff1d(rows, rows[::50][:21]), 2] = np.nan  # 21 headings a second apart
    est = fit_sensors(dataclasses.replace(log, pose=pose), 1.0).heading_noise
    assert est.observable and est.how.startswith("robust std of 20 consecutive heading")


def test_a_few_headings_give_an_offset_but_no_heading_noise(clean):
    log = degrade_log(clean, Degradation(imu_rate=0.1, seed=0, **QUIET)).log  # 12 headings
    fit = fit_sensors(log, 1.0)
    assert fit.heading_offset.observable
    _unknown(fit.heading_noise, "fewer than 20 heading increments")


def _eight_windows(cost: float) -> tuple[WindowFit, np.ndarray, Fixes]:
    """Eight windows of five fixes; the three lowest offsets weigh ten times more."""
    window = np.repeat(np.arange(8), 5)
    fixes = Fixes(np.arange(40.0), np.zeros(40, complex), window)
    info = np.array([100.0, 100.0, 100.0, 10.0, 10.0, 10.0, 10.0, 10.0])
    fit = WindowFit(cost, np.zeros(40, complex), np.ones(8, complex), info, 0j, np.eye(2), 1.0)
    offsets = np.array([-0.03, -0.02, -0.01, 0.0, 0.0, 0.01, 0.02, 0.03])
    return fit, offsets, fixes


def test_heading_wander_is_the_spread_about_the_weighted_median_beyond_the_fits_own():
    """Check the wander by hand.

    2 * 40 - 4 * 8 - 2 = 46 degrees of freedom (two per fix, four per window, two for the
    lever arm); the weighted median is -0.02, the median distance from it 0.02.
    """
    fit, offsets, fixes = _eight_windows(cost=46 * 2e-5)
    est = _heading_wander(fit, offsets, fixes, CalibrationLimits())
    own = 2e-5 / 10.0  # the median window's variance: cost / dof / its information
    assert est.value == pytest.approx(math.sqrt((MAD_TO_STD * 0.02) ** 2 - own), rel=1e-9)
    dev = offsets + 0.02
    assert est.std == pytest.approx(
        est.value / math.sqrt(2.0 * max(8 / correlation_time(dev), 1.0)), rel=1e-9
    )
    assert est.how == "spread of the heading offset over 8 windows beyond their own error"


def test_heading_offset_is_the_weighted_circular_median_of_the_moving_windows():
    """By hand, the last window exactly at the least extent (1.25 m^2 over 5 fixes = 0.5^2)."""
    fit, offsets, fixes = _eight_windows(cost=1.0)
    fit = dataclasses.replace(fit, info=np.r_[fit.info[:7], 1.25])
    est = _heading_offset(fit, offsets, fixes, CalibrationLimits())
    assert est.value == pytest.approx(-0.02, abs=1e-12)
    dev = offsets + 0.02  # median distance 0.02
    spread = MAD_TO_STD * 0.02
    assert est.std == pytest.approx(spread * math.sqrt(correlation_time(dev) / 8), rel=1e-9)
    assert est.how == "circular median of measured heading minus the wheel path's over 8 windows"
    below = dataclasses.replace(fit, info=np.r_[fit.info[:7], 1.2499])
    assert not _heading_offset(below, offsets, fixes, CalibrationLimits()).observable


@pytest.fixture(scope="module")
def mounted(clean) -> WheelLog:
    """Return the run read by a GPS 0.4 s late, antenna at (-0.8, 0.3) m, an IMU turned 3 rad."""
    d = Degradation(latency=0.4, antenna=(-0.8, 0.3), heading_offset=3.0, seed=0, **QUIET)
    return degrade_log(clean, d).log


def test_a_given_delay_is_taken_as_exact(mounted):
    given = fit_sensors(mounted, 1.0, position_delay=0.4)
    assert given.position_delay == Estimate(0.4, 0.0, True, "given")
    fitted = fit_sensors(mounted, 1.0)
    assert fitted.position_delay.value == pytest.approx(0.4, abs=0.01)
    assert fitted.position_delay.observable is True
    assert re.fullmatch(
        r"least squares of \d+ positions against the wheel path, delays \+-1.5 s",
        fitted.position_delay.how,
    )
    # the estimated delay's error adds to the lever arm's; a given one adds none
    assert fitted.lever.std_x > 1.1 * given.lever.std_x
    assert given.antenna_x.std == given.lever.std_x


def test_a_delay_whose_standard_error_is_exactly_the_limit_is_calibrated(mounted):
    std = fit_sensors(mounted, 1.0).position_delay.std
    at = fit_sensors(mounted, 1.0, limits=CalibrationLimits(max_delay_std=std)).position_delay
    assert at.std == std and at.observable is True


def test_a_delay_too_uncertain_keeps_its_value_and_standard_error(mounted):
    fit = fit_sensors(mounted, 1.0, limits=CalibrationLimits(max_delay_std=1e-6))
    delay = fit.position_delay
    assert delay.value == pytest.approx(0.4, abs=0.01) and 1e-6 < delay.std < 0.01
    assert delay.observable is False
    assert delay.how == (
        "too little change of speed and heading against the position noise to time the "
        "positions (standard error 0.00 s > 1e-06 s): drive with starts, stops and turns, or "
        "give the delay in seconds"
    )
    assert math.isfinite(fit.lever.std_x)  # the lever arm's error includes it


def test_a_coarse_lever_arm_is_applied_only_where_significant(mounted):
    fit = fit_sensors(mounted, 1.0, limits=CalibrationLimits(max_antenna_std=1e-5))
    what = "(from the point that does not slide sideways: only antenna - x_icr is observable)"
    x, y = fit.antenna_x, fit.antenna_y
    assert x.observable and x.value == pytest.approx(-0.8, abs=0.02)  # beyond B / 2 = 0.5 m
    assert x.std == fit.lever.std_x
    assert x.how == (
        "coarse (standard error > 1e-05 m), applied as it is significant: least squares of "
        f"positions against the wheel path {what}; measure the antenna for better"
    )
    assert not y.observable and math.isnan(y.value) and math.isnan(y.std)  # 0.3 m: within
    assert re.fullmatch(
        r"standard error of antenna_y 0\.00 m > 1e-05 m and least squares gives \+0\.30 m, "
        r"within the noise or a robot's own x_icr \(\d+ % of the turning is neither straight "
        r"driving nor steady arcs\): drive longer, with S-bends and turns of changing "
        r"sharpness, or measure the antenna",
        y.how,
    )
    calibrated = fit_sensors(mounted, 1.0).antenna_y
    assert calibrated.observable and calibrated.value == pytest.approx(0.3, abs=0.02)
    assert calibrated.std == fit.lever.std_y
    assert calibrated.how == (
        f"least squares of positions against the wheel path in uneven turns {what}"
    )


def test_position_noise_and_its_standard_error(clean):
    d = Degradation(latency=0.4, seed=0, **{**QUIET, "gps_noise": 0.2})
    fit = fit_sensors(degrade_log(clean, d).log, 1.0)
    noise = fit.position_noise
    assert noise.observable and noise.value == pytest.approx(0.2, rel=0.1)
    m = re.fullmatch(r"robust std of (\d+) positions about the wheel path \((\d+) windows\)",
                     noise.how)  # fmt: skip
    assert m is not None and int(m.group(2)) == fit.windows
    dof = 2 * int(m.group(1)) - 4 * fit.windows - 2
    assert noise.std == pytest.approx(noise.value / math.sqrt(2.0 * dof), rel=1e-12)


def test_the_lever_arms_error_adds_the_delays_through_the_slope(mounted):
    """std^2 = (least squares' own)^2 + (d a / d delay * std_delay)^2, the slope over +-0.05 s."""
    fit = fit_sensors(mounted, 1.0)
    best, std = fit.position_delay.value, fit.position_delay.std
    plain = fit_sensors(mounted, 1.0, position_delay=best).lever
    up = fit_sensors(mounted, 1.0, position_delay=best + 0.05).lever
    down = fit_sensors(mounted, 1.0, position_delay=best - 0.05).lever
    slope_x, slope_y = (up.x - down.x) / 0.1, (up.y - down.y) / 0.1
    assert (fit.lever.x, fit.lever.y) == (plain.x, plain.y)
    assert fit.lever.std_x == pytest.approx(math.hypot(plain.std_x, slope_x * std), rel=1e-9)
    assert fit.lever.std_y == pytest.approx(math.hypot(plain.std_y, slope_y * std), rel=1e-9)


def test_lever_significance_by_its_own_limits():
    lim = CalibrationLimits()
    assert x_icr_limit(1.0) == 0.5 and x_icr_limit(0.5) == 0.35  # B / 2, at least 0.35 m
    wide = CalibrationLimits(lever_fraction=0.25, min_lever=1.0)
    assert x_icr_limit(1.0, wide) == 1.0 and x_icr_limit(8.0, wide) == 2.0
    assert lever_significant(-0.8, 0.05, 1.0, lim)
    assert not lever_significant(-0.8, 0.05, 1.0, wide)  # within its 1 m
    assert not lever_significant(0.5, 0.05, 1.0, lim)  # exactly B / 2: not beyond
    assert not lever_significant(0.8, 0.27, 1.0, lim)  # 3 std = 0.81
    assert lever_significant(0.8, 0.26, 1.0, lim)
    assert not lever_significant(5.0, 1.01, 1.0, lim)  # std beyond max_coarse_std
    assert lever_significant(5.0, 1.0, 1.0, lim)
    assert not lever_significant(float("nan"), 0.01, 1.0, lim)


@pytest.mark.parametrize("latency", [0.405, 0.407])
def test_a_delay_between_grid_points_is_found_by_the_parabola(clean, latency):
    """The fine grid steps 0.01 s; the vertex finds 0.405 and 0.407 s within 2.5 ms."""
    log = degrade_log(clean, Degradation(latency=latency, seed=0, **QUIET)).log
    assert fit_sensors(log, 1.0).position_delay.value == pytest.approx(latency, abs=2.5e-3)


def test_positions_of_pure_noise_give_a_delay_of_unknown_error(clean):
    """30-m GPS noise: the costs near the best delay bend the wrong way: no curvature, no error."""
    d = Degradation(seed=1, **{**QUIET, "gps_noise": 30.0})
    delay = fit_sensors(degrade_log(clean, d).log, 1.0).position_delay
    assert delay.std == math.inf and delay.observable is False
    assert "(standard error inf s > 0.15 s)" in delay.how


def test_heading_noise_ignores_a_steady_heading_drift(clean):
    """A heading drifting 0.5 rad/s (0.01 rad a 50-Hz step) beside white noise of 0.01 rad."""
    d = Degradation(seed=0, **{**QUIET, "heading_noise": 0.01})
    log = degrade_log(clean, d).log
    pose = log.pose.copy()
    pose[:, 2] = np.angle(np.exp(1j * (pose[:, 2] + 0.5 * log.t)))
    est = fit_sensors(dataclasses.replace(log, pose=pose), 1.0).heading_noise
    assert est.value == pytest.approx(0.01, rel=0.03)
