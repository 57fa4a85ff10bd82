"""LBP and GLCM families, min_tile_size auto, and the compiled pixel loops against their references."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage import data
from skimage.feature import graycomatrix, graycoprops, local_binary_pattern

from terrain_odom.config.classifier import ClassifierConfig, feature_parts
from terrain_odom.errors import ConfigError
from terrain_odom.vision import _kernels
from terrain_odom.vision.features import (
    GLCM_DISTANCES,
    GLCM_PROPERTIES,
    LBP_POINTS,
    glcm_statistics,
    image_features,
    lbp_histograms,
    region_features,
    resolve_scale,
    tile_grid,
)
from terrain_odom.vision.sfta import to_grey

RNG = np.random.default_rng(0)
IMAGES = {
    "grass": cv2.resize(data.grass(), (96, 72)),
    "noise": RNG.integers(0, 256, (37, 53), dtype=np.uint8),
    "flat": np.full((20, 30), 100, dtype=np.uint8),  # every interpolation ties with its centre
    "binary": (RNG.integers(0, 2, (40, 40)) * 255).astype(np.uint8),
    "pixel": np.full((1, 1), 5, dtype=np.uint8),
    "thin": RNG.integers(0, 3, (2, 7), dtype=np.uint8),
}


@pytest.mark.parametrize("name", IMAGES)
@pytest.mark.parametrize(("points", "radius"), [(8, 1.0), (8, 2.0), (16, 2.0), (12, 1.5)])
def test_lbp_kernel_gives_skimages_codes_pixel_for_pixel(name, points, radius):
    grey = IMAGES[name]
    ours = _kernels.lbp_uniform(grey, points, radius)
    theirs = local_binary_pattern(grey, points, radius, method="uniform")
    np.testing.assert_array_equal(ours, theirs)


def test_uniform_table_counts_ones_of_patterns_changing_at_most_twice():
    table = _kernels.uniform_table(8)
    assert table[0b00000000] == 0 and table[0b11111111] == 8
    assert table[0b00111000] == 3  # two changes
    assert table[0b10000001] == 2  # two changes (not counted around the circle)
    assert table[0b01010000] == 9  # four changes: not uniform, P + 1


def test_lbp_histograms_are_shares_of_each_code_of_the_whole_image_in_each_tile():
    grey = IMAGES["grass"]  # 72 x 96
    boxes = np.array([(0, 0, 96, 72), (0, 0, 40, 30), (40, 30, 96, 72), (95, 71, 96, 72)])
    hist = lbp_histograms(grey, boxes)
    assert hist.shape == (len(boxes), sum(p + 2 for p, _ in LBP_POINTS))
    np.testing.assert_array_equal(lbp_histograms(grey), hist[:1])  # default: the whole image
    start = 0
    for points, radius in LBP_POINTS:
        codes = local_binary_pattern(grey, points, radius, "uniform").astype(int)
        for row, (x0, y0, x1, y1) in zip(hist, boxes, strict=True):
            tile = codes[y0:y1, x0:x1]  # the whole image's codes: edges see the next tile
            expected = np.bincount(tile.ravel(), minlength=points + 2) / tile.size
            np.testing.assert_array_equal(row[start : start + points + 2], expected)
        start += points + 2


def test_glcm_statistics_are_skimages_averaged_over_directions():
    grey = IMAGES["grass"]
    stats = glcm_statistics(grey).reshape(len(GLCM_PROPERTIES), len(GLCM_DISTANCES))
    quantised = (grey.astype(int) * 32 // 256).astype(np.uint8)
    matrix = graycomatrix(
        quantised, GLCM_DISTANCES, [0, np.pi / 4, np.pi / 2, 3 * np.pi / 4], 32, True, True
    )
    for row, name in zip(stats, GLCM_PROPERTIES, strict=True):
        np.testing.assert_allclose(row, graycoprops(matrix, name).mean(axis=1))
    flat = glcm_statistics(IMAGES["flat"])  # a uniform tile: contrast 0, correlation 1, finite
    assert np.isfinite(flat).all() and flat[0] == 0.0 and flat[-1] == 1.0


def test_feature_settings_join_families_and_one_colour_space_in_canonical_order():
    assert feature_parts("lab+glcm+sfta") == (("sfta", "glcm"), "lab")
    assert ClassifierConfig(features="lbp+sfta+hsv").features == "sfta+lbp+hsv"
    for bad in ("lab", "sfta+sfta", "sfta+lab+hsv", "sfta+gabor", ""):
        with pytest.raises(ConfigError, match="features"):
            ClassifierConfig(features=bad)


@pytest.mark.parametrize(
    ("features", "width"),
    [("sfta", 24), ("lbp", 20), ("glcm", 10), ("sfta+lab", 30), ("sfta+lbp+glcm+hsv", 60)],
)
def test_each_family_adds_its_values_in_order(features, width):
    rgb = np.repeat(IMAGES["grass"][..., None], 3, axis=2)
    cfg = ClassifierConfig(features=features, min_tile_size=32)
    tiles = image_features(rgb, cfg)
    assert tiles.shape == (4, width) and np.isfinite(tiles).all()  # 72 px: 2x2 tiles of 32
    whole = region_features(rgb, cfg)
    if features == "sfta+lab":  # SFTA and colour describe a tile alone, as before the families
        np.testing.assert_array_equal(
            image_features(rgb[:36, :48], cfg)[0], region_features(rgb[:36, :48], cfg)
        )
    assert whole.shape == (width,)


def test_min_tile_size_auto_cuts_training_images_into_tiles_by_tiles():
    cfg = ClassifierConfig()
    assert cfg.min_tile_size == "auto"
    for short in (64, 320):
        resolved = resolve_scale(cfg, short)
        assert resolved.min_tile_size == short // 4
        assert tile_grid(short, short + 40, resolved) == (4, 4)
    small = resolve_scale(cfg, 64)  # a region of interest larger than the training patches
    assert tile_grid(480, 640, small) == (4, 4)  # capped by tiles, as before
    assert resolve_scale(ClassifierConfig(min_tile_size=24), 64).min_tile_size == 24  # set: kept
    assert resolve_scale(cfg, 20).min_tile_size == 8  # never below MIN_TILE_SIZE
    assert tile_grid(64, 64, cfg) == (4, 4)  # unresolved: the region's own size


def test_grey_kernel_is_eq_18_exactly_on_every_colour_order():
    rgb = RNG.integers(0, 256, (50, 70, 3), dtype=np.uint8)
    wide = rgb.astype(np.int64)
    expected = (30 * wide[..., 0] + 59 * wide[..., 1] + 11 * wide[..., 2] + 50) // 100
    np.testing.assert_array_equal(to_grey(rgb), expected)
    np.testing.assert_array_equal(to_grey(rgb[..., ::-1], colour_order="bgr"), expected)
    np.testing.assert_array_equal(to_grey(rgb[5:20, 3:40]), expected[5:20, 3:40])  # a view
    assert np.array_equal(
        _kernels.byte_histogram(rgb.ravel()), np.bincount(rgb.ravel(), minlength=256)
    )
