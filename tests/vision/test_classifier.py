"""Tests of the KNN terrain classifier (:mod:`terrain_odom.vision.classifier`)."""

from __future__ import annotations

import dataclasses
import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest
import skimage.data

from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.vision.classifier import (
    FEATURE_VERSION,
    ClassifierConfig,
    TerrainClassifier,
    colour_statistics,
    image_features,
    load_classifier_config,
    make_pipeline,
    paper_config,
    region_features,
    split_tiles,
)

TILE = 64
TEXTURES = ("grass", "gravel", "brick")


def texture_tiles(name: str, half: int) -> list[np.ndarray]:
    """Non-overlapping 64x64 RGB tiles of the left (0) or right (1) half of a skimage texture."""
    grey = getattr(skimage.data, name)()
    width = grey.shape[1] // 2
    part = grey[:, half * width : (half + 1) * width]
    rgb = np.repeat(part[..., None], 3, axis=2)
    return [
        rgb[r : r + TILE, c : c + TILE]
        for r in range(0, rgb.shape[0] - TILE + 1, TILE)
        for c in range(0, rgb.shape[1] - TILE + 1, TILE)
    ]


SMALL_PATCH = ClassifierConfig(tiles=2)
"""The defaults, voting over 32x32 tiles: 4x4 tiles of 16 px are too small for box counting."""


