"""Tests of the KNN terrain classifier (:mod:`terrain_odom.vision.classifier`)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import skimage.data

from terrain_odom.config.classifier import ClassifierConfig, paper_config
from terrain_odom.errors import ConfigError
from terrain_odom.vision.classifier import (
    MODEL_ARRAYS,
    TerrainClassifier,
    check_regions,
    make_pipeline,
)
from terrain_odom.vision.features import FEATURE_VERSION, image_features

TILE = 64
TEXTURES = ("grass", "gravel", "brick")


def texture_half(name: str, half: int) -> np.ndarray:
    """Left (0) or right (1) half of a skimage texture, as RGB."""
    grey = getattr(skimage.data, name)()
    width = grey.shape[1] // 2
    return np.repeat(grey[:, half * width : (half + 1) * width, None], 3, axis=2)


def texture_tiles(name: str, half: int) -> list[np.ndarray]:
    """Non-overlapping 64x64 RGB tiles of the left (0) or right (1) half of a skimage texture."""
    rgb = texture_half(name, half)
    return [
        rgb[r : r + TILE, c : c + TILE]
        for r in range(0, rgb.shape[0] - TILE + 1, TILE)
        for c in range(0, rgb.shape[1] - TILE + 1, TILE)
    ]


def stack_regions(per_region: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Flat tile features and region index of a list of :func:`image_features` results."""
    region = np.repeat(np.arange(len(per_region)), [len(f) for f in per_region])
    return np.concatenate(per_region), region


