"""``terrain-odom calibrate``: find a robot's own pose sensors' delays, mounting and noise."""

from __future__ import annotations

import argparse
from pathlib import Path

from terrain_odom.app.calibration import robot_geometry
from terrain_odom.cli.bag_import import add_bag_topic_options, wheels_from_bag
from terrain_odom.cli.options import (
    add_config_option,
    add_out_option,
    add_wheels_option,
    print_calibration,
    print_pose_delay,
    print_written,
)
from terrain_odom.config import RobotConfig


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``calibrate`` subcommand."""
    p = sub.add_parser(
        "calibrate",
        help="find the pose sensors' delays, heading offset, antenna and noise from a log",
    )
    add_wheels_option(
        p, "wheel log CSV with positions and/or headings, or a ROS bag with --wheels-topic", old=()
    )
    add_config_option(p, "the robot's configuration to complete (default: built-in defaults)")
    add_out_option(
        p,
        "output folder: config.yaml (the configuration with the values found) and calibration.json",
        required=True,
    )
    add_bag_topic_options(p)
    p.set_defaults(func=_cmd_calibrate)


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from terrain_odom.app.calibrate import calibrate

    wheels, bag_config = wheels_from_bag(args, args.out)
    summary = calibrate(wheels, args.out, config_path=args.config, imported=bag_config)
    print(
        f"robot:      {robot_geometry(summary.robot)} ({_source(summary.config_path, summary.robot)})"
    )
    print_pose_delay(summary.timing)
    print_calibration(summary.calibration)
    print(f"{summary.rows} rows in {summary.seconds:.2f} s")
    print_written("config:", [summary.config_yaml])
    print_written("report:", [summary.report_json])
    return 0


def _source(config_path: Path | None, robot: RobotConfig) -> str:
    """Where the robot's geometry came from, for the console (the built-in defaults: say so)."""
    if config_path is None:
        return "the built-in defaults: --config gives the robot's"
    if robot == RobotConfig():  # a file without a robot section (or one giving the defaults)
        return f"the built-in defaults: {config_path} gives no other"
    return f"from {config_path}"
