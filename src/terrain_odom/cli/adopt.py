"""``terrain-odom adopt``: record a folder's files as a command's (a folder from before manifests)."""

from __future__ import annotations

import argparse

BY = {"report": "report accuracy"}
"""``--by`` words that name a command of two words."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``adopt`` subcommand."""
    from terrain_odom.app.adopt import WRITERS

    p = sub.add_parser(
        "adopt",
        help="record a folder's files as written by a command (folders from before manifests)",
    )
    p.add_argument("folder", metavar="DIR", help="the output folder")
    p.add_argument(
        "--by",
        required=True,
        choices=[w.split()[0] for w in WRITERS],
        help="the command that wrote them (report: report accuracy)",
    )
    p.add_argument(
        "--only",
        nargs="+",
        default=[],
        metavar="FILE",
        help="adopt only these files, relative to DIR (default: every file the manifest does not record)",
    )
    p.set_defaults(func=_cmd_adopt)


def _cmd_adopt(args: argparse.Namespace) -> int:
    from terrain_odom.app.adopt import adopt
    from terrain_odom.cli.main import printable  # file names as found: escaped

    done = adopt(args.folder, BY.get(args.by, args.by), args.only)
    names = ", ".join(printable(name) for name in done.adopted[:5])
    more = f" and {len(done.adopted) - 5} more" if len(done.adopted) > 5 else ""
    print(
        f"{printable(str(done.folder))}: {_files(len(done.adopted))} recorded as written by "
        f"terrain-odom {done.command}" + (f" ({names}{more})" if names else "")
    )
    if done.kept:
        print(f"already recorded, left as they were: {_files(len(done.kept))}")
    return 0


def _files(n: int) -> str:
    return f"{n} file" if n == 1 else f"{n} files"
