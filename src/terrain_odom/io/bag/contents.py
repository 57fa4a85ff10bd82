"""Read a ROS bag's selected topics in one pass: :func:`read_bag` returns a :class:`BagContents`.

One pass over the bag's selected topics, message by message: memory grows
with the wheel log's rows, not with the bag (images go to disk one by one,
into ``OUT/frames/``). The streams (:mod:`~terrain_odom.io.bag.streams`)
convert the messages, :mod:`~terrain_odom.io.bag.log` merges them into the
wheel log and :mod:`~terrain_odom.io.bag.configuration` derives the
configuration the bag gives; ``terrain-odom import``
(:mod:`terrain_odom.app.bag_import`) writes the folder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from terrain_odom.config import load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.bag.configuration import BagConfig, bag_config
from terrain_odom.io.bag.frames import FRAME_FORMATS, write_frame
from terrain_odom.io.bag.log import MergedLog, merge_streams
from terrain_odom.io.bag.messages import (
    CAMERA_INFO,
    JOINT_STATE,
    ROLE_TYPES,
    TF_MESSAGE,
    TF_STATIC,
    Intrinsics,
    intrinsics,
    transform_matrix,
)
from terrain_odom.io.bag.options import FRAMES_DIR, STAMP_CHOICES, ImportOptions
from terrain_odom.io.bag.reader import (
    BagMessage,
    open_bag,
    short_type,
    stream_messages,
    topic_connections,
)
from terrain_odom.io.bag.streams import (
    BagStreams,
    HeadingStream,
    PoseStream,
    StampRule,
    WheelStream,
)
from terrain_odom.records import WheelLog

__all__ = ["BagContents", "check_options", "read_bag", "read_bag_log"]


@dataclass(frozen=True)
class BagContents:
    """What one pass over a bag gives: the wheel log, the frames, the configuration, the counts.

    Attributes
    ----------
    bag : str
        The bag, as given.
    log : WheelLog
        The merged wheel log (docs/bags.md), on the clock of ``origin_ns``.
    origin_ns : int
        ns; the log's time origin (the first stamp rounded down to a second).
    topics : dict of str to str
        The topics read (``/tf_static`` aside): their message types.
    frame_t : tuple of float
        s, on the log's clock: the stamp of each frame written.
    frame_files : tuple of str
        Each frame's file, relative to the import folder (``frames/000000.jpg``).
    wheel_messages : int
        Wheel messages kept.
    out_of_order : int
        Wheel messages that arrived out of stamp order.
    skipped : dict of str to dict of str to int
        Per topic (``merge`` for merging), messages skipped by reason.
    gps_origin : (float, float, float) or None
        The ENU origin a NavSatFix pose topic was converted with.
    camera : Intrinsics or None
        The camera-info topic's intrinsics.
    config : BagConfig
        The configuration the bag gives (not validated yet).
    """

    bag: str
    log: WheelLog
    origin_ns: int
    topics: dict[str, str]
    frame_t: tuple[float, ...]
    frame_files: tuple[str, ...]
    wheel_messages: int
    out_of_order: int
    skipped: dict[str, dict[str, int]]
    gps_origin: tuple[float, float, float] | None
    camera: Intrinsics | None
    config: BagConfig


def read_bag(
    bag: str | Path,
    options: ImportOptions,
    robot: dict[str, float | None],
    out_dir: Path | None,
    progress: bool | None = None,
) -> BagContents:
    """Read ``bag`` in one pass (frames written into ``out_dir/frames/``) and merge the wheel log.

    Parameters
    ----------
    bag : str or Path
    options : ImportOptions
    robot : dict of str to float or None
        Track width and wheel radius (m): :func:`check_options`'s.
    out_dir : Path, optional
        The import folder the frames go to (with an image topic).
    progress : bool, optional
        Show a progress bar (default: on a terminal).

    Raises
    ------
    InputFileError
        A bag that is not a bag, a missing topic, a wrong type, a topic
        without messages, a message that cannot be used (one line, naming the
        topic and what was expected).
    ConfigError
        A missing track width or wheel radius, a ``/tf`` pose without frames.
    """
    streams, merged = _read(bag, options, robot, out_dir, progress)
    return BagContents(
        bag=streams.bag,
        log=merged.log,
        origin_ns=merged.origin_ns,
        topics=streams.types,
        frame_t=tuple((stamp - merged.origin_ns) / 1e9 for stamp, _ in streams.images),
        frame_files=tuple(name for _, name in streams.images),
        wheel_messages=len(streams.wheels.stamps_kept),
        out_of_order=merged.out_of_order,
        skipped=_skipped(streams, merged),
        gps_origin=streams.poses.origin_used if streams.poses else None,
        camera=streams.camera,
        config=bag_config(streams, options, robot, bag),
    )


def read_bag_log(bag: str | Path, options: ImportOptions, progress: bool | None = None) -> WheelLog:
    """Return the wheel log ``terrain-odom import`` would write, in memory (direct use of a bag).

    Options as for ``terrain-odom import``, without an image topic (frames need
    a folder: import them).

    Raises
    ------
    InputFileError, ConfigError
        As :func:`read_bag`.
    """
    if options.image_topic is not None:
        raise ConfigError("a bag's frames need a folder: import it (terrain-odom import)")
    return _read(bag, options, check_options(options), None, progress)[1].log


def _read(
    bag: str | Path,
    options: ImportOptions,
    robot: dict[str, float | None],
    out_dir: Path | None,
    progress: bool | None,
) -> tuple[BagStreams, MergedLog]:
    """Read the bag's selected topics in one pass (frames written into ``out_dir``); merge the log."""
    with open_bag(bag) as reader:
        connections, streams = _plan(reader, bag, options, robot)
        if out_dir is not None and options.image_topic is not None:
            (out_dir / FRAMES_DIR).mkdir(exist_ok=True)
        for message in stream_messages(reader, bag, connections, progress):
            _dispatch(streams, message, options, out_dir)
    return streams, _merge(streams, options, bag)


