"""What the command line runs: file in, computation, files out.

Each function here is a plain Python API (usable from a notebook) that reads
its inputs, calls the pure core (``kinematics``, ``estimation``,
``evaluation``) and writes its outputs incrementally or atomically.
"""

from __future__ import annotations

import contextlib
import dataclasses
import enum
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from tqdm import tqdm

from terrain_odom.app.calibration import SensorCalibration, calibrate_inputs, check_plausible
from terrain_odom.app.frames import FRAME_COLUMNS, FramePipeline, FrameRecord, one_thread
from terrain_odom.app.groundtruth import GroundTruthReport, groundtruth_section
from terrain_odom.app.outage_guard import GuardResult, OutageGuard
from terrain_odom.app.plots import write_run_plots
from terrain_odom.app.record import require_rerun
from terrain_odom.app.run_folder import (
    COMPLETE,
    FRAMES_CSV,
    REPORT_JSON,
    REPORT_MD,
    RUN_CONFIG,
    RUN_FILES,
    TRAJECTORY_CSV,
    TRAJECTORY_TUM,
    holds_run_folder,
    mark_interrupted,
    mark_running,
    prepare_folder,
)
from terrain_odom.config import Config, TimeConfig, config_to_dict, dump_config, load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.icr_ekf import IcrPriors
from terrain_odom.estimation.odometry import OdometryBlock, OdometryResult, run_odometry
from terrain_odom.estimation.online import ESTIMATORS, Estimator, OnlineOdometry
from terrain_odom.estimation.pose_measurement import PoseUse
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation.mounting import x_icr_limit
from terrain_odom.io import TrajectoryWriter, read_wheel_log
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.groundtruth import read_groundtruth
from terrain_odom.io.params import read_priors
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import path_or_none, report_header, to_jsonable, write_json
from terrain_odom.io.trajectory import TrajectoryBlocks, TumWriter, trajectory_columns
from terrain_odom.records import GroundTruth, WheelLog
from terrain_odom.reporting import run_markdown

if TYPE_CHECKING:  # the classifier and frame readers (scikit-learn, OpenCV) load with --images
    from terrain_odom.io.frames import FrameList
    from terrain_odom.vision.classifier import TerrainClassifier

__all__ = [
    "TerrainSource",
    "FrameCounts",
    "RunSummary",
    "run",
    "images_config",
    "read_calibrated_log",
    "calibrate_log",
    "calibrate_inputs",
    "run_config",
    "check_plausible",
]


def images_config(images: str | Path) -> Path | None:
    """Return ``images/config.yaml`` if that file exists (a simulated run's camera and robot)."""
    path = Path(images) / "config.yaml"
    return path if path.is_file() else None


class TerrainSource(enum.Enum):
    """Where terrain labels for the adaptive reset come from."""

    AUTO = "auto"  # the log's terrain column if it has one
    LOG = "log"  # the log's terrain column, required
    NONE = "none"  # no terrain information: plain ICR EKF


