"""``terrain-odom fit``: identify a constant kinematic model from logs with poses."""

from __future__ import annotations

import argparse
import dataclasses
from typing import TYPE_CHECKING, Any

from terrain_odom.cli.evaluate import add_pose_delay_option, pose_delay_line

if TYPE_CHECKING:
    from terrain_odom.config import Config
    from terrain_odom.fitting.identify import FitOptions

MODEL_CHOICES = ("idd", "edd-sym", "edd-asym", "roc", "linear", "icr", "icr-slip")


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
    p.add_argument("--config", help="YAML configuration (wheel radius, track width, h_e)")
    add_pose_delay_option(p)


def fit_options(args: argparse.Namespace) -> FitOptions:
    """Build the :class:`FitOptions` of the command-line arguments (defaults for the rest)."""
    from terrain_odom.errors import ConfigError
    from terrain_odom.fitting.identify import FitOptions

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


def fit_config(args: argparse.Namespace) -> Config:
    """Return the configuration of ``--config`` with ``--pose-delay`` applied."""
    from terrain_odom.config import load_config, with_pose_delay

    return with_pose_delay(load_config(args.config), args.pose_delay)


def print_pose_delays(timing: dict[str, dict[str, Any]]) -> None:
    """Print the pose delay applied to each log, unless all are 0 as given."""
    from terrain_odom.estimation.time_offset import shows_pose_delay

    if any(shows_pose_delay(t) for t in timing.values()):
        for source, t in timing.items():
            print(f"{source}: {pose_delay_line(t)}")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``fit`` subcommand."""
    p = sub.add_parser("fit", help="fit a constant kinematic model to logs with poses")
    add_fit_options(p)
    p.add_argument("--model", required=True, choices=MODEL_CHOICES, help="model to fit")
    p.add_argument("--eval", nargs="+", default=[], help="held-out logs to evaluate the fit on")
    p.add_argument("--out", required=True, help="parameter file to write (YAML)")
    p.set_defaults(func=_cmd_fit)


def _cmd_fit(args: argparse.Namespace) -> int:
    from terrain_odom.app.fit import fit
    from terrain_odom.fitting.identify import DEFAULT_TRAINING_HORIZON

    report = fit(
        args.log,
        args.model,
        out=args.out,
        horizon=args.horizon or DEFAULT_TRAINING_HORIZON,
        eval_logs=args.eval,
        by_terrain=args.by_terrain,
        options=fit_options(args),
        config=fit_config(args),
        config_path=args.config,
    )
    print_pose_delays(report.time_calibration)
    mp = report.params
    for terrain, ps in mp.sets.items():
        where = "" if terrain == "*" else f" [{terrain}]"
        values = ", ".join(f"{k}={v:.4f}" for k, v in ps.params.items()) or "(no parameter)"
        f = ps.fit
        print(
            f"{mp.model}{where}: {values}\n  loss {f['loss']:.4g} on {int(f['segments'])} segments "
            f"({f['length_m']:.0f} m, {f['duration_s']:.0f} s of log), fitted in {f['seconds']:.2f} s"
        )
    for terrain in report.skipped:
        print(f"terrain {terrain}: no training segment, not fitted")
    if report.evaluation:
        ev = report.evaluation
        print(f"held-out error per metre over h_e = {ev['horizon_m']:g} m: median [q25-q75]")
        for group, models in ev["groups"].items():
            for name, s in models.items():
                t, r = s["translation_m_per_m"], s["rotation_deg_per_m"]
                if t["count"] == 0:
                    print(f"  {group:<10} {name:<18} no window")
                    continue
                print(
                    f"  {group:<10} {name:<18} {t['median']:.4f} [{t['q25']:.3f}-{t['q75']:.3f}] m/m"
                    f"  {r['median']:.3f} [{r['q25']:.2f}-{r['q75']:.2f}] deg/m"
                    f"  ({t['count']} windows)"
                )
    print(f"parameters: {args.out}")
    return 0
