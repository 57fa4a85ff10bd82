"""Feature vectors of image regions: SFTA, colour statistics, tiles (Chen et al. 2023, §3.2.3).

Chen et al. describe each image region by the 24 SFTA values of its grey image
(eq. 18-21). :class:`~terrain_odom.config.classifier.ClassifierConfig` selects
that recipe or adds to it:

- **relative counts** (``relative_counts``): SFTA's pixel counts ``C_i`` as
  fractions of the region's area (as :func:`~terrain_odom.vision.sfta.sfta_features`
  returns them), so that regions of any size (tiles, regions of interest)
  compare with the training images; the paper's raw counts scale with the
  region's size;
- **other texture families** (``features`` with ``lbp`` or ``glcm``):
  scikit-image's uniform local binary patterns (:func:`lbp_histograms`) and
  grey-level co-occurrence statistics (:func:`glcm_statistics`), alone or
  beside SFTA;
- **colour statistics** (``features="sfta+lab"`` or ``"sfta+hsv"``): grey
  texture throws away colour, which is what separates e.g. wood from carpet;
- **image pyramid** (``pyramid_levels``): SFTA also of the region halved
  ``1, 2, ...`` times, describing the texture at coarser scales;
- **tiles** (``tiles``, ``min_tile_size``, or ``tile_size``): a region is cut
  into up to ``tiles x tiles`` tiles of at least ``min_tile_size`` pixels a
  side (:func:`tiles_per_side`; ``auto``: the training images' size over
  ``tiles``, :func:`resolve_scale`), or, with ``tile_size``, into tiles of about
  ``tile_size`` pixels a side whatever the region's size (:func:`tile_grid`),
  and each tile gets its own feature vector (:func:`image_features`), for
  the classifier's tile vote.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Literal

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray
from skimage.feature import graycomatrix, graycoprops
from skimage.measure import points_in_poly

from terrain_odom.config.classifier import AUTO, MIN_TILE_SIZE, ClassifierConfig, feature_parts
from terrain_odom.vision.sfta import sfta_features, to_grey

__all__ = [
    "FEATURE_VERSION",
    "LBP_POINTS",
    "GLCM_LEVELS",
    "GLCM_DISTANCES",
    "GLCM_PROPERTIES",
    "colour_statistics",
    "lbp_histograms",
    "glcm_statistics",
    "region_features",
    "auto_min_tile_size",
    "resolve_scale",
    "tiles_per_side",
    "tile_grid",
    "tile_boxes",
    "split_tiles",
    "tiles_within",
    "image_features",
]

FEATURE_VERSION = 2
"""Version of the feature vector; bump it whenever :func:`image_features` changes."""

LBP_POINTS = ((8, 1.0), (8, 2.0))
"""``(P, R)`` of the LBP rings: 8 neighbours at 1 px and at 2 px (10 + 10 histogram bins)."""

GLCM_LEVELS = 32
"""Grey levels the co-occurrence matrix counts (the 256 quantised by 8)."""

GLCM_DISTANCES = (1, 2)
"""Pixel offsets of the co-occurrence matrices, px."""

GLCM_PROPERTIES = ("contrast", "dissimilarity", "homogeneity", "energy", "correlation")
"""``graycoprops`` statistics of each matrix."""

_GLCM_ANGLES = (0.0, np.pi / 4, np.pi / 2, 3 * np.pi / 4)

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
    return np.asarray(cv2.cvtColor(np.ascontiguousarray(image_rgb), code), dtype=np.uint8)


def _channel_statistics(converted: NDArray[np.uint8], space: Literal["lab", "hsv"]) -> NDArray:
    """:func:`colour_statistics` of an image already converted to ``space``."""
    mean, std = _mean_std(converted)
    out = np.column_stack((mean, std)).ravel()
    if space == "hsv":
        hue = converted[..., 0].ravel()
        hist = np.bincount(hue, minlength=_HUE_LEVELS) / hue.size
        c, s = hist @ _HUE_COS, hist @ _HUE_SIN
        length = min(np.hypot(c, s), 1.0)
        out[0] = (np.arctan2(s, c) % (2.0 * np.pi)) * (90.0 / np.pi)
        out[1] = np.sqrt(-2.0 * np.log(max(length, 1e-12))) * (90.0 / np.pi)
    return out


def _mean_std(converted: NDArray[np.uint8]) -> tuple[NDArray, NDArray]:
    """Mean and standard deviation of each channel, bit for bit ``cv2.meanStdDev``'s for 8 bits.

    Its arithmetic: exact integer sums ``S`` and sums of squares ``Q``
    (:func:`~terrain_odom.vision._kernels.channel_sums`, ~10x faster than the
    call), then ``mean = S * (1 / n)``, ``std = sqrt(max(Q * (1 / n) - mean**2, 0))``.
    """
    from terrain_odom.vision._kernels import channel_sums

    sums = channel_sums(np.ascontiguousarray(converted).ravel())
    moments = np.array(sums, dtype=np.float64).reshape(2, 3)
    scale = 1.0 / (converted.shape[0] * converted.shape[1])
    mean = moments[0] * scale
    return mean, np.sqrt(np.maximum(moments[1] * scale - mean * mean, 0.0))


def lbp_histograms(grey: NDArray[np.uint8], boxes: ArrayLike | None = None) -> NDArray:
    """Uniform local binary pattern histograms of tiles of a grey image.

    For each :data:`LBP_POINTS` ring, the codes of
    ``skimage.feature.local_binary_pattern(grey, P, R, method="uniform")``
    (rotation-invariant uniform codes ``0 .. P + 1``; ``P + 1``: not
    uniform) of the *whole* image, so that a tile's edge pixels see their
    true neighbours in the next tile, counted in each tile and divided by its
    area. Only the tiles' pixels are coded, by a compiled loop
    (:func:`~terrain_odom.vision._kernels.lbp_tile_counts`; the tests hold
    its codes equal to skimage's, pixel for pixel).

    Parameters
    ----------
    grey : ndarray of uint8, shape (H, W)
    boxes : array_like of int, shape (n_tiles, 4), optional
        ``(x0, y0, x1, y1)`` of each tile, half-open (:func:`tile_boxes`);
        default: the whole image.

    Returns
    -------
    ndarray of float64, shape (n_tiles, sum(P + 2))
        Ring by ring, the share of the tile's pixels with each code.
    """
    from terrain_odom.vision._kernels import lbp_pad, lbp_tile_counts

    grey = np.ascontiguousarray(grey, dtype=np.uint8)
    height, width = grey.shape
    boxes = np.asarray([(0, 0, width, height)] if boxes is None else boxes, dtype=np.int64)
    area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    pad = max(lbp_pad(radius) for _, radius in LBP_POINTS)
    padded = cv2.copyMakeBorder(grey, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    return np.hstack(
        [
            lbp_tile_counts(padded, pad, points, radius, boxes) / area[:, None]
            for points, radius in LBP_POINTS
        ]
    )


def glcm_statistics(grey: NDArray[np.uint8]) -> NDArray:
    """Grey-level co-occurrence statistics of a grey image (tile).

    ``skimage.feature.graycomatrix`` of the grey levels quantised to
    :data:`GLCM_LEVELS` (``grey * GLCM_LEVELS // 256``), symmetric and
    normalised, at each distance of :data:`GLCM_DISTANCES` px and the four
    directions 0, 45, 90, 135 degrees; ``graycoprops`` of each
    :data:`GLCM_PROPERTIES`, averaged over the directions (rotation
    invariant). Correlation, undefined on a uniform image, is 1 there (as
    skimage returns it).

    Returns
    -------
    ndarray of float64, shape (len(GLCM_PROPERTIES) * len(GLCM_DISTANCES),)
        Property by property, each at every distance.
    """
    quantised = (grey.astype(np.uint16) * GLCM_LEVELS >> 8).astype(np.uint8)
    matrix = graycomatrix(
        quantised, GLCM_DISTANCES, _GLCM_ANGLES, levels=GLCM_LEVELS, symmetric=True, normed=True
    )
    values = np.stack([graycoprops(matrix, name).mean(axis=1) for name in GLCM_PROPERTIES])
    return np.nan_to_num(values, nan=1.0).ravel()


def _sfta(image: NDArray[np.uint8], grey: NDArray[np.uint8], config: ClassifierConfig) -> NDArray:
    """SFTA of a tile at each pyramid level (full size from its grey image, then halved RGB)."""
    parts = []
    level = image
    for depth in range(config.pyramid_levels):
        if depth:
            height, width = level.shape[:2]
            size = (max(width // 2, 1), max(height // 2, 1))
            level = np.asarray(
                cv2.resize(level, size, interpolation=cv2.INTER_AREA), dtype=np.uint8
            )
        sfta = np.array(sfta_features(level if depth else grey, config.n_t), dtype=np.float64)
        if not config.relative_counts:  # sfta_features gives fractions of the area
            sfta[1::3] *= level.shape[0] * level.shape[1]
        parts.append(sfta)
    return np.concatenate(parts)


def _tile_features(
    image_rgb: NDArray[np.uint8], config: ClassifierConfig, boxes: NDArray
) -> NDArray:
    """Feature vectors of the tiles ``boxes`` (``(x0, y0, x1, y1)``, half-open) of a region.

    Only the tiles' pixels are described (a region of interest's tiles
    outside its footprint are not); the grey image is the region's, so that
    the LBP codes at a tile's edge see the next tile.
    """
    families, colour = feature_parts(config.features)
    grey = to_grey(image_rgb)
    tiles = [(slice(y0, y1), slice(x0, x1)) for x0, y0, x1, y1 in boxes.tolist()]
    parts = []
    if "sfta" in families:
        coloured = config.pyramid_levels > 1  # halved levels are cut from the RGB tile
        parts.append(
            np.stack(
                [
                    _sfta(image_rgb[tile] if coloured else grey[tile], grey[tile], config)
                    for tile in tiles
                ]
            )
        )
    if "lbp" in families:
        parts.append(lbp_histograms(grey, boxes))
    if "glcm" in families:
        parts.append(np.stack([glcm_statistics(grey[tile]) for tile in tiles]))
    if colour is not None:
        parts.append(np.stack([colour_statistics(image_rgb[tile], colour) for tile in tiles]))  # type: ignore[arg-type]
    return np.hstack(parts)


def region_features(image_rgb: NDArray[np.uint8], config: ClassifierConfig) -> NDArray:
    """Feature vector of one image region (a whole region or one tile).

    Parameters
    ----------
    image_rgb : ndarray of uint8, shape (H, W, 3)
        RGB region.
    config : ClassifierConfig

    Returns
    -------
    ndarray of float64, shape (n_features,)
        In the order of ``config.features``' families (:data:`~terrain_odom.config.classifier.TEXTURE_FAMILIES`):
        the ``6 * n_t`` SFTA values of each pyramid level (full size first,
        then halved; counts ``C_i`` times the level's pixel count unless
        ``config.relative_counts``), the LBP histograms (:func:`lbp_histograms`),
        the GLCM statistics (:func:`glcm_statistics`), then the 6 colour
        statistics if any.
    """
    image_rgb = np.asarray(image_rgb)
    height, width = image_rgb.shape[:2]
    return _tile_features(image_rgb, config, np.array([(0, 0, width, height)]))[0]


def auto_min_tile_size(short_side: float, tiles: int) -> int:
    """``min_tile_size`` of ``auto`` for images of this shorter side, px.

    ``max(MIN_TILE_SIZE, floor(short_side / tiles))``: an image of that
    shorter side is then cut into ``tiles x tiles`` tiles.

    >>> auto_min_tile_size(64, 4), auto_min_tile_size(320, 4), auto_min_tile_size(20, 4)
    (16, 80, 8)
    """
    return max(MIN_TILE_SIZE, int(short_side // tiles))


def resolve_scale(config: ClassifierConfig, short_side: float) -> ClassifierConfig:
    """Return ``config`` with an ``auto`` ``min_tile_size`` chosen for images of this shorter side.

    Parameters
    ----------
    config : ClassifierConfig
    short_side : float
        The training images' (median) shorter side, px.
    """
    if config.min_tile_size != AUTO:
        return config
    return dataclasses.replace(config, min_tile_size=auto_min_tile_size(short_side, config.tiles))


def tiles_per_side(height: int, width: int, config: ClassifierConfig) -> int:
    """Return the number of tiles per side of a ``height x width`` region.

    ``min(config.tiles, max(1, min(height, width) // config.min_tile_size))``: as
    many as ``config.tiles`` allows with tiles of at least ``config.min_tile_size``
    pixels a side, and at least one. With ``min_tile_size: auto`` not
    resolved by :func:`resolve_scale`, the region's own shorter side sets it
    (:func:`auto_min_tile_size`): ``config.tiles`` per side.

    >>> config = ClassifierConfig(tiles=4, min_tile_size=32)
    >>> tiles_per_side(427, 320, config), tiles_per_side(120, 160, config), tiles_per_side(64, 64, config)
    (4, 3, 2)
    >>> tiles_per_side(63, 200, config)
    1
    """
    short = min(height, width)
    size = config.min_tile_size
    smallest = auto_min_tile_size(short, config.tiles) if size == AUTO else int(size)
    return min(config.tiles, max(1, short // smallest))


def tile_grid(height: int, width: int, config: ClassifierConfig) -> tuple[int, int]:
    """Return the tile rows and columns of a ``height x width`` region.

    With ``config.tile_size`` set: ``round(height / tile_size)`` rows and
    ``round(width / tile_size)`` columns (halves up, at least one each), so
    tile sides are within ``[2/3, 3/2] * tile_size`` once the region is at
    least ``tile_size`` a side; otherwise ``n x n`` with
    ``n = tiles_per_side(height, width, config)``.

    >>> config = ClassifierConfig(tile_size=64)
    >>> tile_grid(240, 320, config), tile_grid(96, 100, config), tile_grid(20, 500, config)
    ((4, 5), (2, 2), (1, 8))
    >>> tile_grid(240, 320, ClassifierConfig())
    (4, 4)
    """
    if config.tile_size is None:
        n = tiles_per_side(height, width, config)
        return n, n
    return (
        max(1, int(height / config.tile_size + 0.5)),
        max(1, int(width / config.tile_size + 0.5)),
    )


def _tile_edges(height: int, width: int, tiles: int, columns: int) -> tuple[NDArray, NDArray]:
    """Row and column edges of a ``tiles x columns`` grid: ``round(i * H / tiles)``, ..."""
    if tiles > height or columns > width:
        raise ValueError(f"cannot cut a {height}x{width} image into {tiles}x{columns} tiles")
    return _edges(height, tiles), _edges(width, columns)


def _edges(size: int, parts: int) -> NDArray:
    """``rint(linspace(0, size, parts + 1))`` as integers: ``round(i * (size / parts))``, halves to even."""
    step = size / parts
    return np.array([round(i * step) for i in range(parts)] + [size])


def tile_boxes(height: int, width: int, config: ClassifierConfig) -> NDArray:
    """Return the :func:`tile_grid` tiles of a region as boxes, row by row.

    Returns
    -------
    ndarray of int, shape (n_tiles, 4)
        ``(x0, y0, x1, y1)`` of each tile, px, half-open (as :func:`split_tiles` cuts them).

    >>> tile_boxes(40, 90, ClassifierConfig(tile_size=30)).tolist()
    [[0, 0, 30, 40], [30, 0, 60, 40], [60, 0, 90, 40]]
    """
    rows, cols = _tile_edges(height, width, *tile_grid(height, width, config))
    return np.array(
        [
            (x0, y0, x1, y1)
            for y0, y1 in itertools.pairwise(rows.tolist())
            for x0, x1 in itertools.pairwise(cols.tolist())
        ]
    )


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


def tiles_within(height: int, width: int, config: ClassifierConfig, polygon: ArrayLike) -> NDArray:
    """Return the :func:`tile_grid` tiles whose centre is inside a polygon.

    Parameters
    ----------
    height, width : int
        Region size, px.
    config : ClassifierConfig
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
    grid = tile_grid(height, width, config)
    rows, cols = _tile_edges(height, width, *grid)
    v, u = (rows[:-1] + rows[1:] - 1) / 2.0, (cols[:-1] + cols[1:] - 1) / 2.0
    centres = np.column_stack((np.tile(u, v.size), np.repeat(v, u.size)))  # row by row
    vertices = np.asarray(polygon, dtype=float).reshape(-1, 2)
    inside = points_in_poly(centres, vertices)
    if inside.any():
        return np.flatnonzero(inside)
    nearest = np.argmin(np.sum((centres - vertices.mean(axis=0)) ** 2, axis=1))
    return np.array([nearest], dtype=np.intp)


def image_features(
    image_rgb: NDArray[np.uint8], config: ClassifierConfig, within: ArrayLike | None = None
) -> NDArray:
    """Feature vectors of the tiles of a region.

    Parameters
    ----------
    image_rgb : ndarray of uint8, shape (H, W, 3)
        RGB region of any size.
    config : ClassifierConfig
    within : array_like, shape (M, 2), optional
        A polygon in region pixels: only the tiles whose centre it contains
        are described (:func:`tiles_within`), e.g. the footprint of a region
        of interest inside its bounding box.

    Returns
    -------
    ndarray of float64, shape (n_tiles, n_features)
        :func:`region_features` of each tile (of those within the polygon),
        row by row, of the :func:`tile_grid` of the region (one row for a
        single tile); but the LBP codes are those of the whole region, so
        that a tile's edge pixels compare with their true neighbours.
    """
    image_rgb = np.asarray(image_rgb)
    if image_rgb.ndim != 3 or image_rgb.shape[2] != 3 or image_rgb.dtype != np.uint8:
        raise ValueError(
            f"expected an RGB uint8 image (H, W, 3), got {image_rgb.dtype} {image_rgb.shape}"
        )
    height, width = image_rgb.shape[:2]
    boxes = tile_boxes(height, width, config)
    if within is not None:
        boxes = boxes[tiles_within(height, width, config, within)]
    return _tile_features(image_rgb, config, boxes)