@dataclass(frozen=True)
class RunSummary:
    """Paths and figures of a finished run (what ``terrain-odom run`` prints).

    Attributes
    ----------
    trajectory_csv, trajectory_tum, report_json : Path
        Files written.
    rows : int
        Log rows processed.
    seconds : float
        Wall time of the run, s.
    report_md : Path or None
        ``report.md``.
    time_calibration : TimeCalibration or None
        The pose delay applied to the log.
    frames_csv : Path or None
        ``frames.csv``, when frames were classified.
    plots : tuple of Path
        PNG plots written (``out/plots``: trajectory and states of every run,
        the frames' mosaic with ``images``, frame labels with ground truth).
    updates : int
        Pose measurements fused.
    terrain_changes : int
        Confirmed terrain changes applied.
    config_yaml : Path or None
        ``config.yaml``: the configuration the run used, its pose delay
        resolved (what ``evaluate --run`` reads).
    frames : FrameCounts or None
        What became of the camera frames (with ``images``).
    unused_priors : tuple of str
        Terrains of a per-terrain prior file that the run can never meet (not
        in the log's labels, or not a class of the terrain classifier).
    pose_use : PoseUse or None
        Measured pose components used and dropped (by reason).
    calibration : SensorCalibration or None
        The ``auto`` values found before the run (heading offset, antenna,
        delays, noise), each with its standard error.
    warnings : tuple of str
        What the finished run's estimate makes doubtful (one line each).
    recording : Path or None
        ``run.rrd``, the Rerun recording (``record``).
    outage_guard : GuardResult or None
        The learned model against the nominal one through pose outages
        (:mod:`~terrain_odom.app.outage_guard`).
    """

    trajectory_csv: Path
    trajectory_tum: Path
    report_json: Path
    rows: int
    seconds: float
    report_md: Path | None = None
    time_calibration: TimeCalibration | None = None
    frames_csv: Path | None = None
    plots: tuple[Path, ...] = ()
    updates: int = 0
    terrain_changes: int = 0
    config_yaml: Path | None = None
    frames: FrameCounts | None = None
    unused_priors: tuple[str, ...] = ()
    pose_use: PoseUse | None = None
    calibration: SensorCalibration | None = None
    warnings: tuple[str, ...] = ()
    outage_guard: GuardResult | None = None
    recording: Path | None = None


def _write_run_config(
    out: Path, cfg: Config, timing: TimeCalibration, calibration: SensorCalibration | None
) -> Path:
    """Write the configuration used into the run's folder, its delays and ``auto`` values resolved.

    Each value the run calibrated has a comment saying how it was found.
    """
    position, heading = timing.pose_delay, timing.heading_delay_applied
    time_cfg = (
        TimeConfig(pose_delay=position)
        if heading == position
        else TimeConfig(pose_delay=position, position_delay=position, heading_delay=heading)
    )
    resolved = dataclasses.replace(cfg, time=time_cfg)
    path = out / RUN_CONFIG
    header = "# The configuration this run used (terrain-odom run); evaluate --run reads it.\n"
    comments = calibration.comments() if calibration is not None else None
    write_text_atomic(path, header + dump_config(resolved, comments))
    return path


def run_config(run_dir: str | Path) -> Path | None:
    """Return a run folder's ``config.yaml``, or None for a run written without one."""
    path = Path(run_dir) / RUN_CONFIG
    return path if path.is_file() else None


def read_calibrated_log(wheels: str | Path, cfg: Config) -> tuple[WheelLog, TimeCalibration]:
    """Read a wheel log and apply its pose delays (:func:`calibrate_log`).

    Raises
    ------
    InputFileError
        If the file is missing or malformed, its wheels and poses disagree
        (:func:`check_plausible`), or an ``auto`` value cannot be estimated.
    """
    return calibrate_log(read_wheel_log(wheels, wheel_radius=cfg.robot.wheel_radius), cfg)


def calibrate_log(log: WheelLog, cfg: Config) -> tuple[WheelLog, TimeCalibration]:
    """Calibrate a log read with ``cfg`` and apply its delays (:func:`calibrate_inputs`).

    Raises
    ------
    InputFileError
        Its wheels and poses disagree, or an ``auto`` value cannot be estimated.
    """
    log, _, _, timing = calibrate_inputs(log, cfg)
    return log, timing


def _labels(log: WheelLog, source: TerrainSource) -> np.ndarray | None:
    """Return the log's terrain column when ``source`` asks for it (the log's array, no copy)."""
    if source is TerrainSource.NONE:
        return None
    if log.terrain is None:
        if source is TerrainSource.LOG:
            raise InputFileError(
                f"{log.source}: --terrain-from-log needs a 'terrain' column, the log has none"
            )
        return None
    return log.terrain


