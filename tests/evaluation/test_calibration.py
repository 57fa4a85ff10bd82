"""Self-calibration of a GPS and an IMU against the wheels (evaluation/calibration.py).

Every estimate is tested against values injected by
:func:`terrain_odom.sim.degrade.degrade_log` into a log whose truth is
exact (ideal differential drive, speeds changing every 0.5 s: turns of
changing sharpness), and the rank problems of straight driving and steady
circles against logs that have them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain_odom.evaluation.calibration import fit_sensors
from terrain_odom.evaluation.robust import circular_median
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log

TRACK = 1.0
QUIET = {"gps_noise": 0.0, "gps_walk": 0.0, "heading_wander": 0.0, "heading_noise": 0.0}


@pytest.fixture(scope="module")
def clean() -> WheelLog:
    """Ten minutes of ideal differential drive, true poses every 0.1 s."""
    return constant_model_log("idd", [], seconds=600.0, track_width=TRACK, noise=(0.0, 0.0, 0.0))


def _steady(seconds: float, v: float, omega: float) -> WheelLog:
    """Constant track speeds (a straight line or a circle) at 20 Hz, exact poses on every row."""
    t = np.arange(0.0, seconds, 0.05)
    yaw = omega * t
    if omega == 0.0:
        x, y = v * t, np.zeros_like(t)
    else:
        x, y = v / omega * np.sin(yaw), v / omega * (1.0 - np.cos(yaw))
    pose = np.column_stack([x, y, np.angle(np.exp(1j * yaw))])
    v_l, v_r = np.full(t.size, v - omega * TRACK / 2), np.full(t.size, v + omega * TRACK / 2)
    return WheelLog(t, v_l, v_r, pose, None, np.zeros(t.size, int), "steady")


@pytest.mark.parametrize("centre", [0.0, 3.0, -3.1, math.pi])
def test_circular_median_is_the_median_around_any_angle(centre):
    rng = np.random.default_rng(0)
    deviations = rng.normal(0.0, 0.3, 201)
    angles = np.angle(np.exp(1j * (centre + deviations)))
    expected = np.angle(np.exp(1j * (centre + np.median(deviations))))
    assert abs(np.angle(np.exp(1j * (circular_median(angles) - expected)))) < 1e-12


def test_circular_median_near_180_deg_is_not_split_by_the_wrap():
    # the Husky: +156.5 deg with a tail wrapping past 180: a plain median gives less
    angles = np.angle(np.exp(1j * np.radians(156.5 + np.linspace(-30.0, 30.0, 61))))
    assert int(np.sum(angles < 0)) == 7  # past 180 deg: wrapped to -180 + ...
    assert math.degrees(circular_median(angles)) == pytest.approx(156.5, abs=1e-9)
    assert math.degrees(float(np.median(angles))) == pytest.approx(149.5, abs=1e-9)


def test_noise_free_mounting_and_latency_are_recovered(clean):
    d = Degradation(latency=0.4, antenna=(-0.8, 0.3), heading_offset=3.0, seed=0, **QUIET)
    fit = fit_sensors(degrade_log(clean, d).log, TRACK)
    assert fit.position_delay.value == pytest.approx(0.4, abs=0.02)
    assert fit.heading_offset.value == pytest.approx(3.0, abs=math.radians(0.5))
    assert fit.antenna_x.value == pytest.approx(-0.8, abs=0.03)
    assert fit.antenna_y.value == pytest.approx(0.3, abs=0.03)
    assert fit.antenna_x.observable and 0.0 < fit.antenna_x.std < 0.01
    assert fit.position_noise.value < 0.02
    assert fit.yaw_scale == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("seed", [0, 1])
def test_noise_of_each_sensor_is_recovered_within_30_percent(clean, seed):
    d = Degradation(
        gps_noise=0.5,
        gps_walk=0.02,
        heading_noise=0.03,
        heading_wander=0.0,
        latency=0.3,
        antenna=(0.0, 0.0),
        seed=seed,
    )
    fit = fit_sensors(degrade_log(clean, d).log, TRACK)
    assert fit.position_noise.value == pytest.approx(0.5, rel=0.3)
    assert fit.heading_noise.value == pytest.approx(0.03, rel=0.3)
    # the standard errors cover the truth: latency and heading offset within 3 of them
    assert abs(fit.position_delay.value - 0.3) < 3.0 * fit.position_delay.std
    assert abs(fit.heading_offset.value - d.heading_offset) < 3.0 * fit.heading_offset.std + 0.01


def test_heading_wander_is_measured_beside_the_white_noise(clean):
    d = Degradation(
        gps_noise=0.2,
        gps_walk=0.0,
        heading_noise=0.01,
        heading_wander=0.2,
        wander_time=30.0,
        antenna=(0.0, 0.0),
        seed=3,
    )
    fit = fit_sensors(degrade_log(clean, d).log, TRACK)
    assert fit.heading_noise.value == pytest.approx(0.01, rel=0.3)
    assert fit.heading_wander.value == pytest.approx(0.2, rel=0.5)


def test_positions_alone_give_the_latency_and_the_yaw_scale(clean):
    d = Degradation(imu_rate=0.0, latency=0.5, antenna=(0.0, 0.0), seed=0, **QUIET)
    fit = fit_sensors(degrade_log(clean, d).log, TRACK)
    assert fit.position_delay.value == pytest.approx(0.5, abs=0.03)
    assert fit.yaw_scale == pytest.approx(1.0, abs=0.05)
    assert not fit.heading_offset.observable and "no headings" in fit.heading_offset.how


@pytest.mark.parametrize(("v", "omega", "what"), [(1.0, 0.0, "straight"), (1.0, 0.3, "circle")])
def test_lever_arm_of_straight_driving_or_a_steady_circle_is_not_observable(v, omega, what):
    log = degrade_log(_steady(300.0, v, omega), Degradation(antenna=(-1.0, 0.0), seed=0, **QUIET))
    fit = fit_sensors(log.log, TRACK, position_delay=0.5)
    for est in (fit.antenna_x, fit.antenna_y):
        assert not est.observable and math.isnan(est.value) and math.isnan(est.std), what
        assert "S-bends" in est.how


def test_too_short_a_log_is_reported_not_observable(clean):
    short = clean.take(slice(0, 200))  # 10 s
    fit = fit_sensors(degrade_log(short, Degradation(seed=0)).log, TRACK)
    assert fit.windows < 8 and not fit.position_noise.observable
    assert "record longer" in fit.position_noise.how
