"""Offline identification of constant kinematic models (Baril et al.; Martínez et al.).

See :mod:`terrain_odom.fitting.identify`.
"""

from __future__ import annotations

from terrain_odom.fitting.identify import (
    DEFAULT_TRAINING_HORIZON,
    FitOptions,
    FitResult,
    Horizon,
    SegmentSet,
    fit_model,
    parse_horizon,
    segment_set,
    training_windows,
)

__all__ = [
    "DEFAULT_TRAINING_HORIZON",
    "Horizon",
    "FitOptions",
    "FitResult",
    "SegmentSet",
    "parse_horizon",
    "training_windows",
    "segment_set",
    "fit_model",
]