@dataclass(frozen=True)
class _Inputs:
    """Everything a run reads before its loop."""

    cfg: Config
    config_path: str | Path | None
    log: WheelLog
    timing: TimeCalibration
    gt: GroundTruth | None
    labels: np.ndarray | None
    priors: IcrPriors | None
    frames: FrameList | None
    classifier: TerrainClassifier | None
    model: str | Path | None
    calibration: SensorCalibration | None = None


def _read_inputs(
    wheels: str | Path,
    config: Config | None,
    config_path: str | Path | None,
    terrain: TerrainSource,
    images: str | Path | None,
    model: str | Path | None,
    groundtruth: str | Path | None,
    estimator: str,
    priors: str | Path | None,
) -> _Inputs:
    """Check the options and read the inputs of :func:`run` (its parameters)."""
    if estimator not in ESTIMATORS:
        raise ConfigError(f"unknown estimator {estimator!r}; choose one of {list(ESTIMATORS)}")
    slip = estimator == "slip-ekf"
    if slip and priors is not None:
        raise ConfigError(
            "--priors seeds the ICR EKF (--estimator icr-ekf); the slip EKF's parameters "
            "l1 .. l6 are not ICRs"
        )
    if config is None and config_path is None and images is not None:
        config_path = images_config(images)
    cfg = config if config is not None else load_config(config_path)
    icr_priors = None if priors is None else read_priors(priors, cfg.robot)
    log = read_wheel_log(wheels, wheel_radius=cfg.robot.wheel_radius)
    log, cfg, calibration, timing = calibrate_inputs(log, cfg)
    gt = _read_groundtruth(groundtruth, log) if groundtruth is not None else None
    use_frames = images is not None and terrain is not TerrainSource.NONE
    labels = None if use_frames else _labels(log, terrain)
    if icr_priors is not None and icr_priors.terrains and labels is None and not use_frames:
        raise ConfigError(
            f"{priors}: per-terrain priors ({', '.join(sorted(icr_priors.terrains))}) need "
            f"terrain labels, but this run has none (--no-terrain, or no terrain column in "
            f"{log.source}); fit without --by-terrain for one prior"
        )
    frame_list = classifier = None
    if use_frames and images is not None:
        from terrain_odom.io.classifier_file import default_model, load_classifier
        from terrain_odom.io.frames import read_frames

        if model is None:
            model = default_model()
        frame_list = read_frames(images)
        _check_frame_times(frame_list, log, images)
        classifier = load_classifier(model)
    return _Inputs(
        cfg,
        config_path,
        log,
        timing,
        gt,
        labels,
        icr_priors,
        frame_list,
        classifier,
        model,
        calibration,
    )


def _check_frame_times(frames: FrameList, log: WheelLog, images: str | Path) -> None:
    """Refuse frames none of which lies within the wheel log's time span.

    Raises
    ------
    InputFileError
        Naming both spans and the likely causes (a clock offset, milliseconds).
    """
    t = frames.t
    if t.size and not np.any((t >= log.t[0]) & (t <= log.t[-1])):
        raise InputFileError(
            f"{images}: none of the {t.size} frames (t = {t.min():g}-{t.max():g} s) lies in the "
            f"wheel log's span ({log.t[0]:g}-{log.t[-1]:g} s): a clock offset between camera and "
            "wheels, or frame times in milliseconds?"
        )


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


