"""Import a ROS bag into terrain-odom's own formats (``terrain-odom import``), and inspect one.

Layout of ``OUT`` written by :func:`import_bag`:

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

One pass over the bag's selected topics, message by message: memory grows
with the wheel log's rows, not with the bag (images go to disk one by one).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from terrain_odom.config import load_config, validate_config
from terrain_odom.config.loader import read_yaml
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.bag_frames import FRAME_FORMATS, write_frame, write_frames_csv
from terrain_odom.io.bag_log import MergedLog, merge_streams
from terrain_odom.io.bag_messages import (
    CAMERA_INFO,
    JOINT_STATE,
    NAV_SAT_FIX,
    ROLE_TYPES,
    TF_MESSAGE,
    Intrinsics,
    camera_mount,
    chain_transform,
    intrinsics,
    sensor_mounting,
    transform_matrix,
)
from terrain_odom.io.bag_reader import (
    BagMessage,
    BagSummary,
    open_bag,
    short_type,
    stream_messages,
    summarize_bag,
    topic_connections,
)
from terrain_odom.io.bag_streams import HeadingStream, PoseStream, StampRule, WheelStream
from terrain_odom.io.folder import replacing
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import report_header, write_json
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog

__all__ = ["ImportOptions", "ImportResult", "import_bag", "inspect_bag", "read_bag_log"]

STAMP_CHOICES = ("header", "receive")
FRAMES_DIR = "frames"
"""The folder of an import's frames, in ``OUT``."""
TF_STATIC = "/tf_static"
ANTENNA_KEYS = ("pose_sensor.antenna_x", "pose_sensor.antenna_y")
CAMERA_MOUNT_KEYS = (
    "camera.mount_x",
    "camera.mount_y",
    "camera.mount_height",
    "camera.mount_pitch",
    "camera.mount_yaw",
)


@dataclass(frozen=True)
class ImportOptions:
    """What to read from a bag and how (the options of ``terrain-odom import``).

    Attributes
    ----------
    wheels_topic : str
        JointState, Odometry or TwistStamped topic.
    pose_topic, heading_topic, image_topic, camera_info_topic : str, optional
        Pose (Odometry, PoseStamped, PoseWithCovarianceStamped, /tf,
        NavSatFix), heading (Imu), image (Image, CompressedImage) and
        camera-info topics. The camera-info topic defaults to the image
        topic's sibling ``camera_info`` (used when present).
    track_width, wheel_radius : float, optional
        m; default the configuration's when ``config`` is given. The track
        width converts a body twist, the wheel radius joint velocities.
    left_joints, right_joints : tuple of str
        Shell patterns of the JointState joints of each side (averaged).
    pose_frames : (str, str), optional
        Parent and child frame of the ``/tf`` pose.
    base_frame : str
        The robot's frame, for the mountings from ``/tf_static``: the
        image's ``frame_id``, the pose sensor's frame (a NavSatFix's
        ``frame_id``, an Odometry's ``child_frame_id``, the ``/tf`` pose's
        child) and the Imu's ``frame_id``, each in it.
    gps_origin : (float, float, float), optional
        ENU origin: latitude, longitude (deg), altitude (m).
    stamps : {'header', 'receive'}
        Message header stamps, or the bag's receive times.
    max_gap : float
        s; a longer gap between wheel messages starts a new segment.
    image_format : {'jpg', 'png'}
    config : str or Path, optional
        A project configuration to start ``config.yaml`` from.
    """

    wheels_topic: str
    pose_topic: str | None = None
    heading_topic: str | None = None
    image_topic: str | None = None
    camera_info_topic: str | None = None
    track_width: float | None = None
    wheel_radius: float | None = None
    left_joints: tuple[str, ...] = ("*left*",)
    right_joints: tuple[str, ...] = ("*right*",)
    pose_frames: tuple[str, str] | None = None
    base_frame: str = "base_link"
    gps_origin: tuple[float, float, float] | None = None
    stamps: str = "header"
    max_gap: float = 0.5
    image_format: str = "jpg"
    config: str | Path | None = None


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


