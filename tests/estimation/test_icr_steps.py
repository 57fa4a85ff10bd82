"""The ICR EKF's steps: rows run in one call once, and only once, the pose is anchored."""

from __future__ import annotations

import numpy as np

from terrain_odom.config import Config
from terrain_odom.estimation.online import OnlineOdometry


def test_a_batch_is_offered_once_heading_and_position_are_anchored() -> None:
    """A heading alone anchors the heading only; the batch then equals the calls one by one."""
    odo, calls = OnlineOdometry(Config()), OnlineOdometry(Config())
    for o in (odo, calls):
        o.wheels(0.0, 0.5, 0.6)
        assert o._steps.batch() is None
        o.pose(0.0, yaw=0.1)
        assert o._steps.batch() is None  # heading only
        o.wheels(0.1, 0.5, 0.6)
        o.pose(0.1, 0.05, 0.0, 0.1)
    batch = odo._steps.batch()
    assert batch is not None
    t = np.arange(0.2, 1.0, 0.1)
    pose = np.column_stack([0.5 * t, 0.01 * t, np.full(t.size, 0.1)])
    states, _, _, updates = batch((0.1, 0.5, 0.6), t, (np.full(t.size, 0.5), np.full(t.size, 0.6)),
                               pose, odo.pose_use)  # fmt: skip
    for k, t_k in enumerate(t):
        calls.wheels(float(t_k), 0.5, 0.6)
        calls.pose(float(t_k), *pose[k].tolist())
        assert np.array_equal(states[k], calls.estimate()[0])
    assert updates == t.size
    assert odo.pose_use == calls.pose_use
