"""Exception classes of terrain-odom.

Every error the package raises on purpose derives from :class:`TerrainOdomError`,
so that the command line can print it as one line and exit with code 2, while
real bugs keep their traceback.
"""

from __future__ import annotations

import signal

__all__ = ["TerrainOdomError", "InputFileError", "ConfigError", "EstimationError", "Interrupted"]


class TerrainOdomError(Exception):
    """Base class of every error raised on purpose by terrain-odom."""


class InputFileError(TerrainOdomError, ValueError):
    """An input file is missing, empty or malformed.

    The message names the file and, where it applies, the row and column.
    """


class ConfigError(TerrainOdomError, ValueError):
    """A configuration file or value is invalid; the message names the key."""


class EstimationError(TerrainOdomError, ArithmeticError):
    """An estimator reached a state it cannot continue from (e.g. ``y_l <= y_r``)."""


class Interrupted(KeyboardInterrupt):
    """A termination signal (``SIGTERM``, ``SIGHUP``) received: stop as on Ctrl-C.

    A ``KeyboardInterrupt``, so that whatever cleans up after Ctrl-C (a run
    marking itself interrupted) does so after these signals too.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum

    def __str__(self) -> str:
        return f"interrupted by {signal.Signals(self.signum).name}"