def inspect_bag(bag: str | Path, progress: bool | None = None) -> BagSummary:
    """List every topic of a bag: type, count, rate, span and roles (``terrain-odom inspect``)."""
    return summarize_bag(bag, progress)


@dataclass
class _Collect:
    """The streams of one import and the topics they read."""

    wheels: WheelStream
    poses: PoseStream | None
    headings: HeadingStream | None
    types: dict[str, str]
    bag: str
    images: list[tuple[int, str]] = field(default_factory=list)
    camera: Intrinsics | None = None
    static: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    image_frame: str | None = None
    images_unstamped: int = 0
    camera_topic: str | None = None


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
    start = time.perf_counter()
    _check_options(options)
    robot = _robot(options)
    out = Path(out_dir)
    paths = _output_paths(out)
    check_outputs([bag, options.config], paths.values())
    if Path(bag).is_dir() and out.resolve().is_relative_to(Path(bag).resolve()):
        raise InputFileError(f"{out}: --out is inside the bag folder {bag}; choose another folder")
    # locked; the previous import's files removed, any other file never replaced
    with replacing(out, "import", [*(p.name for p in paths.values()), f"{FRAMES_DIR}/"]):
        collect, merged = _read(bag, options, robot, out, progress)
        text, fill, sources = _config_text(paths["config"], collect, options, robot, bag)
        write_wheel_log(paths["log"], merged.log)
        frames_csv = (
            _write_frames(collect, merged, paths["frames"]) if options.image_topic else None
        )
        write_text_atomic(paths["config"], text)
        seconds = time.perf_counter() - start
        result = _result(paths, frames_csv, collect, merged, (fill, sources), seconds)
        write_json(paths["import"], _report(bag, options, collect, merged, result))
    return result


def read_bag_log(bag: str | Path, options: ImportOptions, progress: bool | None = None) -> WheelLog:
    """Return the wheel log :func:`import_bag` would write, in memory (direct use of a bag).

    Options as for :func:`import_bag`, without an image topic (frames need
    a folder: import them).

    Raises
    ------
    InputFileError, ConfigError
        As :func:`import_bag`.
    """
    if options.image_topic is not None:
        raise ConfigError("a bag's frames need a folder: import it (terrain-odom import)")
    _check_options(options)
    return _read(bag, options, _robot(options), None, progress)[1].log


def _read(
    bag: str | Path,
    options: ImportOptions,
    robot: dict[str, float | None],
    out: Path | None,
    progress: bool | None,
) -> tuple[_Collect, MergedLog]:
    """Read the bag's selected topics in one pass (frames written into ``out``); merge the log."""
    with open_bag(bag) as reader:
        connections, collect = _plan(reader, bag, options, robot)
        if out is not None and options.image_topic is not None:
            (out / FRAMES_DIR).mkdir(exist_ok=True)
        for message in stream_messages(reader, bag, connections, progress):
            _dispatch(collect, message, options, out)
    return collect, _merge(collect, options, bag)


def _output_paths(out: Path) -> dict[str, Path]:
    return {
        "log": out / "log.csv",
        "frames": out / "frames.csv",
        "config": out / "config.yaml",
        "import": out / "import.json",
    }


def _check_options(options: ImportOptions) -> None:
    """Raise ConfigError on an option outside its range."""
    if options.stamps not in STAMP_CHOICES:
        raise ConfigError(
            f"--stamps must be one of {', '.join(STAMP_CHOICES)}, got {options.stamps!r}"
        )
    if not 0.0 < options.max_gap < math.inf:
        raise ConfigError(f"--max-gap must be finite and > 0 s, got {options.max_gap}")
    if options.image_format not in FRAME_FORMATS:
        raise ConfigError(f"--image-format must be one of {', '.join(FRAME_FORMATS)}")
    for name in ("track_width", "wheel_radius"):
        value = getattr(options, name)
        if value is not None and not 0.0 < value < math.inf:
            raise ConfigError(f"--{name.replace('_', '-')} must be finite and > 0 m, got {value}")
    origin = options.gps_origin
    if origin is not None and not (abs(origin[0]) <= 90 and abs(origin[1]) <= 180):
        raise ConfigError(
            f"--gps-origin: latitude within +-90, longitude within +-180; got {origin}"
        )


