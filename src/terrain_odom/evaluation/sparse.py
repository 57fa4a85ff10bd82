"""Model-odometry errors of a log whose positions and headings come on different rows.

A GPS gives positions (``x, y`` of its antenna, ``yaw`` NaN), an IMU
headings (``yaw``, ``x, y`` NaN): no row holds a full pose, so the windows
of :func:`~terrain_odom.evaluation.metrics.window_errors` (measured pose at
both ends) do not exist. :func:`sparse_window_errors` scores what such a log
measures:

- **position windows** (between two position fixes, ``anchor="position"``):
  the model is integrated from the start fix in its own frame; its antenna
  path (the configured lever arm ``a``: ``q_k = P_k + R(psi_k) a - a``, the
  antenna's displacement in the start frame) is turned by the start heading
  ``theta`` that best fits the window's fixes (least squares about the start
  fix, closed form ``theta = atan2(sum q x D, sum q . D)`` over the
  displacements ``D_k`` of every fix in the window), and the translational
  error is ``|R(theta) q_end - D_end|``. With no heading to start from, an
  error of the start heading cannot be told from the model's: only the
  shape of the path is scored.
- the **heading change** between the window's ends, where heading rows lie
  within ``tolerance`` s of both (the nearest ones): the angular error is
  ``|wrap(psi_end - (yaw_end - yaw_start))|``; a constant mounting offset of
  the heading sensor cancels. NaN where there is no heading.
- **heading windows** (``anchor="heading"``, a log without positions): the
  heading change alone, over windows as long as the wheels say
  (:func:`~terrain_odom.evaluation.windows.wheel_path`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.evaluation.metrics import TwistFn, WindowErrors, window_poses
from terrain_odom.evaluation.windows import Windows
from terrain_odom.kinematics.integration import wrap_angle
from terrain_odom.records import WheelLog

__all__ = [
    "HEADING_TOLERANCE",
    "antenna_displacement",
    "nearest_rows",
    "heading_change",
    "sparse_window_errors",
]

HEADING_TOLERANCE = 0.5
"""Largest time between a window's end and the heading row taken for it, s."""


