"""KNN terrain classifier with tile voting (Chen et al. 2023, §3.2.3).

Chen et al. classify a region by the majority vote of the ``k`` nearest
training samples to its feature vector (:mod:`terrain_odom.vision.features`)
in raw Euclidean distance (eq. 23-26). This module keeps that recipe
selectable (``scale=False``, ``weights="uniform"``, ``tiles=1``, see
:func:`~terrain_odom.config.classifier.paper_config`) and adds, each as an
option of :class:`~terrain_odom.config.classifier.ClassifierConfig`:

- **standardisation** (``scale``): the raw SFTA values differ by orders of
  magnitude (border pixel counts ~1e4, fractal dimensions ~1.5), so the raw
  distance of eq. 24 is dominated by the counts;
- **tile voting** (``tiles``, ``min_tile_size``, or ``tile_size``): each tile
  of a region (:func:`~terrain_odom.vision.features.tile_grid`) is
  classified, and the region gets the majority label with the vote share as
  its confidence. Fixed-size tiles describe every region at the scale of the
  training tiles, and make the time a region takes proportional to its area,
  which is what a region of interest saves (Chen's Table 2);
- **distance weighting** of the neighbours' votes (``weights``);
- **unknown ground** (:meth:`TerrainClassifier.calibrate_novelty`): a tile
  farther from every training tile than twice what nearly all training
  tiles are from their nearest tile of another training image votes for no class, so that
  ground unlike any training class gets a low confidence instead of the
  label of whichever class happens to be nearest;
- **a confidence threshold** (``min_confidence``, chosen by the caller from
  cross-validated reliability, :mod:`terrain_odom.vision.calibration`): a
  region classified with less confidence is no sighting for the terrain
  tracker (:class:`~terrain_odom.vision.frame_classifier.FrameClassification`).

Regions of different sizes have different numbers of tiles, so the features
of several regions are *flat*: one row per tile, ``(n_tiles, n_features)``,
and a ``region`` index ``(n_tiles,)`` giving the region (0, 1, ...) of each
row.

A KNN model *is* its training set: :meth:`TerrainClassifier.to_arrays` gives
the training features, labels, region index and scaler parameters as plain
arrays with their metadata, and :meth:`TerrainClassifier.from_arrays` rebuilds
the model from them (:mod:`terrain_odom.io.classifier_file` stores them in
one ``.npz`` file).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.neighbors import KNeighborsClassifier, NearestNeighbors
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError
from terrain_odom.vision.features import FEATURE_VERSION, image_features
from terrain_odom.vision.neighbours import SMALL_QUERY, NeighbourIndex

__all__ = [
    "MODEL_ARRAYS",
    "NOVELTY_QUANTILE",
    "NOVELTY_MARGIN",
    "MAJORITY",
    "make_pipeline",
    "check_regions",
    "TerrainClassifier",
]

MODEL_ARRAYS = ("features", "labels", "region", "scaler_mean", "scaler_scale")
"""Names of the arrays of :meth:`TerrainClassifier.to_arrays`."""

NOVELTY_QUANTILE = 0.99
"""Quantile of the training tiles' distances to their nearest other training image (see below)."""

MAJORITY = 0.5
"""Least confidence of a sighting whatever the threshold: the label's share of the region's tiles.

Tiles of unknown ground count against the label, so a region mostly of
unknown ground is no sighting even when its few known tiles agree.
"""

NOVELTY_MARGIN = 2.0
"""The unknown-ground distance as a multiple of that quantile.

The training tiles' distances underestimate a new image's: tiles of the
simulated 640x480 run (``bench/run.py``), of the trained classes, lie at up
to 1.3 times the 99 % quantile of the training patches' (median 0.93 times);
twice it keeps them all.
"""


def make_pipeline(config: ClassifierConfig) -> Pipeline:
    """Return the unfitted scikit-learn pipeline of a configuration.

    ``StandardScaler`` then ``KNeighborsClassifier(k, weights)`` with
    Euclidean distance; without the scaler when ``config.scale`` is False (the
    raw distance of eq. 24).
    """
    steps: list[tuple[str, Any]] = [("scaler", StandardScaler())] if config.scale else []
    steps.append(("knn", KNeighborsClassifier(n_neighbors=config.k, weights=config.weights)))
    return Pipeline(steps)


