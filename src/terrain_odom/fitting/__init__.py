"""Offline identification of constant kinematic models (Baril et al.; Martinez et al.).

- :mod:`~terrain_odom.fitting.segments`: horizons and training segments.
- :mod:`~terrain_odom.fitting.loss`: the loss (whitened end-pose errors).
- :mod:`~terrain_odom.fitting.identify`: :func:`fit_model`.
"""

from __future__ import annotations

from terrain_odom.fitting import identify, loss, segments
from terrain_odom.fitting.identify import *  # noqa: F403  (re-exports identify.__all__)
from terrain_odom.fitting.loss import *  # noqa: F403  (re-exports loss.__all__)
from terrain_odom.fitting.segments import *  # noqa: F403  (re-exports segments.__all__)

__all__ = [*segments.__all__, *loss.__all__, *identify.__all__]
