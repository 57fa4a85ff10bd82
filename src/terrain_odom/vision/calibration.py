"""What a classification's confidence is worth: reliability on cross-validation, the tracker's threshold.

A region's confidence (:meth:`~terrain_odom.vision.classifier.TerrainClassifier.predict_with_confidence`)
is a vote share, not a probability. Cross-validation says what it is worth:
:func:`reliability` bins the held-out images by confidence and gives the
share of each bin classified right (a reliability diagram as a table), and
:func:`choose_threshold` the lowest confidence from which the labels are
right at least :data:`TARGET_ACCURACY` of the time. Below it a frame's label
is no sighting for the terrain tracker, so that a change is confirmed only
by frames that are usually right.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["TARGET_ACCURACY", "N_BINS", "Reliability", "reliability", "choose_threshold"]

TARGET_ACCURACY = 0.95
"""Share of right labels the confidence threshold is chosen to reach."""

N_BINS = 10
"""Equal-width confidence bins of the reliability table."""


@dataclass(frozen=True)
class Reliability:
    """Observed accuracy against confidence.

    Attributes
    ----------
    edges : ndarray, shape (n_bins + 1,)
        Bin edges in [0, 1]; bin ``i`` is ``edges[i] <= confidence < edges[i + 1]``
        (the last bin includes 1).
    count : ndarray of int, shape (n_bins,)
        Images in each bin.
    mean_confidence, accuracy : ndarray, shape (n_bins,)
        Their mean confidence and the share classified right (NaN for an
        empty bin).
    """

    edges: NDArray[np.float64]
    count: NDArray[np.int64]
    mean_confidence: NDArray[np.float64]
    accuracy: NDArray[np.float64]

    def to_dict(self) -> dict[str, Any]:
        """Plain data: one row per non-empty bin (confidence, accuracy in %)."""
        return {
            "bins": [
                {
                    "from": float(lo),
                    "to": float(hi),
                    "images": int(n),
                    "mean_confidence": float(c),
                    "accuracy_percent": 100.0 * float(a),
                }
                for lo, hi, n, c, a in zip(
                    self.edges[:-1],
                    self.edges[1:],
                    self.count,
                    self.mean_confidence,
                    self.accuracy,
                    strict=True,
                )
                if n
            ]
        }


def reliability(confidence: ArrayLike, correct: ArrayLike, n_bins: int = N_BINS) -> Reliability:
    """Bin held-out classifications by confidence.

    Parameters
    ----------
    confidence : array_like of float, shape (n,)
        In [0, 1].
    correct : array_like of bool, shape (n,)
    n_bins : int

    Examples
    --------
    >>> r = reliability([0.1, 0.15, 0.9, 1.0], [False, True, True, True], n_bins=2)
    >>> r.count.tolist(), r.accuracy.tolist()
    ([2, 2], [0.5, 1.0])
    """
    confidence = np.asarray(confidence, dtype=np.float64)
    correct = np.asarray(correct, dtype=bool)
    if confidence.shape != correct.shape or confidence.ndim != 1:
        raise ValueError("confidence and correct must be 1-D arrays of the same length")
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    bins = np.clip(np.searchsorted(edges, confidence, side="right") - 1, 0, n_bins - 1)
    count = np.bincount(bins, minlength=n_bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.bincount(bins, confidence, minlength=n_bins) / count
        accuracy = np.bincount(bins, correct, minlength=n_bins) / count
    return Reliability(edges, count.astype(np.int64), mean, accuracy)


def choose_threshold(
    confidence: ArrayLike, correct: ArrayLike, target: float = TARGET_ACCURACY
) -> float:
    """Return the lowest confidence from which held-out labels are right at least ``target`` of the time.

    The candidates are the observed confidences: the threshold is the
    smallest ``c`` with ``mean(correct[confidence >= c]) >= target``; 0 when
    every label is (the classifier needs no threshold); the highest
    confidence when no ``c`` reaches the target (only the surest labels count).

    Examples
    --------
    >>> choose_threshold([0.4, 0.6, 0.8, 1.0], [False, False, True, True], target=0.9)
    0.8
    >>> choose_threshold([0.4, 1.0], [True, True])
    0.0
    """
    confidence = np.asarray(confidence, dtype=np.float64)
    correct = np.asarray(correct, dtype=bool)
    if correct.all():
        return 0.0
    order = np.argsort(-confidence, kind="stable")
    right = np.cumsum(correct[order]) / np.arange(1, order.size + 1)  # accuracy from the top down
    values = confidence[order]
    last = np.r_[values[1:] != values[:-1], True]  # a threshold keeps all equal confidences
    ok = np.flatnonzero(last & (right >= target))
    return float(values[ok[-1]] if ok.size else values[0])
