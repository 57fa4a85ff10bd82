"""Issue 24: the run's plots break their lines where the data break (segments, stitched terrain)."""

from __future__ import annotations

import numpy as np

from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.records import WheelLog
from terrain_odom.reporting.plots import data_breaks, states_figure, trajectory_figure

NAMES = ("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")


def _stitched(copies: int = 3, n: int = 100) -> tuple[WheelLog, OdometryResult]:
    """Return ``copies`` straight drives, each 100 m east of the last; time restarts in each.

    Segment 0 on grass, the others on asphalt (a stitched grass -> asphalt log).
    """
    t = np.tile(np.arange(n) * 0.1, copies)
    x = np.concatenate([np.linspace(0.0, 10.0, n) + 100.0 * k for k in range(copies)])
    segment = np.repeat(np.arange(copies), n)
    terrain = np.where(segment == 0, "grass", "asphalt")
    pose = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    log = WheelLog(t, np.ones_like(t), np.ones_like(t), pose, terrain, segment)
    states = np.zeros((len(t), len(NAMES)))
    states[:, 0] = x
    states[:, 3:] = [0.4, -0.4, 0.0, 1.0]
    return log, OdometryResult(NAMES, states, np.full_like(states, 0.1), terrain, [])


def test_no_line_of_the_trajectory_joins_two_segments() -> None:
    log, result = _stitched()
    fig = trajectory_figure(log, result)
    ax = fig.axes[0]
    (path,) = ax.collections
    lengths = [float(np.hypot(*(seg[1] - seg[0]))) for seg in path.get_segments()]
    assert max(lengths) < 1.0  # steps of 0.1 m; a join would be 90 m long


def test_a_terrain_change_of_a_stitched_log_is_a_break() -> None:
    log, _ = _stitched(copies=2)
    one_segment = WheelLog(log.t, log.v_l, log.v_r, log.pose, log.terrain, np.zeros(len(log), int))
    assert data_breaks(one_segment).tolist() == [0, 100]  # the terrain change
    assert data_breaks(log).tolist() == [0, 100]


def test_the_states_lines_break_where_time_restarts() -> None:
    log, result = _stitched()
    fig = states_figure(log.t, result, starts=log.run_starts())
    line = next(line for line in fig.axes[0].get_lines() if line.get_label() == "estimate")
    t = np.asarray(line.get_xdata(), dtype=float)
    assert np.isnan(t).sum() == 2  # one break before each later segment
    pieces = np.split(t, np.flatnonzero(np.isnan(t)))
    assert all(np.all(np.diff(p[np.isfinite(p)]) > 0) for p in pieces)  # time never runs back
    assert fig.axes[-1].get_xlim() == (0.0, 9.9)