def check_options(options: ImportOptions) -> dict[str, float | None]:
    """Check the options; return the robot geometry: ``track_width``, ``wheel_radius`` (m or None).

    The options' geometry, else the configuration's (if one is given).

    Raises
    ------
    ConfigError
        An option outside its range, an invalid configuration.
    """
    _check_ranges(options)
    return _robot(options)


def _check_ranges(options: ImportOptions) -> None:
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
    config = load_config(options.config_path) if options.config_path is not None else None
    return {
        "track_width": options.track_width or (config.robot.track_width if config else None),
        "wheel_radius": options.wheel_radius or (config.robot.wheel_radius if config else None),
    }


def _plan(
    reader: Any, bag: str | Path, options: ImportOptions, robot: dict[str, float | None]
) -> tuple[list[Any], BagStreams]:
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
    return connections, BagStreams(
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
    streams: BagStreams, message: BagMessage, options: ImportOptions, out_dir: Path | None
) -> None:
    """Hand one message to the stream of its topic (a topic may serve several roles)."""
    topic = message.topic
    if topic == options.wheels_topic:
        streams.wheels.add(message)
    if topic == options.pose_topic and streams.poses is not None:
        streams.poses.add(message)
    if topic == options.heading_topic and streams.headings is not None:
        streams.headings.add(message)
    if topic == options.image_topic and out_dir is not None:
        _frame(streams, message, options, out_dir)
    if message.msgtype == CAMERA_INFO and streams.camera is None:
        streams.camera = intrinsics(message.msg)
        streams.camera_topic = topic
    if topic == TF_STATIC and message.msgtype == TF_MESSAGE:
        for tr in message.msg.transforms:
            pair = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
            _add_static(streams, pair, tr.transform)


def _add_static(streams: BagStreams, pair: tuple[str, str], transform: Any) -> None:
    """Keep one ``/tf_static`` transform, refusing what makes no tree of frames.

    Raises
    ------
    InputFileError
        A rotation that is no quaternion (zero, not finite), a frame with
        two parents, or a loop of frames.
    """
    parent, child = pair
    where = f"{streams.bag}: {TF_STATIC} {parent} -> {child}"
    q = transform.rotation
    norm = math.hypot(q.x, q.y, q.z, q.w)
    if not (math.isfinite(norm) and norm > 1e-9):
        raise InputFileError(f"{where}: the rotation ({q.x}, {q.y}, {q.z}, {q.w}) is no quaternion")
    parents = {c: p for p, c in streams.static if (p, c) != pair}
    if child in parents and parents[child] != parent:
        raise InputFileError(
            f"{where}: {child} has another parent, {parents[child]}; a frame has one parent"
        )
    ancestor: str | None = parent
    while ancestor is not None:
        if ancestor == child:
            raise InputFileError(f"{where}: closes a loop of frames ({child} is above {parent})")
        ancestor = parents.get(ancestor)
    streams.static[pair] = transform_matrix(transform)


def _frame(streams: BagStreams, message: BagMessage, options: ImportOptions, out_dir: Path) -> None:
    """Write one image message as ``frames/NNNNNN.<format>`` and remember its stamp."""
    stamp = StampRule(options.stamps).of(message)
    if stamp is None:
        streams.images_unstamped += 1
        return
    if streams.image_frame is None:
        streams.image_frame = message.msg.header.frame_id.lstrip("/")
    name = f"frames/{len(streams.images):06d}.{options.image_format}"
    where = f"{streams.bag}: --image-topic {message.topic}"
    write_frame(message.msg, message.msgtype, out_dir / name, options.image_format, where)
    streams.images.append((stamp, name))


def _merge(streams: BagStreams, options: ImportOptions, bag: str | Path) -> MergedLog:
    """Merge the streams into the wheel log (raising if the wheels topic gave nothing usable)."""
    wheels = streams.wheels.wheel_rows()
    if len(wheels) == 0:
        raise InputFileError(
            f"{streams.wheels.where}: no message with a usable stamp "
            f"({_skips(streams.wheels.skipped)})"
        )
    poses = None
    if streams.poses is not None and options.pose_topic is not None:
        poses = streams.poses.pose_rows(streams.types[options.pose_topic])
    headings = streams.headings.heading_rows() if streams.headings else None
    return merge_streams(wheels, poses, headings, max_gap=options.max_gap, source=str(bag))


def _skips(skipped: dict[str, int]) -> str:
    return "; ".join(f"{n} {reason}" for reason, n in skipped.items()) or "none"


def _skipped(streams: BagStreams, merged: MergedLog) -> dict[str, dict[str, int]]:
    """Return the messages skipped by reason, per topic (``merge``: rows merging dropped)."""
    skipped = {"merge": merged.dropped}
    for stream in (streams.wheels, streams.poses, streams.headings):
        if stream is not None and stream.skipped:
            skipped[stream.where.split(": ", 1)[1]] = dict(stream.skipped)
    if streams.images_unstamped:
        skipped["--image-topic"] = {"header stamp 0 (unset)": streams.images_unstamped}
    return {k: v for k, v in skipped.items() if v}
