"""Tests of the classifier settings (:mod:`terrain_odom.config.classifier`)."""

from __future__ import annotations

import pytest

from terrain_odom import config
from terrain_odom.config.classifier import (
    FEATURE_FIELDS,
    PAPER_K,
    ClassifierConfig,
    load_classifier_config,
    paper_config,
)
from terrain_odom.errors import ConfigError


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
