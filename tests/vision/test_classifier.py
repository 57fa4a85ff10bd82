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
    MODEL_FORMAT_VERSION,
    ClassifierConfig,
    TerrainClassifier,
    check_regions,
    colour_statistics,
    image_features,
    load_classifier_config,
    make_pipeline,
    paper_config,
    region_features,
    split_tiles,
    tile_grid,
    tiles_per_side,
    tiles_within,
)

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
    cfg = ClassifierConfig()
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
        model = TerrainClassifier().fit(x_train, y_train, r_train)
        predicted = model.predict(x_test, r_test)
        correct += int(np.sum(predicted == y_test))
        total += len(y_test)
    assert total == 2 * 3 * 32
    assert np.all(np.bincount(texture_features[0][1]) == 4)
    assert correct / total >= 0.97


def test_model_round_trip_gives_identical_predictions(tmp_path, texture_features):
    x_train, r_train, y_train = texture_features[0]
    x_test, r_test, _ = texture_features[1]
    model = TerrainClassifier().fit(x_train, y_train, r_train)
    path = model.save(tmp_path / "model.npz")
    loaded = TerrainClassifier.load(path, expected=ClassifierConfig())
    assert loaded.cfg == model.cfg
    assert loaded.classes == sorted(TEXTURES)
    np.testing.assert_array_equal(loaded.training_region, r_train)
    for ours, theirs in zip(
        loaded.predict_with_confidence(x_test, r_test),
        model.predict_with_confidence(x_test, r_test),
        strict=True,
    ):
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(loaded.predict_proba(x_test), model.predict_proba(x_test))
    meta = loaded.metadata()
    assert loaded.n_training_images == meta["n_training_images"] == len(y_train)
    assert meta["n_training_samples"] == len(x_train) == 4 * len(y_train)
    assert meta["feature_version"] == FEATURE_VERSION
    assert meta["config"]["min_tile_size"] == ClassifierConfig().min_tile_size


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
        assert data["region"].tolist() == list(range(6))
        assert data["scaler_mean"].size == 0  # no scaler in the paper's recipe
    assert meta["classes"] == ["a", "b"]
    assert meta["config"]["features"] == "sfta"
    assert {"format_version", "created", "terrain_odom_version", "n_training_images"} <= set(meta)


def _rewrite_model(path: Path, arrays_changes: dict | None = None, **changes) -> None:
    """Rewrite a model file with other arrays (None: removed) and metadata ``changes``."""
    with np.load(path, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    arrays.update(arrays_changes or {})
    arrays = {name: array for name, array in arrays.items() if array is not None}
    meta = json.loads(str(arrays["metadata"]))
    meta.update(changes)
    arrays["metadata"] = np.array(json.dumps(meta))
    with open(path, "wb") as handle:
        np.savez(handle, **arrays)


def test_load_refuses_a_model_of_another_feature_version(tmp_path):
    path = TerrainClassifier().fit(np.eye(6), list("aaabbb")).save(tmp_path / "m.npz")
    _rewrite_model(path, feature_version=FEATURE_VERSION + 1)
    with pytest.raises(InputFileError, match="feature_version") as info:
        TerrainClassifier.load(path)
    message = str(info.value)
    assert str(path) in message and str(FEATURE_VERSION + 1) in message
    assert f"uses {FEATURE_VERSION}" in message


def test_load_refuses_a_model_of_the_old_format_without_region_index(tmp_path):
    # Format 1 stored (n_images * tiles**2) rows and no region index.
    path = TerrainClassifier().fit(np.eye(6), list("aaabbb")).save(tmp_path / "m.npz")
    _rewrite_model(path, {"region": None}, format_version=1, feature_version=1)
    with pytest.raises(InputFileError, match="format_version is 1") as info:
        TerrainClassifier.load(path)
    assert f"uses {MODEL_FORMAT_VERSION}" in str(info.value) and "retrain" in str(info.value)


def test_load_refuses_an_inconsistent_region_index(tmp_path):
    path = TerrainClassifier().fit(np.eye(6), list("aaabbb")).save(tmp_path / "m.npz")
    _rewrite_model(path, {"region": np.array([0, 1, 2, 4, 4, 5])})  # region 3 has no tile
    with pytest.raises(InputFileError, match=r"inconsistent model file \(region\(s\) \[3\]"):
        TerrainClassifier.load(path)


@pytest.mark.parametrize(
    ("expected", "text"),
    [
        (ClassifierConfig(n_t=3), "n_t=4.*n_t=3"),
        (ClassifierConfig(features="sfta"), "features='sfta\\+lab'.*features='sfta'"),
        (ClassifierConfig(tiles=3), "tiles"),
        (ClassifierConfig(min_tile_size=24), "min_tile_size=32.*min_tile_size=24"),
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


def test_tile_grid_adapts_to_the_region_size():
    cfg = ClassifierConfig()
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


def test_fit_and_classify_regions_of_mixed_sizes():
    # Training regions of 48, 64 and 128 px: 1, 4 and 16 tiles (ragged), a row of each.
    cfg = ClassifierConfig()
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
    assert image_features(image, ClassifierConfig(tiles=3, min_tile_size=8)).shape == (9, 30)


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


def test_fixed_size_tiles_scale_with_the_area():
    cfg = ClassifierConfig(tile_size=64)
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
    with pytest.raises(ConfigError, match="tile_size: must be >= 8"):
        load_classifier_config(None, {"tile_size": 4})
    assert load_classifier_config(None, {"tile_size": 8}).tile_size == 8


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


def test_fixed_tile_size_is_saved_with_the_model_and_checked(tmp_path):
    rng = np.random.default_rng(4)
    cfg = ClassifierConfig(tile_size=32, k=1)
    images = [rng.integers(0, 256, size=(64, 64, 3), dtype=np.uint8) for _ in range(4)]
    features = [image_features(im, cfg) for im in images]
    region = np.repeat(np.arange(4), [len(f) for f in features])
    clf = TerrainClassifier(cfg).fit(np.vstack(features), ["a", "a", "b", "b"], region)
    loaded = TerrainClassifier.load(clf.save(tmp_path / "m.npz"))
    assert loaded.cfg.tile_size == 32
    with pytest.raises(InputFileError, match="tile_size=32.*tile_size=None"):
        TerrainClassifier.load(tmp_path / "m.npz", expected=ClassifierConfig(k=1))


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


def test_classifier_config_file_and_overrides(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("k: 7\nweights: uniform\n")
    cfg = load_classifier_config(path, {"tiles": 2, "min_tile_size": 24})
    assert (cfg.k, cfg.weights, cfg.tiles, cfg.min_tile_size) == (7, "uniform", 2, 24)
    path.write_text("kk: 7\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: .*unknown key"):
        load_classifier_config(path)
    with pytest.raises(ConfigError, match="min_tile_size: must be a whole number >= 1"):
        load_classifier_config(None, {"min_tile_size": 0})
    with pytest.raises(ConfigError, match="features: must be one of"):
        load_classifier_config(None, {"features": "rgb"})
    with pytest.raises(ConfigError, match="not found"):
        load_classifier_config(tmp_path / "missing.yaml")
