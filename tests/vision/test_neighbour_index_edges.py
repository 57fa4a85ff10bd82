"""NeighbourIndex against scikit-learn on synthetic rows: k = all rows, many ties, one query, refusals."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.neighbors import NearestNeighbors
from threadpoolctl import threadpool_limits

from terrain_odom.errors import ConfigError
from terrain_odom.vision.neighbours import NeighbourIndex


def _sklearn(samples: np.ndarray, queries: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    with threadpool_limits(limits=1):
        return NearestNeighbors(n_neighbors=k, algorithm="brute").fit(samples).kneighbors(queries)


def test_k_may_be_every_training_row():
    samples = np.arange(12.0).reshape(6, 2)
    distance, index = NeighbourIndex(samples, 6).kneighbors(np.array([[10.0, 11.0]]))
    assert index.tolist() == [[5, 4, 3, 2, 1, 0]]  # all six, nearest first
    np.testing.assert_allclose(distance[0], np.hypot(2.0, 2.0) * np.arange(6), rtol=1e-12)
    with pytest.raises(ConfigError, match="k: 7 neighbours but 6 training samples"):
        NeighbourIndex(samples, 7)


@pytest.mark.parametrize("k", [30, 29])
def test_equal_distances_are_listed_by_ascending_index_and_the_lower_ones_kept(k):
    """Every training row three times: 60 rows, ties everywhere; k = 29 splits a triple at the k-th.

    The distances are scikit-learn's bit for bit. Its rows are compared as
    sets only for k = 30: its final sort does not order equal distances by
    index, and at a split triple the two searches may keep different copies
    (the vote is the same: equal rows, equal labels).
    """
    rng = np.random.default_rng(5)
    base = rng.normal(size=(20, 4))
    samples = np.vstack([base, base, base])  # rows i, i + 20, i + 40 equal
    queries = rng.normal(size=(3, 4))
    distance, index = NeighbourIndex(samples, k).kneighbors(queries)
    want_distance, want_index = _sklearn(samples, queries, k)
    np.testing.assert_array_equal(distance, want_distance)
    if k == 30:
        assert [sorted(r) for r in index.tolist()] == [sorted(r) for r in want_index.tolist()]
    for row, d in zip(index, distance, strict=True):
        same = d[:-1] == d[1:]
        assert same.sum() >= k // 3 and (row[:-1][same] < row[1:][same]).all()


@pytest.mark.parametrize("n", [1, 2, 3])
def test_one_two_or_three_queries_are_scikit_learns_bit_for_bit(n):
    rng = np.random.default_rng(11)
    samples = rng.normal(size=(300, 70)) * rng.uniform(0.1, 10.0, size=70)  # more than one chunk
    queries = rng.normal(size=(n, 70)) * 3.0
    distance, index = NeighbourIndex(samples, 5).kneighbors(np.ascontiguousarray(queries))
    want_distance, want_index = _sklearn(samples, queries, 5)
    np.testing.assert_array_equal(index, want_index)
    np.testing.assert_array_equal(distance, want_distance)


def test_a_query_that_is_not_finite_is_refused_in_scikit_learns_words():
    index = NeighbourIndex(np.eye(3), 1)
    with pytest.raises(
        ValueError, match=r"^Input X contains NaN or infinity: the features are not finite$"
    ):
        index.kneighbors(np.array([[0.0, np.nan, 1.0]]))
