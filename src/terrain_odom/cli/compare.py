"""``terrain-odom compare``: fit every kinematic model and tabulate held-out errors."""

from __future__ import annotations

import argparse

from terrain_odom.cli.options import (
    MODEL_CHOICES,
    add_fit_options,
    add_out_option,
    fit_arguments,
    print_pose_delays,
    print_written,
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``compare`` subcommand."""
    p = sub.add_parser("compare", help="fit every kinematic model, compare held-out errors")
    add_fit_options(p)
    p.add_argument(
        "--eval", nargs="+", required=True, metavar="LOG", help="held-out logs (with poses)"
    )
    p.add_argument(
        "--models",
        nargs="+",
        choices=MODEL_CHOICES,
        help="models to compare (default: all)",
    )
    add_out_option(
        p, "folder (created) for compare.md, compare.json, compare.png, params_MODEL.yaml"
    )
    p.set_defaults(func=_cmd_compare)


def _cmd_compare(args: argparse.Namespace) -> int:
    from terrain_odom.app.fit import compare

    report = compare(
        args.wheels, args.eval, out_dir=args.out, models=args.models, **fit_arguments(args)
    )
    print_pose_delays(report.time_calibration)
    print(report.markdown, end="")
    print_written("written:", list(report.outputs))
    return 0
