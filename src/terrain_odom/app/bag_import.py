"""Import a ROS bag into terrain-odom's own formats (``terrain-odom import``): write the folder.

The bag is read by :func:`terrain_odom.io.bag.contents.read_bag` (one pass,
a :class:`~terrain_odom.io.bag.contents.BagContents`); this module writes
what it gives. Layout of ``OUT`` written by :func:`import_bag`:

- ``log.csv``: the wheel log (docs/formats.md): track speeds from the wheels
  topic, pose rows and heading-only rows of their own (docs/bags.md);
- ``frames/NNNNNN.jpg`` (or ``.png``) and ``frames.csv`` (``t,file``) with
  ``--image-topic``;
- ``config.yaml``: the robot geometry used, the pose noise of the message
  covariances (``ekf.sigma_r``, ``slip_ekf.sigma_r``), the pose sensors'
  and the camera's mounting from ``/tf_static``, the camera intrinsics; the
  keys the bag could not tell are listed in a comment at its top (and in
  ``import.json``);
- ``import.json``: bag, topics, counts, time span, time origin, what was
  skipped and why, where each configuration value came from.

:func:`logs_from_bags` imports the bags other commands are given where they
read a wheel log (``run``, ``fit``, ``evaluate``, ``calibrate``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from terrain_odom.config import validate_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.bag.options import FRAMES_DIR, ImportOptions
from terrain_odom.io.bag.paths import is_bag
from terrain_odom.io.folder import replacing
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import report_header, write_json
from terrain_odom.io.wheel_log import write_wheel_log

if TYPE_CHECKING:
    from terrain_odom.io.bag.configuration import BagConfig
    from terrain_odom.io.bag.contents import BagContents

__all__ = ["ImportResult", "import_bag", "logs_from_bags"]


@dataclass(frozen=True)
class ImportResult:
    """What :func:`import_bag` wrote and counted.

    Attributes
    ----------
    log_csv, config_yaml, import_json : Path
    frames_csv : Path or None
        With an image topic.
    rows, pose_rows, heading_rows, frames, segments : int
        Log rows, rows with x, y, rows with yaw, frames written, segments.
    duration : float
        s, first to last log row.
    skipped : dict of str to dict of str to int
        Per topic, messages skipped by reason.
    fill_keys : tuple of str
        Configuration keys the bag could not tell (to fill by hand).
    seconds : float
        Wall time of the import.
    sources : dict of str to str
        Where each configuration value the import set came from (an
        option, a topic's messages, ``/tf_static``), by key.
    """

    log_csv: Path
    config_yaml: Path
    import_json: Path
    frames_csv: Path | None
    rows: int
    pose_rows: int
    heading_rows: int
    frames: int
    segments: int
    duration: float
    skipped: dict[str, dict[str, int]] = field(default_factory=dict)
    fill_keys: tuple[str, ...] = ()
    seconds: float = 0.0
    sources: dict[str, str] = field(default_factory=dict)


def import_bag(
    bag: str | Path, out_dir: str | Path, options: ImportOptions, progress: bool | None = None
) -> ImportResult:
    """Import a bag into ``out_dir`` (module docstring); see :class:`ImportOptions`.

    Raises
    ------
    InputFileError
        A bag that is not a bag, a missing topic, a wrong type, a topic
        without messages, a message that cannot be used (one line, naming the
        topic and what was expected); an output that would overwrite an input.
    ConfigError
        Invalid options (a missing track width or wheel radius, ...).
    """
    from terrain_odom.io.bag.contents import check_options, read_bag  # rosbags: bags only
    from terrain_odom.io.bag.frames import write_frames_csv  # OpenCV: bags only

    start = time.perf_counter()
    robot = check_options(options)
    out_dir = Path(out_dir)
    paths = _output_paths(out_dir)
    check_outputs([bag, options.config_path], paths.values())
    if Path(bag).is_dir() and out_dir.resolve().is_relative_to(Path(bag).resolve()):
        raise InputFileError(
            f"{out_dir}: --out is inside the bag folder {bag}; choose another folder"
        )
    # locked; the previous import's files removed, any other file never replaced
    with replacing(out_dir, "import", [*(p.name for p in paths.values()), f"{FRAMES_DIR}/"]):
        contents = read_bag(bag, options, robot, out_dir, progress)
        text = _config_text(paths["config"], contents.config, bag)
        write_wheel_log(paths["log"], contents.log)
        frames_csv = paths["frames"] if options.image_topic else None
        if frames_csv is not None:  # on the log's clock
            write_frames_csv(frames_csv, list(contents.frame_t), list(contents.frame_files))
        write_text_atomic(paths["config"], text)
        seconds = time.perf_counter() - start
        result = _result(paths, frames_csv, contents, seconds)
        write_json(paths["import"], _report(bag, options, contents, result))
    return result


def logs_from_bags(
    paths: Sequence[str],
    options: ImportOptions | None,
    out_dir: str | Path,
    on_import: Callable[[ImportResult], None],
) -> tuple[list[str], str | None]:
    """Return the wheel logs to use for ``paths``: each itself, or its import if it is a bag.

    The bags are imported with ``options`` (the bag options, ``--wheels-topic``
    ...; None without ``--wheels-topic``) into ``OUT/bag/``, or
    ``OUT/bag/<bag name>/`` when there are several, each import's result
    handed to ``on_import`` as it is written; the first import's
    ``config.yaml`` is the configuration when ``options.config_path`` is not given
    (None is returned otherwise, and without a bag).

    Raises
    ------
    ConfigError
        A bag without ``--wheels-topic``, or ``--wheels-topic`` and no bag.
    """
    bags = [path for path in paths if is_bag(path)]
    if options is None:
        if bags:
            raise ConfigError(
                f"--wheels {bags[0]} is a ROS bag: give --wheels-topic (and the other topic "
                f"options; 'terrain-odom inspect {bags[0]}' lists its topics)"
            )
        return list(paths), None
    if not bags:
        raise ConfigError(
            f"--wheels-topic reads a ROS bag, but --wheels {' '.join(paths)} is not one "
            "(a .bag or .mcap file or a ROS 2 bag folder)"
        )
    folders = _bag_folders(bags, Path(out_dir) / "bag")
    logs, configs = [], []
    for path in paths:
        if path not in folders:
            logs.append(path)
            continue
        result = import_bag(path, folders[path], options)
        on_import(result)
        logs.append(str(result.log_csv))
        configs.append(str(result.config_yaml))
    return logs, None if options.config_path else configs[0]


def _bag_folders(bags: Sequence[str], root: Path) -> dict[str, Path]:
    """Return the import folder of each bag: ``root`` for one, ``root/<name>`` for several."""
    unique = list(dict.fromkeys(bags))
    if len(unique) == 1:
        return {unique[0]: root}
    folders: dict[str, Path] = {}
    for bag in unique:
        name = Path(bag).stem or "bag"
        folder, n = root / name, 1
        while folder in folders.values():
            n += 1
            folder = root / f"{name}-{n}"
        folders[bag] = folder
    return folders


def _output_paths(out_dir: Path) -> dict[str, Path]:
    return {
        "log": out_dir / "log.csv",
        "frames": out_dir / "frames.csv",
        "config": out_dir / "config.yaml",
        "import": out_dir / "import.json",
    }


def _config_text(path: Path, config: BagConfig, bag: str | Path) -> str:
    """Return ``config.yaml``'s text, validated: what will be written must load.

    Raises
    ------
    InputFileError
        The configuration the bag gives is invalid (a CameraInfo with
        ``fx = 0`` ...), naming the bag, the key and the topic it came from.
    """
    try:  # checked before any file is written
        validate_config(config.data, str(path))
    except ConfigError as exc:
        came = [f"{key} from {src}" for key, src in config.sources.items() if key in str(exc)]
        raise InputFileError(
            f"{bag}: the configuration its messages give is invalid: {exc}"
            + (f" ({'; '.join(came)})" if came else "")
        ) from None
    return "\n".join(config.header) + "\n" + yaml.safe_dump(config.data, sort_keys=False)


def _result(
    paths: dict[str, Path], frames_csv: Path | None, contents: BagContents, seconds: float
) -> ImportResult:
    log = contents.log
    return ImportResult(
        log_csv=paths["log"],
        config_yaml=paths["config"],
        import_json=paths["import"],
        frames_csv=frames_csv,
        rows=len(log),
        pose_rows=int(np.count_nonzero(log.has_position)),
        heading_rows=int(np.count_nonzero(log.has_yaw)),
        frames=len(contents.frame_files),
        segments=log.n_runs,
        duration=float(log.t[-1] - log.t[0]),
        skipped=contents.skipped,
        fill_keys=contents.config.fill_keys,
        seconds=seconds,
        sources=contents.config.sources,
    )


def _report(
    bag: str | Path, options: ImportOptions, contents: BagContents, result: ImportResult
) -> dict[str, Any]:
    """Return the content of ``import.json``."""
    log = contents.log
    return {
        **report_header("import"),
        "bag": str(Path(bag).resolve()),
        "topics": {
            topic: msgtype.replace("/msg/", "/") for topic, msgtype in contents.topics.items()
        },
        "stamps": options.stamps,
        "time_origin_ns": contents.origin_ns,
        "time_span_s": [float(log.t[0]), float(log.t[-1])],
        "max_gap_s": options.max_gap,
        "counts": {
            "rows": result.rows,
            "wheel_messages": contents.wheel_messages,
            "pose_rows": result.pose_rows,
            "heading_rows": result.heading_rows,
            "frames": result.frames,
            "segments": result.segments,
            "wheel_messages_out_of_order": contents.out_of_order,
        },
        "skipped": result.skipped,
        "gps_origin": list(contents.gps_origin) if contents.gps_origin else None,
        "camera_distortion": list(contents.camera.distortion) if contents.camera else None,
        "fill_in_config": list(result.fill_keys),
        "config_sources": result.sources,
        "seconds": round(result.seconds, 3),
    }
