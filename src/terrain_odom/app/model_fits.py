"""Constant models fitted on logs and scored per terrain: what ``fit`` and ``compare`` share.

:func:`fit_sets` fits one parameter set (or one per terrain) on training
logs (:func:`~terrain_odom.fitting.fit_model`); :func:`group_errors` and
:func:`evaluate_params` score a fitted model on held-out logs, the windows
grouped by the terrain they start on.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from terrain_odom.errors import InputFileError
from terrain_odom.evaluation import (
    ErrorSummary,
    WindowErrors,
    Windows,
    anchored_window_errors,
    log_anchor,
    model_twist,
    spatial_windows,
    summarize,
)
from terrain_odom.fitting import (
    FitOptions,
    FitResult,
    Horizon,
    fit_model,
    segment_set,
    training_windows,
)
from terrain_odom.fitting.params import ANY_TERRAIN, ModelParams, ParamSet
from terrain_odom.kinematics import get_model
from terrain_odom.records import WheelLog

__all__ = ["fit_sets", "group_errors", "evaluate_params"]


def _terrains(logs: Sequence[WheelLog]) -> list[str]:
    columns = []
    for log in logs:
        if log.terrain is None:
            raise InputFileError(f"{log.source}: no terrain column; --by-terrain needs one")
        columns.append(log.terrain)
    return sorted({str(x) for column in columns for x in np.unique(column)})


def fit_sets(
    model: str,
    logs: Sequence[WheelLog],
    horizon: Horizon,
    by_terrain: bool,
    options: FitOptions,
    track_width: float,
    antenna: tuple[float, float] = (0.0, 0.0),
) -> tuple[dict[str, ParamSet], dict[str, FitResult], tuple[str, ...]]:
    """Fit one set (``ANY_TERRAIN``) or one per terrain.

    Each log's segments run between its full poses, else between its
    position fixes, else between its heading rows (:func:`~terrain_odom.evaluation.log_anchor`).
    """
    groups = _terrains(logs) if by_terrain else [None]
    anchors = [log_anchor(log) for log in logs]
    sets: dict[str, ParamSet] = {}
    fits: dict[str, FitResult] = {}
    skipped = []
    for terrain in groups:
        windows = [
            training_windows(log, horizon, terrain, a) for log, a in zip(logs, anchors, strict=True)
        ]
        segments = segment_set(logs, windows, anchor=anchors, antenna=antenna)
        if segments.count == 0:
            skipped.append(str(terrain))
            continue
        result = fit_model(model, segments, options=options, track_width=track_width)
        key = ANY_TERRAIN if terrain is None else terrain
        sets[key] = ParamSet(
            result.as_dict(),
            {
                "loss": result.loss,
                "segments": result.segments,
                "length_m": result.length,
                "duration_s": result.duration,
                "seconds": result.seconds,
            },
            result.at_bounds,
        )
        fits[key] = result
    if not sets:
        where = "" if not by_terrain else " on any terrain"
        raise InputFileError(
            f"no training segment of {horizon}{where} in "
            f"{', '.join(log.source for log in logs)} (pose measurements never that far apart "
            f"within a segment; fixes or headings alone: as far as the wheels say); use a "
            "shorter --horizon"
        )
    return sets, fits, tuple(skipped)


def group_errors(
    mp: ModelParams,
    logs: Sequence[WheelLog],
    h_e: float,
    track_width: float,
    antenna: tuple[float, float] = (0.0, 0.0),
) -> dict[str, list[WindowErrors]]:
    """Window errors of a model on evaluation logs, grouped by start-row terrain."""
    model = get_model(mp.model)
    groups: dict[str, list[WindowErrors]] = {}
    for log in logs:
        anchor = log_anchor(log)
        windows = spatial_windows(log, h_e, anchor=anchor)
        if len(windows) == 0:
            continue
        values = mp.rows(log)  # per-terrain sets need (and check) the terrain column
        labels = np.asarray(log.terrain) if mp.per_terrain else np.full(len(log), ANY_TERRAIN)
        b = mp.track_width or track_width
        twist = model_twist(model, values[windows.start], b)
        errors = anchored_window_errors(log, windows, twist, anchor=anchor, antenna=antenna)
        start_labels = labels[windows.start]
        for label in np.unique(start_labels):
            keep = np.flatnonzero(start_labels == label)
            groups.setdefault(str(label), []).append(_subset(errors, keep))
    return groups


def _subset(errors: WindowErrors, keep: np.ndarray) -> WindowErrors:
    w = errors.windows
    return WindowErrors(
        windows=Windows(start=w.start[keep], end=w.end[keep], length=w.length[keep]),
        predicted=errors.predicted[keep],
        translation=errors.translation[keep],
        rotation=errors.rotation[keep],
    )


def evaluate_params(
    mp: ModelParams,
    logs: Sequence[WheelLog],
    h_e: float,
    track_width: float,
    antenna: tuple[float, float] = (0.0, 0.0),
) -> dict[str, ErrorSummary]:
    """Error statistics of a fitted model on evaluation logs, per terrain (or ``ANY_TERRAIN``).

    Parameters
    ----------
    mp : ModelParams
        The model; per-terrain sets are applied to the windows starting on
        their terrain.
    logs : sequence of WheelLog
        Evaluation logs.
    h_e : float
        Evaluation horizon, m.
    track_width : float
        Nominal ``B``, m (when ``mp`` has none).
    antenna : tuple of 2 floats, optional
        Where the position sensor is, m (logs of GPS fixes, :func:`~terrain_odom.evaluation.antenna_of`).

    Returns
    -------
    dict of str to ErrorSummary
        Pooled over the logs, per group.
    """
    groups = group_errors(mp, logs, h_e, track_width, antenna)
    return {k: summarize(v) for k, v in groups.items()}
