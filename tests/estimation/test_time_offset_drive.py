"""Pose-stamp delay of real Warthog logs (skipped if ../shared is absent).

bench/slip_ekf.py prints the estimate of every log; the ICP poses lag the
wheel speeds (logged as the latest value received, updated every ~0.25 s)
by 0.07-0.52 s.
"""

from __future__ import annotations

import pytest

from terrain_odom.config import load_config
from terrain_odom.estimation.time_offset import estimate_pose_delay
from terrain_odom.io import read_wheel_log


@pytest.mark.parametrize(
    ("name", "measured"),
    [("asphalt_2024_9_25_12h8s57", 0.065), ("grass_2024_7_29_14h4s53", 0.142)],
)
def test_warthog_pose_delay_is_plausible_and_as_benchmarked(
    name, measured, drive_dir, warthog_yaml
):
    cfg = load_config(warthog_yaml)
    log = read_wheel_log(
        drive_dir / f"warthog_wheels_{name}.csv", wheel_radius=cfg.robot.wheel_radius
    )
    est = estimate_pose_delay(log, cfg.robot.track_width)
    assert 0.0 < est.delay < 0.6  # behind the wheels, by less than the ICP period x 3
    assert est.delay == pytest.approx(measured, abs=0.01)
    assert est.std < 0.01
    assert 0.5 < est.yaw_rate_scale < 0.65  # effective track width ~1.8 m, not 1.08 m
