"""Entry point of the ``terrain-odom`` command.

Argument parsing only: each subcommand unpacks its arguments and calls a
function of :mod:`terrain_odom.workflows`. Errors raised on purpose by the
package (bad input files, invalid configuration) are printed as one line and
exit with code 2; real bugs keep their traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from terrain_odom import __version__
from terrain_odom.errors import TerrainOdomError

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


def _cmd_run(args: argparse.Namespace) -> int:
    from terrain_odom.workflows import TerrainSource, run

    if args.no_terrain:
        source = TerrainSource.NONE
    elif args.terrain_from_log:
        source = TerrainSource.LOG
    else:
        source = TerrainSource.AUTO
    summary = run(args.wheels, args.out, config_path=args.config, terrain=source)
    print(f"{summary.rows} rows in {summary.seconds:.2f} s")
    print(f"trajectory: {summary.trajectory_csv}")
    print(f"report:     {summary.report_json}")
    return 0


def _format_stats(entry: dict) -> str:
    t, r = entry["translation_m_per_m"], entry["rotation_deg_per_m"]
    ate = entry["ate_dead_reckoning"]["rmse_m"]

    def fmt(v: float | None, digits: int) -> str:
        return "n/a" if v is None else f"{v:.{digits}f}"

    return (
        f"{fmt(t['median'], 4):>8} [{fmt(t['q25'], 3)}-{fmt(t['q75'], 3)}]"
        f"  {fmt(r['median'], 3):>7} [{fmt(r['q25'], 2)}-{fmt(r['q75'], 2)}]"
        f"  {fmt(ate, 2):>8}"
    )


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from terrain_odom.workflows import evaluate

    result = evaluate(
        args.run,
        args.log,
        config_path=args.config,
        params=args.params,
        horizon=args.horizon,
        out=args.out,
    )
    print(f"{result['windows']} windows of {result['horizon_m']:g} m on {result['log']}")
    print(f"{'model':<32} {'m/m median [q25-q75]':>24}  {'deg/m median [q25-q75]':>22}  ATE DR (m)")
    for name, entry in result["models"].items():
        print(f"{name:<32} {_format_stats(entry)}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser (no heavy imports happen here)."""
    parser = argparse.ArgumentParser(
        prog="terrain-odom",
        description="Terrain-adaptive odometry for skid-steer and tracked robots.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="EKF odometry over a wheel log (terrain-adaptive)")
    p.add_argument("--wheels", required=True, help="wheel log CSV")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--config", help="YAML configuration (default: built-in defaults)")
    terrain = p.add_mutually_exclusive_group()
    terrain.add_argument(
        "--terrain-from-log",
        action="store_true",
        help="drive the covariance reset from the log's terrain column (required to exist)",
    )
    terrain.add_argument(
        "--no-terrain", action="store_true", help="ignore terrain labels (plain ICR EKF)"
    )
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("evaluate", help="model-odometry error per metre and ATE")
    p.add_argument("--log", required=True, help="wheel log CSV with pose measurements")
    p.add_argument("--run", help="output directory of 'terrain-odom run' on this log")
    p.add_argument("--params", nargs="*", default=[], help="parameter files of constant models")
    p.add_argument("--config", help="YAML configuration (robot geometry, horizon)")
    p.add_argument("--horizon", type=float, help="evaluation horizon h_e in metres (default 2)")
    p.add_argument("--out", help="JSON output (default RUN/evaluation.json)")
    p.set_defaults(func=_cmd_evaluate)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except TerrainOdomError as exc:
        print(f"terrain-odom: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except (
        FileNotFoundError,
        FileExistsError,
        IsADirectoryError,
        NotADirectoryError,
        PermissionError,
    ) as exc:
        print(f"terrain-odom: error: {exc.filename}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("terrain-odom: interrupted; outputs written so far are kept", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    raise SystemExit(main())
