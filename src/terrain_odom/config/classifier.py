"""Settings of the terrain classifier: features, tiles and KNN (pure data).

:class:`ClassifierConfig` is a frozen dataclass validated by
:func:`~terrain_odom.config.fields.build_section` like every section of the
run configuration (it is the ``classifier`` section of
:class:`~terrain_odom.config.sections.Config`); :func:`paper_config` is Chen
et al.'s recipe (2023, §3.2.3), and
:func:`~terrain_odom.config.loader.load_classifier_config` reads the settings
of a configuration file. What
the settings do is described in :mod:`terrain_odom.vision.classifier` and
:mod:`terrain_odom.vision.features`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Literal

from terrain_odom.errors import ConfigError

__all__ = [
    "PAPER_K",
    "MIN_TILE_SIZE",
    "FEATURE_FIELDS",
    "FeatureOption",
    "ClassifierConfig",
    "paper_config",
    "is_flat_classifier",
]

PAPER_K = 5
"""Neighbour count of the paper-faithful configuration (Chen et al. do not state theirs)."""

MIN_TILE_SIZE = 8
"""Smallest ``tile_size``, px (SFTA's box counting needs a few box sizes)."""

FeatureOption = Literal["sfta", "sfta+lab", "sfta+hsv"]

FEATURE_FIELDS = (
    "features",
    "n_t",
    "relative_counts",
    "pyramid_levels",
    "tiles",
    "min_tile_size",
    "tile_size",
)
"""Fields of :class:`ClassifierConfig` that change the feature vectors."""


@dataclass(frozen=True)
class ClassifierConfig:
    """Features and KNN settings of the terrain classifier.

    Attributes
    ----------
    features : {"sfta", "sfta+lab", "sfta+hsv"}
        Grey SFTA only (Chen), or SFTA plus the mean and standard deviation
        of each channel of CIE L*a*b* or HSV (6 values).
    n_t : int
        Number of multi-level Otsu thresholds of SFTA (``6 * n_t`` values).
    relative_counts : bool
        SFTA's pixel counts ``C_i`` as fractions of the region's area (True)
        or as pixel counts (False, Chen).
    pyramid_levels : int
        SFTA of the region at ``pyramid_levels`` scales (full, 1/2, 1/4, ...).
    scale : bool
        Standardise every feature to zero mean, unit variance on the training
        set before the distance (False: raw Euclidean distance, eq. 24).
    k : int
        Number of neighbours voting (eq. 25-26).
    weights : {"uniform", "distance"}
        Each neighbour's vote counts 1 (Chen) or ``1 / distance``.
    tiles : int
        Most tiles per side for tile voting; 1 classifies the whole region.
    min_tile_size : int
        Smallest tile side, px: a region is cut into fewer tiles per side
        when ``tiles`` would make them smaller (:func:`~terrain_odom.vision.features.tiles_per_side`), and
        a region under ``2 * min_tile_size`` px a side is one tile. Box
        counting fits the box sides ``1, 2, 4, ...`` up to the first at which
        every box is occupied: in 16 px tiles of floor photos or skimage's
        textures that leaves about 3 sizes (up to 17 % of the dimensions are
        two-point slopes), in 32 px tiles about 4 (at most 3 %). 64x64
        skimage patches: 96.4 % with 16 px tiles, 98.4 % with 32 px.
    tile_size : int or None
        If set, px (>= 8): tiles of about this side instead, as many as fit
        (:func:`~terrain_odom.vision.features.tile_grid`; ``tiles`` and ``min_tile_size`` are then unused).
        A region's time is then proportional to its area.
    """

    features: FeatureOption = "sfta+lab"
    n_t: int = 4
    relative_counts: bool = True
    pyramid_levels: int = 1
    scale: bool = True
    k: int = 5
    weights: Literal["uniform", "distance"] = "distance"
    tiles: int = 4
    min_tile_size: int = 32
    tile_size: int | None = None

    def __post_init__(self) -> None:
        if self.tile_size is not None and self.tile_size < MIN_TILE_SIZE:
            raise ConfigError(f"tile_size: must be >= {MIN_TILE_SIZE} px, got {self.tile_size}")

    def feature_key(self) -> dict[str, Any]:
        """Return the fields that define the feature vectors (:data:`FEATURE_FIELDS`)."""
        return {name: getattr(self, name) for name in FEATURE_FIELDS}


def paper_config(n_t: int = 4) -> ClassifierConfig:
    """Return Chen et al.'s recipe: grey SFTA, raw counts and distances, ``k = PAPER_K``."""
    return ClassifierConfig(
        features="sfta",
        n_t=n_t,
        relative_counts=False,
        pyramid_levels=1,
        scale=False,
        k=PAPER_K,
        weights="uniform",
        tiles=1,
    )


def is_flat_classifier(data: Any) -> bool:
    """Return whether YAML data is a flat classifier file: only classifier keys, at the top level.

    The old layout of the classifier settings, before they became the
    ``classifier`` section of the configuration.

    Examples
    --------
    >>> is_flat_classifier({"k": 3, "tiles": 1}), is_flat_classifier({"classifier": {"k": 3}})
    (True, False)
    """
    names = {f.name for f in fields(ClassifierConfig)}
    return isinstance(data, dict) and bool(data) and all(key in names for key in data)
