"""Cross-validation of the terrain classifier over images: the seed, the folds, the scores.

Every report scores on the same folds: scikit-learn's ``StratifiedKFold``
shuffled with :data:`CV_SEED` (:func:`stratified_folds`), over images (all
tiles of an image stay in the same fold). :func:`cross_validate_images`
scores one configuration on them; the settings search of
:mod:`~terrain_odom.vision.tuning` uses the same folds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.model_selection import StratifiedKFold

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import InputFileError
from terrain_odom.vision.calibration import Reliability, choose_threshold, reliability
from terrain_odom.vision.classifier import TerrainClassifier
from terrain_odom.vision.dataset import LabelledFeatures

__all__ = [
    "CV_SEED",
    "CrossValidation",
    "check_folds",
    "cross_validate_images",
    "feature_times_ms",
    "stratified_folds",
]

CV_SEED = 0
"""Seed of the fold shuffling: every report uses the same folds."""


def stratified_folds(folds: int, seed: int = CV_SEED) -> StratifiedKFold:
    """Return the splitter of every cross-validation: ``folds`` stratified folds, shuffled with ``seed``."""
    return StratifiedKFold(n_splits=folds, shuffle=True, random_state=seed)


def check_folds(counts: Mapping[str, int], folds: int, what: str) -> None:
    """Raise unless ``folds >= 2`` and every class has ``folds`` images (one per fold).

    Parameters
    ----------
    counts : mapping of str to int
        Usable images of each class, in class order.
    folds : int
    what : str
        What needs the folds, for the message (``"cross-validate"``, ``"tune"``).

    Raises
    ------
    InputFileError
        Naming the smallest class (the first of ties) and its image count.
    """
    name, count = min(counts.items(), key=lambda item: item[1])
    if folds < 2 or count < folds:
        raise InputFileError(
            f"cannot {what} with {folds} folds: class '{name}' has "
            f"{count} usable image(s), and every fold needs one of each class"
        )


@dataclass(frozen=True)
class CrossValidation:
    """Result of a stratified k-fold cross-validation.

    Attributes
    ----------
    config : ClassifierConfig
    classes : tuple of str
    folds : int
    confusion : ndarray of int, shape (n_classes, n_classes)
        Image counts; row = true class, column = predicted class.
    confidence, correct : ndarray, shape (n_images,), optional
        Each held-out image's confidence and whether its label was right
        (in image order; for :meth:`reliability`).
    """

    config: ClassifierConfig
    classes: tuple[str, ...]
    folds: int
    confusion: NDArray[np.int64]
    confidence: NDArray[np.float64] | None = None
    correct: NDArray[np.bool_] | None = None

    def reliability(self) -> Reliability | None:
        """Observed accuracy against confidence of the held-out images (None without them)."""
        if self.confidence is None or self.correct is None:
            return None
        return reliability(self.confidence, self.correct)

    def threshold(self) -> float | None:
        """Return the tracker's confidence threshold chosen from the held-out images (:func:`choose_threshold`)."""
        if self.confidence is None or self.correct is None:
            return None
        return choose_threshold(self.confidence, self.correct)

    @property
    def percent(self) -> NDArray[np.float64]:
        """Row-normalised confusion matrix, % (each row sums to 100)."""
        return 100.0 * self.confusion / self.confusion.sum(axis=1, keepdims=True)

    @property
    def per_class_accuracy(self) -> dict[str, float]:
        """Share of each class's images classified correctly, %."""
        return dict(zip(self.classes, np.diag(self.percent).tolist(), strict=True))

    @property
    def mean_accuracy(self) -> float:
        """Mean of the per-class accuracies, % (balanced accuracy)."""
        return float(np.mean(np.diag(self.percent)))

    @property
    def overall_accuracy(self) -> float:
        """Share of all images classified correctly, %."""
        return float(100.0 * np.trace(self.confusion) / self.confusion.sum())

    def worst_class(self) -> tuple[str, float]:
        """Return the class with the lowest accuracy and that accuracy, %."""
        name = min(self.per_class_accuracy, key=self.per_class_accuracy.__getitem__)
        return name, self.per_class_accuracy[name]

    def to_dict(self) -> dict[str, Any]:
        """Plain data for reports (with the reliability and threshold when known)."""
        table = self.reliability()
        return {
            "config": dataclasses.asdict(self.config),
            "confusion_counts": self.confusion,
            "confusion_percent": self.percent,
            "per_class_accuracy_percent": self.per_class_accuracy,
            "mean_accuracy_percent": self.mean_accuracy,
            "overall_accuracy_percent": self.overall_accuracy,
            **(
                {}
                if table is None
                else {"reliability": table.to_dict(), "min_confidence": self.threshold()}
            ),
        }


def cross_validate_images(
    data: LabelledFeatures,
    config: ClassifierConfig | None = None,
    *,
    folds: int = 5,
    seed: int = CV_SEED,
) -> CrossValidation:
    """Stratified k-fold cross-validation of the classifier over images.

    Parameters
    ----------
    data : LabelledFeatures
        Features of every image; all tiles of an image go to the same fold.
    config : ClassifierConfig, optional
        Classifier settings (default ``data.config``); its feature settings must
        be those ``data`` was computed with, while ``scale``, ``k`` and
        ``weights`` may differ.
    folds : int
        Number of folds (:func:`stratified_folds`, shuffled with ``seed``).
    seed : int

    Returns
    -------
    CrossValidation

    Raises
    ------
    InputFileError
        A class has fewer images than ``folds``.
    """
    config = data.config if config is None else config
    if config.feature_key() != data.config.feature_key():
        raise ValueError(
            "config's feature settings differ from those the features were computed with"
        )
    check_folds(data.counts(), folds, "cross-validate")
    confusion = np.zeros((len(data.classes), len(data.classes)), dtype=np.int64)
    index = {name: i for i, name in enumerate(data.classes)}
    confidence = np.zeros(data.labels.size)
    correct = np.zeros(data.labels.size, dtype=bool)
    splits = stratified_folds(folds, seed).split(np.zeros((data.labels.size, 1)), data.labels)
    for train_idx, test_idx in splits:
        train, test = data.select(train_idx), data.select(test_idx)  # all tiles of an image
        classifier = TerrainClassifier(config).fit(train.features, train.labels, train.region)
        predicted, confidence[test_idx] = classifier.predict_with_confidence(
            test.features, test.region
        )
        correct[test_idx] = predicted == test.labels
        for true, pred in zip(test.labels, predicted, strict=True):
            confusion[index[true], index[pred]] += 1
    return CrossValidation(config, data.classes, folds, confusion, confidence, correct)


def feature_times_ms(data: LabelledFeatures) -> dict[str, dict[str, float]]:
    """Feature-extraction time per image of each class, ms: ``{"mean": ..., "max": ...}``."""
    out = {}
    for name in data.classes:
        ms = 1e3 * data.seconds[data.labels == name]
        out[name] = {"mean": float(ms.mean()), "max": float(ms.max())}
    return out
