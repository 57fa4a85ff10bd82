"""The k nearest training tiles of a frame's few tiles, as scikit-learn finds them.

:class:`~terrain_odom.vision.classifier.TerrainClassifier` searches a
frame's tiles (up to :data:`SMALL_QUERY` rows) with :class:`NeighbourIndex`,
the arithmetic of scikit-learn's brute-force ``kneighbors`` without its
per-call checks; larger batches (cross-validation) go to scikit-learn.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from terrain_odom.errors import ConfigError

__all__ = ["SMALL_QUERY", "NeighbourIndex"]

SMALL_QUERY = 32
"""Most query rows searched by the classifier's own neighbour search (a frame's tiles).

Larger batches (cross-validation) go to scikit-learn's ``kneighbors``; both
give the same neighbours and distances to the last bit
(:class:`NeighbourIndex`).
"""

_CHUNK = 256  # training rows per matrix product: scikit-learn's pairwise_dist_chunk_size


class NeighbourIndex:
    """Brute-force k nearest training rows of a few queries, as scikit-learn finds them.

    ``KNeighborsClassifier.kneighbors`` on dense data (brute force,
    Euclidean) validates its input, then computes squared distances as
    ``|x|**2 + (-2 x . y) + |y|**2``: the norms by BLAS ``ddot``, the middle
    term by a matrix product over blocks of :data:`_CHUNK` training rows,
    then keeps the ``k`` smallest and takes their square roots. Its checks
    cost ~0.5 ms a call, more than the search of a frame's few tiles; this
    is the same arithmetic in the same order without them (numpy's matrix
    product, a single query padded to two rows as scikit-learn's product
    takes it), so that distances and indices are bit for bit scikit-learn's
    (tested on real tiles for 1 to :data:`SMALL_QUERY` queries). Ties in
    distance go to the lower training index, as scikit-learn's heap keeps
    the first of equal candidates.

    Parameters
    ----------
    samples : ndarray of float64, shape (n_samples, n_features)
        Training rows as the search sees them (standardised when the model scales).
    k : int
        Neighbours per query, <= n_samples.
    """

    def __init__(self, samples: NDArray[np.float64], k: int) -> None:
        from scipy.linalg.blas import ddot  # the BLAS scikit-learn's norms call

        self._ddot = ddot
        self.samples = np.ascontiguousarray(samples, dtype=np.float64)
        if not 1 <= k <= self.samples.shape[0]:
            raise ConfigError(f"k: {k} neighbours but {self.samples.shape[0]} training samples")
        self.norms = self._row_norms(self.samples)
        self.k = k

    def _row_norms(self, rows: NDArray[np.float64]) -> NDArray[np.float64]:
        """Squared norm of each row by BLAS ``ddot``, as scikit-learn's ``_sqeuclidean_row_norms``."""
        return np.array([self._ddot(row, row) for row in rows], dtype=np.float64)

    def kneighbors(self, queries: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """Distances (ascending) and indices of the ``k`` nearest training rows of each query.

        Parameters
        ----------
        queries : ndarray of float64, shape (n_queries, n_features), C-contiguous

        Returns
        -------
        distance : ndarray of float64, shape (n_queries, k)
        index : ndarray of intp, shape (n_queries, k)

        Raises
        ------
        ValueError
            A query holds NaN or infinity (as scikit-learn's check raises),
            or has another number of columns than the training rows.
        """
        if queries.ndim != 2 or queries.shape[1] != self.samples.shape[1]:
            raise ValueError(
                f"features of shape {queries.shape}, the model has {self.samples.shape[1]} columns"
            )
        if not np.isfinite(queries).all():
            raise ValueError("Input X contains NaN or infinity: the features are not finite")
        n = queries.shape[0]
        padded = queries if n > 1 else np.vstack((queries, np.zeros_like(queries)))
        middle = np.concatenate(
            [
                -2.0 * (padded @ self.samples[start : start + _CHUNK].T)
                for start in range(0, self.samples.shape[0], _CHUNK)
            ],
            axis=1,
        )[:n]
        squared = self._row_norms(queries)[:, None] + middle + self.norms
        np.maximum(squared, 0.0, out=squared)
        k = self.k
        kth = np.partition(squared, k - 1, axis=1)[:, k - 1 : k]
        within = squared <= kth  # the k nearest and any tied with the k-th
        if np.count_nonzero(within) == n * k:  # no ties at the k-th: k a row, by index
            candidates = np.nonzero(within)[1].reshape(n, k)
            order = np.argsort(np.take_along_axis(squared, candidates, 1), axis=1, kind="stable")
            index: NDArray[np.intp] = np.take_along_axis(candidates, order, axis=1)
        else:
            index = np.empty((n, k), dtype=np.intp)
            for row, (values, near) in enumerate(zip(squared, within, strict=True)):
                tied = np.flatnonzero(near)
                index[row] = tied[np.argsort(values[tied], kind="stable")[:k]]
        return np.sqrt(np.take_along_axis(squared, index, axis=1)), index
