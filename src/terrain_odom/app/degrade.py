"""``terrain-odom degrade``: a consumer GPS + IMU recording made from a log with true poses.

Layout of ``OUT``:

- ``log.csv``: the degraded wheel log (``t,v_l,v_r,x,y,yaw[,terrain],segment``):
  the input's wheel rows without their poses, GPS rows (antenna ``x, y``) and
  IMU rows (``yaw``); :mod:`terrain_odom.sim.degrade` says what is injected.
- ``truth.csv``: the input log as read (surface speeds; its poses are the
  truth), in the same format, to score a run against
  (``terrain-odom evaluate --run R --wheels OUT/truth.csv``).
- ``config.yaml``: the input configuration with the pose noise the sensors'
  messages would claim (``ekf.sigma_r``), and nothing of the mounting,
  latency or real noise: what a user starts from.
- ``degrade.yaml``: every injected value (the answers calibration must find).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import yaml

from terrain_odom.config import Config, dump_config
from terrain_odom.config.sections import PoseSigmas
from terrain_odom.errors import InputFileError
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.folder import replacing
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.wheel_log import read_wheel_log, write_wheel_log
from terrain_odom.sim.degrade import Degradation, DegradedLog, degrade_log

__all__ = ["DEGRADE_FILES", "DegradeOutput", "write_degraded"]

DEGRADE_FILES = ("log.csv", "truth.csv", "config.yaml", "degrade.yaml")
"""The files ``degrade`` writes into its folder."""


@dataclass(frozen=True)
class DegradeOutput:
    """What :func:`write_degraded` wrote.

    Attributes
    ----------
    degraded : DegradedLog
        The recording and its truth.
    out_dir : Path
        The output folder.
    fixes, headings, rows : int
        GPS rows, IMU rows and all rows of ``log.csv``.
    """

    degraded: DegradedLog
    out_dir: Path
    fixes: int
    headings: int
    rows: int

    def path(self, name: str) -> Path:
        """Return the path of one of :data:`DEGRADE_FILES` in the folder."""
        return self.out_dir / name


def write_degraded(
    wheels: str | Path,
    config: Config,
    degradation: Degradation,
    out_dir: str | Path,
    *,
    config_path: str | Path | None = None,
    overwrite: bool = False,
) -> DegradeOutput:
    """Degrade the log ``wheels`` and write the folder ``out_dir``.

    Parameters
    ----------
    wheels : str or Path
        Wheel log with true poses (rad/s columns are converted with
        ``config.robot.wheel_radius``).
    config : Config
        The robot's configuration; written back with the claimed noise.
    degradation : Degradation
    out_dir : str or Path
        Output folder (created).
    config_path : str or Path, optional
        The configuration file read, which no output may overwrite.
    overwrite : bool
        Replace this command's files in ``out_dir``; otherwise a folder that
        holds any of them is refused.

    Raises
    ------
    InputFileError
        An output exists (without ``overwrite``) or is an input, or the log
        has no run with two full poses.
    """
    out_dir = Path(out_dir)
    targets = [out_dir / name for name in DEGRADE_FILES]
    check_outputs((wheels, config_path), targets)
    existing = [p.name for p in targets if p.exists()]
    if existing and not overwrite:
        raise InputFileError(
            f"{out_dir} already holds {', '.join(existing)}: choose another --out, or --overwrite"
        )
    clean = read_wheel_log(wheels, wheel_radius=config.robot.wheel_radius)
    degraded = degrade_log(clean, degradation)
    with replacing(out_dir, "degrade", DEGRADE_FILES, overwrite=overwrite):  # never another's file
        write_wheel_log(out_dir / "log.csv", degraded.log)
        write_wheel_log(out_dir / "truth.csv", degraded.truth)
        write_text_atomic(out_dir / "config.yaml", _claimed_config(config, degradation, wheels))
        write_text_atomic(out_dir / "degrade.yaml", _injected_yaml(degraded, wheels))
    log = degraded.log
    return DegradeOutput(
        degraded, out_dir, int(log.has_position.sum()), int(log.has_yaw.sum()), len(log)
    )


def _claimed_config(config: Config, d: Degradation, wheels: str | Path) -> str:
    """Return the configuration with the noise a driver's covariances would claim, as YAML."""
    injected = d.injected()
    claimed = PoseSigmas(
        x=injected["gps_claimed"], y=injected["gps_claimed"], yaw=d.heading_claimed
    )
    config = dataclasses.replace(config, ekf=dataclasses.replace(config.ekf, sigma_r=claimed))
    header = (
        f"# configuration of the degraded recording of {Path(wheels).name}: the pose noise\n"
        "# (ekf.sigma_r) is what the sensors' messages would claim; the mounting, latency\n"
        "# and real noise are unknown here (degrade.yaml has them)\n"
    )
    return header + dump_config(config)


def _injected_yaml(degraded: DegradedLog, wheels: str | Path) -> str:
    header = (
        f"# what terrain-odom degrade injected into {Path(wheels).name}\n"
        "# (lengths m, angles rad, times s, rates Hz; noise as std)\n"
    )
    return header + yaml.safe_dump(degraded.injected, sort_keys=False)
