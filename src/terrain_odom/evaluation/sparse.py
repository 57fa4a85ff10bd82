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
  within ``tolerance`` s of both (interpolated between the heading rows
  around each end, :func:`heading_at`): the angular error is
  ``|wrap(psi_end - (yaw_end - yaw_start))|``; a constant mounting offset of
  the heading sensor cancels. NaN where there is no heading.
- **heading windows** (``anchor="heading"``, a log without positions): the
  heading change alone, over windows as long as the wheels say
  (:func:`~terrain_odom.evaluation.windows.wheel_path`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import Config
from terrain_odom.errors import ConfigError
from terrain_odom.evaluation.metrics import TwistFn, WindowErrors, window_errors, window_poses
from terrain_odom.evaluation.windows import Windows
from terrain_odom.kinematics.integration import wrap_angle
from terrain_odom.records import WheelLog

__all__ = [
    "HEADING_TOLERANCE",
    "antenna_displacement",
    "heading_at",
    "heading_change",
    "fitted_turn",
    "sparse_window_errors",
    "anchored_window_errors",
    "antenna_of",
]

HEADING_TOLERANCE = 0.5
"""Largest time between a window's end and the heading rows taken for it, s."""


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


def heading_at(log: WheelLog, rows: ArrayLike, tolerance: float = HEADING_TOLERANCE) -> np.ndarray:
    """Measured heading at rows' times, from the heading rows around them, rad (NaN: none).

    The row's own heading if it has one; else interpolated (along the wrapped
    difference) between the heading rows just before and after it in the same
    segment run, both within ``tolerance`` s; else the nearer one within it.

    Examples
    --------
    >>> pose = np.full((5, 3), np.nan)
    >>> pose[[0, 2], 2] = [3.0, -3.0]  # through +-pi
    >>> log = WheelLog(np.arange(5.0), np.ones(5), np.ones(5), pose, None, np.zeros(5, int))
    >>> heading_at(log, [1, 2, 3, 4], tolerance=1.0).round(4).tolist()
    [3.1416, -3.0, -3.0, nan]
    """
    rows = np.asarray(rows, dtype=int)
    cand = np.flatnonzero(log.has_yaw)
    if cand.size == 0 or rows.size == 0:
        return np.full(rows.shape, np.nan)
    runs = log.segment_runs()
    j = np.searchsorted(cand, rows, side="right")
    before, after = cand[np.maximum(j - 1, 0)], cand[np.minimum(j, cand.size - 1)]
    ok_b = (j > 0) & (runs[before] == runs[rows]) & (log.t[rows] - log.t[before] <= tolerance)
    ok_a = (j < cand.size) & (runs[after] == runs[rows]) & (log.t[after] - log.t[rows] <= tolerance)
    yaw_b, yaw_a = log.pose[before, 2], log.pose[after, 2]
    span = log.t[after] - log.t[before]
    share = np.divide(log.t[rows] - log.t[before], span, out=np.zeros(rows.size), where=span > 0)
    between = wrap_angle(yaw_b + share * wrap_angle(yaw_a - yaw_b))
    return np.where(ok_b & ok_a, between, np.where(ok_b, yaw_b, np.where(ok_a, yaw_a, np.nan)))


def heading_change(
    log: WheelLog, start: ArrayLike, end: ArrayLike, tolerance: float = HEADING_TOLERANCE
) -> np.ndarray:
    """Measured heading change between rows (:func:`heading_at` both ends), rad (NaN: none).

    Parameters
    ----------
    log : WheelLog
        The log (its ``yaw`` measurements).
    start, end : array_like of int, shape (W,)
        Window rows.
    tolerance : float
        Largest time between a window row and the heading rows taken for it, s.

    Returns
    -------
    ndarray, shape (W,)
        ``wrap(yaw_end - yaw_start)``, rad; a constant mounting offset cancels.
    """
    return wrap_angle(heading_at(log, end, tolerance) - heading_at(log, start, tolerance))


def fitted_turn(q: np.ndarray, d: np.ndarray, fixes: np.ndarray) -> np.ndarray:
    """Rotation about the start that best maps predicted displacements onto measured ones.

    Parameters
    ----------
    q : ndarray, shape (..., K, 2)
        Predicted displacements from the start in the start frame, m.
    d : ndarray, shape (..., K, 2)
        Measured displacements from the start fix, m (anything where not ``fixes``).
    fixes : ndarray of bool, shape (..., K)
        Where ``d`` was measured.

    Returns
    -------
    ndarray, shape (...)
        ``theta = atan2(sum q x d, sum q . d)`` (least squares), rad.

    Examples
    --------
    >>> q = np.array([[1.0, 0.0], [2.0, 1.0]])
    >>> float(fitted_turn(q, q @ np.array([[0.0, 1.0], [-1.0, 0.0]]), np.ones(2, bool)))
    1.5707963267948966
    """
    cross = np.where(fixes, q[..., 0] * d[..., 1] - q[..., 1] * d[..., 0], 0.0).sum(axis=-1)
    dot = np.where(fixes, q[..., 0] * d[..., 0] + q[..., 1] * d[..., 1], 0.0).sum(axis=-1)
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
        predicted[idx, 2] = poses[:, -1, 2]
        if anchor == "heading":
            continue
        q = antenna_displacement(poses, antenna)  # (C, K + 1, 2)
        at = np.concatenate([rows, windows.end[idx, None]], axis=1)
        fixes = np.concatenate([valid, np.ones((idx.size, 1), bool)], axis=1)
        fixes &= log.has_position[at]
        d = log.pose[at, :2] - start_xy[idx, None, :]
        theta = fitted_turn(q, np.where(fixes[..., None], d, 0.0), fixes)
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


def anchored_window_errors(
    log: WheelLog,
    windows: Windows,
    twist_fn: TwistFn,
    *,
    anchor: str,
    antenna: Sequence[float] = (0.0, 0.0),
) -> WindowErrors:
    """Errors of a model on windows between ``anchor`` rows: full poses, positions or headings.

    :func:`~terrain_odom.evaluation.metrics.window_errors` between full
    poses, :func:`sparse_window_errors` otherwise.
    """
    if anchor == "pose":
        return window_errors(log, windows, twist_fn)
    return sparse_window_errors(log, windows, twist_fn, anchor=anchor, antenna=antenna)


def antenna_of(config: Config) -> tuple[float, float]:
    """Return the configured position sensor's place in the robot frame, m (``pose_sensor``).

    Raises
    ------
    ConfigError
        A coordinate that is not a number yet (e.g. one still to be estimated).

    Examples
    --------
    >>> antenna_of(Config())
    (0.0, 0.0)
    """
    sensor = config.pose_sensor
    values = {"antenna_x": sensor.antenna_x, "antenna_y": sensor.antenna_y}
    for name, value in values.items():
        if isinstance(value, str) or not math.isfinite(value):
            raise ConfigError(
                f"pose_sensor.{name} is {value!r}: scoring needs the lever arm in metres "
                "(a run's config.yaml has the value it used)"
            )
    return float(values["antenna_x"]), float(values["antenna_y"])