def _robot(options: ImportOptions) -> dict[str, float | None]:
    """Track width and wheel radius: the options', else the configuration's (if one is given)."""
    cfg = load_config(options.config) if options.config is not None else None
    return {
        "track_width": options.track_width or (cfg.robot.track_width if cfg else None),
        "wheel_radius": options.wheel_radius or (cfg.robot.wheel_radius if cfg else None),
    }


def _plan(
    reader: Any, bag: str | Path, options: ImportOptions, robot: dict[str, float | None]
) -> tuple[list[Any], _Collect]:
    """Check the topics asked for and set up one stream per role."""
    topics = {
        "--wheels-topic": (options.wheels_topic, ROLE_TYPES["wheels"]),
        "--pose-topic": (options.pose_topic, ROLE_TYPES["pose"]),
        "--heading-topic": (options.heading_topic, ROLE_TYPES["heading"]),
        "--image-topic": (options.image_topic, ROLE_TYPES["images"]),
        "--camera-info-topic": (_camera_info_topic(reader, options), ROLE_TYPES["camera_info"]),
    }
    connections, types = [], {}
    for option, (topic, accepted) in topics.items():
        if topic is not None:
            conns = topic_connections(reader, bag, topic, option, accepted)
            connections += [c for c in conns if c not in connections]
            types[topic] = conns[0].msgtype
    connections += [c for c in reader.connections if c.topic == TF_STATIC and c not in connections]
    stamps = StampRule(options.stamps)
    wheels = WheelStream(f"{bag}: --wheels-topic {options.wheels_topic}", stamps)
    _wheel_geometry(wheels, types[options.wheels_topic], options, robot)
    return connections, _Collect(
        wheels=wheels,
        poses=_pose_stream(bag, options, types, stamps),
        headings=(
            HeadingStream(f"{bag}: --heading-topic {options.heading_topic}", stamps)
            if options.heading_topic
            else None
        ),
        types=types,
        bag=str(bag),
    )


def _camera_info_topic(reader: Any, options: ImportOptions) -> str | None:
    """Return the camera-info topic given, else the image topic's sibling ``camera_info`` if present.

    The sibling of ``/cam/image_raw`` is ``/cam/camera_info``; of an
    image_transport topic ``/cam/image_raw/compressed`` too.
    """
    if options.camera_info_topic is not None or options.image_topic is None:
        return options.camera_info_topic
    parent = options.image_topic.rsplit("/", 1)[0]
    candidates = [parent + "/camera_info"]
    if options.image_topic.endswith("/compressed"):
        candidates.append(parent.rsplit("/", 1)[0] + "/camera_info")
    infos = {c.topic for c in reader.connections if c.msgtype == CAMERA_INFO}
    return next((topic for topic in candidates if topic in infos), None)


def _wheel_geometry(
    wheels: WheelStream, msgtype: str, options: ImportOptions, robot: dict[str, float | None]
) -> None:
    """Give the wheel stream the radius (JointState) or track width (twists) it needs."""
    if msgtype == JOINT_STATE:
        if robot["wheel_radius"] is None:
            raise ConfigError(
                f"--wheels-topic {options.wheels_topic} is a JointState (rad/s): give "
                "--wheel-radius M (or a --config with robot.wheel_radius)"
            )
        wheels.wheel_radius = robot["wheel_radius"]
        wheels.left, wheels.right = options.left_joints, options.right_joints
    elif robot["track_width"] is None:
        raise ConfigError(
            f"--wheels-topic {options.wheels_topic} is a body twist ({short_type(msgtype)}): "
            "give --track-width M, the diff-drive controller's wheel separation (or a --config "
            "with robot.track_width)"
        )
    else:
        wheels.track_width = robot["track_width"]