@holds_run_folder  # out_dir is locked until the run returns
def run(
    wheels: str | Path,
    out_dir: str | Path,
    *,
    config: Config | None = None,
    config_path: str | Path | None = None,
    terrain: TerrainSource = TerrainSource.AUTO,
    progress: bool | None = None,
    images: str | Path | None = None,
    model: str | Path | None = None,
    use_roi: bool = True,
    groundtruth: str | Path | None = None,
    estimator: Estimator = "icr-ekf",
    priors: str | Path | None = None,
    overwrite: bool = False,
    record: bool = False,
    plots: bool = True,
) -> RunSummary:
    """Run the terrain-adaptive ICR EKF (or slip EKF) over a wheel log; write the results.

    The log is streamed row by row through
    :class:`~terrain_odom.estimation.online.OnlineOdometry`
    (:func:`~terrain_odom.estimation.odometry.run_odometry`). Each option is
    the ``terrain-odom run`` option of that name (docs/cli.md).

    Parameters
    ----------
    wheels : str or Path
        Wheel log (docs/formats.md), its wheel speeds delayed by
        ``config.time.pose_delay`` (:func:`read_calibrated_log`).
    out_dir : str or Path
        Output folder, one run per folder (:mod:`~terrain_odom.app.run_folder`:
        ``report.json`` says ``running``, ``complete`` or ``interrupted``);
        ``InputFileError`` if a file to write is an input
        (:func:`~terrain_odom.io.paths.check_outputs`) or the folder holds a
        run and ``overwrite`` is false.
    config, config_path : optional
        Configuration, or its YAML file; without either, ``images/config.yaml``
        if it exists, else the built-in defaults.
    terrain : TerrainSource
        Source of the labels driving the covariance reset.
    progress : bool, optional
        Show a progress bar (``None``: only on a terminal).
    images : str or Path, optional
        Folder of camera frames (:mod:`terrain_odom.io.frames`): their
        classified terrain drives the reset; ``frames.csv`` is written.
        Not read when ``terrain`` is ``NONE``.
    model : str or Path, optional
        Classifier model file (default: the packaged model).
    use_roi : bool
        Classify the region of interest (default), or whole frames.
    groundtruth : str or Path, optional
        Ground truth (a simulated run's ``groundtruth.csv``): the run and its
        filter variants scored in ``report.json``, ``report.md`` and the plots.
    estimator : {"icr-ekf", "slip-ekf"}
        The ICR EKF, or the slip-parameter EKF
        (:mod:`terrain_odom.estimation.slip_ekf`: dead reckoning reset to
        every measured pose component, the ICRs at the row's track speeds,
        then ``l1 .. l6(, alpha)``).
    priors : str or Path, optional
        Parameter file of ``fit --model icr|icr-slip`` (:func:`read_priors`),
        per terrain with ``--by-terrain`` (ICR EKF only).
    overwrite, record, plots : bool
        Replace a run already in ``out_dir`` (its files removed first); also
        write ``run.rrd`` (:func:`~terrain_odom.app.record.write_recording`;
        ``ConfigError`` at once without ``rerun-sdk``); draw the plots.

    Returns
    -------
    RunSummary
    """
    started = time.perf_counter()
    if record:
        require_rerun()
    inputs = _read_inputs(
        wheels, config, config_path, terrain, images, model, groundtruth, estimator, priors
    )
    _check_run_outputs(out_dir, inputs, [wheels, groundtruth, priors], images)
    out = prepare_folder(out_dir, overwrite=overwrite)
    config_yaml, read = _start(out, inputs, wheels, priors)
    odometry = OnlineOdometry(
        inputs.cfg,
        inputs.classifier,
        estimator=estimator,
        priors=inputs.priors,
        use_roi=use_roi,
        time_full_frame=inputs.gt is not None,
    )
    root = None if images is None else Path(images)
    keep = 1 if record else _keep(inputs)
    guard = OutageGuard(inputs.log, inputs.cfg, odometry.names, estimator)
    streamed = _stream(inputs, odometry, out, root, progress, read, keep, guard.add)
    result, pipeline, records, x_icr = streamed
    if pipeline is not None and root is not None:
        pipeline.check_used(root)  # a camera run without one classified frame: an error
    guarded = guard.result()
    log, tum_path = inputs.log, out / TRAJECTORY_TUM
    seconds = time.perf_counter() - started
    report = _report(inputs, result, wheels, estimator, terrain, priors, seconds)
    report["counts"]["pose_components"] = asdict(odometry.pose_use)
    report["warnings"] = _lever_arm_warning(x_icr, inputs.cfg) + guarded.warnings()
    report["outage_guard"] = guarded.section()
    scored = _add_sections(report, inputs, result, (pipeline, records, root), groundtruth, use_roi)
    drawn, recording = _pictures(out, inputs, result, scored, records, root, plots, record)
    if recording is not None:
        report["outputs"]["recording"] = recording.name
    report_path, md_path = _write_reports(out, report, drawn)
    return RunSummary(
        out / TRAJECTORY_CSV, tum_path, report_path, len(log), seconds, md_path, inputs.timing,
        frames_csv=None if pipeline is None else out / FRAMES_CSV,
        plots=tuple(out / name for name in drawn),
        config_yaml=config_yaml,
        frames=_frame_counts(result, pipeline),
        unused_priors=_unused_priors(inputs),
        updates=result.n_updates,
        terrain_changes=len(result.changes),
        pose_use=odometry.pose_use,
        calibration=inputs.calibration,
        warnings=tuple(report["warnings"]),
        recording=recording,
        outage_guard=guarded,
    )  # fmt: skip


