"""``terrain-odom calibrate``: a robot's own pose sensors calibrated against its wheels.

Reads a wheel log with its GPS positions and IMU headings, finds every
value the log can give (:func:`~terrain_odom.app.calibration.calibrate_config`
with ``everything``: the position and heading delays, the heading offset,
the antenna lever arm, the noise of each sensor), and writes

- ``OUT/config.yaml``: the input configuration with the values found, each
  line commented with how it was found and its standard error (values the
  log cannot give keep the input's, commented "not observable" and why);
- ``OUT/calibration.json``: every value, its standard error, whether it was
  observable and used, and the notes (a noise a covariance understated).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from terrain_odom.app.calibration import SensorCalibration, calibrate_inputs
from terrain_odom.app.inputs import choose_config
from terrain_odom.config import Config, dump_config
from terrain_odom.config.sections import RobotConfig
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.io import read_wheel_log
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.folder import replacing
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import report_header, write_json

__all__ = ["CalibrateSummary", "CALIBRATION_JSON", "calibrate"]

CALIBRATION_JSON = "calibration.json"


@dataclass(frozen=True)
class CalibrateSummary:
    """What ``terrain-odom calibrate`` found and wrote.

    Attributes
    ----------
    config_yaml, report_json : Path
        ``OUT/config.yaml`` and ``OUT/calibration.json``.
    calibration : SensorCalibration
        The values found.
    timing : TimeCalibration
        The delays found.
    rows : int
        Log rows read.
    seconds : float
        Wall time, s.
    robot : RobotConfig
        The geometry the log was calibrated with (the input configuration's).
    config_path : Path or None
        The input configuration's file; None: the built-in defaults.
    """

    config_yaml: Path
    report_json: Path
    calibration: SensorCalibration
    timing: TimeCalibration
    rows: int
    seconds: float
    robot: RobotConfig
    config_path: Path | None


def calibrate(
    wheels: str | Path,
    out_dir: str | Path,
    *,
    config: Config | None = None,
    config_path: str | Path | None = None,
    imported: str | Path | None = None,
) -> CalibrateSummary:
    """Calibrate a log's pose sensors and write ``OUT/config.yaml`` and ``OUT/calibration.json``.

    Parameters
    ----------
    wheels : str or Path
        Wheel log with positions and/or headings (docs/formats.md).
    out_dir : str or Path
        Output folder (created).
    config, config_path : optional
        The input configuration, or its YAML file (the user's ``--config``).
    imported : str or Path, optional
        The configuration a bag's import wrote, used where neither is given
        (:func:`~terrain_odom.app.inputs.choose_config`; else the built-in
        defaults). The summary's ``config_path`` says which file was used.

    Returns
    -------
    CalibrateSummary

    Raises
    ------
    InputFileError
        A log that cannot be calibrated (no poses, no motion) or an ``auto``
        value it cannot give: one line saying what data would.
    """
    started = time.perf_counter()
    chosen = choose_config(config, config_path, imported=imported)
    config, config_path = chosen.config, chosen.path
    out_dir = Path(out_dir)
    paths = [out_dir / "config.yaml", out_dir / CALIBRATION_JSON]
    check_outputs([wheels, config_path], paths)
    log = read_wheel_log(wheels, wheel_radius=config.robot.wheel_radius)
    _, resolved, found, timing = calibrate_inputs(log, config, everything=True)
    header = (
        f"# {Path(wheels).name} calibrated by terrain-odom calibrate: each value found is "
        "commented with how and its standard error.\n"
    )
    seconds = time.perf_counter() - started
    report = {
        **report_header("calibrate"),
        "inputs": {"wheels": str(Path(wheels).resolve()), "config": _path(config_path)},
        "rows": len(log),
        "seconds": seconds,
        "time_calibration": timing.to_dict(),
        **found.to_dict(),
    }
    with replacing(out_dir, "calibrate", [p.name for p in paths], all_previous=False):
        write_text_atomic(paths[0], header + dump_config(resolved, found.comments()))
        write_json(paths[1], report)  # its own previous files replaced, never another's
    source = None if config_path is None else Path(config_path)
    return CalibrateSummary(
        paths[0], paths[1], found, timing, len(log), seconds, config.robot, source
    )


def _path(path: str | Path | None) -> str | None:
    return None if path is None else str(Path(path).resolve())
