"""``terrain-odom import``: convert a ROS bag into a wheel log, frames and a configuration.

Also the bag options other subcommands share to read a bag where they read
a wheel log (``run``, ``fit`` and ``evaluate`` with ``--wheels BAG
--wheels-topic ...``): the same import code, into ``OUT/bag/``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from terrain_odom.cli.options import add_config_option, print_written
from terrain_odom.io.bag.options import ImportOptions  # light: no rosbags


def add_bag_topic_options(p: argparse.ArgumentParser, *, wheels_required: bool = False) -> None:
    """Add the options that read a log out of a bag: topics, geometry, joints, stamps, gaps."""
    p.add_argument(
        "--wheels-topic",
        required=wheels_required,
        help="sensor_msgs/JointState, nav_msgs/Odometry or geometry_msgs/TwistStamped"
        + ("" if wheels_required else " (when --wheels is a ROS bag)"),
    )
    p.add_argument(
        "--pose-topic",
        help="nav_msgs/Odometry, geometry_msgs/PoseStamped, PoseWithCovarianceStamped, "
        "/tf (with --pose-frames) or sensor_msgs/NavSatFix (local east-north metres)",
    )
    p.add_argument("--heading-topic", help="sensor_msgs/Imu: its orientation's yaw")
    p.add_argument(
        "--track-width",
        type=float,
        help="m: the diff-drive controller's wheel separation (converts a body twist)",
    )
    p.add_argument("--wheel-radius", type=float, help="m: converts JointState velocities")
    p.add_argument(
        "--left-joints",
        nargs="+",
        default=["*left*"],
        metavar="PATTERN",
        help="JointState joints of the left side (shell patterns, averaged; default *left*)",
    )
    p.add_argument(
        "--right-joints",
        nargs="+",
        default=["*right*"],
        metavar="PATTERN",
        help="JointState joints of the right side (default *right*)",
    )
    p.add_argument(
        "--pose-frames", nargs=2, metavar=("PARENT", "CHILD"), help="frames of the /tf pose"
    )
    p.add_argument(
        "--gps-origin",
        nargs=3,
        type=float,
        metavar=("LAT", "LON", "ALT"),
        help="origin of the east-north frame of a NavSatFix topic (default: the first fix)",
    )
    p.add_argument(
        "--stamps",
        choices=("header", "receive"),
        default="header",
        help="message header stamps (default) or the bag's receive times",
    )
    p.add_argument(
        "--max-gap",
        type=float,
        default=0.5,
        help="s: a longer gap between wheel messages starts a new segment (default 0.5)",
    )


def _options(args: argparse.Namespace, wheels_topic: str) -> ImportOptions:
    """Return the :class:`~terrain_odom.io.bag.options.ImportOptions` of parsed arguments."""
    return ImportOptions(
        wheels_topic=wheels_topic,
        pose_topic=args.pose_topic,
        heading_topic=args.heading_topic,
        image_topic=getattr(args, "image_topic", None),
        camera_info_topic=getattr(args, "camera_info_topic", None),
        track_width=args.track_width,
        wheel_radius=args.wheel_radius,
        left_joints=tuple(args.left_joints),
        right_joints=tuple(args.right_joints),
        pose_frames=tuple(args.pose_frames) if args.pose_frames else None,
        base_frame=getattr(args, "base_frame", "base_link"),
        gps_origin=tuple(args.gps_origin) if args.gps_origin else None,
        stamps=args.stamps,
        max_gap=args.max_gap,
        image_format=getattr(args, "image_format", "jpg"),
        config_path=args.config,
    )


def wheels_from_bag(args: argparse.Namespace, out_dir: str) -> tuple[str, str | None]:
    """Return the wheel log (and configuration) to use: ``--wheels`` itself, or its import if a bag.

    A bag given to ``--wheels`` is imported into ``OUT/bag/`` (the files
    named on the console) with the bag options; the import's
    ``config.yaml`` is the configuration when ``--config`` is not given.

    Raises
    ------
    ConfigError
        A bag without ``--wheels-topic``, or ``--wheels-topic`` with a wheel log.
    """
    logs, config = logs_from_bags([args.wheels], args, out_dir)
    return logs[0], config


def logs_from_bags(
    paths: Sequence[str], args: argparse.Namespace, out_dir: str | Path
) -> tuple[list[str], str | None]:
    """Return the wheel logs to use for ``paths`` and the configuration an import gives.

    :func:`terrain_odom.app.bag_import.logs_from_bags` with the bag options
    of ``args``, each import printed as it is written.
    """
    from terrain_odom.app.bag_import import logs_from_bags as import_logs

    topic = args.wheels_topic
    options = _options(args, topic) if topic is not None else None
    return import_logs(paths, options, out_dir, _print_import)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``import`` subcommand."""
    p = sub.add_parser(
        "import",
        help="import a ROS bag: log.csv, frames/, frames.csv, config.yaml, import.json in --out",
    )
    p.add_argument("bag", metavar="BAG", help="ROS 1 .bag file, ROS 2 bag folder or .mcap file")
    p.add_argument("--out", required=True, help="output folder (created)")
    add_bag_topic_options(p, wheels_required=True)
    p.add_argument("--image-topic", help="sensor_msgs/Image or CompressedImage: camera frames")
    p.add_argument(
        "--camera-info-topic",
        help="sensor_msgs/CameraInfo (default: the image topic's sibling camera_info, if present)",
    )
    p.add_argument(
        "--base-frame",
        default="base_link",
        help="the robot's frame: the mountings are read from /tf_static as the frames of the "
        "image, the pose sensor (GPS antenna) and the Imu in it (default base_link)",
    )
    p.add_argument(
        "--image-format", choices=("jpg", "png"), default="jpg", help="frame files (default jpg)"
    )
    add_config_option(p, "project configuration to start DIR/config.yaml from (robot geometry)")
    p.set_defaults(func=_cmd_import)


def _cmd_import(args: argparse.Namespace) -> int:
    from terrain_odom.app.bag_import import import_bag

    _print_import(import_bag(args.bag, args.out, _options(args, args.wheels_topic)))
    return 0


def _print_import(result: Any) -> None:
    """Print what an import wrote and counted (an :class:`ImportResult`)."""
    print(
        f"{result.rows} rows over {result.duration:.1f} s ({result.segments} segment"
        f"{'s' if result.segments != 1 else ''}): {result.pose_rows} with x, y, "
        f"{result.heading_rows} with yaw; {result.frames} frames; {result.seconds:.2f} s"
    )
    for where, reasons in result.skipped.items():
        for reason, n in reasons.items():
            print(f"skipped:    {n} {reason} ({where})")
    mounting = [key for key, source in result.sources.items() if source.startswith("/tf_static")]
    if mounting:
        print(f"mounting:   {', '.join(mounting)} from /tf_static (in {result.config_yaml})")
    if result.fill_keys:
        print(f"fill in:    {', '.join(result.fill_keys)} (in {result.config_yaml})")
    print_written("log:", [result.log_csv])
    print_written("frames:", [result.frames_csv])
    print_written("config:", [result.config_yaml])
    print_written("report:", [result.import_json])
