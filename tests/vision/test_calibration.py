"""Confidence: neighbour votes as scikit-learn's, unknown ground, reliability and the threshold."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.vision.calibration import choose_threshold, reliability
from terrain_odom.vision.classifier import TerrainClassifier
from terrain_odom.vision.frame_classifier import FrameClassification


@pytest.mark.parametrize("weights", ["uniform", "distance"])
@pytest.mark.parametrize("scale", [True, False])
def test_vote_shares_are_scikit_learns_predict_proba(weights, scale):
    rng = np.random.default_rng(1)
    features = rng.normal(size=(60, 4))
    features[7] = features[3]  # a duplicate: distance 0 to a query equal to it
    model = TerrainClassifier(ClassifierConfig(k=5, weights=weights, scale=scale))
    model.fit(features, np.array(list("abc") * 20))
    queries = np.vstack([rng.normal(size=(25, 4)), features[3:4]])
    np.testing.assert_allclose(
        model.predict_proba(queries), model.pipeline.predict_proba(queries), atol=1e-12
    )


def test_unknown_ground_votes_for_nothing_and_known_ground_still_votes():
    rng = np.random.default_rng(2)
    centres = {"a": (0.0, 0.0), "b": (6.0, 0.0)}
    features, labels, region = [], [], []
    for i in range(40):  # 40 images of 4 tiles around their class centre
        name = "ab"[i % 2]
        features.append(rng.normal(centres[name], 0.5, size=(4, 2)))
        labels.append(name)
        region += [i] * 4
    model = TerrainClassifier(ClassifierConfig(k=3))
    model.fit(np.vstack(features), np.array(labels), np.array(region))
    distance = model.calibrate_novelty()
    assert 0.0 < distance < 3.0
    known = rng.normal(centres["a"], 0.5, size=(200, 2))
    far = rng.normal((3.0, 12.0), 0.5, size=(200, 2))  # ground like neither class
    assert (model.predict_proba(known).max(axis=1) > 0).mean() > 0.95  # ~1 % rejected
    assert (model.predict_proba(far).sum(axis=1) == 0).all()
    labels_far, confidence = model.predict_with_confidence(far, np.repeat(np.arange(50), 4))
    assert (confidence == 0).all()  # a region of unknown ground: no tile voted
    _, confidence = model.predict_with_confidence(known, np.repeat(np.arange(50), 4))
    assert confidence.mean() > 0.9


def test_reliability_bins_confidence_against_accuracy():
    table = reliability([0.05, 0.55, 0.6, 0.95, 1.0], [False, True, False, True, True], 10)
    assert table.count.tolist() == [1, 0, 0, 0, 0, 2, 0, 0, 0, 2]
    assert table.accuracy[5] == 0.5 and table.accuracy[9] == 1.0 and np.isnan(table.accuracy[1])
    rows = table.to_dict()["bins"]
    assert [r["images"] for r in rows] == [1, 2, 2]  # empty bins left out
    with pytest.raises(ValueError, match="same length"):
        reliability([0.5], [True, False])


def test_threshold_is_the_lowest_confidence_reaching_the_target_accuracy():
    rng = np.random.default_rng(3)
    confidence = rng.uniform(size=2000)
    correct = rng.uniform(size=2000) < confidence  # right with probability = confidence
    threshold = choose_threshold(confidence, correct, target=0.9)
    kept = confidence >= threshold
    assert correct[kept].mean() >= 0.9
    # the next lower confidence would fall short: the threshold is the lowest that reaches it
    lower = confidence[confidence < threshold].max()
    assert correct[confidence >= lower].mean() < 0.9
    assert 0.75 < threshold < 0.85  # the mean of U(c, 1) is (1 + c) / 2 = 0.9 at c = 0.8
    assert (
        choose_threshold([0.3, 0.3], [True, False], target=0.9) == 0.3
    )  # none reach it: the surest


def test_a_frame_below_the_models_threshold_or_of_unknown_ground_is_no_sighting():
    assert FrameClassification(1.0, "grass", 0.7, min_confidence=0.6).sighting is not None
    assert FrameClassification(1.0, "grass", 0.5, min_confidence=0.6).sighting is None
    assert FrameClassification(1.0, "grass", 0.0).sighting is None
    assert FrameClassification(1.0, "", float("nan")).sighting is None


def test_a_sighting_needs_a_majority_of_the_regions_tiles_whatever_the_threshold():
    model = TerrainClassifier(ClassifierConfig(k=1)).fit(np.eye(4), list("aabb"))
    assert model.min_confidence == 0.0 and model.sighting_threshold == 0.5
    model.min_confidence = 0.8
    assert model.sighting_threshold == 0.8
