"""``terrain-odom train``: fit the KNN terrain classifier on a labelled image folder."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from terrain_odom.cli.options import (
    add_classifier_options,
    add_out_option,
    classifier_config,
    warn_out_file,
)

if TYPE_CHECKING:
    from terrain_odom.config.classifier import ClassifierConfig
    from terrain_odom.vision.cross_validation import CrossValidation
    from terrain_odom.vision.dataset import SkippedImage
    from terrain_odom.vision.tuning import Search


def describe(config: ClassifierConfig) -> str:
    """Return a one-line summary of a classifier configuration."""
    return (
        f"features={config.features} n_t={config.n_t} relative_counts={config.relative_counts} "
        f"pyramid_levels={config.pyramid_levels} scale={config.scale} k={config.k} "
        f"weights={config.weights} "
        + (
            f"tile_size={config.tile_size}"
            if config.tile_size is not None
            else f"tiles={config.tiles} min_tile_size={config.min_tile_size}"
        )
    )


def describe_threshold(cv: CrossValidation) -> str:
    """One line: the confidence threshold chosen from the held-out images, and what it keeps."""
    threshold = cv.threshold()
    if threshold is None or cv.confidence is None or cv.correct is None:
        return "confidence: not measured"
    kept = cv.confidence >= threshold
    right = 100.0 * float(cv.correct[kept].mean()) if kept.any() else float("nan")
    return (
        f"confidence threshold {threshold:.2f} (frames below it are no sighting): "
        f"{100.0 * float(kept.mean()):.1f} % of held-out images reach it, {right:.1f} % of them right"
    )


def print_skipped(skipped: tuple[SkippedImage, ...]) -> None:
    """List the images that were left out."""
    if skipped:
        print(f"skipped {len(skipped)} image(s):")
        for item in skipped:
            print(f"  {item.path}: {item.reason}")


def describe_values(params: dict[str, Any]) -> str:
    """Return a grid candidate's values as ``name=value`` words."""
    return " ".join(f"{name}={value}" for name, value in params.items())


def print_search(search: Search, top: int = 5) -> None:
    """Print how many candidates a search scored and its best ``top``, best first."""
    print(
        f"tuned: {len(search.candidates)} candidates of the grid, {search.folds}-fold "
        "cross-validated mean accuracy, best first:"
    )
    ranked = sorted(range(len(search.candidates)), key=lambda i: -search.mean_score[i])
    for i in ranked[:top]:  # a stable sort: of ties, the chosen (the first) first
        score = f"{100 * search.mean_score[i]:5.1f} % +- {100 * search.std_score[i]:.1f}"
        print(f"  {score}  {describe_values(search.candidates[i])}")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``train`` subcommand."""
    p = sub.add_parser("train", help="train the terrain classifier on labelled images")
    add_classifier_options(p)
    add_out_option(p, "folder (created) for the model file classifier.npz", required=True)
    p.set_defaults(func=_cmd_train)


def _cmd_train(args: argparse.Namespace) -> int:
    from terrain_odom.app.train import MODEL_SUFFIXES, train

    warn_out_file(args.out, MODEL_SUFFIXES)
    summary = train(
        args.images,
        args.out,
        classifier_config(args),
        jobs=args.jobs,
        config_path=args.config,
        tune=args.tune,
        grid_path=args.grid,
        dask=args.dask,
    )
    if summary.tuning is not None:
        print_search(summary.tuning.search)
    print(describe(summary.config))
    total = sum(summary.counts.values())
    print(f"{total} images: " + ", ".join(f"{k} {v}" for k, v in summary.counts.items()))
    print_skipped(summary.skipped)
    cv = summary.cross_validation
    if cv is None:
        print("cross-validation skipped: a class has fewer than 2 images")
    else:
        worst, worst_acc = cv.worst_class()
        print(
            f"{cv.folds}-fold cross-validated accuracy: mean {cv.mean_accuracy:.1f} % "
            f"(overall {cv.overall_accuracy:.1f} %, worst class {worst} {worst_acc:.1f} %)"
        )
        if summary.tuning is not None:
            print(
                "  (optimistic: the settings were chosen on these folds; "
                "'report accuracy --tune' scores the tuning by nested cross-validation)"
            )
        print(describe_threshold(cv))
    print(f"model: {summary.classifier_path}")
    return 0
