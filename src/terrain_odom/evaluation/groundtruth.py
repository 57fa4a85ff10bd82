"""Scores of a run against ground truth (a simulated run's ``groundtruth.csv``).

- :func:`frame_truth`: the true terrain of the ground each frame classified.
  The camera looks ``ahead`` metres along the path, so a frame's truth is the
  terrain under the robot when the true path has advanced that far.
- :func:`frame_accuracy` and :func:`feature_times`: per true terrain, the
  classification accuracy and the feature-extraction time with and without
  the region of interest (Chen et al. 2023, Tables 1-2).
- :func:`model_odometry_error`: the model-odometry metric of
  :mod:`terrain_odom.evaluation.metrics` (each window integrated from the
  true pose with the model known at its start) on the true trajectory; its
  mean end-of-window position error is the figure Chen reports (0.06 m with
  terrain adaptation, 0.14 m without).
- :func:`reconvergence`: seconds from each true terrain change until the ICR
  estimate stays within a band around the new terrain's true ICRs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.errors import EstimationError
from terrain_odom.evaluation.metrics import (
    ErrorSummary,
    TwistFn,
    settling_time,
    summarize,
    window_errors,
)
from terrain_odom.evaluation.windows import Windows, spatial_windows
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import GroundTruth, WheelLog

__all__ = [
    "Accuracy",
    "FrameAccuracy",
    "TimeStats",
    "FrameTime",
    "ModelOdometry",
    "Reconvergence",
    "path_length",
    "frame_truth",
    "frame_accuracy",
    "feature_times",
    "groundtruth_log",
    "model_odometry_error",
    "reconvergence",
]


@dataclass(frozen=True)
class Accuracy:
    """Frames of one true terrain (or all) and how many were classified right.

    ``confused_with`` (per terrain only, None overall): wrong labels and their counts.
    """

    frames: int
    correct: int
    confused_with: dict[str, int] | None = None

    @property
    def accuracy(self) -> float | None:
        """Fraction classified right (None without frames)."""
        return self.correct / self.frames if self.frames else None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``frames``, ``correct``, ``accuracy`` (and ``confused_with``)."""
        out: dict[str, Any] = {
            "frames": self.frames,
            "correct": self.correct,
            "accuracy": self.accuracy,
        }
        if self.confused_with is not None:
            out["confused_with"] = self.confused_with
        return out


@dataclass(frozen=True)
class FrameAccuracy:
    """Classification accuracy per true terrain and overall (:func:`frame_accuracy`)."""

    per_terrain: dict[str, Accuracy]
    overall: Accuracy

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``per_terrain`` and ``overall``."""
        return {
            "per_terrain": {k: a.to_dict() for k, a in self.per_terrain.items()},
            "overall": self.overall.to_dict(),
        }


@dataclass(frozen=True)
class TimeStats:
    """Per-frame times measured, ms (``mean_ms``, ``max_ms`` None without frames)."""

    frames: int
    mean_ms: float | None
    max_ms: float | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``frames``, ``mean_ms``, ``max_ms``."""
        return {"frames": self.frames, "mean_ms": self.mean_ms, "max_ms": self.max_ms}


@dataclass(frozen=True)
class FrameTime:
    """Time with and without the region of interest, and the speed-up (None: not measured)."""

    roi: TimeStats
    full_frame: TimeStats
    speedup: float | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``roi``, ``full_frame``, ``speedup``."""
        return {
            "roi": self.roi.to_dict(),
            "full_frame": self.full_frame.to_dict(),
            "speedup": self.speedup,
        }


@dataclass(frozen=True)
class ModelOdometry:
    """A model's odometry error over windows from the true pose (:func:`model_odometry_error`)."""

    mean_position_error_m: float
    mean_heading_error_deg: float
    summary: ErrorSummary
    per_terrain_mean_position_error_m: dict[str, float]
    windows: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: the means, the summary's m/m and deg/m, per terrain, windows."""
        return {
            "mean_position_error_m": self.mean_position_error_m,
            "mean_heading_error_deg": self.mean_heading_error_deg,
            **self.summary.to_dict(),
            "per_terrain_mean_position_error_m": self.per_terrain_mean_position_error_m,
            "windows": self.windows,
        }


