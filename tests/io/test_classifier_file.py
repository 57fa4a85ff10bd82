"""Tests of classifier model files and the default model (:mod:`terrain_odom.io.classifier_file`)."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest

import terrain_odom
from terrain_odom import __version__
from terrain_odom.config.classifier import ClassifierConfig, paper_config
from terrain_odom.errors import InputFileError
from terrain_odom.io.classifier_file import (
    MODEL_FORMAT_VERSION,
    default_classifier,
    default_classifier_path,
    load_classifier,
    save_classifier,
)
from terrain_odom.vision.classifier import TerrainClassifier
from terrain_odom.vision.features import FEATURE_VERSION, image_features


def test_model_round_trip_gives_identical_predictions(tmp_path):
    rng = np.random.default_rng(0)
    features = rng.normal(size=(40, 5))
    region = np.repeat(np.arange(10), 4)
    model = TerrainClassifier(ClassifierConfig(k=3)).fit(features, list("aaaaabbbbb"), region)
    path = save_classifier(model, tmp_path / "model")  # written as given, no suffix added
    assert [p.name for p in tmp_path.iterdir()] == ["model"]
    loaded = load_classifier(path, expected=ClassifierConfig())
    assert loaded.config == model.config and loaded.classes == ["a", "b"]
    query = rng.normal(size=(12, 5))
    for ours, theirs in zip(
        loaded.predict_with_confidence(query, np.arange(12) // 3),
        model.predict_with_confidence(query, np.arange(12) // 3),
        strict=True,
    ):
        np.testing.assert_array_equal(ours, theirs)
    arrays, meta = model.to_arrays()
    with np.load(path, allow_pickle=False) as data:
        for name, array in arrays.items():
            np.testing.assert_array_equal(data[name], array)
        stored = json.loads(str(data["metadata"]))
    assert list(stored) == ["format_version", *meta, "created", "terrain_odom_version"]
    assert stored["format_version"] == MODEL_FORMAT_VERSION
    assert stored["terrain_odom_version"] == __version__


def test_an_unfitted_model_is_not_saved(tmp_path):
    with pytest.raises(ValueError, match="fit the classifier"):
        save_classifier(TerrainClassifier(), tmp_path / "m.npz")
    assert not list(tmp_path.iterdir())


def test_default_classifier_is_package_data_and_loads():
    path = default_classifier_path()
    assert path == Path(terrain_odom.__file__).parent / "models" / "default.npz"
    assert default_classifier() == path and path.stat().st_size < 2e6
    model = load_classifier(path)
    assert {"grass", "gravel"} <= set(model.classes)
    assert model.config.tile_size == 32


def test_missing_default_classifier_is_an_input_error(tmp_path):
    missing = tmp_path / "default.npz"
    with pytest.raises(InputFileError, match="pass --classifier") as info:
        default_classifier(missing)
    assert str(missing) in str(info.value)


def test_model_file_holds_no_pickle_and_readable_metadata(tmp_path):
    model = TerrainClassifier(paper_config()).fit(np.arange(12.0).reshape(6, 2), list("aaabbb"))
    path = save_classifier(model, tmp_path / "m.npz")
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
    path = save_classifier(TerrainClassifier().fit(np.eye(6), list("aaabbb")), tmp_path / "m.npz")
    _rewrite_model(path, feature_version=FEATURE_VERSION + 1)
    with pytest.raises(InputFileError, match="feature_version") as info:
        load_classifier(path)
    message = str(info.value)
    assert str(path) in message and str(FEATURE_VERSION + 1) in message
    assert f"uses {FEATURE_VERSION}" in message


def test_load_refuses_a_model_of_the_old_format_without_region_index(tmp_path):
    # Format 1 stored (n_images * tiles**2) rows and no region index.
    path = save_classifier(TerrainClassifier().fit(np.eye(6), list("aaabbb")), tmp_path / "m.npz")
    _rewrite_model(path, {"region": None}, format_version=1, feature_version=1)
    with pytest.raises(InputFileError, match="format_version is 1") as info:
        load_classifier(path)
    assert f"uses {MODEL_FORMAT_VERSION}" in str(info.value) and "retrain" in str(info.value)


def test_load_refuses_an_inconsistent_region_index(tmp_path):
    path = save_classifier(TerrainClassifier().fit(np.eye(6), list("aaabbb")), tmp_path / "m.npz")
    _rewrite_model(path, {"region": np.array([0, 1, 2, 4, 4, 5])})  # region 3 has no tile
    with pytest.raises(InputFileError, match=r"inconsistent model file \(region\(s\) \[3\]"):
        load_classifier(path)


@pytest.mark.parametrize(
    ("expected", "text"),
    [
        (ClassifierConfig(n_t=3), "n_t=4.*n_t=3"),
        (ClassifierConfig(features="sfta"), "features='sfta\\+lbp\\+lab'.*features='sfta'"),
        (ClassifierConfig(tiles=3), "tiles"),
        (ClassifierConfig(min_tile_size=24), "min_tile_size=32.*min_tile_size=24"),
    ],
)
def test_load_refuses_a_model_with_other_feature_settings(tmp_path, expected, text):
    model = TerrainClassifier(ClassifierConfig(min_tile_size=32)).fit(np.eye(6), list("aaabbb"))
    path = save_classifier(model, tmp_path / "m.npz")
    load_classifier(path, expected=ClassifierConfig())  # auto accepts what the training chose
    with pytest.raises(InputFileError, match=text) as info:
        load_classifier(path, expected=expected)
    assert str(path) in str(info.value)


def test_load_reports_missing_and_foreign_files(tmp_path):
    with pytest.raises(InputFileError, match="not found"):
        load_classifier(tmp_path / "none.npz")
    (tmp_path / "junk.npz").write_text("not a model")
    with pytest.raises(InputFileError, match="not a terrain-odom model"):
        load_classifier(tmp_path / "junk.npz")


def test_fixed_tile_size_is_saved_with_the_model_and_checked(tmp_path):
    rng = np.random.default_rng(4)
    cfg = ClassifierConfig(tile_size=32, k=1)
    images = [rng.integers(0, 256, size=(64, 64, 3), dtype=np.uint8) for _ in range(4)]
    features = [image_features(im, cfg) for im in images]
    region = np.repeat(np.arange(4), [len(f) for f in features])
    clf = TerrainClassifier(cfg).fit(np.vstack(features), ["a", "a", "b", "b"], region)
    loaded = load_classifier(save_classifier(clf, tmp_path / "m.npz"))
    assert loaded.config.tile_size == 32
    with pytest.raises(InputFileError, match="tile_size=32.*tile_size=None"):
        load_classifier(tmp_path / "m.npz", expected=ClassifierConfig(k=1))
