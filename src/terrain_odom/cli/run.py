"""``terrain-odom run``: EKF odometry over a wheel log."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from terrain_odom.cli.bag_import import add_bag_topic_options, wheels_from_bag
from terrain_odom.cli.options import (
    add_config_option,
    add_log_options,
    add_option,
    add_out_option,
    add_wheels_option,
    config_edits,
    find_input,
    print_calibration,
    print_config,
    print_pose_delay,
    print_written,
)

if TYPE_CHECKING:
    from terrain_odom.app.run import RunOptions
    from terrain_odom.reporting.run_report import FrameCounts


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``run`` subcommand."""
    p = sub.add_parser("run", help="EKF odometry over a wheel log (terrain-adaptive)")
    add_wheels_option(
        p, "wheel log CSV, or a ROS bag with --wheels-topic", old=()
    )  # run never had --log
    add_out_option(p, "output folder (created; one run per folder)", required=True)
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the run already in --out (its files are removed first; other files kept)",
    )
    p.add_argument(
        "--record",
        action="store_true",
        help="also write OUT/run.rrd, the run as a Rerun recording to scrub through: frames "
        "with their region and votes, path, states, terrain (needs terrain-odom[viz])",
    )
    add_config_option(
        p,
        "project configuration (default: IMAGES/config.yaml if --images has one, "
        "else built-in defaults)",
    )
    p.add_argument(
        "--images",
        help="folder of camera frames (frames.csv with t,file, or images named by their "
        "time in s): their classified terrain drives the reset; writes OUT/frames.csv",
    )
    add_option(
        p,
        "--classifier",
        "--model",
        metavar="FILE_OR_DIR",
        help="terrain classifier model, or the --out folder of 'terrain-odom train' "
        "(default: the model shipped with the package)",
    )
    p.add_argument(
        "--no-roi", action="store_true", help="classify whole frames, not the region of interest"
    )
    p.add_argument(
        "--groundtruth",
        help="ground truth CSV (t,x,y,yaw,y_l,y_r,x_icr,terrain; a simulated run's "
        "groundtruth.csv): scores the run and writes report.md and plots/*.png",
    )
    p.add_argument(
        "--no-plots", action="store_true", help="do not draw the plots (a faster start-up)"
    )
    p.add_argument(
        "--reset-at",
        choices=("arrival", "immediate"),
        help="when a camera-confirmed terrain change resets the filter (default: the "
        "configuration's terrain.reset_at, 'arrival')",
    )
    p.add_argument(
        "--estimator",
        choices=("icr-ekf", "slip-ekf"),
        default="icr-ekf",
        help="icr-ekf: EKF over pose and ICRs (default); slip-ekf: EKF over the slip "
        "parameters of the ICR functions, for low-rate or heading-only pose",
    )
    p.add_argument(
        "--priors",
        metavar="FILE_OR_DIR",
        help="offline ICRs from 'terrain-odom fit --model icr|icr-slip' (its parameter file "
        "or --out folder; icr-ekf only): the "
        "filter starts from them and, with --by-terrain sets, takes a terrain's set on "
        "each confirmed change to it (covariance ekf.sigma_prior)",
    )
    add_log_options(p)
    add_bag_topic_options(p)
    terrain = p.add_mutually_exclusive_group()
    terrain.add_argument(
        "--terrain-from-log",
        action="store_true",
        help="drive the covariance reset from the log's terrain column (required to exist)",
    )
    terrain.add_argument(
        "--no-terrain", action="store_true", help="ignore terrain labels (plain ICR EKF)"
    )
    p.set_defaults(func=_cmd_run)


def _options(args: argparse.Namespace, bag_config: str | None) -> RunOptions:
    """Return the run's options as given: nothing chosen here (the app says what it chose)."""
    from terrain_odom.app.inputs import TerrainSource
    from terrain_odom.app.run import RunOptions

    if args.no_terrain:
        source = TerrainSource.NONE
    elif args.terrain_from_log:
        source = TerrainSource.LOG
    else:
        source = TerrainSource.AUTO
    return RunOptions(
        config_path=args.config,
        imported_config=bag_config,
        edits=config_edits(args, reset_at=args.reset_at),
        terrain=source,
        images=args.images,
        classifier_path=find_input(args.classifier, "*.npz", "classifier model"),
        use_roi=not args.no_roi,
        groundtruth=args.groundtruth,
        estimator=args.estimator,
        priors=find_input(args.priors, "params_*.yaml", "parameter file"),
        overwrite=args.overwrite,
        record=args.record,
        plots=not args.no_plots,
    )


def _cmd_run(args: argparse.Namespace) -> int:
    from terrain_odom.app.inputs import DEFAULT
    from terrain_odom.app.record import require_rerun
    from terrain_odom.app.run import run
    from terrain_odom.app.run_folder import check_folder
    from terrain_odom.errors import ConfigError

    if args.images is not None and args.terrain_from_log:
        raise ConfigError("--images and --terrain-from-log exclude each other")
    if args.record:
        require_rerun()  # before a bag is imported
    if (
        args.wheels_topic is not None
    ):  # a bag is imported into OUT/bag/: refuse a run's folder first
        check_folder(args.out, overwrite=args.overwrite)
    wheels, bag_config = wheels_from_bag(args, args.out)
    summary = run(wheels, args.out, _options(args, bag_config))
    report = summary.report
    print_config(summary.config)
    if summary.classifier is not None and summary.classifier.how == DEFAULT:
        print(f"model:      {summary.classifier.path} (default; --classifier to change)")
    print_pose_delay(report.time_calibration)
    print_calibration(summary.calibration)
    print(f"{report.counts.rows} rows in {report.run_time_s:.2f} s")
    print(f"pose:       {report.counts.pose_components.summary()}")
    if summary.outage_guard is not None:
        for line in summary.outage_guard.lines():
            print(f"outages:    {line}")
    for warning in report.warnings:
        print(f"warning:    {warning}")
    if report.frames is not None and report.frames.counts is not None:
        _print_frames(report.frames.counts)
    if summary.unused_priors:
        unused = ", ".join(summary.unused_priors)
        print(f"priors never used: {unused} (no such terrain in this run)")
    print_written("trajectory:", [summary.trajectory_csv, summary.trajectory_tum])
    print_written("frames:", [summary.frames_csv])
    print_written("report:", [summary.report_json, summary.report_md])
    print_written("run config:", [summary.config_yaml])
    print_written("plots:", list(summary.plots))
    print_written("recording:", [summary.recording])
    return 0


def _print_frames(counts: FrameCounts) -> None:
    """Print how many frames were used, and which were skipped and why."""
    reasons = [
        f"{n} {why}"
        for n, why in (
            (counts.before, "before the first wheel sample"),
            (counts.after, "after the last"),
            (len(counts.problems), "missing or unreadable"),
        )
        if n
    ]
    skipped = f" (skipped: {', '.join(reasons)})" if reasons else ""
    print(f"{counts.classified} of {counts.total} frames classified{skipped}")
    for problem in counts.problems:
        print(f"  skipped {problem}")
