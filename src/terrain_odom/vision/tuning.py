"""Choosing the classifier's settings by cross-validation (scikit-learn model selection).

The best settings of :class:`~terrain_odom.config.classifier.ClassifierConfig`
depend on the ground and the image size, so ``train --tune`` lets
scikit-learn's ``GridSearchCV`` choose them by stratified cross-validation
over images, and ``report accuracy --tune`` scores that choice honestly by
nested cross-validation (``cross_validate`` of the search: each outer
training fold is searched on its own, the outer test fold scores the setting
chosen without it).

The estimator of the search, :class:`ImageKNN`, has every field of the
configuration as a scikit-learn parameter and takes *image indices* as its
``X`` (one column): its features come from a :class:`FeatureCache` that holds
the features of every image once per feature setting
(:meth:`~terrain_odom.config.classifier.ClassifierConfig.feature_key`), so
candidates that only change the KNN (``scale``, ``k``, ``weights``) and every
fold reuse the same features. Features are per image and unsupervised, so
computing them once for all images leaks nothing between folds; the scaler
and the neighbours are fitted on each training fold only.

The candidates are scored by balanced accuracy (the mean of the per-class
accuracies, the "mean accuracy" of the reports). The search runs its fits
through joblib (``n_jobs``), so a joblib backend (e.g. dask's) can take it
over. Folds are shuffled with a fixed seed: the same data give the same choice.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.model_selection import GridSearchCV, ParameterGrid, cross_validate

from terrain_odom.config.classifier import MIN_TILE_SIZE, ClassifierConfig
from terrain_odom.config.fields import build_section
from terrain_odom.errors import ConfigError
from terrain_odom.vision.classifier import TerrainClassifier
from terrain_odom.vision.cross_validation import stratified_folds
from terrain_odom.vision.dataset import LabelledFeatures

__all__ = [
    "DEFAULT_FEATURES",
    "TILE_FRACTIONS",
    "default_grid",
    "SCORING",
    "Grid",
    "check_grid",
    "grid_configs",
    "FeatureCache",
    "ImageKNN",
    "image_index",
    "Search",
    "NestedFold",
    "search_settings",
    "nested_search",
]

Grid = list[dict[str, list[Any]]]
"""A scikit-learn ``param_grid``: sub-grids, each a field name -> the values to try."""

DEFAULT_FEATURES = ("sfta+lab", "sfta+lbp+lab")
"""Feature families the default grid tries (docs/results/classification.md says why)."""

TILE_FRACTIONS = (4, 2)
"""The default grid's ``min_tile_size``: the images' shorter side over these (1/4 and 1/2)."""


def default_grid(short_side: float | None) -> dict[str, list[Any]]:
    """Return the grid ``--tune`` searches without ``--grid``, built around the images' size.

    ``features`` :data:`DEFAULT_FEATURES` x ``min_tile_size`` the shorter side
    over each of :data:`TILE_FRACTIONS` (at least
    :data:`~terrain_odom.config.classifier.MIN_TILE_SIZE`; with ``tiles: 4``:
    4x4 and 2x2 tiles of a training image) x ``k`` 5 / 9: 8 candidates of 4
    feature settings. Without a size (``None``), ``min_tile_size`` is left out.

    Parameters
    ----------
    short_side : float or None
        The training images' median shorter side, px.

    Examples
    --------
    >>> default_grid(64)["min_tile_size"], default_grid(320)["min_tile_size"]
    ([16, 32], [80, 160])
    """
    grid: dict[str, list[Any]] = {"features": list(DEFAULT_FEATURES), "k": [5, 9]}
    if short_side is not None:
        sizes = [max(MIN_TILE_SIZE, int(short_side // f)) for f in TILE_FRACTIONS]
        grid["min_tile_size"] = list(dict.fromkeys(sizes))
    return grid


SCORING = "balanced_accuracy"
"""scikit-learn scorer of the candidates: the mean of the per-class accuracies."""

_DEFAULTS = ClassifierConfig()
_FIELDS = tuple(field.name for field in dataclasses.fields(ClassifierConfig))


def check_grid(
    grid: Mapping[str, Any] | Sequence[Mapping[str, Any]], base: ClassifierConfig
) -> Grid:
    """Validate a grid of classifier settings.

    Parameters
    ----------
    grid : mapping or sequence of mappings
        Field of :class:`ClassifierConfig` -> non-empty list of values; a
        list of such mappings searches each sub-grid (scikit-learn's
        ``param_grid``).
    base : ClassifierConfig
        Values of the fields a sub-grid leaves out.

    Returns
    -------
    Grid
        The grid as a list of sub-grids of lists.

    Raises
    ------
    ConfigError
        Not a mapping (or list of them), an unknown field, an empty or
        non-list value, or a value the field does not take (naming it).
    """
    subgrids = [grid] if isinstance(grid, Mapping) else grid
    if (
        not isinstance(subgrids, (list, tuple))
        or not subgrids
        or not all(isinstance(sub, Mapping) and sub for sub in subgrids)
    ):
        raise ConfigError("grid: expected a mapping of field -> list of values (or a list of them)")
    out: Grid = []
    for sub in subgrids:
        for name, values in sub.items():
            if name not in _FIELDS:
                raise ConfigError(f"grid: unknown field {name!r}; fields: {', '.join(_FIELDS)}")
            if not isinstance(values, (list, tuple)) or not values:
                raise ConfigError(f"grid.{name}: expected a non-empty list of values")
        out.append({name: list(values) for name, values in sub.items()})
    grid_configs(out, base)  # every candidate must be a valid configuration
    return out


def grid_configs(grid: Grid, base: ClassifierConfig) -> list[ClassifierConfig]:
    """Return the configuration of every candidate of a grid, in the search's order.

    Raises
    ------
    ConfigError
        A candidate's values are not a valid configuration.
    """
    return [build_section(base, params, "grid") for params in ParameterGrid(grid)]


def _cache_key(config: ClassifierConfig) -> tuple[tuple[str, Any], ...]:
    """Return the feature settings of ``config`` that change features (tiles unused with a tile size)."""
    key = config.feature_key()
    if config.tile_size is not None:
        del key["tiles"], key["min_tile_size"]
    return tuple(key.items())


class FeatureCache:
    """Features of one image set, computed once per feature setting and kept.

    Parameters
    ----------
    extract : callable
        ``extract(configs)`` returns the :class:`LabelledFeatures` of every
        image of the set for each configuration (e.g.
        :func:`~terrain_odom.vision.dataset.extract_feature_sets` bound to
        the images); called only with settings not yet cached, each once.

    Notes
    -----
    scikit-learn clones estimators (deep copies their parameters) for every
    fit; a copy of the cache is the cache itself, so that every clone shares
    the features. A cache sent to a worker process (pickled) takes its
    features without ``extract``: call :meth:`prepare` with every setting of
    a search before it runs in workers.
    """

    def __init__(self, extract: Callable[[list[ClassifierConfig]], Sequence[LabelledFeatures]]):
        self._extract: Callable[[list[ClassifierConfig]], Sequence[LabelledFeatures]] | None
        self._extract = extract
        self._sets: dict[tuple[tuple[str, Any], ...], LabelledFeatures] = {}

    def __deepcopy__(self, memo: dict[int, Any]) -> FeatureCache:
        """Return ``self``: clones of an estimator share its cache."""
        return self

    def __getstate__(self) -> dict[str, Any]:
        """Return the state sent to a worker process: the features only."""
        return {"_extract": None, "_sets": self._sets}

    def __len__(self) -> int:
        """Return the number of feature settings held."""
        return len(self._sets)

    def prepare(self, configs: Sequence[ClassifierConfig]) -> None:
        """Compute, in one call of ``extract``, the features of the settings not yet held."""
        todo: dict[tuple[tuple[str, Any], ...], ClassifierConfig] = {}
        for config in configs:
            if _cache_key(config) not in self._sets:
                todo.setdefault(_cache_key(config), config)
        if not todo:
            return
        if self._extract is None:
            raise ValueError("feature settings not prepared before the search went to workers")
        for key, data in zip(todo, self._extract(list(todo.values())), strict=True):
            if self._sets and data.paths != next(iter(self._sets.values())).paths:
                raise ValueError("the extraction returned another image set")
            self._sets[key] = data

    def features(self, config: ClassifierConfig) -> LabelledFeatures:
        """Return the features of every image for ``config``'s feature settings."""
        self.prepare([config])
        return self._sets[_cache_key(config)]


