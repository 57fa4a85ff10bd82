"""Options shared by several subcommands, and their loading: one grammar.

One spelling per concept across the subcommands (the table at the top of
``docs/cli.md``): ``--wheels`` (wheel logs), ``--eval`` (held-out logs),
``--out`` (always a folder), ``--config`` (always the project
configuration), ``--classifier`` (a classifier model), ``--model`` /
``--models`` (kinematic models), ``--horizon`` (``2m``, ``2s``, bare
metres; :func:`horizon_option`). Old spellings still parse for a release,
through one mechanism (:func:`add_option`), each use printing a
deprecation line. Also here: ``--pose-delay`` (and the line that reports
the delay applied), the lines naming the files written, the optimiser
options of ``fit`` and ``compare``, and the classifier options of ``train``
and ``report accuracy``. Heavy modules are imported inside the functions,
so building the parser stays fast.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict, overload

if TYPE_CHECKING:
    from terrain_odom.app.calibration import SensorCalibration
    from terrain_odom.app.inputs import Chosen, ConfigEdits
    from terrain_odom.config import Config
    from terrain_odom.config.classifier import ClassifierConfig
    from terrain_odom.estimation.time_offset import TimeCalibration
    from terrain_odom.fitting import FitOptions, Horizon

MODEL_CHOICES = ("idd", "edd-sym", "edd-asym", "roc", "linear", "icr", "icr-slip")
REMOVED_IN = "0.3"
"""The release that drops the deprecated spellings."""


def warn_deprecated(old: str, new: str) -> None:
    """Print the one deprecation line of an old spelling ``old`` (stderr)."""
    print(
        f"terrain-odom: warning: {old} is deprecated and will be removed in {REMOVED_IN}; "
        f"use {new}",
        file=sys.stderr,
    )


class _Spellings(argparse.Action):
    """Store an option's value under any of its spellings; note the old ones used.

    The new spelling is ``option_strings[0]``; the parser also dispatches the
    old spellings here (see :func:`add_option`). Giving two spellings of the
    same option is a :class:`~terrain_odom.errors.ConfigError` (one line).
    The old spellings used are kept in the namespace for
    :func:`warn_deprecated_spellings` (printed once parsing succeeded, so an
    error stays one line).
    """

    def __init__(self, option_strings: Sequence[str], dest: str, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.new = option_strings[0]

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        from terrain_odom.errors import ConfigError

        spelling = option_string or self.new
        used: dict[str, tuple[str, str]] = vars(namespace).setdefault(_SPELLINGS, {})
        _, first = used.setdefault(self.dest, (self.new, spelling))
        if first != spelling:
            old = first if first != self.new else spelling
            raise ConfigError(
                f"{old} and {self.new} given: {old} is the deprecated spelling of {self.new}; "
                f"give {self.new} only"
            )
        setattr(namespace, self.dest, values)


_SPELLINGS = "_spellings"
"""Namespace attribute: option dest -> (new spelling, spelling used)."""


def warn_deprecated_spellings(args: argparse.Namespace) -> None:
    """Print one deprecation line per old spelling used in ``args`` (see :func:`add_option`)."""
    for new, used in getattr(args, _SPELLINGS, {}).values():
        if used != new:
            warn_deprecated(used, new)


def add_option(p: argparse.ArgumentParser, name: str, *old: str, **kwargs: Any) -> argparse.Action:
    """Add option ``name`` (``add_argument`` keywords) with deprecated spellings ``old``.

    The old spellings parse as ``name`` does, each printing one deprecation
    line (:func:`warn_deprecated_spellings`, after parsing); ``--help`` and
    the usage show ``name`` only; both spellings at once are a one-line error.
    """
    action = p.add_argument(name, *old, action=_Spellings, **kwargs)
    action.option_strings = [name]  # the parser still maps the old spellings to this action
    return action


def add_config_option(p: argparse.ArgumentParser, help: str) -> None:
    """Add ``--config`` (the project configuration; what the subcommand uses of it: ``help``)."""
    p.add_argument("--config", metavar="YAML", help=help)


def add_out_option(p: argparse.ArgumentParser, help: str, *, required: bool = False) -> None:
    """Add ``--out`` (the folder the subcommand writes into; told by ``help``)."""
    p.add_argument("--out", metavar="DIR", required=required, help=help)


def add_dask_option(p: argparse.ArgumentParser, what: str) -> None:
    """Add ``--dask`` (run ``what`` on a Dask cluster: a scheduler's address or ``local:N``)."""
    p.add_argument(
        "--dask",
        metavar="ADDRESS",
        help=f"run {what} on a Dask cluster: a running scheduler (tcp://host:8786; the workers "
        "need the same data paths) or local:N (N local worker processes); needs the extra "
        "terrain-odom[dask]",
    )


def add_wheels_option(
    p: argparse.ArgumentParser, help: str, *, many: bool = False, old: Sequence[str] = ("--log",)
) -> None:
    """Add ``--wheels`` (the wheel log, or logs if ``many``; deprecated spellings ``old``)."""
    nargs = "+" if many else None
    add_option(p, "--wheels", *old, nargs=nargs, required=True, metavar="LOG", help=help)


def warn_out_file(out: str | None, suffixes: Sequence[str]) -> None:
    """Print the deprecation line if ``--out`` names a file (the old form).

    ``--out DIR`` is a folder; a name ending in one of ``suffixes`` (the
    file's own, :func:`~terrain_odom.app.locate.names_a_file`) names the
    file, as before.
    """
    from terrain_odom.app.locate import names_a_file

    if out is not None and names_a_file(out, suffixes):
        warn_deprecated(f"--out {Path(out).name}", "--out DIR (a folder)")


@overload
def find_input(path: str, pattern: str, kind: str) -> str: ...


@overload
def find_input(path: None, pattern: str, kind: str) -> None: ...


def find_input(path: str | None, pattern: str, kind: str) -> str | None:
    """Return the file an input option names: the file itself, or the one ``pattern`` in a folder.

    See :func:`~terrain_odom.app.locate.find_input` (None passes).
    """
    from terrain_odom.app.locate import find_input as find

    return None if path is None else str(find(path, pattern, kind))


def printable(text: str) -> str:
    r"""Return ``text`` with control characters and undecodable bytes escaped: one safe line.

    A file name may hold a newline, an ESC (a terminal's escape sequences)
    or bytes that are not UTF-8; they are shown as Python escapes.

    Examples
    --------
    >>> printable("a\nb\x1b[31m")
    'a\\nb\\x1b[31m'
    """
    return "".join(_escape(char) for char in text)


def _escape(char: str) -> str:
    if char.isprintable() or char == " ":
        return char
    if "\udc80" <= char <= "\udcff":  # a byte that was not UTF-8 (surrogateescape)
        return f"\\x{ord(char) - 0xDC00:02x}"
    return repr(char)[1:-1]


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
        "delayed to match), or auto: estimate it from the whole log's heading, or its "
        "positions without headings (offline calibration); default: the configuration's "
        "time.pose_delay, 0",
    )


