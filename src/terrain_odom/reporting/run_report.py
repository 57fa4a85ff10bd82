"""A run's report as a typed record: what ``report.json`` holds, and ``report.md`` shows.

:class:`RunReport` is built by :func:`terrain_odom.app.run.run`;
:meth:`RunReport.to_dict` is the content of ``report.json`` (docs/formats.md)
and :func:`~terrain_odom.reporting.markdown.run_markdown` renders it from
its attributes, the ground-truth and outage-guard sections included
(:class:`~terrain_odom.reporting.groundtruth.GroundTruthSection`,
:class:`~terrain_odom.reporting.outage.OutageSection`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from terrain_odom.config import Config, config_to_dict
from terrain_odom.estimation.pose_measurement import PoseUse
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.records import TerrainChange
from terrain_odom.reporting.groundtruth import GroundTruthSection
from terrain_odom.reporting.outage import OutageSection

__all__ = ["RunInputs", "RunCounts", "RunOutputs", "FrameCounts", "FramesReport", "RunReport"]


@dataclass(frozen=True)
class RunInputs:
    """The files a run read (absolute paths; None: not given): ``inputs`` of ``report.json``.

    ``images`` and ``classifier`` (written ``model``) are reported for a run
    with ``--images``, ``groundtruth`` for one with ``--groundtruth``.
    """

    wheels: str | None
    config: str | None
    priors: str | None
    images: str | None = None
    classifier: str | None = None
    groundtruth: str | None = None
    with_images: bool = False

    def to_dict(self) -> dict[str, str | None]:
        """Return the ``inputs`` section."""
        out = {"wheels": self.wheels, "config": self.config, "priors": self.priors}
        if self.with_images:
            out.update(images=self.images, model=self.classifier)
        if self.groundtruth is not None:
            out["groundtruth"] = self.groundtruth
        return out


@dataclass(frozen=True)
class RunCounts:
    """What a run counted: ``counts`` of ``report.json``.

    Attributes
    ----------
    rows, pose_measurements, updates, segments, terrain_changes : int
        Log rows, rows with a pose measurement, measurements fused, the
        log's segments, confirmed terrain changes applied.
    pose_components : PoseUse
        Pose components measured, used and dropped (by reason).
    """

    rows: int
    pose_measurements: int
    updates: int
    segments: int
    terrain_changes: int
    pose_components: PoseUse

    def to_dict(self) -> dict[str, Any]:
        """Return the ``counts`` section."""
        return {
            "rows": self.rows,
            "pose_measurements": self.pose_measurements,
            "updates": self.updates,
            "segments": self.segments,
            "terrain_changes": self.terrain_changes,
            "pose_components": asdict(self.pose_components),
        }


@dataclass(frozen=True)
class RunOutputs:
    """The files of a run's folder, by their names in it: ``outputs`` of ``report.json``."""

    trajectory_csv: str
    trajectory_tum: str
    frames_csv: str | None = None
    recording: str | None = None

    def to_dict(self) -> dict[str, str]:
        """Return the ``outputs`` section (files not written left out)."""
        out = {"trajectory_csv": self.trajectory_csv, "trajectory_tum": self.trajectory_tum}
        if self.frames_csv is not None:
            out["frames_csv"] = self.frames_csv
        if self.recording is not None:
            out["recording"] = self.recording
        return out


@dataclass(frozen=True)
class FrameCounts:
    """What became of a run's camera frames.

    Attributes
    ----------
    total, classified : int
        Frames listed, and frames classified.
    before, after : int
        Frames skipped before the first or after the last wheel sample.
    problems : tuple of str
        Missing or unreadable frames, ``"file (problem)"``, skipped.
    """

    total: int
    classified: int
    before: int
    after: int
    problems: tuple[str, ...]