def _pose_stream(
    bag: str | Path, options: ImportOptions, types: dict[str, str], stamps: StampRule
) -> PoseStream | None:
    """Return the pose stream, checking that a ``/tf`` pose topic comes with ``--pose-frames``."""
    if options.pose_topic is None:
        return None
    if types[options.pose_topic] == TF_MESSAGE and options.pose_frames is None:
        raise ConfigError(
            f"--pose-topic {options.pose_topic} is a tf2_msgs/TFMessage: give "
            "--pose-frames PARENT CHILD (e.g. odom base_link)"
        )
    frames = tuple(f.lstrip("/") for f in options.pose_frames) if options.pose_frames else None
    return PoseStream(
        f"{bag}: --pose-topic {options.pose_topic}",
        stamps,
        frames=frames,  # type: ignore[arg-type]
        origin=options.gps_origin,
    )


def _dispatch(
    collect: _Collect, message: BagMessage, options: ImportOptions, out: Path | None
) -> None:
    """Hand one message to the stream of its topic (a topic may serve several roles)."""
    topic = message.topic
    if topic == options.wheels_topic:
        collect.wheels.add(message)
    if topic == options.pose_topic and collect.poses is not None:
        collect.poses.add(message)
    if topic == options.heading_topic and collect.headings is not None:
        collect.headings.add(message)
    if topic == options.image_topic and out is not None:
        _frame(collect, message, options, out)
    if message.msgtype == CAMERA_INFO and collect.camera is None:
        collect.camera = intrinsics(message.msg)
        collect.camera_topic = topic
    if topic == TF_STATIC and message.msgtype == TF_MESSAGE:
        for tr in message.msg.transforms:
            pair = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
            _add_static(collect, pair, tr.transform)


def _add_static(collect: _Collect, pair: tuple[str, str], transform: Any) -> None:
    """Keep one ``/tf_static`` transform, refusing what makes no tree of frames.

    Raises
    ------
    InputFileError
        A rotation that is no quaternion (zero, not finite), a frame with
        two parents, or a loop of frames.
    """
    parent, child = pair
    where = f"{collect.bag}: {TF_STATIC} {parent} -> {child}"
    q = transform.rotation
    norm = math.hypot(q.x, q.y, q.z, q.w)
    if not (math.isfinite(norm) and norm > 1e-9):
        raise InputFileError(f"{where}: the rotation ({q.x}, {q.y}, {q.z}, {q.w}) is no quaternion")
    parents = {c: p for p, c in collect.static if (p, c) != pair}
    if child in parents and parents[child] != parent:
        raise InputFileError(
            f"{where}: {child} has another parent, {parents[child]}; a frame has one parent"
        )
    ancestor: str | None = parent
    while ancestor is not None:
        if ancestor == child:
            raise InputFileError(f"{where}: closes a loop of frames ({child} is above {parent})")
        ancestor = parents.get(ancestor)
    collect.static[pair] = transform_matrix(transform)


def _frame(collect: _Collect, message: BagMessage, options: ImportOptions, out: Path) -> None:
    """Write one image message as ``frames/NNNNNN.<format>`` and remember its stamp."""
    stamp = StampRule(options.stamps).of(message)
    if stamp is None:
        collect.images_unstamped += 1
        return
    if collect.image_frame is None:
        collect.image_frame = message.msg.header.frame_id.lstrip("/")
    name = f"frames/{len(collect.images):06d}.{options.image_format}"
    where = f"{collect.bag}: --image-topic {message.topic}"
    write_frame(message.msg, message.msgtype, out / name, options.image_format, where)
    collect.images.append((stamp, name))


def _merge(collect: _Collect, options: ImportOptions, bag: str | Path) -> MergedLog:
    """Merge the streams into the wheel log (raising if the wheels topic gave nothing usable)."""
    wheels = collect.wheels.wheel_rows()
    if len(wheels) == 0:
        raise InputFileError(
            f"{collect.wheels.where}: no message with a usable stamp "
            f"({_skips(collect.wheels.skipped)})"
        )
    poses = None
    if collect.poses is not None and options.pose_topic is not None:
        poses = collect.poses.pose_rows(collect.types[options.pose_topic])
    headings = collect.headings.heading_rows() if collect.headings else None
    return merge_streams(wheels, poses, headings, max_gap=options.max_gap, source=str(bag))


def _skips(skipped: dict[str, int]) -> str:
    return "; ".join(f"{n} {reason}" for reason, n in skipped.items()) or "none"