def image_index(n_images: int) -> NDArray[np.intp]:
    """Return the ``X`` of :class:`ImageKNN` for ``n_images`` images: indices, one column."""
    return np.arange(n_images, dtype=np.intp)[:, None]


class ImageKNN(ClassifierMixin, BaseEstimator):
    """:class:`TerrainClassifier` of cached images, its settings as scikit-learn parameters.

    ``X`` holds image indices (:func:`image_index`) into ``cache``; ``y`` their
    labels. The other parameters are the fields of :class:`ClassifierConfig`
    (same defaults).

    Parameters
    ----------
    cache : FeatureCache
    features, n_t, relative_counts, pyramid_levels, scale, k, weights, tiles, min_tile_size, tile_size
        As :class:`ClassifierConfig`.
    """

    def __init__(
        self,
        cache: FeatureCache | None = None,
        features: str = _DEFAULTS.features,
        n_t: int = _DEFAULTS.n_t,
        relative_counts: bool = _DEFAULTS.relative_counts,
        pyramid_levels: int = _DEFAULTS.pyramid_levels,
        scale: bool = _DEFAULTS.scale,
        k: int = _DEFAULTS.k,
        weights: str = _DEFAULTS.weights,
        tiles: int = _DEFAULTS.tiles,
        min_tile_size: int | str = _DEFAULTS.min_tile_size,
        tile_size: int | None = _DEFAULTS.tile_size,
    ) -> None:
        self.cache = cache
        self.features = features
        self.n_t = n_t
        self.relative_counts = relative_counts
        self.pyramid_levels = pyramid_levels
        self.scale = scale
        self.k = k
        self.weights = weights
        self.tiles = tiles
        self.min_tile_size = min_tile_size
        self.tile_size = tile_size

    @classmethod
    def of(cls, cache: FeatureCache, config: ClassifierConfig) -> ImageKNN:
        """Return the estimator of a configuration."""
        return cls(cache, **dataclasses.asdict(config))

    def config(self) -> ClassifierConfig:
        """Return the parameters as a :class:`ClassifierConfig` (validated)."""
        result: ClassifierConfig = build_section(
            _DEFAULTS, {name: getattr(self, name) for name in _FIELDS}
        )
        return result

    def _data(self, X: NDArray) -> LabelledFeatures:
        if self.cache is None:
            raise ValueError("ImageKNN needs a FeatureCache")
        return self.cache.features(self.config()).select(np.asarray(X, dtype=np.intp)[:, 0])

    def fit(self, X: NDArray, y: NDArray) -> ImageKNN:
        """Fit on the images ``X[:, 0]`` of the cache, labelled ``y``."""
        data = self._data(X)
        self.classifier_ = TerrainClassifier(self.config()).fit(data.features, y, data.region)
        self.classes_ = np.asarray(self.classifier_.classes)
        return self

    def predict(self, X: NDArray) -> NDArray:
        """Label of each image ``X[:, 0]`` of the cache (its tiles' vote)."""
        data = self._data(X)
        return self.classifier_.predict(data.features, data.region)


