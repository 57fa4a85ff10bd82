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
    "TEXTURE_FAMILIES",
    "COLOUR_SPACES",
    "AUTO",
    "feature_parts",
    "ClassifierConfig",
    "paper_config",
    "is_flat_classifier",
]

PAPER_K = 5
"""Neighbour count of the paper-faithful configuration (Chen et al. do not state theirs)."""

MIN_TILE_SIZE = 8
"""Smallest ``tile_size``, px (SFTA's box counting needs a few box sizes)."""

TEXTURE_FAMILIES = ("sfta", "lbp", "glcm")
"""Texture feature families, in their order in a feature vector (:mod:`terrain_odom.vision.features`)."""

COLOUR_SPACES = ("lab", "hsv")
"""Colour spaces whose channel statistics can follow the texture features."""

AUTO: Literal["auto"] = "auto"
"""``min_tile_size: auto``: chosen from the training images' size (:func:`~terrain_odom.vision.features.auto_min_tile_size`)."""


def feature_parts(features: str) -> tuple[tuple[str, ...], str | None]:
    """Split a ``features`` setting into its texture families and colour space.

    ``features`` joins with ``+`` one or more of :data:`TEXTURE_FAMILIES`
    and at most one of :data:`COLOUR_SPACES`, in any order.

    Returns
    -------
    families : tuple of str
        In the order of :data:`TEXTURE_FAMILIES`.
    colour : str or None

    Raises
    ------
    ConfigError
        An unknown or repeated part, no texture family, two colour spaces.

    Examples
    --------
    >>> feature_parts("lab+lbp+sfta")
    (('sfta', 'lbp'), 'lab')
    >>> feature_parts("glcm")
    (('glcm',), None)
    """
    parts = features.split("+") if isinstance(features, str) else [features]
    unknown = [p for p in parts if p not in TEXTURE_FAMILIES + COLOUR_SPACES]
    if unknown or len(set(parts)) != len(parts):
        raise ConfigError(
            f"features: {features!r} is not texture families ({', '.join(TEXTURE_FAMILIES)}) "
            f"and at most one colour space ({', '.join(COLOUR_SPACES)}) joined by '+', "
            "each once, e.g. sfta+lab"
        )
    families = tuple(f for f in TEXTURE_FAMILIES if f in parts)
    colours = [c for c in COLOUR_SPACES if c in parts]
    if not families or len(colours) > 1:
        raise ConfigError(
            f"features: {features!r} needs at least one texture family "
            f"({', '.join(TEXTURE_FAMILIES)}) and at most one colour space"
        )
    return families, colours[0] if colours else None


def _canonical(features: str) -> str:
    """``features`` with its parts in the canonical order (families, then colour)."""
    families, colour = feature_parts(features)
    return "+".join(families + (() if colour is None else (colour,)))


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
    features : str
        Texture families of the grey image joined by ``+`` (:func:`feature_parts`):
        ``sfta`` (Chen), ``lbp`` (uniform local binary patterns),
        ``glcm`` (grey-level co-occurrence statistics), optionally with the
        mean and standard deviation of each channel of CIE L*a*b* (``lab``)
        or HSV (``hsv``), 6 values; e.g. ``sfta`` (Chen), ``sfta+lab``.
        Stored in the canonical order (families as :data:`TEXTURE_FAMILIES`, then colour).
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
    min_tile_size : int or "auto"
        Smallest tile side, px; ``auto`` (default): the training images'
        median shorter side divided by ``tiles`` (at least :data:`MIN_TILE_SIZE`),
        so that a training image is ``tiles x tiles`` tiles whatever its size;
        ``train`` records the number it chose in the classifier file, and a region
        described without that choice (:func:`~terrain_odom.vision.features.image_features`
        on an ``auto`` configuration) uses its own shorter side. A number: a region is cut into fewer tiles per side
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

    features: str = "sfta+lbp+lab"
    n_t: int = 4
    relative_counts: bool = True
    pyramid_levels: int = 1
    scale: bool = True
    k: int = 5
    weights: Literal["uniform", "distance"] = "distance"
    tiles: int = 4
    min_tile_size: int | Literal["auto"] = AUTO
    tile_size: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "features", _canonical(self.features))
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