def check_regions(
    features: NDArray, region: NDArray | None = None, n_regions: int | None = None
) -> tuple[NDArray, NDArray, NDArray]:
    """Check flat tile features and their region index.

    Parameters
    ----------
    features : array_like, shape (n_tiles, n_features)
        One row per tile, e.g. :func:`image_features` of several regions
        concatenated.
    region : array_like of int, shape (n_tiles,), optional
        Region of each row, numbered ``0 .. n_regions - 1`` in any order;
        every region has at least one row. Default: each row is a region.
    n_regions : int, optional
        Number of regions (default: ``max(region) + 1``).

    Returns
    -------
    features : ndarray of float64, shape (n_tiles, n_features)
    region : ndarray of intp, shape (n_tiles,)
    tile_counts : ndarray of intp, shape (n_regions,)
        Rows of each region.

    Raises
    ------
    ValueError
        Shapes that do not match, or a region without rows.

    >>> check_regions([[0.0], [1.0], [2.0]], [1, 0, 1])[2].tolist()
    [1, 2]
    """
    features = np.asarray(features, dtype=np.float64)
    if features.ndim != 2:
        raise ValueError(f"features must have shape (n_tiles, n_features), got {features.shape}")
    if region is None:
        region = np.arange(features.shape[0])
    region = np.asarray(region)
    if region.shape != features.shape[:1] or (region.size and region.dtype.kind not in "iu"):
        raise ValueError(
            f"region must hold one integer per feature row ({features.shape[0]}), "
            f"got {region.dtype} {region.shape}"
        )
    region = region.astype(np.intp, copy=False)
    if n_regions is None:
        n_regions = int(region.max()) + 1 if region.size else 0
    if region.size and (region.min() < 0 or region.max() >= n_regions):
        raise ValueError(f"region numbers must be in 0 .. {n_regions - 1}")
    tile_counts = np.bincount(region, minlength=n_regions)
    if not np.all(tile_counts):
        empty = np.flatnonzero(tile_counts == 0)
        raise ValueError(f"region(s) {empty[:5].tolist()} have no feature rows")
    return features, region, tile_counts