def load_config_option(args: argparse.Namespace, config_path: str | Path | None = None) -> Config:
    """Return the configuration of ``--config`` with ``--pose-delay`` and ``--no-checks`` applied.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments with ``config`` and, for subcommands that have them,
        ``pose_delay`` and ``no_checks``.
    config_path : str or Path, optional
        The configuration file to load instead of ``--config`` (e.g. one found
        beside the input); built-in defaults when neither is given.
    """
    from terrain_odom.config import ChecksConfig, load_config, with_pose_delay

    config = load_config(args.config if config_path is None else config_path)
    if getattr(args, "no_checks", False):
        config = dataclasses.replace(config, checks=ChecksConfig(enabled=False))
    return with_pose_delay(config, getattr(args, "pose_delay", None))


def config_edits(args: argparse.Namespace, **edits: Any) -> ConfigEdits:
    """Return ``--pose-delay`` and ``--no-checks`` (and ``edits``) as the app takes them.

    The app chooses and loads the configuration file and applies them
    (:func:`~terrain_odom.app.inputs.choose_config`).
    """
    from terrain_odom.app.inputs import ConfigEdits

    return ConfigEdits(
        pose_delay=getattr(args, "pose_delay", None),
        checks=not getattr(args, "no_checks", False),
        **edits,
    )


def print_config(chosen: Chosen | None) -> None:
    """Print the configuration file the app found for the user (``--images``), if it did."""
    from terrain_odom.app.inputs import IN_IMAGES

    if chosen is not None and chosen.how == IN_IMAGES:
        print(f"config:     {chosen.path} (found in the --images folder; --config to change)")


def pose_delay_line(timing: TimeCalibration) -> str:
    """Return one line on the pose delay applied to a log."""
    separate = timing.heading_delay_applied != timing.pose_delay
    line = f"{'position' if separate else 'pose'} delay: {timing.pose_delay:.3f} s"
    if timing.position_std is not None:
        line += f" (estimated, +-{timing.position_std:.3f} s, from the positions)"
    elif timing.estimate is not None and not separate:
        line += (
            f" (estimated, +-{timing.estimate.std:.3f} s, from {timing.estimate.pairs} "
            "heading changes)"
        )
    if separate:
        line += f"; heading delay: {timing.heading_delay_applied:.3f} s"
        if timing.estimate is not None:
            line += f" (estimated, +-{timing.estimate.std:.3f} s)"
    return line