@dataclass(frozen=True)
class Reconvergence:
    """Re-convergence after one true terrain change (:func:`reconvergence`).

    ``settling_s`` None: never settled before the next change.
    """

    t: float
    previous: str
    new: str
    settling_s: float | None
    true_icr: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``t``, ``from``, ``to``, ``settling_s``, ``true_icr``."""
        return {
            "t": self.t,
            "from": self.previous,
            "to": self.new,
            "settling_s": self.settling_s,
            "true_icr": self.true_icr,
        }


def path_length(pose: ArrayLike) -> np.ndarray:
    """Cumulative planar path length along poses, shape (N,), m (0 at the first)."""
    xy = np.asarray(pose, dtype=float)[:, :2]
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])


def frame_truth(truth: GroundTruth, t: ArrayLike, ahead: ArrayLike) -> np.ndarray:
    """Return the true terrain of the ground classified in each frame.

    Parameters
    ----------
    truth : GroundTruth
    t : array_like, shape (F,)
        Frame times, s.
    ahead : array_like, shape (F,)
        Distance from the robot to the classified ground along the path, m
        (``frames.csv``'s ``ahead_m``; NaN: unknown, treated as 0).

    Returns
    -------
    ndarray of str, shape (F,)
        Terrain under the true robot once its path has advanced ``ahead``
        past where it was at ``t``; ``""`` for frames outside the ground
        truth's time span or whose ground the robot never reaches.
    """
    t = np.asarray(t, dtype=float)
    ahead = np.nan_to_num(np.asarray(ahead, dtype=float), nan=0.0)
    s = path_length(truth.pose)
    target = np.interp(t, truth.t, s) + ahead
    row = np.searchsorted(s, target - 1e-9, side="left")
    known = (t >= truth.t[0]) & (t <= truth.t[-1]) & (row < s.size)
    out = np.full(t.shape, "", dtype=object)
    out[known] = truth.terrain[row[known]]
    return out.astype(str)


def _per_terrain(truth: np.ndarray) -> list[str]:
    return sorted({str(s) for s in truth if s})


def frame_accuracy(truth: ArrayLike, predicted: ArrayLike) -> FrameAccuracy:
    """Classification accuracy per true terrain and overall.

    Frames with an unknown truth (``""``) are left out; frames with no label
    (``""``: unreadable, no usable region) count as wrong.

    Returns
    -------
    FrameAccuracy
        Per true terrain (with what it was confused with) and overall.
    """
    truth = np.asarray(truth, dtype=str)
    predicted = np.asarray(predicted, dtype=str)
    used = truth != ""
    per: dict[str, Accuracy] = {}
    for label in _per_terrain(truth):
        rows = truth == label
        wrong = predicted[rows & (predicted != label)]
        names, counts = np.unique(wrong, return_counts=True)
        per[label] = Accuracy(
            int(rows.sum()),
            int(np.count_nonzero(predicted[rows] == label)),
            {(str(n) or "(no label)"): int(c) for n, c in zip(names, counts, strict=True)},
        )
    correct = int(np.count_nonzero(predicted[used] == truth[used]))
    return FrameAccuracy(per, Accuracy(int(used.sum()), correct))


def _time_stats(ms: np.ndarray) -> TimeStats:
    ms = ms[np.isfinite(ms)]
    if ms.size == 0:
        return TimeStats(0, None, None)
    return TimeStats(int(ms.size), float(ms.mean()), float(ms.max()))


def feature_times(truth: ArrayLike, ms_roi: ArrayLike, ms_full: ArrayLike) -> dict[str, FrameTime]:
    """Per-frame time per true terrain, with and without the region of interest.

    Parameters
    ----------
    truth : array_like of str, shape (F,)
        True terrain of each frame (``""`` rows are pooled into ``all`` only).
    ms_roi, ms_full : array_like, shape (F,)
        Time on the region of interest and on the whole frame, ms (NaN where
        not measured), e.g. of feature extraction.

    Returns
    -------
    dict of str to FrameTime
        Per terrain and ``all``: with and without the region of interest,
        and the speed-up (mean full / mean roi).
    """
    truth = np.asarray(truth, dtype=str)
    roi = np.asarray(ms_roi, dtype=float)
    full = np.asarray(ms_full, dtype=float)
    groups = {label: truth == label for label in _per_terrain(truth)}
    groups["all"] = np.ones(truth.shape, dtype=bool)
    out: dict[str, FrameTime] = {}
    for name, rows in groups.items():
        with_roi, without = _time_stats(roi[rows]), _time_stats(full[rows])
        speedup = None
        if with_roi.mean_ms and without.mean_ms:
            speedup = without.mean_ms / with_roi.mean_ms
        out[name] = FrameTime(with_roi, without, speedup)
    return out


def groundtruth_log(log: WheelLog, truth: GroundTruth) -> WheelLog:
    """Return the log with its pose column replaced by the true pose at every row.

    Raises
    ------
    ValueError
        If the ground truth does not cover the log's time span.
    """
    if not truth.covers(log.t):
        raise ValueError(
            f"{truth.source} covers {truth.t[0]:g}-{truth.t[-1]:g} s but the log {log.source} spans "
            f"{log.t[0]:g}-{log.t[-1]:g} s"
        )
    yaw = np.interp(log.t, truth.t, np.unwrap(truth.pose[:, 2]))
    pose = np.column_stack(
        [
            np.interp(log.t, truth.t, truth.pose[:, 0]),
            np.interp(log.t, truth.t, truth.pose[:, 1]),
            wrap_angle(yaw),
        ]
    )
    return dataclasses.replace(log, pose=pose)


def model_odometry_error(
    log: WheelLog,
    terrain: ArrayLike,
    models: Mapping[str, Callable[[Windows], TwistFn]],
    horizon: float,
) -> dict[str, ModelOdometry]:
    """Model-odometry error of several models over ``horizon``-metre windows.

    Parameters
    ----------
    log : WheelLog
        Log whose poses are the ground truth at every row
        (:func:`groundtruth_log`).
    terrain : array_like of str, shape (N,)
        True terrain per row, to split the errors by the terrain at the
        window start.
    models : mapping of str to callable
        Name to ``make(windows) -> TwistFn`` (called once with the windows).
    horizon : float
        Window length ``h_e``, m.

    Returns
    -------
    dict of str to ModelOdometry
        Per model: the mean end-of-window position error, the
        median/quartile summary in m/m and deg/m, and per-terrain mean
        position errors.

    Raises
    ------
    EstimationError
        The run travels less than ``horizon`` (no window to score).
    """
    windows = spatial_windows(log, horizon)
    if len(windows) == 0:
        raise EstimationError(
            f"{log.source}: no {horizon:g} m window to score against the ground truth (the run "
            f"travels less than {horizon:g} m)"
        )
    start_terrain = np.asarray(terrain, dtype=str)[windows.start]
    out: dict[str, ModelOdometry] = {}
    for name, make in models.items():
        errors = window_errors(log, windows, make(windows))
        out[name] = ModelOdometry(
            float(errors.translation.mean()),
            float(np.degrees(errors.rotation).mean()),
            summarize(errors),
            {
                label: float(errors.translation[start_terrain == label].mean())
                for label in _per_terrain(start_terrain)
            },
            len(windows),
        )
    return out


def reconvergence(
    truth: GroundTruth,
    t: ArrayLike,
    icr: ArrayLike,
    tolerance: float,
    *,
    changes: Sequence[tuple[float, str, str]] | None = None,
    resets: Sequence[tuple[float, str]] = (),
) -> list[Reconvergence]:
    """Re-convergence time of an ICR estimate after each true terrain change.

    The clock starts when the robot enters the new terrain; the estimate has
    re-converged once ``y_l``, ``y_r`` and ``x_icr`` all stay within
    ``tolerance`` of the new terrain's true values until the next change
    (the next true change, or the filter's switch to another terrain if
    that comes first, e.g. a reset scheduled a little early).

    Parameters
    ----------
    truth : GroundTruth
    t : array_like, shape (N,)
        Times of the estimates, s.
    icr : array_like, shape (N, 3)
        Estimated ``y_l, y_r, x_icr``, m.
    tolerance : float
        Band half-width, m.
    changes : sequence, optional
        ``(t, previous, new)``; the ground truth's own changes by default.
    resets : sequence of (float, str)
        The filter's applied terrain changes ``(t, label)``.

    Returns
    -------
    list of Reconvergence
        Per change: its time, terrains, settling time (None if it never
        settles before the next change) and the true ICRs.
    """
    t = np.asarray(t, dtype=float)
    icr = np.asarray(icr, dtype=float)
    changes = truth.changes() if changes is None else list(changes)
    out = []
    for i, (t_c, previous, new) in enumerate(changes):
        t_end = changes[i + 1][0] if i + 1 < len(changes) else np.inf
        t_end = min([t_end] + [t_r for t_r, label in resets if t_c < t_r and label != new])
        rows = (t >= t_c) & (t < t_end)
        true_icr = truth.icr[np.searchsorted(truth.t, t_c)]
        settle = (
            settling_time(t[rows], icr[rows], true_icr, [tolerance] * 3, t_from=t_c)
            if rows.any()
            else np.inf
        )
        out.append(
            Reconvergence(
                t_c,
                previous,
                new,
                float(settle) if np.isfinite(settle) else None,
                dict(zip(("y_l", "y_r", "x_icr"), true_icr.tolist(), strict=True)),
            )
        )
    return out
