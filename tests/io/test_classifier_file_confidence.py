"""Model files carry the confidence threshold and unknown-ground distance; older files load without them."""

from __future__ import annotations

import json

import numpy as np
import pytest

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import InputFileError
from terrain_odom.io.classifier_file import load_classifier, save_classifier
from terrain_odom.vision.classifier import TerrainClassifier


def _rewritten(path, tmp_path, change):
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    meta = change(json.loads(str(arrays["metadata"])))
    arrays["metadata"] = np.array(json.dumps(meta))
    out = tmp_path / "changed.npz"
    np.savez(out, **arrays)
    return out


@pytest.fixture
def saved(tmp_path):
    rng = np.random.default_rng(0)
    model = TerrainClassifier(ClassifierConfig(k=3, min_tile_size=16))
    model.fit(rng.normal(size=(40, 5)), list("aaaaabbbbb"), np.repeat(np.arange(10), 4))
    model.calibrate_novelty()
    model.min_confidence = 0.7
    return model, save_classifier(model, tmp_path / "m.npz")


def test_threshold_and_distance_round_trip(saved):
    model, path = saved
    loaded = load_classifier(path)
    assert loaded.min_confidence == 0.7 and loaded.novelty_distance == model.novelty_distance
    assert loaded.config.min_tile_size == 16  # the resolved tile size, not auto


def test_a_model_saved_before_them_loads_as_before(saved, tmp_path):
    _, path = saved

    def older(meta):
        del meta["min_confidence"], meta["novelty_distance"]
        meta["config"]["features"] = "sfta+lab"  # the former default, and a numeric tile size
        return meta

    loaded = load_classifier(_rewritten(path, tmp_path, older))
    assert loaded.min_confidence == 0.0 and loaded.novelty_distance is None
    assert loaded.config.features == "sfta+lab"


@pytest.mark.parametrize(
    "bad",
    [
        {"min_confidence": "x"},
        {"min_confidence": 1.5},
        {"novelty_distance": -1.0},
        {"novelty_distance": True},
        {"min_confidence": None},
    ],
)
def test_invalid_values_are_one_line_errors_naming_the_file(saved, tmp_path, bad):
    _, path = saved
    changed = _rewritten(path, tmp_path, lambda meta: {**meta, **bad})
    with pytest.raises(InputFileError, match="invalid model metadata") as info:
        load_classifier(changed)
    assert str(changed) in str(info.value) and "\n" not in str(info.value)