class TerrainClassifier:
    """KNN terrain classifier with optional tile voting.

    Features come flat, one row per tile, with a ``region`` index telling
    which region (image) each row belongs to (see :func:`check_regions`);
    without it every row is a region of its own.

    Parameters
    ----------
    config : ClassifierConfig, optional
        Features and KNN settings (default: :class:`ClassifierConfig`).

    Examples
    --------
    >>> clf = TerrainClassifier(ClassifierConfig(k=1)).fit(
    ...     np.array([[0.0, 0.0], [1.0, 1.0]]), np.array(["grass", "gravel"]))
    >>> clf.predict(np.array([[0.1, 0.2]])).tolist()
    ['grass']
    >>> clf.predict(np.array([[0.1, 0.2], [0.9, 0.8], [0.7, 0.9]]), region=[0, 1, 1]).tolist()
    ['grass', 'gravel']
    """

    def __init__(self, config: ClassifierConfig | None = None) -> None:
        self.config = config if config is not None else ClassifierConfig()
        self.pipeline = make_pipeline(self.config)
        self.training_features = np.empty((0, 0))
        self.training_labels = np.empty(0, dtype=str)
        self.training_region = np.empty(0, dtype=np.intp)
        self.novelty_distance: float | None = None
        self.min_confidence = 0.0
        self._index: NeighbourIndex | None = None  # built at the first small query
        self._encoded_labels: NDArray[np.intp] | None = None
        self._n_classes = 0  # set with _encoded_labels

    def calibrate_novelty(
        self, quantile: float = NOVELTY_QUANTILE, *, max_queries: int = 4000, seed: int = 0
    ) -> float:
        """Set :attr:`novelty_distance` from the training tiles themselves.

        For each of up to ``max_queries`` training tiles (a seeded sample),
        the distance (standardised when ``config.scale``) to the nearest
        training tile of *another* training image; :data:`NOVELTY_MARGIN`
        times the ``quantile`` of these is the distance beyond which a tile
        counts as unknown ground (:meth:`predict_with_confidence`).

        Returns
        -------
        float
            The distance set.

        Raises
        ------
        ValueError
            Not fitted, or fewer than two training images.
        """
        if self.n_training_images < 2:
            raise ValueError("calibrate_novelty needs a classifier fitted on >= 2 images")
        samples = self._transformed(self.training_features)
        rng = np.random.default_rng(seed)
        n = samples.shape[0]
        queries = np.sort(rng.choice(n, size=min(n, max_queries), replace=False))
        same = int(np.bincount(self.training_region).max())  # tiles of one image
        neighbours = NearestNeighbors(n_neighbors=min(n, same + 1)).fit(samples)
        distance, index = neighbours.kneighbors(samples[queries])
        other = self.training_region[index] != self.training_region[queries, None]
        nearest = np.where(other, distance, np.inf).min(axis=1)
        finite = nearest[np.isfinite(nearest)]
        self.novelty_distance = NOVELTY_MARGIN * float(np.quantile(finite, quantile))
        return self.novelty_distance

    def _transformed(self, features: NDArray) -> NDArray:
        """Features as the neighbour search sees them (standardised when ``config.scale``).

        ``(x - mean) / scale`` with the fitted scaler's arrays: what its
        ``transform`` computes (subtract, then divide), without its checks.
        """
        features = np.asarray(features, dtype=np.float64)
        if not self.config.scale:
            return features
        scaler = self.pipeline["scaler"]
        if features.shape[-1:] != scaler.mean_.shape:
            raise ValueError(
                f"features have {features.shape[-1]} columns, the model {scaler.mean_.size}"
            )
        return (features - scaler.mean_) / scaler.scale_

    def _neighbours(self, queries: NDArray) -> tuple[NDArray, NDArray]:
        """Distances and indices of the ``k`` nearest training tiles of each query row.

        Up to :data:`SMALL_QUERY` rows by :class:`NeighbourIndex`, more by
        scikit-learn's ``kneighbors``: the same values either way.
        """
        if queries.shape[0] > SMALL_QUERY:
            return self.pipeline["knn"].kneighbors(queries)
        if self._index is None:
            self._index = NeighbourIndex(self._transformed(self.training_features), self.config.k)
        return self._index.kneighbors(np.ascontiguousarray(queries))

    @property
    def classes(self) -> list[str]:
        """Class names, sorted (the columns of :meth:`predict_proba`)."""
        return [str(c) for c in self.pipeline.classes_]

    @property
    def n_training_images(self) -> int:
        """Number of training regions (images); 0 before :meth:`fit`."""
        return int(self.training_region.max()) + 1 if self.training_region.size else 0

    def fit(
        self, features: NDArray, labels: NDArray, region: NDArray | None = None
    ) -> TerrainClassifier:
        """Fit on the tiles of labelled regions.

        Parameters
        ----------
        features : ndarray, shape (n_tiles, n_features)
            The :func:`image_features` rows of every training region.
        labels : array_like of str, shape (n_regions,)
            Terrain of each region; every tile of a region gets its label.
        region : array_like of int, shape (n_tiles,), optional
            Region of each row (:func:`check_regions`); default: each row is
            a region.

        Returns
        -------
        TerrainClassifier
            ``self``.

        Raises
        ------
        ConfigError
            ``k`` is larger than the number of training samples (tiles).
        ValueError
            ``features``, ``labels`` and ``region`` do not match.
        """
        labels = np.asarray(labels).astype(str)
        if labels.ndim != 1:
            raise ValueError(f"labels must have shape (n_regions,), got {labels.shape}")
        features, region, _ = check_regions(features, region, labels.size)
        if self.config.k > features.shape[0]:
            raise ConfigError(
                f"k: {self.config.k} neighbours but only {features.shape[0]} training samples"
            )
        self.training_features = features
        self.training_labels = labels[region]
        self.training_region = region
        self.pipeline.fit(self.training_features, self.training_labels)
        self.novelty_distance = None
        self._index = self._encoded_labels = None
        return self

    @property
    def sighting_threshold(self) -> float:
        """Least confidence of a sighting: :attr:`min_confidence`, and at least :data:`MAJORITY`."""
        return max(self.min_confidence, MAJORITY)

    @property
    def _encoded(self) -> NDArray[np.intp]:
        """Column of :attr:`classes` of each training tile (computed once per fit)."""
        if self._encoded_labels is None:
            classes = self.pipeline["knn"].classes_
            self._encoded_labels = np.searchsorted(classes, self.training_labels)
            self._n_classes = len(classes)
        return self._encoded_labels

    def predict_proba(self, features: NDArray) -> NDArray:
        """Neighbour vote shares of every tile.

        Parameters
        ----------
        features : ndarray, shape (n_samples, n_features)
            One row per tile (or region).

        Returns
        -------
        ndarray, shape (n_samples, n_classes)
            Share of the ``k`` neighbours' votes (weighted by inverse distance
            when ``weights == "distance"``) for each class of :attr:`classes`
            (scikit-learn's ``predict_proba``); all zero for a tile farther
            than :attr:`novelty_distance` from every training tile (unknown ground).
        """
        return self._votes(features)

    def _votes(self, features: NDArray) -> NDArray:
        """:meth:`predict_proba` from one neighbour search (the shares and the nearest distance)."""
        distance, index = self._neighbours(self._transformed(features))
        if self.config.weights == "uniform":
            weight = np.ones_like(distance)
        else:  # scikit-learn's rule: a neighbour at distance 0 takes the whole vote
            with np.errstate(divide="ignore"):
                weight = 1.0 / distance
            exact = ~np.isfinite(weight)
            weight = np.where(exact.any(axis=1, keepdims=True), exact.astype(float), weight)
        encoded = self._encoded
        n_rows, n_classes = distance.shape[0], self._n_classes
        cells = encoded[index] + n_classes * np.arange(n_rows)[:, None]
        summed = np.bincount(cells.ravel(), weight.ravel(), n_rows * n_classes)  # in order
        shares = np.asarray(summed, dtype=np.float64).reshape(n_rows, n_classes)  # (no copy)
        shares /= shares.sum(axis=1, keepdims=True)
        if self.novelty_distance is not None:
            shares[distance[:, 0] > self.novelty_distance] = 0.0
        return shares

    def predict_with_confidence(
        self, features: NDArray, region: NDArray | None = None
    ) -> tuple[NDArray, NDArray]:
        """Label and confidence of each region.

        Parameters
        ----------
        features : ndarray, shape (n_tiles, n_features)
        region : array_like of int, shape (n_tiles,), optional
            Region of each row (:func:`check_regions`); default: each row is
            a region.

        Returns
        -------
        labels : ndarray of str, shape (n_regions,)
            Of a one-tile region: the KNN label (eq. 26). Of a region of
            several tiles: the label most of its tiles get; a tie goes to the
            class with the larger summed neighbour vote share.
        confidence : ndarray of float, shape (n_regions,)
            Of a one-tile region: the neighbour vote share of the label. Of a
            region of several tiles: the share of its tiles that voted for
            the label. Tiles of unknown ground (:meth:`predict_proba`) vote
            for nothing, so a region of unknown ground has confidence 0.
        """
        features, region, tile_counts = check_regions(features, region)
        proba = self.predict_proba(features)
        shape = (tile_counts.size, proba.shape[1])
        votes, shares = np.zeros(shape), np.zeros(shape)
        np.add.at(votes, (region, proba.argmax(axis=1)), proba.max(axis=1) > 0)
        np.add.at(shares, region, proba)
        # The summed vote shares (< the region's tiles) only break ties between vote counts;
        # with one tile the label is the tile's.
        best = (votes + shares / (tile_counts[:, None] + 1)).argmax(axis=1)
        rows = np.arange(tile_counts.size)
        confidence = np.where(tile_counts == 1, shares[rows, best], votes[rows, best] / tile_counts)
        return np.asarray(self.pipeline.classes_)[best], confidence

    def predict(self, features: NDArray, region: NDArray | None = None) -> NDArray:
        """Label of each region (see :meth:`predict_with_confidence`)."""
        return self.predict_with_confidence(features, region)[0]

    def classify(
        self, image_rgb: NDArray[np.uint8], within: ArrayLike | None = None
    ) -> tuple[str, float]:
        """Classify one RGB image region of any size.

        Parameters
        ----------
        image_rgb : ndarray of uint8, shape (H, W, 3)
            Cut into the tiles of :func:`~terrain_odom.vision.features.tile_grid`.
        within : array_like, shape (M, 2), optional
            Polygon in region pixels: only the tiles whose centre it contains
            vote (:func:`image_features`).

        Returns
        -------
        label : str
        confidence : float
            Vote share in [0, 1] (of the tiles with several, else of the neighbours).
        """
        return self.vote(image_features(image_rgb, self.config, within))

    def vote(self, features: NDArray) -> tuple[str, float]:
        """Label and confidence of one region from its tiles' features.

        Parameters
        ----------
        features : ndarray, shape (n_tiles, n_features)
            :func:`image_features` of the region.

        Returns
        -------
        label : str
        confidence : float
            As :meth:`classify` (the region is all the rows).
        """
        features = np.asarray(features, dtype=np.float64)
        if features.ndim != 2 or not features.shape[0]:
            raise ValueError(f"expected one row of features per tile, got shape {features.shape}")
        proba = self.predict_proba(features)
        n_tiles = proba.shape[0]
        # predict_with_confidence for one region: votes of the known tiles, ties to the shares
        known = proba.max(axis=1) > 0
        votes = np.bincount(proba.argmax(axis=1), weights=known, minlength=proba.shape[1])
        shares = np.add.reduce(proba, axis=0)
        best = int((votes + shares / (n_tiles + 1)).argmax())
        confidence = shares[best] if n_tiles == 1 else votes[best] / n_tiles
        return str(self.pipeline.classes_[best]), float(confidence)

    def to_arrays(self) -> tuple[dict[str, NDArray], dict[str, Any]]:
        """Return the fitted model as plain arrays and metadata.

        Returns
        -------
        arrays : dict of str to ndarray
            :data:`MODEL_ARRAYS`: ``features`` (n_samples, n_features) raw
            training features (one row per tile), ``labels`` (n_samples,)
            str, ``region`` (n_samples,) int64 the training image of each row
            (numbered from 0), ``scaler_mean`` and ``scaler_scale``
            (n_features,) (empty without scaling).
        metadata : dict
            JSON-able: ``feature_version``, ``config`` (the
            :class:`ClassifierConfig` as a mapping), ``classes``,
            ``n_training_images``, ``n_training_samples``,
            ``novelty_distance`` (None if not calibrated), ``min_confidence``.

        Raises
        ------
        ValueError
            The classifier is not fitted.
        """
        if not self.n_training_images:
            raise ValueError("fit the classifier before saving it")
        if self.config.scale:
            scaler = self.pipeline["scaler"]
            mean, scale = scaler.mean_, scaler.scale_
        else:
            mean = scale = np.empty(0)
        arrays = {
            "features": self.training_features,
            "labels": self.training_labels,
            "region": self.training_region.astype(np.int64),
            "scaler_mean": mean,
            "scaler_scale": scale,
        }
        metadata = {
            "feature_version": FEATURE_VERSION,
            "config": dataclasses.asdict(self.config),
            "classes": self.classes,
            "n_training_images": self.n_training_images,
            "n_training_samples": len(self.training_labels),
            "novelty_distance": self.novelty_distance,
            "min_confidence": self.min_confidence,
        }
        return arrays, metadata

    @classmethod
    def from_arrays(
        cls,
        config: ClassifierConfig,
        arrays: Mapping[str, NDArray],
        *,
        novelty_distance: float | None = None,
        min_confidence: float = 0.0,
    ) -> TerrainClassifier:
        """Rebuild a model from the arrays of :meth:`to_arrays`, without refitting the scaler.

        Parameters
        ----------
        config : ClassifierConfig
            The model's configuration (its metadata's ``config``).
        arrays : mapping of str to ndarray
            At least :data:`MODEL_ARRAYS`.
        novelty_distance, min_confidence
            Its metadata's (:meth:`to_arrays`); models saved before they
            existed have neither: no unknown ground, no threshold.

        Raises
        ------
        ValueError
            An array is missing, or the arrays do not match each other.
        """
        missing = set(MODEL_ARRAYS) - set(arrays)
        if missing:
            raise ValueError(f"no {sorted(missing)}")
        labels = arrays["labels"]
        features, region, _ = check_regions(arrays["features"], arrays["region"])
        if labels.shape != region.shape:
            raise ValueError(f"{labels.size} labels for {region.size} feature rows")
        classifier = cls(config)
        classifier.training_features = samples = features
        classifier.training_labels = labels
        classifier.training_region = region
        if config.scale:  # the stored scaler, not one refitted
            scaler = classifier.pipeline["scaler"]
            scaler.mean_, scaler.scale_ = arrays["scaler_mean"], arrays["scaler_scale"]
            scaler.var_ = scaler.scale_**2
            scaler.n_features_in_ = samples.shape[1]
            scaler.n_samples_seen_ = samples.shape[0]
            samples = scaler.transform(samples)
        classifier.pipeline["knn"].fit(samples, classifier.training_labels)
        classifier.novelty_distance, classifier.min_confidence = novelty_distance, min_confidence
        return classifier
