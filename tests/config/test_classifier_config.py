"""Tests of the classifier settings (:mod:`terrain_odom.config.classifier`).

They are the ``classifier`` section of the configuration, read by
:func:`~terrain_odom.config.loader.load_classifier_config`, which also reads
the old flat classifier files.
"""

from __future__ import annotations

import pytest

from terrain_odom import config
from terrain_odom.config import load_classifier_config, load_config
from terrain_odom.config.classifier import (
    FEATURE_FIELDS,
    PAPER_K,
    ClassifierConfig,
    is_flat_classifier,
    paper_config,
)
from terrain_odom.errors import ConfigError


def test_classifier_section_and_overrides(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("robot: {track_width: 0.7}\nclassifier: {k: 7, weights: uniform}\n")
    flat = []
    cfg = load_classifier_config(path, {"tiles": 2, "min_tile_size": 24}, on_flat=flat.append)
    assert (cfg.k, cfg.weights, cfg.tiles, cfg.min_tile_size) == (7, "uniform", 2, 24)
    assert flat == []  # the new layout: no deprecation
    assert load_config(path).classifier == ClassifierConfig(k=7, weights="uniform")


def test_flat_classifier_file_is_still_read_and_reported(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("k: 7\nweights: uniform\n")
    flat = []
    cfg = load_classifier_config(path, {"tiles": 2}, on_flat=flat.append)
    assert (cfg.k, cfg.weights, cfg.tiles) == (7, "uniform", 2)
    assert flat == [path]
    path.write_text("k: 0\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: k: must be a whole number >= 1"):
        load_classifier_config(path)


def test_classifier_section_is_validated_like_the_others(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("classifier: {k: 3, kk: 7}\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: classifier: unknown key\(s\) \['kk'\]"):
        load_classifier_config(path)
    with pytest.raises(ConfigError, match=r"c\.yaml: classifier: unknown key"):
        load_config(path)
    path.write_text("classifier: {tile_size: 4}\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: classifier\.tile_size: must be >= 8"):
        load_config(path)
    path.write_text("k: 3\nrobot: {track_width: 0.7}\n")  # mixed layouts: not a flat file
    with pytest.raises(ConfigError, match=r"c\.yaml: top level: unknown key\(s\) \['k'\]"):
        load_classifier_config(path)


def test_is_flat_classifier():
    assert is_flat_classifier({"k": 3, "tile_size": None})
    assert not is_flat_classifier({})
    assert not is_flat_classifier(None)
    assert not is_flat_classifier(["k"])
    assert not is_flat_classifier({"classifier": {"k": 3}})
    assert not is_flat_classifier({"k": 3, "robot": {}})


def test_bad_classifier_settings_are_config_errors(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("kk: 7\n")
    with pytest.raises(ConfigError, match=r"c\.yaml: .*unknown key"):
        load_classifier_config(path)
    with pytest.raises(ConfigError, match="min_tile_size: must be a whole number >= 1"):
        load_classifier_config(None, {"min_tile_size": 0})
    with pytest.raises(ConfigError, match="features: 'rgb' is not texture families"):
        load_classifier_config(None, {"features": "rgb"})
    with pytest.raises(ConfigError, match="not found"):
        load_classifier_config(tmp_path / "missing.yaml")


def test_tile_size_has_a_lower_bound():
    with pytest.raises(ConfigError, match="tile_size: must be >= 8"):
        load_classifier_config(None, {"tile_size": 4})
    assert load_classifier_config(None, {"tile_size": 8}).tile_size == 8


def test_paper_config_is_chen_recipe_and_config_reexports_it():
    cfg = paper_config(n_t=3)
    assert (cfg.features, cfg.n_t, cfg.relative_counts, cfg.scale) == ("sfta", 3, False, False)
    assert (cfg.k, cfg.weights, cfg.tiles) == (PAPER_K, "uniform", 1)
    assert config.ClassifierConfig is ClassifierConfig
    assert set(ClassifierConfig().feature_key()) == set(FEATURE_FIELDS)


def test_invalid_yaml_names_the_file(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("k: [1,\n")
    with pytest.raises(ConfigError, match=r"c\.yaml.*not valid YAML"):
        load_classifier_config(path)


def test_a_missing_file_is_named_once(tmp_path):
    path = tmp_path / "missing.yaml"
    with pytest.raises(ConfigError) as info:
        load_classifier_config(path)
    assert str(info.value) == f"{path}: config file not found"
