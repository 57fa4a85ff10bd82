"""Tuned classifier settings: what ``train --tune`` and ``report accuracy --tune`` add.

:func:`tune_settings` chooses the settings of a grid by stratified
cross-validation (:func:`~terrain_odom.vision.tuning.search_settings`);
:func:`nested_tuning` scores that choice by nested cross-validation
(:func:`~terrain_odom.vision.tuning.nested_search`) on the outer folds the
untuned report uses. The grid is :func:`~terrain_odom.vision.tuning.default_grid` (built
around the images' size) or a YAML file (:func:`load_grid`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.config.loader import read_yaml
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.images import read_image_rgb
from terrain_odom.vision.cross_validation import CV_SEED, CrossValidation, check_folds
from terrain_odom.vision.dataset import LabelledImages, extract_feature_sets
from terrain_odom.vision.tuning import (
    FeatureCache,
    Grid,
    NestedFold,
    Search,
    check_grid,
    default_grid,
    grid_configs,
    nested_search,
    search_settings,
)

__all__ = [
    "INNER_FOLDS",
    "load_grid",
    "feature_cache",
    "Tuning",
    "NestedTuning",
    "tune_settings",
    "nested_tuning",
]

INNER_FOLDS = 3
"""Folds of the search inside each outer training fold of :func:`nested_tuning`."""


def load_grid(
    path: str | Path | None, base: ClassifierConfig, short_side: float | None = None
) -> Grid:
    """Return the grid of a YAML file, or the default grid without one.

    The default grid (:func:`~terrain_odom.vision.tuning.default_grid`) is
    built around ``short_side``, the training images' median shorter side, px.

    The file holds a mapping of :class:`ClassifierConfig` fields to lists of
    values (every combination is a candidate), or a list of such mappings
    (sub-grids searched one after the other), e.g.::

        k: [1, 5, 15]
        tile_size: [null, 32]

    Raises
    ------
    ConfigError
        Naming the file and the first invalid field or value.
    """
    if path is None:
        return check_grid(default_grid(short_side), base)
    path = Path(path)
    data = read_yaml(path, kind="grid file")
    try:
        return check_grid(data or {}, base)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def feature_cache(images: LabelledImages, jobs: int | None, progress: bool | None) -> FeatureCache:
    """Return the feature cache of a labelled folder (images read and described in ``jobs`` processes)."""
    return FeatureCache(
        partial(extract_feature_sets, images, read=read_image_rgb, jobs=jobs, progress=progress)
    )


def _search_jobs(jobs: int | None) -> int:
    """Joblib workers of a search: ``jobs``, or all cores (-1)."""
    return -1 if jobs is None else jobs


@dataclass(frozen=True)
class Tuning:
    """The settings ``train --tune`` chose.

    Attributes
    ----------
    search : Search
        Grid, scores of every candidate and the choice.
    chosen : ClassifierConfig
        The base configuration with the chosen values.
    """

    search: Search
    chosen: ClassifierConfig

    def to_dict(self) -> dict[str, Any]:
        """Plain data (the ``tuning`` metadata of the model file)."""
        return {
            **self.search.to_dict(),
            "seed": CV_SEED,
            "chosen_config": dataclasses.asdict(self.chosen),
        }


def tune_settings(
    cache: FeatureCache,
    base: ClassifierConfig,
    grid: Grid,
    *,
    folds: int,
    jobs: int | None = None,
) -> Tuning:
    """Choose the settings of ``grid`` on all the cached images.

    Parameters
    ----------
    cache : FeatureCache
        Of the training images; the features of every candidate are
        computed first, once each.
    base : ClassifierConfig
        Values of the fields the grid leaves out.
    grid : Grid
    folds : int
        Stratified folds (seed :data:`~terrain_odom.vision.cross_validation.CV_SEED`),
        reduced to the smallest class's image count.
    jobs : int, optional
        joblib workers (default: all cores).

    Raises
    ------
    InputFileError
        A class has fewer than 2 images.
    ConfigError
        A candidate's ``k`` is larger than a training fold's tiles.
    """
    cache.prepare(grid_configs(grid, base))
    data = cache.features(base)
    folds = min(folds, *data.counts().values())
    check_folds(data.counts(), folds, "tune")
    search, chosen = search_settings(
        cache, base, grid, data.labels, folds=folds, seed=CV_SEED, jobs=_search_jobs(jobs)
    )
    return Tuning(search, chosen)


@dataclass(frozen=True)
class NestedTuning:
    """Nested cross-validation of the tuned classifier.

    Attributes
    ----------
    base : ClassifierConfig
    grid : Grid
    inner_folds : int
    cross_validation : CrossValidation
        Confusion of the outer test folds, each predicted with the setting
        chosen on the other folds (its ``config`` is ``base``).
    folds : tuple of NestedFold
        Each outer fold: its test images, their predictions, the inner search.
    """

    base: ClassifierConfig
    grid: Grid
    inner_folds: int
    cross_validation: CrossValidation
    folds: tuple[NestedFold, ...]

    def to_dict(self) -> dict[str, Any]:
        """Plain data for the JSON report: pooled confusion and each fold's choice."""
        pooled = self.cross_validation.to_dict()
        del pooled["config"]
        return {
            "base_config": dataclasses.asdict(self.base),
            "grid": self.grid,
            "inner_folds": self.inner_folds,
            **pooled,
            "folds": [
                {
                    "test_images": int(fold.test.size),
                    "accuracy_percent": fold.accuracy,
                    "choice": fold.search.choice,
                    "inner_mean_percent": 100.0 * float(fold.search.mean_score[fold.search.best]),
                    "search": fold.search.to_dict(),
                }
                for fold in self.folds
            ],
        }


def nested_tuning(
    cache: FeatureCache,
    base: ClassifierConfig,
    grid: Grid,
    *,
    folds: int,
    inner_folds: int = INNER_FOLDS,
    jobs: int | None = None,
) -> NestedTuning:
    """Score the tuned classifier by nested stratified cross-validation.

    The outer folds are those of :func:`~terrain_odom.vision.cross_validation.cross_validate_images`
    (seed :data:`~terrain_odom.vision.cross_validation.CV_SEED`); each outer training fold
    is searched with ``inner_folds`` folds, and its test fold is classified
    with that choice only. Parameters as :func:`tune_settings`.

    Raises
    ------
    InputFileError
        A class has too few images for ``folds`` outer and ``inner_folds``
        inner folds.
    """
    cache.prepare(grid_configs(grid, base))
    data = cache.features(base)
    check_folds(data.counts(), folds, "cross-validate")
    name, count = min(data.counts().items(), key=lambda item: item[1])
    if count - -(-count // folds) < inner_folds:  # the fewest a class has in an outer training fold
        raise InputFileError(
            f"cannot nest {inner_folds}-fold searches in {folds} folds: class '{name}' has "
            f"{count} usable image(s), fewer than {inner_folds} in some outer training fold"
        )
    nested = nested_search(
        cache,
        base,
        grid,
        data.labels,
        folds=folds,
        inner_folds=inner_folds,
        seed=CV_SEED,
        jobs=_search_jobs(jobs),
    )
    index = {name: i for i, name in enumerate(data.classes)}
    confusion = np.zeros((len(index), len(index)), dtype=np.int64)
    for fold in nested:
        np.add.at(
            confusion, ([index[t] for t in fold.truth], [index[p] for p in fold.predicted]), 1
        )
    cv = CrossValidation(base, data.classes, folds, confusion)
    return NestedTuning(base, grid, inner_folds, cv, tuple(nested))
