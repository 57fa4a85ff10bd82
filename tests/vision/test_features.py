"""Tests of region and tile features (:mod:`terrain_odom.vision.features`)."""

from __future__ import annotations

import numpy as np
import pytest
import skimage.data

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.vision.features import (
    colour_statistics,
    image_features,
    region_features,
    split_tiles,
    tile_grid,
    tiles_per_side,
    tiles_within,
)

TILE = 64


def test_tile_grid_adapts_to_the_region_size():
    cfg = ClassifierConfig(features="sfta+lab", min_tile_size=32)
    assert (cfg.tiles, cfg.min_tile_size) == (4, 32)
    # Below 2 * min_tile_size on the short side: one tile, whatever the long side.
    assert tiles_per_side(63, 500, cfg) == tiles_per_side(1, 1, cfg) == 1
    assert tiles_per_side(64, 64, cfg) == 2
    assert tiles_per_side(120, 160, cfg) == 3
    assert tiles_per_side(427, 320, cfg) == tiles_per_side(320, 427, cfg) == 4
    assert tiles_per_side(427, 320, ClassifierConfig(tiles=6)) == 6
    assert tiles_per_side(427, 320, ClassifierConfig(min_tile_size=200)) == 1
    rng = np.random.default_rng(2)
    for shape, rows in (((63, 90), 1), ((64, 64), 4), ((120, 160), 9), ((427, 320), 16)):
        image = rng.integers(0, 256, size=(*shape, 3), dtype=np.uint8)
        assert image_features(image, cfg).shape == (rows, 30)
    tiny = image_features(rng.integers(0, 256, size=(2, 3, 3), dtype=np.uint8), cfg)
    assert tiny.shape == (1, 30) and np.all(np.isfinite(tiny))


def test_region_features_length_and_finite():
    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, size=(48, 40, 3), dtype=np.uint8)
    cases = {
        ClassifierConfig(features="sfta"): 24,
        ClassifierConfig(features="sfta+lab"): 30,
        ClassifierConfig(features="sfta+hsv", pyramid_levels=2): 54,
        ClassifierConfig(features="sfta", n_t=2, pyramid_levels=3): 36,
    }
    for cfg, length in cases.items():
        features = region_features(image, cfg)
        assert features.shape == (length,)
        assert np.all(np.isfinite(features))
    assert image_features(
        image, ClassifierConfig(features="sfta+lab", tiles=3, min_tile_size=8)
    ).shape == (9, 30)


def test_relative_counts_are_fractions_of_the_area():
    image = np.repeat(skimage.data.gravel()[:TILE, :TILE, None], 3, axis=2)
    raw = region_features(image, ClassifierConfig(features="sfta", relative_counts=False))
    rel = region_features(image, ClassifierConfig(features="sfta"))
    np.testing.assert_allclose(rel[1::3], raw[1::3] / TILE**2)
    np.testing.assert_array_equal(rel[0::3], raw[0::3])


def test_colour_statistics_lab_of_a_grey_patch_and_circular_hue():
    grey = np.full((8, 8, 3), 100, dtype=np.uint8)
    lab = colour_statistics(grey, "lab")
    np.testing.assert_allclose(lab[[2, 4]], [128.0, 128.0])  # a*, b* of grey
    np.testing.assert_allclose(lab[1::2], 0.0, atol=1e-12)
    # Two reds on either side of hue 0 (OpenCV 178 and 2, i.e. -4 and +4 degrees).
    red = np.zeros((2, 1, 3), dtype=np.uint8)
    red[0, 0] = (255, 0, 17)  # hue ~ 176-178
    red[1, 0] = (255, 17, 0)  # hue ~ 2
    hsv = colour_statistics(red, "hsv")
    assert min(hsv[0], 180.0 - hsv[0]) < 0.5  # the mean is red, not cyan (90)
    assert hsv[1] < 3.0  # the spread is small, not ~88


def test_fixed_size_tiles_scale_with_the_area():
    cfg = ClassifierConfig(features="sfta+lab", tile_size=64)
    # Tiles of about 64 px whatever the region: a region 4x the area has 4x the tiles.
    assert tile_grid(120, 160, cfg) == (2, 3)
    assert tile_grid(240, 320, cfg) == (4, 5)
    assert tile_grid(480, 640, cfg) == (8, 10)
    assert tile_grid(95, 96, cfg) == (1, 2)  # 95 / 64 = 1.48: one row; 96 / 64 = 1.5: two
    assert tile_grid(10, 700, cfg) == (1, 11)  # a sliver: one row, never zero
    rng = np.random.default_rng(3)
    for shape in ((120, 160), (240, 320), (40, 50)):
        image = rng.integers(0, 256, size=(*shape, 3), dtype=np.uint8)
        features = image_features(image, cfg)
        assert features.shape == (np.prod(tile_grid(*shape, cfg)), 30)
        # Each row is the features of its tile, cut at rounded edges.
        tiles = split_tiles(image, *tile_grid(*shape, cfg))
        np.testing.assert_array_equal(features[-1], region_features(tiles[-1], cfg))


def test_tiles_within_a_polygon_are_those_whose_centre_it_contains():
    cfg = ClassifierConfig(tile_size=10)  # a 40x60 region: 4 x 6 tiles, centres at 4.5, 14.5, ...
    triangle = [(0, 0), (59, 0), (0, 39)]  # the upper-left half, u / 59 + v / 39 <= 1
    kept = tiles_within(40, 60, cfg, triangle)
    v, u = np.divmod(kept, 6) * np.array([[10], [10]]) + 4.5
    assert np.all(u / 59 + v / 39 <= 1) and kept.size == 12
    outside = np.setdiff1d(np.arange(24), kept)
    v, u = np.divmod(outside, 6) * np.array([[10], [10]]) + 4.5
    assert np.all(u / 59 + v / 39 > 1)
    # A polygon between tile centres keeps the tile nearest its vertex mean.
    sliver = [(20, 20), (23, 20), (23, 23)]
    assert tiles_within(40, 60, cfg, sliver).tolist() == [2 * 6 + 2]
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, size=(40, 60, 3), dtype=np.uint8)
    np.testing.assert_array_equal(
        image_features(image, cfg, within=triangle), image_features(image, cfg)[kept]
    )


def test_split_tiles_covers_every_pixel_once():
    image = np.arange(7 * 9).reshape(7, 9)
    tiles = split_tiles(image, 3)
    assert len(tiles) == 9
    assert sorted(np.concatenate([t.ravel() for t in tiles]).tolist()) == list(range(63))
    with pytest.raises(ValueError, match="cannot cut"):
        split_tiles(image, 8)
    columns = split_tiles(image, 2, 4)
    assert [t.shape for t in columns[:4]] == [(4, 2), (4, 2), (4, 3), (4, 2)]
    assert sorted(np.concatenate([t.ravel() for t in columns]).tolist()) == list(range(63))
    with pytest.raises(ValueError, match="cannot cut"):
        split_tiles(image, 2, 10)


def test_image_features_rejects_non_rgb_input():
    with pytest.raises(ValueError, match="RGB uint8"):
        image_features(np.zeros((8, 8)), ClassifierConfig())
