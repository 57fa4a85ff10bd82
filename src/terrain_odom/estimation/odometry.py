"""Run the ICR EKF or the slip EKF over a wheel log, row by row.

Row ``k`` of a log holds the wheel speeds at ``t[k]``, held until
``t[k+1]``; the filter predicts over ``[t[k-1], t[k]]`` with the speeds of
row ``k-1``, then fuses the pose measurement of row ``k`` if there is one.
The loop (:func:`run_odometry`) is the streaming API
(:class:`~terrain_odom.estimation.online.OnlineOdometry`) called row by row,
so a robot feeding it live gets what a log run gets.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from terrain_odom.config import Config
from terrain_odom.estimation.icr_ekf import IcrPriors
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.records import TerrainChange, WheelLog

__all__ = [
    "FrameObserver",
    "OdometryRow",
    "OdometryResult",
    "run_icr_ekf",
    "run_odometry",
    "run_slip_ekf",
]


@dataclass(frozen=True)
class OdometryRow:
    """The filter's estimate after processing one log row.

    Attributes
    ----------
    index : int
        Row of the log.
    t : float
        Time, s.
    state : ndarray, shape (n,)
        ``x, y, yaw, y_l, y_r, x_icr(, alpha)``.
    std : ndarray, shape (n,)
        Standard deviation of each state.
    terrain : str
        Confirmed terrain label, ``""`` if none.
    """

    index: int
    t: float
    state: np.ndarray
    std: np.ndarray
    terrain: str


class FrameObserver(Protocol):
    """Camera frames interleaved with the log rows (see :func:`run_odometry`).

    ``times`` are the frame times (s, non-decreasing). For each frame in the
    log's time span, :meth:`feed` gives frame ``index`` to the odometry
    (:meth:`~terrain_odom.estimation.online.OnlineOdometry.frame` with its
    image, or :meth:`~terrain_odom.estimation.online.OnlineOdometry.sighting`
    with a label classified elsewhere).
    """

    @property
    def times(self) -> np.ndarray:
        """Frame times, s, non-decreasing."""
        ...  # pragma: no cover

    def feed(self, index: int, odometry: OnlineOdometry) -> None:
        """Give frame ``index`` to ``odometry``."""
        ...  # pragma: no cover


@dataclass
class OdometryResult:
    """Everything an EKF run over a log produced.

    Attributes
    ----------
    names : tuple of str
        State names, in column order of ``states``.
    states, stds : ndarray, shape (N, n)
        Estimate and standard deviation after each row.
    terrain : ndarray of str, shape (N,)
        Confirmed terrain per row (``""`` before any label).
    changes : list of TerrainChange
        Confirmed terrain changes, with the log time of each.
    n_updates : int
        Pose measurements fused.
    frames_before, frames_after : int
        Frames before the first log row or after the last one (skipped).
    """

    names: tuple[str, ...]
    states: np.ndarray
    stds: np.ndarray
    terrain: np.ndarray
    changes: list[TerrainChange] = field(default_factory=list)
    n_updates: int = 0
    frames_before: int = 0
    frames_after: int = 0


def run_icr_ekf(
    log: WheelLog,
    config: Config,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    on_row: Callable[[OdometryRow], None] | None = None,
    frames: FrameObserver | None = None,
    priors: IcrPriors | None = None,
) -> OdometryResult:
    """Estimate pose and ICRs over a whole log.

    Parameters
    ----------
    log : WheelLog
        Wheel speeds and pose measurements.
    config : Config
        Filter and terrain settings; ``config.terrain.adapt`` switches the
        covariance reset on terrain changes.
    labels : sequence of str, shape (N,), optional
        Terrain label observed at each row (e.g. ``log.terrain``); ``None``
        runs without terrain information.
    on_row : callable, optional
        Called with an :class:`OdometryRow` after every row (to stream output).
    frames : FrameObserver, optional
        Camera frames supplying the terrain labels (instead of ``labels``);
        see :func:`run_odometry`. Frames fed as images need an
        :class:`~terrain_odom.estimation.online.OnlineOdometry` with a
        classifier: build it and call :func:`run_odometry`.
    priors : IcrPriors, optional
        Offline ICR parameters seeding the filter at the start and on
        confirmed changes (see :class:`~terrain_odom.estimation.icr_ekf.IcrEkf`).

    Returns
    -------
    OdometryResult
    """
    odometry = OnlineOdometry(config, priors=priors)
    return run_odometry(log, odometry, labels=labels, on_row=on_row, frames=frames)


def run_slip_ekf(
    log: WheelLog,
    config: Config,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    on_row: Callable[[OdometryRow], None] | None = None,
    frames: FrameObserver | None = None,
) -> OdometryResult:
    """Estimate the slip parameters over a whole log (:mod:`~terrain_odom.estimation.slip_ekf`).

    Parameters
    ----------
    log : WheelLog
        Wheel speeds and pose measurements: heading changes between rows
        with a yaw, position changes between rows with ``x, y`` (oriented by
        a heading measured within 1 s; without one, the length and turn of
        consecutive chords between the fixes).
    config : Config
        ``config.slip_ekf``, ``config.robot.track_width`` and ``config.terrain``.
    labels, on_row, frames
        As for :func:`run_icr_ekf`.

    Returns
    -------
    OdometryResult
        ``names`` are ``x, y, yaw`` (dead reckoning from the origin at each
        segment start, reset to every measured component), ``y_l, y_r,
        x_icr`` (at the row's track speeds), then the parameters; ``stds``
        hold NaN for the pose.
    """
    odometry = OnlineOdometry(config, estimator="slip-ekf")
    return run_odometry(log, odometry, labels=labels, on_row=on_row, frames=frames)


def run_odometry(
    log: WheelLog,
    odometry: OnlineOdometry,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    on_row: Callable[[OdometryRow], None] | None = None,
    frames: FrameObserver | None = None,
) -> OdometryResult:
    """Stream a log through :class:`~terrain_odom.estimation.online.OnlineOdometry`, row by row.

    Per row ``k`` the calls are: ``terrain(t[k], labels[k])`` when the label
    differs from the previous row's, ``wheels(t[k], v_l[k], v_r[k])`` (a
    new segment where :meth:`~terrain_odom.records.WheelLog.segment_runs`
    changes), ``pose(t[k], ...)`` when the row has a measured component,
    then the frames with ``t[k] <= t_f < t[k + 1]`` (``t_f <= t[-1]`` for
    the last row; frames before the first row or after the last are
    skipped), then the estimate is recorded.

    Parameters
    ----------
    log : WheelLog
    odometry : OnlineOdometry
        A fresh estimator (no sample given yet).
    labels, on_row, frames
        As for :func:`run_icr_ekf`; ``labels`` and ``frames`` exclude each other.

    Returns
    -------
    OdometryResult
    """
    if labels is not None and len(labels) != len(log):
        raise ValueError(f"labels has {len(labels)} entries for a log of {len(log)} rows")
    if labels is not None and frames is not None:
        raise ValueError("give terrain labels or frames, not both")
    n_rows, n_state = len(log), len(odometry.names)
    states = np.empty((n_rows, n_state))
    stds = np.empty((n_rows, n_state))
    terrain = np.full(n_rows, "", dtype=object)
    frame_t = np.empty(0) if frames is None else np.asarray(frames.times, dtype=float)
    # frames observed after row k: those with t[k] <= t_f < t[k + 1] (t_f <= t[-1] for the last)
    bounds = np.searchsorted(frame_t, log.t, side="left")
    n_after = int(frame_t.size - np.searchsorted(frame_t, log.t[-1], side="right")) if n_rows else 0
    for k, t, v_l, v_r, new, has_pose, label in _rows(log, labels):
        if label is not None:
            odometry.terrain(t, label)
        odometry.wheels(t, v_l, v_r, new_segment=new)
        if has_pose:
            odometry.pose(t, *log.pose[k].tolist())
        if frames is not None:
            stop = int(bounds[k + 1]) if k + 1 < n_rows else frame_t.size - n_after
            for i in range(int(bounds[k]), stop):
                frames.feed(i, odometry)
        states[k], stds[k] = odometry.estimate()
        terrain[k] = odometry.current_terrain
        if on_row is not None:
            on_row(OdometryRow(k, t, states[k], stds[k], terrain[k]))
    return OdometryResult(
        odometry.names,
        states,
        stds,
        terrain.astype(str),
        odometry.changes,
        odometry.n_updates,
        frames_before=int(bounds[0]) if n_rows else int(frame_t.size),
        frames_after=n_after,
    )


_CHUNK = 4096  # rows converted to Python numbers at a time


def _rows(
    log: WheelLog, labels: Sequence[str] | np.ndarray | None
) -> Iterator[tuple[int, float, float, float, bool, bool, str | None]]:
    """Yield ``k, t, v_l, v_r, new segment, has a pose, new label`` per row, as Python objects.

    The new label is ``str(labels[k])`` where it differs from the previous
    row's (and on row 0), else None. Indexing numpy per row costs more than
    the row's filter step; the columns are converted a chunk at a time, so
    memory does not grow with the log.
    """
    new_segment = np.zeros(len(log), dtype=bool)
    new_segment[log.run_starts()] = True
    has_pose = np.isfinite(log.pose).any(axis=1)
    events = _label_changes(labels)
    for start in range(0, len(log), _CHUNK):
        chunk = slice(start, min(start + _CHUNK, len(log)))
        yield from zip(
            range(chunk.start, chunk.stop),
            log.t[chunk].tolist(),
            log.v_l[chunk].tolist(),
            log.v_r[chunk].tolist(),
            new_segment[chunk].tolist(),
            has_pose[chunk].tolist(),
            map(events.get, range(chunk.start, chunk.stop)),
            strict=True,
        )


def _label_changes(labels: Sequence[str] | np.ndarray | None) -> dict[int, str]:
    """Row -> ``str`` label of every row whose label differs from the previous row's."""
    if labels is None or len(labels) == 0:
        return {}
    values = np.asarray(labels)
    rows = np.flatnonzero(np.r_[True, values[1:] != values[:-1]])
    return dict(zip(rows.tolist(), map(str, values[rows].tolist()), strict=True))
