"""Offline identification of constant kinematic models (Baril et al.; Martinez et al.).

- :mod:`~terrain_odom.fitting.segments`: horizons and training segments.
- :mod:`~terrain_odom.fitting.loss`: the loss (whitened end-pose errors).
- :mod:`~terrain_odom.fitting.identify`: :func:`fit_model`.
- :mod:`~terrain_odom.fitting.params`: the fit results (:class:`ModelParams`,
  :data:`ANY_TERRAIN`), the ICR EKF's priors from them, their checks.
"""

from __future__ import annotations

from terrain_odom.fitting import identify, loss, params, segments
from terrain_odom.fitting.identify import *  # noqa: F403  (re-exports identify.__all__)
from terrain_odom.fitting.loss import *  # noqa: F403  (re-exports loss.__all__)
from terrain_odom.fitting.params import *  # noqa: F403  (re-exports params.__all__)
from terrain_odom.fitting.segments import *  # noqa: F403  (re-exports segments.__all__)

__all__ = [*segments.__all__, *loss.__all__, *identify.__all__, *params.__all__]
