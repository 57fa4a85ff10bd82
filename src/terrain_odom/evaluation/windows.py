"""Evaluation windows of a log: spatial (per metre), time and prediction windows.

A window runs from a row with a full pose measurement to a later full-pose
row of the same run (:meth:`~terrain_odom.records.WheelLog.segment_runs`);
windows never cross a ``segment`` change.

- :func:`spatial_windows` (Baril et al., CRV 2020, section IV): the end is
  the first full-pose row whose measured path length from the start is at
  least ``horizon`` (2 m by default); windows that never reach it are
  dropped. The path length is the sum of the distances between consecutive
  measured positions.
- :func:`time_windows`: the same with a minimum duration instead.
- :func:`prediction_windows` (the 2016 slip-model paper): the end is the
  full-pose row whose time is nearest ``t_start + horizon`` (s), within a
  tolerance.
- :func:`non_overlapping`: windows chained end to start (training segments).
- :func:`padded_steps`: the wheel rows of windows as a padded block, for
  vectorised integration.

Logs whose positions and headings come on different rows (a GPS and an IMU)
have no full-pose row: ``anchor`` chooses the rows windows run between
(``"pose"``: full poses, the default; ``"position"``: any measured ``x, y``;
``"heading"``: any measured ``yaw``). Windows between position fixes or
heading rows are as long as the wheels say (:func:`wheel_path`): the noise
of a GPS lengthens the path of its fixes several times over on a slow robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.records import WheelLog

__all__ = [
    "DEFAULT_HORIZON",
    "MIN_HORIZON",
    "PREDICTION_HORIZON",
    "Windows",
    "spatial_windows",
    "time_windows",
    "prediction_windows",
    "non_overlapping",
    "padded_steps",
    "ANCHORS",
    "anchor_mask",
    "log_anchor",
    "wheel_path",
]

DEFAULT_HORIZON = 2.0  # m, Baril et al.'s spatial window h_e
MIN_HORIZON = 1e-3  # m: shorter windows are lost in the rounding of the path length
PREDICTION_HORIZON = 2.0  # s, the 2016 slip-model paper's prediction horizon
ANCHORS = ("pose", "position", "heading")
"""What the rows a window starts and ends on measure (see the module docstring)."""


def anchor_mask(log: WheelLog, anchor: str) -> np.ndarray:
    """Rows windows may start and end on, shape (N,): full poses, positions or headings.

    Examples
    --------
    >>> pose = np.array([[0.0, 0.0, np.nan], [np.nan, np.nan, 0.1], [1.0, 0.0, 0.2]])
    >>> log = WheelLog(np.arange(3.0), np.ones(3), np.ones(3), pose, None, np.zeros(3, int))
    >>> [anchor_mask(log, a).tolist() for a in ANCHORS]
    [[False, False, True], [True, False, True], [False, True, True]]
    """
    masks = {"pose": log.has_pose, "position": log.has_position, "heading": log.has_yaw}
    if anchor not in masks:
        raise ValueError(f"window anchor must be one of {ANCHORS}, got {anchor!r}")
    return masks[anchor]


def log_anchor(log: WheelLog) -> str:
    """Return what a log's windows run between: full poses, else positions, else headings.

    Examples
    --------
    >>> pose = np.array([[0.0, 0.0, np.nan], [np.nan, np.nan, 0.1]])
    >>> log = WheelLog(np.arange(2.0), np.ones(2), np.ones(2), pose, None, np.zeros(2, int))
    >>> log_anchor(log), log_anchor(log.take([1]))
    ('position', 'heading')
    """
    if log.has_pose.any():
        return "pose"
    return "position" if log.has_position.any() else "heading"


def wheel_path(log: WheelLog) -> np.ndarray:
    """Cumulative path length by the wheels per row, shape (N,), m (frozen across segments).

    Row ``k``'s mean track speed ``|v_l + v_r| / 2`` held until ``t[k+1]``;
    what a window between heading rows is as long as (no positions to measure it).

    Examples
    --------
    >>> log = WheelLog(np.arange(4.0), np.ones(4), np.full(4, 3.0), np.full((4, 3), np.nan),
    ...                None, np.array([0, 0, 1, 1]))
    >>> wheel_path(log).tolist()
    [0.0, 2.0, 2.0, 4.0]
    """
    runs = log.segment_runs()
    step = np.abs(log.v_l[:-1] + log.v_r[:-1]) / 2.0 * np.diff(log.t)
    return np.concatenate([[0.0], np.cumsum(np.where(runs[1:] == runs[:-1], step, 0.0))])


@dataclass(frozen=True)
class Windows:
    """Evaluation windows of a log (spatial, time or prediction windows).

    Attributes
    ----------
    start, end : ndarray of int, shape (W,)
        Log rows of the start and end pose measurements (``start < end``).
    length : ndarray, shape (W,)
        Measured path length between start and end, m (``>= horizon`` for
        spatial windows).
    """

    start: np.ndarray
    end: np.ndarray
    length: np.ndarray

    def __len__(self) -> int:
        return int(self.start.shape[0])


def _measured_path(log: WheelLog) -> np.ndarray:
    """Cumulative measured path length per row, shape (N,), m (NaN without position).

    Only differences within a segment run are path lengths (the step into a
    new run is its jump): every window starts and ends in one run.
    """
    rows = np.flatnonzero(log.has_position)
    steps = np.zeros(rows.size)
    steps[1:] = np.linalg.norm(np.diff(log.pose[rows, :2], axis=0), axis=1)
    path = np.full(len(log), np.nan)
    path[rows] = np.cumsum(steps)
    return path


def _path(log: WheelLog, anchor: str) -> np.ndarray:
    """Path length per row as windows between ``anchor`` rows measure it, m.

    Full poses measure it along their positions; windows between position
    fixes or heading rows by the wheels (a GPS's noise lengthens the path of
    its fixes several times over on a slow robot).
    """
    return _measured_path(log) if anchor == "pose" else wheel_path(log)


def spatial_windows(
    log: WheelLog, horizon: float = DEFAULT_HORIZON, *, anchor: str = "pose"
) -> Windows:
    """Find the spatial evaluation windows of a log.

    Parameters
    ----------
    log : WheelLog
        Log with pose measurements (``N`` rows).
    horizon : float, optional
        Minimum measured path length of a window ``h_e``, m (> 0).
    anchor : {"pose", "position", "heading"}, optional
        The rows windows run between (:func:`anchor_mask`); other than
        ``"pose"`` the path is measured by the wheels (:func:`wheel_path`).

    Returns
    -------
    Windows
        One window per anchor row that reaches ``horizon`` within its
        segment, in row order.

    Examples
    --------
    Poses every 0.5 m along x, a segment change after row 5:

    >>> n = 8
    >>> pose = np.c_[0.5 * np.arange(n), np.zeros(n), np.zeros(n)]
    >>> log = WheelLog(np.arange(n, dtype=float), np.ones(n), np.ones(n), pose,
    ...                None, np.array([0] * 6 + [1] * 2))
    >>> w = spatial_windows(log, horizon=1.0)
    >>> w.start.tolist(), w.end.tolist(), w.length.tolist()
    ([0, 1, 2, 3], [2, 3, 4, 5], [1.0, 1.0, 1.0, 1.0])
    """
    if not horizon >= MIN_HORIZON:
        raise ValueError(f"window horizon must be >= {MIN_HORIZON:g} m, got {horizon}")
    rows = anchor_mask(log, anchor)
    runs = log.segment_runs()
    path = _path(log, anchor)
    return _windows_reaching(rows, runs, path, path, horizon)


def time_windows(log: WheelLog, duration: float, *, anchor: str = "pose") -> Windows:
    """Find windows of a minimum duration (the time-horizon variant of :func:`spatial_windows`).

    Parameters
    ----------
    log : WheelLog
        Log with pose measurements (``N`` rows).
    duration : float
        Minimum time between the start and end pose measurements, s (> 0).
    anchor : {"pose", "position", "heading"}, optional
        The rows windows run between (:func:`anchor_mask`).

    Returns
    -------
    Windows
        One window per full-pose row that reaches ``duration`` within its
        segment, in row order; ``length`` is the measured path length (m,
        possibly 0 when the robot stood still).

    Examples
    --------
    >>> n = 6
    >>> pose = np.c_[0.5 * np.arange(n), np.zeros(n), np.zeros(n)]
    >>> log = WheelLog(0.5 * np.arange(n), np.ones(n), np.ones(n), pose,
    ...                None, np.array([0] * 4 + [1] * 2))
    >>> w = time_windows(log, duration=1.0)
    >>> w.start.tolist(), w.end.tolist()
    ([0, 1], [2, 3])
    """
    if not duration > 0.0:
        raise ValueError(f"window duration must be > 0 s, got {duration}")
    runs = log.segment_runs()
    same_run = runs[1:] == runs[:-1]
    clock = np.concatenate([[0.0], np.cumsum(np.where(same_run, np.diff(log.t), 0.0))])
    path = _path(log, anchor)
    return _windows_reaching(anchor_mask(log, anchor), runs, clock, path, duration)


def _windows_reaching(
    anchor: np.ndarray, runs: np.ndarray, measure: np.ndarray, path: np.ndarray, horizon: float
) -> Windows:
    """Windows from each ``anchor`` row to the first one of its run ``horizon`` further.

    ``measure`` is a per-row quantity that never decreases (path length or
    time, frozen across segment changes); ``path`` gives the window lengths.
    """
    rows = np.flatnonzero(anchor)
    m = measure[rows]
    j = np.searchsorted(m, m + horizon, side="left")
    inside = j < rows.size
    j_in = np.minimum(j, rows.size - 1)
    keep = inside & (runs[rows[j_in]] == runs[rows])
    start, end = rows[keep], rows[j_in[keep]]
    return Windows(start=start, end=end, length=path[end] - path[start])


def non_overlapping(windows: Windows) -> Windows:
    """Chain windows end to start: the distinct segments of Baril et al.'s training.

    Greedily keeps the first window, then the first window starting at or
    after the end of the last kept one, and so on.

    Parameters
    ----------
    windows : Windows
        Windows in row order (from :func:`spatial_windows` or :func:`time_windows`).

    Returns
    -------
    Windows
        A subset whose row ranges ``start .. end`` do not overlap (they may
        share an end/start row).

    Examples
    --------
    >>> w = Windows(np.array([0, 1, 2, 3, 4]), np.array([2, 3, 4, 6, 6]), np.ones(5))
    >>> non_overlapping(w).start.tolist()
    [0, 2, 4]
    """
    keep = []
    i = 0
    while i < len(windows):
        keep.append(i)
        i = int(np.searchsorted(windows.start, windows.end[i], side="left"))
    idx = np.asarray(keep, dtype=int)
    return Windows(start=windows.start[idx], end=windows.end[idx], length=windows.length[idx])


def prediction_windows(
    log: WheelLog,
    horizon: float = PREDICTION_HORIZON,
    *,
    starts: ArrayLike | None = None,
    tolerance: float = 0.25,
    anchor: str = "pose",
) -> Windows:
    """Time windows of ``horizon`` seconds between full pose measurements (or ``anchor`` rows).

    Parameters
    ----------
    log : WheelLog
        The reference log (its full poses are the ground truth).
    horizon : float
        Prediction horizon, s (> 0).
    starts : array_like of int, optional
        Candidate start rows (e.g. the rows of a subsampled pose stream);
        every full-pose row if omitted. Rows without a full pose are skipped.
    tolerance : float
        Largest accepted ``|t_end - t_start - horizon|``, s.
    anchor : {"pose", "position", "heading"}, optional
        The rows windows run between (:func:`anchor_mask`).

    Returns
    -------
    Windows
        ``start``, ``end`` rows and the measured path ``length`` (m).

    Examples
    --------
    >>> n = 9
    >>> log = WheelLog(np.arange(n) * 0.5, np.ones(n), np.ones(n),
    ...                np.c_[np.arange(n) * 0.5, np.zeros(n), np.zeros(n)],
    ...                None, np.zeros(n, dtype=int))
    >>> w = prediction_windows(log, 2.0, starts=[0, 2, 4, 6])
    >>> w.start.tolist(), w.end.tolist()
    ([0, 2, 4], [4, 6, 8])
    """
    if not horizon > 0.0:
        raise ValueError(f"prediction horizon must be > 0 s, got {horizon}")
    mask = anchor_mask(log, anchor)
    rows = np.flatnonzero(mask)
    cand = rows if starts is None else np.asarray(starts, dtype=int)
    cand = cand[mask[cand]]
    runs = log.segment_runs()
    clock = _run_clock(log, runs, horizon + tolerance + 1.0)
    t_rows = clock[rows]
    target = clock[cand] + horizon
    j = np.clip(np.searchsorted(t_rows, target), 1, max(rows.size - 1, 1))
    before = np.clip(j - 1, 0, rows.size - 1)
    j = np.minimum(j, rows.size - 1)
    nearest = np.where(np.abs(t_rows[before] - target) <= np.abs(t_rows[j] - target), before, j)
    end = rows[nearest] if rows.size else cand
    keep = (
        (end > cand)
        & (runs[end] == runs[cand])
        & (np.abs(clock[end] - target) <= tolerance)
    )  # fmt: skip
    path = _path(log, anchor)
    start, end = cand[keep], end[keep]
    return Windows(start=start, end=end, length=path[end] - path[start])


def _run_clock(log: WheelLog, runs: np.ndarray, gap: float) -> np.ndarray:
    """Time per row that never decreases: each run's own time, runs ``gap`` s apart.

    A log's time need only increase within a segment (it may start again at
    each); searching a time across the whole log needs one that increases
    throughout, and ``gap`` keeps a search from one run finding the next.
    """
    first = np.flatnonzero(np.r_[True, runs[1:] != runs[:-1]])
    jump = np.zeros(first.size)  # each run's shift beyond the previous one's (run 0: none)
    jump[1:] = log.t[first[1:] - 1] - log.t[first[1:]] + gap
    return log.t + np.cumsum(jump)[runs]


def padded_steps(
    log: WheelLog, windows: Windows, index: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wheel rows of some windows as a padded ``(W, K)`` block.

    Parameters
    ----------
    log : WheelLog
        The log the windows belong to.
    windows : Windows
        The windows.
    index : ndarray of int, shape (W,)
        Which windows to take; ``K`` is the longest one's number of steps.

    Returns
    -------
    rows : ndarray of int, shape (W, K)
        Log row of each step (padding repeats the last real row).
    valid : ndarray of bool, shape (W, K)
        False on padding.
    dt : ndarray, shape (W, K)
        Duration of each step (``t[k+1] - t[k]``, zero-order hold), s; 0 on padding.
    """
    dt_row = np.append(np.diff(log.t), 0.0)
    k = (windows.end - windows.start)[index, None]
    step = np.arange(k.max())
    valid = step < k
    rows = windows.start[index, None] + np.minimum(step, k - 1)
    return rows, valid, np.where(valid, dt_row[rows], 0.0)