def _add_sections(
    report: dict[str, Any],
    inputs: _Inputs,
    result: OdometryResult,
    camera: tuple[FramePipeline | None, list[FrameRecord], Path | None],
    groundtruth: str | Path | None,
    use_roi: bool,
) -> GroundTruthReport | None:
    """Add the calibration, frames and ground-truth sections to ``report``.

    ``camera`` is the frame pipeline, its records and the frames' folder.
    Returns the run scored against its ground truth, if one was given.
    """
    pipeline, records, root = camera
    if inputs.calibration is not None and inputs.calibration.found:
        report["calibration"] = inputs.calibration.to_dict()
    if root is not None:
        _add_frames_report(report, root, inputs, result, pipeline, use_roi)
    if inputs.gt is None or groundtruth is None:
        return None
    frames = records if pipeline is not None else None
    scored = _score(inputs, inputs.gt, report, frames, use_roi)
    report["inputs"]["groundtruth"] = str(Path(groundtruth).resolve())
    return scored


def _pictures(
    out: Path,
    inputs: _Inputs,
    result: OdometryResult,
    scored: GroundTruthReport | None,
    records: list[FrameRecord],
    root: Path | None,
    plots: bool,
    record: bool,
) -> tuple[list[str], Path | None]:
    """Draw the run's plots (if ``plots``) and write ``run.rrd`` (if ``record``).

    Returns the plots' paths relative to ``out`` and the recording's path (or None).
    """
    log = inputs.log if result.rows is None else inputs.log.take(result.rows)
    drawn = write_run_plots(
        out, log, result, inputs.cfg, truth=inputs.gt, scored=scored, records=records,
        images=root, classifier=inputs.classifier,
    ) if plots else []  # fmt: skip
    if not record:
        return drawn, None
    from terrain_odom.app.record import write_recording  # OpenCV, rerun: with record only

    recording = write_recording(
        out, inputs.log, result, inputs.cfg, records=records, images=root,
        classifier=inputs.classifier,
    )  # fmt: skip
    return drawn, recording


def _start(
    out: Path, inputs: _Inputs, wheels: str | Path, priors: str | Path | None
) -> tuple[Path, dict[str, str | None]]:
    """Write ``config.yaml`` and a ``report.json`` saying the run has started.

    Returns the configuration's path and the ``inputs`` section of the report.
    """
    config_yaml = _write_run_config(out, inputs.cfg, inputs.timing, inputs.calibration)
    read = _report_inputs(inputs, wheels, priors)
    mark_running(out, read)
    return config_yaml, read


