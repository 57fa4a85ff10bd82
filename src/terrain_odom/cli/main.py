"""Entry point of the ``terrain-odom`` command.

Argument parsing only: each subcommand (one module each) unpacks its
arguments, calls a function of :mod:`terrain_odom.app` and prints the typed
result; the options several subcommands share live in
:mod:`terrain_odom.cli.options`. Errors raised on purpose by the
package (bad input files, invalid configuration) and files the operating
system refuses (read-only, a name too long, a full disk) are printed as one
line, control characters escaped, and exit with code 2; ``SIGTERM`` and
``SIGHUP`` stop a command as Ctrl-C does; a library's warning (numpy's
floating-point ones) is one line at the end of a command that succeeded;
real bugs keep their traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TextIO

from terrain_odom import __version__
from terrain_odom.cli import (
    adopt,
    bag_import,
    calibrate,
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
from terrain_odom.errors import Interrupted, TerrainOdomError

# One module per subcommand, each with ``add_parser(subparsers)``.
SUBCOMMANDS = (
    run,
    calibrate,
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
    adopt,
)

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
TERMINATING_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals handled as Ctrl-C (exit code 128 + the signal's number)."""


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
    with _library_warnings() as caught:
        code = _main(parser, argv)
    if caught and code == 0:  # after an error, its one line says what matters
        print(f"terrain-odom: warning: {printable(caught.describe())}", file=sys.stderr)
    return code


def _main(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> int:
    try:
        with _terminating_signals_interrupt():
            args = parser.parse_args(argv)  # two spellings of one option: a ConfigError
            warn_deprecated_spellings(args)
            return int(args.func(args))
    except TerrainOdomError as exc:
        return _error(str(exc))
    except OSError as exc:  # the operating system refused a file: name it
        if exc.filename is None:
            return _error(exc.strerror or str(exc))
        return _error(f"{exc.filename}: {exc.strerror or exc}")
    except Interrupted as exc:
        print(f"terrain-odom: {exc}; outputs written so far are kept", file=sys.stderr)
        return 128 + exc.signum
    except KeyboardInterrupt:
        print("terrain-odom: interrupted; outputs written so far are kept", file=sys.stderr)
        return EXIT_INTERRUPTED


def _error(message: str) -> int:
    """Print ``message`` as one line (control characters escaped); return :data:`EXIT_USAGE`."""
    print(f"terrain-odom: error: {printable(message)}", file=sys.stderr)
    return EXIT_USAGE


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


class _Caught:
    """Warnings of the libraries (numpy's floating-point ones ...) met during a command."""

    def __init__(self) -> None:
        self.first = ""
        self.count = 0

    def __bool__(self) -> bool:
        return self.count > 0

    def show(
        self,
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        """Count a warning and keep the first (``warnings.showwarning``'s signature)."""
        self.count += 1
        if not self.first:
            where = Path(filename)
            inside = (
                "/".join(where.parts[where.parts.index("terrain_odom") :])
                if "terrain_odom" in where.parts
                else where.name
            )
            self.first = f"{category.__name__}: {message} ({inside}:{lineno})"

    def describe(self) -> str:
        """One line: the first warning, how many others, what it means."""
        more = f" and {self.count - 1} other warning(s)" if self.count > 1 else ""
        return (
            f"{self.first}{more}: the results above were computed past it; check them, and "
            "please report it"
        )


@contextlib.contextmanager
def _library_warnings() -> Iterator[_Caught]:
    """Within: warnings of the libraries are counted, not printed.

    The package raises none itself and handles the non-finite numbers its
    computations may meet; a warning that still reaches this point is printed
    as one line at the end of a command that succeeded, never as the
    library's two lines of source in the middle of the output.
    """
    caught = _Caught()
    with warnings.catch_warnings():  # the filters stay: ``-W error`` (and pytest's) still raise
        warnings.showwarning = caught.show
        yield caught


@contextlib.contextmanager
def _terminating_signals_interrupt() -> Iterator[None]:
    """Within: ``SIGTERM`` and ``SIGHUP`` raise :class:`Interrupted`, as Ctrl-C raises its own.

    A signal the process ignores (``nohup``) stays ignored; after the first
    signal, further ones are ignored while the command cleans up. Only in
    the main thread (where Python delivers signals).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: object) -> None:
        for number in previous:
            signal.signal(number, signal.SIG_IGN)  # let the cleanup finish
        raise Interrupted(signum)

    previous = {
        number: signal.getsignal(number)
        for number in TERMINATING_SIGNALS
        if signal.getsignal(number) is not signal.SIG_IGN
    }
    for number in previous:
        signal.signal(number, interrupt)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


if __name__ == "__main__":
    raise SystemExit(main())
