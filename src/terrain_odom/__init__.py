"""terrain-odom: terrain-adaptive odometry for skid-steer and tracked robots.

Conventions (used everywhere in the package): x forward, y left, z up, yaw
counter-clockwise, SI units, angles wrapped to (-pi, pi].
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from terrain_odom.errors import ConfigError, EstimationError, InputFileError, TerrainOdomError

if TYPE_CHECKING:
    from terrain_odom.estimation.online import OnlineOdometry

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

    ``import terrain_odom`` stays light (no filterpy, scikit-learn or SciPy).
    """
    if name == "OnlineOdometry":
        from terrain_odom.estimation.online import OnlineOdometry

        return OnlineOdometry
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


logging.getLogger(__name__).addHandler(logging.NullHandler())