@dataclass(frozen=True)
class FramesReport:
    """The camera frames of a run with ``--images``: ``frames`` of ``report.json``.

    Attributes
    ----------
    classification : str
        What was classified: the region of interest, whole frames, or why
        nothing was (``--no-terrain``).
    counts : FrameCounts or None
        None: the frames were not read.
    unusable : int
        Frames whose region was outside the image or too small.
    roi_status : dict of str to int
        Frames per region status.
    ms_mean, ms_max : float or None
        Classification time per frame, ms (None: no frame classified).
    problems : list of dict
        Missing or unreadable frames (``file``, ``problem``):
        ``frame_problems`` of ``report.json``.
    """

    classification: str
    counts: FrameCounts | None = None
    unusable: int = 0
    roi_status: dict[str, int] = field(default_factory=dict)
    ms_mean: float | None = None
    ms_max: float | None = None
    problems: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Return the ``frames`` section."""
        counts = self.counts
        if counts is None:
            return {"classification": self.classification}
        return {
            "classification": self.classification,
            "total": counts.total,
            "classified": counts.classified,
            "skipped": {
                "before_first_wheel_sample": counts.before,
                "after_last_wheel_sample": counts.after,
                "missing_or_unreadable": len(counts.problems),
                "roi_outside_or_too_small": self.unusable,
            },
            "roi_status": dict(sorted(self.roi_status.items())),
            "ms_per_frame": {"mean": self.ms_mean, "max": self.ms_max},
        }


@dataclass(frozen=True)
class RunReport:
    """A finished run's report: :meth:`to_dict` is ``report.json``.

    Attributes
    ----------
    header : dict
        The fields every JSON report starts with (format and package versions, command).
    status : str
        ``complete``.
    estimator : str
        ``icr-ekf`` or ``slip-ekf``.
    inputs : RunInputs
    terrain_source : str
        ``camera``, ``auto``, ``log`` or ``none``.
    config : Config
        The configuration used, its delays resolved.
    time_calibration : TimeCalibration
        The pose delays applied.
    counts : RunCounts
    terrain_changes : tuple of TerrainChange
        The confirmed changes applied, in order.
    final_state, final_std : dict of str to float
        The filter's last state and standard deviations, by state name.
    outputs : RunOutputs
    run_time_s : float
        Wall time of the run, s.
    warnings : tuple of str
        What the finished run's estimate makes doubtful (one line each).
    outage_guard : OutageSection
        The learned model against the nominal one through pose outages.
    calibration : dict or None
        The ``auto`` values found before the run (its JSON section), if any.
    frames : FramesReport or None
        With ``--images``.
    groundtruth : GroundTruthSection or None
        The run scored against ground truth, with ``--groundtruth``.
    """

    header: dict[str, Any]
    status: str
    estimator: str
    inputs: RunInputs
    terrain_source: str
    config: Config
    time_calibration: TimeCalibration
    counts: RunCounts
    terrain_changes: tuple[TerrainChange, ...]
    final_state: dict[str, float]
    final_std: dict[str, float]
    outputs: RunOutputs
    run_time_s: float
    warnings: tuple[str, ...] = ()
    outage_guard: OutageSection = field(default_factory=OutageSection)
    calibration: dict[str, Any] | None = None
    frames: FramesReport | None = None
    groundtruth: GroundTruthSection | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return the content of ``report.json``."""
        out: dict[str, Any] = {
            **self.header,
            "status": self.status,
            "estimator": self.estimator,
            "inputs": self.inputs.to_dict(),
            "terrain_source": self.terrain_source,
            "config": config_to_dict(self.config),
            "time_calibration": self.time_calibration.to_dict(),
            "counts": self.counts.to_dict(),
            "terrain_changes": [asdict(c) for c in self.terrain_changes],
            "final_state": self.final_state,
            "final_std": self.final_std,
            "outputs": self.outputs.to_dict(),
            "run_time_s": self.run_time_s,
            "warnings": list(self.warnings),
            "outage_guard": self.outage_guard.to_dict(),
        }
        if self.calibration is not None:
            out["calibration"] = self.calibration
        if self.frames is not None:
            out["frames"] = self.frames.to_dict()
            if self.frames.counts is not None:
                out["frame_problems"] = self.frames.problems
        if self.groundtruth is not None:
            out["groundtruth"] = self.groundtruth.to_dict()
        return out
