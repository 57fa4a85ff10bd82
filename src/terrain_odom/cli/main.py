"""Entry point of the ``terrain-odom`` command.

Argument parsing only: each subcommand (one module each) unpacks its
arguments, calls a function of :mod:`terrain_odom.app` and prints the typed
result; the options several subcommands share live in
:mod:`terrain_odom.cli.options`. Errors raised on purpose by the
package (bad input files, invalid configuration) are printed as one line and
exit with code 2; real bugs keep their traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from terrain_odom import __version__
from terrain_odom.cli import (
    bag_import,
    compare,
    degrade,
    evaluate,
    fit,
    inspect,
    patches,
    report,
    run,
    simulate,
    train,
)
from terrain_odom.cli.options import warn_deprecated_spellings
from terrain_odom.errors import TerrainOdomError

# One module per subcommand, each with ``add_parser(subparsers)``.
SUBCOMMANDS = (
    run,
    evaluate,
    train,
    report,
    simulate,
    degrade,
    fit,
    compare,
    inspect,
    bag_import,
    patches,
)

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser (no heavy imports happen here)."""
    parser = argparse.ArgumentParser(
        prog="terrain-odom",
        description="Terrain-adaptive odometry for skid-steer and tracked robots.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in SUBCOMMANDS:
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)  # two spellings of one option: a ConfigError
        warn_deprecated_spellings(args)
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