def _write_reports(out: Path, report: dict[str, Any], plots: list[str]) -> tuple[Path, Path]:
    """Write ``report.json`` and ``report.md`` atomically; return their paths."""
    report_path, md_path = out / REPORT_JSON, out / REPORT_MD
    write_json(report_path, report)
    write_text_atomic(md_path, run_markdown(to_jsonable(report), plots))
    return report_path, md_path


def _check_run_outputs(
    out_dir: str | Path,
    inputs: _Inputs,
    files: list[str | Path | None],
    images: str | Path | None,
) -> None:
    """Refuse an output folder where :func:`run` would overwrite an input.

    The inputs are ``files``, the configuration and model files of ``inputs``
    and, with ``images``, its ``frames.csv`` and every frame listed.
    """
    read = [*files, inputs.config_path, inputs.model]
    if images is not None:
        read += [Path(images) / FRAMES_CSV, *(inputs.frames.files if inputs.frames else [])]
    check_outputs(read, [Path(out_dir) / name for name in RUN_FILES])


def _score(
    inputs: _Inputs,
    gt: GroundTruth,
    report: dict[str, Any],
    records: list[FrameRecord] | None,
    use_roi: bool,
) -> GroundTruthReport:
    """Score the run against ground truth into ``report``; return the scores."""
    scored = groundtruth_section(
        inputs.log,
        inputs.cfg,
        gt,
        labels=inputs.labels,
        records=records,
        use_roi=use_roi,
        priors=inputs.priors,
    )
    report["groundtruth"] = scored.section
    return scored


def _stream(
    inputs: _Inputs,
    odometry: OnlineOdometry,
    out: Path,
    images: Path | None,
    progress: bool | None,
    read: dict[str, str | None],
    keep: int,
    also: Callable[[OdometryBlock], None] = lambda block: None,
) -> tuple[OdometryResult, FramePipeline | None, list[FrameRecord], float]:
    """Stream the log through ``odometry``, writing ``trajectory.csv`` (and ``frames.csv``).

    ``also`` sees every block of rows too (the outage guard keeps states from it).

    The result keeps every ``keep``-th row (:func:`run_odometry`). Returns
    it, the frames' pipeline and records, and the mean ``x_icr`` over the
    second half of the rows (all of them). If anything stops the stream,
    ``report.json`` says the run was interrupted, with the rows written and
    the files ``read``.
    """
    log = inputs.log
    names = odometry.names
    records: list[FrameRecord] = []
    bar = tqdm(total=len(log), unit="row", disable=None if progress is None else not progress)
    with contextlib.ExitStack() as stack:
        writer = stack.enter_context(
            TrajectoryWriter(out / TRAJECTORY_CSV, trajectory_columns(names))
        )
        tum = stack.enter_context(TumWriter(out / TRAJECTORY_TUM))  # in place when complete
        stack.enter_context(bar)
        pipeline = None
        if inputs.frames is not None and images is not None:
            stack.enter_context(one_thread())  # camera-rate work on one core (see one_thread)
            frame_writer = stack.enter_context(TrajectoryWriter(out / FRAMES_CSV, FRAME_COLUMNS))

            def on_frame(record: FrameRecord) -> None:
                frame_writer.write(record.row())
                records.append(record)

            root = images
            pipeline = FramePipeline(
                inputs.frames,
                on_frame=on_frame,
                names=lambda path: _relative(path, root),
            )

        blocks = TrajectoryBlocks(writer, names, tum)
        x_icr = _SecondHalf(len(log), names.index("x_icr"))

        def on_block(block: OdometryBlock) -> None:
            blocks.write(block.t, block.states, block.stds, block.terrain)
            x_icr.add(block)
            also(block)
            bar.update(block.t.size)

        try:
            result = run_odometry(
                log, odometry, labels=inputs.labels, on_block=on_block, frames=pipeline, keep=keep
            )
        except BaseException as exc:
            tum.discard()  # no TUM file of an incomplete run
            with contextlib.suppress(OSError):  # a full disk: the rows are cut to whole ones
                stack.close()  # flush the rows streamed so far before saying how many
            mark_interrupted(out, read, writer.rows_written, exc)
            raise
    return result, pipeline, records, x_icr.mean


