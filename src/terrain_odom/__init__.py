"""terrain-odom: terrain-adaptive odometry for skid-steer and tracked robots.

Conventions (used everywhere in the package): x forward, y left, z up, yaw
counter-clockwise, SI units, angles wrapped to (-pi, pi].
"""

from __future__ import annotations

import importlib
import logging
from typing import Any

from terrain_odom.errors import ConfigError, EstimationError, InputFileError, TerrainOdomError

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "TerrainOdomError",
    "InputFileError",
    "ConfigError",
    "EstimationError",
    "OnlineOdometry",
]


def __getattr__(name: str) -> Any:
    """Import :class:`~terrain_odom.estimation.online.OnlineOdometry` on first use.

    ``import terrain_odom`` stays light (no filterpy, scikit-learn or SciPy), and
    the package root imports no layer (the layers import it for ``__version__``).
    """
    if name == "OnlineOdometry":
        return importlib.import_module("terrain_odom.estimation.online").OnlineOdometry
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


logging.getLogger(__name__).addHandler(logging.NullHandler())
