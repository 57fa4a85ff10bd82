"""``terrain-odom patches``: labelled training patches from a recording."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from terrain_odom.cli.options import (
    add_config_option,
    add_log_options,
    add_out_option,
    add_wheels_option,
    horizon_option,
    load_config_option,
    print_written,
)

if TYPE_CHECKING:
    from terrain_odom.app.patches import PatchesResult
    from terrain_odom.config import Config

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


def _config(args: argparse.Namespace) -> tuple[Config, str | None]:
    """Return the configuration (``--horizon`` applied) and its file."""
    import dataclasses

    from terrain_odom.app.run import images_config
    from terrain_odom.errors import ConfigError

    path = args.config
    if path is None:
        found = images_config(args.images)
        if found is not None:
            path = str(found)
            print(f"config:     {path} (found in the --images folder; --config to change)")
    cfg = load_config_option(args, path)
    horizon = horizon_option(args.horizon, durations=True)
    if horizon is not None:
        if horizon.unit != "s":
            raise ConfigError(
                f"--horizon: the region is predicted a duration ahead, like 2s; got {args.horizon!r}"
            )
        cfg = dataclasses.replace(cfg, roi=dataclasses.replace(cfg.roi, horizon=horizon.value))
    return cfg, path


def _cmd_patches(args: argparse.Namespace) -> int:
    from terrain_odom.app.patches import make_patches

    cfg, path = _config(args)
    result = make_patches(
        args.images,
        args.wheels,
        args.out,
        label=args.label,
        intervals=args.labels,
        config=cfg,
        config_path=path,
        overwrite=args.overwrite,
        append=args.append,
    )
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
    print_written("patches:", [result.out / label for label in result.total])
    print_written("report:", [result.patches_json])
