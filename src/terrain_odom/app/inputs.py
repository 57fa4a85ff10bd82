"""The inputs every command shares: which configuration and classifier, the log as read.

``run``, ``fit``, ``compare``, ``evaluate`` and ``patches`` take their inputs
from here, so that no command module imports another: the configuration
file chosen (the user's ``--config``, a bag import's, the ``--images``
folder's, a run folder's, or the built-in defaults) with the command line's
edits applied, the terrain classifier (``--classifier`` or the packaged
default), the wheel log read and its delays calibrated, the ground truth and
the source of terrain labels. Each choice says how it was made
(:class:`Chosen`), so the command line prints it and chooses nothing itself.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from terrain_odom.app.calibration import calibrate_inputs
from terrain_odom.app.run_folder import RUN_CONFIG
from terrain_odom.config import ChecksConfig, Config, load_config, with_pose_delay
from terrain_odom.errors import InputFileError
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.io import read_wheel_log
from terrain_odom.io.groundtruth import read_groundtruth
from terrain_odom.records import GroundTruth, WheelLog

if TYPE_CHECKING:  # OpenCV: with --images only
    from terrain_odom.io.frames import FrameList

__all__ = [
    "LogSource",
    "GIVEN",
    "IMPORTED",
    "IN_IMAGES",
    "OF_RUN",
    "DEFAULT",
    "Chosen",
    "ConfigEdits",
    "ChosenConfig",
    "TerrainSource",
    "images_config",
    "run_config",
    "choose_config",
    "choose_classifier",
    "read_calibrated_log",
    "read_pose_logs",
    "calibrate_log",
    "read_groundtruth_of",
    "check_frame_times",
    "terrain_labels",
]

LogSource = str | Path | WheelLog
"""A wheel-log CSV path, or an already loaded :class:`WheelLog`."""

GIVEN = "given"
"""How a file was chosen: the user named it (``--config``, ``--classifier``)."""
IMPORTED = "imported from the bag"
"""The configuration written by the import of a bag given as ``--wheels``."""
IN_IMAGES = "found in the --images folder"
"""The ``config.yaml`` of the ``--images`` folder (a simulated run's camera and robot)."""
OF_RUN = "the run's"
"""The ``config.yaml`` of the ``--run`` folder: the configuration the run used."""
DEFAULT = "default"
"""Nothing named: the built-in configuration, or the packaged classifier."""


@dataclass(frozen=True)
class Chosen:
    """A file a command reads, and how it was chosen.

    Attributes
    ----------
    path : Path or None
        The file (None: the built-in defaults, or a configuration object given).
    how : str
        :data:`GIVEN`, :data:`IMPORTED`, :data:`IN_IMAGES`, :data:`OF_RUN`
        or :data:`DEFAULT`.
    """

    path: Path | None
    how: str


@dataclass(frozen=True)
class ConfigEdits:
    """What the command line changes in the configuration file's values.

    Attributes
    ----------
    pose_delay : str or None
        ``--pose-delay`` as given, seconds or ``auto`` (``time.pose_delay``,
        :func:`~terrain_odom.config.with_pose_delay`); None: the file's.
    checks : bool
        False: ``--no-checks`` (``checks.enabled``).
    reset_at : str or None
        ``run --reset-at`` (``terrain.reset_at``).
    roi_horizon : float or None
        ``patches --horizon``, s (``roi.horizon``).
    """

    pose_delay: str | None = None
    checks: bool = True
    reset_at: Literal["arrival", "immediate"] | None = None
    roi_horizon: float | None = None

    def apply(self, config: Config) -> Config:
        """Return ``config`` with the edits made (a new object; ``config`` is kept)."""
        if not self.checks:
            config = dataclasses.replace(config, checks=ChecksConfig(enabled=False))
        config = with_pose_delay(config, self.pose_delay)
        if self.reset_at is not None:
            terrain = dataclasses.replace(config.terrain, reset_at=self.reset_at)
            config = dataclasses.replace(config, terrain=terrain)
        if self.roi_horizon is not None:
            roi = dataclasses.replace(config.roi, horizon=self.roi_horizon)
            config = dataclasses.replace(config, roi=roi)
        return config


@dataclass(frozen=True)
class ChosenConfig:
    """The configuration a command runs with, its file and how that was chosen.

    Attributes
    ----------
    config : Config
        Loaded, the command line's edits applied.
    file : Chosen
        Its file and how it was chosen.
    """

    config: Config
    file: Chosen

    @property
    def path(self) -> Path | None:
        """The configuration file read (None: the built-in defaults or a given object)."""
        return self.file.path


def images_config(images: str | Path) -> Path | None:
    """Return ``images/config.yaml`` if that file exists (a simulated run's camera and robot)."""
    path = Path(images) / "config.yaml"
    return path if path.is_file() else None


def run_config(run_dir: str | Path) -> Path | None:
    """Return a run folder's ``config.yaml``, or None for a run written without one."""
    path = Path(run_dir) / RUN_CONFIG
    return path if path.is_file() else None


def _config_file(
    config_path: str | Path | None,
    imported: str | Path | None,
    images: str | Path | None,
    run_dir: str | Path | None,
) -> Chosen:
    """Return the configuration file to read: given, the run's, imported, found, or none."""
    if config_path is not None:
        return Chosen(Path(config_path), GIVEN)
    recorded = None if run_dir is None else run_config(run_dir)
    if recorded is not None:
        return Chosen(recorded, OF_RUN)
    if imported is not None:
        return Chosen(Path(imported), IMPORTED)
    found = None if images is None else images_config(images)
    return Chosen(found, IN_IMAGES) if found is not None else Chosen(None, DEFAULT)


def choose_config(
    config: Config | None = None,
    config_path: str | Path | None = None,
    *,
    edits: ConfigEdits | None = None,
    imported: str | Path | None = None,
    images: str | Path | None = None,
    run_dir: str | Path | None = None,
) -> ChosenConfig:
    """Return the configuration a command runs with, and how its file was chosen.

    In this order: ``config`` (an object, with ``config_path`` its file if
    any), ``config_path`` (the user's ``--config``), the ``run_dir``'s
    ``config.yaml`` (the configuration that run used), ``imported`` (written by
    the import of a bag), the ``images`` folder's ``config.yaml``, the
    built-in defaults. ``edits`` are applied to the configuration chosen
    (a new object: a given one is not changed).

    Raises
    ------
    ConfigError
        The file chosen is not a valid configuration (naming it).
    """
    if config is not None:
        file = Chosen(None if config_path is None else Path(config_path), GIVEN)
    else:
        file = _config_file(config_path, imported, images, run_dir)
        config = load_config(file.path)
    return ChosenConfig(config if edits is None else edits.apply(config), file)


def choose_classifier(classifier_path: str | Path | None) -> Chosen:
    """Return the terrain classifier file: ``classifier_path``, else the packaged default."""
    if classifier_path is not None:
        return Chosen(Path(classifier_path), GIVEN)
    from terrain_odom.io.classifier_file import default_classifier  # scikit-learn: with frames only

    return Chosen(default_classifier(), DEFAULT)


def read_calibrated_log(wheels: str | Path, config: Config) -> tuple[WheelLog, TimeCalibration]:
    """Read a wheel log and apply its pose delays (:func:`calibrate_log`).

    Raises
    ------
    InputFileError
        If the file is missing or malformed, its wheels and poses disagree
        (:func:`~terrain_odom.app.calibration.check_plausible`), or an
        ``auto`` value cannot be estimated.
    """
    return calibrate_log(read_wheel_log(wheels, wheel_radius=config.robot.wheel_radius), config)


def calibrate_log(log: WheelLog, config: Config) -> tuple[WheelLog, TimeCalibration]:
    """Calibrate a log read with ``config`` and apply its delays.

    :func:`~terrain_odom.app.calibration.calibrate_inputs`, keeping the log
    and its delays.

    Raises
    ------
    InputFileError
        Its wheels and poses disagree, or an ``auto`` value cannot be estimated.
    """
    log, _, _, timing = calibrate_inputs(log, config)
    return log, timing


def read_pose_logs(
    sources: Sequence[LogSource],
    config: Config,
    role: str,
    timing: dict[str, TimeCalibration],
) -> list[WheelLog]:
    """Read logs with poses (``fit``, ``compare``) and calibrate each; record its delays in ``timing``.

    Parameters
    ----------
    sources : sequence of str, Path or WheelLog
        The logs (a loaded one is calibrated as it is).
    config : Config
    role : str
        What the logs are for (``training``, ``evaluation``), for messages.
    timing : dict of str to TimeCalibration
        Filled: per log (its ``source``), the delays applied.

    Raises
    ------
    InputFileError
        No log, a log without pose measurements, or as :func:`calibrate_log`.
    """
    logs = []
    for src in sources:
        log = (
            src
            if isinstance(src, WheelLog)
            else read_wheel_log(src, wheel_radius=config.robot.wheel_radius)
        )
        if not np.isfinite(log.pose).any():
            raise InputFileError(
                f"{log.source}: no pose measurements (x, y or yaw); a {role} log needs them"
            )
        log, calibration = calibrate_log(log, config)
        timing[log.source] = calibration
        logs.append(log)
    if not logs:
        raise InputFileError(f"no {role} log given")
    return logs


def read_groundtruth_of(path: str | Path, log: WheelLog) -> GroundTruth:
    """Read ground truth and check it covers the log's time span.

    Raises
    ------
    InputFileError
        Unreadable, or its span does not cover the log's (naming both).
    """
    truth = read_groundtruth(path)
    if not truth.covers(log.t):
        raise InputFileError(
            f"{truth.source}: covers {truth.t[0]:g}-{truth.t[-1]:g} s but the wheel log "
            f"{log.source} spans {log.t[0]:g}-{log.t[-1]:g} s (is it the ground truth of this run?)"
        )
    return truth


def check_frame_times(frames: FrameList, log: WheelLog, images: str | Path) -> None:
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


class TerrainSource(enum.Enum):
    """Where terrain labels for the adaptive reset come from."""

    AUTO = "auto"  # the log's terrain column if it has one
    LOG = "log"  # the log's terrain column, required
    NONE = "none"  # no terrain information: plain ICR EKF


def terrain_labels(log: WheelLog, source: TerrainSource) -> np.ndarray | None:
    """Return the log's terrain column when ``source`` asks for it (the log's array, no copy).

    Raises
    ------
    InputFileError
        ``source`` is ``LOG`` and the log has no terrain column.
    """
    if source is TerrainSource.NONE:
        return None
    if log.terrain is None:
        if source is TerrainSource.LOG:
            raise InputFileError(
                f"{log.source}: --terrain-from-log needs a 'terrain' column, the log has none"
            )
        return None
    return log.terrain
