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
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.errors import EstimationError
from terrain_odom.evaluation.metrics import TwistFn, settling_time, summarize, window_errors
from terrain_odom.evaluation.windows import Windows, spatial_windows
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import GroundTruth, WheelLog

__all__ = [
    "path_length",
    "frame_truth",
    "frame_accuracy",
    "feature_times",
    "groundtruth_log",
    "model_odometry_error",
    "reconvergence",
]


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


def frame_accuracy(truth: ArrayLike, predicted: ArrayLike) -> dict[str, Any]:
    """Classification accuracy per true terrain and overall.

    Frames with an unknown truth (``""``) are left out; frames with no label
    (``""``: unreadable, no usable region) count as wrong.

    Returns
    -------
    dict
        ``{"per_terrain": {label: {"frames", "correct", "accuracy", "confused_with"}},
        "overall": {"frames", "correct", "accuracy"}}``.
    """
    truth = np.asarray(truth, dtype=str)
    predicted = np.asarray(predicted, dtype=str)
    used = truth != ""
    per: dict[str, Any] = {}
    for label in _per_terrain(truth):
        rows = truth == label
        wrong = predicted[rows & (predicted != label)]
        names, counts = np.unique(wrong, return_counts=True)
        per[label] = {
            **_accuracy(int(rows.sum()), int(np.count_nonzero(predicted[rows] == label))),
            "confused_with": {
                (n or "(no label)"): int(c) for n, c in zip(names, counts, strict=True)
            },
        }
    correct = int(np.count_nonzero(predicted[used] == truth[used]))
    return {"per_terrain": per, "overall": _accuracy(int(used.sum()), correct)}


def _accuracy(frames: int, correct: int) -> dict[str, Any]:
    return {"frames": frames, "correct": correct, "accuracy": correct / frames if frames else None}


def _time_stats(ms: np.ndarray) -> dict[str, Any]:
    ms = ms[np.isfinite(ms)]
    if ms.size == 0:
        return {"frames": 0, "mean_ms": None, "max_ms": None}
    return {"frames": int(ms.size), "mean_ms": float(ms.mean()), "max_ms": float(ms.max())}


def feature_times(
    truth: ArrayLike, ms_roi: ArrayLike, ms_full: ArrayLike
) -> dict[str, dict[str, Any]]:
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
    dict
        Per terrain and ``all``: ``{"roi": {frames, mean_ms, max_ms},
        "full_frame": {...}, "speedup": mean full / mean roi}``.
    """
    truth = np.asarray(truth, dtype=str)
    roi = np.asarray(ms_roi, dtype=float)
    full = np.asarray(ms_full, dtype=float)
    groups = {label: truth == label for label in _per_terrain(truth)}
    groups["all"] = np.ones(truth.shape, dtype=bool)
    out: dict[str, dict[str, Any]] = {}
    for name, rows in groups.items():
        with_roi, without = _time_stats(roi[rows]), _time_stats(full[rows])
        speedup = None
        if with_roi["mean_ms"] and without["mean_ms"]:
            speedup = without["mean_ms"] / with_roi["mean_ms"]
        out[name] = {"roi": with_roi, "full_frame": without, "speedup": speedup}
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
) -> dict[str, dict[str, Any]]:
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
    dict
        Per model: ``mean_position_error_m`` (mean end-of-window position
        error), the median/quartile summary in m/m and deg/m, and
        ``per_terrain`` mean position errors.

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
    out: dict[str, dict[str, Any]] = {}
    for name, make in models.items():
        errors = window_errors(log, windows, make(windows))
        out[name] = {
            "mean_position_error_m": float(errors.translation.mean()),
            "mean_heading_error_deg": float(np.degrees(errors.rotation).mean()),
            **summarize(errors).to_dict(),
            "per_terrain_mean_position_error_m": {
                label: float(errors.translation[start_terrain == label].mean())
                for label in _per_terrain(start_terrain)
            },
            "windows": len(windows),
        }
    return out


def reconvergence(
    truth: GroundTruth,
    t: ArrayLike,
    icr: ArrayLike,
    tolerance: float,
    *,
    changes: Sequence[tuple[float, str, str]] | None = None,
    resets: Sequence[tuple[float, str]] = (),
) -> list[dict[str, Any]]:
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
    list of dict
        Per change: ``t``, ``from``, ``to``, ``settling_s`` (None if it never
        settles before the next change) and ``true_icr``.
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
            {
                "t": t_c,
                "from": previous,
                "to": new,
                "settling_s": float(settle) if np.isfinite(settle) else None,
                "true_icr": dict(zip(("y_l", "y_r", "x_icr"), true_icr.tolist(), strict=True)),
            }
        )
    return out