@dataclass(frozen=True)
class Search:
    """Scores of the candidates of a grid search and its choice.

    Attributes
    ----------
    grid : Grid
    folds : int
        Stratified cross-validation folds the candidates were scored on.
    candidates : tuple of dict
        The grid's values of each candidate (scikit-learn's order).
    mean_score, std_score : ndarray of float, shape (n_candidates,)
        Balanced accuracy (:data:`SCORING`) over the folds, fraction.
    best : int
        Index of the chosen candidate (the best mean score; the first of ties).
    """

    grid: Grid
    folds: int
    candidates: tuple[dict[str, Any], ...]
    mean_score: NDArray[np.float64]
    std_score: NDArray[np.float64]
    best: int

    @classmethod
    def of(cls, search: GridSearchCV) -> Search:
        """Summarise a fitted ``GridSearchCV``."""
        results = search.cv_results_
        return cls(
            grid=search.param_grid,
            folds=search.n_splits_,
            candidates=tuple(results["params"]),
            mean_score=np.asarray(results["mean_test_score"], dtype=np.float64),
            std_score=np.asarray(results["std_test_score"], dtype=np.float64),
            best=int(search.best_index_),
        )

    @property
    def choice(self) -> dict[str, Any]:
        """The grid's values of the chosen candidate."""
        return self.candidates[self.best]

    def to_dict(self) -> dict[str, Any]:
        """Plain data for reports and model files (scores in %)."""
        return {
            "grid": self.grid,
            "scoring": SCORING,
            "folds": self.folds,
            "candidates": [
                {"params": params, "mean_percent": 100.0 * mean, "std_percent": 100.0 * std}
                for params, mean, std in zip(
                    self.candidates, self.mean_score.tolist(), self.std_score.tolist(), strict=True
                )
            ],
            "choice": self.choice,
        }


