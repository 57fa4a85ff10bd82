"""Windows of logs without a full pose on any row: position fixes (GPS) and heading rows (IMU)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import (
    error_stats,
    heading_at,
    icr_twist_from_rows,
    model_twist,
    sparse_window_errors,
    spatial_windows,
    wheel_path,
)
from terrain_odom.kinematics import get_model, integrate, twist_icr
from terrain_odom.records import WheelLog

ICR = (0.9, -0.8, 0.15, 0.95)
ANTENNA = (-1.0, 0.3)


def _log(positions=True, headings=True, offset=2.7):
    """Smoothly varying track speeds of a robot with known ICRs; fixes at 2.5 Hz, headings at 10 Hz.

    Positions are the antenna's, in a world frame turned by an arbitrary
    angle (so no start heading is known); headings carry a mounting offset.
    """
    t = np.arange(0.0, 60.0, 0.05)
    v_l = 0.8 + 0.3 * np.sin(t / 4.0)
    v_r = 0.8 + 0.3 * np.cos(t / 3.0)
    true = integrate(*twist_icr(v_l[:-1], v_r[:-1], *ICR), np.diff(t), start=[5.0, 1.0, 2.0])
    pose = np.full((t.size, 3), np.nan)
    if positions:
        fixes = np.arange(2, t.size, 8)
        c, s = np.cos(true[fixes, 2]), np.sin(true[fixes, 2])
        pose[fixes, 0] = true[fixes, 0] + c * ANTENNA[0] - s * ANTENNA[1]
        pose[fixes, 1] = true[fixes, 1] + s * ANTENNA[0] + c * ANTENNA[1]
    if headings:
        heads = np.flatnonzero((np.arange(t.size) % 2 == 1) & ~np.isfinite(pose[:, 0]))
        pose[heads, 2] = np.angle(np.exp(1j * (true[heads, 2] + offset)))
    return WheelLog(t, v_l, v_r, pose, None, np.zeros(t.size, int), "<sparse>")


def _true_twist(windows, n):
    return icr_twist_from_rows(windows, *(np.full(n, v) for v in ICR))


def test_position_windows_score_the_true_model_zero_without_a_start_heading():
    log = _log()
    assert not log.has_pose.any()
    w = spatial_windows(log, 3.0, anchor="position")
    assert len(w) > 50
    assert log.has_position[w.start].all() and log.has_position[w.end].all()
    np.testing.assert_allclose(w.length, (wheel_path(log)[w.end] - wheel_path(log)[w.start]))
    err = sparse_window_errors(log, w, _true_twist(w, len(log)), antenna=ANTENNA)
    assert err.translation.max() < 1e-9
    # the heading change, interpolated at the fix times between rows 0.1 s apart
    assert err.rotation.max() < 5e-4  # rad (0.03 deg)


def test_position_windows_see_a_wrong_model_and_a_forgotten_lever_arm():
    log = _log()
    w = spatial_windows(log, 3.0, anchor="position")
    idd = model_twist(get_model("idd"), [], 1.0)
    err = sparse_window_errors(log, w, idd, antenna=ANTENNA)
    assert np.median(err.rotation_per_m) > 2.0  # deg/m: it turns ~1.7x too fast
    assert np.median(err.translation) > 0.05
    forgot = sparse_window_errors(log, w, _true_twist(w, len(log)))
    assert forgot.translation.max() > 0.05


def test_positions_alone_have_no_heading_error_and_headings_alone_no_translation():
    gps = _log(headings=False)
    w = spatial_windows(gps, 3.0, anchor="position")
    err = sparse_window_errors(gps, w, _true_twist(w, len(gps)), antenna=ANTENNA)
    assert np.isnan(err.rotation).all() and err.translation.max() < 1e-9
    imu = _log(positions=False)
    w = spatial_windows(imu, 3.0, anchor="heading")
    assert len(w) > 50 and imu.has_yaw[w.start].all()
    err = sparse_window_errors(imu, w, _true_twist(w, len(imu)), anchor="heading")
    assert np.isnan(err.translation).all() and err.rotation.max() < 1e-9  # on heading rows
    idd = sparse_window_errors(imu, w, model_twist(get_model("idd"), [], 1.0), anchor="heading")
    assert error_stats(idd.rotation).median > 0.05
    with pytest.raises(ValueError, match="positions or headings"):
        sparse_window_errors(imu, w, idd, anchor="pose")  # type: ignore[arg-type]


def test_heading_at_interpolates_only_within_the_tolerance_and_its_segment():
    t = np.arange(6.0)
    pose = np.full((6, 3), np.nan)
    pose[[0, 2, 4], 2] = [0.0, 1.0, 2.0]
    log = WheelLog(t, t, t, pose, None, np.array([0, 0, 0, 0, 1, 1]))
    got = heading_at(log, [0, 1, 3, 5], tolerance=1.0)
    assert got[:3].tolist() == [0.0, 0.5, 1.0]  # row 3: the next heading is in another segment
    assert got[3] == 2.0
    assert np.isnan(heading_at(log, [1], tolerance=0.5)).all()
