"""KNN terrain classifier on SFTA texture features (Chen et al. 2023, §3.2.3).

Chen et al. describe each image region by the 24 SFTA values of its grey image
(eq. 18-21) and classify it by the majority vote of its ``k`` nearest
training samples in raw Euclidean distance (eq. 23-26). This module keeps
that recipe selectable (``features="sfta"``, ``relative_counts=False``,
``scale=False``, see :func:`paper_config`) and adds, each as an option of
:class:`ClassifierConfig`:

- **standardisation** (``scale``): the raw SFTA values differ by orders of
  magnitude (border pixel counts ~1e4, fractal dimensions ~1.5), so the raw
  distance of eq. 24 is dominated by the counts;
- **relative counts** (``relative_counts``): SFTA's pixel counts ``C_i`` as
  fractions of the region's area (as :func:`~terrain_odom.vision.sfta.sfta_features`
  returns them), so that regions of any size (tiles, regions of interest)
  compare with the training images; the paper's raw counts scale with the
  region's size;
- **colour statistics** (``features="sfta+lab"`` or ``"sfta+hsv"``): grey
  SFTA throws away colour, which is what separates e.g. wood from carpet;
- **image pyramid** (``pyramid_levels``): SFTA also of the region halved
  ``1, 2, ...`` times, describing the texture at coarser scales;
- **tile voting** (``tiles``, ``min_tile_size``, or ``tile_size``): a region
  is cut into up to ``tiles x tiles`` tiles of at least ``min_tile_size``
  pixels a side (:func:`tiles_per_side`), or, with ``tile_size``, into tiles
  of about ``tile_size`` pixels a side whatever the region's size
  (:func:`tile_grid`), each tile is classified, and the region gets the
  majority label with the vote share as its confidence. Fixed-size tiles
  describe every region at the scale of the training tiles, and make the
  time a region takes proportional to its area, which is what a region of
  interest saves (Chen's Table 2);
- **distance weighting** of the neighbours' votes (``weights``).

Regions of different sizes have different numbers of tiles, so the features
of several regions are *flat*: one row per tile, ``(n_tiles, n_features)``,
and a ``region`` index ``(n_tiles,)`` giving the region (0, 1, ...) of each
row.

A KNN model *is* its training set: :meth:`TerrainClassifier.save` writes the
training features, labels, region index, scaler parameters and metadata to
one ``.npz`` file (no pickle), and :meth:`TerrainClassifier.load` refuses a
model whose file or feature format differs from this code's.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray
from skimage.measure import points_in_poly
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from terrain_odom import __version__
from terrain_odom.config.fields import build_section
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.atomic import write_atomic
from terrain_odom.vision.sfta import sfta_features

__all__ = [
    "FEATURE_VERSION",
    "MODEL_FORMAT_VERSION",
    "PAPER_K",
    "FEATURE_FIELDS",
    "ClassifierConfig",
    "paper_config",
    "load_classifier_config",
    "colour_statistics",
    "region_features",
    "tiles_per_side",
    "tile_grid",
    "split_tiles",
    "tiles_within",
    "image_features",
    "make_pipeline",
    "check_regions",
    "TerrainClassifier",
]

FEATURE_VERSION = 2
"""Version of the feature vector; bump it whenever :func:`image_features` changes."""

MODEL_FORMAT_VERSION = 2
"""Version of the model file layout written by :meth:`TerrainClassifier.save`."""

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
        when ``tiles`` would make them smaller (:func:`tiles_per_side`), and
        a region under ``2 * min_tile_size`` px a side is one tile. Box
        counting fits the box sides ``1, 2, 4, ...`` up to the first at which
        every box is occupied: in 16 px tiles of floor photos or skimage's
        textures that leaves about 3 sizes (up to 17 % of the dimensions are
        two-point slopes), in 32 px tiles about 4 (at most 3 %). 64x64
        skimage patches: 96.4 % with 16 px tiles, 98.4 % with 32 px.
    tile_size : int or None
        If set, px (>= 8): tiles of about this side instead, as many as fit
        (:func:`tile_grid`; ``tiles`` and ``min_tile_size`` are then unused).
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


def load_classifier_config(
    path: str | Path | None = None, overrides: Mapping[str, Any] | None = None
) -> ClassifierConfig:
    """Load a classifier configuration (YAML, keys of :class:`ClassifierConfig`).

    A file holds any subset of the fields at its top level, e.g. Chen et
    al.'s recipe::

        features: sfta
        relative_counts: false
        scale: false
        k: 5
        weights: uniform
        tiles: 1

    Parameters
    ----------
    path : str or Path, optional
        YAML file; keys left out keep the defaults. ``None``: the defaults.
    overrides : mapping, optional
        Values that replace those of the file (e.g. command-line options),
        validated by the same rules.

    Raises
    ------
    ConfigError
        Naming the file and the first unknown or invalid key.
    """
    cfg = ClassifierConfig()
    if path is not None:
        path = Path(path)
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ConfigError(f"{path}: config file not found") from None
        except OSError as exc:
            raise ConfigError(f"{path}: cannot read config file ({exc.strerror})") from None
        except yaml.YAMLError:
            raise ConfigError(f"{path}: not valid YAML") from None
        try:
            cfg = build_section(cfg, data or {})
        except ConfigError as exc:
            raise ConfigError(f"{path}: {exc}") from None
    return build_section(cfg, dict(overrides or {}))


_HUE_LEVELS = 180  # OpenCV's 8-bit hue: 2 degrees per level
_HUE_COS = np.cos(np.arange(_HUE_LEVELS) * (np.pi / 90.0))
_HUE_SIN = np.sin(np.arange(_HUE_LEVELS) * (np.pi / 90.0))


def colour_statistics(image_rgb: NDArray[np.uint8], space: Literal["lab", "hsv"]) -> NDArray:
    """Mean and standard deviation of each channel of a colour space.

    Parameters
    ----------
    image_rgb : ndarray of uint8, shape (H, W, 3)
        RGB image.
    space : {"lab", "hsv"}
        CIE L*a*b* (OpenCV's 8-bit scaling: L in [0, 255], a and b offset by
        128) or HSV (H in [0, 180) as OpenCV, S and V in [0, 255]). The hue
        of HSV is an angle, so its "mean" and "spread" are those of the
        circular statistics, in OpenCV hue units: the direction of the mean
        hue vector and ``sqrt(-2 ln R)`` (R its length).

    Returns
    -------
    ndarray of float64, shape (6,)
        ``[mean_0, std_0, mean_1, std_1, mean_2, std_2]``.
    """
    return _channel_statistics(_convert(image_rgb, space), space)


def _convert(image_rgb: NDArray[np.uint8], space: Literal["lab", "hsv"]) -> NDArray[np.uint8]:
    code = cv2.COLOR_RGB2Lab if space == "lab" else cv2.COLOR_RGB2HSV
    return cv2.cvtColor(np.ascontiguousarray(image_rgb), code)


def _channel_statistics(converted: NDArray[np.uint8], space: Literal["lab", "hsv"]) -> NDArray:
    """:func:`colour_statistics` of an image already converted to ``space``."""
    mean, std = cv2.meanStdDev(np.ascontiguousarray(converted))
    out = np.column_stack((mean.ravel(), std.ravel())).ravel()
    if space == "hsv":
        hue = converted[..., 0].ravel()
        hist = np.bincount(hue, minlength=_HUE_LEVELS) / hue.size
        c, s = hist @ _HUE_COS, hist @ _HUE_SIN
        length = min(np.hypot(c, s), 1.0)
        out[0] = (np.arctan2(s, c) % (2.0 * np.pi)) * (90.0 / np.pi)
        out[1] = np.sqrt(-2.0 * np.log(max(length, 1e-12))) * (90.0 / np.pi)
    return out


def _colour_space(cfg: ClassifierConfig) -> Literal["lab", "hsv"] | None:
    return {"sfta": None, "sfta+lab": "lab", "sfta+hsv": "hsv"}[cfg.features]


def _features(
    image_rgb: NDArray[np.uint8], converted: NDArray[np.uint8] | None, cfg: ClassifierConfig
) -> NDArray:
    """:func:`region_features` given the region already in the colour space, if any."""
    parts = []
    level = image_rgb
    for depth in range(cfg.pyramid_levels):
        if depth:
            height, width = level.shape[:2]
            size = (max(width // 2, 1), max(height // 2, 1))
            level = cv2.resize(level, size, interpolation=cv2.INTER_AREA)
        sfta = np.array(sfta_features(level, cfg.n_t), dtype=np.float64)
        if not cfg.relative_counts:  # sfta_features gives fractions of the area
            sfta[1::3] *= level.shape[0] * level.shape[1]
        parts.append(sfta)
    space = _colour_space(cfg)
    if space is not None:
        parts.append(_channel_statistics(converted, space))
    return np.concatenate(parts)


def region_features(image_rgb: NDArray[np.uint8], cfg: ClassifierConfig) -> NDArray:
    """Feature vector of one image region (a whole region or one tile).

    Parameters
    ----------
    image_rgb : ndarray of uint8, shape (H, W, 3)
        RGB region.
    cfg : ClassifierConfig

    Returns
    -------
    ndarray of float64, shape (n_features,)
        The ``6 * n_t`` SFTA values of each pyramid level (full size first,
        then halved; counts ``C_i`` times the level's pixel count unless
        ``cfg.relative_counts``), then the 6 colour statistics if any:
        ``n_features = 6 * n_t * pyramid_levels (+ 6)``.
    """
    space = _colour_space(cfg)
    return _features(image_rgb, None if space is None else _convert(image_rgb, space), cfg)


def tiles_per_side(height: int, width: int, cfg: ClassifierConfig) -> int:
    """Return the number of tiles per side of a ``height x width`` region.

    ``min(cfg.tiles, max(1, min(height, width) // cfg.min_tile_size))``: as
    many as ``cfg.tiles`` allows with tiles of at least ``cfg.min_tile_size``
    pixels a side, and at least one.

    >>> cfg = ClassifierConfig(tiles=4, min_tile_size=32)
    >>> tiles_per_side(427, 320, cfg), tiles_per_side(120, 160, cfg), tiles_per_side(64, 64, cfg)
    (4, 3, 2)
    >>> tiles_per_side(63, 200, cfg)
    1
    """
    return min(cfg.tiles, max(1, min(height, width) // cfg.min_tile_size))


def tile_grid(height: int, width: int, cfg: ClassifierConfig) -> tuple[int, int]:
    """Return the tile rows and columns of a ``height x width`` region.

    With ``cfg.tile_size`` set: ``round(height / tile_size)`` rows and
    ``round(width / tile_size)`` columns (halves up, at least one each), so
    tile sides are within ``[2/3, 3/2] * tile_size`` once the region is at
    least ``tile_size`` a side; otherwise ``n x n`` with
    ``n = tiles_per_side(height, width, cfg)``.

    >>> cfg = ClassifierConfig(tile_size=64)
    >>> tile_grid(240, 320, cfg), tile_grid(96, 100, cfg), tile_grid(20, 500, cfg)
    ((4, 5), (2, 2), (1, 8))
    >>> tile_grid(240, 320, ClassifierConfig())
    (4, 4)
    """
    if cfg.tile_size is None:
        n = tiles_per_side(height, width, cfg)
        return n, n
    return (
        max(1, int(height / cfg.tile_size + 0.5)),
        max(1, int(width / cfg.tile_size + 0.5)),
    )


def _tile_edges(height: int, width: int, tiles: int, columns: int) -> tuple[NDArray, NDArray]:
    """Row and column edges of a ``tiles x columns`` grid: ``round(i * H / tiles)``, ..."""
    if tiles > height or columns > width:
        raise ValueError(f"cannot cut a {height}x{width} image into {tiles}x{columns} tiles")
    rows = np.rint(np.linspace(0, height, tiles + 1)).astype(int)
    cols = np.rint(np.linspace(0, width, columns + 1)).astype(int)
    return rows, cols


def split_tiles(image: NDArray, tiles: int, columns: int | None = None) -> list[NDArray]:
    """Cut an image into ``tiles`` rows by ``columns`` (default ``tiles``) columns of tiles.

    Tiles come row by row. Tile edges are at ``round(i * H / tiles)`` and
    ``round(j * W / columns)``, so every pixel belongs to exactly one tile.

    >>> [t.shape for t in split_tiles(np.zeros((5, 4)), 2)]
    [(2, 2), (2, 2), (3, 2), (3, 2)]
    >>> [t.shape for t in split_tiles(np.zeros((4, 9)), 1, 3)]
    [(4, 3), (4, 3), (4, 3)]
    """
    columns = tiles if columns is None else columns
    rows, cols = _tile_edges(image.shape[0], image.shape[1], tiles, columns)
    return [
        image[rows[i] : rows[i + 1], cols[j] : cols[j + 1]]
        for i in range(tiles)
        for j in range(columns)
    ]


def tiles_within(height: int, width: int, cfg: ClassifierConfig, polygon: ArrayLike) -> NDArray:
    """Return the :func:`tile_grid` tiles whose centre is inside a polygon.

    Parameters
    ----------
    height, width : int
        Region size, px.
    cfg : ClassifierConfig
    polygon : array_like, shape (M, 2)
        ``(u, v)`` vertices in region pixels (pixel centres at integers),
        e.g. the visible footprint of a region of interest.

    Returns
    -------
    ndarray of intp
        Tile indices, row by row, of the tiles whose centre is inside the
        polygon (``skimage.measure.points_in_poly``; a centre exactly on an
        edge may fall either way); if there is none, the one tile nearest the polygon's
        vertex mean, so that a region is never left without a tile.

    >>> square = [(0, 0), (99, 0), (99, 99), (0, 99)]
    >>> tiles_within(100, 200, ClassifierConfig(tile_size=50), square).tolist()
    [0, 1, 4, 5]
    """
    grid = tile_grid(height, width, cfg)
    rows, cols = _tile_edges(height, width, *grid)
    v, u = np.meshgrid(
        (rows[:-1] + rows[1:] - 1) / 2.0, (cols[:-1] + cols[1:] - 1) / 2.0, indexing="ij"
    )
    centres = np.column_stack((u.ravel(), v.ravel()))
    vertices = np.asarray(polygon, dtype=float).reshape(-1, 2)
    inside = points_in_poly(centres, vertices)
    if inside.any():
        return np.flatnonzero(inside)
    nearest = np.argmin(np.sum((centres - vertices.mean(axis=0)) ** 2, axis=1))
    return np.array([nearest], dtype=np.intp)


def image_features(
    image_rgb: NDArray[np.uint8], cfg: ClassifierConfig, within: ArrayLike | None = None
) -> NDArray:
    """Feature vectors of the tiles of a region.

    Parameters
    ----------
    image_rgb : ndarray of uint8, shape (H, W, 3)
        RGB region of any size.
    cfg : ClassifierConfig
    within : array_like, shape (M, 2), optional
        A polygon in region pixels: only the tiles whose centre it contains
        are described (:func:`tiles_within`), e.g. the footprint of a region
        of interest inside its bounding box.

    Returns
    -------
    ndarray of float64, shape (n_tiles, n_features)
        :func:`region_features` of each tile (of those within the polygon),
        row by row, of the :func:`tile_grid` of the region (one row for a
        single tile).
    """
    image_rgb = np.asarray(image_rgb)
    if image_rgb.ndim != 3 or image_rgb.shape[2] != 3 or image_rgb.dtype != np.uint8:
        raise ValueError(
            f"expected an RGB uint8 image (H, W, 3), got {image_rgb.dtype} {image_rgb.shape}"
        )
    height, width = image_rgb.shape[:2]
    grid = tile_grid(height, width, cfg)
    keep = range(grid[0] * grid[1]) if within is None else tiles_within(height, width, cfg, within)
    rgb_tiles = split_tiles(image_rgb, *grid)
    space = _colour_space(cfg)
    if space is None:
        return np.stack([_features(rgb_tiles[i], None, cfg) for i in keep])
    colour_tiles = split_tiles(_convert(image_rgb, space), *grid)  # one conversion
    return np.stack([_features(rgb_tiles[i], colour_tiles[i], cfg) for i in keep])


def make_pipeline(cfg: ClassifierConfig) -> Pipeline:
    """Return the unfitted scikit-learn pipeline of a configuration.

    ``StandardScaler`` then ``KNeighborsClassifier(k, weights)`` with
    Euclidean distance; without the scaler when ``cfg.scale`` is False (the
    raw distance of eq. 24).
    """
    steps: list[tuple[str, Any]] = [("scaler", StandardScaler())] if cfg.scale else []
    steps.append(("knn", KNeighborsClassifier(n_neighbors=cfg.k, weights=cfg.weights)))
    return Pipeline(steps)


def check_regions(
    features: NDArray, region: NDArray | None = None, n_regions: int | None = None
) -> tuple[NDArray, NDArray, NDArray]:
    """Check flat tile features and their region index.

    Parameters
    ----------
    features : array_like, shape (n_tiles, n_features)
        One row per tile, e.g. :func:`image_features` of several regions
        concatenated.
    region : array_like of int, shape (n_tiles,), optional
        Region of each row, numbered ``0 .. n_regions - 1`` in any order;
        every region has at least one row. Default: each row is a region.
    n_regions : int, optional
        Number of regions (default: ``max(region) + 1``).

    Returns
    -------
    features : ndarray of float64, shape (n_tiles, n_features)
    region : ndarray of intp, shape (n_tiles,)
    tile_counts : ndarray of intp, shape (n_regions,)
        Rows of each region.

    Raises
    ------
    ValueError
        Shapes that do not match, or a region without rows.

    >>> check_regions([[0.0], [1.0], [2.0]], [1, 0, 1])[2].tolist()
    [1, 2]
    """
    features = np.asarray(features, dtype=np.float64)
    if features.ndim != 2:
        raise ValueError(f"features must have shape (n_tiles, n_features), got {features.shape}")
    if region is None:
        region = np.arange(features.shape[0])
    region = np.asarray(region)
    if region.shape != features.shape[:1] or (region.size and region.dtype.kind not in "iu"):
        raise ValueError(
            f"region must hold one integer per feature row ({features.shape[0]}), "
            f"got {region.dtype} {region.shape}"
        )
    region = region.astype(np.intp, copy=False)
    if n_regions is None:
        n_regions = int(region.max()) + 1 if region.size else 0
    if region.size and (region.min() < 0 or region.max() >= n_regions):
        raise ValueError(f"region numbers must be in 0 .. {n_regions - 1}")
    tile_counts = np.bincount(region, minlength=n_regions)
    if not np.all(tile_counts):
        empty = np.flatnonzero(tile_counts == 0)
        raise ValueError(f"region(s) {empty[:5].tolist()} have no feature rows")
    return features, region, tile_counts


class TerrainClassifier:
    """KNN terrain classifier with optional tile voting.

    Features come flat, one row per tile, with a ``region`` index telling
    which region (image) each row belongs to (see :func:`check_regions`);
    without it every row is a region of its own.

    Parameters
    ----------
    cfg : ClassifierConfig, optional
        Features and KNN settings (default: :class:`ClassifierConfig`).

    Examples
    --------
    >>> clf = TerrainClassifier(ClassifierConfig(k=1)).fit(
    ...     np.array([[0.0, 0.0], [1.0, 1.0]]), np.array(["grass", "gravel"]))
    >>> clf.predict(np.array([[0.1, 0.2]])).tolist()
    ['grass']
    >>> clf.predict(np.array([[0.1, 0.2], [0.9, 0.8], [0.7, 0.9]]), region=[0, 1, 1]).tolist()
    ['grass', 'gravel']
    """

    def __init__(self, cfg: ClassifierConfig | None = None) -> None:
        self.cfg = cfg if cfg is not None else ClassifierConfig()
        self.pipeline = make_pipeline(self.cfg)
        self.training_features = np.empty((0, 0))
        self.training_labels = np.empty(0, dtype=str)
        self.training_region = np.empty(0, dtype=np.intp)

    @property
    def classes(self) -> list[str]:
        """Class names, sorted (the columns of :meth:`predict_proba`)."""
        return [str(c) for c in self.pipeline.classes_]

    @property
    def n_training_images(self) -> int:
        """Number of training regions (images); 0 before :meth:`fit`."""
        return int(self.training_region.max()) + 1 if self.training_region.size else 0

    def fit(
        self, features: NDArray, labels: NDArray, region: NDArray | None = None
    ) -> TerrainClassifier:
        """Fit on the tiles of labelled regions.

        Parameters
        ----------
        features : ndarray, shape (n_tiles, n_features)
            The :func:`image_features` rows of every training region.
        labels : array_like of str, shape (n_regions,)
            Terrain of each region; every tile of a region gets its label.
        region : array_like of int, shape (n_tiles,), optional
            Region of each row (:func:`check_regions`); default: each row is
            a region.

        Returns
        -------
        TerrainClassifier
            ``self``.

        Raises
        ------
        ConfigError
            ``k`` is larger than the number of training samples (tiles).
        ValueError
            ``features``, ``labels`` and ``region`` do not match.
        """
        labels = np.asarray(labels).astype(str)
        if labels.ndim != 1:
            raise ValueError(f"labels must have shape (n_regions,), got {labels.shape}")
        features, region, _ = check_regions(features, region, labels.size)
        if self.cfg.k > features.shape[0]:
            raise ConfigError(
                f"k: {self.cfg.k} neighbours but only {features.shape[0]} training samples"
            )
        self.training_features = features
        self.training_labels = labels[region]
        self.training_region = region
        self.pipeline.fit(self.training_features, self.training_labels)
        return self

    def predict_proba(self, features: NDArray) -> NDArray:
        """Neighbour vote shares of every tile.

        Parameters
        ----------
        features : ndarray, shape (n_samples, n_features)
            One row per tile (or region).

        Returns
        -------
        ndarray, shape (n_samples, n_classes)
            Share of the ``k`` neighbours' votes (weighted by inverse distance
            when ``weights == "distance"``) for each class of :attr:`classes`.
        """
        return self.pipeline.predict_proba(np.asarray(features, dtype=np.float64))

    def predict_with_confidence(
        self, features: NDArray, region: NDArray | None = None
    ) -> tuple[NDArray, NDArray]:
        """Label and confidence of each region.

        Parameters
        ----------
        features : ndarray, shape (n_tiles, n_features)
        region : array_like of int, shape (n_tiles,), optional
            Region of each row (:func:`check_regions`); default: each row is
            a region.

        Returns
        -------
        labels : ndarray of str, shape (n_regions,)
            Of a one-tile region: the KNN label (eq. 26). Of a region of
            several tiles: the label most of its tiles get; a tie goes to the
            class with the larger summed neighbour vote share.
        confidence : ndarray of float, shape (n_regions,)
            Of a one-tile region: the neighbour vote share of the label. Of a
            region of several tiles: the share of its tiles that voted for
            the label.
        """
        features, region, tile_counts = check_regions(features, region)
        proba = self.predict_proba(features)
        shape = (tile_counts.size, proba.shape[1])
        votes, shares = np.zeros(shape), np.zeros(shape)
        np.add.at(votes, (region, proba.argmax(axis=1)), 1.0)
        np.add.at(shares, region, proba)
        # The summed vote shares (< the region's tiles) only break ties between vote counts;
        # with one tile the label is the tile's.
        best = (votes + shares / (tile_counts[:, None] + 1)).argmax(axis=1)
        rows = np.arange(tile_counts.size)
        confidence = np.where(tile_counts == 1, shares[rows, best], votes[rows, best] / tile_counts)
        return np.asarray(self.pipeline.classes_)[best], confidence

    def predict(self, features: NDArray, region: NDArray | None = None) -> NDArray:
        """Label of each region (see :meth:`predict_with_confidence`)."""
        return self.predict_with_confidence(features, region)[0]

    def classify(
        self, image_rgb: NDArray[np.uint8], within: ArrayLike | None = None
    ) -> tuple[str, float]:
        """Classify one RGB image region of any size.

        Parameters
        ----------
        image_rgb : ndarray of uint8, shape (H, W, 3)
            Cut into the tiles of :func:`tile_grid`.
        within : array_like, shape (M, 2), optional
            Polygon in region pixels: only the tiles whose centre it contains
            vote (:func:`image_features`).

        Returns
        -------
        label : str
        confidence : float
            Vote share in [0, 1] (of the tiles with several, else of the neighbours).
        """
        return self.vote(image_features(image_rgb, self.cfg, within))

    def vote(self, features: NDArray) -> tuple[str, float]:
        """Label and confidence of one region from its tiles' features.

        Parameters
        ----------
        features : ndarray, shape (n_tiles, n_features)
            :func:`image_features` of the region.

        Returns
        -------
        label : str
        confidence : float
            As :meth:`classify` (the region is all the rows).
        """
        labels, confidence = self.predict_with_confidence(
            features, np.zeros(features.shape[0], dtype=np.intp)
        )
        return str(labels[0]), float(confidence[0])

    def metadata(self) -> dict[str, Any]:
        """Metadata stored in the model file."""
        return {
            "format_version": MODEL_FORMAT_VERSION,
            "feature_version": FEATURE_VERSION,
            "config": dataclasses.asdict(self.cfg),
            "classes": self.classes,
            "n_training_images": self.n_training_images,
            "n_training_samples": len(self.training_labels),
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "terrain_odom_version": __version__,
        }

    def save(self, path: str | Path) -> Path:
        """Write the model atomically to one ``.npz`` file (no pickle).

        Arrays: ``features`` (n_samples, n_features) raw training features
        (one row per tile), ``labels`` (n_samples,) str, ``region``
        (n_samples,) int64 the training image of each row (numbered from 0),
        ``scaler_mean`` and ``scaler_scale`` (n_features,) (empty without
        scaling), ``metadata`` a JSON string (:meth:`metadata`). The file is
        written as given, even without the ``.npz`` suffix.

        Returns
        -------
        Path
        """
        path = Path(path)
        if not self.n_training_images:
            raise ValueError("fit the classifier before saving it")
        if self.cfg.scale:
            scaler = self.pipeline["scaler"]
            mean, scale = scaler.mean_, scaler.scale_
        else:
            mean = scale = np.empty(0)
        arrays = {
            "features": self.training_features,
            "labels": self.training_labels,
            "region": self.training_region.astype(np.int64),
            "scaler_mean": mean,
            "scaler_scale": scale,
            "metadata": np.array(json.dumps(self.metadata())),
        }
        write_atomic(path, lambda handle: np.savez(handle, **arrays))
        return path

    @classmethod
    def load(cls, path: str | Path, expected: ClassifierConfig | None = None) -> TerrainClassifier:
        """Read a model written by :meth:`save`.

        Parameters
        ----------
        path : str or Path
        expected : ClassifierConfig, optional
            If given, the model's feature settings (:data:`FEATURE_FIELDS`)
            must equal these.

        Raises
        ------
        InputFileError
            The file is missing, not a model or inconsistent, or its format
            version, feature version or feature settings differ from this
            code's or ``expected``'s (the message names the file and both
            values).
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
        except FileNotFoundError:
            raise InputFileError(f"{path}: model file not found") from None
        except (OSError, ValueError) as exc:
            raise InputFileError(f"{path}: not a terrain-odom model file ({exc})") from None
        try:
            meta = json.loads(str(arrays["metadata"]))
        except KeyError:
            raise InputFileError(f"{path}: not a terrain-odom model file (no metadata)") from None
        except json.JSONDecodeError:
            meta = None
        if not isinstance(meta, dict):
            raise InputFileError(f"{path}: not a terrain-odom model file (bad metadata)")
        cfg = _check_model_metadata(path, meta, expected)  # versions before the arrays
        missing = {"features", "labels", "region", "scaler_mean", "scaler_scale"} - set(arrays)
        if missing:
            raise InputFileError(f"{path}: not a terrain-odom model file (no {sorted(missing)})")
        labels = arrays["labels"]
        try:
            features, region, _ = check_regions(arrays["features"], arrays["region"])
            if labels.shape != region.shape:
                raise ValueError(f"{labels.size} labels for {region.size} feature rows")
        except ValueError as exc:
            raise InputFileError(f"{path}: inconsistent model file ({exc})") from None
        model = cls(cfg)
        model.training_features = samples = features
        model.training_labels = labels
        model.training_region = region
        if cfg.scale:  # the stored scaler, not one refitted
            scaler = model.pipeline["scaler"]
            scaler.mean_, scaler.scale_ = arrays["scaler_mean"], arrays["scaler_scale"]
            scaler.var_ = scaler.scale_**2
            scaler.n_features_in_ = samples.shape[1]
            scaler.n_samples_seen_ = samples.shape[0]
            samples = scaler.transform(samples)
        model.pipeline["knn"].fit(samples, model.training_labels)
        return model


def _check_model_metadata(
    path: Path, meta: dict[str, Any], expected: ClassifierConfig | None
) -> ClassifierConfig:
    """Return the model's configuration, or raise if it does not match this code."""
    for key, ours in (
        ("format_version", MODEL_FORMAT_VERSION),
        ("feature_version", FEATURE_VERSION),
    ):
        if meta.get(key) != ours:
            raise InputFileError(
                f"{path}: model {key} is {meta.get(key)!r} but this terrain-odom uses {ours}; "
                "retrain the model with 'terrain-odom train'"
            )
    try:
        cfg = build_section(ClassifierConfig(), meta["config"], "config")
    except (ConfigError, KeyError) as exc:
        raise InputFileError(f"{path}: invalid model metadata ({exc})") from None
    if expected is not None:
        for name in FEATURE_FIELDS:
            theirs, ours = getattr(cfg, name), getattr(expected, name)
            if theirs != ours:
                raise InputFileError(
                    f"{path}: model was trained with {name}={theirs!r} but the configuration "
                    f"asks for {name}={ours!r}; retrain the model or change the configuration"
                )
    return cfg
