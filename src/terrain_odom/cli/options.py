"""Options shared by several subcommands, and their loading.

``--config`` (the YAML configuration), ``--pose-delay`` (and the line that
reports the delay applied), ``--out`` (and the lines naming the files
written), the optimiser options of ``fit`` and
``compare``, and the classifier options of ``train`` and ``report accuracy``.
Heavy modules are imported inside the functions, so building the parser
stays fast.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

if TYPE_CHECKING:
    from terrain_odom.config import Config
    from terrain_odom.config.classifier import ClassifierConfig
    from terrain_odom.estimation.time_offset import TimeCalibration
    from terrain_odom.fitting import FitOptions, Horizon

MODEL_CHOICES = ("idd", "edd-sym", "edd-asym", "roc", "linear", "icr", "icr-slip")
FEATURE_CHOICES = ("sfta", "sfta+lab", "sfta+hsv")


def add_config_option(p: argparse.ArgumentParser, help: str) -> None:
    """Add ``--config`` (a YAML file; what it configures is told by ``help``)."""
    p.add_argument("--config", help=help)


def add_out_option(p: argparse.ArgumentParser, help: str, *, required: bool = False) -> None:
    """Add ``--out`` (where the subcommand writes; told by ``help``)."""
    p.add_argument("--out", required=required, help=help)


def print_written(label: str, paths: Sequence[Path | None]) -> None:
    """Print the files written under ``label`` (``"frames:"``), one a line, aligned.

    ``None`` entries (files not written) are skipped; nothing is printed if
    every entry is ``None``.
    """
    for i, path in enumerate(p for p in paths if p is not None):
        print(f"{label if i == 0 else '':<12}{path}")


def add_log_options(p: argparse.ArgumentParser) -> None:
    """Add ``--pose-delay`` and ``--no-checks``: how a log is read (override the configuration)."""
    p.add_argument(
        "--no-checks",
        action="store_true",
        help="run even where the log's wheels and poses disagree (travel, turn, time unit; "
        "configuration: checks.enabled)",
    )
    p.add_argument(
        "--pose-delay",
        metavar="{auto,SECONDS}",
        help="the pose stamps lag the wheel speeds by this many seconds (the wheel speeds are "
        "delayed to match), or auto: estimate it from the whole log's heading (offline "
        "calibration); default: the configuration's time.pose_delay, 0",
    )


def load_config_option(args: argparse.Namespace, path: str | Path | None = None) -> Config:
    """Return the configuration of ``--config`` with ``--pose-delay`` and ``--no-checks`` applied.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments with ``config`` and, for subcommands that have them,
        ``pose_delay`` and ``no_checks``.
    path : str or Path, optional
        The configuration file to load instead of ``--config`` (e.g. one found
        beside the input); built-in defaults when neither is given.
    """
    from terrain_odom.config import ChecksConfig, load_config, with_pose_delay

    cfg = load_config(args.config if path is None else path)
    if getattr(args, "no_checks", False):
        cfg = dataclasses.replace(cfg, checks=ChecksConfig(enabled=False))
    return with_pose_delay(cfg, getattr(args, "pose_delay", None))


def pose_delay_line(timing: TimeCalibration) -> str:
    """Return one line on the pose delay applied to a log."""
    line = f"pose delay: {timing.pose_delay:.3f} s"
    if timing.estimate is not None:
        line += (
            f" (estimated, +-{timing.estimate.std:.3f} s, from {timing.estimate.pairs} "
            "heading changes)"
        )
    return line


def print_pose_delay(timing: TimeCalibration | None) -> None:
    """Print the pose delay applied to a log, unless it is 0 as given."""
    if timing is not None and _shows(timing):
        print(pose_delay_line(timing))


def print_pose_delays(timing: Mapping[str, TimeCalibration]) -> None:
    """Print the pose delay applied to each log, unless all are 0 as given."""
    if any(_shows(t) for t in timing.values()):
        for source, t in timing.items():
            print(f"{source}: {pose_delay_line(t)}")


def _shows(timing: TimeCalibration) -> bool:
    from terrain_odom.estimation.time_offset import shows_pose_delay

    return shows_pose_delay(timing.to_dict())


def check_horizon(value: float | None, option: str = "--horizon") -> float | None:
    """Return a command-line horizon, m, or raise unless it is a finite distance >= 1 mm.

    Raises
    ------
    ConfigError
        ``value`` is below :data:`~terrain_odom.evaluation.windows.MIN_HORIZON`,
        NaN or infinite (None, not given, passes).
    """
    from terrain_odom.errors import ConfigError
    from terrain_odom.evaluation.windows import MIN_HORIZON

    if value is not None and not MIN_HORIZON <= value < math.inf:
        raise ConfigError(
            f"{option}: must be a finite distance >= {MIN_HORIZON:g} m, got {value:g}"
        )
    return value


def check_seed(value: int, option: str = "--seed") -> int:
    """Return a command-line random seed, or raise unless it is a whole number >= 0.

    Raises
    ------
    ConfigError
        ``value`` is negative (NumPy's generators take seeds >= 0).
    """
    from terrain_odom.errors import ConfigError

    if value < 0:
        raise ConfigError(f"{option}: must be a whole number >= 0, got {value}")
    return value


def add_fit_options(p: argparse.ArgumentParser) -> None:
    """Add the options shared by ``fit`` and ``compare``."""
    p.add_argument(
        "--log", nargs="+", required=True, help="training wheel logs (CSV with x, y, yaw)"
    )
    p.add_argument(
        "--horizon",
        help="training segment length h_t: a distance like 2m (default) or a duration like 2s",
    )
    p.add_argument(
        "--by-terrain",
        action="store_true",
        help="one parameter set per terrain label (needs a terrain column)",
    )
    p.add_argument(
        "--sigma",
        nargs=3,
        type=float,
        metavar=("SX", "SY", "SYAW"),
        help="loss Sigma as standard deviations in m, m, rad (default: identity)",
    )
    p.add_argument(
        "--popsize", type=int, help="differential-evolution population per parameter (15)"
    )
    p.add_argument("--maxiter", type=int, help="most generations (300)")
    p.add_argument("--seed", type=int, help="seed of the optimiser, for reproducible fits (0)")
    add_config_option(p, "YAML configuration (wheel radius, track width, h_e)")
    add_log_options(p)


def fit_options(args: argparse.Namespace) -> FitOptions:
    """Build the :class:`FitOptions` of the command-line arguments (defaults for the rest)."""
    from terrain_odom.errors import ConfigError
    from terrain_odom.fitting import FitOptions

    given = {
        k: getattr(args, k) for k in ("popsize", "maxiter", "seed") if getattr(args, k) is not None
    }
    if args.sigma is not None:
        given["sigma"] = tuple(args.sigma)
    opt = dataclasses.replace(FitOptions(), **given)
    if opt.popsize < 5 or opt.maxiter < 1:
        raise ConfigError(
            f"--popsize must be >= 5 and --maxiter >= 1, got {opt.popsize} and {opt.maxiter}"
        )
    if opt.sigma is not None and not all(s > 0 for s in opt.sigma):
        raise ConfigError(f"--sigma standard deviations must be > 0, got {list(opt.sigma)}")
    return opt


class FitArguments(TypedDict):
    """The keyword arguments of ``fit`` and ``compare`` set by :func:`add_fit_options`."""

    horizon: str | Horizon
    by_terrain: bool
    options: FitOptions
    config: Config
    config_path: str | None


def fit_arguments(args: argparse.Namespace) -> FitArguments:
    """Return the keyword arguments that ``fit`` and ``compare`` take from the shared options."""
    from terrain_odom.fitting import DEFAULT_TRAINING_HORIZON

    return {
        "horizon": args.horizon or DEFAULT_TRAINING_HORIZON,
        "by_terrain": args.by_terrain,
        "options": fit_options(args),
        "config": load_config_option(args),
        "config_path": args.config,
    }


def add_classifier_options(p: argparse.ArgumentParser) -> None:
    """Add the options shared by ``train`` and ``report accuracy``."""
    p.add_argument(
        "--images", required=True, help="folder with one sub-folder of images per terrain"
    )
    add_config_option(
        p,
        "classifier YAML: any of features, n_t, relative_counts, pyramid_levels, "
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
    p.add_argument(
        "--tune",
        action="store_true",
        help="choose the settings of a grid around the configuration by stratified "
        "cross-validation (report accuracy: scored by nested cross-validation)",
    )
    p.add_argument(
        "--grid",
        help="YAML grid for --tune: classifier fields -> lists of values (implies --tune; "
        "default: the built-in grid)",
    )


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
