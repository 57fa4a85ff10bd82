"""Tests of the settings search (:mod:`terrain_odom.vision.tuning`).

Small in-memory image sets (crops of skimage textures, decoded by a dict
lookup) keep the searches to seconds. The constructed case: two classes of crops of
the same texture, one grey and one tinted *without changing the grey levels*,
so grey SFTA cannot tell them apart and SFTA + CIELAB can.
"""

from __future__ import annotations

import copy
import functools
import pickle
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import skimage.data
from sklearn.base import clone

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError
from terrain_odom.vision import dataset
from terrain_odom.vision.dataset import LabelledImages, extract_feature_sets
from terrain_odom.vision.sfta import to_grey
from terrain_odom.vision.tuning import (
    FeatureCache,
    ImageKNN,
    check_grid,
    default_grid,
    grid_configs,
    image_index,
    nested_search,
    search_settings,
)

SIZE = 32  # one tile per image with the default min_tile_size
BASE = ClassifierConfig(n_t=1)  # 6 SFTA values beside the 6 colour statistics


def colour_classes(per_class: int = 12) -> dict[Path, np.ndarray]:
    """Crops of skimage's brick texture in two classes that differ only in colour.

    Crop ``g`` (32 px, grey levels clipped to 40-230) ``2 i`` is
    ``neutral/i``: (g, g, g); crop ``2 i + 1`` is ``warm/i``: (g + 11, g, g - 30),
    whose grey ``(30 R + 59 G + 11 B + 50) // 100`` is again ``g``.
    """
    grey = np.clip(skimage.data.brick().astype(np.int64), 40, 230)
    images = {}
    for i in range(2 * per_class):
        g = grey[(i // 8) * SIZE : (i // 8 + 1) * SIZE, (i % 8) * SIZE : (i % 8 + 1) * SIZE]
        if i % 2:
            images[Path(f"warm/{i // 2}")] = np.stack([g + 11, g, g - 30], axis=-1).astype(np.uint8)
        else:
            images[Path(f"neutral/{i // 2}")] = np.stack([g, g, g], axis=-1).astype(np.uint8)
    return images


def image_set(images: dict[Path, np.ndarray]) -> LabelledImages:
    """Return the labelled set of ``images`` (class: the folder), sorted like a folder scan."""
    paths = tuple(sorted(images))
    labels = tuple(path.parent.name for path in paths)
    return LabelledImages(Path("."), tuple(sorted(set(labels))), paths, labels)


def memory_cache(images: dict[Path, np.ndarray]) -> FeatureCache:
    """Return a cache extracting the features of ``images`` in this process."""
    labelled = image_set(images)

    def extract(configs: list[ClassifierConfig]) -> list[dataset.LabelledFeatures]:
        return extract_feature_sets(labelled, configs, read=images.__getitem__, jobs=1)

    return FeatureCache(extract)


def test_the_tint_keeps_the_grey_levels():
    for image in colour_classes(2).values():
        assert np.array_equal(to_grey(image), image[..., 1])  # the crop g


def test_the_search_picks_colour_features_where_only_colour_separates_the_classes():
    images = colour_classes()
    cache = memory_cache(images)
    base = BASE
    grid = check_grid({"features": ["sfta", "sfta+lab"], "k": [1, 3]}, base)
    labels = cache.features(base).labels
    search, chosen = search_settings(cache, base, grid, labels, folds=3, seed=0)
    scores = {
        (c["features"], c["k"]): s
        for c, s in zip(search.candidates, search.mean_score, strict=True)
    }
    assert chosen.features == "sfta+lab" and search.choice["features"] == "sfta+lab"
    assert scores["sfta+lab", 1] == scores["sfta+lab", 3] == 1.0
    assert max(scores["sfta", 1], scores["sfta", 3]) <= 0.75  # grey: about chance (0.5)
    assert chosen == ClassifierConfig(n_t=1, features="sfta+lab", k=search.choice["k"])
    assert search.folds == 3 and len(search.candidates) == 4
    assert search.to_dict()["choice"] == search.choice


def test_each_image_is_described_once_per_feature_setting(monkeypatch):
    calls: Counter[tuple[bytes, tuple]] = Counter()
    original = dataset.image_features

    def counting(image, cfg, within=None):
        calls[image.tobytes(), tuple(cfg.feature_key().items())] += 1
        return original(image, cfg, within)

    monkeypatch.setattr(dataset, "image_features", counting)
    images = colour_classes(9)
    cache = memory_cache(images)
    base = ClassifierConfig()
    # 3 feature settings: (sfta+lab, tiles 4), (sfta+lab, tiles 2), and tile_size 16 (tiles unused)
    grid = check_grid(
        [
            {"tiles": [2, 4], "k": [1, 3], "weights": ["uniform", "distance"]},
            {"tile_size": [16], "tiles": [2, 4], "scale": [True, False]},
        ],
        base,
    )
    labels = cache.features(base).labels
    search_settings(cache, base, grid, labels, folds=3, seed=0)
    nested_search(cache, base, grid, labels, folds=3, inner_folds=2, seed=0)
    assert len(cache) == 3
    assert len(calls) == 3 * len(images) and set(calls.values()) == {1}


def test_nested_cv_never_fits_or_tunes_on_the_outer_test_fold(monkeypatch):
    log: list[tuple[str, np.ndarray]] = []
    fit, predict = ImageKNN.fit, ImageKNN.predict

    @functools.wraps(fit)  # scikit-learn calls the scorer's method by its name
    def spy_fit(self, X, y):
        log.append(("fit", X[:, 0].copy()))
        return fit(self, X, y)

    @functools.wraps(predict)
    def spy_predict(self, X):
        log.append(("predict", X[:, 0].copy()))
        return predict(self, X)

    monkeypatch.setattr(ImageKNN, "fit", spy_fit)
    monkeypatch.setattr(ImageKNN, "predict", spy_predict)
    images = colour_classes(12)
    cache = memory_cache(images)
    base = BASE
    grid = check_grid({"features": ["sfta", "sfta+lab"], "k": [1, 3]}, base)
    labels = cache.features(base).labels
    folds = nested_search(cache, base, grid, labels, folds=4, inner_folds=3, seed=0)
    tests = [fold.test for fold in folds]
    assert np.array_equal(np.sort(np.concatenate(tests)), np.arange(labels.size))
    fits = [idx for kind, idx in log if kind == "fit"]
    per_fold = 4 * 3 + 1  # candidates x inner folds, then the refit of the choice
    assert len(fits) == 4 * per_fold
    for j, test in enumerate(tests):
        train = np.setdiff1d(np.arange(labels.size), test)
        for idx in fits[j * per_fold : (j + 1) * per_fold]:
            assert not np.intersect1d(idx, test).size  # never trained or tuned on the test fold
        assert np.array_equal(np.sort(fits[(j + 1) * per_fold - 1]), train)  # refit: all others
        assert folds[j].search.folds == 3
        assert np.array_equal(folds[j].truth, labels[test])
    # each fold: the inner searches score only its training images, then its test fold is scored
    predictions = [idx for kind, idx in log if kind == "predict"]
    per_fold = 4 * 3 + 1
    for j, test in enumerate(tests):
        chunk = predictions[j * per_fold : (j + 1) * per_fold]
        assert all(not np.intersect1d(idx, test).size for idx in chunk[:-1])
        assert np.array_equal(chunk[-1], test)
    assert all(fold.accuracy == 100.0 for fold in folds)  # colour separates the classes


def test_the_search_is_deterministic_and_the_same_in_worker_processes():
    cache = memory_cache(colour_classes(9))
    grid = check_grid({"features": ["sfta", "sfta+lab"], "k": [1, 3]}, BASE)
    cache.prepare(grid_configs(grid, BASE))
    labels = cache.features(BASE).labels
    serial = search_settings(cache, BASE, grid, labels, folds=3, seed=0)
    parallel = search_settings(cache, BASE, grid, labels, folds=3, seed=0, jobs=2)
    assert np.array_equal(serial[0].mean_score, parallel[0].mean_score)
    assert serial[1] == parallel[1]
    worker = pickle.loads(pickle.dumps(cache))  # what a joblib worker gets: no extraction
    assert np.array_equal(worker.features(BASE).features, cache.features(BASE).features)
    with pytest.raises(ValueError, match="not prepared"):
        worker.features(ClassifierConfig(n_t=2))


def test_clones_share_the_cache_and_estimator_parameters_are_the_configuration():
    cache = memory_cache(colour_classes(2))
    estimator = ImageKNN.of(cache, ClassifierConfig(k=3, tile_size=16))
    assert clone(estimator).cache is cache and copy.deepcopy(cache) is cache
    assert clone(estimator).config() == ClassifierConfig(k=3, tile_size=16)
    model = estimator.set_params(k=1).fit(image_index(4), np.array(["a", "a", "b", "b"]))
    assert model.predict(image_index(4)).tolist() == ["a", "a", "b", "b"]  # k=1 on its own images
    with pytest.raises(ValueError, match="FeatureCache"):
        ImageKNN().fit(image_index(2), np.array(["a", "b"]))


def test_grid_checks_name_the_field():
    base = ClassifierConfig()
    assert check_grid({"k": (1, 3)}, base) == [{"k": [1, 3]}]
    assert len(grid_configs(check_grid(default_grid(64), base), base)) == 8
    assert default_grid(64)["min_tile_size"] == [16, 32]  # 1/4 and 1/2 of the shorter side
    assert default_grid(20)["min_tile_size"] == [8, 10]  # never under MIN_TILE_SIZE
    assert "min_tile_size" not in default_grid(None)
    for bad, match in (
        ({"colour": ["lab"]}, "unknown field 'colour'"),
        ({"k": []}, r"grid.k: expected a non-empty list"),
        ({"k": 3}, r"grid.k: expected a non-empty list"),
        ({"weights": ["nearest"]}, "weights"),
        ({"tile_size": [4]}, "tile_size"),
        ([], "expected a mapping"),
        ("k: 3", "expected a mapping"),
        (3, "expected a mapping"),
    ):
        with pytest.raises(ConfigError, match=match):
            check_grid(bad, base)


def test_the_cache_refuses_an_extraction_of_other_images():
    images = colour_classes(2)
    fewer = {path: image for path, image in images.items() if path.name != "1"}
    sets = [image_set(images), image_set(fewer)]

    def extract(configs: list[ClassifierConfig]) -> list[dataset.LabelledFeatures]:
        return extract_feature_sets(sets.pop(0), configs, read=images.__getitem__, jobs=1)

    cache = FeatureCache(extract)
    cache.features(ClassifierConfig())
    with pytest.raises(ValueError, match="another image set"):
        cache.features(ClassifierConfig(features="sfta"))