def _write_frames(collect: _Collect, merged: MergedLog, path: Path) -> Path:
    """Write ``frames.csv`` on the log's clock."""
    t = [(stamp - merged.origin_ns) / 1e9 for stamp, _ in collect.images]
    write_frames_csv(path, t, [name for _, name in collect.images])
    return path


def _config_text(
    path: Path,
    collect: _Collect,
    options: ImportOptions,
    robot: dict[str, float | None],
    bag: str | Path,
) -> tuple[str, tuple[str, ...], dict[str, str]]:
    """Return ``config.yaml`` (validated), the keys the user must fill and where each value came from.

    Raises
    ------
    InputFileError
        The configuration the bag gives is invalid (a CameraInfo with
        ``fx = 0`` ...), naming the bag, the key and the topic it came from.
    """
    data: dict[str, Any] = dict(read_yaml(Path(options.config)) or {}) if options.config else {}
    fill = ["robot.track_width"] if robot["track_width"] is None else []
    data["robot"] = {**data.get("robot", {}), **{k: v for k, v in robot.items() if v is not None}}
    sources = {
        f"robot.{k}": f"--{k.replace('_', '-')}" if getattr(options, k) else "--config"
        for k, v in robot.items()
        if v is not None
    }
    _pose_noise(data, collect, options, sources)
    header = [f"# terrain-odom import of {bag}"]
    fill += _pose_sensor(data, collect, options, sources)
    if any(key.startswith("pose_sensor.") and "/tf_static" in v for key, v in sources.items()):
        header.append(
            f"# pose_sensor.* from {TF_STATIC} (the sensors' frames in {options.base_frame}); "
            "a heading's magnetic declination is not in it (heading_offset: auto estimates both)"
        )
    if options.image_topic is not None:
        mount = _mount(collect, options.base_frame)
        fill += _camera(data, collect, mount, options.base_frame, sources)
        if mount is not None:
            header.append(
                f"# camera.mount_* from {TF_STATIC} ({options.base_frame} -> "
                f"{collect.image_frame}); mount_height is above {options.base_frame}'s origin: "
                "add its height above the ground unless it is on the ground"
            )
    if fill:
        header.append("# FILL IN (the bag does not tell them): " + ", ".join(fill))
    try:  # what will be written must load: checked before any file is written
        validate_config(data, str(path))
    except ConfigError as exc:
        came = [f"{key} from {src}" for key, src in sources.items() if key in str(exc)]
        raise InputFileError(
            f"{bag}: the configuration its messages give is invalid: {exc}"
            + (f" ({'; '.join(came)})" if came else "")
        ) from None
    return "\n".join(header) + "\n" + yaml.safe_dump(data, sort_keys=False), tuple(fill), sources


def _pose_noise(
    data: dict[str, Any], collect: _Collect, options: ImportOptions, sources: dict[str, str]
) -> None:
    """Set ``ekf.sigma_r`` and ``slip_ekf.sigma_r`` from the message covariances that give one.

    Per component: ``x, y`` from the position covariance, ``yaw`` from the
    yaw variance (of the pose topic, else of the Imu's orientation). The slip
    EKF measures the change between two poses, whose independent errors add:
    its ``dx, dy, dyaw`` are sqrt(2) times the pose's.
    """
    found = collect.poses.sigma() if collect.poses else {}
    sigma = {key: float(f"{value:.6g}") for key, value in found.items()}
    for key in sigma:
        n = len(collect.poses.sigmas) if collect.poses else 0
        sources[f"ekf.sigma_r.{key}"] = f"{options.pose_topic} covariances (median of {n})"
    yaw = collect.headings.sigma() if collect.headings else None
    if yaw is not None and "yaw" not in sigma and collect.headings is not None:
        sigma["yaw"] = float(f"{yaw:.6g}")
        sources["ekf.sigma_r.yaw"] = (
            f"{options.heading_topic} orientation covariances (median of "
            f"{len(collect.headings.sigmas)})"
        )
    if not sigma:
        return
    ekf = data.setdefault("ekf", {})
    ekf["sigma_r"] = {**ekf.get("sigma_r", {}), **sigma}
    change = {f"d{key}": float(f"{math.sqrt(2.0) * value:.6g}") for key, value in sigma.items()}
    slip = data.setdefault("slip_ekf", {})
    slip["sigma_r"] = {**slip.get("sigma_r", {}), **change}
    for key in sigma:
        sources[f"slip_ekf.sigma_r.d{key}"] = (
            f"sqrt(2) ekf.sigma_r.{key} (the change between two independent measurements)"
        )


