"""terrain-odom: terrain-adaptive odometry for skid-steer and tracked robots.

Conventions (used everywhere in the package): x forward, y left, z up, yaw
counter-clockwise, SI units, angles wrapped to (-pi, pi].
"""

from __future__ import annotations

import logging

from terrain_odom.errors import ConfigError, EstimationError, InputFileError, TerrainOdomError

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "TerrainOdomError",
    "InputFileError",
    "ConfigError",
    "EstimationError",
]

logging.getLogger(__name__).addHandler(logging.NullHandler())
