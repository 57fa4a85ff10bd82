"""``terrain-odom report accuracy``: cross-validated confusion matrix of the terrain classifier."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from terrain_odom.cli.options import add_classifier_options, add_out_option, classifier_config
from terrain_odom.cli.train import describe, describe_threshold, describe_values, print_skipped

if TYPE_CHECKING:
    from terrain_odom.app.tune import NestedTuning
    from terrain_odom.vision.cross_validation import CrossValidation


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
    add_out_option(acc, "folder (created) for accuracy.json, accuracy.csv, confusion.png")
    acc.set_defaults(func=_cmd_accuracy)


def format_table(
    cv: CrossValidation, feature_ms: dict[str, dict[str, float]] | None = None
) -> list[str]:
    """Return the confusion matrix as text lines, plus per-class feature times (ms) if given.

    Rows are the true class and sum to 100 %. (Chen et al.'s printed Table 1
    is the transpose: its columns sum to 100 %.)
    """
    corner = "true \\ predicted"
    first = max(len(corner), *(len(c) for c in cv.classes)) + 2
    width = max(8, *(len(c) + 2 for c in cv.classes))
    head = f"{corner:<{first}}" + "".join(f"{c:>{width}}" for c in cv.classes)
    lines = [
        head
        + f"{'images':>8}"
        + ("" if feature_ms is None else f"{'feature ms mean':>17}{'max':>8}")
    ]
    for i, name in enumerate(cv.classes):
        cells = "".join(f"{v:>{width}.1f}" for v in cv.percent[i])
        times = (
            ""
            if feature_ms is None
            else (f"{feature_ms[name]['mean']:>17.1f}{feature_ms[name]['max']:>8.1f}")
        )
        lines.append(f"{name:<{first}}{cells}{int(cv.confusion[i].sum()):>8}{times}")
    worst, worst_acc = cv.worst_class()
    lines.append(
        f"mean accuracy {cv.mean_accuracy:.1f} % (overall {cv.overall_accuracy:.1f} %, "
        f"worst class {worst} {worst_acc:.1f} %)"
    )
    return lines


def print_tuned(tuned: NestedTuning) -> None:
    """Print the nested cross-validation of the tuned classifier: each fold's choice, the table."""
    candidates = len(tuned.folds[0].search.candidates)
    print(
        f"\ntuned (nested: {candidates} candidates searched by {tuned.inner_folds}-fold "
        f"cross-validation on the other folds of each fold): around {describe(tuned.base)}"
    )
    for i, fold in enumerate(tuned.folds):
        inner = 100 * fold.search.mean_score[fold.search.best]
        print(
            f"  fold {i + 1}: {describe_values(fold.search.choice)} "
            f"(inner {inner:.1f} %, this fold {fold.accuracy:.1f} %)"
        )
    print("\n".join(format_table(tuned.cross_validation)))


def _cmd_accuracy(args: argparse.Namespace) -> int:
    from terrain_odom.app.train import report_accuracy

    report = report_accuracy(
        args.images,
        classifier_config(args),
        folds=args.folds,
        out_dir=args.out,
        jobs=args.jobs,
        config_path=args.config,
        tune=args.tune,
        grid_path=args.grid,
        dask=args.dask,
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
        print(f"\n{title}: {describe(cv.config)}")
        print("\n".join(format_table(cv, report.feature_ms[key])))
        print(describe_threshold(cv))
    if report.tuned is not None:
        print_tuned(report.tuned)
    if report.outputs:
        print()
        for path in report.outputs:
            print(f"written: {path}")
    return 0
