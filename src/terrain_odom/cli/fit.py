"""``terrain-odom fit``: identify a constant kinematic model from logs with poses."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from terrain_odom.cli.bag_import import add_bag_topic_options, logs_from_bags
from terrain_odom.cli.options import (
    MODEL_CHOICES,
    add_fit_options,
    add_out_option,
    fit_arguments,
    print_pose_delays,
    warn_out_file,
)

if TYPE_CHECKING:
    from terrain_odom.app.fit import FitEvaluation, FitReport


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``fit`` subcommand."""
    p = sub.add_parser("fit", help="fit a constant kinematic model to logs with poses")
    add_fit_options(p)
    p.add_argument("--model", required=True, choices=MODEL_CHOICES, help="model to fit")
    p.add_argument(
        "--eval",
        nargs="+",
        default=[],
        metavar="LOG",
        help="held-out logs to evaluate the fit on",
    )
    add_out_option(p, "folder (created) for the parameter file params_MODEL.yaml", required=True)
    add_bag_topic_options(p)
    p.set_defaults(func=_cmd_fit)


def _print_sets(report: FitReport) -> None:
    from terrain_odom.fitting.params import ANY_TERRAIN

    mp = report.params
    for terrain, ps in mp.sets.items():
        where = "" if terrain == ANY_TERRAIN else f" [{terrain}]"
        values = ", ".join(f"{k}={v:.4f}" for k, v in ps.params.items()) or "(no parameter)"
        f = report.fits[terrain]
        print(
            f"{mp.model}{where}: {values}\n  loss {f.loss:.4g} on {f.segments} segments "
            f"({f.length:.0f} m, {f.duration:.0f} s of log), fitted in {f.seconds:.2f} s"
        )
        if ps.at_bounds:
            print(
                f"  at a search bound: {', '.join(ps.at_bounds)} (not determined by the data, "
                "or the optimum lies beyond the bound)"
            )
    for terrain in report.skipped:
        print(f"terrain {terrain}: no training segment, not fitted")
    between = {"position": "position fixes (start heading fitted to the fixes)",
               "heading": "heading rows (heading change only)", "pose": "full poses"}  # fmt: skip
    for source, anchor in mp.info.get("segments_between", {}).items():
        print(f"segments:   between {between[anchor]} on {source}")


def _print_evaluation(ev: FitEvaluation) -> None:
    from terrain_odom.app.fit import group_name

    print(f"held-out error per metre over h_e = {ev.horizon:g} m: median [q25-q75]")
    for terrain, models in ev.groups.items():
        group = group_name(terrain)
        for name, s in models.items():
            t, r = s.translation, s.rotation
            if t.count == 0:
                print(f"  {group:<10} {name:<18} no window")
                continue
            print(
                f"  {group:<10} {name:<18} {t.median:.4f} [{t.q25:.3f}-{t.q75:.3f}] m/m"
                f"  {r.median:.3f} [{r.q25:.2f}-{r.q75:.2f}] deg/m"
                f"  ({t.count} windows)"
            )


def _logs_from_bags(args: argparse.Namespace) -> None:
    """Replace the bags among ``--wheels`` and ``--eval`` by their imports (into OUT/bag/).

    The import's configuration becomes ``--config`` when that is not given.
    """
    from pathlib import Path

    from terrain_odom.app.fit import YAML_SUFFIXES
    from terrain_odom.app.locate import names_a_file

    folder = Path(args.out).parent if names_a_file(args.out, YAML_SUFFIXES) else args.out
    logs, config = logs_from_bags([*args.wheels, *args.eval], args, folder)
    args.wheels, args.eval = logs[: len(args.wheels)], logs[len(args.wheels) :]
    args.config = args.config or config


def _cmd_fit(args: argparse.Namespace) -> int:
    from terrain_odom.app.fit import YAML_SUFFIXES, fit

    warn_out_file(args.out, YAML_SUFFIXES)
    _logs_from_bags(args)
    report = fit(
        args.wheels, args.model, out_dir=args.out, eval_logs=args.eval, **fit_arguments(args)
    )
    print_pose_delays(report.time_calibration)
    _print_sets(report)
    if report.evaluation is not None:
        _print_evaluation(report.evaluation)
    print(f"parameters: {report.output}")
    return 0
