"""``run --record``: the run as a Rerun recording, ``OUT/run.rrd``.

The recording is written after the run, from what it holds in memory (like
the plots): the log, its result and the frames' records. Each frame's file
goes in as it is (JPEG or PNG; other formats are encoded to JPEG), with its
region of interest and the votes of its tiles computed again
(:func:`~terrain_odom.app.plots.with_votes`, as for the mosaic).
``rerun`` (the ``[viz]`` extra) is imported only here, only when asked for:
a run without ``--record`` never loads it.
"""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from terrain_odom.app.frames import FrameRecord, one_thread
from terrain_odom.app.plots import with_votes
from terrain_odom.app.run_folder import RECORDING
from terrain_odom.config import Config
from terrain_odom.errors import ConfigError
from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.io.atomic import write_atomic
from terrain_odom.io.images import decode_image_rgb, read_image_bytes
from terrain_odom.records import WheelLog
from terrain_odom.reporting.mosaic import MosaicPanel

if TYPE_CHECKING:
    from terrain_odom.reporting.recording import RecordedFrame
    from terrain_odom.vision.classifier import TerrainClassifier

__all__ = ["RECORDING", "NEEDS_RERUN", "require_rerun", "write_recording"]

NEEDS_RERUN = "--record needs rerun-sdk: pip install 'terrain-odom[viz]'"


def require_rerun() -> None:
    """Check that ``rerun`` can be imported (without importing it).

    Raises
    ------
    ConfigError
        :data:`NEEDS_RERUN`: the ``[viz]`` extra is not installed.
    """
    if importlib.util.find_spec("rerun") is None:
        raise ConfigError(NEEDS_RERUN)


def _recorded(
    records: Sequence[FrameRecord],
    images: Path,
    result: OdometryResult,
    log: WheelLog,
    config: Config,
    classifier: TerrainClassifier,
) -> Iterator[RecordedFrame]:
    """Yield each readable frame of ``records`` with its region of interest and votes."""
    from terrain_odom.reporting.recording import RecordedFrame, frame_media_type

    for record in records:
        path = images / record.file
        data, _ = read_image_bytes(path)
        image = None if data is None else decode_image_rgb(data)
        if data is None or image is None:
            continue
        media_type = frame_media_type(path.suffix)
        if media_type is None:
            import cv2

            data = cv2.imencode(".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))[1].tobytes()
            media_type = "image/jpeg"
        panel = MosaicPanel(record.t, image, record.label, record.confidence, "", "",
                            box=record.box)  # fmt: skip
        panel = with_votes(panel, record, result, log, config, classifier)
        yield RecordedFrame(panel.t, data, media_type, panel.label, panel.confidence,
                            panel.box, panel.polygon, panel.tiles, panel.votes)  # fmt: skip


def write_recording(
    out_dir: Path,
    log: WheelLog,
    result: OdometryResult,
    config: Config,
    *,
    records: Sequence[FrameRecord] = (),
    images: Path | None = None,
    classifier: TerrainClassifier | None = None,
) -> Path:
    """Write ``out_dir/run.rrd`` (atomically): the run on one timeline, for the Rerun viewer.

    Parameters
    ----------
    out_dir : Path
        The run's output folder.
    log, result, config
        The run's (calibrated) log, its result and configuration.
    records, images, classifier : optional
        The frames of a camera run, their folder and the classifier.

    Returns
    -------
    Path
        The recording written.

    Raises
    ------
    ConfigError
        ``rerun`` is not installed (:func:`require_rerun`).
    """
    require_rerun()
    from terrain_odom.reporting.recording import record_run

    frames: Iterable[RecordedFrame] = ()
    classes: Sequence[str] = ()
    if records and images is not None and classifier is not None:
        frames = _recorded(records, images, result, log, config, classifier)
        classes = [str(c) for c in classifier.classes]
    path = out_dir / RECORDING
    write = functools.partial(
        record_run, log=log, result=result, frames=frames, labels=classes,
        arrow=config.robot.track_width,
    )  # fmt: skip
    with one_thread():  # the votes' features, as in the run (see one_thread)
        write_atomic(path, write)
    return path