def print_calibration(calibration: SensorCalibration | None) -> None:
    """Print each value a calibration found (or could not), then its notes (noise overrides)."""
    if calibration is None:
        return
    for found in calibration.found:
        if not found.key.startswith("time.") and not found.key.startswith("ekf.sigma_r"):
            print(f"calibrated: {found.line()}")
    for note in calibration.notes:
        print(f"calibrated: {note}")


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


def horizon_option(
    text: str | None, *, durations: bool, option: str = "--horizon"
) -> Horizon | None:
    """Parse a command-line horizon: ``2m`` (distance), ``2s`` (duration), ``2`` (metres).

    Parameters
    ----------
    text : str or None
        The option's value (None, not given, passes).
    durations : bool
        Whether the subcommand takes a duration (``fit``, ``compare``) or
        only a distance (``evaluate``, whose distance must also pass
        :func:`check_horizon`).

    Raises
    ------
    ConfigError
        Malformed, not positive and finite, or a duration where only a
        distance is taken.
    """
    from terrain_odom.errors import ConfigError
    from terrain_odom.evaluation.windows import MIN_HORIZON
    from terrain_odom.fitting import parse_horizon

    if text is None:
        return None
    try:
        horizon = parse_horizon(text)
    except ValueError as exc:
        if durations:
            raise ConfigError(f"{option}: {exc}") from None
        raise ConfigError(
            f"{option}: must be a finite distance >= {MIN_HORIZON:g} m like 2m (or 2, metres), "
            f"got {text!r}"
        ) from None
    if horizon.unit == "s" and not durations:
        raise ConfigError(
            f"{option}: {text!r} is a duration; this subcommand takes a distance like 2m "
            "(or 2, metres)"
        )
    if not durations:
        check_horizon(horizon.value, option)
    return horizon


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
    add_wheels_option(p, "training wheel logs (CSV with x, y, yaw)", many=True)
    p.add_argument(
        "--horizon",
        metavar="H",
        help="training segment length h_t: a distance like 2m (default; bare 2: metres) "
        "or a duration like 2s",
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
    add_config_option(p, "project configuration (wheel radius, track width, h_e)")
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

    horizon: Horizon
    by_terrain: bool
    options: FitOptions
    config: Config
    config_path: str | None


def fit_arguments(args: argparse.Namespace) -> FitArguments:
    """Return the keyword arguments that ``fit`` and ``compare`` take from the shared options."""
    from terrain_odom.fitting import DEFAULT_TRAINING_HORIZON

    return {
        "horizon": horizon_option(args.horizon, durations=True) or DEFAULT_TRAINING_HORIZON,
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
        "project configuration: its classifier section (any of features, n_t, "
        "relative_counts, pyramid_levels, scale, k, weights, tiles, min_tile_size, "
        "tile_size; default: built-in defaults)",
    )
    p.add_argument(
        "--features",
        help="texture families sfta (Chen et al.), lbp, glcm joined by '+', optionally with "
        "one colour space lab or hsv (default sfta+lbp+lab; Chen's recipe: sfta)",
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
        help="smallest tile side in pixels: smaller images get fewer tiles per side "
        "(default auto: the training images' median shorter side / --tiles, recorded in the model)",
    )
    p.add_argument(
        "--tile-size",
        type=int,
        help="tiles of about this side in pixels, as many as fit (instead of --tiles); "
        "a region's time is then proportional to its area",
    )
    p.add_argument(
        "--jobs",
        type=int,
        help="feature-extraction processes (default: all cores; with --dask: the cluster's workers)",
    )
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
    add_dask_option(p, "the feature extraction and the --tune search")


def classifier_config(args: argparse.Namespace) -> ClassifierConfig:
    """Return the :class:`ClassifierConfig` of ``--config`` and the options that override it.

    ``--config``'s ``classifier`` section; a flat classifier YAML (its keys at
    the top level, the old layout) is read too, with a deprecation line.
    """
    from terrain_odom.config import load_classifier_config

    overrides: dict[str, Any] = {
        name: getattr(args, name)
        for name in ("features", "k", "tiles", "min_tile_size", "tile_size")
        if getattr(args, name) is not None
    }
    if args.no_scale:
        overrides["scale"] = False
    return load_classifier_config(args.config, overrides, on_flat=_warn_flat)


def _warn_flat(path: Path) -> None:
    warn_deprecated(
        f"a flat classifier YAML ({path})",
        "--config with the classifier settings in a classifier: section",
    )
