"""``terrain-odom degrade``: a consumer GPS + IMU recording made from a log with true poses."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from terrain_odom.cli.options import (
    add_config_option,
    add_out_option,
    add_wheels_option,
    check_seed,
    load_config_option,
)

if TYPE_CHECKING:
    from terrain_odom.sim.degrade import Degradation


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``degrade`` subcommand."""
    p = sub.add_parser(
        "degrade",
        help="a realistic GPS + IMU recording (sparse noisy fixes, latency, lever arm, "
        "mounted and disturbed heading) from a log whose poses are the truth",
    )
    add_wheels_option(
        p, "wheel log whose poses are the truth (e.g. lidar ICP, a simulation)", old=()
    )
    add_config_option(
        p, "YAML configuration of the robot (wheel radius; written back with the claimed noise)"
    )
    add_out_option(p, "output folder: log.csv, truth.csv, config.yaml, degrade.yaml", required=True)
    p.add_argument("--overwrite", action="store_true", help="replace this command's files in --out")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    gps = p.add_argument_group("GPS")
    gps.add_argument(
        "--gps-rate",
        type=float,
        default=2.5,
        metavar="HZ",
        help="fixes per second; 0: none (default 2.5)",
    )
    gps.add_argument(
        "--gps-noise",
        type=float,
        default=0.8,
        metavar="M",
        help="white noise std per axis (default 0.8)",
    )
    gps.add_argument(
        "--gps-walk",
        type=float,
        default=0.05,
        metavar="M_PER_SQRT_S",
        help="random-walk bias (default 0.05)",
    )
    gps.add_argument(
        "--latency",
        type=float,
        default=0.5,
        metavar="S",
        help="a fix stamped t was taken at t - latency (default 0.5)",
    )
    gps.add_argument(
        "--antenna",
        type=float,
        nargs=2,
        default=(-1.0, 0.0),
        metavar=("X_M", "Y_M"),
        help="antenna in the robot frame, x forward, y left (default -1 0)",
    )
    gps.add_argument(
        "--gps-claimed",
        type=float,
        metavar="M",
        help="position std the messages claim (default: --gps-noise)",
    )
    imu = p.add_argument_group("IMU heading")
    imu.add_argument(
        "--imu-rate",
        type=float,
        default=50.0,
        metavar="HZ",
        help="headings per second; 0: none (default 50)",
    )
    imu.add_argument(
        "--heading-offset",
        type=float,
        default=2.7,
        metavar="RAD",
        help="heading minus the robot's yaw, the mounting (default 2.7)",
    )
    imu.add_argument(
        "--heading-wander",
        type=float,
        default=0.26,
        metavar="RAD",
        help="std of the slow disturbance (default 0.26)",
    )
    imu.add_argument(
        "--wander-time",
        type=float,
        default=30.0,
        metavar="S",
        help="time constant of the disturbance (default 30)",
    )
    imu.add_argument(
        "--heading-noise",
        type=float,
        default=0.02,
        metavar="RAD",
        help="white noise std (default 0.02)",
    )
    imu.add_argument(
        "--heading-claimed",
        type=float,
        default=0.035,
        metavar="RAD",
        help="heading std the messages claim (default 0.035, 2 deg)",
    )
    imu.add_argument(
        "--imu-latency", type=float, default=0.0, metavar="S", help="IMU latency (default 0)"
    )
    p.set_defaults(func=_cmd_degrade)


def _degradation(args: argparse.Namespace) -> Degradation:
    """Return the degradation the options describe (checked: one-line ConfigError)."""
    from terrain_odom.sim.degrade import Degradation

    return Degradation(
        gps_rate=args.gps_rate,
        gps_noise=args.gps_noise,
        gps_walk=args.gps_walk,
        latency=args.latency,
        antenna=(args.antenna[0], args.antenna[1]),
        gps_claimed=args.gps_claimed,
        imu_rate=args.imu_rate,
        heading_offset=args.heading_offset,
        heading_wander=args.heading_wander,
        wander_time=args.wander_time,
        heading_noise=args.heading_noise,
        heading_claimed=args.heading_claimed,
        imu_latency=args.imu_latency,
        seed=check_seed(args.seed),
    )


def _cmd_degrade(args: argparse.Namespace) -> int:
    from terrain_odom.app.degrade import DEGRADE_FILES, write_degraded

    out = write_degraded(
        args.wheels,
        load_config_option(args),
        _degradation(args),
        args.out,
        config_path=args.config,
        overwrite=args.overwrite,
    )
    print(f"{out.rows} rows: {out.fixes} GPS fixes, {out.headings} IMU headings")
    for i, name in enumerate(DEGRADE_FILES):
        print(f"{'written:' if i == 0 else '':<12}{out.path(name)}")
    return 0
