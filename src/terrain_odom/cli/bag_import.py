"""``terrain-odom import``: convert a ROS bag into a wheel log, frames and a configuration."""

from __future__ import annotations

import argparse

from terrain_odom.cli.options import add_config_option, print_written


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``import`` subcommand."""
    p = sub.add_parser(
        "import",
        help="import a ROS bag: log.csv, frames/, frames.csv, config.yaml, import.json in --out",
    )
    p.add_argument("bag", metavar="BAG", help="ROS 1 .bag file, ROS 2 bag folder or .mcap file")
    p.add_argument("--out", required=True, help="output folder (created)")
    p.add_argument(
        "--wheels-topic",
        required=True,
        help="sensor_msgs/JointState, nav_msgs/Odometry or geometry_msgs/TwistStamped",
    )
    p.add_argument(
        "--pose-topic",
        help="nav_msgs/Odometry, geometry_msgs/PoseStamped, PoseWithCovarianceStamped, "
        "/tf (with --pose-frames) or sensor_msgs/NavSatFix (local east-north metres)",
    )
    p.add_argument("--heading-topic", help="sensor_msgs/Imu: its orientation's yaw")
    p.add_argument("--image-topic", help="sensor_msgs/Image or CompressedImage: camera frames")
    p.add_argument(
        "--camera-info-topic",
        help="sensor_msgs/CameraInfo (default: the image topic's sibling camera_info, if present)",
    )
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
        "--base-frame",
        default="base_link",
        help="the robot's frame: the camera mounting is read from /tf_static as the image's "
        "frame in it (default base_link)",
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
    p.add_argument(
        "--image-format", choices=("jpg", "png"), default="jpg", help="frame files (default jpg)"
    )
    add_config_option(p, "project configuration to start DIR/config.yaml from (robot geometry)")
    p.set_defaults(func=_cmd_import)


def _cmd_import(args: argparse.Namespace) -> int:
    from terrain_odom.app.bag_import import ImportOptions, import_bag

    options = ImportOptions(
        wheels_topic=args.wheels_topic,
        pose_topic=args.pose_topic,
        heading_topic=args.heading_topic,
        image_topic=args.image_topic,
        camera_info_topic=args.camera_info_topic,
        track_width=args.track_width,
        wheel_radius=args.wheel_radius,
        left_joints=tuple(args.left_joints),
        right_joints=tuple(args.right_joints),
        pose_frames=tuple(args.pose_frames) if args.pose_frames else None,
        base_frame=args.base_frame,
        gps_origin=tuple(args.gps_origin) if args.gps_origin else None,
        stamps=args.stamps,
        max_gap=args.max_gap,
        image_format=args.image_format,
        config=args.config,
    )
    result = import_bag(args.bag, args.out, options)
    print(
        f"{result.rows} rows over {result.duration:.1f} s ({result.segments} segment"
        f"{'s' if result.segments != 1 else ''}): {result.pose_rows} with x, y, "
        f"{result.heading_rows} with yaw; {result.frames} frames; {result.seconds:.2f} s"
    )
    for where, reasons in result.skipped.items():
        for reason, n in reasons.items():
            print(f"skipped:    {n} {reason} ({where})")
    if result.fill_keys:
        print(f"fill in:    {', '.join(result.fill_keys)} (in {result.config_yaml})")
    print_written("log:", [result.log_csv])
    print_written("frames:", [result.frames_csv])
    print_written("config:", [result.config_yaml])
    print_written("report:", [result.import_json])
    return 0
