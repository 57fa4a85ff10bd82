"""Outage windows: how far a fused estimator's model carries the robot when the poses stop.

What matters about the model a fused estimator has learned is what it does
when its pose sensor drops out (a GPS under trees). An outage window
simulates that on a recorded log: from the estimator's state at a position
fix (its pose and its model, e.g. the ICR EKF's ``y_l, y_r, x_icr, alpha``),
the model is frozen and driven by the logged wheel speeds for ``duration``
seconds with no pose update (exact SE(2) integration,
:func:`~terrain_odom.evaluation.metrics.window_poses`), and its displacement
is compared with the measured one:

- position error: ``|R(yaw_0) q - (g_end - g_start)|`` (m), where ``g`` are
  the measured positions (of the antenna: the configured lever arm ``a``
  enters as ``q = P + R(psi) a - a``,
  :func:`~terrain_odom.evaluation.sparse.antenna_displacement`) and
  ``yaw_0`` the state's heading at the start;
- heading error: ``|wrap(psi - (yaw_end - yaw_start))|`` (rad) where heading
  rows lie near both ends (:func:`~terrain_odom.evaluation.sparse.heading_change`;
  a heading sensor's constant offset cancels), NaN elsewhere.

Comparing displacements, not positions, leaves out where the estimate stood
at the start; the start heading is the state's, the same for every model
compared from it (e.g. the ideal differential drive beside the learned
model), so the comparison is of the models alone.

Windows (:func:`outage_windows`) start at the first position fix of every
``every`` seconds (10; on a log longer than 20 min, as many as 120 windows
spread evenly: :func:`outage_spacing`) of each segment and end at the fix
nearest ``duration`` later (within ``tolerance``), in the same segment.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.evaluation.metrics import (
    ErrorStats,
    TwistFn,
    error_stats,
    icr_twist_per_window,
    predict_window_ends,
    window_poses,
)
from terrain_odom.evaluation.sparse import HEADING_TOLERANCE, antenna_displacement, heading_change
from terrain_odom.evaluation.windows import Windows, prediction_windows
from terrain_odom.kinematics.integration import integrate, relative_pose, wrap_angle
from terrain_odom.kinematics.models import twist_icr
from terrain_odom.records import WheelLog

__all__ = [
    "DEFAULT_OUTAGES",
    "OUTAGE_EVERY",
    "OUTAGE_TOLERANCE",
    "MIN_OUTAGE",
    "MAX_OUTAGE_WINDOWS",
    "outage_spacing",
    "OutageErrors",
    "outage_windows",
    "outage_errors",
    "outage_table",
    "outage_starts",
    "frozen_icr_table",
    "ModelAt",
    "RowsTwist",
    "is_sparse",
]

DEFAULT_OUTAGES = (30.0, 60.0)
"""Outage durations scored by default, s."""
OUTAGE_EVERY = 10.0
"""An outage window starts every this many seconds of a segment, s."""
OUTAGE_TOLERANCE = 1.0
"""Largest ``|t_end - t_start - duration|`` of an outage window, s."""
MAX_OUTAGE_WINDOWS = 120
"""Most outage windows of one duration: a longer log spaces them wider than :data:`OUTAGE_EVERY`."""
MIN_OUTAGE = 1.0
"""Shortest outage duration, s (shorter ones end on the fix they start from)."""
ModelAt = Callable[[Windows], TwistFn]
"""The frozen model of each window (its start row's estimate): ``model_at(windows) -> twist_fn``."""
RowsTwist = tuple[np.ndarray, np.ndarray, np.ndarray]
"""A model that is the same in every window: its body twist at every log row, m/s, m/s, rad/s."""
SPARSE_INTERVAL = 0.15
"""Median time between position fixes from which poses count as sparse (GPS-like), s."""


@dataclass(frozen=True)
class OutageErrors:
    """Errors of one model dead-reckoned through the outage windows of one duration.

    Attributes
    ----------
    duration : float
        Outage duration, s.
    windows : Windows
        The windows (``W``; ``length`` is the wheels' path, m).
    position : ndarray, shape (W,)
        Displacement error at the end, m.
    heading : ndarray, shape (W,)
        Heading-change error at the end, rad (NaN where no heading was measured).
    """

    duration: float
    windows: Windows
    position: np.ndarray
    heading: np.ndarray

    @property
    def position_stats(self) -> ErrorStats:
        """Median, quartiles, mean and count of the position errors, m."""
        return error_stats(self.position)

    @property
    def heading_stats(self) -> ErrorStats:
        """The same of the heading errors (where measured), deg."""
        return error_stats(np.degrees(self.heading[np.isfinite(self.heading)]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``position_m`` and ``heading_deg`` statistics."""
        return {
            "position_m": self.position_stats.to_dict(),
            "heading_deg": self.heading_stats.to_dict(),
        }


def is_sparse(log: WheelLog) -> bool:
    """Whether a log's poses are GPS-like: positions without a heading on their row, or slower than ~7 Hz.

    Examples
    --------
    >>> t = np.arange(0.0, 10.0, 0.1)
    >>> pose = np.c_[t, t * 0, np.where(np.arange(t.size) % 4 == 0, 0.0, np.nan)]
    >>> log = WheelLog(t, t, t, pose, None, np.zeros(t.size, int))
    >>> is_sparse(log), is_sparse(log.take(np.arange(t.size) % 4 == 0))
    (True, True)
    """
    rows = np.flatnonzero(log.has_position)
    if rows.size < 2:
        return False
    if np.count_nonzero(log.has_pose[rows]) < rows.size / 2:
        return True
    return float(np.median(np.diff(log.t[rows]))) >= SPARSE_INTERVAL


def outage_windows(
    log: WheelLog,
    duration: float,
    *,
    every: float = OUTAGE_EVERY,
    tolerance: float = OUTAGE_TOLERANCE,
) -> Windows:
    """Outage windows of a log: ``duration`` s from a position fix every ``every`` s.

    Parameters
    ----------
    log : WheelLog
        Log with position measurements.
    duration : float
        Outage duration, s (>= :data:`MIN_OUTAGE`).
    every : float
        Time between window starts within a segment, s (> 0).
    tolerance : float
        Largest ``|t_end - t_start - duration|``, s.

    Returns
    -------
    Windows
        Start and end rows (both position fixes of one segment run) and the
        path length between them by the wheels, m.

    Examples
    --------
    Fixes every second for 25 s, 10-s outages (the last one ends 1 s short,
    within the tolerance):

    >>> t = np.arange(0.0, 25.0, 0.5)
    >>> pose = np.c_[t, 0 * t, np.full(t.size, np.nan)]
    >>> pose[1::2, :2] = np.nan
    >>> log = WheelLog(t, t, t, pose, None, np.zeros(t.size, int))
    >>> w = outage_windows(log, 10.0, every=5.0)
    >>> log.t[w.start].tolist(), log.t[w.end].tolist()
    ([0.0, 5.0, 10.0, 15.0], [10.0, 15.0, 20.0, 24.0])
    """
    if not (math.isfinite(duration) and duration >= MIN_OUTAGE):
        raise ValueError(f"outage duration must be >= {MIN_OUTAGE:g} s, got {duration}")
    if not every > 0.0:
        raise ValueError(f"outage windows start every > 0 s, got {every}")
    rows = np.flatnonzero(log.has_position)
    runs = log.segment_runs()[rows]
    first = np.r_[True, runs[1:] != runs[:-1]]
    t_run = log.t[rows][first][np.cumsum(first) - 1]  # each fix's run's first fix time
    slot = np.floor((log.t[rows] - t_run) / outage_spacing(log, every))
    new = np.r_[True, (runs[1:] != runs[:-1]) | (slot[1:] != slot[:-1])]
    return prediction_windows(
        log, duration, starts=rows[new], tolerance=tolerance, anchor="position"
    )


def outage_spacing(log: WheelLog, every: float = OUTAGE_EVERY) -> float:
    """Time between outage window starts, s: ``every``, or wider on a long log.

    At most :data:`MAX_OUTAGE_WINDOWS` windows of a duration: the fixes'
    time span (summed over segments) over that many, if more than ``every``.

    Examples
    --------
    >>> t = np.arange(0.0, 3600.0, 0.5)
    >>> pose = np.c_[t, 0 * t, np.full(t.size, np.nan)]
    >>> log = WheelLog(t, t, t, pose, None, np.zeros(t.size, int))
    >>> round(outage_spacing(log), 4), outage_spacing(log.take(t < 600.0))
    (29.9958, 10.0)
    """
    rows = np.flatnonzero(log.has_position)
    if rows.size == 0:
        return every
    runs = log.segment_runs()[rows]
    span = sum(float(np.ptp(log.t[rows[runs == r]])) for r in np.unique(runs))
    return max(every, span / MAX_OUTAGE_WINDOWS)


def outage_errors(
    log: WheelLog,
    windows: Windows,
    start_yaw: ArrayLike,
    twist_fn: TwistFn,
    *,
    duration: float,
    antenna: Sequence[float] = (0.0, 0.0),
    tolerance: float = HEADING_TOLERANCE,
) -> OutageErrors:
    """Dead-reckon a frozen model through each outage window; compare the displacement.

    Parameters
    ----------
    log : WheelLog
        The log (wheel speeds, measured positions and headings).
    windows : Windows
        From :func:`outage_windows`.
    start_yaw : array_like, shape (W,)
        The estimator's heading at each window's start row, rad.
    twist_fn : TwistFn
        The frozen model of each window (e.g.
        :func:`~terrain_odom.evaluation.metrics.icr_twist_per_window` with the
        state at each start, or :func:`~terrain_odom.evaluation.metrics.model_twist`).
    duration : float
        The windows' nominal duration, s (recorded in the result).
    antenna : sequence of 2 floats
        Where the measured positions are in the robot frame, m.
    tolerance : float
        Largest time between a window end and the heading row taken for it, s.

    Returns
    -------
    OutageErrors

    Examples
    --------
    The ideal differential drive (B = 1 m) on a robot whose track ICRs are
    2 m apart, for 10 s at 1 m/s: it turns 2 rad on a 5-m circle where the
    robot turned 1 rad on a 10-m one, so the chords differ by a known amount.

    >>> from terrain_odom.evaluation.metrics import model_twist
    >>> from terrain_odom.kinematics import get_model, integrate, twist_icr
    >>> t = np.arange(0.0, 10.01, 0.01)
    >>> v_l, v_r = np.full(t.size, 0.9), np.full(t.size, 1.1)
    >>> true = integrate(*twist_icr(v_l[:-1], v_r[:-1], 1.0, -1.0, 0.0), np.diff(t))
    >>> log = WheelLog(t, v_l, v_r, true, None, np.zeros(t.size, int))
    >>> w = Windows(np.array([0]), np.array([t.size - 1]), np.array([10.0]))
    >>> idd = outage_errors(log, w, [0.0], model_twist(get_model("idd"), [], 1.0), duration=10)
    >>> chord = lambda r, turn: 2 * r * np.sin(turn / 2) * np.array([np.cos(turn / 2),
    ...                                                           np.sin(turn / 2)])
    >>> bool(np.isclose(idd.position[0], np.linalg.norm(chord(5, 2) - chord(10, 1))))
    True
    >>> round(float(idd.heading[0]), 9)
    1.0
    """
    relative = predict_window_ends(log, windows, twist_fn, start=np.zeros((len(windows), 3)))
    return _compared(log, windows, relative, start_yaw, duration, antenna, tolerance)


def _compared(
    log: WheelLog,
    windows: Windows,
    relative: np.ndarray,
    start_yaw: ArrayLike,
    duration: float,
    antenna: Sequence[float],
    tolerance: float = HEADING_TOLERANCE,
) -> OutageErrors:
    """Errors of the dead-reckoned end poses ``relative`` (in each start frame) of the windows."""
    start_yaw = np.asarray(start_yaw, dtype=float)
    q = antenna_displacement(relative, antenna)
    c, s = np.cos(start_yaw), np.sin(start_yaw)
    predicted = np.c_[c * q[:, 0] - s * q[:, 1], s * q[:, 0] + c * q[:, 1]]
    measured = log.pose[windows.end, :2] - log.pose[windows.start, :2]
    change = heading_change(log, windows.start, windows.end, tolerance)
    return OutageErrors(
        duration=float(duration),
        windows=windows,
        position=np.linalg.norm(predicted - measured, axis=1),
        heading=np.abs(wrap_angle(relative[:, 2] - change)),
    )


def outage_starts(
    log: WheelLog, durations: Sequence[float], every: float = OUTAGE_EVERY
) -> np.ndarray:
    """Start rows of the outage windows of every duration, sorted, each once.

    What a running estimator keeps its state of (:func:`outage_table` reads
    only these rows' estimates).
    """
    starts = [outage_windows(log, d, every=every).start for d in durations]
    return np.unique(np.concatenate([np.zeros(0, dtype=int), *starts]))


def outage_table(
    log: WheelLog,
    durations: Sequence[float],
    start_yaw: Callable[[np.ndarray], np.ndarray],
    models: Mapping[str, ModelAt | RowsTwist],
    *,
    antenna: Sequence[float] = (0.0, 0.0),
    every: float = OUTAGE_EVERY,
) -> dict[float, dict[str, OutageErrors]]:
    """Outage errors of several models from the same start poses, per duration.

    The same numbers as :func:`outage_errors` window by window, computed
    cheaper: a model given by its per-row twist (:data:`RowsTwist`, the same
    in every window) is integrated once over each segment and each window's
    motion read off as a relative pose; a model frozen per window
    (:data:`ModelAt`) is integrated once from each start, over its longest
    window, the shorter ones read on the way.

    Parameters
    ----------
    log : WheelLog
        The log.
    durations : sequence of float
        Outage durations, s.
    start_yaw : callable
        ``start_yaw(rows) -> yaw`` (rad): the estimator's heading at window start rows.
    models : mapping of str to ModelAt or RowsTwist
        Per model name: its frozen model of each window, or its twist at every row.
    antenna : sequence of 2 floats
        Where the measured positions are in the robot frame, m.
    every : float
        Time between window starts, s.

    Returns
    -------
    dict of float to dict of str to OutageErrors
        Per duration (with at least one window), per model.
    """
    found = {float(d): outage_windows(log, d, every=every) for d in durations}
    windows = {d: w for d, w in found.items() if len(w)}
    if not windows:
        return {}
    starts = np.unique(np.concatenate([w.start for w in windows.values()]))
    longest = np.zeros(starts.size, dtype=int)
    for w in windows.values():
        np.maximum.at(longest, np.searchsorted(starts, w.start), w.end)
    combined = Windows(starts, longest, np.zeros(starts.size))
    table: dict[float, dict[str, OutageErrors]] = {d: {} for d in windows}
    for name, model in models.items():
        if isinstance(model, tuple):
            relative = _relative_by_rows(log, windows, model)
        else:
            relative = _relative_by_windows(log, windows, combined, model(combined))
        for d, w in windows.items():
            yaw = start_yaw(w.start)
            table[d][name] = _compared(log, w, relative[d], yaw, d, antenna)
    return table


def _relative_by_rows(
    log: WheelLog, windows: Mapping[float, Windows], twist: RowsTwist
) -> dict[float, np.ndarray]:
    """End pose of each window in its start frame, from one integration of each segment run."""
    reckoned = np.zeros((len(log), 3))
    for run in log.run_ranges():
        a, b = run.start, run.stop
        v_x, v_y, omega = (np.asarray(c, dtype=float)[a : b - 1] for c in twist)
        reckoned[a:b] = integrate(v_x, v_y, omega, np.diff(log.t[a:b]))
    return {d: relative_pose(reckoned[w.start], reckoned[w.end]) for d, w in windows.items()}


def _relative_by_windows(
    log: WheelLog, windows: Mapping[float, Windows], combined: Windows, twist_fn: TwistFn
) -> dict[float, np.ndarray]:
    """End pose of each window in its start frame, integrating each start once (``combined``)."""
    relative = {d: np.empty((len(w), 3)) for d, w in windows.items()}
    where = {d: np.searchsorted(combined.start, w.start) for d, w in windows.items()}
    zero = np.zeros((len(combined), 3))
    slot = np.full(len(combined), -1)
    for idx, _, _, poses in window_poses(log, combined, twist_fn, start=zero):
        slot[idx] = np.arange(idx.size)
        for d, w in windows.items():
            mine = np.flatnonzero(slot[where[d]] >= 0)
            column = w.end[mine] - w.start[mine]
            relative[d][mine] = poses[slot[where[d][mine]], column]
        slot[idx] = -1
    return relative


def frozen_icr_table(
    log: WheelLog,
    durations: Sequence[float],
    starts: np.ndarray,
    states: np.ndarray,
    nominal: ArrayLike,
    *,
    track_width: float,
    antenna: Sequence[float] = (0.0, 0.0),
    every: float = OUTAGE_EVERY,
) -> dict[float, dict[str, OutageErrors]]:
    """Outage errors of an ICR EKF's learned model, the nominal one and the ideal differential drive.

    All three are dead-reckoned from the filter's pose at each window start
    (:func:`outage_table`): ``learned`` with the filter's ICRs there,
    ``nominal`` with the ICR model it started from, ``idd`` with ``y = +-B/2``.

    Parameters
    ----------
    log : WheelLog
        The log the filter ran over.
    durations : sequence of float
        Outage durations, s.
    starts : ndarray of int, shape (S,)
        Sorted rows whose states are given (at least :func:`outage_starts` of ``durations``).
    states : ndarray, shape (S, 5)
        The filter's ``yaw, y_l, y_r, x_icr, alpha`` after each of those rows
        (rad, m, m, m, -).
    nominal : array_like, shape (4,)
        ``y_l, y_r, x_icr, alpha`` of the nominal model (m, m, m, -).
    track_width : float
        Nominal track width ``B`` of the ideal differential drive, m.
    antenna : sequence of 2 floats
        Where the measured positions are in the robot frame, m.
    every : float
        Time between window starts, s.

    Returns
    -------
    dict of float to dict of str to OutageErrors
        Per duration with a window: ``learned``, ``nominal``, ``idd``.
    """
    half = track_width / 2.0
    fixed = np.asarray(nominal, dtype=float)

    def at(rows: np.ndarray) -> np.ndarray:
        return states[np.searchsorted(starts, rows)]

    models: dict[str, ModelAt | RowsTwist] = {
        "learned": lambda w: icr_twist_per_window(*at(w.start)[:, 1:5].T),
        "nominal": twist_icr(log.v_l, log.v_r, *fixed),
        "idd": twist_icr(log.v_l, log.v_r, half, -half, 0.0),
    }
    return outage_table(
        log, durations, lambda rows: at(rows)[:, 0], models, antenna=antenna, every=every
    )
