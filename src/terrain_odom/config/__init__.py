"""Typed configuration: every section a frozen dataclass, loaded from YAML and validated.

- :mod:`~terrain_odom.config.sections`: robot, EKFs, terrain, evaluation, time (units and noise conventions there).
- :mod:`~terrain_odom.config.camera`: the camera and the region of interest.
- :mod:`~terrain_odom.config.classifier`: the terrain classifier's features and KNN.
- :mod:`~terrain_odom.config.loader`: one YAML loader with clear messages.
"""

from __future__ import annotations

from terrain_odom.config import camera, classifier, fields, loader, sections
from terrain_odom.config.camera import *  # noqa: F403  (re-exports camera.__all__)
from terrain_odom.config.classifier import *  # noqa: F403  (re-exports classifier.__all__)
from terrain_odom.config.fields import *  # noqa: F403  (re-exports fields.__all__)
from terrain_odom.config.loader import *  # noqa: F403  (re-exports loader.__all__)
from terrain_odom.config.sections import *  # noqa: F403  (re-exports sections.__all__)

__all__ = [
    *sections.__all__,
    *camera.__all__,
    *classifier.__all__,
    *fields.__all__,
    *loader.__all__,
]
