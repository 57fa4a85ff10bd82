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
    "OdometryBlock",
    "OdometryResult",
    "run_icr_ekf",
    "run_odometry",
    "run_slip_ekf",
]


@dataclass(frozen=True)
class OdometryBlock:
    """The filter's estimates after a block of consecutive log rows.

    Attributes
    ----------
    start : int
        Log row of the block's first row.
    t : ndarray, shape (B,)
        Times, s.
    states, stds : ndarray, shape (B, n)
        Estimate ``x, y, yaw, y_l, y_r, x_icr(, alpha)`` (or the slip EKF's
        values) and standard deviations after each row.
    terrain : ndarray of str, shape (B,)
        Confirmed terrain per row, ``""`` if none.
    """

    start: int
    t: np.ndarray
    states: np.ndarray
    stds: np.ndarray
    terrain: np.ndarray


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
        Estimate and standard deviation after each row (each kept row: ``rows``).
    terrain : ndarray of str, shape (N,)
        Confirmed terrain per row (``""`` before any label).
    changes : list of TerrainChange
        Confirmed terrain changes, with the log time of each.
    n_updates : int
        Pose measurements fused.
    frames_before, frames_after : int
        Frames before the first log row or after the last one (skipped).
    rows : ndarray of int, shape (N,), optional
        The log rows of ``states``, ``stds`` and ``terrain`` where only some
        were kept (``run_odometry(keep=...)``); None: one per log row.
    """

    names: tuple[str, ...]
    states: np.ndarray
    stds: np.ndarray
    terrain: np.ndarray
    changes: list[TerrainChange] = field(default_factory=list)
    n_updates: int = 0
    frames_before: int = 0
    frames_after: int = 0
    rows: np.ndarray | None = None


def run_icr_ekf(
    log: WheelLog,
    config: Config,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    on_block: Callable[[OdometryBlock], None] | None = None,
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
    on_block : callable, optional
        Called with each :class:`OdometryBlock` of rows done (to stream
        output; see :func:`run_odometry`).
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
    return run_odometry(log, odometry, labels=labels, on_block=on_block, frames=frames)


def run_slip_ekf(
    log: WheelLog,
    config: Config,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    on_block: Callable[[OdometryBlock], None] | None = None,
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
    labels, on_block, frames
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
    return run_odometry(log, odometry, labels=labels, on_block=on_block, frames=frames)


def run_odometry(
    log: WheelLog,
    odometry: OnlineOdometry,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    on_block: Callable[[OdometryBlock], None] | None = None,
    frames: FrameObserver | None = None,
    keep: int = 1,
) -> OdometryResult:
    """Stream a log through :class:`~terrain_odom.estimation.online.OnlineOdometry`, row by row.

    Per row ``k`` the calls are: ``terrain(t[k], labels[k])`` when the label
    differs from the previous row's, ``wheels(t[k], v_l[k], v_r[k])`` (a
    new segment where :meth:`~terrain_odom.records.WheelLog.segment_runs`
    changes), ``pose(t[k], ...)`` when the row has a measured component,
    then the frames with ``t[k] <= t_f < t[k + 1]`` (``t_f <= t[-1]`` for
    the last row; frames before the first row or after the last are
    skipped), then the estimate is recorded. The rows between a label, a
    segment start and a frame go in one
    :meth:`~terrain_odom.estimation.online.OnlineOdometry.rows` call (the
    same results, compiled once the filter is anchored).

    Parameters
    ----------
    log : WheelLog
    odometry : OnlineOdometry
        A fresh estimator (no sample given yet).
    labels, frames
        As for :func:`run_icr_ekf`; ``labels`` and ``frames`` exclude each other.
    on_block : callable, optional
        Called with each :class:`OdometryBlock` of rows done, in order (about
        4096 rows each; on an error or interrupt, with the rows done so far,
        before the exception goes on).
    keep : int
        Keep the estimate of every ``keep``-th row (and of the last) in the
        result (:attr:`OdometryResult.rows`): memory that grows ``keep``
        times slower with the log, where ``on_block`` takes every row.

    Returns
    -------
    OdometryResult
    """
    if labels is not None and len(labels) != len(log):
        raise ValueError(f"labels has {len(labels)} entries for a log of {len(log)} rows")
    if labels is not None and frames is not None:
        raise ValueError("give terrain labels or frames, not both")
    if keep < 1:
        raise ValueError(f"keep must be >= 1, got {keep}")
    done = _Rows(log, len(odometry.names), keep, on_block)
    frame_t = np.empty(0) if frames is None else np.asarray(frames.times, dtype=float)
    # frames observed after row k: those with t[k] <= t_f < t[k + 1] (t_f <= t[-1] for the last)
    bounds = np.searchsorted(frame_t, log.t, side="left")
    n_after = (
        int(frame_t.size - np.searchsorted(frame_t, log.t[-1], side="right")) if len(log) else 0
    )
    ends = np.append(bounds[1:], frame_t.size - n_after)[: len(log)]  # frames: bounds[k]:ends[k]
    try:
        for rows, new, label in _stretches(log, labels, ends > bounds):
            if label is not None:
                odometry.terrain(float(log.t[rows.start]), label)
            stretch = odometry.rows(
                log.t[rows], log.v_l[rows], log.v_r[rows], log.pose[rows], new_segment=new
            )
            last = rows.stop - 1
            if frames is not None and ends[last] > bounds[last]:
                for i in range(int(bounds[last]), int(ends[last])):
                    frames.feed(i, odometry)
                stretch[0][-1], stretch[1][-1] = odometry.estimate()  # a frame may apply a change
                stretch[2][-1] = odometry.current_terrain
            done.add(*stretch)
    finally:
        done.flush()
    return OdometryResult(
        odometry.names,
        done.states,
        done.stds,
        done.terrain.astype(str),
        odometry.changes,
        odometry.n_updates,
        frames_before=int(bounds[0]) if len(log) else int(frame_t.size),
        frames_after=n_after,
        rows=None if keep == 1 else done.kept,
    )


class _Rows:
    """The rows done: handed on in blocks (``on_block``), every ``keep``-th (and the last) kept."""

    def __init__(
        self,
        log: WheelLog,
        n_state: int,
        keep: int,
        on_block: Callable[[OdometryBlock], None] | None,
    ) -> None:
        n_rows = len(log)
        self.kept = np.arange(0, n_rows, keep)
        if n_rows and self.kept[-1] != n_rows - 1:
            self.kept = np.append(self.kept, n_rows - 1)  # the last row is always kept
        self.states = np.empty((self.kept.size, n_state))
        self.stds = np.empty((self.kept.size, n_state))
        self.terrain = np.full(self.kept.size, "", dtype=object)
        self._t = log.t
        self._on_block = on_block
        self._pending: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._done = self._flushed = 0

    def add(self, states: np.ndarray, stds: np.ndarray, terrain: np.ndarray) -> None:
        """Take the next stretch of rows; hand them on once :data:`_CHUNK` rows are pending."""
        self._pending.append((states, stds, terrain))
        self._done += len(states)
        if self._done - self._flushed >= _CHUNK:
            self.flush()

    def flush(self) -> None:
        """Hand the pending rows on as one block and keep those to keep."""
        if not self._pending:
            return
        start, stop = self._flushed, self._done
        states, stds, terrain = (np.concatenate(part) for part in zip(*self._pending, strict=True))
        self._pending.clear()
        self._flushed = stop
        lo, hi = np.searchsorted(self.kept, [start, stop])
        kept = self.kept[lo:hi] - start
        self.states[lo:hi], self.stds[lo:hi], self.terrain[lo:hi] = (
            states[kept],
            stds[kept],
            terrain[kept],
        )
        if self._on_block is not None:
            self._on_block(OdometryBlock(start, self._t[start:stop], states, stds, terrain))


_CHUNK = 4096  # rows per stretch at most, and per block handed on


def _stretches(
    log: WheelLog, labels: Sequence[str] | np.ndarray | None, frames_after: np.ndarray
) -> Iterator[tuple[slice, bool, str | None]]:
    """Yield ``rows, new segment, new label`` for the stretches of rows run in one go.

    A stretch starts at a segment start (``new segment`` True) and at a new
    label (``str(labels[k])`` where it differs from the previous row's, and
    on row 0; else None), and ends after a row with frames after it, or
    after :data:`_CHUNK` rows.
    """
    new_segment = np.zeros(len(log), dtype=bool)
    new_segment[log.run_starts()] = True
    changes = _label_changes(labels)
    starts = new_segment.copy()
    starts[list(changes)] = True
    ends = frames_after | np.append(starts[1:], True)  # a stretch ends before a start
    start = 0
    for cut in np.flatnonzero(ends).tolist():
        while start <= cut:
            stop = min(cut + 1, start + _CHUNK)
            yield slice(start, stop), bool(new_segment[start]), changes.get(start)
            start = stop


def _label_changes(labels: Sequence[str] | np.ndarray | None) -> dict[int, str]:
    """Row -> ``str`` label of every row whose label differs from the previous row's."""
    if labels is None or len(labels) == 0:
        return {}
    values = np.asarray(labels)
    rows = np.flatnonzero(np.r_[True, values[1:] != values[:-1]])
    return dict(zip(rows.tolist(), map(str, values[rows].tolist()), strict=True))
