"""``terrain-odom patches``: labelled training patches from a recording."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from terrain_odom.cli.options import (
    add_config_option,
    add_log_options,
    add_out_option,
    add_wheels_option,
    config_edits,
    horizon_option,
    print_config,
    print_written,
)

if TYPE_CHECKING:
    from terrain_odom.app.inputs import ConfigEdits
    from terrain_odom.app.patches import PatchesResult

_REASONS = {
    "before_first_wheel_sample": "before the first wheel sample",
    "after_last_wheel_sample": "after the last wheel sample",
    "roi_clipped": "region partly outside the image",
    "roi_outside": "region outside the image",
    "roi_too_small": "region smaller than roi.min_size",
    "not_reached": "region not reached before the log (segment) ends",
    "unlabelled": "no label where the robot reaches the region",
    "missing_or_unreadable": "frame missing or unreadable",
}


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``patches`` subcommand."""
    p = sub.add_parser(
        "patches",
        help="cut labelled training patches (the ground ahead) from a recording's frames",
    )
    p.add_argument(
        "--images",
        required=True,
        help="folder of camera frames (frames.csv with t,file, or images named by their time in s)",
    )
    add_wheels_option(p, "wheel log CSV of the recording", old=())
    add_out_option(
        p,
        "training folder (created): LABEL/FRAME.png and patches.json, what 'terrain-odom "
        "train --images' reads",
        required=True,
    )
    labels = p.add_mutually_exclusive_group()
    labels.add_argument("--label", help="one terrain label for the whole recording")
    labels.add_argument(
        "--labels",
        metavar="INTERVALS.csv",
        help="terrain per time interval (CSV t_start,t_end,label); default: the log's "
        "terrain column",
    )
    add_config_option(
        p,
        "project configuration: camera, roi, robot, ekf (default: IMAGES/config.yaml if "
        "--images has one, else built-in defaults)",
    )
    p.add_argument(
        "--horizon",
        metavar="H",
        help="predict the region this long ahead, a duration like 2s (default: the "
        "configuration's roi.horizon, as run; longer puts it further into the image)",
    )
    existing = p.add_mutually_exclusive_group()
    existing.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the patches already in --out (those its patches.json lists)",
    )
    existing.add_argument(
        "--append",
        action="store_true",
        help="add this recording's patches to those already in --out (e.g. one recording "
        "per terrain)",
    )
    add_log_options(p)
    p.set_defaults(func=_cmd_patches)


def _edits(args: argparse.Namespace) -> ConfigEdits:
    """Return the command line's edits of the configuration: ``--horizon`` its ``roi.horizon``."""
    from terrain_odom.errors import ConfigError

    horizon = horizon_option(args.horizon, durations=True)
    if horizon is not None and horizon.unit != "s":
        raise ConfigError(
            f"--horizon: the region is predicted a duration ahead, like 2s; got {args.horizon!r}"
        )
    return config_edits(args, roi_horizon=None if horizon is None else horizon.value)


def _cmd_patches(args: argparse.Namespace) -> int:
    from terrain_odom.app.patches import make_patches

    result = make_patches(
        args.images,
        args.wheels,
        args.out,
        label=args.label,
        intervals=args.labels,
        config_path=args.config,
        edits=_edits(args),
        overwrite=args.overwrite,
        append=args.append,
    )
    print_config(result.config)
    _print_result(result)
    return 0


def _print_result(result: PatchesResult) -> None:
    """Print the patches written per label, the frames skipped per reason, the files."""
    source = {"label": "--label", "intervals": "--labels", "log": "the log's terrain column"}
    total = sum(result.counts.values())
    per_label = ", ".join(f"{k} {v}" for k, v in result.counts.items()) or "none"
    print(
        f"{total} patches from {result.frames} frames in {result.seconds:.2f} s: {per_label} "
        f"(labels: {source[result.label_source]}, where the robot reaches the region)"
    )
    for i, (reason, n) in enumerate(result.skipped.items()):
        print(f"{'skipped:' if i == 0 else '':<12}{n} {_REASONS[reason]} ({reason})")
    if result.total != result.counts:
        print(f"in --out:   {', '.join(f'{k} {v}' for k, v in result.total.items())}")
    print_written("patches:", [result.out_dir / label for label in result.total])
    print_written("report:", [result.patches_json])
