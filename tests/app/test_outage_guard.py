"""The run's outage guard: the states it keeps from the stream, its verdict and its warning."""

from __future__ import annotations

import numpy as np

from terrain_odom.app.outage_guard import OutageGuard
from terrain_odom.config import Config, RobotConfig
from terrain_odom.estimation.odometry import OdometryBlock
from terrain_odom.kinematics import integrate, twist_icr
from terrain_odom.records import WheelLog

NAMES = ("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")
TRUE = (0.8, -0.8, 0.1, 0.95)


def _log():
    """130 s of curves at 20 Hz by a robot with ICRs ``TRUE``; full poses at 2 Hz."""
    t = np.arange(0.0, 130.0, 0.05)
    v_l, v_r = 0.9 + 0.4 * np.sin(t / 7.0), 0.9 - 0.4 * np.sin(t / 7.0)
    true = integrate(*twist_icr(v_l[:-1], v_r[:-1], *TRUE), np.diff(t))
    pose = np.full_like(true, np.nan)
    pose[::10] = true[::10]
    return WheelLog(t, v_l, v_r, pose, None, np.zeros(t.size, int), "<curves>"), true


def _stream(guard, true, learned, first, block=37):
    """Hand the guard blocks of rows as a run does: the first row's ICRs ``first``, then ``learned``."""
    n = true.shape[0]
    states = np.c_[true, np.tile(learned, (n, 1))]
    states[0, 3:] = first
    for start in range(0, n, block):
        rows = slice(start, min(start + block, n))
        guard.add(OdometryBlock(start, np.zeros(rows.stop - start), states[rows], states[rows],
                                np.full(rows.stop - start, "")))  # fmt: skip


def test_a_learned_model_worse_than_the_nominal_one_is_one_warning():
    log, true = _log()
    cfg = Config(robot=RobotConfig(wheel_radius=0.1, track_width=1.6))
    guard = OutageGuard(log, cfg, NAMES, "icr-ekf")
    assert guard.skipped is None and guard.starts.size == 11  # every 10 s, 0-100 s
    _stream(guard, true, learned=(0.4, -0.4, 0.6, 1.0), first=TRUE)
    result = guard.result()
    for models in result.outages.values():
        assert models["nominal"].position.max() < 1e-9  # the truth, from the true poses
        assert models["learned"].position_stats.median > 1.0
    assert [d for d, _, _ in result.worse()] == [30.0, 60.0]
    (warning,) = result.warnings()
    assert warning.startswith("the learned model dead-reckons worse than the nominal one")
    assert "30 s:" in warning and "60 s:" in warning
    assert result.section().to_dict()["learned_worse_s"] == [30.0, 60.0]


def test_a_learned_model_that_is_right_passes():
    log, true = _log()
    cfg = Config(robot=RobotConfig(wheel_radius=0.1, track_width=1.6))
    guard = OutageGuard(log, cfg, NAMES, "icr-ekf")
    _stream(guard, true, learned=TRUE, first=(0.8, -0.8, 0.0, 1.0))
    result = guard.result()
    assert result.worse() == [] and result.warnings() == []
    for models in result.outages.values():  # the window from row 0 starts with what it had then
        assert models["learned"].position[1:].max() < 1e-9
        assert models["learned"].position[0] == models["nominal"].position[0] > 0.1
    assert result.lines()[0].startswith("30 s outages (11): learned 0.00 m, nominal")


def test_skipped_runs_say_why():
    log, _ = _log()
    short = log.take(log.t < 20.0)
    cfg = Config()
    assert "no 30 s stretch" in OutageGuard(short, cfg, NAMES, "icr-ekf").result().skipped
    slip = OutageGuard(log, cfg, NAMES, "slip-ekf").result()
    assert slip.skipped.startswith("the guard freezes ICR EKF states; a slip-ekf run's model")
    assert slip.lines() == [f"skipped: {slip.skipped}"]
