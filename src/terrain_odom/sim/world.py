"""Ground map of the simulator: a top-down texture image of terrain regions.

The map is an RGB image covering a rectangle of the world plane (metres) at a
fixed resolution (metres per pixel), plus a label image giving the terrain of
every map pixel. Map pixel ``(u, v)`` (column, row) has its centre at
integer coordinates (OpenCV's convention) and lies at world point

    x = x_min + (u + 0.5) * resolution,   y = y_max - (v + 0.5) * resolution

so the image is the usual top-down view (x to the right, y up the image).

Textures
--------
Every terrain is textured with a **real photo shipped by scikit-image**
(``skimage.data.grass()``, ``gravel()``, ``brick()``; 512 x 512 grey photos),
mirror-tiled to cover the map (so there are no seams) and multiplied by a
per-terrain RGB tint so that the terrains also differ in colour. Any other
texture added here must likewise be a real photo shipped by a dependency, or
be generated procedurally and named as such (e.g. ``"procedural-noise"``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "TEXTURES",
    "TINTS",
    "Region",
    "MapSpec",
    "GroundMap",
    "load_texture",
    "build_map",
]

TEXTURES: Mapping[str, str] = {"grass": "grass", "gravel": "gravel", "brick": "brick"}
"""Terrain name -> name of the ``skimage.data`` photo that textures it."""

TINTS: Mapping[str, tuple[float, float, float]] = {
    "grass": (0.80, 1.00, 0.65),
    "gravel": (1.00, 0.97, 0.92),
    "brick": (1.05, 0.75, 0.62),
}
"""Terrain name -> RGB gain applied to its grey photo."""


@dataclass(frozen=True)
class Region:
    """A terrain painted over a polygon of the world plane.

    Attributes
    ----------
    terrain : str
        Terrain name (a key of :data:`TEXTURES`).
    polygon : tuple of (x, y)
        Vertices in world metres, in order (convex or not).
    """

    terrain: str
    polygon: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class MapSpec:
    """What a ground map is made of.

    Attributes
    ----------
    extent : tuple of 4 float
        ``(x_min, x_max, y_min, y_max)`` covered by the map, m.
    resolution : float
        Size of a map pixel, m.
    base : str
        Terrain everywhere no region covers.
    regions : tuple of Region
        Painted in order over the base (later ones on top).
    """

    extent: tuple[float, float, float, float]
    resolution: float
    base: str
    regions: tuple[Region, ...] = ()

    @property
    def terrains(self) -> tuple[str, ...]:
        """Terrain names in first-use order: the base, then the regions."""
        names = [self.base] + [r.terrain for r in self.regions]
        return tuple(dict.fromkeys(names))


def load_texture(terrain: str) -> np.ndarray:
    """Return the tinted RGB photo of a terrain, uint8, shape (512, 512, 3).

    Raises
    ------
    KeyError
        If the terrain has no texture in :data:`TEXTURES`.
    """
    import skimage.data

    grey = getattr(skimage.data, TEXTURES[terrain])().astype(np.float32)
    if grey.ndim == 3:  # a colour photo: keep its luminance
        grey = grey[..., :3].mean(axis=-1)
    rgb = grey[..., None] * np.asarray(TINTS[terrain], dtype=np.float32)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def _mirror_tile(
    texture: np.ndarray, shape: tuple[int, int], offset: tuple[int, int]
) -> np.ndarray:
    """Cover ``shape`` (rows, cols) with mirror copies of ``texture``, shifted by ``offset``."""
    cell = np.concatenate([texture, texture[:, ::-1]], axis=1)
    cell = np.concatenate([cell, cell[::-1]], axis=0)
    reps = (
        -(-(shape[0] + offset[0]) // cell.shape[0]),
        -(-(shape[1] + offset[1]) // cell.shape[1]),
    )
    tiled = np.tile(cell, (reps[0], reps[1], 1))
    return tiled[offset[0] : offset[0] + shape[0], offset[1] : offset[1] + shape[1]]


class GroundMap:
    """A top-down RGB texture of the world with a terrain label per pixel.

    Parameters
    ----------
    image : ndarray, shape (H, W, 3), uint8
        RGB map.
    labels : ndarray, shape (H, W), uint8
        Index into ``terrains`` of every pixel.
    terrains : sequence of str
        Terrain names.
    extent : tuple of 4 float
        ``(x_min, x_max, y_min, y_max)``, m; ``W * resolution`` wide.
    resolution : float
        m per pixel.
    """

    def __init__(
        self,
        image: np.ndarray,
        labels: np.ndarray,
        terrains: Sequence[str],
        extent: tuple[float, float, float, float],
        resolution: float,
    ) -> None:
        if image.shape[:2] != labels.shape or image.ndim != 3:
            raise ValueError(f"image {image.shape} and labels {labels.shape} do not match")
        self.image = image
        self.labels = labels
        self.terrains = tuple(terrains)
        self.extent = tuple(float(e) for e in extent)
        self.resolution = float(resolution)

    @property
    def pixel_to_world(self) -> np.ndarray:
        """Affine 3 x 3 map of map pixels ``(u, v, 1)`` to world ``(x, y, 1)``, m."""
        r = self.resolution
        x_min, _, _, y_max = self.extent
        return np.array([[r, 0.0, x_min + 0.5 * r], [0.0, -r, y_max - 0.5 * r], [0.0, 0.0, 1.0]])

    def world_to_pixel(self, points_xy: ArrayLike) -> np.ndarray:
        """Map pixel coordinates ``(u, v)`` of world points ``(..., 2)`` (m), px."""
        p = np.asarray(points_xy, dtype=float)
        x_min, _, _, y_max = self.extent
        u = (p[..., 0] - x_min) / self.resolution - 0.5
        v = (y_max - p[..., 1]) / self.resolution - 0.5
        return np.stack([u, v], axis=-1)

    def contains(self, points_xy: ArrayLike) -> np.ndarray:
        """Whether world points ``(..., 2)`` lie on the map."""
        p = np.asarray(points_xy, dtype=float)
        x_min, x_max, y_min, y_max = self.extent
        return (
            (p[..., 0] >= x_min) & (p[..., 0] < x_max) & (p[..., 1] > y_min) & (p[..., 1] <= y_max)
        )

    def label_index(self, points_xy: ArrayLike) -> np.ndarray:
        """Index of the terrain at world points ``(..., 2)``; -1 off the map."""
        uv = np.rint(self.world_to_pixel(points_xy)).astype(int)
        h, w = self.labels.shape
        inside = self.contains(points_xy)
        u = np.clip(uv[..., 0], 0, w - 1)
        v = np.clip(uv[..., 1], 0, h - 1)
        return np.where(inside, self.labels[v, u].astype(int), -1)

    def terrain_at(self, points_xy: ArrayLike) -> np.ndarray:
        """Terrain names at world points ``(..., 2)``; ``""`` off the map.

        Examples
        --------
        >>> spec = MapSpec((0.0, 4.0, 0.0, 2.0), 0.1, "grass",
        ...                (Region("gravel", ((2.0, 0.0), (4.0, 0.0), (4.0, 2.0), (2.0, 2.0))),))
        >>> build_map(spec, np.random.default_rng(0)).terrain_at([[1.0, 1.0], [3.0, 1.0], [9.0, 0.0]]).tolist()
        ['grass', 'gravel', '']
        """
        names = np.array(self.terrains + ("",))
        return names[self.label_index(points_xy)]


def _region_mask(region: Region, ground: GroundMap) -> np.ndarray:
    mask = np.zeros(ground.labels.shape, dtype=np.uint8)
    uv = ground.world_to_pixel(np.asarray(region.polygon, dtype=float))
    pts = np.rint(uv * 16).astype(np.int32)  # 4 fractional bits
    cv2.fillPoly(mask, [pts], 1, lineType=cv2.LINE_8, shift=4)
    return mask.astype(bool)


def build_map(spec: MapSpec, rng: np.random.Generator) -> GroundMap:
    """Paint the regions of ``spec`` and texture them.

    Parameters
    ----------
    spec : MapSpec
        Extent, resolution, base terrain and regions.
    rng : numpy.random.Generator
        Draws the offset of each terrain's tiling (so maps differ by seed).

    Returns
    -------
    GroundMap
    """
    x_min, x_max, y_min, y_max = spec.extent
    w = int(round((x_max - x_min) / spec.resolution))
    h = int(round((y_max - y_min) / spec.resolution))
    terrains = spec.terrains
    labels = np.zeros((h, w), dtype=np.uint8)
    extent = (x_min, x_min + w * spec.resolution, y_max - h * spec.resolution, y_max)
    ground = GroundMap(np.zeros((h, w, 3), np.uint8), labels, terrains, extent, spec.resolution)
    for region in spec.regions:
        labels[_region_mask(region, ground)] = terrains.index(region.terrain)
    for index, name in enumerate(terrains):
        offset = (int(rng.integers(0, 1024)), int(rng.integers(0, 1024)))
        texture = _mirror_tile(load_texture(name), (h, w), offset)
        where = labels == index
        ground.image[where] = texture[where]
    return ground
