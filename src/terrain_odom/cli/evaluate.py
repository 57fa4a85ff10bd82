"""``terrain-odom evaluate``: model-odometry error per metre and ATE."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

from terrain_odom.cli.bag_import import add_bag_topic_options, logs_from_bags
from terrain_odom.cli.options import (
    add_config_option,
    add_dask_option,
    add_log_options,
    add_out_option,
    add_wheels_option,
    config_edits,
    find_input,
    horizon_option,
    print_pose_delay,
    print_pose_delays,
    print_written,
    warn_out_file,
)

if TYPE_CHECKING:
    from terrain_odom.app.evaluation_results import EvaluationResult, ModelErrors


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``evaluate`` subcommand."""
    p = sub.add_parser("evaluate", help="model-odometry error per metre and ATE")
    add_wheels_option(
        p,
        "wheel log CSV with pose measurements, or a ROS bag with --wheels-topic; several: one "
        "report, per log and pooled (evaluation.json, evaluation.md in --out)",
        many=True,
    )
    p.add_argument("--run", metavar="DIR", help="output folder of 'terrain-odom run' on this log")
    p.add_argument(
        "--params",
        nargs="*",
        default=[],
        metavar="FILE_OR_DIR",
        help="parameter files of constant models, or --out folders of 'terrain-odom fit'",
    )
    add_config_option(p, "project configuration (robot geometry, horizon)")
    p.add_argument(
        "--horizon",
        metavar="H",
        help="evaluation horizon h_e: a distance like 2m (bare 2: metres; default: the "
        "configuration's evaluation.horizon, 2 m)",
    )
    p.add_argument(
        "--outage",
        nargs="+",
        metavar="DURATION",
        help="outage windows: from the run's state at a position fix every 10 s (at most 120 "
        "windows; wider apart on a long log), dead-reckon "
        "each model without poses for DURATION (like 30s; bare: seconds) and compare the "
        "displacement with the measured one (>= 1 s; needs --run; default with --run on "
        "sparse, GPS-like poses: 30s 60s; 'off': none)",
    )
    add_out_option(p, "folder for evaluation.json (created; default: the --run folder)")
    add_log_options(p)
    add_bag_topic_options(p)
    add_dask_option(p, "the logs of a batch (two or more --wheels)")
    p.set_defaults(func=_cmd_evaluate)


def _fmt(value: float, digits: int) -> str:
    return "n/a" if math.isnan(value) else f"{value:.{digits}f}"


def _format_stats(entry: ModelErrors) -> str:
    t, r = entry.errors.translation, entry.errors.rotation
    translation = f"{_fmt(t.median, 4):>8}" + (f" [{t.q25:.3f}-{t.q75:.3f}]" if t.count else "")
    rotation = f"{_fmt(r.median, 3):>7}" + (f" [{r.q25:.2f}-{r.q75:.2f}]" if r.count else "")
    return f"{translation}  {rotation}  {_fmt(entry.ate.rmse, 2):>8}"


def _print_outages(result: EvaluationResult) -> None:
    from terrain_odom.reporting.markdown import OUTAGE_HEADER, outage_rows
    from terrain_odom.reporting.outage import OutageSection

    if not result.outages:
        return
    print()
    print(
        "outage windows: each model dead-reckoned from the run's state at a position fix, "
        "no pose updates; displacement error"
    )
    widths = (8, 9, 32, 30, 30)
    print("".join(f"{h:<{w}}" for h, w in zip(OUTAGE_HEADER, widths, strict=True)).rstrip())
    for row in outage_rows(OutageSection(result.outages, result.outage_every)):
        print("".join(f"{c:<{w}}" for c, w in zip(row, widths, strict=True)).rstrip())


def _print_prediction(result: EvaluationResult) -> None:
    print()
    print(
        f"2-s prediction from {result.prediction_windows} measured poses: "
        "mean position (m), heading (deg)"
    )
    for name, p in result.prediction.items():
        shown = (
            "n/a"
            if math.isnan(p.position)
            else f"{p.position:8.3f}  {math.degrees(p.heading):8.2f}"
        )
        print(f"{name:<32} {shown}")


