"""Hand-worked answers for the classifier's unknown-ground distance, one region's vote and its arrays.

One-dimensional features on the raw scale (``paper_config``), so every
distance and share is written out; no image is read.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from terrain_odom.config.classifier import ClassifierConfig, paper_config
from terrain_odom.errors import ConfigError
from terrain_odom.vision.classifier import (
    MAJORITY,
    NOVELTY_MARGIN,
    NOVELTY_QUANTILE,
    TerrainClassifier,
)
from terrain_odom.vision.neighbours import SMALL_QUERY

# Two training images of three tiles each, on a line: 0, 1, 3 and 10, 12, 13.
LINE = np.array([[0.0], [1.0], [3.0], [10.0], [12.0], [13.0]])
LINE_REGION = np.array([0, 0, 0, 1, 1, 1])
# Each tile's distance to the nearest tile of the other image: 10, 9, 7 and 7, 9, 10.
LINE_OTHER = np.array([10.0, 9.0, 7.0, 7.0, 9.0, 10.0])


def _line_model(**config) -> TerrainClassifier:
    cfg = dataclasses.replace(paper_config(), k=1, **config)
    return TerrainClassifier(cfg).fit(LINE, ["a", "b"], LINE_REGION)


def test_novelty_distance_is_twice_a_quantile_of_the_distances_to_other_images():
    model = _line_model()
    for quantile in (0.5, 0.3, NOVELTY_QUANTILE):
        expected = NOVELTY_MARGIN * np.quantile(LINE_OTHER, quantile)
        assert model.calibrate_novelty(quantile) == pytest.approx(expected, rel=1e-12)
        assert model.novelty_distance == pytest.approx(expected, rel=1e-12)
    assert NOVELTY_MARGIN == 2.0


def test_a_sample_of_the_tiles_is_seeded_and_seed_0_by_default():
    model = _line_model()
    sampled = [model.calibrate_novelty(0.0, max_queries=2, seed=s) for s in range(12)]
    # the least distance of any two tiles drawn without replacement: 7, 9 or 10
    assert set(sampled) <= {14.0, 18.0, 20.0} and len(set(sampled)) > 1
    assert model.calibrate_novelty(0.0, max_queries=2) == sampled[0]
    assert model.calibrate_novelty(0.0, max_queries=2) == sampled[0]  # reproducible
    # without replacement: 6 draws are all 6 tiles, whatever the seed
    assert model.calibrate_novelty(0.0, max_queries=6, seed=3) == 14.0


def test_at_most_4000_tiles_are_sampled_by_default():
    rng = np.random.default_rng(0)
    features = rng.normal(size=(4002, 1))
    region = np.repeat(np.arange(2001), 2)  # 2001 images of two tiles: a short neighbour search
    model = TerrainClassifier(dataclasses.replace(paper_config(), k=1))
    model.fit(features, np.where(np.arange(2001) % 2, "a", "b"), region)
    default = model.calibrate_novelty(0.5)
    assert default == model.calibrate_novelty(0.5, max_queries=4000, seed=0)
    assert default != model.calibrate_novelty(0.5, max_queries=4001, seed=0)


def test_calibration_needs_two_training_images_and_says_so():
    model = _line_model()
    model.calibrate_novelty()  # two images are enough
    one = TerrainClassifier(dataclasses.replace(paper_config(), k=1)).fit(LINE, ["a"], [0] * 6)
    with pytest.raises(
        ValueError, match=r"^calibrate_novelty needs a classifier fitted on >= 2 images$"
    ):
        one.calibrate_novelty()


# ---------------------------------------------------------------- one region's vote

# k = 3 on the line 0, 0.1 (a) and 1.0, 1.1, 1.2 (b)
VOTERS = np.array([[0.0], [0.1], [1.0], [1.1], [1.2]])


def _voters() -> TerrainClassifier:
    cfg = dataclasses.replace(paper_config(), k=3)
    return TerrainClassifier(cfg).fit(VOTERS, np.array(list("aabbb")))


def _both(model, tiles):
    """``vote`` and ``predict_with_confidence`` of the tiles as one region."""
    labels, confidence = model.predict_with_confidence(tiles, np.zeros(len(tiles), int))
    return model.vote(tiles), (str(labels[0]), float(confidence[0]))


def test_a_vote_tie_goes_to_the_larger_summed_share():
    # tiles near a: shares a 2/3 twice; near b: b 3/3 twice -> 2 votes each, b weighs more
    vote, region = _both(_voters(), np.array([[0.0], [0.05], [1.1], [1.2]]))
    assert vote == region
    assert vote[0] == "b" and vote[1] == pytest.approx(0.5)


def test_the_majority_of_tiles_wins_over_a_larger_summed_share():
    # two tiles vote a by 2/3 (a 4/3, b 2/3), one votes b by 3/3: b's share 5/3 > a's 4/3
    tiles = np.array([[0.0], [0.05], [1.2]])
    vote, region = _both(_voters(), tiles)
    assert vote == region
    assert vote[0] == "a" and vote[1] == pytest.approx(2 / 3)


def test_one_tile_gets_its_neighbour_share_not_a_whole_vote():
    vote, region = _both(_voters(), np.array([[0.4]]))  # neighbours 0.1, 0.0 (a) and 1.0 (b)
    assert vote == region
    assert vote[0] == "a" and vote[1] == pytest.approx(2 / 3)


def test_tiles_of_unknown_ground_vote_for_nothing():
    model = _line_model()
    model.novelty_distance = 2.5
    # 0.5 (a) and 12.4 (b) are known; 6.0 and 20.0 are farther than 2.5 from every tile
    tiles = np.array([[0.5], [6.0], [20.0], [12.4]])
    vote, region = _both(model, tiles)
    assert vote == region
    assert vote[1] == pytest.approx(0.25)  # one tile of four for the label (a tie: a or b)
    unknown = np.array([[6.0], [20.0], [0.2]])
    assert model.vote(unknown) == ("a", pytest.approx(1 / 3))
    assert model.vote(unknown) == _both(model, unknown)[1]


# -------------------------------------------------------------------- its arrays


def test_an_unscaled_model_stores_empty_scaler_arrays():
    arrays, metadata = _line_model().to_arrays()
    assert arrays["scaler_mean"].shape == (0,) and arrays["scaler_scale"].shape == (0,)
    assert metadata["n_training_images"] == 2 and metadata["n_training_samples"] == 6
    with pytest.raises(ValueError, match=r"^fit the classifier before saving it$"):
        TerrainClassifier(paper_config()).to_arrays()


def test_the_rebuilt_scaler_is_the_one_fit_made():
    cfg = ClassifierConfig(k=1)  # standardised
    features = np.array([[0.0, 10.0], [1.0, 30.0], [3.0, 20.0], [10.0, 50.0]])
    fitted = TerrainClassifier(cfg).fit(features, ["a", "b"], [0, 0, 1, 1])
    arrays, _ = fitted.to_arrays()
    rebuilt = TerrainClassifier.from_arrays(cfg, arrays)
    a, b = fitted.pipeline["scaler"], rebuilt.pipeline["scaler"]
    np.testing.assert_allclose(b.var_, a.var_, rtol=1e-12)
    np.testing.assert_allclose(b.var_, features.var(axis=0), rtol=1e-12)
    assert b.n_samples_seen_ == a.n_samples_seen_ == 4
    assert b.n_features_in_ == a.n_features_in_ == 2


def test_a_model_rebuilt_without_a_threshold_has_none():
    arrays, _ = _line_model().to_arrays()
    rebuilt = TerrainClassifier.from_arrays(paper_config(), arrays)
    assert rebuilt.min_confidence == 0.0 and rebuilt.novelty_distance is None
    assert rebuilt.sighting_threshold == MAJORITY


def test_a_batch_larger_than_a_frame_gets_the_shares_of_its_rows_one_by_one():
    """Batches past SMALL_QUERY rows go to scikit-learn's search, with the same k."""
    for weights in ("uniform", "distance"):
        cfg = dataclasses.replace(paper_config(), k=3, weights=weights)
        model = TerrainClassifier(cfg).fit(VOTERS, np.array(list("aabbb")))
        queries = np.linspace(-0.5, 1.7, SMALL_QUERY + 9)[:, None]
        one_by_one = np.vstack([model.predict_proba(row[None]) for row in queries])
        np.testing.assert_allclose(model.predict_proba(queries), one_by_one, rtol=1e-12)


def test_k_beyond_the_training_tiles_names_both_counts():
    with pytest.raises(ConfigError, match=r"^k: 5 neighbours but only 3 training samples$"):
        TerrainClassifier(ClassifierConfig(k=5)).fit(np.zeros((3, 2)), list("abc"))


def test_an_unfitted_classifier_holds_no_training_data():
    model = TerrainClassifier(paper_config())
    assert model.training_features.shape == (0, 0) and model.training_labels.shape == (0,)
    assert model.n_training_images == 0 and model.novelty_distance is None


def test_a_region_index_of_the_wrong_length_names_the_rows():
    model = _line_model()
    message = "region must hold one integer per feature row (3), got int64 (2,)"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        model.predict(np.zeros((3, 1)), np.array([0, 1]))
