"""The degraded GPS + IMU recording: every injected quantity is where the model says it is."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.wheel_log import read_wheel_log
from terrain_odom.kinematics.integration import wrap_angle
from terrain_odom.kinematics.mounting import sensor_pose
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log

CLEAN = Degradation(
    gps_noise=0.0, gps_walk=0.0, latency=0.0, antenna=(0.0, 0.0), heading_offset=0.0,
    heading_wander=0.0, heading_noise=0.0, seed=3,
)  # fmt: skip


def _circle(duration: float = 60.0, rate: float = 20.0, segment: int = 0) -> WheelLog:
    """Return a robot on a circle of radius 5 m at 1 m/s (truth on every row)."""
    t = np.arange(0.0, duration, 1.0 / rate)
    yaw = t / 5.0
    pose = np.column_stack([5.0 * np.sin(yaw), 5.0 * (1.0 - np.cos(yaw)), wrap_angle(yaw)])
    n = t.size
    return WheelLog(t, np.full(n, 0.9), np.full(n, 1.1), pose, np.full(n, "grass"),
                    np.full(n, segment), "circle")  # fmt: skip


def _truth_at(t: np.ndarray) -> np.ndarray:
    yaw = t / 5.0
    return np.column_stack([5.0 * np.sin(yaw), 5.0 * (1.0 - np.cos(yaw)), wrap_angle(yaw)])


def test_without_noise_the_fixes_and_headings_are_the_truth() -> None:
    out = degrade_log(_circle(), CLEAN).log
    fix, head = out.has_position, out.has_yaw
    # linear interpolation between 20-Hz poses on a 5-m circle: chord error < 1e-3 m
    np.testing.assert_allclose(out.pose[fix, :2], _truth_at(out.t[fix])[:, :2], atol=1e-3)
    np.testing.assert_allclose(
        wrap_angle(out.pose[head, 2] - _truth_at(out.t[head])[:, 2]), 0.0, atol=1e-9
    )


def test_antenna_latency_and_heading_offset_follow_the_measurement_model() -> None:
    d = Degradation(gps_noise=0.0, gps_walk=0.0, latency=0.4, antenna=(-1.0, 0.3), heading_offset=3.0,
                    heading_wander=0.0, heading_noise=0.0, imu_latency=0.1, seed=1)  # fmt: skip
    out = degrade_log(_circle(), d).log
    fix, head = out.has_position, out.has_yaw
    expected = np.array([sensor_pose(p, d.mounting)[:2] for p in _truth_at(out.t[fix] - 0.4)])
    np.testing.assert_allclose(out.pose[fix, :2], expected, atol=1e-3)
    err = wrap_angle(out.pose[head, 2] - _truth_at(out.t[head] - 0.1)[:, 2] - 3.0)
    np.testing.assert_allclose(err, 0.0, atol=1e-6)
    # no fix stamped before the truth covers its measurement time
    assert out.t[fix].min() >= 0.4


def test_noise_has_the_injected_scale_and_the_wander_is_slow() -> None:
    d = Degradation(gps_rate=5.0, gps_noise=0.8, gps_walk=0.0, latency=0.0, antenna=(0.0, 0.0),
                    heading_offset=0.0, heading_wander=0.25, wander_time=20.0, heading_noise=0.01,
                    seed=7)  # fmt: skip
    out = degrade_log(_circle(duration=2000.0, rate=10.0), d).log
    fix, head = out.has_position, out.has_yaw
    err = out.pose[fix, :2] - _truth_at(out.t[fix])[:, :2]
    assert np.std(err) == pytest.approx(0.8, rel=0.05)
    wander = wrap_angle(out.pose[head, 2] - _truth_at(out.t[head])[:, 2])
    assert np.std(wander) == pytest.approx(0.25, rel=0.25)  # ~100 time constants
    lag = int(50 * 2.0)  # 2 s apart: correlation exp(-2/20) = 0.90
    assert np.corrcoef(wander[:-lag], wander[lag:])[0, 1] == pytest.approx(np.exp(-0.1), abs=0.05)


def test_random_walk_bias_grows_with_time() -> None:
    d = Degradation(gps_rate=5.0, gps_noise=0.0, gps_walk=0.1, latency=0.0, antenna=(0.0, 0.0),
                    imu_rate=0.0, seed=2)  # fmt: skip
    ends = []
    for seed in range(40):
        out = degrade_log(_circle(duration=100.0), Degradation(**{**d.__dict__, "seed": seed})).log
        fix = out.has_position
        ends.append(out.pose[fix, :2][-1] - _truth_at(out.t[fix][-1:])[0, :2])
    # after ~100 s: std 0.1 * sqrt(100) = 1 m per axis
    assert np.std(ends) == pytest.approx(1.0, rel=0.3)


def test_wheel_rows_keep_their_speeds_and_lose_their_poses() -> None:
    clean = _circle()
    out = degrade_log(clean, Degradation(seed=4)).log
    on_wheel_rows = np.isin(out.t, clean.t)
    assert on_wheel_rows.sum() == len(clean)
    inserted = ~on_wheel_rows
    previous = np.searchsorted(clean.t, out.t, side="right") - 1
    np.testing.assert_array_equal(out.v_l, clean.v_l[previous])
    assert inserted.any()
    assert not out.has_pose.any()  # GPS and IMU never on one row here (different phases)
    assert np.all(np.diff(out.t) > 0)


def test_segments_are_degraded_apart() -> None:
    a, b = _circle(duration=20.0, segment=0), _circle(duration=20.0, segment=1)
    two = WheelLog(*(np.concatenate([getattr(a, f), getattr(b, f)]) for f in
                     ("t", "v_l", "v_r", "pose", "terrain", "segment")))  # fmt: skip
    out = degrade_log(two, Degradation(seed=5)).log
    assert out.segment_runs().max() == 1
    for rows in out.run_ranges():
        assert np.all(np.diff(out.t[rows.start : rows.stop]) > 0)


def test_the_same_seed_gives_the_same_recording() -> None:
    first, again = (degrade_log(_circle(), Degradation(seed=9)).log for _ in range(2))
    np.testing.assert_array_equal(first.pose, again.pose)
    other = degrade_log(_circle(), Degradation(seed=10)).log
    assert not np.array_equal(np.nan_to_num(first.pose), np.nan_to_num(other.pose))


@pytest.mark.parametrize(
    "change",
    [
        {"gps_noise": -1.0},
        {"latency": float("nan")},
        {"heading_offset": 180.0},
        {"antenna": (float("inf"), 0.0)},
        {"wander_time": 0.0},
    ],  # fmt: skip
)
def test_bad_degradations_are_one_line_errors(change: dict) -> None:
    with pytest.raises(ConfigError, match="degradation: "):
        Degradation(**change)


def test_a_log_without_two_poses_is_refused() -> None:
    clean = _circle()
    bare = WheelLog(clean.t, clean.v_l, clean.v_r, np.full_like(clean.pose, np.nan), None,
                    clean.segment, "bare.csv")  # fmt: skip
    with pytest.raises(InputFileError, match="bare.csv: no run with two full poses"):
        degrade_log(bare, Degradation())


def test_real_drive_log_rates(drive_dir) -> None:
    clean = read_wheel_log(
        drive_dir / "warthog_wheels_grass_2024_7_29_14h4s53.csv", wheel_radius=0.3
    )
    out = degrade_log(clean, Degradation(seed=1)).log
    span = clean.t[clean.has_pose][-1] - clean.t[clean.has_pose][0]
    assert out.has_position.sum() == pytest.approx(2.5 * (span - 0.5), abs=2)
    assert out.has_yaw.sum() == pytest.approx(50.0 * span, abs=2)
    assert not np.isnan(out.v_l).any()
