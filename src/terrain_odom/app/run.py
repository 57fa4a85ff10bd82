"""What ``terrain-odom run`` runs: a wheel log through the EKF, files out.

:func:`run` reads its inputs (:mod:`~terrain_odom.app.inputs`), streams the
log through :class:`~terrain_odom.estimation.online.OnlineOdometry`, writing
the trajectory as it goes, and ends with the report
(:class:`~terrain_odom.reporting.run_report.RunReport`), the plots and the
run's configuration in one folder (:mod:`~terrain_odom.app.run_folder`).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from terrain_odom.app.calibration import SensorCalibration, calibrate_inputs
from terrain_odom.app.frames import FrameRecord
from terrain_odom.app.groundtruth import GroundTruthReport, groundtruth_section
from terrain_odom.app.inputs import (
    GIVEN,
    Chosen,
    ConfigEdits,
    TerrainSource,
    check_frame_times,
    choose_classifier,
    choose_config,
    read_groundtruth_of,
    terrain_labels,
)
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
    mark_running,
    prepare_folder,
)
from terrain_odom.app.run_stream import frames_report, stream_log
from terrain_odom.config import Config, TimeConfig, dump_config
from terrain_odom.errors import ConfigError
from terrain_odom.estimation.icr_ekf import IcrPriors
from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.estimation.online import ESTIMATORS, Estimator, OnlineOdometry
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation.mounting import x_icr_limit
from terrain_odom.io import read_wheel_log
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.params import read_priors
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import path_or_none, report_header, write_json
from terrain_odom.records import GroundTruth, WheelLog
from terrain_odom.reporting import run_markdown
from terrain_odom.reporting.run_report import (
    RunCounts,
    RunInputs,
    RunOutputs,
    RunReport,
)

if TYPE_CHECKING:  # the classifier and frame readers (scikit-learn, OpenCV) load with --images
    from terrain_odom.io.frames import FrameList
    from terrain_odom.vision.classifier import TerrainClassifier

__all__ = ["RunOptions", "RunSummary", "run"]


@dataclass(frozen=True)
class RunOptions:
    """How :func:`run` runs: each field the ``terrain-odom run`` option of that name (docs/cli.md).

    Attributes
    ----------
    config, config_path : optional
        Configuration, or its YAML file (``--config``); without either,
        ``imported_config``, else ``images/config.yaml`` if it exists, else
        the built-in defaults (:func:`~terrain_odom.app.inputs.choose_config`).
    imported_config : str or Path, optional
        The configuration written by the import of a bag (``--wheels BAG``).
    edits : ConfigEdits, optional
        The command line's changes to a configuration file's values
        (``--pose-delay``, ``--no-checks``, ``--reset-at``).
    terrain : TerrainSource
        Source of the labels driving the covariance reset.
    images : str or Path, optional
        Folder of camera frames (:mod:`terrain_odom.io.frames`): their
        classified terrain drives the reset; ``frames.csv`` is written.
        Not read when ``terrain`` is ``NONE``.
    classifier_path : str or Path, optional
        Terrain classifier file (``--classifier``; default: the packaged one).
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
        Parameter file of ``fit --model icr|icr-slip``
        (:func:`~terrain_odom.io.params.read_priors`), per terrain with
        ``--by-terrain`` (ICR EKF only).
    overwrite, record, plots : bool
        Replace a run already in the folder (its files removed first); also
        write ``run.rrd`` (:func:`~terrain_odom.app.record.write_recording`;
        ``ConfigError`` at once without ``rerun-sdk``); draw the plots.
    progress : bool, optional
        Show a progress bar (``None``: only on a terminal).
    """

    config: Config | None = None
    config_path: str | Path | None = None
    imported_config: str | Path | None = None
    edits: ConfigEdits | None = None
    terrain: TerrainSource = TerrainSource.AUTO
    images: str | Path | None = None
    classifier_path: str | Path | None = None
    use_roi: bool = True
    groundtruth: str | Path | None = None
    estimator: Estimator = "icr-ekf"
    priors: str | Path | None = None
    overwrite: bool = False
    record: bool = False
    plots: bool = True
    progress: bool | None = None


@dataclass(frozen=True)
class RunSummary:
    """A finished run: its folder and report, and what ``terrain-odom run`` prints beside them.

    The figures are the report's (:class:`~terrain_odom.reporting.run_report.RunReport`);
    the files are the folder's, named by the report.

    Attributes
    ----------
    out_dir : Path
        The run's folder.
    report : RunReport
        What ``report.json`` holds (:meth:`RunReport.to_dict`).
    config : Chosen
        The configuration file read, and how it was chosen.
    classifier : Chosen or None
        The terrain classifier file, and how it was chosen (with frames).
    plots : tuple of Path
        PNG plots written (``out_dir/plots``: trajectory and states of every
        run, the frames' mosaic with ``images``, frame labels with ground truth).
    unused_priors : tuple of str
        Terrains of a per-terrain prior file that the run can never meet (not
        in the log's labels, or not a class of the terrain classifier).
    calibration : SensorCalibration or None
        The ``auto`` values found before the run (heading offset, antenna,
        delays, noise), each with its standard error.
    outage_guard : GuardResult or None
        The learned model against the nominal one through pose outages
        (:mod:`~terrain_odom.app.outage_guard`).
    """

    out_dir: Path
    report: RunReport
    config: Chosen
    classifier: Chosen | None = None
    plots: tuple[Path, ...] = ()
    unused_priors: tuple[str, ...] = ()
    calibration: SensorCalibration | None = None
    outage_guard: GuardResult | None = None

    @property
    def trajectory_csv(self) -> Path:
        """``trajectory.csv``."""
        return self.out_dir / self.report.outputs.trajectory_csv

    @property
    def trajectory_tum(self) -> Path:
        """``trajectory.tum``."""
        return self.out_dir / self.report.outputs.trajectory_tum

    @property
    def report_json(self) -> Path:
        """``report.json``."""
        return self.out_dir / REPORT_JSON

    @property
    def report_md(self) -> Path:
        """``report.md``."""
        return self.out_dir / REPORT_MD

    @property
    def config_yaml(self) -> Path:
        """``config.yaml``: the configuration the run used, its delays resolved."""
        return self.out_dir / RUN_CONFIG

    @property
    def frames_csv(self) -> Path | None:
        """``frames.csv``, when frames were classified."""
        name = self.report.outputs.frames_csv
        return None if name is None else self.out_dir / name

    @property
    def recording(self) -> Path | None:
        """``run.rrd``, the Rerun recording (``record``)."""
        name = self.report.outputs.recording
        return None if name is None else self.out_dir / name


@dataclass(frozen=True)
class _Inputs:
    """Everything a run reads before its loop."""

    options: RunOptions
    config: Config
    config_file: Chosen
    log: WheelLog
    timing: TimeCalibration
    truth: GroundTruth | None
    labels: np.ndarray | None
    priors: IcrPriors | None
    frames: FrameList | None
    classifier: TerrainClassifier | None
    classifier_file: Chosen | None
    calibration: SensorCalibration | None = None


def _check_options(options: RunOptions) -> None:
    """Refuse an unknown estimator, and priors for the slip EKF.

    Raises
    ------
    ConfigError
        Naming the option.
    """
    if options.estimator not in ESTIMATORS:
        raise ConfigError(
            f"unknown estimator {options.estimator!r}; choose one of {list(ESTIMATORS)}"
        )
    if options.estimator == "slip-ekf" and options.priors is not None:
        raise ConfigError(
            "--priors seeds the ICR EKF (--estimator icr-ekf); the slip EKF's parameters "
            "l1 .. l6 are not ICRs"
        )


def _read_inputs(wheels: str | Path, options: RunOptions) -> _Inputs:
    """Check the options and read the inputs of :func:`run`."""
    _check_options(options)
    chosen = choose_config(
        options.config, options.config_path, edits=options.edits,
        imported=options.imported_config, images=options.images,
    )  # fmt: skip
    priors = options.priors
    icr_priors = None if priors is None else read_priors(priors, chosen.config.robot)
    log = read_wheel_log(wheels, wheel_radius=chosen.config.robot.wheel_radius)
    log, config, calibration, timing = calibrate_inputs(log, chosen.config)
    groundtruth = options.groundtruth
    truth = None if groundtruth is None else read_groundtruth_of(groundtruth, log)
    images = options.images
    use_frames = images is not None and options.terrain is not TerrainSource.NONE
    labels = None if use_frames else terrain_labels(log, options.terrain)
    if icr_priors is not None and icr_priors.terrains and labels is None and not use_frames:
        raise ConfigError(
            f"{priors}: per-terrain priors ({', '.join(sorted(icr_priors.terrains))}) need "
            f"terrain labels, but this run has none (--no-terrain, or no terrain column in "
            f"{log.source}); fit without --by-terrain for one prior"
        )
    frame_list = classifier = None
    given = options.classifier_path
    classifier_file = None if given is None else Chosen(Path(given), GIVEN)
    if use_frames and images is not None:
        from terrain_odom.io.classifier_file import load_classifier
        from terrain_odom.io.frames import read_frames

        classifier_file = choose_classifier(given)
        assert classifier_file.path is not None  # a classifier is always a file
        frame_list = read_frames(images)
        check_frame_times(frame_list, log, images)
        classifier = load_classifier(classifier_file.path)
    return _Inputs(
        options, config, chosen.file, log, timing, truth, labels, icr_priors, frame_list,
        classifier, classifier_file, calibration,
    )  # fmt: skip


@holds_run_folder  # out_dir is locked until the run returns
def run(wheels: str | Path, out_dir: str | Path, options: RunOptions | None = None) -> RunSummary:
    """Run the terrain-adaptive ICR EKF (or slip EKF) over a wheel log; write the results.

    The log is streamed row by row through
    :class:`~terrain_odom.estimation.online.OnlineOdometry`
    (:func:`~terrain_odom.estimation.odometry.run_odometry`).

    Parameters
    ----------
    wheels : str or Path
        Wheel log (docs/formats.md), its wheel speeds delayed by
        ``config.time.pose_delay`` (:func:`~terrain_odom.app.inputs.read_calibrated_log`).
    out_dir : str or Path
        Output folder, one run per folder (:mod:`~terrain_odom.app.run_folder`:
        ``report.json`` says ``running``, ``complete`` or ``interrupted``);
        ``InputFileError`` if a file to write is an input
        (:func:`~terrain_odom.io.paths.check_outputs`) or the folder holds a
        run and ``options.overwrite`` is false.
    options : RunOptions, optional
        How to run (default: ``RunOptions()``).

    Returns
    -------
    RunSummary
    """
    started = time.perf_counter()
    options = RunOptions() if options is None else options
    if options.record:
        require_rerun()
    inputs = _read_inputs(wheels, options)
    _check_run_outputs(out_dir, inputs, wheels)
    out = prepare_folder(out_dir, overwrite=options.overwrite)
    _write_run_config(out, inputs.config, inputs.timing, inputs.calibration)
    read = _run_inputs(inputs, wheels)
    started_with = RunInputs(read.wheels, read.config, read.priors).to_dict()
    mark_running(out, started_with)  # the files it reads besides: in the report at the end
    odometry = OnlineOdometry(
        inputs.config,
        inputs.classifier,
        estimator=options.estimator,
        priors=inputs.priors,
        use_roi=options.use_roi,
        time_full_frame=inputs.truth is not None,
    )
    root = None if options.images is None else Path(options.images)
    keep = 1 if options.record else _keep(inputs)
    guard = OutageGuard(inputs.log, inputs.config, odometry.names, options.estimator)
    streamed = stream_log(
        inputs.log, odometry, out, labels=inputs.labels, frames=inputs.frames, images=root,
        progress=options.progress, read=started_with, keep=keep, also=guard.add,
    )  # fmt: skip
    result, pipeline, records, x_icr = streamed
    if pipeline is not None and root is not None:
        pipeline.check_used(root)  # a camera run without one classified frame: an error
    guarded = guard.result()
    seconds = time.perf_counter() - started
    scored = _score(inputs, records if pipeline is not None else None)
    report = _report(inputs, read, result, odometry, seconds)
    report = dataclasses.replace(
        report,
        warnings=tuple(_lever_arm_warning(x_icr, inputs.config) + guarded.warnings()),
        outage_guard=guarded.section(),
        frames=None if root is None else frames_report(result, pipeline, options.use_roi),
        groundtruth=None if scored is None else scored.section,
    )
    drawn, recording = _pictures(out, inputs, result, scored, records, root)
    if recording is not None:
        outputs = dataclasses.replace(report.outputs, recording=recording.name)
        report = dataclasses.replace(report, outputs=outputs)
    _write_reports(out, report, drawn)
    return RunSummary(
        out, report, inputs.config_file, inputs.classifier_file,
        plots=tuple(out / name for name in drawn), unused_priors=_unused_priors(inputs),
        calibration=inputs.calibration, outage_guard=guarded,
    )  # fmt: skip


def _run_inputs(inputs: _Inputs, wheels: str | Path) -> RunInputs:
    """Return the files a run reads (``inputs`` of ``report.json``)."""
    options = inputs.options
    classifier = inputs.classifier_file
    return RunInputs(
        wheels=path_or_none(wheels),
        config=path_or_none(inputs.config_file.path),
        priors=path_or_none(options.priors),
        images=None if options.images is None else str(Path(options.images).resolve()),
        classifier=None if classifier is None else path_or_none(classifier.path),
        groundtruth=None if inputs.truth is None else path_or_none(options.groundtruth),
        with_images=options.images is not None,
    )


def _report(
    inputs: _Inputs,
    read: RunInputs,
    result: OdometryResult,
    odometry: OnlineOdometry,
    seconds: float,
) -> RunReport:
    """Return the report of a run (``seconds`` long), without its sections of the end."""
    log, names = inputs.log, result.names
    if inputs.frames is not None:
        source = "camera"
    else:
        source = inputs.options.terrain.value if inputs.labels is not None else "none"
    counts = RunCounts(
        rows=len(log),
        pose_measurements=int(np.count_nonzero(np.isfinite(log.pose).any(axis=1))),
        updates=result.n_updates,
        segments=log.n_runs,
        terrain_changes=len(result.changes),
        pose_components=odometry.pose_use,
    )
    frames_csv = None if inputs.frames is None else FRAMES_CSV
    calibration = inputs.calibration
    return RunReport(
        header=report_header("run"),
        status=COMPLETE,
        estimator=inputs.options.estimator,
        inputs=read,
        terrain_source=source,
        config=inputs.config,
        time_calibration=inputs.timing,
        counts=counts,
        terrain_changes=tuple(result.changes),
        final_state=dict(zip(names, result.states[-1].tolist(), strict=True)),
        final_std=dict(zip(names, result.stds[-1].tolist(), strict=True)),
        outputs=RunOutputs(TRAJECTORY_CSV, TRAJECTORY_TUM, frames_csv),
        run_time_s=seconds,
        calibration=calibration.to_dict()
        if calibration is not None and calibration.found
        else None,
    )


def _score(inputs: _Inputs, records: list[FrameRecord] | None) -> GroundTruthReport | None:
    """Score the run against its ground truth, if it has one (its frames' ``records`` too)."""
    if inputs.truth is None:
        return None
    return groundtruth_section(
        inputs.log,
        inputs.config,
        inputs.truth,
        labels=inputs.labels,
        records=records,
        use_roi=inputs.options.use_roi,
        priors=inputs.priors,
    )


def _write_reports(out: Path, report: RunReport, plots: list[str]) -> None:
    """Write ``report.json`` and ``report.md`` atomically."""
    write_json(out / REPORT_JSON, report.to_dict())
    write_text_atomic(out / REPORT_MD, run_markdown(report, plots))


def _check_run_outputs(out_dir: str | Path, inputs: _Inputs, wheels: str | Path) -> None:
    """Refuse an output folder where :func:`run` would overwrite an input.

    The inputs are the log, ground truth, priors, configuration and
    classifier files and, with images, their ``frames.csv`` and every frame listed.
    """
    options = inputs.options
    classifier = inputs.classifier_file
    read = [
        wheels, options.groundtruth, options.priors, inputs.config_file.path,
        None if classifier is None else classifier.path,
    ]  # fmt: skip
    if options.images is not None:
        read += [Path(options.images) / FRAMES_CSV, *(inputs.frames.files if inputs.frames else [])]
    check_outputs(read, [Path(out_dir) / name for name in RUN_FILES])


KEPT_ROWS = 20_000
"""A run keeps the estimates of at most about twice this many rows in memory (for its plots)."""


def _keep(inputs: _Inputs) -> int:
    """Keep every how many rows' estimates: all with frames or ground truth, else ~:data:`KEPT_ROWS`.

    ``trajectory.csv`` and ``trajectory.tum`` get every row as it is done;
    the plots draw at most a few thousand points; a camera run's mosaic and
    a run scored against ground truth look rows up by time.
    """
    if inputs.frames is not None or inputs.truth is not None:
        return 1
    return max(1, len(inputs.log) // KEPT_ROWS)


def _lever_arm_warning(x_icr: float, config: Config) -> list[str]:
    """Warn when ``x_icr`` lies beyond :func:`~terrain_odom.evaluation.mounting.x_icr_limit`.

    The estimate judged is the mean over the second half of the run's rows;
    within 10 % of the filter's bound (``ekf.limits.x_icr_max``, which holds
    it) counts as beyond.

    A position antenna ``a`` m ahead of the reference point, left out of
    ``pose_sensor``, moves sideways in turns as ICRs ``a`` m further back do;
    without a heading the log cannot tell the two apart before the run.
    """
    bound = config.ekf.limits.resolve(config.robot).x_icr_max
    limit = min(x_icr_limit(config.robot.track_width), 0.9 * bound)
    if not abs(x_icr) > limit:
        return []
    sensor = config.pose_sensor
    return [
        f"the estimated x_icr, {x_icr:+.2f} m over the second half, lies beyond {limit:.2f} m "
        f"(its bound: {bound:.2f} m): a position antenna {abs(x_icr):.2f} m "
        f"{'ahead of' if x_icr < 0 else 'behind'} the reference point (pose_sensor.antenna_x is "
        f"{sensor.antenna_x:g} m), or a heading error or latency read as side slip?"
    ]


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


def _write_run_config(
    out: Path, config: Config, timing: TimeCalibration, calibration: SensorCalibration | None
) -> None:
    """Write the configuration used into the run's folder, its delays and ``auto`` values resolved.

    Each value the run calibrated has a comment saying how it was found.
    """
    position, heading = timing.pose_delay, timing.heading_delay_applied
    time_config = (
        TimeConfig(pose_delay=position)
        if heading == position
        else TimeConfig(pose_delay=position, position_delay=position, heading_delay=heading)
    )
    resolved = dataclasses.replace(config, time=time_config)
    path = out / RUN_CONFIG
    header = "# The configuration this run used (terrain-odom run); evaluate --run reads it.\n"
    comments = calibration.comments() if calibration is not None else None
    write_text_atomic(path, header + dump_config(resolved, comments))


def _pictures(
    out: Path,
    inputs: _Inputs,
    result: OdometryResult,
    scored: GroundTruthReport | None,
    records: list[FrameRecord],
    root: Path | None,
) -> tuple[list[str], Path | None]:
    """Draw the run's plots (option ``plots``) and write ``run.rrd`` (option ``record``).

    Returns the plots' paths relative to ``out`` and the recording's path (or None).
    """
    plots, record = inputs.options.plots, inputs.options.record
    log = inputs.log if result.rows is None else inputs.log.take(result.rows)
    drawn = write_run_plots(
        out, log, result, inputs.config, truth=inputs.truth, scored=scored, records=records,
        images=root, classifier=inputs.classifier,
    ) if plots else []  # fmt: skip
    if not record:
        return drawn, None
    from terrain_odom.app.record import write_recording  # OpenCV, rerun: with record only

    recording = write_recording(
        out, inputs.log, result, inputs.config, records=records, images=root,
        classifier=inputs.classifier,
    )  # fmt: skip
    return drawn, recording
