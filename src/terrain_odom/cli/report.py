"""``terrain-odom report accuracy``: cross-validated confusion matrix of the terrain classifier."""

from __future__ import annotations

import argparse

from terrain_odom.cli.train import (
    add_classifier_options,
    classifier_config,
    describe,
    print_skipped,
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``report`` subcommand and its ``accuracy`` report."""
    p = sub.add_parser("report", help="reports on the terrain classifier")
    kinds = p.add_subparsers(dest="report", required=True)
    acc = kinds.add_parser(
        "accuracy",
        help="stratified k-fold confusion matrix, beside Chen et al.'s recipe",
    )
    add_classifier_options(acc)
    acc.add_argument("--folds", type=int, default=5, help="cross-validation folds (default 5)")
    acc.add_argument("--out", help="folder for accuracy.json, accuracy.csv, confusion.png")
    acc.set_defaults(func=_cmd_accuracy)


def format_table(cv, feature_ms: dict) -> list[str]:
    """Chen's Table 1 layout: rows = true class, row-normalised %, plus timing columns."""
    width = max(8, *(len(c) for c in cv.classes))
    corner = "true \\ predicted"
    head = f"{corner:<{width + 4}}" + "".join(f"{c:>{width}}" for c in cv.classes)
    lines = [head + f"{'images':>8}{'feat. ms mean':>15}{'max':>8}"]
    for i, name in enumerate(cv.classes):
        cells = "".join(f"{v:>{width}.1f}" for v in cv.percent[i])
        ms = feature_ms[name]
        lines.append(
            f"{name:<{width + 4}}{cells}{int(cv.confusion[i].sum()):>8}"
            f"{ms['mean']:>15.1f}{ms['max']:>8.1f}"
        )
    worst, worst_acc = cv.worst_class()
    lines.append(
        f"mean accuracy {cv.mean_accuracy:.1f} % (overall {cv.overall_accuracy:.1f} %, "
        f"worst class {worst} {worst_acc:.1f} %)"
    )
    return lines


def _cmd_accuracy(args: argparse.Namespace) -> int:
    from terrain_odom.training import report_accuracy

    report = report_accuracy(
        args.images, classifier_config(args), folds=args.folds, out_dir=args.out, jobs=args.jobs
    )
    total = sum(report.counts.values())
    print(
        f"{report.chosen.folds}-fold cross-validation on {report.images} ({total} images: "
        + ", ".join(f"{k} {v}" for k, v in report.counts.items())
        + ")"
    )
    print_skipped(report.skipped)
    for title, cv, key in (
        ("chosen", report.chosen, "chosen"),
        ("paper (Chen et al.)", report.paper, "paper"),
    ):
        print(f"\n{title}: {describe(cv.cfg)}")
        print("\n".join(format_table(cv, report.feature_ms[key])))
    if report.outputs:
        print()
        for path in report.outputs:
            print(f"written: {path}")
    return 0
