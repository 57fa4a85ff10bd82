"""The travel check on a slow robot's noisy GPS: chords, not the noise, measure the path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from terrain_odom.evaluation import check_log
from terrain_odom.evaluation.plausibility import _position_noise
from terrain_odom.io import read_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log

DRIVE = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "drive"
SLOW = DRIVE / "warthog_wheels_grass_2024_7_29_14h4s53.csv"  # the issue's: 48 m in 114 s
GPS = Degradation(
    gps_rate=2.5,
    gps_noise=0.8,
    gps_walk=0.05,
    latency=0.5,
    antenna=(-1.0, 0.0),
    imu_rate=0.0,
    seed=0,
)


@pytest.fixture(scope="module")
def slow() -> WheelLog:
    if not SLOW.is_file():
        pytest.skip(f"{SLOW} not present")
    return read_wheel_log(SLOW, wheel_radius=0.3)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_slow_robots_noisy_gps_is_not_taken_for_a_wrong_wheel_radius(slow, seed):
    gps = degrade_log(slow, Degradation(**{**GPS.__dict__, "seed": seed})).log
    found = check_log(gps, 1.08)
    assert "travel" not in [f.check for f in found.findings]
    # over chords of 5 noise stds (the noise estimated from the fixes) the path is near the
    # wheels' (it was x4.3 over 0.5-s intervals); a turning path's chords are shorter than
    # its arcs, so below 1
    assert 0.6 < found.pose_travel / found.wheel_travel < 1.2
    known = check_log(gps, 1.08, position_noise=0.8)  # the noise as a calibration found it
    assert known.ok and 0.6 < known.pose_travel / known.wheel_travel < 1.2


def test_the_noise_is_estimated_from_the_fixes(slow):
    for noise in (0.3, 0.8):
        gps = degrade_log(slow, Degradation(**{**GPS.__dict__, "gps_noise": noise})).log
        assert _position_noise(gps) == pytest.approx(noise, rel=0.3)
    assert _position_noise(slow) < 0.01  # the ICP poses


def test_a_wrong_wheel_radius_is_still_found_through_the_noise(slow):
    gps = degrade_log(slow, GPS).log
    wrong = WheelLog(gps.t, 3.0 * gps.v_l, 3.0 * gps.v_r, gps.pose, None, gps.segment, "x3")
    found = check_log(wrong, 1.08)
    assert [f.check for f in found.findings][:1] == ["travel"]
    assert "wheel radius" in found.findings[0].message


def test_a_still_robots_gps_noise_is_no_travel(slow):
    gps = degrade_log(slow, GPS).log
    still = WheelLog(gps.t, 0 * gps.v_l, 0 * gps.v_r, gps.pose, None, gps.segment)
    assert np.isfinite(check_log(still, 1.08).wheel_travel)