@pytest.fixture(scope="module")
def texture_features() -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Features (:data:`SMALL_PATCH`) and labels of the 64x64 tiles of each image half."""
    cfg = SMALL_PATCH
    out = {}
    for half in (0, 1):
        feats, labels = [], []
        for name in TEXTURES:
            for tile in texture_tiles(name, half):
                feats.append(image_features(tile, cfg))
                labels.append(name)
        out[half] = (np.stack(feats), np.array(labels))
    return out


def test_skimage_textures_are_classified_from_the_other_image_half(texture_features):
    # 2-fold cross-validation over disjoint image halves: train on one, test on the other.
    correct = total = 0
    for train_half in (0, 1):
        x_train, y_train = texture_features[train_half]
        x_test, y_test = texture_features[1 - train_half]
        predicted = TerrainClassifier(SMALL_PATCH).fit(x_train, y_train).predict(x_test)
        correct += int(np.sum(predicted == y_test))
        total += len(y_test)
    assert total == 2 * 3 * 32
    assert correct / total >= 0.97


def test_model_round_trip_gives_identical_predictions(tmp_path, texture_features):
    x_train, y_train = texture_features[0]
    x_test, _ = texture_features[1]
    model = TerrainClassifier(SMALL_PATCH).fit(x_train, y_train)
    path = model.save(tmp_path / "model.npz")
    loaded = TerrainClassifier.load(path, expected=SMALL_PATCH)
    assert loaded.cfg == model.cfg
    assert loaded.classes == sorted(TEXTURES)
    np.testing.assert_array_equal(loaded.predict(x_test), model.predict(x_test))
    np.testing.assert_array_equal(
        loaded.predict_proba(x_test[:, 0]), model.predict_proba(x_test[:, 0])
    )
    meta = loaded.metadata()
    assert meta["n_training_images"] == len(y_train)
    assert meta["feature_version"] == FEATURE_VERSION


def test_model_file_holds_no_pickle_and_readable_metadata(tmp_path):
    model = TerrainClassifier(paper_config()).fit(np.arange(12.0).reshape(6, 2), list("aaabbb"))
    path = model.save(tmp_path / "m.npz")
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask  # not a private temp file's 0600
    assert [p.name for p in tmp_path.iterdir()] == ["m.npz"]  # no temporary file left
    with np.load(path, allow_pickle=False) as data:  # would raise on object arrays
        meta = json.loads(str(data["metadata"]))
        assert data["labels"].dtype.kind == "U"
        assert data["scaler_mean"].size == 0  # no scaler in the paper's recipe
    assert meta["classes"] == ["a", "b"]
    assert meta["config"]["features"] == "sfta"
    assert {"format_version", "created", "terrain_odom_version", "n_training_images"} <= set(meta)


def _rewrite_metadata(path: Path, **changes) -> None:
    with np.load(path, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    meta = json.loads(str(arrays["metadata"]))
    meta.update(changes)
    arrays["metadata"] = np.array(json.dumps(meta))
    with open(path, "wb") as handle:
        np.savez(handle, **arrays)


def test_load_refuses_a_model_of_another_feature_version(tmp_path):
    path = TerrainClassifier().fit(np.eye(6), list("aaabbb")).save(tmp_path / "m.npz")
    _rewrite_metadata(path, feature_version=FEATURE_VERSION + 1)
    with pytest.raises(InputFileError, match="feature_version") as info:
        TerrainClassifier.load(path)
    message = str(info.value)
    assert str(path) in message and str(FEATURE_VERSION + 1) in message
    assert f"uses {FEATURE_VERSION}" in message


@pytest.mark.parametrize(
    ("expected", "text"),
    [
        (ClassifierConfig(n_t=3), "n_t=4.*n_t=3"),
        (ClassifierConfig(features="sfta"), "features='sfta\\+lab'.*features='sfta'"),
        (ClassifierConfig(tiles=3), "tiles"),
    ],
)
def test_load_refuses_a_model_with_other_feature_settings(tmp_path, expected, text):
    path = TerrainClassifier().fit(np.eye(6), list("aaabbb")).save(tmp_path / "m.npz")
    with pytest.raises(InputFileError, match=text) as info:
        TerrainClassifier.load(path, expected=expected)
    assert str(path) in str(info.value)


def test_load_reports_missing_and_foreign_files(tmp_path):
    with pytest.raises(InputFileError, match="not found"):
        TerrainClassifier.load(tmp_path / "none.npz")
    (tmp_path / "junk.npz").write_text("not a model")
    with pytest.raises(InputFileError, match="not a terrain-odom model"):
        TerrainClassifier.load(tmp_path / "junk.npz")


def test_paper_pipeline_uses_raw_features_and_default_standardises():
    assert list(make_pipeline(paper_config()).named_steps) == ["knn"]
    assert list(make_pipeline(ClassifierConfig()).named_steps) == ["scaler", "knn"]
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
    tiles = np.array([[[0.0], [0.1], [0.9], [0.2]], [[1.0], [0.9], [0.2], [0.95]]])
    labels, confidence = model.predict_with_confidence(tiles)
    assert labels.tolist() == ["a", "b"]
    np.testing.assert_allclose(confidence, [0.75, 0.75])


def test_tile_vote_tie_goes_to_the_larger_neighbour_share():
    cfg = dataclasses.replace(paper_config(), k=3)
    x = np.array([[0.0], [0.1], [1.0], [1.1], [1.2]])
    model = TerrainClassifier(cfg).fit(x, np.array(list("aabbb")))
    # Tile shares: a 2/3, a 2/3, b 3/3, b 3/3 -> 2 votes each, b has more weight.
    labels, confidence = model.predict_with_confidence(np.array([[[0.0], [0.05], [1.1], [1.2]]]))
    assert labels.tolist() == ["b"]
    np.testing.assert_allclose(confidence, [0.5])


def test_classify_a_whole_image_and_with_tiles():
    tile = texture_tiles("brick", 0)[0]
    for tiles in (1, 2):
        cfg = ClassifierConfig(tiles=tiles, k=1)
        x = np.stack([image_features(texture_tiles(name, 0)[1], cfg) for name in TEXTURES])
        model = TerrainClassifier(cfg).fit(x, np.array(TEXTURES))
        label, confidence = model.classify(tile)
        assert isinstance(label, str) and label in TEXTURES
        assert isinstance(confidence, float) and 0.0 < confidence <= 1.0


def test_k_larger_than_the_training_set_is_a_config_error():
    with pytest.raises(ConfigError, match="k: 5 neighbours but only 3"):
        TerrainClassifier(ClassifierConfig(k=5)).fit(np.eye(3), list("abc"))


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
    assert image_features(image, ClassifierConfig(tiles=3)).shape == (9, 30)


def test_relative_counts_are_fractions_of_the_area():
    image = np.repeat(texture_tiles("gravel", 0)[0][..., :1], 3, axis=2)
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


def test_split_tiles_covers_every_pixel_once():
    image = np.arange(7 * 9).reshape(7, 9)
    tiles = split_tiles(image, 3)
    assert len(tiles) == 9
    assert sorted(np.concatenate([t.ravel() for t in tiles]).tolist()) == list(range(63))
    with pytest.raises(ValueError, match="cannot cut"):
        split_tiles(image, 8)


def test_image_features_rejects_non_rgb_input():
    with pytest.raises(ValueError, match="RGB uint8"):
        image_features(np.zeros((8, 8)), ClassifierConfig())


def test_classifier_config_file_and_overrides(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("k: 7\nweights: uniform\n")
    cfg = load_classifier_config(path, {"tiles": 2})
    assert (cfg.k, cfg.weights, cfg.tiles) == (7, "uniform", 2)
    path.write_text("kk: 7\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: .*unknown key"):
        load_classifier_config(path)
    with pytest.raises(ConfigError, match="features: must be one of"):
        load_classifier_config(None, {"features": "rgb"})
    with pytest.raises(ConfigError, match="not found"):
        load_classifier_config(tmp_path / "missing.yaml")
