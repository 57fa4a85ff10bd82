"""Pose-stamp delay: estimation from heading changes, and delaying the wheel speeds."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.errors import EstimationError
from terrain_odom.estimation.time_offset import (
    calibrate_pose_delay,
    delay_wheel_speeds,
    estimate_pose_delay,
)
from terrain_odom.records import WheelLog
from terrain_odom.sim.slip_scenario import simulate_log

FINE = 0.01  # s, rows of the simulation
WHEEL_PERIOD = 0.05  # s, rows of the log handed to the estimator (20 Hz)
TRACK_WIDTH = 1.0  # m; the true ICRs at +-0.9 m turn the robot at 0.56 of the ideal rate
ICR = (0.9, -0.9, 0.05)


def delayed_pose_log(delay: float, *, seconds: float = 120.0, seed: int = 0, turn: float = 1.0):
    """Simulate a 20-Hz wheel log whose 10-Hz poses, stamped ``t``, were taken at wheel time ``t - delay``.

    Track speeds change every 0.5-2 s (on the 20-Hz rows); the truth is
    simulated on a 100-Hz grid (2 cm / 0.5 deg pose noise) and each pose is
    read ``delay`` (a multiple of 0.01 s) before its stamp.
    """
    rng = np.random.default_rng(seed)
    rows = int(seconds / WHEEL_PERIOD)
    lengths = rng.integers(10, 41, rows // 10)
    piece = np.repeat(np.arange(lengths.size), lengths)[:rows]
    forward = rng.uniform(0.3, 1.5, lengths.size)[piece]
    diff = turn * rng.uniform(-1.0, 1.0, lengths.size)[piece]
    v_l, v_r = forward - 0.5 * diff, forward + 0.5 * diff
    per_row = round(WHEEL_PERIOD / FINE)
    t_fine = np.arange(rows * per_row) * FINE
    fine = simulate_log(
        t_fine,
        np.repeat(v_l, per_row),
        np.repeat(v_r, per_row),
        np.tile(ICR, (t_fine.size, 1)),
        pose_every=1,
        seed=seed + 1,
    )
    taken = np.arange(rows) * per_row - round(delay / FINE)
    pose = np.full((rows, 3), np.nan)
    stamped = np.flatnonzero((np.arange(rows) % 2 == 0) & (taken >= 0) & (taken < t_fine.size))
    pose[stamped] = fine.log.pose[taken[stamped]]
    return WheelLog(
        t_fine[::per_row], v_l, v_r, pose, None, np.zeros(rows, dtype=np.int64), "<sim delay>"
    )


@pytest.mark.parametrize(("delay", "seed"), [(0.23, 0), (0.07, 1), (-0.12, 2), (0.0, 3)])
def test_recovers_an_injected_delay_within_one_wheel_period(delay, seed):
    est = estimate_pose_delay(delayed_pose_log(delay, seed=seed), TRACK_WIDTH)
    assert abs(est.delay - delay) < WHEEL_PERIOD
    assert est.std < 0.02
    assert est.yaw_rate_scale == pytest.approx(TRACK_WIDTH / (ICR[0] - ICR[1]), abs=0.05)


def test_heading_only_log_and_segments_restarting_the_clock():
    log = delayed_pose_log(0.2, seed=4)
    heading = log.pose.copy()
    heading[:, :2] = np.nan
    half = len(log) // 2
    t = np.r_[log.t[:half], log.t[half:] - log.t[half]]  # the second segment starts at 0 again
    segment = (np.arange(len(log)) >= half).astype(np.int64)
    split = dataclasses.replace(log, t=t, pose=heading, segment=segment)
    assert estimate_pose_delay(split, TRACK_WIDTH).delay == pytest.approx(0.2, abs=WHEEL_PERIOD)


def test_driving_straight_is_a_clear_error():
    with pytest.raises(EstimationError, match="turning"):
        estimate_pose_delay(delayed_pose_log(0.2, turn=0.0), TRACK_WIDTH)


def test_too_few_poses_is_a_clear_error():
    log = delayed_pose_log(0.2, seconds=3.0)
    with pytest.raises(EstimationError, match="heading changes"):
        estimate_pose_delay(log, TRACK_WIDTH)


def test_delaying_by_the_estimate_aligns_the_wheels_with_the_poses():
    log = delayed_pose_log(0.23, seed=5)
    fixed, timing = calibrate_pose_delay(log, "auto", TRACK_WIDTH)
    assert timing.estimate is not None and timing.pose_delay == timing.estimate.delay
    assert estimate_pose_delay(fixed, TRACK_WIDTH).delay == pytest.approx(0.0, abs=WHEEL_PERIOD)
    report = timing.to_dict()
    assert report["estimated"] and report["pose_delay_s"] == timing.pose_delay


def test_zero_delay_is_a_no_op():
    log = delayed_pose_log(0.1, seconds=10.0)
    assert delay_wheel_speeds(log, 0.0) is log
    same, timing = calibrate_pose_delay(log, 0.0, TRACK_WIDTH)
    assert same is log and timing.to_dict() == {"pose_delay_s": 0.0, "estimated": False}


def test_delay_of_whole_rows_shifts_the_speeds_and_holds_the_first():
    log = delayed_pose_log(0.0, seconds=10.0)
    late = delay_wheel_speeds(log, 3 * WHEEL_PERIOD)
    assert np.allclose(late.v_l[3:], log.v_l[:-3]) and np.allclose(late.v_l[:3], log.v_l[0])
    early = delay_wheel_speeds(log, -2 * WHEEL_PERIOD)
    assert np.allclose(early.v_r[:-2], log.v_r[2:]) and np.allclose(early.v_r[-2:], log.v_r[-1])
    for name in ("t", "pose", "segment"):
        assert getattr(late, name) is getattr(log, name)


def test_delayed_speeds_travel_what_the_recorded_ones_travel_over_the_delayed_interval():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.02, 0.3, 200))
    v = rng.uniform(-1.0, 2.0, t.size)
    log = WheelLog(t, v, -v, np.full((t.size, 3), np.nan), None, np.zeros(t.size, int))
    d = 0.37
    late = delay_wheel_speeds(log, d)
    a, b = 20, 150
    fine = np.linspace(t[a] - d, t[b] - d, 200_001)
    recorded = v[np.searchsorted(t, fine[:-1], side="right") - 1]
    assert np.sum(late.v_l[a:b] * np.diff(t[a : b + 1])) == pytest.approx(
        np.sum(recorded * np.diff(fine)), abs=1e-3
    )
    assert np.allclose(late.v_r, -late.v_l)


def test_segments_do_not_exchange_speeds():
    t = np.r_[np.arange(10.0), np.arange(10.0)] * 0.1
    segment = np.repeat([0, 1], 10)
    v = np.repeat([1.0, 2.0], 10)
    log = WheelLog(t, v, v, np.full((20, 3), np.nan), None, segment)
    late = delay_wheel_speeds(log, 0.25)
    assert np.allclose(late.v_l, v) and np.allclose(late.v_r, v)
