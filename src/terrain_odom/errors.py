"""Exception classes of terrain-odom.

Every error the package raises on purpose derives from :class:`TerrainOdomError`,
so that the command line can print it as one line and exit with code 2, while
real bugs keep their traceback.
"""

from __future__ import annotations

__all__ = ["TerrainOdomError", "InputFileError", "ConfigError", "EstimationError"]


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