def _pose_sensor(
    data: dict[str, Any], collect: _Collect, options: ImportOptions, sources: dict[str, str]
) -> list[str]:
    """Set ``pose_sensor`` from ``/tf_static``; return the keys to fill (a GPS antenna not in it).

    The antenna is the pose sensor's frame origin in the base frame; the
    heading offset is the yaw of the frame whose yaw is measured (the Imu's,
    or the pose's) in the base frame (:func:`sensor_mounting`).
    """
    base = options.base_frame.lstrip("/")
    sensor, fill, pose_yaw = _antenna(collect, options, base, sources)
    offsets = dict([pose_yaw]) if pose_yaw is not None else {}
    if collect.headings is not None:
        frame = collect.headings.sensor_frame or base
        mount = chain_transform(collect.static, base, frame)
        offsets[frame] = None if mount is None else sensor_mounting(mount)[2]
    offset = _heading_offset(offsets, options, base)
    if offset is not None:
        sensor["heading_offset"] = offset[1]
        sources["pose_sensor.heading_offset"] = f"{TF_STATIC} {base} -> {offset[0]} (yaw)"
    if sensor:
        data["pose_sensor"] = {**data.get("pose_sensor", {}), **sensor}
    return fill


def _antenna(
    collect: _Collect, options: ImportOptions, base: str, sources: dict[str, str]
) -> tuple[dict[str, float], list[str], tuple[str, float | None] | None]:
    """Return the antenna keys ``/tf_static`` gives, the keys to fill, the pose's yaw frame.

    The last: the frame whose yaw the pose topic measures and its yaw in the
    base frame (None if ``/tf_static`` does not tell); None for a GPS (no yaw).
    """
    poses = collect.poses
    if poses is None or options.pose_topic is None:
        return {}, [], None
    gps = collect.types[options.pose_topic] == NAV_SAT_FIX
    frame = poses.sensor_frame
    if frame is None and gps:
        sources.update(dict.fromkeys(ANTENNA_KEYS, "not set: the NavSatFix names no frame"))
        return {}, list(ANTENNA_KEYS), None
    if frame is None or frame == base:
        return {}, [], None if gps else (base, 0.0)
    mount = chain_transform(collect.static, base, frame)
    where = f"{TF_STATIC} {base} -> {frame}"
    if mount is None:
        sources.update(dict.fromkeys(ANTENNA_KEYS, f"not set: {where} not in the bag"))
        return {}, list(ANTENNA_KEYS) if gps else [], None if gps else (frame, None)
    antenna_x, antenna_y, yaw = sensor_mounting(mount)
    sources.update(dict.fromkeys(ANTENNA_KEYS, where))
    return {"antenna_x": antenna_x, "antenna_y": antenna_y}, [], None if gps else (frame, yaw)


def _heading_offset(
    offsets: dict[str, float | None], options: ImportOptions, base: str
) -> tuple[str, float] | None:
    """Return the frame and yaw (rad) measured headings are offset by, if ``/tf_static`` tells.

    Raises
    ------
    InputFileError
        If the pose's yaw and the Imu's are of frames turned from each other
        (one ``heading_offset`` cannot serve both).
    """
    known = {frame: yaw for frame, yaw in offsets.items() if yaw is not None}
    if len(known) == 2:
        (pose_frame, pose_yaw), (imu_frame, imu_yaw) = known.items()
        turn = float(wrap_angle(imu_yaw - pose_yaw))
        if abs(turn) > 1e-6:
            raise InputFileError(
                f"--pose-topic {options.pose_topic} measures the yaw of {pose_frame}, "
                f"--heading-topic {options.heading_topic} of {imu_frame}, turned "
                f"{math.degrees(turn):+.1f} deg from it ({TF_STATIC}): one "
                "pose_sensor.heading_offset cannot serve both; import one of them"
            )
    turned = [(frame, yaw) for frame, yaw in known.items() if frame != base]
    return turned[-1] if turned else None