def _grid_search(
    cache: FeatureCache, base: ClassifierConfig, grid: Grid, folds: int, seed: int, jobs: int
) -> GridSearchCV:
    """Return the unfitted ``GridSearchCV`` of ``grid`` around ``base`` (errors raise, no NaN)."""
    return GridSearchCV(
        ImageKNN.of(cache, base),
        grid,
        scoring=SCORING,
        cv=stratified_folds(folds, seed),
        n_jobs=jobs,
        error_score="raise",
    )


def search_settings(
    cache: FeatureCache,
    base: ClassifierConfig,
    grid: Grid,
    labels: NDArray,
    *,
    folds: int,
    seed: int,
    jobs: int = 1,
) -> tuple[Search, ClassifierConfig]:
    """Choose the settings of ``grid`` by stratified cross-validation on all images.

    Parameters
    ----------
    cache : FeatureCache
        Features of the images ``labels`` belongs to (prepared with every
        setting of the grid when ``jobs > 1``).
    base : ClassifierConfig
        Values of the fields the grid leaves out.
    grid : Grid
        From :func:`check_grid`.
    labels : ndarray of str, shape (n_images,)
    folds, seed : int
        :func:`~terrain_odom.vision.cross_validation.stratified_folds` ``(folds, seed)``.
    jobs : int
        joblib workers of the search.

    Returns
    -------
    search : Search
    chosen : ClassifierConfig
        ``base`` with the chosen candidate's values.
    """
    search = _grid_search(cache, base, grid, folds, seed, jobs)
    search.fit(image_index(labels.size), labels)
    summary = Search.of(search)
    return summary, build_section(base, summary.choice, "grid")


@dataclass(frozen=True)
class NestedFold:
    """One outer fold of a nested cross-validation.

    Attributes
    ----------
    test : ndarray of intp
        The outer test images (indices into the labels).
    truth, predicted : ndarray of str
        Their labels, and those predicted by the setting chosen on the other
        images.
    search : Search
        The search on the other images (its choice, refitted on all of them).
    """

    test: NDArray[np.intp]
    truth: NDArray[np.str_]
    predicted: NDArray[np.str_]
    search: Search

    @property
    def accuracy(self) -> float:
        """Share of the fold's images classified correctly, %."""
        return 100.0 * float(np.mean(self.truth == self.predicted))


def nested_search(
    cache: FeatureCache,
    base: ClassifierConfig,
    grid: Grid,
    labels: NDArray,
    *,
    folds: int,
    inner_folds: int,
    seed: int,
    jobs: int = 1,
) -> list[NestedFold]:
    """Nested stratified cross-validation of the search: never scores a setting on its tuning images.

    ``cross_validate`` runs :func:`search_settings`'s ``GridSearchCV`` (with
    ``inner_folds`` folds) on each outer training fold and predicts the
    outer test fold with the refitted choice. Parameters as
    :func:`search_settings`; the outer folds are
    :func:`~terrain_odom.vision.cross_validation.stratified_folds` ``(folds, seed)``.
    """
    X = image_index(labels.size)
    result = cross_validate(
        _grid_search(cache, base, grid, inner_folds, seed, jobs),
        X,
        labels,
        scoring=SCORING,
        cv=stratified_folds(folds, seed),
        return_estimator=True,
        return_indices=True,
        error_score="raise",
    )
    return [
        NestedFold(
            np.asarray(test, dtype=np.intp),
            labels[test],
            search.predict(X[test]),
            Search.of(search),
        )
        for search, test in zip(result["estimator"], result["indices"]["test"], strict=True)
    ]