@pytest.fixture(scope="module")
def texture_features() -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Default features, region index and labels of the 64x64 tiles of each image half."""
    cfg = ClassifierConfig(min_tile_size=32)
    out = {}
    for half in (0, 1):
        feats, labels = [], []
        for name in TEXTURES:
            for tile in texture_tiles(name, half):
                feats.append(image_features(tile, cfg))
                labels.append(name)
        out[half] = (*stack_regions(feats), np.array(labels))
    return out


def test_skimage_textures_are_classified_from_the_other_image_half(texture_features):
    # 2-fold cross-validation over disjoint image halves: train on one, test on the other,
    # with the default configuration (64 px patches: 2x2 tiles of 32 px).
    correct = total = 0
    for train_half in (0, 1):
        x_train, r_train, y_train = texture_features[train_half]
        x_test, r_test, y_test = texture_features[1 - train_half]
        model = TerrainClassifier(ClassifierConfig(min_tile_size=32)).fit(x_train, y_train, r_train)
        predicted = model.predict(x_test, r_test)
        correct += int(np.sum(predicted == y_test))
        total += len(y_test)
    assert total == 2 * 3 * 32
    assert np.all(np.bincount(texture_features[0][1]) == 4)
    assert correct / total >= 0.97


def test_arrays_round_trip_gives_identical_predictions(texture_features):
    x_train, r_train, y_train = texture_features[0]
    x_test, r_test, _ = texture_features[1]
    model = TerrainClassifier(ClassifierConfig(min_tile_size=32)).fit(x_train, y_train, r_train)
    model.calibrate_novelty()
    model.min_confidence = 0.6
    arrays, meta = model.to_arrays()
    assert sorted(arrays) == sorted(MODEL_ARRAYS)
    assert arrays["region"].dtype == np.int64 and arrays["labels"].dtype.kind == "U"
    json.dumps(meta)  # plain data
    loaded = TerrainClassifier.from_arrays(
        ClassifierConfig(min_tile_size=32),
        arrays,
        novelty_distance=meta["novelty_distance"],
        min_confidence=meta["min_confidence"],
    )
    assert loaded.config == model.config
    assert (loaded.novelty_distance, loaded.min_confidence) == (model.novelty_distance, 0.6)
    assert loaded.classes == sorted(TEXTURES)
    np.testing.assert_array_equal(loaded.training_region, r_train)
    for ours, theirs in zip(
        loaded.predict_with_confidence(x_test, r_test),
        model.predict_with_confidence(x_test, r_test),
        strict=True,
    ):
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(loaded.predict_proba(x_test), model.predict_proba(x_test))
    assert loaded.n_training_images == meta["n_training_images"] == len(y_train)
    assert meta["n_training_samples"] == len(x_train) == 4 * len(y_train)
    assert meta["feature_version"] == FEATURE_VERSION
    assert meta["config"] == dataclasses.asdict(ClassifierConfig(min_tile_size=32))
    assert meta["classes"] == sorted(TEXTURES)


def test_paper_pipeline_uses_raw_features_and_default_standardises():
    assert list(make_pipeline(paper_config()).named_steps) == ["knn"]
    assert list(make_pipeline(ClassifierConfig(min_tile_size=32)).named_steps) == ["scaler", "knn"]
    # Raw distance: the large second feature decides, as in eq. 24.
    x = np.array(
        [[0.0, 1000.0], [0.0, 1010.0], [0.0, 1020.0], [1.0, 0.0], [1.0, 10.0], [1.0, 20.0]]
    )
    y = np.array(list("aaabbb"))
    query = np.array([[1.0, 1005.0]])
    cfg = dataclasses.replace(paper_config(), k=1)
    assert TerrainClassifier(cfg).fit(x, y).predict(query).tolist() == ["a"]
    scaled = dataclasses.replace(cfg, scale=True)
    x_scaled = np.array(
        [[0.0, 1000.0], [0.0, 1000.0], [0.0, 1000.0], [1.0, 990.0], [1.0, 990.0], [1.0, 990.0]]
    )
    # Standardised, the first feature (spread 0.5) counts as much as the second.
    assert TerrainClassifier(scaled).fit(x_scaled, y).predict([[1.0, 999.0]]).tolist() == ["b"]
    assert TerrainClassifier(cfg).fit(x_scaled, y).predict([[1.0, 999.0]]).tolist() == ["a"]


def test_confidence_is_the_neighbour_vote_share():
    x = np.array([[0.0], [0.1], [0.2], [1.0], [1.1], [5.0]])
    y = np.array(["a", "a", "a", "b", "b", "c"])
    cfg = dataclasses.replace(paper_config(), k=3)
    model = TerrainClassifier(cfg).fit(x, y)
    # Neighbours of 0.58: 0.2, 1.0, 0.1; of 0.9: 1.0, 1.1, 0.2; of 0.0: the three a's.
    labels, confidence = model.predict_with_confidence(np.array([[0.58], [0.9], [0.0]]))
    assert labels.tolist() == ["a", "b", "a"]
    np.testing.assert_allclose(confidence, [2 / 3, 2 / 3, 1.0])


def test_tile_vote_confidence_is_the_share_of_tiles():
    cfg = dataclasses.replace(paper_config(), k=1)
    model = TerrainClassifier(cfg).fit(np.array([[0.0], [1.0]]), np.array(["a", "b"]))
    # Ragged regions, rows in any order: region 0 has 4 tiles, 1 has 3, 2 has 1.
    tiles = np.array([[0.0], [1.0], [0.1], [0.9], [0.9], [0.2], [0.3], [0.95]])
    region = np.array([0, 1, 0, 1, 0, 2, 0, 1])
    labels, confidence = model.predict_with_confidence(tiles, region)
    assert labels.tolist() == ["a", "b", "a"]
    np.testing.assert_allclose(confidence, [0.75, 1.0, 1.0])


def test_tile_vote_tie_goes_to_the_larger_neighbour_share():
    cfg = dataclasses.replace(paper_config(), k=3)
    x = np.array([[0.0], [0.1], [1.0], [1.1], [1.2]])
    model = TerrainClassifier(cfg).fit(x, np.array(list("aabbb")))
    # Tile shares: a 2/3, a 2/3, b 3/3, b 3/3 -> 2 votes each, b has more weight.
    tiles = np.array([[0.0], [0.05], [1.1], [1.2], [0.4]])
    labels, confidence = model.predict_with_confidence(tiles, [0, 0, 0, 0, 1])
    assert labels.tolist() == ["b", "a"]
    # A one-tile region keeps the neighbour vote share (0.4: 0.1, 0.0 and 1.0).
    np.testing.assert_allclose(confidence, [0.5, 2 / 3])


def test_region_index_is_checked():
    model = TerrainClassifier(ClassifierConfig(k=1)).fit(np.eye(2), ["a", "b"])
    with pytest.raises(ValueError, match=r"region\(s\) \[1\] have no feature rows"):
        model.predict(np.eye(2), [0, 2])
    with pytest.raises(ValueError, match="one integer per feature row"):
        model.predict(np.eye(2), [0.0, 1.0])
    with pytest.raises(ValueError, match="shape \\(n_tiles, n_features\\)"):
        model.predict(np.zeros((1, 2, 2)))
    with pytest.raises(ValueError, match=r"in 0 \.\. 1"):  # 3 regions for 2 labels
        TerrainClassifier(ClassifierConfig(k=1)).fit(np.eye(3), ["a", "b"], [0, 1, 2])
    assert check_regions(np.eye(3), [1, 0, 1])[2].tolist() == [1, 2]


def test_fit_and_classify_regions_of_mixed_sizes():
    # Training regions of 48, 64 and 128 px: 1, 4 and 16 tiles (ragged), a row of each.
    cfg = ClassifierConfig(min_tile_size=32)
    per_region, labels = [], []
    for name in TEXTURES:
        rgb, top = texture_half(name, 0), 0
        for size in (48, 64, 128):
            for left in range(0, rgb.shape[1] - size + 1, size):
                per_region.append(image_features(rgb[top : top + size, left : left + size], cfg))
                labels.append(name)
            top += size
    features, region = stack_regions(per_region)
    assert np.bincount(region).tolist() == ([1] * 5 + [4] * 4 + [16] * 2) * 3
    model = TerrainClassifier(cfg).fit(features, labels, region)
    assert model.n_training_images == 33 and len(model.training_labels) == 3 * 53
    assert model.training_labels[region == 10].tolist() == ["grass"] * 16
    assert model.training_labels[region == 11].tolist() == ["gravel"]
    # Regions of the other half, of several sizes, one at a time.
    correct = total = 0
    for name in TEXTURES:
        rgb = texture_half(name, 1)
        for size in (96, 120, 128, 256):  # 3x3, 3x3, 4x4, 4x4 tiles
            for top in range(0, rgb.shape[0] - size + 1, size):
                for left in range(0, rgb.shape[1] - size + 1, size):
                    label, confidence = model.classify(rgb[top : top + size, left : left + size])
                    assert 1 / 3 <= confidence <= 1.0  # a plurality of the tiles
                    correct += label == name
                    total += 1
        label, confidence = model.classify(rgb[:40, :56])  # one tile: neighbour share
        assert label in TEXTURES and 0.0 < confidence <= 1.0
    assert total == 3 * (10 + 8 + 8 + 2)
    assert correct / total >= 0.95


def test_classify_a_whole_image_and_with_tiles():
    tile = texture_tiles("brick", 0)[0]
    for tiles in (1, 2):
        cfg = ClassifierConfig(tiles=tiles, k=1)
        x, region = stack_regions(
            [image_features(texture_tiles(name, 0)[1], cfg) for name in TEXTURES]
        )
        model = TerrainClassifier(cfg).fit(x, np.array(TEXTURES), region)
        label, confidence = model.classify(tile)
        # another brick crop than the trained one: every nearest tile is brick
        assert isinstance(label, str) and label == "brick"
        assert isinstance(confidence, float) and confidence == 1.0


def test_k_larger_than_the_training_set_is_a_config_error():
    with pytest.raises(ConfigError, match="k: 5 neighbours but only 3"):
        TerrainClassifier(ClassifierConfig(k=5)).fit(np.eye(3), list("abc"))


def test_a_polygon_decides_which_tiles_vote():
    # Gravel on the left two thirds, brick on the right third; the polygon covers the
    # right third only, so brick wins there although gravel has most of the region.
    cfg = ClassifierConfig(tile_size=64, k=1)
    features = [image_features(t, cfg) for n in ("gravel", "brick") for t in texture_tiles(n, 0)]
    labels = [n for n in ("gravel", "brick") for _ in texture_tiles(n, 0)]
    flat, region_index = stack_regions(features)
    clf = TerrainClassifier(cfg).fit(flat, labels, region_index)
    region = np.concatenate(
        (texture_half("gravel", 1)[:128, :128], texture_half("brick", 1)[:128, :64]), axis=1
    )
    assert clf.classify(region)[0] == "gravel"
    right = [(128, 0), (191, 0), (191, 127), (128, 127)]
    assert clf.classify(region, within=right) == ("brick", 1.0)


def test_from_arrays_refuses_missing_or_inconsistent_arrays():
    with pytest.raises(ValueError, match="fit the classifier"):
        TerrainClassifier().to_arrays()
    arrays, _ = TerrainClassifier().fit(np.eye(6), list("aaabbb")).to_arrays()
    no_region = {name: a for name, a in arrays.items() if name != "region"}
    with pytest.raises(ValueError, match=r"no \['region'\]"):
        TerrainClassifier.from_arrays(ClassifierConfig(min_tile_size=32), no_region)
    short = {**arrays, "labels": arrays["labels"][:5]}
    with pytest.raises(ValueError, match="5 labels for 6 feature rows"):
        TerrainClassifier.from_arrays(ClassifierConfig(min_tile_size=32), short)
