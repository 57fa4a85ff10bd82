"""``terrain-odom train``: fit the KNN terrain classifier on a labelled image folder."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from terrain_odom.config.classifier import ClassifierConfig
    from terrain_odom.vision.dataset import SkippedImage

FEATURE_CHOICES = ("sfta", "sfta+lab", "sfta+hsv")


def add_classifier_options(p: argparse.ArgumentParser) -> None:
    """Add the options shared by ``train`` and ``report accuracy``."""
    p.add_argument(
        "--images", required=True, help="folder with one sub-folder of images per terrain"
    )
    p.add_argument(
        "--config",
        help="classifier YAML: any of features, n_t, relative_counts, pyramid_levels, "
        "scale, k, weights, tiles, min_tile_size, tile_size (default: built-in defaults)",
    )
    p.add_argument(
        "--features",
        choices=FEATURE_CHOICES,
        help="grey SFTA only (Chen et al.) or SFTA + colour statistics",
    )
    p.add_argument(
        "--no-scale",
        action="store_true",
        help="raw Euclidean distance on unstandardised features (Chen et al.)",
    )
    p.add_argument("--k", type=int, help="number of neighbours voting")
    p.add_argument("--tiles", type=int, help="most tiles per side for tile voting (1: whole image)")
    p.add_argument(
        "--min-tile-size",
        type=int,
        help="smallest tile side in pixels: smaller images get fewer tiles per side",
    )
    p.add_argument(
        "--tile-size",
        type=int,
        help="tiles of about this side in pixels, as many as fit (instead of --tiles); "
        "a region's time is then proportional to its area",
    )
    p.add_argument("--jobs", type=int, help="feature-extraction processes (default: all cores)")


def classifier_config(args: argparse.Namespace) -> ClassifierConfig:
    """Return the :class:`ClassifierConfig` of ``--config`` and the options that override it."""
    from terrain_odom.config.classifier import load_classifier_config

    overrides: dict[str, Any] = {
        name: getattr(args, name)
        for name in ("features", "k", "tiles", "min_tile_size", "tile_size")
        if getattr(args, name) is not None
    }
    if args.no_scale:
        overrides["scale"] = False
    return load_classifier_config(args.config, overrides)


def describe(cfg: ClassifierConfig) -> str:
    """Return a one-line summary of a classifier configuration."""
    return (
        f"features={cfg.features} n_t={cfg.n_t} relative_counts={cfg.relative_counts} "
        f"pyramid_levels={cfg.pyramid_levels} scale={cfg.scale} k={cfg.k} "
        f"weights={cfg.weights} "
        + (
            f"tile_size={cfg.tile_size}"
            if cfg.tile_size is not None
            else f"tiles={cfg.tiles} min_tile_size={cfg.min_tile_size}"
        )
    )


def print_skipped(skipped: tuple[SkippedImage, ...]) -> None:
    """List the images that were left out."""
    if skipped:
        print(f"skipped {len(skipped)} image(s):")
        for item in skipped:
            print(f"  {item.path}: {item.reason}")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``train`` subcommand."""
    p = sub.add_parser("train", help="train the terrain classifier on labelled images")
    add_classifier_options(p)
    p.add_argument("--out", required=True, help="model file to write (.npz)")
    p.set_defaults(func=_cmd_train)


def _cmd_train(args: argparse.Namespace) -> int:
    from terrain_odom.app.train import train

    summary = train(args.images, args.out, classifier_config(args), jobs=args.jobs)
    print(describe(summary.cfg))
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
    print(f"model: {summary.model_path}")
    return 0
