"""The classifier's own neighbour search and vote equal scikit-learn's, bit for bit, on real tiles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError
from terrain_odom.io.images import read_image_rgb
from terrain_odom.vision.classifier import TerrainClassifier
from terrain_odom.vision.features import image_features
from terrain_odom.vision.neighbours import SMALL_QUERY, NeighbourIndex

BATCHES = (1, 2, 3, 4, 5, 16, SMALL_QUERY)


@pytest.fixture(scope="module")
def floor_tiles(indoor_dir: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Default features of 96x96 crops of 60 floor photos: training tiles, their labels and images, queries."""
    cfg = ClassifierConfig()
    rng = np.random.default_rng(3)
    rows, labels, region = [], [], []
    for name in ("carpet", "tiles", "wood"):
        paths = sorted((indoor_dir / name).glob("*.jpg"))
        for path in rng.choice(paths, size=20, replace=False):
            image = read_image_rgb(path)
            assert image is not None
            y, x = rng.integers(0, np.array(image.shape[:2]) - 96)
            tiles = image_features(image[y : y + 96, x : x + 96], cfg)  # 16 tiles of 24 px
            region += [len(labels)] * len(tiles)
            rows.append(tiles)
            labels.append(name)
    features = np.vstack(rows)
    train = np.asarray(region) % 2 == 0  # even photos train, odd photos query
    renumbered = np.asarray(region)[train] // 2
    return features[train], np.asarray(labels)[::2], renumbered, features[~train]


def _fitted(features, labels, region, cfg) -> TerrainClassifier:
    return TerrainClassifier(cfg).fit(features, labels, region)


@pytest.mark.parametrize("weights", ["distance", "uniform"])
def test_neighbours_and_vote_shares_are_scikit_learns_bit_for_bit_on_real_tiles(
    floor_tiles, weights
):
    features, labels, region, queries = floor_tiles
    model = _fitted(features, labels, region, ClassifierConfig(weights=weights))
    knn = model.pipeline["knn"]
    standard = model.pipeline["scaler"].transform(queries)
    with threadpool_limits(limits=1):  # as a run queries: scikit-learn's OpenMP on one thread
        np.testing.assert_array_equal(model._transformed(queries), standard)
        for batch in BATCHES:
            for start in range(0, 2 * SMALL_QUERY, batch):
                rows = standard[start : start + batch]
                distance, index = model._neighbours(rows)
                expected_distance, expected_index = knn.kneighbors(rows)
                np.testing.assert_array_equal(index, expected_index)
                np.testing.assert_array_equal(distance, expected_distance)
                np.testing.assert_array_equal(
                    model.predict_proba(queries[start : start + batch]),
                    model.pipeline.predict_proba(queries[start : start + batch]),
                )


def test_vote_of_a_region_is_predict_with_confidence_of_it(floor_tiles):
    features, labels, region, queries = floor_tiles
    model = _fitted(features, labels, region, ClassifierConfig())
    model.calibrate_novelty()
    far = queries[:16] * 3.0  # mostly unknown ground: some tiles vote for nothing
    outcomes = set()
    for tiles in [*np.split(queries, len(queries) // 16), far, queries[:1], queries[5:8]]:
        labels_, confidence = model.predict_with_confidence(tiles, np.zeros(len(tiles), int))
        label, share = model.vote(tiles)
        assert (label, share) == (labels_[0], confidence[0])
        outcomes.add(share == 1.0)
    assert outcomes == {True, False}  # unanimous regions and split ones were both compared


def test_ties_go_to_the_lower_training_index_and_bad_queries_are_refused():
    samples = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [-1.0, 0.0]])
    index = NeighbourIndex(samples, k=2)
    distance, nearest = index.kneighbors(np.array([[0.0, 0.0], [1.0, 0.0]]))
    assert nearest.tolist() == [[0, 1], [1, 3]]  # 1, 2, 3, 4 tie at 1 from the origin
    np.testing.assert_array_equal(distance, [[0.0, 1.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match="NaN or infinity"):
        index.kneighbors(np.array([[np.nan, 0.0]]))
    with pytest.raises(ValueError, match="the model has 2 columns"):
        index.kneighbors(np.zeros((1, 3)))
    with pytest.raises(ConfigError, match="k: 6 neighbours but 5 training samples"):
        NeighbourIndex(samples, k=6)
    model = TerrainClassifier(ClassifierConfig(k=1)).fit(samples, np.array(list("abcab")))
    with pytest.raises(ValueError, match="one row of features per tile"):
        model.vote(np.empty((0, 2)))
    with pytest.raises(ValueError, match="3 columns, the model 2"):
        model.vote(np.zeros((1, 3)))