def outage_durations(values: list[str] | None) -> list[float] | None:
    """Parse ``--outage``: durations like ``30s`` (bare: seconds), or ``off``; None: the default.

    Raises
    ------
    ConfigError
        A value that is not a positive finite duration, a distance, or ``off`` beside durations.

    Examples
    --------
    >>> outage_durations(["30s", "60", "30"]), outage_durations(["off"]), outage_durations(None)
    ([30.0, 60.0], [], None)
    """
    from terrain_odom.errors import ConfigError
    from terrain_odom.evaluation.outage import MIN_OUTAGE
    from terrain_odom.fitting import parse_horizon

    if values is None:
        return None
    if values == ["off"]:
        return []
    durations = []
    for text in values:
        try:
            horizon = parse_horizon(text if text.strip()[-1:] in "ms" else f"{text}s")
        except ValueError:
            horizon = None
        if horizon is None or horizon.unit != "s" or not math.isfinite(horizon.value):
            raise ConfigError(
                f"--outage: {text!r} is not a duration like 30s (or 30, seconds; 'off' alone: none)"
            )
        if horizon.value < MIN_OUTAGE:
            raise ConfigError(
                f"--outage: {text!r} is shorter than {MIN_OUTAGE:g} s (an outage that short ends "
                "on the fix it starts from)"
            )
        durations.append(horizon.value)
    return sorted(set(durations))


def _wheels(args: argparse.Namespace) -> tuple[list[str], str | None]:
    """Return ``--wheels``, or their imports (into OUT/bag/) and configuration if they are bags.

    Raises
    ------
    ConfigError
        A bag with neither ``--out`` nor ``--run`` to import it into.
    """
    from terrain_odom.app.evaluate import JSON_SUFFIXES
    from terrain_odom.app.locate import names_a_file
    from terrain_odom.errors import ConfigError

    folder = args.out if args.out is not None else args.run
    if folder is None and args.wheels_topic is not None:
        raise ConfigError("--wheels-topic imports the bag into OUT/bag/: give --out (or --run)")
    if folder is not None and names_a_file(folder, JSON_SUFFIXES):
        folder = str(Path(folder).parent)
    return logs_from_bags(args.wheels, args, folder or ".")


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from terrain_odom.app.evaluate import JSON_SUFFIXES, evaluate
    from terrain_odom.app.evaluation_results import WINDOW_KINDS
    from terrain_odom.errors import ConfigError

    horizon = horizon_option(args.horizon, durations=False)
    outages = outage_durations(args.outage)
    if outages and args.run is None:
        raise ConfigError("--outage dead-reckons from a run's state: give --run")
    if len(args.wheels) > 1 or args.dask is not None:
        return _cmd_batch(args, None if horizon is None else horizon.value)
    warn_out_file(args.out, JSON_SUFFIXES)
    wheels, bag_config = _wheels(args)
    result = evaluate(
        args.run,
        wheels[0],
        config_path=args.config,
        edits=config_edits(args),
        imported_config=bag_config,
        params=[find_input(p, "params_*.yaml", "parameter file") for p in args.params],
        horizon=None if horizon is None else horizon.value,
        out_dir=args.out,
        outage=outages,
    )
    print(f"{result.windows} windows of {result.horizon:g} m on {result.log}")
    if result.anchor != "pose":
        print(f"windows:    {WINDOW_KINDS[result.anchor]}")
    print_pose_delay(result.time_calibration)
    print(f"{'model':<32} {'m/m median [q25-q75]':>24}  {'deg/m median [q25-q75]':>22}  ATE DR (m)")
    for name, entry in result.models.items():
        print(f"{name:<32} {_format_stats(entry)}")
    _print_prediction(result)
    _print_outages(result)
    print_written("written:", [result.output, *result.plots])
    return 0


def _cmd_batch(args: argparse.Namespace, horizon: float | None) -> int:
    """``evaluate --wheels LOG LOG ...``: one report over the logs, per log and pooled."""
    from terrain_odom.app.evaluate import evaluate_logs
    from terrain_odom.errors import ConfigError

    if args.run is not None:
        raise ConfigError("--run evaluates one run on its own log: give one --wheels log")
    if len(args.wheels) < 2:
        raise ConfigError("--dask sends whole logs to the workers: give two or more --wheels logs")
    wheels, bag_config = _wheels(args)
    batch = evaluate_logs(
        wheels,
        config_path=args.config,
        edits=config_edits(args),
        imported_config=bag_config,
        params=[find_input(p, "params_*.yaml", "parameter file") for p in args.params],
        horizon=horizon,
        out_dir=args.out,
        dask=args.dask,
    )
    print_pose_delays({str(r.log): r.time_calibration for r in batch.logs})
    print(batch.markdown(), end="")
    print_written("written:", list(batch.outputs))
    return 0