KEPT_ROWS = 20_000
"""A run keeps the estimates of at most about twice this many rows in memory (for its plots)."""


def _keep(inputs: _Inputs) -> int:
    """Keep every how many rows' estimates: all with frames or ground truth, else ~:data:`KEPT_ROWS`.

    ``trajectory.csv`` and ``trajectory.tum`` get every row as it is done;
    the plots draw at most a few thousand points; a camera run's mosaic and
    a run scored against ground truth look rows up by time.
    """
    if inputs.frames is not None or inputs.gt is not None:
        return 1
    return max(1, len(inputs.log) // KEPT_ROWS)


@dataclass
class _SecondHalf:
    """Mean of one state over the second half of a run's rows, from its blocks."""

    n_rows: int
    column: int
    total: float = 0.0
    count: int = 0

    def add(self, block: OdometryBlock) -> None:
        first = max(self.n_rows // 2 - block.start, 0)
        values = block.states[first:, self.column]
        self.total += float(values.sum())
        self.count += values.size

    @property
    def mean(self) -> float:
        """The mean (0 before any row)."""
        return self.total / self.count if self.count else 0.0


def _report(
    inputs: _Inputs,
    result: OdometryResult,
    wheels: str | Path,
    estimator: str,
    terrain: TerrainSource,
    priors: str | Path | None,
    seconds: float,
) -> dict[str, Any]:
    """Return ``report.json`` of a run (``seconds`` long), without its frames and ground truth."""
    log, names = inputs.log, result.names
    if inputs.frames is not None:
        source = "camera"
    else:
        source = terrain.value if inputs.labels is not None else "none"
    return {
        **report_header("run"),
        "status": COMPLETE,
        "estimator": estimator,
        "inputs": _report_inputs(inputs, wheels, priors),
        "terrain_source": source,
        "config": config_to_dict(inputs.cfg),
        "time_calibration": inputs.timing.to_dict(),
        "counts": {
            "rows": len(log),
            "pose_measurements": int(np.count_nonzero(np.isfinite(log.pose).any(axis=1))),
            "updates": result.n_updates,
            "segments": log.n_runs,
            "terrain_changes": len(result.changes),
        },
        "terrain_changes": [asdict(c) for c in result.changes],
        "final_state": dict(zip(names, result.states[-1].tolist(), strict=True)),
        "final_std": dict(zip(names, result.stds[-1].tolist(), strict=True)),
        "outputs": {"trajectory_csv": TRAJECTORY_CSV, "trajectory_tum": TRAJECTORY_TUM},
        "run_time_s": seconds,
    }


def _report_inputs(
    inputs: _Inputs, wheels: str | Path, priors: str | Path | None
) -> dict[str, str | None]:
    """Return the ``inputs`` section of ``report.json``: the files a run read."""
    return {
        "wheels": path_or_none(wheels),
        "config": path_or_none(inputs.config_path),
        "priors": path_or_none(priors),
    }


def _lever_arm_warning(x_icr: float, cfg: Config) -> list[str]:
    """Warn when ``x_icr`` lies beyond :func:`~terrain_odom.evaluation.mounting.x_icr_limit`.

    The estimate judged is the mean over the second half of the run's rows;
    within 10 % of the filter's bound (``ekf.limits.x_icr_max``, which holds
    it) counts as beyond.

    A position antenna ``a`` m ahead of the reference point, left out of
    ``pose_sensor``, moves sideways in turns as ICRs ``a`` m further back do;
    without a heading the log cannot tell the two apart before the run.
    """
    bound = cfg.ekf.limits.resolve(cfg.robot).x_icr_max
    limit = min(x_icr_limit(cfg.robot.track_width), 0.9 * bound)
    if not abs(x_icr) > limit:
        return []
    sensor = cfg.pose_sensor
    return [
        f"the estimated x_icr, {x_icr:+.2f} m over the second half, lies beyond {limit:.2f} m "
        f"(its bound: {bound:.2f} m): a position antenna {abs(x_icr):.2f} m "
        f"{'ahead of' if x_icr < 0 else 'behind'} the reference point (pose_sensor.antenna_x is "
        f"{sensor.antenna_x:g} m), or a heading error or latency read as side slip?"
    ]


def _read_groundtruth(path: str | Path, log: WheelLog) -> GroundTruth:
    """Read ground truth and check it covers the log's time span."""
    gt = read_groundtruth(path)
    if not gt.covers(log.t):
        raise InputFileError(
            f"{gt.source}: covers {gt.t[0]:g}-{gt.t[-1]:g} s but the wheel log {log.source} "
            f"spans {log.t[0]:g}-{log.t[-1]:g} s (is it the ground truth of this run?)"
        )
    return gt


def _add_frames_report(
    report: dict[str, Any],
    images: Path,
    inputs: _Inputs,
    result: OdometryResult,
    pipeline: FramePipeline | None,
    use_roi: bool,
) -> None:
    """Add the frames of a run with ``--images`` to its ``report``."""
    report["inputs"]["images"] = str(images.resolve())
    report["inputs"]["model"] = path_or_none(inputs.model)
    report["frames"] = _frames_report(result, pipeline, use_roi)
    if pipeline is not None:
        report["frame_problems"] = pipeline.problems
        report["outputs"]["frames_csv"] = FRAMES_CSV


def _relative(path: Path, root: Path) -> str:
    try:
        return path.relative_to(root).as_posix()
    except ValueError:
        return str(path)


def _unused_priors(inputs: _Inputs) -> tuple[str, ...]:
    """Return the prior terrains no label of this run can name (log labels or classifier classes)."""
    if inputs.priors is None or not inputs.priors.terrains:
        return ()
    if inputs.labels is not None:
        known = set(inputs.labels)
    elif inputs.classifier is not None:
        known = set(inputs.classifier.classes)
    else:
        return ()
    return tuple(sorted(set(inputs.priors.terrains) - known))


def _frame_counts(result: OdometryResult, pipeline: FramePipeline | None) -> FrameCounts | None:
    """Return what became of the frames (the figures of the report's ``frames`` section)."""
    if pipeline is None:
        return None
    return FrameCounts(
        len(pipeline.frames),
        len(pipeline.ms_total),
        result.frames_before,
        result.frames_after,
        tuple(f"{p['file']} ({p['problem']})" for p in pipeline.problems),
    )


def _frames_report(
    result: OdometryResult, pipeline: FramePipeline | None, use_roi: bool
) -> dict[str, Any]:
    """Return the ``frames`` section of a run's report.json."""
    counts = _frame_counts(result, pipeline)
    if pipeline is None or counts is None:
        return {"classification": "skipped (--no-terrain: frames not read)"}
    ms = np.asarray(pipeline.ms_total)
    unusable = sum(
        n for status, n in pipeline.roi_counts.items() if status in ("outside", "too_small")
    )
    return {
        "classification": "region of interest" if use_roi else "whole frame (--no-roi)",
        "total": counts.total,
        "classified": counts.classified,
        "skipped": {
            "before_first_wheel_sample": counts.before,
            "after_last_wheel_sample": counts.after,
            "missing_or_unreadable": len(counts.problems),
            "roi_outside_or_too_small": unusable,
        },
        "roi_status": dict(sorted(pipeline.roi_counts.items())),
        "ms_per_frame": {
            "mean": float(ms.mean()) if ms.size else None,
            "max": float(ms.max()) if ms.size else None,
        },
    }
