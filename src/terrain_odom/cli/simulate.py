"""``terrain-odom simulate``: write a simulated run with ground truth."""

from __future__ import annotations

import argparse
import math
from typing import Any

from terrain_odom.cli.options import (
    add_config_option,
    add_out_option,
    check_seed,
    load_config_option,
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``simulate`` subcommand."""
    p = sub.add_parser(
        "simulate", help="simulate a run: wheel log, camera frames, ground truth, training patches"
    )
    add_out_option(p, "output directory (created; files overwritten)", required=True)
    p.add_argument("--scenario", default="chen2023", help="scenario name (default: chen2023)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.add_argument("--duration", type=float, help="seconds to simulate (default: the scenario's)")
    p.add_argument(
        "--pose-rate", type=float, help="GPS-like pose rate, Hz (default: the scenario's)"
    )
    p.add_argument(
        "--pose-noise",
        type=float,
        nargs=2,
        metavar=("XY_M", "YAW_RAD"),
        help="pose measurement noise std: position (m) and yaw (rad) (default: the scenario's)",
    )
    p.add_argument(
        "--antenna",
        type=float,
        nargs=2,
        metavar=("X_M", "Y_M"),
        help="GPS antenna in the robot frame, m (x forward, y left): the logged positions are "
        "the antenna's; written to config.yaml pose_sensor (default 0 0)",
    )
    p.add_argument(
        "--heading-offset",
        type=float,
        metavar="RAD",
        help="IMU mounting: logged yaw minus the true yaw, rad; written to config.yaml "
        "pose_sensor (default 0)",
    )
    p.add_argument(
        "--frame-rate", type=float, help="camera frame rate, Hz (default: the scenario's)"
    )
    add_config_option(p, "YAML configuration: its camera and robot sections replace the scenario's")
    p.add_argument(
        "--frame-format",
        choices=("png", "jpg"),
        default="png",
        help="image format of the frames and map preview: png (lossless, default) or "
        "jpg (JPEG quality 90, about 6x smaller)",
    )
    p.add_argument("--no-frames", action="store_true", help="do not render camera frames")
    p.add_argument("--no-patches", action="store_true", help="do not render training patches")
    p.set_defaults(func=_cmd_simulate)


def _scenario_changes(args: argparse.Namespace) -> dict[str, Any]:
    """Return the scenario fields the options change (checked: one-line ConfigError)."""
    from terrain_odom.config.sections import MAX_ANTENNA_OFFSET
    from terrain_odom.errors import ConfigError

    changes = {
        "duration": args.duration,
        "pose_rate": args.pose_rate,
        "frame_rate": args.frame_rate,
    }
    for name, value in changes.items():
        if value is not None and not 0.0 < value < float("inf"):
            raise ConfigError(f"--{name.replace('_', '-')} must be finite and > 0, got {value}")
    given: dict[str, Any] = {k: v for k, v in changes.items() if v is not None}
    if args.pose_noise is not None:
        if not all(0.0 <= value < float("inf") for value in args.pose_noise):
            raise ConfigError(f"--pose-noise must be two finite values >= 0, got {args.pose_noise}")
        given.update(zip(("sigma_xy", "sigma_yaw"), args.pose_noise, strict=True))
    if args.antenna is not None:
        if not all(abs(value) <= MAX_ANTENNA_OFFSET for value in args.antenna):
            raise ConfigError(
                f"--antenna X Y: metres within +-{MAX_ANTENNA_OFFSET:g}, got {args.antenna}"
            )
        given["antenna"] = tuple(args.antenna)
    if args.heading_offset is not None:
        if not abs(args.heading_offset) <= math.pi:
            raise ConfigError(
                f"--heading-offset: radians within +-pi, got {args.heading_offset} (degrees?)"
            )
        given["heading_offset"] = args.heading_offset
    return given


def _cmd_simulate(args: argparse.Namespace) -> int:
    import dataclasses

    from terrain_odom.app.simulate import write_simulation
    from terrain_odom.sim import get_scenario, simulate

    seed = check_seed(args.seed)
    scenario = dataclasses.replace(get_scenario(args.scenario), **_scenario_changes(args))
    robot = camera = None
    if args.config is not None:
        config = load_config_option(args)
        robot, camera = config.robot, config.camera
    sim = simulate(scenario, seed, robot=robot, camera=camera)
    out = write_simulation(
        sim,
        args.out,
        frames=not args.no_frames,
        patches=not args.no_patches,
        frame_format=args.frame_format,
        inputs=(args.config,),
    )
    print(f"scenario {scenario.name} (seed {seed}): {scenario.description}")
    print(f"wheel log:    {out.log_csv} ({out.rows} rows, {out.pose_rows} poses)")
    print(f"ground truth: {out.groundtruth_csv}")
    if out.frames_csv is not None:
        print(f"frames:       {out.frames_csv} ({out.frames} frames)")
    if out.patches_dir is not None:
        counts = ", ".join(f"{k} {v}" for k, v in out.patches.items())
        print(f"patches:      {out.patches_dir} ({counts})")
    print(f"config:       {out.config_yaml}")
    print(f"map preview:  {out.map_preview}")
    print(f"map plot:     {out.map_plot}")
    print(f"metadata:     {out.metadata_json}")
    return 0