def antenna_displacement(relative: ArrayLike, antenna: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """Displacement of an antenna ``a`` in the start frame after a relative motion.

    Parameters
    ----------
    relative : array_like, shape (..., 3)
        Pose of the reference point relative to its start pose ``(x, y, yaw)``, m, m, rad.
    antenna : sequence of 2 floats
        Antenna position in the robot frame ``a`` (x forward, y left), m.

    Returns
    -------
    ndarray, shape (..., 2)
        ``P + R(psi) a - a``, m.

    Examples
    --------
    A half turn on the spot moves an antenna 1 m behind the centre 2 m forward:

    >>> antenna_displacement([0.0, 0.0, np.pi], (-1.0, 0.0)).round(12) + 0.0
    array([2., 0.])
    """
    rel = np.asarray(relative, dtype=float)
    a_x, a_y = (float(v) for v in antenna)
    c, s = np.cos(rel[..., 2]), np.sin(rel[..., 2])
    return np.stack(
        [rel[..., 0] + c * a_x - s * a_y - a_x, rel[..., 1] + s * a_x + c * a_y - a_y], axis=-1
    )


def nearest_rows(log: WheelLog, mask: np.ndarray, rows: ArrayLike, tolerance: float) -> np.ndarray:
    """For each row, the ``mask`` row of the same segment run nearest in time (-1: none within ``tolerance``).

    Parameters
    ----------
    log : WheelLog
        Times and segments.
    mask : ndarray of bool, shape (N,)
        Candidate rows (e.g. ``log.has_yaw``).
    rows : array_like of int, shape (W,)
        Rows to find a candidate for.
    tolerance : float
        Largest accepted time difference, s.

    Returns
    -------
    ndarray of int, shape (W,)

    Examples
    --------
    >>> log = WheelLog(np.arange(5.0), np.ones(5), np.ones(5), np.full((5, 3), np.nan),
    ...                None, np.zeros(5, int))
    >>> nearest_rows(log, np.array([0, 1, 0, 0, 0], bool), [0, 3], 1.0).tolist()
    [1, -1]
    """
    rows = np.asarray(rows, dtype=int)
    cand = np.flatnonzero(mask)
    if cand.size == 0 or rows.size == 0:
        return np.full(rows.shape, -1)
    runs = log.segment_runs()
    after = np.clip(np.searchsorted(cand, rows), 0, cand.size - 1)
    before = np.clip(np.searchsorted(cand, rows, side="right") - 1, 0, cand.size - 1)
    gap = [np.abs(log.t[cand[j]] - log.t[rows]) for j in (before, after)]
    best = np.where(gap[0] <= gap[1], cand[before], cand[after])
    ok = (np.minimum(*gap) <= tolerance) & (runs[best] == runs[rows])
    return np.where(ok, best, -1)


def heading_change(
    log: WheelLog, start: ArrayLike, end: ArrayLike, tolerance: float = HEADING_TOLERANCE
) -> np.ndarray:
    """Measured heading change between rows, from the nearest heading rows, rad (NaN: none).

    Parameters
    ----------
    log : WheelLog
        The log (its ``yaw`` measurements).
    start, end : array_like of int, shape (W,)
        Window rows.
    tolerance : float
        Largest time between a window row and its heading row, s.

    Returns
    -------
    ndarray, shape (W,)
        ``wrap(yaw_end - yaw_start)``, rad.
    """
    first = nearest_rows(log, log.has_yaw, start, tolerance)
    last = nearest_rows(log, log.has_yaw, end, tolerance)
    change = wrap_angle(log.pose[last, 2] - log.pose[first, 2])
    return np.where((first >= 0) & (last >= 0), change, np.nan)


def _fitted_turn(q: np.ndarray, d: np.ndarray, fixes: np.ndarray) -> np.ndarray:
    """Rotation of the start frame that best maps ``q`` onto ``d`` at the fixes, rad, shape (C,)."""
    cross = np.where(fixes, q[..., 0] * d[..., 1] - q[..., 1] * d[..., 0], 0.0).sum(axis=1)
    dot = np.where(fixes, q[..., 0] * d[..., 0] + q[..., 1] * d[..., 1], 0.0).sum(axis=1)
    return np.arctan2(cross, dot)


def sparse_window_errors(
    log: WheelLog,
    windows: Windows,
    twist_fn: TwistFn,
    *,
    anchor: str = "position",
    antenna: Sequence[float] = (0.0, 0.0),
    tolerance: float = HEADING_TOLERANCE,
) -> WindowErrors:
    """Errors of a model on position windows (start heading fitted) or heading windows.

    Parameters
    ----------
    log : WheelLog
        The log the windows belong to.
    windows : Windows
        From :func:`~terrain_odom.evaluation.windows.spatial_windows` with the same ``anchor``.
    twist_fn : TwistFn
        ``twist_fn(v_l, v_r, window_index) -> (v_x, v_y, omega)``.
    anchor : {"position", "heading"}
        What the windows' rows measure.
    antenna : sequence of 2 floats
        Position sensor's place in the robot frame, m (``pose_sensor.antenna_x, antenna_y``).
    tolerance : float
        Largest time between a window end and the heading row taken for it, s.

    Returns
    -------
    WindowErrors
        ``translation`` (m; NaN for heading windows), ``rotation`` (rad; NaN
        where no heading is near both ends); ``predicted`` holds the
        predicted end position of the antenna (NaN for heading windows) and
        the predicted heading change.
    """
    if anchor not in ("position", "heading"):
        raise ValueError(f"sparse windows run between positions or headings, not {anchor!r}")
    n = len(windows)
    predicted = np.full((n, 3), np.nan)
    zero = np.zeros((n, 3))
    start_xy = log.pose[windows.start, :2]
    for idx, rows, valid, poses in window_poses(log, windows, twist_fn, start=zero):
        predicted[idx, 2] = poses[:, -1, 2] + 0.0
        if anchor == "heading":
            continue
        q = antenna_displacement(poses, antenna)  # (C, K + 1, 2)
        at = np.concatenate([rows, windows.end[idx, None]], axis=1)
        fixes = np.concatenate([valid, np.ones((idx.size, 1), bool)], axis=1)
        fixes &= log.has_position[at]
        d = log.pose[at, :2] - start_xy[idx, None, :]
        theta = _fitted_turn(q, np.where(fixes[..., None], d, 0.0), fixes)
        c, s = np.cos(theta), np.sin(theta)
        q_end = q[:, -1]
        predicted[idx, 0] = start_xy[idx, 0] + c * q_end[:, 0] - s * q_end[:, 1]
        predicted[idx, 1] = start_xy[idx, 1] + s * q_end[:, 0] + c * q_end[:, 1]
    measured = heading_change(log, windows.start, windows.end, tolerance)
    return WindowErrors(
        windows=windows,
        predicted=predicted,
        translation=np.linalg.norm(predicted[:, :2] - log.pose[windows.end, :2], axis=1),
        rotation=np.abs(wrap_angle(predicted[:, 2] - measured)),
    )
