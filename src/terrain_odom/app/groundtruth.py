"""The ground-truth section of a run's report (``run --groundtruth``).

Besides the run itself, the section re-runs the filter over the same log
and frame labels in the variants Chen et al. 2023 compare (no terrain
adaptation, adaptation, adaptation with terrain memory) and scores each,
plus ideal differential drive, against the ground truth: frame accuracy,
feature time with and without the region of interest, model-odometry error
and ICR re-convergence after every true terrain change.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrain_odom.app.frames import FrameRecord, ReplayedFrames
from terrain_odom.config import Config
from terrain_odom.estimation.icr_ekf import IcrPriors
from terrain_odom.estimation.odometry import OdometryResult, run_icr_ekf
from terrain_odom.evaluation.groundtruth import (
    feature_times,
    frame_accuracy,
    frame_truth,
    groundtruth_log,
    model_odometry_error,
    reconvergence,
)
from terrain_odom.evaluation.metrics import icr_twist_from_rows, model_twist
from terrain_odom.kinematics import get_model
from terrain_odom.records import GroundTruth, WheelLog
from terrain_odom.reporting.groundtruth import (
    FrameScores,
    GroundTruthSection,
    GroundTruthSettings,
)

__all__ = ["VARIANTS", "Variant", "GroundTruthReport", "run_variants", "groundtruth_section"]


@dataclass(frozen=True)
class Variant:
    """A filter variant: its name and terrain settings."""

    name: str
    adapt: bool
    memory: bool


VARIANTS = (
    Variant("ekf (no terrain)", adapt=False, memory=False),
    Variant("ekf (terrain)", adapt=True, memory=False),
    Variant("ekf (terrain + memory)", adapt=True, memory=True),
)
"""The filter variants of the report, in Chen's order plus terrain memory."""


def run_variants(
    log: WheelLog,
    config: Config,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    records: list[FrameRecord] | None = None,
    priors: IcrPriors | None = None,
) -> dict[str, OdometryResult]:
    """Run the filter variants on the same log and terrain labels.

    Parameters
    ----------
    log : WheelLog
    config : Config
        Everything but ``terrain.adapt`` and ``terrain.memory`` is kept.
    labels : sequence of str, optional
        Terrain label per log row.
    records : list of FrameRecord, optional
        Frames of a camera run, replayed (their labels and distances ahead).
    priors : IcrPriors, optional
        The run's offline priors, used by every variant (per-terrain priors
        only by those with terrain labels).

    Returns
    -------
    dict of str to OdometryResult
        Keyed by variant name; without labels or frames only the variant
        without terrain.
    """
    out = {}
    frames = ReplayedFrames(records) if records is not None else None
    for variant in VARIANTS:
        if variant.adapt and labels is None and records is None:
            continue
        terrain = dataclasses.replace(config.terrain, adapt=variant.adapt, memory=variant.memory)
        out[variant.name] = run_icr_ekf(
            log,
            dataclasses.replace(config, terrain=terrain),
            labels=labels if variant.adapt else None,
            frames=frames if variant.adapt else None,
            priors=priors,
        )
    return out


def _icr_model(result: OdometryResult) -> Any:
    names = list(result.names)
    y_l, y_r, x_icr = _icr_columns(result).T
    alpha = result.states[:, names.index("alpha")] if "alpha" in names else 1.0
    return lambda windows: icr_twist_from_rows(windows, y_l, y_r, x_icr, alpha)


def _frames_section(
    truth: GroundTruth, records: list[FrameRecord]
) -> tuple[FrameScores, np.ndarray]:
    t = np.array([r.t for r in records], dtype=float)
    true_labels = frame_truth(truth, t, [r.ahead for r in records])
    return FrameScores(
        accuracy=frame_accuracy(true_labels, [r.label for r in records]),
        feature_time=feature_times(
            true_labels, [r.ms_features for r in records], [r.ms_features_full for r in records]
        ),
        classification_time=feature_times(
            true_labels,
            [r.ms_features + r.ms_knn for r in records],
            [r.ms_features_full + r.ms_knn_full for r in records],
        ),
    ), true_labels


@dataclass(frozen=True)
class GroundTruthReport:
    """A run scored against ground truth.

    Attributes
    ----------
    section : GroundTruthSection
        The ``groundtruth`` section of ``report.json``.
    results : dict of str to OdometryResult
        The filter variants' runs.
    frame_truth : ndarray of str, shape (F,), or None
        True terrain of each recorded frame.
    """

    section: GroundTruthSection
    results: dict[str, OdometryResult]
    frame_truth: np.ndarray | None


def groundtruth_section(
    log: WheelLog,
    config: Config,
    truth: GroundTruth,
    *,
    labels: Sequence[str] | np.ndarray | None = None,
    records: list[FrameRecord] | None = None,
    use_roi: bool = True,
    priors: IcrPriors | None = None,
) -> GroundTruthReport:
    """Score a run against ground truth.

    Parameters
    ----------
    log : WheelLog
        The run's wheel log.
    config : Config
        The run's configuration.
    truth : GroundTruth
        True pose, ICRs and terrain covering the log.
    labels, records : optional
        The run's terrain labels per row, or its frame records.
    use_roi : bool
        Whether the frames were classified on the region of interest.
    priors : IcrPriors, optional
        The run's offline priors (``run --priors``).

    Returns
    -------
    GroundTruthReport
        Its section: the settings, the true changes, the odometry error per
        model, the re-convergence and resets per variant, and with records
        the frames' accuracy and times per true terrain.
    """
    true_log = groundtruth_log(log, truth)
    true_terrain = truth.terrain[np.clip(np.searchsorted(truth.t, log.t - 1e-9), 0, len(truth) - 1)]
    results = run_variants(log, config, labels=labels, records=records, priors=priors)
    b = config.robot.track_width
    idd = get_model("idd")
    models: dict[str, Any] = {f"idd (B={b:g} m)": lambda _w: model_twist(idd, [], b)}
    models.update((name, _icr_model(result)) for name, result in results.items())
    horizon = config.evaluation.horizon
    tolerance = config.evaluation.icr_tolerance * b
    changes = [c for c in truth.changes() if log.t[0] < c[0] <= log.t[-1]]
    frames, frame_labels = None, None
    if records is not None:
        frames, frame_labels = _frames_section(truth, records)
    section = GroundTruthSection(
        settings=GroundTruthSettings(
            horizon_m=horizon,
            icr_tolerance_m=tolerance,
            reset_at=config.terrain.reset_at,
            classification=None if records is None else ("roi" if use_roi else "whole frame"),
        ),
        true_changes=tuple(changes),
        odometry=model_odometry_error(true_log, true_terrain, models, horizon),
        reconvergence={
            name: reconvergence(
                truth,
                log.t,
                _icr_columns(result),
                tolerance,
                changes=changes,
                resets=[(c.t, c.label) for c in result.changes],
            )
            for name, result in results.items()
        },
        resets={name: list(result.changes) for name, result in results.items()},
        frames=frames,
    )
    return GroundTruthReport(section, results, frame_labels)


def _icr_columns(result: OdometryResult) -> np.ndarray:
    names = list(result.names)
    return result.states[:, [names.index(n) for n in ("y_l", "y_r", "x_icr")]]