def _mount(collect: _Collect, base_frame: str) -> dict[str, float] | None:
    """Return the camera mounting from ``/tf_static`` (base frame -> the image frame), if there."""
    frame = collect.image_frame
    pose = chain_transform(collect.static, base_frame.lstrip("/"), frame) if frame else None
    if pose is None or frame is None:
        return None
    return camera_mount(pose, optical="optical" in frame)


def _camera(
    data: dict[str, Any],
    collect: _Collect,
    mount: dict[str, float] | None,
    base_frame: str,
    sources: dict[str, str],
) -> list[str]:
    """Set the camera intrinsics and mounting that are known; return the camera keys to fill."""
    fill: list[str] = []
    known: dict[str, Any] = {}
    camera = collect.camera
    if camera is None:
        fill += [f"camera.{k}" for k in ("width", "height", "fx", "fy", "cx", "cy")]
    else:
        known.update({k: getattr(camera, k) for k in ("width", "height", "fx", "fy", "cx", "cy")})
    if mount is None:
        fill += CAMERA_MOUNT_KEYS
    else:
        known.update(mount)
    if known:
        data["camera"] = {**data.get("camera", {}), **known}
    for key in known:
        sources[f"camera.{key}"] = (
            f"{TF_STATIC} {base_frame} -> {collect.image_frame}"
            if key.startswith("mount_")
            else f"{collect.camera_topic} (CameraInfo)"
        )
    return fill


def _result(
    paths: dict[str, Path],
    frames_csv: Path | None,
    collect: _Collect,
    merged: MergedLog,
    config: tuple[tuple[str, ...], dict[str, str]],
    seconds: float,
) -> ImportResult:
    log = merged.log
    skipped = {"merge": merged.dropped}
    for stream in (collect.wheels, collect.poses, collect.headings):
        if stream is not None and stream.skipped:
            skipped[stream.where.split(": ", 1)[1]] = dict(stream.skipped)
    if collect.images_unstamped:
        skipped["--image-topic"] = {"header stamp 0 (unset)": collect.images_unstamped}
    return ImportResult(
        log_csv=paths["log"],
        config_yaml=paths["config"],
        import_json=paths["import"],
        frames_csv=frames_csv,
        rows=len(log),
        pose_rows=int(np.count_nonzero(log.has_position)),
        heading_rows=int(np.count_nonzero(log.has_yaw)),
        frames=len(collect.images),
        segments=log.n_runs,
        duration=float(log.t[-1] - log.t[0]),
        skipped={k: v for k, v in skipped.items() if v},
        fill_keys=config[0],
        seconds=seconds,
        sources=config[1],
    )


def _report(
    bag: str | Path,
    options: ImportOptions,
    collect: _Collect,
    merged: MergedLog,
    result: ImportResult,
) -> dict[str, Any]:
    """Return the content of ``import.json``."""
    log = merged.log
    return {
        **report_header("import"),
        "bag": str(Path(bag).resolve()),
        "topics": {
            topic: msgtype.replace("/msg/", "/") for topic, msgtype in collect.types.items()
        },
        "stamps": options.stamps,
        "time_origin_ns": merged.origin_ns,
        "time_span_s": [float(log.t[0]), float(log.t[-1])],
        "max_gap_s": options.max_gap,
        "counts": {
            "rows": result.rows,
            "wheel_messages": len(collect.wheels.stamps_kept),
            "pose_rows": result.pose_rows,
            "heading_rows": result.heading_rows,
            "frames": result.frames,
            "segments": result.segments,
            "wheel_messages_out_of_order": merged.out_of_order,
        },
        "skipped": result.skipped,
        "gps_origin": list(collect.poses.origin_used)
        if collect.poses and collect.poses.origin_used
        else None,
        "camera_distortion": list(collect.camera.distortion) if collect.camera else None,
        "fill_in_config": list(result.fill_keys),
        "config_sources": result.sources,
        "seconds": round(result.seconds, 3),
    }
